//! The watched-folder camera against a writer that misbehaves: files written
//! slowly, garbage, a truncated PNG, a file that never completes, a folder
//! that disappears. Each case ends in a frame, a recorded skip, `Ok(None)`
//! or a typed error, within a bounded time.

use nanopush::render::microscope::{RenderSettings, SceneView, TipView, render_frame};
use nanopush::rig::RigError;
use nanopush::rig::camera::Camera;
use nanopush::rig::camera_clock::WallClock;
use nanopush::rig::camera_folder::{FolderCamera, FolderCameraSettings};
use nanopush::rig::camera_source::{FrameOrder, FramePick};
use nanopush::vision::frame::Frame;
use nanopush::vision::frame_input::{Channel, load_frame, save_png};
use std::io::Write;
use std::path::Path;
use std::time::{Duration, Instant};

/// Upper bound for any single grab in these tests: far above every timeout
/// used, so that exceeding it can only mean a hang.
const HANG: Duration = Duration::from_secs(10);

fn settings(dir: &Path) -> FolderCameraSettings {
    FolderCameraSettings {
        skip_existing: false,
        stable_for: Duration::from_millis(30),
        timeout: Duration::from_millis(1500),
        ..FolderCameraSettings::new(dir)
    }
}

fn frame(seed: u64) -> Frame {
    let scene = SceneView {
        width_px: 48,
        height_px: 40,
        particles: vec![],
        tip: Some(TipView {
            apex_x_px: 20.0 + seed as f64,
            apex_y_px: 18.0,
            angle_rad: 1.0,
        }),
    };
    render_frame(&scene, &RenderSettings::with_snr(30.0, 12), seed).unwrap()
}

/// PNG bytes of a rendered frame (written once, outside the watched folder).
fn png_bytes(seed: u64, _watched: &Path) -> Vec<u8> {
    let scratch = tempfile::tempdir().unwrap();
    let path = scratch.path().join("frame.png");
    save_png(&frame(seed), &path).unwrap();
    std::fs::read(&path).unwrap()
}

fn grab_bounded(camera: &mut FolderCamera) -> Result<Option<Frame>, RigError> {
    let t0 = Instant::now();
    let out = camera.grab();
    assert!(t0.elapsed() < HANG, "grab hung for {:?}", t0.elapsed());
    out.map(|o| o.map(|f| f.frame))
}

#[test]
fn a_frame_written_slowly_is_read_only_once_complete() {
    let dir = tempfile::tempdir().unwrap();
    let bytes = png_bytes(1, dir.path());
    let mut camera = FolderCamera::open(settings(dir.path()), WallClock::start()).unwrap();
    let path = dir.path().join("frame_0001.png");
    let writer = {
        let path = path.clone();
        let bytes = bytes.clone();
        std::thread::spawn(move || {
            let mut f = std::fs::File::create(&path).unwrap();
            // Half the file, then a pause longer than the stable time: the
            // camera sees a still, undecodable file and must retry, not fail.
            let half = bytes.len() / 2;
            f.write_all(&bytes[..half]).unwrap();
            f.flush().unwrap();
            std::thread::sleep(Duration::from_millis(120));
            for chunk in bytes[half..].chunks(64) {
                f.write_all(chunk).unwrap();
                f.flush().unwrap();
                std::thread::sleep(Duration::from_millis(2));
            }
        })
    };
    let got = grab_bounded(&mut camera).unwrap().expect("a frame");
    writer.join().unwrap();
    assert_eq!(got, load_frame(&path, Channel::Luminance).unwrap());
    assert!(camera.skipped().is_empty(), "{:?}", camera.skipped());
    // It is taken once only.
    let mut quick = settings(dir.path());
    quick.timeout = Duration::from_millis(100);
    let mut camera2 = FolderCamera::open(quick, WallClock::start()).unwrap();
    assert!(grab_bounded(&mut camera2).unwrap().is_some());
    assert_eq!(grab_bounded(&mut camera2).unwrap(), None);
}

#[test]
fn garbage_and_a_truncated_png_are_skipped_and_recorded() {
    let dir = tempfile::tempdir().unwrap();
    let good = png_bytes(2, dir.path());
    std::fs::write(
        dir.path().join("frame_0001.png"),
        b"\x89PNG this is not an image at all",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("frame_0002.png"),
        &good[..good.len() * 2 / 3],
    )
    .unwrap();
    std::fs::write(dir.path().join("frame_0003.tif"), [0u8; 10]).unwrap();
    std::fs::write(dir.path().join("frame_0004.png"), &good).unwrap();
    std::fs::write(dir.path().join("notes.txt"), b"not a frame").unwrap();
    let mut camera = FolderCamera::open(settings(dir.path()), WallClock::start()).unwrap();
    let got = grab_bounded(&mut camera).unwrap().expect("the good frame");
    assert_eq!(
        got,
        load_frame(&dir.path().join("frame_0004.png"), Channel::Luminance).unwrap()
    );
    let skipped: Vec<String> = camera
        .skipped()
        .iter()
        .map(|s| s.path.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    assert_eq!(
        skipped,
        ["frame_0001.png", "frame_0002.png", "frame_0003.tif"]
    );
    assert!(camera.skipped().iter().all(|s| !s.reason.is_empty()));
}

#[test]
fn a_file_that_never_completes_does_not_hang_the_camera() {
    let dir = tempfile::tempdir().unwrap();
    let good = png_bytes(3, dir.path());
    std::fs::write(dir.path().join("a.png"), &good[..100]).unwrap();
    let mut s = settings(dir.path());
    s.timeout = Duration::from_millis(60);
    let mut camera = FolderCamera::open(s, WallClock::start()).unwrap();
    // Within one short timeout the stuck file is retried, not yet given up.
    assert_eq!(grab_bounded(&mut camera).unwrap(), None);
    // Asking again eventually gives it up; a later good frame comes through.
    std::fs::write(dir.path().join("b.png"), &good).unwrap();
    let mut got = None;
    for _ in 0..20 {
        got = grab_bounded(&mut camera).unwrap();
        if got.is_some() {
            break;
        }
    }
    assert!(
        got.is_some(),
        "the good frame behind the stuck one never came"
    );
    assert_eq!(camera.skipped().len(), 1);
}

#[test]
fn no_new_frame_is_ok_none_after_the_timeout() {
    let dir = tempfile::tempdir().unwrap();
    let mut s = settings(dir.path());
    s.timeout = Duration::from_millis(200);
    let mut camera = FolderCamera::open(s, WallClock::start()).unwrap();
    let t0 = Instant::now();
    assert_eq!(grab_bounded(&mut camera).unwrap(), None);
    assert!(
        t0.elapsed() >= Duration::from_millis(200),
        "returned before the timeout: {:?}",
        t0.elapsed()
    );
}

#[test]
fn existing_files_are_skipped_and_latest_drops_the_backlog() {
    let dir = tempfile::tempdir().unwrap();
    let old = png_bytes(4, dir.path());
    std::fs::write(dir.path().join("frame_0001.png"), &old).unwrap();
    let mut s = settings(dir.path());
    s.skip_existing = true;
    s.pick = FramePick::Latest;
    s.timeout = Duration::from_millis(300);
    let mut camera = FolderCamera::open(s, WallClock::start()).unwrap();
    assert_eq!(grab_bounded(&mut camera).unwrap(), None, "old file taken");
    for (i, seed) in [5u64, 6, 7].iter().enumerate() {
        std::fs::write(
            dir.path().join(format!("frame_{:04}.png", i + 2)),
            png_bytes(*seed, dir.path()),
        )
        .unwrap();
    }
    let got = grab_bounded(&mut camera).unwrap().expect("newest");
    assert_eq!(
        got,
        load_frame(&dir.path().join("frame_0004.png"), Channel::Luminance).unwrap()
    );
    assert_eq!(grab_bounded(&mut camera).unwrap(), None, "backlog dropped");
}

#[test]
fn mtime_order_takes_the_oldest_first_whatever_the_names() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("z.png"), png_bytes(8, dir.path())).unwrap();
    std::thread::sleep(Duration::from_millis(30));
    std::fs::write(dir.path().join("a.png"), png_bytes(9, dir.path())).unwrap();
    let mut s = settings(dir.path());
    s.order = FrameOrder::Mtime;
    let mut camera = FolderCamera::open(s, WallClock::start()).unwrap();
    let first = grab_bounded(&mut camera).unwrap().unwrap();
    let second = grab_bounded(&mut camera).unwrap().unwrap();
    assert_eq!(
        first,
        load_frame(&dir.path().join("z.png"), Channel::Luminance).unwrap()
    );
    assert_eq!(
        second,
        load_frame(&dir.path().join("a.png"), Channel::Luminance).unwrap()
    );
}

#[test]
fn frame_times_follow_the_files_and_the_clock() {
    let dir = tempfile::tempdir().unwrap();
    let clock = WallClock::start();
    let mut camera = FolderCamera::open(settings(dir.path()), clock).unwrap();
    std::thread::sleep(Duration::from_millis(50));
    std::fs::write(dir.path().join("f.png"), png_bytes(10, dir.path())).unwrap();
    let timed = camera.grab().unwrap().unwrap();
    assert!(
        timed.t_s > 0.0 && timed.t_s <= clock.now_s(),
        "t_s {} now {}",
        timed.t_s,
        clock.now_s()
    );
}

#[test]
fn a_folder_that_disappears_is_a_typed_error() {
    let dir = tempfile::tempdir().unwrap();
    let watched = dir.path().join("frames");
    std::fs::create_dir(&watched).unwrap();
    let mut camera = FolderCamera::open(settings(&watched), WallClock::start()).unwrap();
    std::fs::remove_dir(&watched).unwrap();
    assert!(matches!(camera.grab(), Err(RigError::Io(_))));
}
