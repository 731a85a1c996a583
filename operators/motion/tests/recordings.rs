//! The two shared mocap recordings read, converted and turned into plausible joint centres.
//!
//! The CMU data was obtained from mocap.cs.cmu.edu; the database was created with funding from
//! NSF EIA-0196217. The Rajagopal TRC is from opensim-models (Apache-2.0).
#![allow(clippy::unwrap_used)] // tests may unwrap (STYLE.md §6); helpers outside #[test] fns need saying so

mod common;

use common::{measure, range, segment_lengths, stances, std_dev};
use trigait_motion::{
    Joint, MarkerSet, MotionClip, joint_centres, load_motion, read_c3d, read_trc,
};

const CMU: &str = "mocap-cmu-07_01/07_01.c3d";
const RAJAGOPAL: &str = "mocap-opensim-rajagopal-walk/Rajagopal__motion_capture_walk.trc";

/// Mean height of the pelvis markers over the trial.
fn pelvis_marker_height(set: &MarkerSet, labels: &[&str]) -> f64 {
    let z: Vec<f64> = labels
        .iter()
        .flat_map(|l| {
            let column = set.marker(l).unwrap();
            set.trajectory(column).into_iter().flatten().map(|p| p.z)
        })
        .collect();
    z.iter().sum::<f64>() / z.len() as f64
}

/// Checks shared by both recordings: heights in metres with the floor at 0, a walk along +X
/// over the README's span, and leg segments of constant length.
fn check_walk(clip: &MotionClip, x_start: f64, x_end: f64) {
    for j in [
        Joint::SpineBase,
        Joint::HipLeft,
        Joint::KneeLeft,
        Joint::AnkleLeft,
        Joint::HipRight,
        Joint::KneeRight,
        Joint::AnkleRight,
        Joint::FootLeft,
        Joint::FootRight,
    ] {
        assert_eq!(clip.missing_frames(j), 0, "{j} has gaps");
    }
    let n = clip.frame_count();
    // Hip centres at hip height, in metres (a unit error would give hundreds).
    let pelvis_z: Vec<f64> = (0..n)
        .map(|f| clip.position(f, Joint::SpineBase).unwrap().z)
        .collect();
    let (lo, hi) = range(&pelvis_z);
    assert!(lo > 0.75 && hi < 1.0, "SpineBase height {lo:.3}..{hi:.3} m");

    // Ankles in stance sit just above the floor.
    for ankle in [Joint::AnkleLeft, Joint::AnkleRight] {
        let still = stances(clip, ankle, 0.15, (0.08 * clip.rate_hz()) as usize);
        assert!(!still.is_empty(), "{ankle} never stands still");
        for s in &still {
            for f in s.first..=s.last {
                let z = clip.position(f, ankle).unwrap().z;
                assert!(
                    (0.03..0.2).contains(&z),
                    "{ankle} at {z:.3} m in stance frame {f}"
                );
            }
        }
    }

    // Walking along +X across the README's span (the README rounds; 0.5 m tolerance), straight.
    let first = clip.position(0, Joint::SpineBase).unwrap();
    let last = clip.position(n - 1, Joint::SpineBase).unwrap();
    assert!((first.x - x_start).abs() < 0.5, "start x {:.2}", first.x);
    assert!((last.x - x_end).abs() < 0.5, "end x {:.2}", last.x);
    assert!((last.y - first.y).abs() < 0.15, "drifts sideways");
    let step = (0.1 * clip.rate_hz()) as usize;
    for f in (step..n).step_by(step) {
        let a = clip.position(f - step, Joint::SpineBase).unwrap();
        let b = clip.position(f, Joint::SpineBase).unwrap();
        assert!(b.x > a.x, "pelvis moves backwards at frame {f}");
    }

    // Thigh and shank lengths stay constant up to skin-marker movement.
    for (a, b) in [
        (Joint::HipLeft, Joint::KneeLeft),
        (Joint::KneeLeft, Joint::AnkleLeft),
        (Joint::HipRight, Joint::KneeRight),
        (Joint::KneeRight, Joint::AnkleRight),
    ] {
        let lengths = segment_lengths(clip, a, b);
        let (lo, hi) = range(&lengths);
        let sd = std_dev(&lengths);
        eprintln!("{}: {a}–{b} {lo:.4}..{hi:.4} m, sd {sd:.4} m", clip.name());
        assert!(
            (0.35..0.48).contains(&lo) && hi < 0.48,
            "{a}–{b} length {lo:.3}..{hi:.3}"
        );
        assert!(sd < 0.01, "{a}–{b} length varies by sd {sd:.4} m");
        assert!(hi - lo < 0.03, "{a}–{b} length range {:.4} m", hi - lo);
    }
}

/// CMU 07_01: 316 frames at 120 Hz, 41 markers, no gaps, mm converted to m.
#[test]
fn cmu_c3d_reads_and_gives_joint_centres() {
    let Some(path) = trigait_test_data::shared_file(CMU) else {
        return;
    };
    let set = read_c3d(&path).unwrap();
    assert_eq!(set.frame_count(), 316);
    assert_eq!(set.rate_hz(), 120.0);
    assert_eq!(set.labels().len(), 41);
    assert!(set.gaps().is_empty(), "{:?}", set.gaps());
    assert!(set.marker("LHEE").is_some() && set.marker("liu:RTOE").is_some());
    let waist = pelvis_marker_height(&set, &["LFWT", "RFWT", "LBWT", "RBWT"]);
    assert!(
        (0.85..1.1).contains(&waist),
        "waist markers at {waist:.3} m"
    );

    let clip = joint_centres(&set).unwrap();
    assert_eq!(clip.frame_count(), 316);
    assert_eq!(clip.rate_hz(), 120.0);
    check_walk(&clip, -2.2, 2.15);

    let gait = measure(&clip, 0.15);
    eprintln!("CMU 07_01 measured: {gait:?}");
    assert!(gait.steps >= 3, "{gait:?}");
    assert!((0.5..0.9).contains(&gait.step_length_m), "{gait:?}");
    assert!(
        (80.0..140.0).contains(&gait.cadence_steps_per_min),
        "{gait:?}"
    );
    assert!((0.9..1.8).contains(&gait.speed_m_per_s), "{gait:?}");
    // Speed ≈ step length × cadence for steady walking.
    let implied = gait.step_length_m * gait.cadence_steps_per_min / 60.0;
    assert!((implied - gait.speed_m_per_s).abs() < 0.15, "{gait:?}");
}

/// Rajagopal: 238 frames at 100 Hz, Y-up mm converted to Z-up m; left markers at +Y.
#[test]
fn rajagopal_trc_reads_and_gives_joint_centres() {
    let Some(path) = trigait_test_data::shared_file(RAJAGOPAL) else {
        return;
    };
    let set = read_trc(&path).unwrap();
    assert_eq!(set.frame_count(), 238);
    assert_eq!(set.rate_hz(), 100.0);
    assert_eq!(set.labels().len(), 41);
    assert!(set.gaps().is_empty());
    let pelvis = pelvis_marker_height(&set, &["R.ASIS", "L.ASIS", "R.PSIS", "L.PSIS"]);
    assert!(
        (0.85..1.1).contains(&pelvis),
        "pelvis markers at {pelvis:.3} m"
    );
    // Frame change: the left ASIS is on the +Y side of the right one.
    let l = set.position(0, "L.ASIS").unwrap();
    let r = set.position(0, "R.ASIS").unwrap();
    assert!(
        l.y - r.y > 0.15,
        "left ASIS at y {:.3}, right at {:.3}",
        l.y,
        r.y
    );

    let clip = load_motion(&path).unwrap();
    assert_eq!(clip.frame_count(), 238);
    check_walk(&clip, -0.7, 2.2);
    let gait = measure(&clip, 0.15);
    eprintln!("Rajagopal measured: {gait:?}");
    assert!(
        gait.steps >= 2 && (0.5..0.9).contains(&gait.step_length_m),
        "{gait:?}"
    );
}

/// `load_motion` dispatches on the extension whatever its case.
#[test]
fn load_motion_dispatches_case_insensitively() {
    let Some(path) = trigait_test_data::shared_file(CMU) else {
        return;
    };
    let upper = common::temp_path("WALK.C3D");
    std::fs::copy(&path, &upper).unwrap();
    let clip = load_motion(&upper).unwrap();
    std::fs::remove_file(&upper).unwrap();
    assert_eq!(clip.frame_count(), 316);
    assert!(clip.has(Joint::FootLeft));
}
