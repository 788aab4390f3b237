//! The one line a failed command prints: the error and its causes, each
//! said once.
//!
//! The library's errors name their cause in their own message ("layout
//! file l.json: No such file or directory") and also expose it as their
//! source, so a library user who prints only the top error still learns
//! why. anyhow's `{:#}` appends every source again; here a cause already
//! in the message so far is left out.

/// `err` and each cause not already spelled out by the ones above it,
/// joined by ": ".
pub fn error_message(err: &anyhow::Error) -> String {
    let mut message = String::new();
    for cause in err.chain() {
        let text = cause.to_string();
        if message.contains(&text) {
            continue;
        }
        if !message.is_empty() {
            message.push_str(": ");
        }
        message.push_str(&text);
    }
    message
}

#[cfg(test)]
mod tests {
    use super::*;
    use anyhow::Context;

    #[derive(Debug, thiserror::Error)]
    #[error("layout file {path}: {source}")]
    struct NamesItsSource {
        path: String,
        source: std::io::Error,
    }

    fn not_found() -> std::io::Error {
        std::io::Error::new(std::io::ErrorKind::NotFound, "no such file")
    }

    #[test]
    fn a_cause_the_message_already_names_is_said_once() {
        let err = anyhow::Error::new(NamesItsSource {
            path: "l.json".into(),
            source: not_found(),
        });
        assert_eq!(
            format!("{err:#}"),
            "layout file l.json: no such file: no such file"
        );
        assert_eq!(error_message(&err), "layout file l.json: no such file");
    }

    #[test]
    fn context_and_causes_not_yet_named_are_kept_in_order() {
        let err = Err::<(), _>(not_found())
            .context("reading the scene")
            .context("demo")
            .unwrap_err();
        assert_eq!(error_message(&err), "demo: reading the scene: no such file");
    }
}
