//! The model's choice is real: the executor asks the pushing model for every
//! push and does what it says. Two scenes differing only in rolling
//! resistance run on the same layout; the journal's decisions must carry the
//! model's numbers for each scene (recomputed here through the executor's
//! decision function), and the stiffer scene must get longer pushes. A scene
//! in which the model finds no safe contact angle must get no push at all.

use nalgebra::Vector3;
use nanopush::exec::assemble::{AssemblySettings, PushIntent, decide_push};
use nanopush::exec::events::RunEvent;
use nanopush::exec::journal::read_journal;
use nanopush::model::Scene;
use std::path::Path;
use std::process::Command;

mod paper_scene;
use paper_scene::{RIDE_OVER, scene_file};

const RUN: [&str; 6] = ["--text", "L", "--seed", "6", "--particles", "20"];

/// One journalled decision.
#[derive(Debug, Clone)]
struct Decision {
    t_s: f64,
    particle: usize,
    from_um: [f64; 2],
    to_um: [f64; 2],
    angle_deg: f64,
    duration_s: f64,
    onset_s: f64,
    critical_force_un: f64,
    radius_um: f64,
}

/// Runs assemble on `scene` (the outcome does not matter here) and returns the journal's events.
fn run(scene: &Path, out: &Path) -> Vec<(f64, RunEvent)> {
    Command::new(env!("CARGO_BIN_EXE_nanopush"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(["assemble", "--json", "--scene", scene.to_str().unwrap()])
        .args(["--out", out.to_str().unwrap()])
        .args(RUN)
        .output()
        .unwrap();
    read_journal::<RunEvent>(&out.join("journal.jsonl"))
        .unwrap()
        .entries
        .into_iter()
        .map(|e| (e.t_s, e.event))
        .collect()
}

fn decisions(events: &[(f64, RunEvent)]) -> Vec<Decision> {
    let mut out = Vec::new();
    for (t_s, e) in events {
        if let RunEvent::Decision {
            particle,
            from_um,
            to_um,
            contact_angle_deg,
            duration_s,
            onset_s,
            critical_force_un,
            radius_um,
            ..
        } = e
        {
            out.push(Decision {
                t_s: *t_s,
                particle: *particle,
                from_um: *from_um,
                to_um: *to_um,
                angle_deg: *contact_angle_deg,
                duration_s: *duration_s,
                onset_s: *onset_s,
                critical_force_un: *critical_force_un,
                radius_um: radius_um.expect("the journal names the radius"),
            });
        }
    }
    out
}

/// The executor's decision function, fed what the journal says it saw.
fn model_says(scene: &Scene, d: &Decision) -> (f64, f64) {
    // The simulated world's particles are the scene's size: measured so.
    assert!(
        (d.radius_um - scene.particle_radius_m * 1e6).abs() < 0.02,
        "{d:?}"
    );
    let intent = PushIntent {
        particle: d.particle,
        from: [d.from_um[0] * 1e-6, d.from_um[1] * 1e-6],
        to: [d.to_um[0] * 1e-6, d.to_um[1] * 1e-6],
        // The loop decides with the batch's measured radius, as journalled.
        radius_m: d.radius_um * 1e-6,
    };
    let a = decide_push(scene, &intent, d.t_s).unwrap();
    (a.contact_angle_rad.to_degrees(), a.duration_s)
}

#[test]
fn higher_rolling_resistance_gets_longer_pushes_with_the_models_angle() {
    let dir = tempfile::tempdir().unwrap();
    let low = scene_file(dir.path(), "low.toml", &[]);
    let high = scene_file(
        dir.path(),
        "high.toml",
        &[("rolling_shear_pa_m = 98.5", "rolling_shear_pa_m = 300.0")],
    );
    let lo = decisions(&run(&low, &dir.path().join("lo")));
    let hi = decisions(&run(&high, &dir.path().join("hi")));
    assert!(
        lo.len() >= 3 && hi.len() >= 3,
        "{} and {} decisions",
        lo.len(),
        hi.len()
    );
    for (scene_path, ds) in [(&low, &lo), (&high, &hi)] {
        let scene = Scene::load(scene_path).unwrap();
        for d in ds.iter() {
            let (angle, duration) = model_says(&scene, d);
            assert_eq!(d.angle_deg, angle, "{d:?}");
            assert!(
                (d.duration_s - duration).abs() <= 1e-6 * duration,
                "journal {} s, model {duration} s",
                d.duration_s
            );
        }
    }
    // The first push is the same particle over the same distance in both runs
    // (same layout, same first plan); only the physics differs.
    let (a, b) = (&lo[0], &hi[0]);
    assert_eq!((a.particle, a.to_um), (b.particle, b.to_um));
    let start_gap_um = (a.from_um[0] - b.from_um[0]).hypot(a.from_um[1] - b.from_um[1]);
    assert!(start_gap_um < 0.05, "starts {start_gap_um} um apart");
    assert!(
        b.onset_s > a.onset_s,
        "onset {} vs {}",
        b.onset_s,
        a.onset_s
    );
    assert!(
        b.duration_s > a.duration_s,
        "duration {} vs {}",
        b.duration_s,
        a.duration_s
    );
    assert!(b.critical_force_un > a.critical_force_un);
    // Later pushes differ between the runs (their timing differs, so do the
    // frames and the re-plans): ask the stiffer scene about the same pushes.
    let high_scene = Scene::load(&high).unwrap();
    for d in lo.iter().take(3) {
        let (_, high_duration) = model_says(&high_scene, d);
        assert!(
            high_duration > d.duration_s,
            "push {d:?}: {high_duration} s with the stiffer scene"
        );
    }
}

#[test]
fn a_scene_without_a_safe_contact_angle_gets_no_push() {
    let dir = tempfile::tempdir().unwrap();
    // The tip may ride over, and rolling is so hard that it rides over at every angle.
    let unsafe_scene = scene_file(dir.path(), "ride-over.toml", &RIDE_OVER);
    let events = run(&unsafe_scene, &dir.path().join("o"));
    assert!(decisions(&events).is_empty());
    let refusals = events
        .iter()
        .filter(|(_, e)| {
            matches!(e, RunEvent::Check { result, .. } if result.contains("no safe contact angle"))
        })
        .count();
    assert!(refusals >= 1);
    let pushing_moves = events
        .iter()
        .filter(|(_, e)| matches!(e, RunEvent::Move { target_um, .. } if target_um[2] < 10.0))
        .count();
    assert_eq!(pushing_moves, 0, "the tip was lowered without a decision");
}

/// Each push crosses the gap to its particle at the travel speed but for
/// its last 0.25 um (`AssemblySettings::slow_approach_m`), then strokes on
/// at the scene's push speed for the model's duration: the move at the
/// push speed is the slow approach plus the duration's travel, the move
/// before it the rest of the gap at the travel speed.
#[test]
fn each_stroke_slows_to_the_push_speed_just_before_its_particle() {
    let dir = tempfile::tempdir().unwrap();
    let scene_path = Path::new(env!("CARGO_MANIFEST_DIR")).join("calib/paper-ps-ito.toml");
    let events = run(&scene_path, &dir.path().join("o"));
    let push_um_s = Scene::load(&scene_path).unwrap().push.speed_m_per_s * 1e6;
    let settings = AssemblySettings::default();
    let travel_um_s = settings.travel_speed_m_per_s * 1e6;
    let slow_um = settings.slow_approach_m * 1e6;
    let fast_um = (settings.clearance_m - settings.slow_approach_m) * 1e6;
    assert!(slow_um > 0.0 && fast_um > 0.0);
    let (mut duration_s, mut at, mut before) = (None, None::<[f64; 3]>, None::<(f64, f64)>);
    let mut strokes = 0;
    for (_, e) in &events {
        match e {
            RunEvent::Decision { duration_s: d, .. } => duration_s = Some(*d),
            RunEvent::Move {
                target_um,
                speed_um_s,
            } => {
                let len = at.map(|a| (Vector3::from(*target_um) - Vector3::from(a)).norm());
                if let (Some(len), Some(d)) = (len, duration_s)
                    && (speed_um_s - push_um_s).abs() < 1e-9
                {
                    // Within the few nm the drift estimate moves between moves.
                    assert!((len - (slow_um + d * push_um_s)).abs() < 0.005, "{len} um");
                    let (gap_len, gap_speed) = before.expect("a move before the stroke");
                    assert!((gap_len - fast_um).abs() < 0.005, "{gap_len} um");
                    assert!((gap_speed - travel_um_s).abs() < 1e-9);
                    strokes += 1;
                    duration_s = None;
                }
                before = len.map(|l| (l, *speed_um_s));
                at = Some(*target_um);
            }
            _ => {}
        }
    }
    assert!(strokes >= decisions(&events).len() / 2, "{strokes} strokes");
}
