//! How many frames a TIFF stack says it holds. ImageJ and tifffile write a
//! stack's page directories after its pixels, so a file cut short (a copy
//! stopped midway, a recorder that crashed) reads as its first page alone;
//! the first page's description still says how many there were.

use super::tiff_description::{first_page_description, imagej_value};
use std::path::Path;

/// The frame count `path`'s first page describes, if it says one.
pub fn stated_pages(path: &Path) -> Option<usize> {
    pages_in_description(&first_page_description(path)?)
}

/// ImageJ's `images=N` line, or tifffile's JSON `"shape"` of a stack
/// (`[N, height, width]` of grey pages, `[N, height, width, 3]` of colour
/// ones; a single colour image is `[height, width, 3]`).
fn pages_in_description(text: &str) -> Option<usize> {
    if let Some(n) = imagej_value(text, "images") {
        return n.parse().ok();
    }
    let json: serde_json::Value = serde_json::from_str(text).ok()?;
    let shape: Vec<u64> = json
        .get("shape")?
        .as_array()?
        .iter()
        .map(serde_json::Value::as_u64)
        .collect::<Option<_>>()?;
    match shape.as_slice() {
        [n, _, _, 3 | 4] => Some(*n as usize),
        [_, _, 3 | 4] => None,
        [n, _, _] => Some(*n as usize),
        _ => None,
    }
}

/// The warning for a stack of `read` pages at `path` whose description
/// says more.
pub fn cut_short(path: &Path, read: usize) -> Option<String> {
    let said = stated_pages(path).filter(|&said| said > read)?;
    Some(format!(
        "{}: the TIFF stack says it holds {}, but only {read} could be read (is the file cut short?)",
        path.display(),
        crate::wording::counted(said, "frame")
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use tiff::tags::Tag;

    #[test]
    fn imagej_and_tifffile_descriptions_give_the_frame_count() {
        let imagej = "ImageJ=1.11a\nimages=27\nframes=27\nfinterval=0.5\nloop=false\n";
        assert_eq!(pages_in_description(imagej), Some(27));
        assert_eq!(pages_in_description(r#"{"shape": [27, 64, 80]}"#), Some(27));
        assert_eq!(
            pages_in_description(r#"{"shape": [5, 64, 80, 3]}"#),
            Some(5)
        );
        assert_eq!(pages_in_description(r#"{"shape": [64, 80, 3]}"#), None);
        assert_eq!(pages_in_description("a microscope's own words"), None);
    }

    #[test]
    fn a_stack_that_says_more_pages_than_it_holds_is_cut_short() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("s.tif");
        let mut tiff =
            tiff::encoder::TiffEncoder::new(std::fs::File::create(&path).unwrap()).unwrap();
        for page in 0..2u16 {
            let mut image = tiff
                .new_image::<tiff::encoder::colortype::Gray16>(4, 3)
                .unwrap();
            if page == 0 {
                image
                    .encoder()
                    .write_tag(Tag::ImageDescription, "ImageJ=1.11a\nimages=5\n")
                    .unwrap();
            }
            image.write_data(&[page; 12]).unwrap();
        }
        assert_eq!(stated_pages(&path), Some(5));
        let said = cut_short(&path, 2).expect("5 said, 2 read");
        assert!(
            said.ends_with(
                "says it holds 5 frames, but only 2 could be read (is the file cut short?)"
            ),
            "{said}"
        );
        assert_eq!(cut_short(&path, 5), None);
    }
}
