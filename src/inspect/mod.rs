//! Human-readable views of our files: summaries as text or JSON, and pictures.

pub mod instances;
pub mod pictures;
pub mod terrain;
pub mod texel;

/// What a container file says about itself that its decoded content does not carry.
#[derive(Clone, Copy, Debug)]
pub struct FileFacts {
    pub bytes: u64,
    pub minor: u16,
    /// The payload's length once decompressed, as the preamble declares it.
    pub raw_bytes: u64,
}

impl FileFacts {
    /// The facts of a container file's bytes (zeros where the preamble is short).
    pub fn of(bytes: &[u8]) -> FileFacts {
        let p = crate::formats::container::preamble(bytes);
        FileFacts {
            bytes: bytes.len() as u64,
            minor: p.map_or(0, |p| p.minor),
            raw_bytes: p.map_or(0, |p| p.raw_len),
        }
    }
}

/// Text from a file, safe to print on a terminal: control characters (C0, DEL, C1) and the
/// invisible characters that reorder or hide text are shown as `\u{..}` escapes, so a name
/// in a file cannot move the cursor, recolour the terminal or disguise itself.
pub fn printable(text: &str) -> String {
    let hidden = |c: char| {
        c.is_control()
            || matches!(c, '\u{200B}'..='\u{200F}' | '\u{202A}'..='\u{202E}' | '\u{2066}'..='\u{2069}')
    };
    if !text.chars().any(hidden) {
        return text.to_string();
    }
    text.chars()
        .map(|c| {
            if hidden(c) {
                c.escape_unicode().to_string()
            } else {
                c.to_string()
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    #[test]
    fn escape_sequences_are_shown_not_sent() {
        assert_eq!(super::printable("bark"), "bark");
        assert_eq!(
            super::printable("a\u{1b}[31mred\u{9b}2J\u{202e}"),
            "a\\u{1b}[31mred\\u{9b}2J\\u{202e}"
        );
    }
}
