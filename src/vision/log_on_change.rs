//! A camera's state that every frame would repeat (a dead line, an
//! over-exposed sensor) is logged when it first appears or changes, per
//! source, not thirty times a second.

use std::collections::BTreeMap;
use std::sync::Mutex;

/// True when `state` differs from the state last given for `topic` (none
/// before), which it then becomes.
pub fn changed(topic: String, state: String) -> bool {
    static LAST: Mutex<BTreeMap<String, String>> = Mutex::new(BTreeMap::new());
    let mut last = LAST.lock().unwrap_or_else(|p| p.into_inner());
    last.insert(topic, state.clone()).as_ref() != Some(&state)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_state_is_new_once_per_topic_until_it_changes() {
        let t = |topic: &str, state: &str| changed(format!("test {topic}"), state.to_owned());
        assert!(t("a", "x"));
        assert!(!t("a", "x"));
        assert!(t("b", "x"), "another topic has its own state");
        assert!(t("a", "y"));
        assert!(t("a", "x"), "back to an earlier state is a change");
    }
}
