//! Our JSON inputs (species files, camera keyframes) read strictly: an error names the JSON
//! path of the field at fault, and anything after the document (a second object, a stray
//! brace) is refused rather than ignored.

use serde::de::DeserializeOwned;

/// `bytes` as a `T`; an error is (JSON path, or empty for the document; problem). A UTF-8
/// byte-order mark before the document, which some Windows editors write, is skipped (RFC
/// 8259 lets a parser ignore it), so lines and columns count from what an editor shows.
pub fn parse<T: DeserializeOwned>(bytes: &[u8]) -> Result<T, (String, String)> {
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    let de = &mut serde_json::Deserializer::from_slice(bytes);
    let value: T = serde_path_to_error::deserialize(&mut *de).map_err(|e| {
        let path = e.path().to_string();
        let inner = e.into_inner().to_string();
        (if path == "." { String::new() } else { path }, inner)
    })?;
    de.end().map_err(|e| (String::new(), e.to_string()))?;
    Ok(value)
}

#[cfg(test)]
mod tests {
    #[derive(serde::Deserialize, Debug)]
    #[allow(dead_code)]
    struct Doc {
        a: u32,
    }

    #[test]
    fn fields_are_named_and_trailing_documents_refused() {
        assert_eq!(super::parse::<Doc>(b" {\"a\": 1} \n").unwrap().a, 1);
        let (path, _) = super::parse::<Doc>(b"{\"a\": \"one\"}").unwrap_err();
        assert_eq!(path, "a");
        let (path, why) = super::parse::<Doc>(b"{\"a\": 1} {\"a\": 2}").unwrap_err();
        assert_eq!(path, "");
        assert!(why.contains("trailing characters"), "{why}");
        // A byte-order mark is no error; anything else before the document is.
        assert_eq!(super::parse::<Doc>(b"\xEF\xBB\xBF{\"a\": 3}").unwrap().a, 3);
        assert!(super::parse::<Doc>(b"\xEF\xBB{\"a\": 3}").is_err());
    }
}
