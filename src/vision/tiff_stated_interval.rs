//! How far apart a TIFF stack's frames are, as its ImageJ description says
//! (`finterval=`, in `tunit=` or seconds; else `fps=`). A stack's frames
//! had been taken 1 s apart whatever it said, so the model's advice was
//! asked for a session twice as old as it was for a stack at 0.5 s.

use super::tiff_description::{first_page_description, imagej_value};
use std::path::Path;

/// The seconds between `path`'s frames its first page's description
/// states: `Ok(None)` when it states none, `Err` (saying what it states)
/// when that is not a positive, finite time.
pub fn stated_interval_s(path: &Path) -> Result<Option<f64>, String> {
    first_page_description(path).map_or(Ok(None), |text| interval_in_description(&text))
}

/// ImageJ's `finterval` (seconds unless `tunit` names another unit of
/// time), else `1 / fps`.
fn interval_in_description(text: &str) -> Result<Option<f64>, String> {
    let (said, seconds) = if let Some(value) = imagej_value(text, "finterval") {
        let unit = imagej_value(text, "tunit").unwrap_or("sec");
        let Some(per_unit) = seconds_per(unit) else {
            return Err(format!(
                "finterval={value} in tunit={unit}, which is not a unit of time"
            ));
        };
        (format!("finterval={value}"), parse(value) * per_unit)
    } else if let Some(value) = imagej_value(text, "fps") {
        (format!("fps={value}"), 1.0 / parse(value))
    } else {
        return Ok(None);
    };
    if seconds.is_finite() && seconds > 0.0 {
        Ok(Some(seconds))
    } else {
        Err(format!(
            "{said}, which is not a positive time between frames"
        ))
    }
}

/// The number in `value`, NaN when it is none (refused with the rest).
fn parse(value: &str) -> f64 {
    value.parse().unwrap_or(f64::NAN)
}

/// Seconds in one of ImageJ's time units (its default is "sec").
fn seconds_per(unit: &str) -> Option<f64> {
    match unit {
        "s" | "sec" | "second" | "seconds" => Some(1.0),
        "ms" | "msec" => Some(1e-3),
        "us" | "\u{b5}s" | "\u{3bc}s" | "usec" => Some(1e-6),
        "min" | "minute" | "minutes" => Some(60.0),
        "h" | "hr" | "hour" | "hours" => Some(3600.0),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn imagej_intervals_are_read_in_their_unit_and_bad_ones_refused() {
        let head = "ImageJ=1.54f\nimages=27\nframes=27\n";
        let said = |rest: &str| interval_in_description(&format!("{head}{rest}"));
        assert_eq!(said("finterval=0.5\nloop=false\n"), Ok(Some(0.5)));
        assert_eq!(said("finterval=250\ntunit=ms\n"), Ok(Some(0.25)));
        assert_eq!(said("finterval=2\ntunit=min\n"), Ok(Some(120.0)));
        assert_eq!(said("fps=4\n"), Ok(Some(0.25)));
        // finterval wins over the playback rate.
        assert_eq!(said("finterval=0.5\nfps=7\n"), Ok(Some(0.5)));
        assert_eq!(said("loop=false\n"), Ok(None));
        assert_eq!(interval_in_description("a microscope's words"), Ok(None));
        for bad in [
            "finterval=0",
            "finterval=-1",
            "finterval=NaN",
            "finterval=inf",
            "fps=0",
            "finterval=x",
        ] {
            let why = said(bad).unwrap_err();
            assert!(
                why.starts_with(bad) && why.ends_with("not a positive time between frames"),
                "{why}"
            );
        }
        assert_eq!(
            said("finterval=3\ntunit=frames\n"),
            Err("finterval=3 in tunit=frames, which is not a unit of time".to_owned())
        );
    }
}
