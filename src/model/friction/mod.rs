//! Friction at the particle's contacts: the motion criteria in margin form.

pub mod criteria;
