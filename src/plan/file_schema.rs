//! The `schema` a JSON file says it is, for errors: a file of another kind
//! (a layout given as a plan, a plan as a layout) is named by its schema,
//! not by the first field serde found missing.

/// The text's top-level `"schema"`, when it has one other than `expected`.
pub fn other_schema(text: &str, expected: &str) -> Option<String> {
    serde_json::from_str::<serde_json::Value>(text)
        .ok()?
        .get("schema")?
        .as_str()
        .filter(|s| *s != expected)
        .map(str::to_owned)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_another_schema_is_named() {
        let text = r#"{"schema": "nanopush.layout/1", "field_um": [1, 1]}"#;
        assert_eq!(
            other_schema(text, "nanopush.plan/1").as_deref(),
            Some("nanopush.layout/1")
        );
        assert_eq!(other_schema(text, "nanopush.layout/1"), None);
        assert_eq!(other_schema("{}", "nanopush.plan/1"), None);
        assert_eq!(other_schema("not json", "nanopush.plan/1"), None);
    }
}
