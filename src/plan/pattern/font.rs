//! Built-in 3x5 bitmap font (A-Z, 0-9, space), drawn for nanopush.
//!
//! Three columns keep words short: "CMU" at the default 10.5 um pitch spans
//! 115 um, which fits the 120 um field of the acceptance layouts. `#` is a site.

/// Glyph height in rows.
pub const GLYPH_ROWS: usize = 5;
/// Glyph width in columns.
pub const GLYPH_COLS: usize = 3;

/// The 3x5 rows of a character (upper case; lower case maps to upper), or None.
pub fn glyph(c: char) -> Option<[&'static str; GLYPH_ROWS]> {
    Some(match c.to_ascii_uppercase() {
        'A' => [".#.", "#.#", "###", "#.#", "#.#"],
        'B' => ["##.", "#.#", "##.", "#.#", "##."],
        'C' => ["###", "#..", "#..", "#..", "###"],
        'D' => ["##.", "#.#", "#.#", "#.#", "##."],
        'E' => ["###", "#..", "##.", "#..", "###"],
        'F' => ["###", "#..", "##.", "#..", "#.."],
        'G' => ["###", "#..", "#.#", "#.#", "###"],
        'H' => ["#.#", "#.#", "###", "#.#", "#.#"],
        'I' => ["###", ".#.", ".#.", ".#.", "###"],
        'J' => ["..#", "..#", "..#", "#.#", "###"],
        'K' => ["#.#", "#.#", "##.", "#.#", "#.#"],
        'L' => ["#..", "#..", "#..", "#..", "###"],
        'M' => ["#.#", "###", "#.#", "#.#", "#.#"],
        'N' => ["##.", "#.#", "#.#", "#.#", "#.#"],
        'O' => ["###", "#.#", "#.#", "#.#", "###"],
        'P' => ["###", "#.#", "###", "#..", "#.."],
        'Q' => ["###", "#.#", "#.#", "###", "..#"],
        'R' => ["##.", "#.#", "##.", "#.#", "#.#"],
        'S' => ["###", "#..", "###", "..#", "###"],
        'T' => ["###", ".#.", ".#.", ".#.", ".#."],
        'U' => ["#.#", "#.#", "#.#", "#.#", "###"],
        'V' => ["#.#", "#.#", "#.#", "#.#", ".#."],
        'W' => ["#.#", "#.#", "#.#", "###", "#.#"],
        'X' => ["#.#", "#.#", ".#.", "#.#", "#.#"],
        'Y' => ["#.#", "#.#", ".#.", ".#.", ".#."],
        'Z' => ["###", "..#", ".#.", "#..", "###"],
        '0' => ["###", "#.#", "#.#", "#.#", "###"],
        '1' => [".#.", "##.", ".#.", ".#.", "###"],
        '2' => ["###", "..#", "###", "#..", "###"],
        '3' => ["###", "..#", ".##", "..#", "###"],
        '4' => ["#.#", "#.#", "###", "..#", "..#"],
        '5' => ["###", "#..", "###", "..#", "###"],
        '6' => ["###", "#..", "###", "#.#", "###"],
        '7' => ["###", "..#", ".#.", ".#.", ".#."],
        '8' => ["###", "#.#", "###", "#.#", "###"],
        '9' => ["###", "#.#", "###", "..#", "###"],
        ' ' => ["...", "...", "...", "...", "..."],
        _ => return None,
    })
}

/// Grid cells (column, row from the top) of every site of `text`, one blank column between glyphs.
pub fn text_cells(text: &str) -> Result<Vec<(i32, i32)>, char> {
    let mut cells = Vec::new();
    for (k, c) in text.chars().enumerate() {
        let rows = glyph(c).ok_or(c)?;
        let x0 = (k * (GLYPH_COLS + 1)) as i32;
        for (r, row) in rows.iter().enumerate() {
            for (col, ch) in row.chars().enumerate() {
                if ch == '#' {
                    cells.push((x0 + col as i32, r as i32));
                }
            }
        }
    }
    Ok(cells)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_letter_and_digit_has_a_well_formed_glyph() {
        for c in ('A'..='Z').chain('0'..='9') {
            let g = glyph(c).unwrap_or_else(|| panic!("missing {c}"));
            assert!(
                g.iter()
                    .all(|r| r.len() == GLYPH_COLS && r.chars().all(|ch| ch == '#' || ch == '.'))
            );
            assert!(g.iter().any(|r| r.contains('#')), "{c} is blank");
        }
        assert_eq!(text_cells("CMU").unwrap().len(), 9 + 11 + 11);
        assert_eq!(text_cells("C?"), Err('?'));
    }
}
