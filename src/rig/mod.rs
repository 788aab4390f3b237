//! Rig interface (stage, camera, probe readout) and its implementations.
