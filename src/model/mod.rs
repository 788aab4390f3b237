//! The dynamic pushing model (shared/spec/pushing-model.md): cantilever springs,
//! contact mechanics, motion criteria and the quasi-static push simulation.
//!
//! Entry points: [`scene::Scene::load`], [`push_sim::simulate_push`] (the
//! simulated rig's per-push call) and [`advice::advise_push`] (the executor's).

pub mod advice;
pub mod cantilever;
pub mod contact;
pub mod critical_force;
pub mod effects;
pub mod error;
pub mod friction;
pub mod kinematics;
pub mod mode_machine;
pub mod outcome;
mod plausible;
pub mod push_plots;
pub mod push_sim;
pub mod root;
pub mod scene;
pub mod series_csv;
pub mod study;
pub mod summary;
pub mod units;

pub use error::ModelError;
pub use outcome::{Outcome, PushResult};
pub(crate) use plausible::plausible;
pub use push_sim::{PushParams, SolverSettings, simulate_push};
pub use scene::Scene;
