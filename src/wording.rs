//! Counts in messages: "1 particle", "3 particles" (a refusal reading "only
//! 1 particles" was the message a user saw on every frame).

/// `n` and `noun`, the noun plural unless `n` is 1 (`plural`: "1 axis",
/// "2 axes").
pub fn counted(n: usize, noun: &str) -> String {
    match n {
        1 => format!("1 {noun}"),
        _ => format!("{n} {}", plural(noun)),
    }
}

/// The plural of `noun` by English's regular endings: "axis" -> "axes",
/// "try" -> "tries" (but "key" -> "keys"), "re-push" -> "re-pushes",
/// otherwise an "s" ("1 axes" and "1 tries" had been printed).
fn plural(noun: &str) -> String {
    if let Some(stem) = noun.strip_suffix("is") {
        return format!("{stem}es");
    }
    if let Some(stem) = noun.strip_suffix('y')
        && !stem.ends_with(['a', 'e', 'i', 'o', 'u'])
    {
        return format!("{stem}ies");
    }
    if ["s", "sh", "ch", "x"].iter().any(|end| noun.ends_with(end)) {
        return format!("{noun}es");
    }
    format!("{noun}s")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_is_singular_and_every_other_count_plural() {
        assert_eq!(counted(1, "particle"), "1 particle");
        assert_eq!(counted(0, "particle"), "0 particles");
        assert_eq!(counted(3, "site"), "3 sites");
        assert_eq!(counted(2, "re-push"), "2 re-pushes");
        assert_eq!(counted(1, "re-push"), "1 re-push");
    }

    #[test]
    fn irregular_endings_take_their_plurals() {
        assert_eq!(counted(2, "axis"), "2 axes");
        assert_eq!(counted(1, "axis"), "1 axis");
        assert_eq!(counted(3, "try"), "3 tries");
        assert_eq!(counted(1, "try"), "1 try");
        assert_eq!(counted(2, "key"), "2 keys");
        assert_eq!(counted(2, "box"), "2 boxes");
    }
}
