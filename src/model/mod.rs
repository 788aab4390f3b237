//! The dynamic pushing model (shared/spec/pushing-model.md): cantilever springs,
//! contact mechanics, motion criteria and the quasi-static push simulation.
