//! nanopush: a vision-in-the-loop automated assembly planner for probe-based
//! micro/nanoparticle manipulation.
//!
//! The data flow, one folder per stage:
//! frame ([`render`] or camera) -> [`vision`] -> [`calib`] -> [`plan`] ->
//! [`exec`] (asks [`model`] for contact angle and push duration) -> [`rig`].
//! The [`cli`] module is a thin layer over these.

pub mod byte_order_mark;
pub mod calib;
pub mod cli;
pub mod exec;
pub mod file_schema;
pub mod median;
pub mod model;
pub mod natural_order;
pub mod plan;
pub mod render;
pub mod rig;
pub mod toml_blame;
pub mod vision;
pub mod wording;
