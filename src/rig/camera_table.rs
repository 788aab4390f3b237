//! Reading a rig file's `[camera]` table into a [`CameraSource`], key by
//! key. Why by hand: serde's internally tagged enums (`tag = "kind"`) read
//! the whole table before they look at `kind`, which drops toml's spans, so
//! a misspelt key or a bad value was reported at the `[camera]` header, not
//! at its line. Here each key and each value is read where it stands, so
//! toml points at it; a key of another kind is refused at the key, naming
//! the keys this kind takes (toml's `preserve_order` gives the keys in the
//! file's order, so the keys after `kind`; one written before `kind` is
//! refused at `kind`, naming the key).

use super::camera_source::{
    CameraSource, FrameOrder, FramePick, default_frame_timeout_ms, default_stable_ms, default_true,
};
use crate::vision::frame_input::Channel;
use serde::Deserialize;
use serde::de::{self, DeserializeSeed, Deserializer, MapAccess, Visitor};
use std::path::PathBuf;

/// The kinds of camera, as `kind` names them.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(rename_all = "lowercase")]
enum Kind {
    Folder,
    Video,
    Device,
    Gstreamer,
    Aravis,
    Simulated,
}

/// Every kind, for the keys any of them takes.
const KINDS: [Kind; 6] = [
    Kind::Folder,
    Kind::Video,
    Kind::Device,
    Kind::Gstreamer,
    Kind::Aravis,
    Kind::Simulated,
];

impl Kind {
    /// The keys a camera of this kind takes besides `kind`.
    fn keys(self) -> &'static [&'static str] {
        match self {
            Kind::Folder => &[
                "path",
                "order",
                "pick",
                "skip_existing",
                "stable_ms",
                "timeout_ms",
                "channel",
            ],
            Kind::Video => &["path", "channel"],
            Kind::Device => &["index", "channel"],
            Kind::Gstreamer => &["pipeline", "channel"],
            Kind::Aravis => &["device", "timeout_ms"],
            Kind::Simulated => &[],
        }
    }

    /// `key` as some kind takes it.
    fn any_takes(key: &str) -> Option<&'static str> {
        KINDS
            .iter()
            .flat_map(|k| k.keys())
            .find(|k| **k == key)
            .copied()
    }

    /// Why `key`, read before `kind`, is refused: no kind takes it.
    fn none_takes(key: &str) -> String {
        let mut keys: Vec<&str> = KINDS.iter().flat_map(|k| k.keys()).copied().collect();
        keys.sort_unstable();
        keys.dedup();
        format!(
            "unknown field `{key}`, expected `kind` or a key of its kind: {}",
            keys.join(", ")
        )
    }

    /// Why `key` is refused for this kind, naming the keys it takes.
    fn refusal(self, key: &str) -> String {
        let name = format!("{self:?}").to_lowercase();
        let takes = match self.keys() {
            [] => "no other key".to_string(),
            keys => format!("only {}", keys.join(", ")),
        };
        format!("unknown field `{key}`: a camera of kind = \"{name}\" takes {takes}")
    }
}

impl<'de> Deserialize<'de> for CameraSource {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        deserializer.deserialize_map(TableVisitor)
    }
}

/// Visits the `[camera]` table's keys in the order written.
struct TableVisitor;

impl<'de> Visitor<'de> for TableVisitor {
    type Value = CameraSource;

    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("a [camera] table with a kind")
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<CameraSource, A::Error> {
        let mut kind = None;
        let mut read = Read::default();
        while let Some(key) = map.next_key_seed(KeySeed(kind))? {
            match key {
                "kind" => kind = Some(map.next_value_seed(KindSeed(&read.keys))?),
                "path" => read.path = Some(map.next_value()?),
                "order" => read.order = Some(map.next_value()?),
                "pick" => read.pick = Some(map.next_value()?),
                "skip_existing" => read.skip_existing = Some(map.next_value()?),
                "stable_ms" => read.stable_ms = Some(map.next_value()?),
                "timeout_ms" => read.timeout_ms = Some(map.next_value()?),
                "channel" => read.channel = Some(map.next_value()?),
                "index" => read.index = Some(map.next_value()?),
                "pipeline" => read.pipeline = Some(map.next_value()?),
                "device" => read.device = Some(map.next_value()?),
                other => return Err(de::Error::custom(Kind::none_takes(other))),
            }
            if key != "kind" {
                read.keys.push(key);
            }
        }
        read.into_source(kind.ok_or_else(|| de::Error::missing_field("kind"))?)
    }
}

/// A key of the table: one some kind takes, and once `kind` is read, one
/// that kind takes (refused inside the key's read, so toml points at it).
struct KeySeed(Option<Kind>);

impl<'de> DeserializeSeed<'de> for KeySeed {
    type Value = &'static str;

    fn deserialize<D: Deserializer<'de>>(self, deserializer: D) -> Result<Self::Value, D::Error> {
        let key = String::deserialize(deserializer)?;
        if key == "kind" {
            return Ok("kind");
        }
        match (Kind::any_takes(&key), self.0) {
            (Some(k), Some(kind)) if kind.keys().contains(&k) => Ok(k),
            (Some(k), None) => Ok(k),
            (_, Some(kind)) => Err(de::Error::custom(kind.refusal(&key))),
            (None, None) => Err(de::Error::custom(Kind::none_takes(&key))),
        }
    }
}

/// `kind`'s value, refused when a key read before it is not of that kind
/// (`kind` written after the keys: toml then points at the kind).
struct KindSeed<'a>(&'a [&'static str]);

impl<'de> DeserializeSeed<'de> for KindSeed<'_> {
    type Value = Kind;

    fn deserialize<D: Deserializer<'de>>(self, deserializer: D) -> Result<Kind, D::Error> {
        let kind = Kind::deserialize(deserializer)?;
        match self.0.iter().find(|k| !kind.keys().contains(k)) {
            Some(key) => Err(de::Error::custom(kind.refusal(key))),
            None => Ok(kind),
        }
    }
}

/// The values read so far, and which keys were written.
#[derive(Default)]
struct Read {
    keys: Vec<&'static str>,
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

impl Read {
    /// The camera of `kind`, defaults filled in; a required key missing
    /// is refused (at the table: it has no line of its own).
    fn into_source<E: de::Error>(self, kind: Kind) -> Result<CameraSource, E> {
        let path = || self.path.clone().ok_or_else(|| E::missing_field("path"));
        let channel = self.channel.unwrap_or_default();
        let timeout_ms = self.timeout_ms.unwrap_or_else(default_frame_timeout_ms);
        Ok(match kind {
            Kind::Folder => CameraSource::Folder {
                path: path()?,
                order: self.order.unwrap_or_default(),
                pick: self.pick.unwrap_or_default(),
                skip_existing: self.skip_existing.unwrap_or_else(default_true),
                stable_ms: self.stable_ms.unwrap_or_else(default_stable_ms),
                timeout_ms,
                channel,
            },
            Kind::Video => CameraSource::Video {
                path: path()?,
                channel,
            },
            Kind::Device => CameraSource::Device {
                index: self.index.ok_or_else(|| E::missing_field("index"))?,
                channel,
            },
            Kind::Gstreamer => CameraSource::Gstreamer {
                pipeline: self.pipeline.ok_or_else(|| E::missing_field("pipeline"))?,
                channel,
            },
            Kind::Aravis => CameraSource::Aravis {
                device: self.device.unwrap_or_default(),
                timeout_ms,
            },
            Kind::Simulated => CameraSource::Simulated,
        })
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

    /// The line toml's error points at, 1-based.
    fn error_line(text: &str) -> (usize, String) {
        let err = toml::from_str::<Rig>(text).unwrap_err();
        let at = err.span().expect("a span").start;
        (text[..at].matches('\n').count() + 1, err.to_string())
    }

    /// A misspelt key, a bad value, a key of another kind (before or after
    /// `kind`) and an unknown kind are each reported at their own line; they
    /// had all been reported at the `[camera]` header (line 2).
    #[test]
    fn each_error_points_at_its_key() {
        let head = "name = \"r\"\n[camera]\n";
        for (body, line, says) in [
            (
                "kind = \"folder\"\npath = \"f\"\nstabel_ms = 50\n",
                5,
                "unknown field `stabel_ms`: a camera of kind = \"folder\" takes only path, order",
            ),
            (
                "kind = \"folder\"\npath = \"f\"\nstable_ms = \"fast\"\n",
                5,
                "invalid type: string \"fast\", expected u64",
            ),
            (
                "kind = \"device\"\nindex = 0\npath = \"x\"\n",
                5,
                "a camera of kind = \"device\" takes only index, channel",
            ),
            (
                "index = 0\npath = \"x\"\nkind = \"device\"\n",
                5,
                "unknown field `path`: a camera of kind = \"device\"",
            ),
            ("path = \"x\"\nkind = \"webcam\"\n", 4, "webcam"),
            (
                "path = \"x\"\nstabel_ms = 1\n",
                4,
                "unknown field `stabel_ms`, expected `kind` or a key of its kind: channel, device",
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
