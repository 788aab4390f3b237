//! The closed-loop executor: detect, plan, push, verify, recover.

pub mod journal;
pub mod tracker;
