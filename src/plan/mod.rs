//! From a target pattern to an ordered, collision-checked push plan.
