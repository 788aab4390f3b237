//! File names in the order a person numbers them: `img_2.png` before
//! `img_10.png`. Cameras and acquisition programs often write frame numbers
//! without leading zeros, and plain string order then put frame 10 between
//! frames 1 and 2 (a recording replayed out of order, and its stage log
//! matched to the wrong frames).

use std::cmp::Ordering;
use std::path::Path;

/// Compares two paths as text, runs of ASCII digits by their value,
/// everything else by character; names equal so (`f07` and `f7`) in plain
/// text order, so that the order is total.
pub fn natural_cmp(a: &Path, b: &Path) -> Ordering {
    let (a, b) = (a.to_string_lossy(), b.to_string_lossy());
    by_chunks(a.as_bytes(), b.as_bytes()).then_with(|| a.cmp(&b))
}

/// The comparison of [`natural_cmp`] without its tie-break.
fn by_chunks(mut x: &[u8], mut y: &[u8]) -> Ordering {
    loop {
        match (x.first(), y.first()) {
            (None, None) => return Ordering::Equal,
            (None, Some(_)) => return Ordering::Less,
            (Some(_), None) => return Ordering::Greater,
            (Some(c), Some(d)) if c.is_ascii_digit() && d.is_ascii_digit() => {
                let (m, n) = (digits(x), digits(y));
                let order = by_value(&x[..m], &y[..n]);
                if order != Ordering::Equal {
                    return order;
                }
                (x, y) = (&x[m..], &y[n..]);
            }
            (Some(c), Some(d)) => {
                if c != d {
                    return c.cmp(d);
                }
                (x, y) = (&x[1..], &y[1..]);
            }
        }
    }
}

/// Length of the run of ASCII digits `s` starts with.
fn digits(s: &[u8]) -> usize {
    s.iter().take_while(|c| c.is_ascii_digit()).count()
}

/// Two runs of digits by the number they write (any length: no overflow).
fn by_value(a: &[u8], b: &[u8]) -> Ordering {
    let trim = |s: &[u8]| -> usize { s.iter().take_while(|&&c| c == b'0').count() };
    let (a, b) = (&a[trim(a)..], &b[trim(b)..]);
    a.len().cmp(&b.len()).then_with(|| a.cmp(b))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    #[test]
    fn numbers_sort_by_value_and_the_rest_as_text() {
        let mut names: Vec<PathBuf> = [
            "f10.png",
            "f2.png",
            "f1.png",
            "f0.png",
            "f11.png",
            "e9.png",
            "f1a.png",
            "f01.png",
            "f99999999999999999999999.png",
            "f100000000000000000000000.png",
        ]
        .iter()
        .map(PathBuf::from)
        .collect();
        names.sort_by(|a, b| natural_cmp(a, b));
        let got: Vec<String> = names.iter().map(|p| p.display().to_string()).collect();
        assert_eq!(
            got,
            [
                "e9.png",
                "f0.png",
                "f01.png",
                "f1.png",
                "f1a.png",
                "f2.png",
                "f10.png",
                "f11.png",
                "f99999999999999999999999.png",
                "f100000000000000000000000.png",
            ]
        );
        // Zero-padded names keep the order they had.
        let padded = [
            PathBuf::from("frame_00009.png"),
            PathBuf::from("frame_00010.png"),
        ];
        assert_eq!(natural_cmp(&padded[0], &padded[1]), Ordering::Less);
        assert_eq!(natural_cmp(&padded[0], &padded[0]), Ordering::Equal);
    }
}
