//! Text files saved by Windows editors (Notepad, Excel's "UTF-8 CSV") start
//! with a byte-order mark, U+FEFF. serde_json refuses it ("expected value
//! at line 1 column 1"), so every reader of a user's file drops it first.

/// `text` without a leading byte-order mark.
pub fn without_bom(text: &str) -> &str {
    text.strip_prefix('\u{feff}').unwrap_or(text)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_a_leading_mark_is_dropped() {
        assert_eq!(without_bom("\u{feff}{\"a\": 1}"), "{\"a\": 1}");
        assert_eq!(without_bom("{}"), "{}");
        assert_eq!(without_bom("a\u{feff}"), "a\u{feff}");
    }
}
