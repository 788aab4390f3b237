//! A colour camera named in a rig file gives the channel its `[camera]`
//! section asks for (`channel = "green"`), as `detect --channel` does for a
//! file: through the watched folder and through OpenCV's video input.

use nanopush::render::video::VideoWriter;
use nanopush::rig::camera::Camera;
use nanopush::rig::camera_clock::WallClock;
use nanopush::rig::camera_open::open_camera;
use nanopush::rig::camera_source::{CameraSource, FrameOrder, FramePick};
use nanopush::vision::frame::Frame;
use nanopush::vision::frame_input::{Channel, load_frame};
use std::time::{Duration, Instant};

/// The next frame, waiting at most a few seconds for the folder's writer.
fn grab(camera: &mut dyn Camera) -> Frame {
    let t0 = Instant::now();
    loop {
        if let Some(timed) = camera.grab().expect("grab") {
            return timed.frame;
        }
        assert!(t0.elapsed() < Duration::from_secs(10), "no frame came");
    }
}

/// A colour picture whose three channels differ everywhere: red rises
/// along x, green along y, blue is flat.
fn colour_picture(w: u32, h: u32) -> image::RgbImage {
    image::RgbImage::from_fn(w, h, |x, y| {
        image::Rgb([(x * 255 / w) as u8, (y * 255 / h) as u8, 90])
    })
}

fn folder_camera(dir: &std::path::Path, channel: Channel) -> CameraSource {
    CameraSource::Folder {
        path: dir.to_owned(),
        order: FrameOrder::Name,
        pick: FramePick::Every,
        skip_existing: false,
        stable_ms: 20,
        timeout_ms: 500,
        channel,
    }
}

#[test]
fn a_watched_folder_gives_the_channel_the_rig_file_names() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("frame_0001.png");
    colour_picture(40, 30).save(&path).unwrap();
    for channel in [Channel::Green, Channel::Red, Channel::Luminance] {
        let source = folder_camera(dir.path(), channel);
        let mut camera = open_camera(&source, WallClock::start()).unwrap();
        let frame = grab(camera.as_mut());
        assert_eq!(frame, load_frame(&path, channel).unwrap(), "{channel}");
    }
    // The channels differ, so the comparison above tells them apart.
    let green = load_frame(&path, Channel::Green).unwrap();
    assert_ne!(green, load_frame(&path, Channel::Red).unwrap());
    assert_ne!(green, load_frame(&path, Channel::Luminance).unwrap());
}

#[test]
fn a_video_input_gives_the_channel_the_rig_file_names() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("run.avi");
    // Left half green, right half red: which half is bright says which
    // channel was taken (the codec is lossy, the halves 180 counts apart).
    let (w, h) = (64u32, 48u32);
    let halves = image::RgbImage::from_fn(w, h, |x, _| {
        if x < w / 2 {
            image::Rgb([20, 200, 20])
        } else {
            image::Rgb([200, 20, 20])
        }
    });
    let mut video = VideoWriter::create(&path, 10.0, (w, h)).unwrap();
    for _ in 0..3 {
        video.write(&halves).unwrap();
    }
    video.finish().unwrap();
    let left_minus_right = |channel| {
        let source = CameraSource::Video {
            path: path.clone(),
            channel,
        };
        let mut camera = open_camera(&source, WallClock::start()).unwrap();
        let frame = grab(camera.as_mut());
        let mean = |xs: std::ops::Range<usize>| {
            let n = (xs.len() * h as usize) as f64;
            let sum: f64 = xs
                .flat_map(|x| (0..h as usize).map(move |y| (x, y)))
                .map(|(x, y)| f64::from(frame.at(x, y)))
                .sum();
            sum / n
        };
        mean(4..28) - mean(36..60)
    };
    let green = left_minus_right(Channel::Green);
    let red = left_minus_right(Channel::Red);
    assert!(green > 150.0, "green: left - right = {green:.1}");
    assert!(red < -150.0, "red: left - right = {red:.1}");
}
