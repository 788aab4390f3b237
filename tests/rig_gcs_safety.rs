//! Host-side safety: soft limits and step limits refuse a move before any
//! motion byte is sent, the dry run logs the exact bytes, the first real move
//! needs confirmation, and Ctrl-C halts.

use nanopush::rig::gcs::{
    self, FirstMoveConfirmation, GcsError, GcsStage, RigFile, SafetyViolation, SentLog,
};
use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

fn dry_stage(confirmation: FirstMoveConfirmation) -> (GcsStage, SentLog, Arc<AtomicBool>) {
    let rig = RigFile::load(Path::new("calib/rig-gcs-sim.toml")).unwrap();
    let (ctrl, log) = gcs::connect(&rig, true).unwrap();
    let interrupt = Arc::new(AtomicBool::new(false));
    let stage = GcsStage::new(
        ctrl,
        rig.stage_settings(),
        confirmation,
        Arc::clone(&interrupt),
    )
    .unwrap();
    (stage, log.unwrap(), interrupt)
}

#[test]
fn a_stage_with_a_repeated_axis_is_refused_before_any_move() {
    let rig = RigFile::load(Path::new("calib/rig-gcs-sim-xyz.toml")).unwrap();
    let (ctrl, log) = gcs::connect(&rig, true).unwrap();
    let mut settings = rig.stage_settings();
    settings.axes = vec!["1".into(), "1".into(), "3".into()];
    let interrupt = Arc::new(AtomicBool::new(false));
    let err = GcsStage::new(ctrl, settings, FirstMoveConfirmation::NotNeeded, interrupt)
        .err()
        .expect("a repeated axis was accepted");
    assert!(err.to_string().contains("axis 1 is named twice"), "{err}");
    assert!(motion_commands(&log.unwrap()).is_empty());
}

#[test]
fn open_stage_from_a_real_hardware_rig_in_dry_run_sends_nothing_real() {
    let mut rig = RigFile::load(Path::new("calib/rig-pi-e727-serial.toml")).unwrap();
    let interrupt = Arc::new(AtomicBool::new(false));
    let (mut stage, log) = gcs::open_stage(&rig, true, false, interrupt.clone()).unwrap();
    let log = log.expect("a dry run keeps a log");
    stage.enable_servo().unwrap();
    stage.move_to_m(&[52e-6, 50e-6, 7.5e-6]).unwrap();
    assert!(
        sent(&log).contains(&"MOV 1 52 2 50 3 7.5\n".to_string()),
        "{:?}",
        sent(&log)
    );
    // Without dry run the serial tty of the example does not exist here.
    rig.stage.address = "/nonexistent/ttyUSB0".into();
    assert!(matches!(
        gcs::open_stage(&rig, false, false, interrupt),
        Err(GcsError::Io { .. })
    ));
}

fn sent(log: &SentLog) -> Vec<String> {
    log.lock()
        .unwrap()
        .iter()
        .map(|b| String::from_utf8_lossy(b).into_owned())
        .collect()
}

fn motion_commands(log: &SentLog) -> Vec<String> {
    sent(log)
        .into_iter()
        .filter(|c| c.starts_with("MOV") || c.starts_with("VEL"))
        .collect()
}

#[test]
fn dry_run_logs_the_exact_bytes_of_a_move() {
    let (mut stage, log, _) = dry_stage(FirstMoveConfirmation::NotNeeded);
    stage.enable_servo().unwrap();
    stage.move_to_m(&[60e-6, 45.5e-6]).unwrap();
    let sent = sent(&log);
    assert_eq!(sent[0], "SAI?\n");
    assert!(sent.contains(&"SVO 1 1 2 1\n".to_string()), "{sent:?}");
    assert!(sent.contains(&"MOV 1 60 2 45.5\n".to_string()), "{sent:?}");
    assert_eq!(
        sent.iter().filter(|c| *c == "ERR?\n").count(),
        2,
        "ERR? after each setting command"
    );
    let pos = stage.position_m().unwrap();
    assert!((pos[0] - 60e-6).abs() < 1e-12 && (pos[1] - 45.5e-6).abs() < 1e-12);
}

#[test]
fn soft_limit_violation_sends_nothing_at_all() {
    let (mut stage, log, _) = dry_stage(FirstMoveConfirmation::NotNeeded);
    stage.enable_servo().unwrap();
    let before = sent(&log).len();
    let err = stage.start_move_m(&[99e-6, 50e-6]).unwrap_err();
    assert!(
        matches!(err, GcsError::Safety(SafetyViolation::OutsideSoftLimits { ref axis, .. }) if axis == "1"),
        "{err}"
    );
    assert_eq!(
        sent(&log).len(),
        before,
        "bytes were sent for a refused move"
    );
    let err = stage.start_move_m(&[f64::NAN, 50e-6]).unwrap_err();
    assert!(
        matches!(err, GcsError::Safety(SafetyViolation::BadTarget(_))),
        "{err}"
    );
    assert_eq!(sent(&log).len(), before);
}

#[test]
fn too_large_a_step_or_speed_sends_no_motion() {
    let (mut stage, log, _) = dry_stage(FirstMoveConfirmation::NotNeeded);
    stage.enable_servo().unwrap();
    // From (50, 50) um, 25 um is over the 20 um largest step.
    let err = stage.start_move_m(&[75e-6, 50e-6]).unwrap_err();
    assert!(
        matches!(err, GcsError::Safety(SafetyViolation::StepTooLarge { .. })),
        "{err}"
    );
    let err = stage.set_speed_m_per_s(250e-6).unwrap_err();
    assert!(
        matches!(
            err,
            GcsError::Safety(SafetyViolation::SpeedNotAllowed { .. })
        ),
        "{err}"
    );
    assert!(
        motion_commands(&log).is_empty(),
        "{:?}",
        motion_commands(&log)
    );
    stage.set_speed_m_per_s(150e-6).unwrap();
    assert_eq!(motion_commands(&log), vec!["VEL 1 150 2 150\n"]);
}

#[test]
fn first_move_needs_confirmation_once() {
    let asked = Arc::new(AtomicUsize::new(0));
    let counter = Arc::clone(&asked);
    let refusals = Arc::new(AtomicUsize::new(0));
    let refused = Arc::clone(&refusals);
    let refuse = FirstMoveConfirmation::Ask(Box::new(move |_: &str| {
        refused.fetch_add(1, Ordering::SeqCst);
        false
    }));
    let (mut stage, log, _) = dry_stage(refuse);
    // Servo on powers the axes: not before the operator said yes.
    let err = stage.enable_servo().unwrap_err();
    assert!(
        matches!(err, GcsError::Safety(SafetyViolation::NotConfirmed)),
        "{err}"
    );
    for _ in 0..2 {
        let err = stage.start_move_m(&[55e-6, 50e-6]).unwrap_err();
        assert!(
            matches!(err, GcsError::Safety(SafetyViolation::NotConfirmed)),
            "{err}"
        );
    }
    // Refused once, refused for good: a clean-up move does not ask again.
    assert_eq!(refusals.load(Ordering::SeqCst), 1);
    assert!(motion_commands(&log).is_empty());
    assert!(
        !sent(&log).iter().any(|c| c.starts_with("SVO")),
        "{:?}",
        sent(&log)
    );

    let accept = FirstMoveConfirmation::Ask(Box::new(move |text: &str| {
        assert!(text.contains("first move"), "{text}");
        counter.fetch_add(1, Ordering::SeqCst);
        true
    }));
    let (mut stage, log, _) = dry_stage(accept);
    stage
        .confirm_first_move(&[50e-6, 50e-6], &[55e-6, 50e-6])
        .unwrap();
    stage.enable_servo().unwrap();
    stage.move_to_m(&[55e-6, 50e-6]).unwrap();
    stage.move_to_m(&[60e-6, 50e-6]).unwrap();
    assert_eq!(asked.load(Ordering::SeqCst), 1);
    assert_eq!(motion_commands(&log).len(), 2);
}

/// The line stage (what every command moves with) asks before servo on and
/// VEL: a "no" leaves the controller with nothing but queries.
#[test]
fn a_refused_first_move_sends_no_servo_or_velocity() {
    use nanopush::rig::gcs_line_stage::GcsLineStage;
    let refuse = FirstMoveConfirmation::Ask(Box::new(|_: &str| false));
    let (stage, log, interrupt) = dry_stage(refuse);
    let mut line = GcsLineStage::new(stage, interrupt, &['x', 'y']).unwrap();
    let err = line.move_to_m(&[55e-6, 50e-6], 20e-6).unwrap_err();
    assert!(err.to_string().contains("not confirmed"), "{err}");
    let changing: Vec<String> = sent(&log)
        .into_iter()
        .filter(|c| !c.trim_end().ends_with('?') && !c.contains("? "))
        .collect();
    assert!(changing.is_empty(), "{changing:?}");
}

#[test]
fn interrupt_halts_and_refuses_further_moves() {
    let (mut stage, log, interrupt) = dry_stage(FirstMoveConfirmation::NotNeeded);
    stage.enable_servo().unwrap();
    interrupt.store(true, Ordering::SeqCst);
    let err = stage.start_move_m(&[55e-6, 50e-6]).unwrap_err();
    assert!(matches!(err, GcsError::Interrupted), "{err}");
    let sent = sent(&log);
    assert!(sent.contains(&"HLT\n".to_string()), "{sent:?}");
    assert!(motion_commands(&log).is_empty());
}

/// The loop speaks heights above the substrate; the rig file says where the
/// substrate is on the controller's z and which way lifts. On a stage whose
/// larger z brings the tip down (surface at z 14 um), a lift to 12 um is a
/// move to z 2, not 12 (the controller's z had been taken as the height:
/// "lift to the top of travel" drove such a tip into the sample).
#[test]
fn heights_go_through_the_rig_files_z_convention() {
    use nanopush::rig::hardware::GcsNanoStage;
    use nanopush::rig::stage::NanoStage;
    let text = std::fs::read_to_string("calib/rig-gcs-sim-xyz.toml")
        .unwrap()
        .replace(
            "real_hardware = false",
            "real_hardware = false\nz_surface_um = 14.0\nz_lifts = \"decreasing\"",
        );
    let rig = RigFile::from_toml(&text, Path::new("rig.toml")).unwrap();
    let (ctrl, log) = gcs::connect(&rig, true).unwrap();
    let interrupt = Arc::new(AtomicBool::new(false));
    let stage = GcsStage::new(
        ctrl,
        rig.stage_settings(),
        FirstMoveConfirmation::NotNeeded,
        Arc::clone(&interrupt),
    )
    .unwrap();
    let mut nano = GcsNanoStage::new(stage, interrupt, rig.z_convention()).unwrap();
    // Soft z 0..15 um is heights -1..14 um.
    let z = nano.range()[2];
    assert!(
        (z.min_m + 1e-6).abs() < 1e-12 && (z.max_m - 14e-6).abs() < 1e-12,
        "{z:?}"
    );
    let at = nano.position().unwrap();
    nano.move_to([at[0], at[1], 12e-6], 10e-6).unwrap();
    let moves = motion_commands(&log.unwrap());
    assert!(moves.last().unwrap().ends_with(" 3 2\n"), "{moves:?}");
    assert!((nano.position().unwrap()[2] - 12e-6).abs() < 1e-9);
}

/// A real nanostage with z names its convention, and only a stage with z does.
#[test]
fn a_real_nanostage_with_z_must_say_where_the_substrate_is() {
    let xyz = std::fs::read_to_string("calib/rig-gcs-sim-xyz.toml").unwrap();
    let real = xyz.replace("real_hardware = false", "real_hardware = true");
    let err = RigFile::from_toml(&real, Path::new("rig.toml")).unwrap_err();
    let said = format!("{err:?}");
    assert!(
        said.contains("z_surface_um") && said.contains("z_lifts"),
        "{said}"
    );
    let stated = real.replace(
        "real_hardware = true",
        "real_hardware = true\nz_surface_um = 0.0\nz_lifts = \"increasing\"",
    );
    assert!(RigFile::from_toml(&stated, Path::new("rig.toml")).is_ok());
    let xy = std::fs::read_to_string("calib/rig-gcs-sim.toml")
        .unwrap()
        .replace(
            "real_hardware = false",
            "real_hardware = false\nz_lifts = \"increasing\"",
        );
    assert!(RigFile::from_toml(&xy, Path::new("rig.toml")).is_err());
    // Nor a coarse stage (it has no z).
    let coarse = std::fs::read_to_string("calib/rig-gcs-sim-coarse-folder.toml").unwrap();
    let at = coarse.rfind("real_hardware = false").unwrap();
    let mut with_z = coarse.clone();
    with_z.insert_str(at, "z_lifts = \"increasing\"\n");
    let err = RigFile::from_toml(&with_z, Path::new("rig.toml")).unwrap_err();
    assert!(
        format!("{err:?}").contains("coarse.stage has no z"),
        "{err:?}"
    );
    // A calibration given as the rig file is named as one.
    let calibration = std::fs::read_to_string("calib/camera-stage-sim.toml").unwrap();
    let err = RigFile::from_toml(&calibration, Path::new("c.toml")).unwrap_err();
    assert!(
        err.to_string()
            .contains("this is a calibration (nanopush.calibration/1), not a rig file"),
        "{err}"
    );
}
