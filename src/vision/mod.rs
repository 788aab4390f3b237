//! Microscope image pipeline: frame input, particle and tip detection.
