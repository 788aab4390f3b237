//! A TIFF's first-page description (the ImageDescription tag), where ImageJ
//! and tifffile state what a stack is: how many frames, how far apart.

use std::io::BufReader;
use std::path::Path;
use tiff::decoder::Decoder;
use tiff::tags::Tag;

/// The ImageDescription text of `path`'s first page, if it has one.
pub fn first_page_description(path: &Path) -> Option<String> {
    let file = std::fs::File::open(path).ok()?;
    let mut decoder = Decoder::new(BufReader::new(file)).ok()?;
    decoder.get_tag_ascii_string(Tag::ImageDescription).ok()
}

/// The value of ImageJ's `key=value` line `key` in `text`, trimmed.
pub fn imagej_value<'a>(text: &'a str, key: &str) -> Option<&'a str> {
    text.lines().find_map(|line| {
        let (k, v) = line.split_once('=')?;
        (k.trim() == key).then(|| v.trim())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn imagej_values_are_found_by_their_whole_key() {
        let text = "ImageJ=1.54f\nimages=27\nfinterval=0.5\nfps=2\n";
        assert_eq!(imagej_value(text, "images"), Some("27"));
        assert_eq!(imagej_value(text, "finterval"), Some("0.5"));
        assert_eq!(imagej_value(text, "interval"), None);
        assert_eq!(imagej_value("{\"shape\": [2, 3]}", "shape"), None);
    }
}
