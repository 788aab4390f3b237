//! Reading a rig file's `[camera]` table into a [`CameraSource`]: first
//! every key any kind takes, flat (`Table`), then the kind's own. Why not
//! serde's internally tagged enum (`tag = "kind"`): it reads the whole table
//! before it looks at `kind`, which drops toml's spans, so every error was
//! reported at the `[camera]` header. Read flat, toml reports a misspelt key
//! or a bad value at its line. A key of another kind is known only once the
//! table is read (`kind` may come last); [`at_its_key`] moves that refusal
//! from the header to the key's line.

use super::camera_source::{
    CameraSource, FrameOrder, FramePick, default_frame_timeout_ms, default_stable_ms, default_true,
};
use crate::vision::frame_input::Channel;
use serde::{Deserialize, Deserializer, Serialize, de};
use std::path::PathBuf;

/// The kinds of camera, as `kind` names them.
#[derive(Debug, Clone, Copy, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
enum Kind {
    Folder,
    Video,
    Device,
    Gstreamer,
    Aravis,
    Simulated,
}

/// The `[camera]` table as written: every key any kind takes. A new key is
/// added here and where [`Table::into_source`] builds its kind; which keys
/// a kind takes is read off the [`CameraSource`] built.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Table {
    kind: Kind,
    path: Option<PathBuf>,
    order: Option<FrameOrder>,
    pick: Option<FramePick>,
    skip_existing: Option<bool>,
    stable_ms: Option<u64>,
    timeout_ms: Option<u64>,
    channel: Option<Channel>,
    index: Option<i32>,
    pipeline: Option<String>,
    device: Option<String>,
}

/// Why a table read whole is refused: a key its kind does not take (named,
/// to be reported at its line) or a required key missing (`key` none: it
/// has no line of its own, the table's is used).
struct Refusal {
    key: Option<String>,
    message: String,
}

impl Table {
    /// The camera of its kind, defaults filled in; refused for a key of
    /// another kind, then for a required key missing.
    fn into_source(self) -> Result<CameraSource, Refusal> {
        let written = keys_of(&self);
        let mut missing = None;
        let channel = self.channel.unwrap_or_default();
        let timeout_ms = self.timeout_ms.unwrap_or_else(default_frame_timeout_ms);
        let source = match self.kind {
            Kind::Folder => CameraSource::Folder {
                path: required(self.path, "path", &mut missing),
                order: self.order.unwrap_or_default(),
                pick: self.pick.unwrap_or_default(),
                skip_existing: self.skip_existing.unwrap_or_else(default_true),
                stable_ms: self.stable_ms.unwrap_or_else(default_stable_ms),
                timeout_ms,
                channel,
            },
            Kind::Video => CameraSource::Video {
                path: required(self.path, "path", &mut missing),
                channel,
            },
            Kind::Device => CameraSource::Device {
                index: required(self.index, "index", &mut missing),
                channel,
            },
            Kind::Gstreamer => CameraSource::Gstreamer {
                pipeline: required(self.pipeline, "pipeline", &mut missing),
                channel,
            },
            Kind::Aravis => CameraSource::Aravis {
                device: self.device.unwrap_or_default(),
                timeout_ms,
            },
            Kind::Simulated => CameraSource::Simulated,
        };
        let takes = keys_of(&source);
        if let Some(key) = written.into_iter().find(|k| !takes.contains(k)) {
            let takes = match takes.as_slice() {
                [] => "no other key".to_string(),
                keys => format!("only {}", keys.join(", ")),
            };
            let kind = source.kind();
            return Err(Refusal {
                message: format!(
                    "unknown field `{key}`: a camera of kind = \"{kind}\" takes {takes}"
                ),
                key: Some(key),
            });
        }
        match missing {
            Some(key) => Err(Refusal {
                key: None,
                message: format!("missing field `{key}`"),
            }),
            None => Ok(source),
        }
    }
}

/// `value`, or a stand-in noting `key` as missing (refused once the keys
/// are checked: a key of another kind says more).
fn required<T: Default>(value: Option<T>, key: &'static str, missing: &mut Option<&str>) -> T {
    value.unwrap_or_else(|| {
        missing.get_or_insert(key);
        T::default()
    })
}

/// The keys `value` writes besides `kind` (a `None` writes none), in order.
fn keys_of(value: &impl Serialize) -> Vec<String> {
    toml::Table::try_from(value)
        .map(|t| t.keys().filter(|k| *k != "kind").cloned().collect())
        .unwrap_or_default()
}

impl<'de> Deserialize<'de> for CameraSource {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        Table::deserialize(deserializer)?
            .into_source()
            .map_err(|refusal| de::Error::custom(refusal.message))
    }
}

/// `err`, toml's error reading the rig file `text`, at the key it names when
/// it refuses a `[camera]` key of another kind (toml had put it at the
/// `[camera]` header); any other error as it is.
pub fn at_its_key(text: &str, err: toml::de::Error) -> toml::de::Error {
    #[derive(Deserialize)]
    struct Rig {
        camera: Table,
    }
    let Ok(Rig { camera }) = toml::from_str::<Rig>(text) else {
        return err;
    };
    match camera.into_source() {
        Err(Refusal {
            key: Some(key),
            message,
        }) if message == err.message() => {
            crate::toml_blame::error_at_key(text, &["camera", &key], &message).unwrap_or(err)
        }
        _ => err,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, Deserialize)]
    #[allow(dead_code)]
    struct Rig {
        name: String,
        camera: CameraSource,
    }

    /// The line the error points at, 1-based, as a rig file is read.
    fn error_line(text: &str) -> (usize, String) {
        let err = toml::from_str::<Rig>(text).unwrap_err();
        let err = at_its_key(text, err);
        let at = err.span().expect("a span").start;
        (text[..at].matches('\n').count() + 1, err.to_string())
    }

    /// A misspelt key, a bad value, a key of another kind (before or after
    /// `kind`) and an unknown kind are each reported at their own line; they
    /// had all been reported at the `[camera]` header (line 2), and a key of
    /// another kind above `kind` at the kind's line.
    #[test]
    fn each_error_points_at_its_key() {
        let head = "name = \"r\"\n[camera]\n";
        for (body, line, says) in [
            (
                "kind = \"folder\"\npath = \"f\"\nstabel_ms = 50\n",
                5,
                "unknown field `stabel_ms`, expected one of `kind`, `path`",
            ),
            (
                "kind = \"folder\"\npath = \"f\"\nstable_ms = \"fast\"\n",
                5,
                "invalid type: string \"fast\", expected u64",
            ),
            (
                "kind = \"device\"\nindex = 0\npath = \"x\"\n",
                5,
                "unknown field `path`: a camera of kind = \"device\" takes only index, channel",
            ),
            (
                "index = 0\npath = \"x\"\nkind = \"device\"\n",
                4,
                "unknown field `path`: a camera of kind = \"device\"",
            ),
            (
                "path = \"x\"\nkind = \"device\"\nindex = 0\n",
                3,
                "unknown field `path`: a camera of kind = \"device\"",
            ),
            ("path = \"x\"\nkind = \"webcam\"\n", 4, "webcam"),
            (
                "path = \"x\"\nstabel_ms = 1\n",
                4,
                "unknown field `stabel_ms`, expected one of `kind`, `path`",
            ),
            (
                "kind = \"aravis\"\nchannel = \"green\"\n",
                4,
                "kind = \"aravis\" takes only device, timeout_ms",
            ),
            (
                "kind = \"simulated\"\npath = \"x\"\n",
                4,
                "takes no other key",
            ),
            // A key of another kind is named before a required key missing.
            (
                "kind = \"device\"\npath = \"x\"\n",
                4,
                "unknown field `path`",
            ),
        ] {
            let (at, err) = error_line(&format!("{head}{body}"));
            assert_eq!(at, line, "{body}: {err}");
            assert!(err.contains(says), "{body}: {err}");
        }
        // A required key missing has no line of its own: the table's.
        let (at, err) = error_line(&format!("{head}kind = \"folder\"\n"));
        assert_eq!(at, 2, "{err}");
        assert!(err.contains("missing field `path`"), "{err}");
    }
}
