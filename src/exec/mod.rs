//! The closed-loop executor: detect, plan, push, verify, recover.

pub mod assemble;
pub mod events;
pub mod journal;
pub mod observe;
pub mod push_check;
pub mod report;
pub mod stroke;
pub mod tracker;
