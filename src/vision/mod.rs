//! Microscope image pipeline: frame input, noise, particle and tip detection,
//! and the Cramer-Rao bound that says how good detection can get.

pub mod analyse;
pub mod band_noise;
pub mod camera_bits;
pub mod cpu_dispatch;
pub mod cramer_rao;
pub mod crocker_grier;
pub mod detect;
pub mod detections_file;
pub mod exposure;
pub mod fast_exp;
pub mod filter;
pub mod frame;
pub mod frame_input;
pub mod frame_pool;
pub mod frame_stream;
pub mod least_squares;
pub mod line_defects;
pub mod log_on_change;
pub mod matching;
pub mod noise;
pub mod opencv_quiet;
pub mod overlay;
pub mod pixel_window;
pub mod poor_fits;
pub mod profile_fit;
pub mod radial_symmetry;
pub mod ring_edge;
pub mod roi;
pub mod size_check;
pub mod tiff_description;
pub mod tiff_fallback;
pub mod tiff_stated_interval;
pub mod tiff_stated_pages;
pub mod tip;
pub mod wide_samples;
