//! toml's own error at a key chosen after the whole file was read. Some
//! refusals can only be made once a table is read whole (a `[camera]` key
//! that `kind`, written below it, does not take); raised then, toml puts
//! them at the table's header. Read again, with the refusal raised while
//! the key itself is read, toml reports it at the key's line, with its
//! snippet, as it does a misspelt key.

use serde::Deserialize;
use serde::de::{self, DeserializeSeed, Deserializer, IgnoredAny, MapAccess, Visitor};

/// toml's error saying `message` at the key `path` (`["camera", "index"]`)
/// of `text`; `None` when `text` has no such key.
pub fn error_at_key(text: &str, path: &[&str], message: &str) -> Option<toml::de::Error> {
    let document = toml::de::Deserializer::parse(text).ok()?;
    Blame { path, message }.deserialize(document).err()
}

/// Walks down `path`, skipping every other key, and refuses its last key.
struct Blame<'a> {
    path: &'a [&'a str],
    message: &'a str,
}

impl<'de> DeserializeSeed<'de> for Blame<'_> {
    type Value = ();

    fn deserialize<D: Deserializer<'de>>(self, deserializer: D) -> Result<(), D::Error> {
        deserializer.deserialize_map(self)
    }
}

impl<'de> Visitor<'de> for Blame<'_> {
    type Value = ();

    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("a table")
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<(), A::Error> {
        let [first, rest @ ..] = self.path else {
            return Ok(());
        };
        let last = rest.is_empty().then_some(self.message);
        while let Some(found) = map.next_key_seed(Key { name: first, last })? {
            match found {
                true => map.next_value_seed(Blame {
                    path: rest,
                    message: self.message,
                })?,
                false => drop(map.next_value::<IgnoredAny>()?),
            }
        }
        Ok(())
    }
}

/// A key: whether it is `name`; refused with `last`'s message when it is
/// and the path ends there (refused while it is read: toml then puts the
/// error at the key).
struct Key<'a> {
    name: &'a str,
    last: Option<&'a str>,
}

impl<'de> DeserializeSeed<'de> for Key<'_> {
    type Value = bool;

    fn deserialize<D: Deserializer<'de>>(self, deserializer: D) -> Result<bool, D::Error> {
        let found = String::deserialize(deserializer)? == self.name;
        match (found, self.last) {
            (true, Some(message)) => Err(de::Error::custom(message)),
            _ => Ok(found),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The error stands at the key's line, with toml's snippet of it.
    #[test]
    fn the_error_is_at_the_key() {
        let text = "name = \"r\"\n[camera]\nindex = 0\nkind = \"folder\"\n";
        let err = error_at_key(text, &["camera", "index"], "not here").unwrap();
        let shown = err.to_string();
        assert!(shown.contains("at line 3, column 1"), "{shown}");
        assert!(
            shown.contains("index = 0") && shown.contains("not here"),
            "{shown}"
        );
        assert!(error_at_key(text, &["camera", "path"], "x").is_none());
        assert!(error_at_key(text, &["stage", "index"], "x").is_none());
    }
}
