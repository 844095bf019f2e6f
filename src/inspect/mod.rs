//! Human-readable views of our files: summaries as text or JSON, and pictures.

pub mod frame;
pub mod instances;
pub mod pictures;
pub mod terrain;
pub mod texel;

/// The kinds of file `texel inspect` reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    Texel,
    Instances,
    Terrain,
}

impl Kind {
    /// The kind of a file from its first bytes (16 suffice) and its name's extension, or
    /// `None` for none of them. A magic number decides first; a damaged file is then taken for
    /// the kind its name says, so that kind's reader reports the damage.
    pub fn of(head: &[u8], extension: Option<&std::ffi::OsStr>) -> Option<Kind> {
        if head.starts_with(crate::formats::texel::MAGIC) {
            return Some(Kind::Texel);
        }
        if head.starts_with(crate::formats::instances::MAGIC) {
            return Some(Kind::Instances);
        }
        let extension = extension.map(|e| e.to_string_lossy().to_ascii_lowercase());
        match extension.as_deref() {
            Some("texel") => Some(Kind::Texel),
            Some("instances") => Some(Kind::Instances),
            Some("glb" | "gltf") => Some(Kind::Terrain),
            _ if crate::terrain::heightmap::Format::of(head, std::path::Path::new(""))
                .is_some() =>
            {
                Some(Kind::Terrain)
            }
            Some("png" | "exr" | "tif" | "tiff" | "r16" | "raw") => Some(Kind::Terrain),
            _ if head.starts_with(b"glTF") || head.trim_ascii_start().starts_with(b"{") => {
                Some(Kind::Terrain)
            }
            _ => None,
        }
    }
}

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
