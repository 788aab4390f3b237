//! Counts in messages: "1 particle", "3 particles" (a refusal reading "only
//! 1 particles" was the message a user saw on every frame).

/// `n` and `noun`, the noun with an "s" unless `n` is 1 ("es" after a
/// hissing end: "re-pushes").
pub fn counted(n: usize, noun: &str) -> String {
    let plural = if ["s", "sh", "ch", "x"].iter().any(|end| noun.ends_with(end)) {
        "es"
    } else {
        "s"
    };
    match n {
        1 => format!("1 {noun}"),
        _ => format!("{n} {noun}{plural}"),
    }
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
}
