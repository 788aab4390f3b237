//! stage.csv of a calibration recording: one row per frame file, the stage
//! position (micrometres) when it was taken, under the header
//! `frame,x_um,y_um`. Written by `rig calibrate`, read by `calibrate`; also
//! written by hand, by stage software and by spreadsheets, so it is read
//! as CSV is written in the wild: quoted fields, a byte-order mark, CRLF
//! line ends, and the semicolons and decimal commas of a spreadsheet in a
//! locale that writes 2,5 for 2.5.

use anyhow::Context;

/// One row of stage.csv.
#[derive(Debug, Clone, PartialEq)]
pub struct StageRow {
    /// Frame file, relative to the recording folder.
    pub frame: String,
    /// Stage x, micrometres.
    pub x_um: f64,
    /// Stage y, micrometres.
    pub y_um: f64,
}

/// The columns, in order.
const HEADER: [&str; 3] = ["frame", "x_um", "y_um"];

/// Parses stage.csv text; errors name the line.
pub fn parse_stage_csv(text: &str) -> anyhow::Result<Vec<StageRow>> {
    // A spreadsheet's UTF-8 export starts with a byte-order mark.
    let text = crate::byte_order_mark::without_bom(text);
    // A spreadsheet whose locale writes decimal commas separates fields
    // with semicolons: the header says which.
    let first = text.lines().find(|l| !l.trim().is_empty()).unwrap_or("");
    let semicolons = first.contains(';') && !first.contains(',');
    let mut reader = csv::ReaderBuilder::new()
        .delimiter(if semicolons { b';' } else { b',' })
        .has_headers(false)
        .flexible(true)
        .trim(csv::Trim::All)
        .from_reader(text.as_bytes());
    let mut records = reader.records().filter(|r| {
        // A line of spaces is a record of one empty field: skipped, as
        // blank lines are.
        r.as_ref().map_or(true, |r| r.iter().any(|f| !f.is_empty()))
    });
    let header = match records.next() {
        Some(r) => r.context("stage.csv: reading the header")?,
        None => csv::StringRecord::new(),
    };
    if header.iter().ne(HEADER) {
        anyhow::bail!(
            "stage.csv must start with the header `frame,x_um,y_um`, found `{}`",
            header.iter().collect::<Vec<_>>().join(",")
        );
    }
    records
        .map(|record| {
            let record = record.context("stage.csv")?;
            let line = record.position().map_or(0, csv::Position::line);
            if record.len() != 3 {
                anyhow::bail!(
                    "stage.csv line {line}: expected 3 fields, found {}",
                    record.len()
                );
            }
            let num = |s: &str| -> anyhow::Result<f64> {
                let v: f64 = (if semicolons {
                    s.replacen(',', ".", 1)
                } else {
                    s.to_owned()
                })
                .parse()
                .with_context(|| format!("stage.csv line {line}: `{s}` is not a number"))?;
                anyhow::ensure!(v.is_finite(), "stage.csv line {line}: `{s}` is not finite");
                Ok(v)
            };
            Ok(StageRow {
                frame: record[0].to_owned(),
                x_um: num(&record[1])?,
                y_um: num(&record[2])?,
            })
        })
        .collect()
}

/// The text of a stage.csv holding `rows` ([`parse_stage_csv`] reads it
/// back; a frame name with a comma or a quote is quoted).
pub fn stage_csv(rows: &[StageRow]) -> String {
    let mut writer = csv::Writer::from_writer(Vec::new());
    let written =
        std::iter::once(writer.write_record(HEADER)).chain(rows.iter().map(|r| {
            writer.write_record([r.frame.clone(), r.x_um.to_string(), r.y_um.to_string()])
        }));
    // Writing to memory cannot fail, and every record has three fields.
    written.for_each(|w| w.expect("a stage.csv row written to memory"));
    let bytes = writer.into_inner().expect("stage.csv flushed to memory");
    String::from_utf8(bytes).expect("stage.csv of UTF-8 fields")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stage_csv_parses_and_names_bad_lines() {
        let rows = parse_stage_csv("frame,x_um,y_um\nf0.png,1.5,2\n\nf1.png,-3,4e1\n").unwrap();
        assert_eq!(rows.len(), 2);
        assert_eq!(rows[1].y_um, 40.0);
        let e = parse_stage_csv("frame,x_um,y_um\nf0.png,abc,2\n").unwrap_err();
        assert!(format!("{e:#}").contains("line 2"), "{e:#}");
        let e = parse_stage_csv("frame,x_um,y_um\n\n  \nf0.png,1,2,3\n").unwrap_err();
        assert!(
            format!("{e:#}").contains("line 4: expected 3 fields, found 4"),
            "{e:#}"
        );
        assert!(parse_stage_csv("a,b\n").is_err());
        assert!(parse_stage_csv("").is_err());
        assert!(parse_stage_csv("frame,x_um,y_um\nf0.png,inf,2\n").is_err());
    }

    /// As spreadsheets and stage software write it: quoted, with a
    /// byte-order mark and CRLF; or in a decimal-comma locale, semicolons
    /// between fields. Quoted fields were read with their quotes (the
    /// header refused, or `"1.5"` not a number).
    #[test]
    fn stage_csv_reads_as_spreadsheets_write_it() {
        let want = vec![
            StageRow {
                frame: "f 0.png".into(),
                x_um: 1.5,
                y_um: -2.0,
            },
            StageRow {
                frame: "f1.png".into(),
                x_um: 10.25,
                y_um: 4.0,
            },
        ];
        for text in [
            "\u{feff}\"frame\",\"x_um\",\"y_um\"\r\n\"f 0.png\",\"1.5\",\"-2\"\r\n\"f1.png\",\"10.25\",\"4\"\r\n",
            "frame;x_um;y_um\nf 0.png;1,5;-2\nf1.png;10,25;4,0\n",
            "frame, x_um, y_um\n f 0.png , 1.5 , -2\nf1.png,10.25,4\n",
        ] {
            assert_eq!(parse_stage_csv(text).unwrap(), want, "{text:?}");
        }
    }

    #[test]
    fn stage_csv_reads_back_what_it_writes() {
        let rows = vec![
            StageRow {
                frame: "frame_000.png".into(),
                x_um: 50.000000001,
                y_um: -3.25e-3,
            },
            StageRow {
                frame: "frame,\"001\".png".into(),
                x_um: 1e2 / 3.0,
                y_um: 98.0,
            },
        ];
        assert_eq!(parse_stage_csv(&stage_csv(&rows)).unwrap(), rows);
    }
}
