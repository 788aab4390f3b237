//! The closed-loop executor: detect, plan, push, verify, recover.

pub mod journal;
pub mod push_check;
pub mod stroke;
pub mod tracker;
