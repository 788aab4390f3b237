//! The `schema` a file says it is, for errors: a file of another kind (a
//! layout given as a plan, a scene given as a calibration, a calibration as
//! a rig file) is named by its schema, not by the first field serde found
//! missing or unknown ("unknown field `interfaces`" had answered a scene
//! given as `--calib`). nanopush's TOML files (calibrations, scenes, rig
//! files, a recording's recording.toml) look alike to a person, so every
//! TOML reader asks [`other_toml_kind`] first.

use thiserror::Error;

/// A nanopush file of another kind given where `wanted` was expected.
#[derive(Debug, Clone, PartialEq, Error)]
#[error("this is {} ({schema}), not {wanted}", kind_of(schema))]
pub struct AnotherKind {
    /// The schema the file names, such as `nanopush.scene/1`.
    pub schema: String,
    /// What the reader expected, said for a person, with how to tell it
    /// ("a calibration (nanopush.calibration/1 or /2: pixel_to_stage_um ...)").
    pub wanted: &'static str,
}

/// The JSON text's top-level `"schema"`, when it has one other than `expected`.
pub fn other_json_schema(text: &str, expected: &str) -> Option<String> {
    serde_json::from_str::<serde_json::Value>(text)
        .ok()?
        .get("schema")?
        .as_str()
        .filter(|s| *s != expected)
        .map(str::to_owned)
}

/// The TOML text's top-level `schema`, when it names a nanopush kind other
/// than `expected`'s (any version of it: another version is the reader's
/// own schema check to word), as an error saying that the file is not
/// `wanted`. `None` for text that does not parse or names no such schema:
/// the reader's own errors say more then.
pub fn other_toml_kind(text: &str, expected: &str, wanted: &'static str) -> Option<AnotherKind> {
    let table = toml::from_str::<toml::Table>(crate::byte_order_mark::without_bom(text)).ok()?;
    let schema = table.get("schema")?.as_str()?;
    (schema.starts_with("nanopush.") && family(schema) != family(expected)).then(|| AnotherKind {
        schema: schema.to_owned(),
        wanted,
    })
}

/// A schema without its version: `nanopush.scene` of `nanopush.scene/1`.
fn family(schema: &str) -> &str {
    schema.split_once('/').map_or(schema, |(family, _)| family)
}

/// What a person calls a file of `schema`: "a scene file".
fn kind_of(schema: &str) -> String {
    let said = match family(schema) {
        "nanopush.scene" => "a scene file",
        "nanopush.calibration" => "a calibration",
        "nanopush.rig" => "a rig file",
        "nanopush.recording" => "a recording's recording.toml",
        "nanopush.layout" => "a layout",
        "nanopush.plan" => "a plan",
        "nanopush.detections" => "a detections file",
        "nanopush.journal" => "a run's journal",
        other => return format!("a {} file", other.trim_start_matches("nanopush.")),
    };
    said.to_owned()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_another_schema_is_named() {
        let text = r#"{"schema": "nanopush.layout/1", "field_um": [1, 1]}"#;
        assert_eq!(
            other_json_schema(text, "nanopush.plan/1").as_deref(),
            Some("nanopush.layout/1")
        );
        assert_eq!(other_json_schema(text, "nanopush.layout/1"), None);
        assert_eq!(other_json_schema("{}", "nanopush.plan/1"), None);
        assert_eq!(other_json_schema("not json", "nanopush.plan/1"), None);
    }

    /// Another kind is named by what it is; the same kind in another
    /// version, a schema not nanopush's, none at all, or text that is not
    /// TOML are left to the reader.
    #[test]
    fn a_toml_file_of_another_kind_is_named_by_what_it_is() {
        let scene = "schema = \"nanopush.scene/1\"\n[interfaces.particle_substrate]\nx = 1\n";
        let err = other_toml_kind(scene, "nanopush.calibration/1", "a calibration").unwrap();
        assert_eq!(
            err.to_string(),
            "this is a scene file (nanopush.scene/1), not a calibration"
        );
        let later = "schema = \"nanopush.calibration/9\"\n";
        assert_eq!(other_toml_kind(later, "nanopush.calibration/1", "x"), None);
        for text in ["schema = \"acme/1\"\n", "name = \"x\"\n", "schema = ", ""] {
            assert_eq!(
                other_toml_kind(text, "nanopush.calibration/1", "x"),
                None,
                "{text}"
            );
        }
        let odd = other_toml_kind(
            "schema = \"nanopush.truth/1\"",
            "nanopush.rig/1",
            "a rig file",
        );
        assert_eq!(
            odd.unwrap().to_string(),
            "this is a truth file (nanopush.truth/1), not a rig file"
        );
    }
}
