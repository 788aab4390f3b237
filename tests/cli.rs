//! The binary's contract: help works, unknown commands fail with a non-zero exit.

use std::process::Command;
use std::time::Duration;

mod interrupted;
use interrupted::{interrupt_after, interrupt_once_caught};

fn nanopush() -> Command {
    Command::new(env!("CARGO_BIN_EXE_nanopush"))
}

#[test]
fn help_lists_every_top_level_command() {
    let out = nanopush().arg("--help").output().expect("run nanopush");
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    for cmd in [
        "simulate", "study", "detect", "plan", "assemble", "dry-run", "rig",
    ] {
        assert!(text.contains(cmd), "--help does not list `{cmd}`:\n{text}");
    }
}

#[test]
fn unknown_command_exits_non_zero() {
    let out = nanopush()
        .arg("no-such-command")
        .output()
        .expect("run nanopush");
    assert!(!out.status.success());
}

/// A negative number is a value of the flag before it everywhere: a
/// negative seed is refused as a seed, not as an argument nanopush does
/// not know, and a negative radius reaches the layout's own check.
#[test]
fn a_negative_number_is_read_as_the_flags_value() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out_file = dir.path().join("layout.json");
    let synth = |extra: [&str; 2]| {
        nanopush()
            .args(["synth", "layout", "--n", "5", "--field-um", "50x50"])
            .args(extra)
            .arg("--out")
            .arg(&out_file)
            .output()
            .expect("run nanopush")
    };
    let seed = synth(["--seed", "-1"]);
    let err = String::from_utf8_lossy(&seed.stderr);
    assert!(!seed.status.success());
    assert!(err.contains("invalid value '-1' for '--seed"), "{err}");
    let radius = synth(["--radius-um", "-2"]);
    let err = String::from_utf8_lossy(&radius.stderr);
    assert!(!radius.status.success());
    assert!(err.contains("radius_um is -2"), "{err}");
    assert!(!out_file.exists(), "a refused layout was written");
}

/// Output piped into a reader that has gone (`| head`) ends the process
/// quietly, as for any Unix tool, not with a panic and a backtrace.
#[test]
fn a_closed_output_pipe_is_not_a_panic() {
    let mut child = nanopush()
        .args(["simulate", "--scene", "calib/paper-ps-ito.toml"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("run nanopush");
    drop(child.stdout.take());
    let out = child.wait_with_output().expect("wait for nanopush");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_ne!(out.status.code(), Some(101), "{stderr}");
    use std::os::unix::process::ExitStatusExt;
    assert_eq!(
        out.status.signal(),
        Some(13),
        "not ended by SIGPIPE: {stderr}"
    );
}

/// `study assemble` keeps what it measured: the summary is written after
/// every run, an --out holding a study is refused without --force (it had
/// overwritten the summary and deleted a same-seed run's folder), and a
/// study where no run produced a report fails (it had exited 0).
#[test]
fn study_assemble_keeps_an_earlier_study_and_fails_when_nothing_ran() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("study");
    let study = |text: &str, extra: &[&str]| {
        nanopush()
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .args(["study", "assemble", "--text", text, "--runs", "1", "--out"])
            .arg(&out)
            .args(extra)
            .output()
            .expect("run nanopush")
    };
    let first = study("L", &[]);
    assert!(
        first.status.success(),
        "{}",
        String::from_utf8_lossy(&first.stderr)
    );
    let summary = out.join("study-assemble.json");
    let written = std::fs::read_to_string(&summary).unwrap();
    // The simulated rig counts the tip's landings on particles: none.
    assert!(
        written.contains("\"tip_landings_on_particles\": 0,"),
        "{written}"
    );
    let again = study("L", &[]);
    let said = String::from_utf8_lossy(&again.stderr);
    assert!(
        !again.status.success() && said.contains("--force"),
        "{said}"
    );
    assert_eq!(std::fs::read_to_string(&summary).unwrap(), written);
    assert!(study("L", &["--force"]).status.success());
    let written = std::fs::read_to_string(&summary).unwrap();
    // More sites than the layout's particles: refused before any run, the
    // study left as it was (each run had failed on it in turn).
    let too_big = study("HELLO WORLD NANOPUSH", &["--force"]);
    let said = String::from_utf8_lossy(&too_big.stderr);
    assert!(
        !too_big.status.success()
            && said.contains("sites but only 50 particles: cannot fill the pattern"),
        "{said}"
    );
    assert_eq!(std::fs::read_to_string(&summary).unwrap(), written);
    // The gap round the pattern: checked before any run, and passed to
    // every run (assemble's default, half the radius, when not given).
    let start = || {
        let journal = std::fs::read_to_string(out.join("seed-1/journal.jsonl")).unwrap();
        journal.lines().nth(1).unwrap().to_owned()
    };
    assert!(start().contains(r#""keep_clear_um":2.5"#), "{}", start());
    let bad = study("L", &["--force", "--keep-clear-um", "-1"]);
    let said = String::from_utf8_lossy(&bad.stderr);
    assert!(
        !bad.status.success() && said.contains("--keep-clear-um is -1.000"),
        "{said}"
    );
    assert_eq!(std::fs::read_to_string(&summary).unwrap(), written);
    assert!(
        study("L", &["--force", "--keep-clear-um", "0"])
            .status
            .success()
    );
    assert!(!start().contains("keep_clear_um"), "{}", start());
}

/// A study whose every seed fails before its run reports (here a scene
/// whose 10 um particles the simulated rig's 120 x 100 um field cannot hold
/// 50 of: each seed's layout is refused) fails, naming the first seed and
/// its error, and keeps a summary of the seeds' errors; it does not print
/// an acceptance table of nothing as a success.
#[test]
fn a_study_where_no_run_reports_fails_with_the_first_seeds_error() {
    let dir = tempfile::tempdir().unwrap();
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let paper = std::fs::read_to_string(root.join("calib/paper-ps-ito.toml")).unwrap();
    let large = paper.replacen("radius_um = 5.0 ", "radius_um = 10.0 ", 1);
    assert_ne!(large, paper, "the paper scene's particle radius moved");
    let scene = dir.path().join("large-particles.toml");
    std::fs::write(&scene, large).unwrap();
    let out = dir.path().join("study");
    let run = nanopush()
        .current_dir(root)
        .args(["study", "assemble", "--text", "L", "--runs", "2", "--scene"])
        .arg(&scene)
        .arg("--out")
        .arg(&out)
        .output()
        .expect("run nanopush");
    let said = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success(), "{said}");
    assert!(
        said.contains("no run produced a report; seed 1: ")
            && said.contains("50 particles of radius 10.000 um at least 1.000 um apart cannot fit"),
        "{said}"
    );
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("study-assemble.json")).unwrap())
            .unwrap();
    let rows = summary["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 2);
    assert!(rows.iter().all(|r| r["figures"].is_null()), "{rows:?}");
}

/// `demo` and `study assemble` count a text's sites against the simulated
/// layout's particles before any work, and refuse in the planner's words
/// with both counts: the demo had simulated the paper push and placed the
/// pattern, the study had run every seed, before the run said so.
#[test]
fn a_text_with_more_sites_than_particles_is_refused_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    for (command, extra) in [
        ("demo", &[][..]),
        ("study", &["assemble", "--runs", "3"][..]),
    ] {
        let out = dir.path().join(command);
        let run = nanopush()
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .arg(command)
            .args(extra)
            .args(["--text", "NANOPUSH NANOPUSH", "--out"])
            .arg(&out)
            .output()
            .unwrap();
        let said = String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success(), "{command}: {said}");
        let sites = nanopush::plan::Pattern::from_text("NANOPUSH NANOPUSH", 1e-5)
            .unwrap()
            .offsets_m
            .len();
        assert!(
            said.contains(&format!(
                "{sites} sites but only 50 particles: cannot fill the pattern"
            )),
            "{command}: {said}"
        );
        assert!(
            !out.exists(),
            "{command} worked first: {}",
            String::from_utf8_lossy(&run.stdout)
        );
    }
}

/// Ctrl-C (here SIGINT to the study alone, as `kill -INT` sends it) is
/// answered at once and stops the seed in progress as a run stops, within
/// seconds: the seeds finished are kept and said (it had let the seed run
/// to its end). The stopped seed's journal reads back, ending in its stop.
#[test]
fn ctrl_c_stops_a_study_at_once_keeping_the_seeds_finished() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("study");
    let mut command = nanopush();
    command
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(["study", "assemble", "--text", "CMU", "--runs", "4", "--out"])
        .arg(&out);
    // Pressed once the first seed is done, the second under way.
    let pressed = interrupt_after(command, &["seed   1:"], Duration::from_millis(1500));
    let stderr = pressed.stopped_at_once("stopping the study (Ctrl-C or a termination signal) now");
    assert!(
        !pressed.after.iter().any(|l| l.starts_with("seed   2:")),
        "seed 2 was counted: {:?}",
        pressed.after
    );
    assert!(
        stderr.contains("study interrupted (Ctrl-C or a termination signal) after 1 of 4 seeds"),
        "{stderr}"
    );
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("study-assemble.json")).unwrap())
            .unwrap();
    assert_eq!(summary["rows"].as_array().unwrap().len(), 1);
    assert_eq!(summary["rows"][0]["seed"], 1);
    // Seed 2 stopped as a run stops, or (pressed in its first moments,
    // before it wrote anything) ended without a journal; never finished.
    match std::fs::read_to_string(out.join("seed-2/journal.jsonl")) {
        Ok(journal) => {
            let last: serde_json::Value =
                serde_json::from_str(journal.lines().last().unwrap()).unwrap();
            assert!(
                last.to_string().contains("interrupted"),
                "seed 2 ended on {last}"
            );
            assert!(
                stderr.contains("seed 2, stopped part way, is left in"),
                "{stderr}"
            );
        }
        Err(_) => assert!(
            stderr.contains("seed 2 was stopped before it wrote anything"),
            "{stderr}"
        ),
    }
}

/// `plan` without particles names both ways to give them (it named only
/// --layout, and a user with a microscope frame never heard of --frame).
#[test]
fn plan_without_particles_names_layout_and_frame() {
    let out = nanopush().args(["plan", "--text", "CMU"]).output().unwrap();
    let said = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && said.contains("--layout") && said.contains("--frame"),
        "{said}"
    );
}

/// A TOML file of one nanopush kind given where another is expected is
/// named by what it is: a scene given as a calibration (`--calib`, or a rig
/// file's `calibration`) had been refused for its "unknown field
/// `interfaces`", a calibration as a scene for `pixel_to_stage_um`, and a
/// rig file given as a recording was looked into as a folder.
#[test]
fn a_toml_file_of_another_kind_is_named_by_what_it_is() {
    let dir = tempfile::tempdir().unwrap();
    let rig = dir.path().join("rig.toml");
    let scene = std::fs::canonicalize("calib/paper-ps-ito.toml").unwrap();
    let text = std::fs::read_to_string("calib/rig-gcs-sim.toml")
        .unwrap()
        .replace(
            "\"camera-stage-sim.toml\"",
            &format!("{:?}", scene.display().to_string()),
        );
    std::fs::write(&rig, text).unwrap();
    let frame = "fixtures/recordings/real-brightfield/frames/bf_0000.png";
    let rig = rig.to_str().unwrap();
    let out = dir.path().join("out");
    let out = out.to_str().unwrap();
    for (args, says) in [
        (
            vec!["detect", frame, "--calib", "calib/paper-ps-ito.toml"],
            "calib/paper-ps-ito.toml: this is a scene file (nanopush.scene/1), not a calibration",
        ),
        (
            vec!["rig", "probe", "--dry-run", "--camera", "--rig", rig],
            "this is a scene file (nanopush.scene/1), not a calibration",
        ),
        (
            vec!["detect", frame, "--calib", "calib/rig-gcs-sim.toml"],
            "this is a rig file (nanopush.rig/1), not a calibration",
        ),
        (
            vec![
                "assemble",
                "--text",
                "L",
                "--scene",
                "calib/camera-stage-sim.toml",
                "--out",
                out,
            ],
            "this is a calibration (nanopush.calibration/1), not a scene",
        ),
        (
            vec![
                "dry-run",
                "--recording",
                "calib/rig-gcs-sim.toml",
                "--out",
                out,
            ],
            "recording calib/rig-gcs-sim.toml: this is a rig file (nanopush.rig/1), not a recording",
        ),
    ] {
        let run = nanopush().args(&args).output().unwrap();
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success(), "{args:?}: {stderr}");
        assert!(stderr.contains(says), "{args:?}: {stderr}");
        assert!(!stderr.contains("unknown field"), "{args:?}: {stderr}");
    }
}

/// A file given where a command writes a folder is refused before the
/// command works, in words (simulate had printed its whole summary, then
/// failed with "File exists (os error 17)"; dry-run and study plan's
/// --dump-dir said the same).
#[test]
fn a_file_given_as_an_output_folder_is_refused_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("keep.json");
    std::fs::write(&file, "kept").unwrap();
    let f = file.to_str().unwrap();
    let recording = "fixtures/recordings/real-brightfield";
    for args in [
        vec!["simulate", "--scene", "calib/paper-ps-ito.toml", "--out", f],
        vec!["dry-run", "--recording", recording, "--out", f],
        vec!["study", "plan", "--sizes", "30", "--dump-dir", f],
        vec![
            "study", "assemble", "--text", "I", "--runs", "1", "--out", f,
        ],
        vec!["demo", "--out", f],
    ] {
        let run = nanopush().args(&args).output().unwrap();
        let (stdout, stderr) = (
            String::from_utf8_lossy(&run.stdout),
            String::from_utf8_lossy(&run.stderr),
        );
        assert!(!run.status.success(), "{args:?}: {stderr}");
        let flag = args[args.len() - 2];
        assert!(
            stderr.contains(&format!("{flag} {f} is a file: give a folder")),
            "{args:?}: {stderr}"
        );
        assert!(stdout.trim().is_empty(), "{args:?} worked first: {stdout}");
    }
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "kept");
}

/// Ctrl-C as soon as `assemble` (the simulated rig) can take it: answered
/// at once, and the run not begun while the pattern is placed, --out left
/// unmade. A press there had ended the program without a word, or, where
/// the shell ignores SIGINT for a background job, gone unseen and let the
/// run finish. CMU on 50 particles places in a second or so; on a crowded
/// adversarial field each of the 26 centres is refused in about 0.7 s,
/// some 10 s in all, and the press had waited for every one.
#[test]
fn ctrl_c_while_assemble_places_the_pattern_starts_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let crowded = dir.path().join("crowded.json");
    let made = nanopush()
        .args(["synth", "layout", "--n", "70", "--field-um", "120x100"])
        .args(["--radius-um", "5", "--min-gap-um", "0.5"])
        .args(["--kind", "adversarial", "--seed", "1", "--out"])
        .arg(&crowded)
        .output()
        .unwrap();
    assert!(made.status.success(), "{made:?}");
    for world in [
        vec!["--seed", "2"],
        vec!["--layout", crowded.to_str().unwrap()],
    ] {
        let out = dir.path().join("run");
        let mut command = nanopush();
        command
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .args(["assemble", "--text", "CMU"])
            .args(&world)
            .arg("--out")
            .arg(&out);
        let pressed = interrupt_once_caught(command);
        let stderr = pressed.stopped_at_once("stopping (Ctrl-C or a termination signal) now");
        assert!(
            stderr.contains(
                "interrupted (Ctrl-C or a termination signal) while the pattern was placed"
            ),
            "{world:?}: {stderr}"
        );
        assert!(
            stderr.contains("nothing was started"),
            "{world:?}: {stderr}"
        );
        assert!(
            !out.exists(),
            "{world:?}: --out was made for a run that never began"
        );
    }
}
