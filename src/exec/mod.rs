//! The closed-loop executor: detect, plan, push, verify, recover.

pub mod animation;
pub mod artifacts;
pub mod assemble;
pub mod calibration_fit;
pub mod camera_look;
pub mod drift;
pub mod dry_run;
mod dry_run_plan;
pub mod events;
pub mod frame_layout;
pub mod journal;
pub mod observe;
pub mod particle_sizes;
pub mod push_check;
pub mod push_log;
pub mod push_reach;
pub mod recording;
mod recording_check;
pub mod recording_frames;
pub mod recording_times;
pub mod report;
pub mod resume_point;
pub mod scale_doubt;
pub mod sim_run;
pub mod stop_cause;
pub mod stroke;
pub mod tracker;
