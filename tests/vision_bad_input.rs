//! Bad input never panics: truncated, corrupt, empty, unsupported files give
//! clear errors; all-black and all-saturated frames give no detections.

use std::io::Write;

use nanopush::vision::detect::{DetectSettings, detect_particles};
use nanopush::vision::frame::Frame;
use nanopush::vision::frame_input::{Channel, FrameInputError, load_frame, load_frames};
use nanopush::vision::tip::{TipSettings, detect_tip};

fn write(dir: &tempfile::TempDir, name: &str, bytes: &[u8]) -> std::path::PathBuf {
    let p = dir.path().join(name);
    std::fs::File::create(&p).unwrap().write_all(bytes).unwrap();
    p
}

#[test]
fn broken_files_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let good = std::fs::read(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/fixtures/real/brightfield/bf_0000.png"
    ))
    .unwrap();
    let cases = [
        ("truncated.png", good[..good.len() / 3].to_vec()),
        ("corrupt.png", {
            let mut b = good.clone();
            for v in b.iter_mut().skip(100).step_by(7) {
                *v ^= 0x5a;
            }
            b
        }),
        ("empty.png", vec![]),
        ("text.png", b"this is not an image".to_vec()),
        ("broken.tif", b"II*\0garbage".to_vec()),
    ];
    for (name, bytes) in cases {
        let p = write(&dir, name, &bytes);
        let e = load_frame(&p, Channel::Luminance).expect_err(name);
        let msg = e.to_string();
        assert!(
            msg.contains(name),
            "{name}: message {msg:?} should name the file"
        );
        assert!(load_frames(&p, Channel::Luminance).is_err(), "{name}");
    }
    let missing = dir.path().join("missing.png");
    assert!(matches!(
        load_frame(&missing, Channel::Luminance),
        Err(FrameInputError::Io { .. })
    ));
    let empty_dir = tempfile::tempdir().unwrap();
    assert!(matches!(
        load_frames(empty_dir.path(), Channel::Luminance),
        Err(FrameInputError::Empty { .. })
    ));
    let bad_video = write(&dir, "clip.avi", b"not a video");
    assert!(load_frames(&bad_video, Channel::Luminance).is_err());
}

#[test]
fn black_and_saturated_frames_give_nothing() {
    for (v, bits) in [(0.0f32, 8u8), (255.0, 8), (0.0, 16), (65535.0, 16)] {
        let f = Frame::new(128, 96, vec![v; 128 * 96], bits).unwrap();
        assert!(
            detect_particles(&f, &DetectSettings::default())
                .unwrap()
                .is_empty()
        );
        assert_eq!(detect_tip(&f, &TipSettings::default()), None);
    }
    let tiny = Frame::new(4, 4, vec![1.0; 16], 8).unwrap();
    assert!(detect_particles(&tiny, &DetectSettings::default()).is_err());
    let bad = DetectSettings {
        diameter_px: f64::NAN,
        ..DetectSettings::default()
    };
    assert!(detect_particles(&Frame::new(64, 64, vec![1.0; 4096], 8).unwrap(), &bad).is_err());
}

/// Settings that make no sense at the frame's scale are refused by the
/// settings the user gave: `--radius-um` at a calibration's scale (not a
/// "diameter hint" they never typed), and a Crocker-Grier separation below
/// a pixel (which found each particle many times over).
#[test]
fn detect_refuses_settings_by_the_flags_the_user_gave() {
    use nanopush::calib::camera_map::CameraCalibration;
    let dir = tempfile::tempdir().unwrap();
    let frame = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/fixtures/real/brightfield/bf_0000.png"
    );
    let detect = |args: &[&str]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_nanopush"))
            .arg("detect")
            .arg(frame)
            .args(args)
            .output()
            .unwrap()
    };
    let calib = |um_per_px: f64| {
        let c = CameraCalibration::from_scale_rotation(um_per_px * 1e-6, 0.0, [0.0, 0.0]);
        let p = write(
            &dir,
            &format!("calib-{um_per_px}.toml"),
            c.to_toml(None).as_bytes(),
        );
        p.to_str().unwrap().to_string()
    };
    for (radius, um_per_px) in [("5", 25.0), ("-4", 0.5)] {
        let out = detect(&[
            "--calib",
            &calib(um_per_px),
            &format!("--radius-um={radius}"),
        ]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            !out.status.success(),
            "--radius-um {radius} at {um_per_px} um/px: {err}"
        );
        assert!(
            err.contains(&format!("--radius-um {radius}")) && !err.contains("hint"),
            "{err}"
        );
    }
    let out = detect(&[
        "--locator",
        "crocker-grier",
        "--diameter-px",
        "9",
        "--separation-px",
        "0",
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("separation 0 px"),
        "{err}"
    );
    // The hint is named by its flag, and Crocker-Grier's rule in full (1 px,
    // odd, had been refused as not odd).
    for args in [
        &["--diameter-px", "0"][..],
        &["--locator", "crocker-grier", "--diameter-px", "1"],
    ] {
        let out = detect(args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?}");
        assert!(
            err.contains("--diameter-px") && err.contains("at least"),
            "{err}"
        );
    }
    // An overlay name no image format goes with is refused before the
    // detection (it failed only after it, with nothing printed), and nothing
    // is written.
    let overlay = dir.path().join("overlay");
    let out = detect(&["--overlay", overlay.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("--overlay"), "{err}");
    assert!(out.stdout.is_empty() && !overlay.exists());
}

/// A file that is not a video gets our one-line error, not a page of
/// OpenCV's backend errors before it.
#[test]
fn a_broken_video_is_one_line_of_error() {
    let dir = tempfile::tempdir().unwrap();
    let clip = write(&dir, "clip.avi", b"not a video");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_nanopush"))
        .arg("detect")
        .arg(&clip)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(err.contains("clip.avi holds no frames"), "{err}");
}

/// A video that cannot be read, given to `detect` and to `dry-run`: random
/// bytes as an .mp4 (FFmpeg had printed "[mov,mp4,... @ 0x...] moov atom
/// not found") and an MJPG .avi cut after its header (OpenCV's own AVI
/// reader had printed "Unexpected element. Expected: LIST. Got: ."). Only
/// this program's error is on standard error, naming the file; the exit is
/// non-zero.
#[test]
fn a_broken_video_leaves_only_our_error_on_stderr() {
    let dir = tempfile::tempdir().unwrap();
    let mut noise = 0x2545_f491_4f6c_dd1d_u64;
    let random: Vec<u8> = (0..6000)
        .map(|_| {
            noise ^= noise << 13;
            noise ^= noise >> 7;
            noise ^= noise << 17;
            (noise >> 32) as u8
        })
        .collect();
    let mp4 = write(&dir, "random.mp4", &random);
    let whole = dir.path().join("whole.avi");
    let mut video = nanopush::render::video::VideoWriter::create(&whole, 5.0, (64, 48)).unwrap();
    for level in [40u8, 120, 200] {
        video
            .write(&image::RgbImage::from_pixel(64, 48, image::Rgb([level; 3])))
            .unwrap();
    }
    video.finish().unwrap();
    let avi = write(&dir, "cut.avi", &std::fs::read(&whole).unwrap()[..2000]);
    let fixture = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/fixtures/recordings/real-brightfield"
    );
    for clip in [&mp4, &avi] {
        let name = clip.file_name().unwrap().to_string_lossy().into_owned();
        let rec = dir.path().join(format!("rec-{name}"));
        std::fs::create_dir(&rec).unwrap();
        std::fs::write(
            rec.join("recording.toml"),
            format!(
                "schema = \"nanopush.recording/1\"\nsource = \"a broken video\"\n\
                 frames = {:?}\ncalibration = \"{fixture}/calibration.toml\"\n\
                 particle_radius_um = 5.0\nframe_interval_s = 1.0\n\
                 pattern = \"{fixture}/pattern.toml\"\ndetect_tip = false\n",
                clip.to_string_lossy()
            ),
        )
        .unwrap();
        let out = dir.path().join(format!("out-{name}"));
        for args in [
            vec!["detect".to_owned(), clip.to_string_lossy().into_owned()],
            vec![
                "dry-run".to_owned(),
                "--recording".to_owned(),
                rec.to_string_lossy().into_owned(),
                "--out".to_owned(),
                out.to_string_lossy().into_owned(),
            ],
        ] {
            let o = std::process::Command::new(env!("CARGO_BIN_EXE_nanopush"))
                .args(&args)
                .output()
                .unwrap();
            let err = String::from_utf8_lossy(&o.stderr);
            assert!(!o.status.success(), "{args:?}: {err}");
            assert!(
                err.contains(&format!("{name} holds no frames")),
                "{args:?}: {err}"
            );
            assert!(
                err.lines().all(|l| l.starts_with("error: ")),
                "{args:?}: lines not ours on stderr:\n{err}"
            );
            assert!(!err.contains("global ") && !err.contains("[ERROR"), "{err}");
        }
    }
}

mod deadline;

/// Runs `nanopush args` (at most 20 s) and returns its stderr, checking it failed.
fn refused(dir: &std::path::Path, args: &[&str]) -> String {
    let ran = deadline::nanopush_within(dir, args, 20);
    assert!(
        !ran.ok,
        "nanopush {} succeeded: {}",
        args.join(" "),
        ran.stderr
    );
    ran.stderr
}

/// `synth frame` draws only a layout the planner would accept, and a
/// radius flag that is a radius; a huge particle is refused at once
/// rather than after minutes of computing its Cramer-Rao bound.
#[test]
fn synth_frame_refuses_bad_layouts_and_radii_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let layout = |name: &str, particles: &str| {
        let text = format!(
            r#"{{"schema":"nanopush.layout/1","field_um":[100,100],"particles":[{particles}]}}"#
        );
        write(&dir, name, text.as_bytes()).display().to_string()
    };
    let p = |id: u32, x: &str, y: &str, r: &str| {
        format!(r#"{{"id":{id},"x_um":{x},"y_um":{y},"radius_um":{r}}}"#)
    };
    let out = dir.path().join("f.png").display().to_string();
    let truth = dir.path().join("t.json").display().to_string();
    let cases = [
        (
            layout("wide.json", &p(0, "50", "50", "60")),
            "particle 0 radius_um 60.000 is too large",
        ),
        (
            layout("huge.json", &p(0, "50", "50", "1e4")),
            "particle 0 radius_um 10000.000 is over 500 um",
        ),
        (
            layout("far.json", &p(2, "5000", "-50", "5")),
            "particle 2 at (5000.000, -50.000) um",
        ),
        (
            layout(
                "twice.json",
                &format!("{},{}", p(1, "20", "20", "5"), p(1, "60", "60", "5")),
            ),
            "particle id 1 appears twice",
        ),
        (
            layout("e300.json", &p(0, "50", "50", "1e300")),
            "particle 0 radius_um",
        ),
        // Named once, by its path ("layout file layout:" before).
        (
            write(&dir, "empty.json", b"{}").display().to_string(),
            "layout file ",
        ),
    ];
    for (path, needle) in &cases {
        let args = [
            "synth", "frame", "--layout", path, "--truth", &truth, "--out", &out,
        ];
        let err = refused(dir.path(), &args);
        assert!(err.contains(needle), "{path}: {err}");
        assert!(!err.contains("layout file layout"), "{path}: {err}");
    }
    for (r, needle) in [
        ("nan", "--radius-px must be finite and > 0, got NaN"),
        ("inf", "--radius-px must be finite and > 0, got inf"),
        (
            "1e4",
            "--radius-px: its image is 20000.0 px across, larger than the 1024x1024 px frame",
        ),
    ] {
        let err = refused(
            dir.path(),
            &[
                "synth",
                "frame",
                "--n",
                "3",
                "--radius-px",
                r,
                "--out",
                &out,
            ],
        );
        assert!(err.contains(needle), "--radius-px {r}: {err}");
    }
    // A flag of the other source is refused by name, not ignored: with
    // --layout the frame is the field at --um-per-px (a 300 px wide frame
    // asked for had come out 200 px wide without a word).
    let some_layout = layout("some.json", &p(0, "50", "50", "5"));
    for (source, flags, named) in [
        ("--layout", &["--width-px", "300"][..], "--width-px"),
        ("--layout", &["--height-px", "300"][..], "--height-px"),
        ("--layout", &["--radius-px", "4"][..], "--radius-px"),
        ("--n", &["--um-per-px", "0.25"][..], "--um-per-px"),
    ] {
        let value = if source == "--n" { "3" } else { &some_layout };
        let args = [&["synth", "frame", source, value, "--out", &out][..], flags].concat();
        let err = refused(dir.path(), &args);
        assert!(
            err.contains(named) && err.contains("cannot be used with"),
            "{source} with {flags:?}: {err}"
        );
    }
    // Flags named as the user gave them, not as internal render settings.
    for (flags, needle) in [
        (
            &["--snr", "1e300"][..],
            "--snr must be > 0 and at most 1e6, got 1e300",
        ),
        (
            &["--snr", "0"][..],
            "--snr must be > 0 and at most 1e6, got 0",
        ),
        (&["--snr=-2.5"][..], "got -2.5"),
        (
            &["--tip-x-px", "nan", "--tip-y-px", "3"][..],
            "--tip-x-px, --tip-y-px and --tip-angle-deg must be numbers, got NaN",
        ),
    ] {
        let args = [&["synth", "frame", "--n", "3", "--out", &out][..], flags].concat();
        let err = refused(dir.path(), &args);
        assert!(
            err.contains(needle) && !err.contains("0e0"),
            "{flags:?}: {err}"
        );
    }
    assert!(!dir.path().join("f.png").exists() && !dir.path().join("t.json").exists());
}

/// A failed `synth frame` leaves nothing behind: a lossy or unknown format
/// is refused before rendering, and a truth that cannot be written takes the
/// frame with it (a frame without its truth, or an empty file, would pass for
/// a study's input).
#[test]
fn synth_frame_writes_the_frame_and_its_truth_or_neither() {
    let dir = tempfile::tempdir().unwrap();
    let outputs = dir.path().join("outputs");
    std::fs::create_dir(&outputs).unwrap();
    let at = |name: &str| outputs.join(name).display().to_string();
    // A truth that cannot be written once the frame is: it is a folder.
    let a_folder = dir.path().join("a-folder");
    std::fs::create_dir(&a_folder).unwrap();
    let a_folder = a_folder.display().to_string();
    for (out, truth, needle) in [
        (at("f.jpg"), at("t.json"), "--out must end in .png or .tif"),
        (at("f.xyz"), at("t.json"), "--out must end in .png or .tif"),
        (at("f.png"), a_folder.clone(), "a-folder"),
        (at("f.png"), at("f.png"), "is also --out"),
    ] {
        let args = [
            "synth", "frame", "--n", "3", "--bits", "16", "--out", &out, "--truth", &truth,
        ];
        let err = refused(dir.path(), &args);
        assert!(err.contains(needle), "{out}: {err}");
        let left: Vec<_> = std::fs::read_dir(&outputs).unwrap().collect();
        assert!(left.is_empty(), "{out}: left {left:?}");
    }
    let (out, truth) = (at("f.tif"), at("t.json"));
    let args = [
        "synth", "frame", "--n", "3", "--bits", "16", "--out", &out, "--truth", &truth,
    ];
    assert!(deadline::nanopush_within(dir.path(), &args, 20).ok);
    let frame = load_frame(std::path::Path::new(&out), Channel::Luminance).unwrap();
    assert_eq!(frame.bit_depth(), 16);
    assert!(std::path::Path::new(&truth).is_file());
}

/// `study vision` checks its particles before the expensive bound: a
/// radius wider than the frame and zero particles are refused, and a
/// frame too small for the particles asked says how many it holds.
#[test]
fn study_vision_refuses_what_it_cannot_study() {
    let dir = tempfile::tempdir().unwrap();
    let study = [
        "study",
        "vision",
        "--snr",
        "8",
        "--frames",
        "1",
        "--size-px",
        "128",
    ];
    let with = |extra: &[&'static str]| -> Vec<&'static str> {
        study.iter().chain(extra).copied().collect()
    };
    let err = refused(
        dir.path(),
        &with(&["--radius-px", "1e4", "--particles", "5"]),
    );
    assert!(
        err.contains(
            "--radius-px: its image is 20000.0 px across, larger than the 128x128 px frame"
        ),
        "{err}"
    );
    let err = refused(dir.path(), &with(&["--particles", "0"]));
    assert!(err.contains("--particles must be > 0"), "{err}");
    // An SNR of 0 is said as 0 (it printed "0e0").
    let mut dark = study.to_vec();
    dark[3] = "8,0";
    let err = refused(dir.path(), &dark);
    assert!(
        err.contains("--snr must be > 0 and at most 1e6, got 0") && !err.contains("0e0"),
        "{err}"
    );
    // A frame too small for any sphere: it had printed recall 0, precision
    // 1 and radius error 0 % for particles never drawn, and exited 0.
    let mut tiny = study.to_vec();
    let size = tiny.iter().position(|a| *a == "--size-px").unwrap() + 1;
    tiny[size] = "17";
    let err = refused(dir.path(), &tiny);
    assert!(err.contains("nothing to study"), "{err}");
    // A frame of no pixels is said of the frame (it blamed --radius-px).
    let mut empty = study.to_vec();
    let size = empty.iter().position(|a| *a == "--size-px").unwrap() + 1;
    empty[size] = "0";
    let err = refused(dir.path(), &empty);
    assert!(
        err.contains("the frame is 0x0 px") && !err.contains("--radius-px"),
        "{err}"
    );
    // Its tables go into a folder that is not there yet.
    let table = dir.path().join("new/folder/vis");
    let table_arg = table.display().to_string();
    let mut args: Vec<&str> = with(&["--particles", "100000"]);
    args.extend(["--out", table_arg.as_str()]);
    let ran = deadline::nanopush_within(dir.path(), &args, 60);
    assert!(ran.ok, "{}", ran.stderr);
    let header = ran.stdout.lines().next().unwrap_or_default();
    assert!(
        header.contains("(of 100000 asked; no more fit) spheres"),
        "{header}"
    );
    assert!(table.with_extension("md").is_file() && table.with_extension("json").is_file());
}

/// `detect` on a folder of frames, or a TIFF stack, says which one it looked at (before,
/// it took the first silently, after reading every one).
#[test]
fn detect_on_a_folder_or_a_stack_names_the_frame_it_reads() {
    let folder = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/fixtures/recordings/sim-L-seed6/frames"
    );
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_nanopush"))
        .args(["detect", folder, "--no-tip"])
        .output()
        .unwrap();
    assert!(out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("detecting on its first image of 4, frame_00000.png"),
        "{stderr}"
    );
    // So does a TIFF stack, of its first page.
    let dir = tempfile::tempdir().unwrap();
    let stack = dir.path().join("stack.tif");
    let frames = nanopush::vision::frame_input::load_frames(
        std::path::Path::new(folder),
        nanopush::vision::frame_input::Channel::Luminance,
    )
    .unwrap();
    let mut encoder =
        tiff::encoder::TiffEncoder::new(std::fs::File::create(&stack).unwrap()).unwrap();
    for f in &frames[..3] {
        let page: Vec<u16> = f.pixels().iter().map(|&p| p as u16).collect();
        encoder
            .write_image::<tiff::encoder::colortype::Gray16>(
                f.width() as u32,
                f.height() as u32,
                &page,
            )
            .unwrap();
    }
    drop(encoder);
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_nanopush"))
        .args(["detect", stack.to_str().unwrap(), "--no-tip"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains("detecting on its first page of 3 (a TIFF stack)"),
        "{stderr}"
    );
}
