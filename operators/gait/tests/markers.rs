//! Acceptance on real motion capture: every heel strike that the heel *markers* show is found
//! from the joint centres alone (ankles, hips, toes), by both detectors.
//!
//! The reference is independent of the detectors: it reads only the heel markers' height
//! (`LHEE`/`RHEE` in the CMU file, `L.Heel`/`R.Heel` in the OpenSim one). A heel strike is the
//! first local minimum of heel height, after a swing peak, that lies within 3 cm of the floor
//! level (that heel's lower-quartile height). A descent already under way when the clip starts
//! counts too, so a landing shortly after the first frame is expected to be found; a swing the
//! clip cuts off before the heel comes down gives no reference event.
#![allow(clippy::unwrap_used)] // a test that cannot unwrap has failed

use trigait_gait::{EventKind, EventMethod, Foot, GaitAnalysis, GaitParams, analyse};
use trigait_motion::MarkerSet;

/// Heel strikes (s) from the heel marker's height minima.
fn heel_strikes_from_marker_height(set: &MarkerSet, label: &str) -> Vec<f64> {
    let column = set
        .marker(label)
        .unwrap_or_else(|| panic!("no marker {label}"));
    let z: Vec<f64> = set
        .trajectory(column)
        .iter()
        .map(|p| p.map_or(f64::NAN, |p| p.z))
        .collect();
    let mut sorted: Vec<f64> = z.iter().copied().filter(|v| v.is_finite()).collect();
    sorted.sort_by(f64::total_cmp);
    let floor = sorted[sorted.len() / 4];
    let high = |v: f64| v > floor + 0.10;
    // Swing peaks: local maxima 10 cm above the floor, or a first frame that high and falling.
    let mut peaks: Vec<usize> = Vec::new();
    if high(z[0]) && z[1] < z[0] {
        peaks.push(0);
    }
    for i in 1..z.len() - 1 {
        if z[i] > z[i - 1] && z[i] >= z[i + 1] && high(z[i]) {
            peaks.push(i);
        }
    }
    let mut out = Vec::new();
    for (k, &p) in peaks.iter().enumerate() {
        let end = peaks.get(k + 1).copied().unwrap_or(z.len() - 1);
        if let Some(i) =
            (p + 1..end).find(|&i| z[i] < z[i - 1] && z[i] <= z[i + 1] && z[i] < floor + 0.03)
        {
            out.push(i as f64 / set.rate_hz());
        }
    }
    out
}

fn analyse_file(relative: &str, method: EventMethod) -> Option<(MarkerSet, GaitAnalysis)> {
    let path = trigait_test_data::shared_file(relative)?;
    let set = trigait_motion::read_markers(&path).unwrap();
    let clip = trigait_motion::joint_centres(&set).unwrap();
    let mut params = GaitParams::default();
    params.events.method = method;
    let analysis = analyse(&clip, &params).unwrap();
    Some((set, analysis))
}

/// Matches detected heel strikes one-to-one with the marker reference. The joint-centre events
/// come 40–70 ms after the heel marker's lowest point (the ankle rolls on after contact), so the
/// window is 0.1 s: a tenth of a stride, far from the other foot's events half a stride away.
fn check_file(relative: &str, heels: [&str; 2], expected_per_foot: [usize; 2]) {
    for method in [EventMethod::Coordinate, EventMethod::Velocity] {
        let Some((set, analysis)) = analyse_file(relative, method) else {
            return;
        };
        for (foot, heel) in Foot::BOTH.into_iter().zip(heels) {
            let reference = heel_strikes_from_marker_height(&set, heel);
            assert_eq!(
                reference.len(),
                expected_per_foot[foot as usize],
                "{relative} {heel}: reference {reference:?}"
            );
            let found: Vec<f64> = analysis
                .events_of(foot, EventKind::HeelStrike)
                .map(|e| e.time_secs)
                .collect();
            assert_eq!(
                found.len(),
                reference.len(),
                "{relative} {method:?} {foot:?}: found {found:?}, markers say {reference:?}"
            );
            for (f, r) in found.iter().zip(&reference) {
                let lag = f - r;
                assert!(
                    (-0.03..=0.1).contains(&lag),
                    "{relative} {method:?} {foot:?}: {f:.3} s vs marker {r:.3} s"
                );
            }
        }
        let s = &analysis.summary;
        assert!(s.strides >= 2, "{relative}: {s:?}");
        // Normal adult walking (the subjects walk at 1.25–1.4 m/s).
        let cadence = s.cadence_steps_per_min.mean.unwrap();
        let stride = s.stride_length_m.mean.unwrap();
        let speed = s.speed_mps.mean.unwrap();
        assert!((95.0..125.0).contains(&cadence), "cadence {cadence}");
        assert!((1.2..1.7).contains(&stride), "stride {stride}");
        assert!((1.0..1.6).contains(&speed), "speed {speed}");
        assert!((speed - stride * cadence / 120.0).abs() < 0.02);
        let width = s.step_width_m.mean.unwrap();
        assert!((0.05..0.25).contains(&width), "step width {width}");
        // One straight segment: the subjects walk along +X (data README).
        assert_eq!(analysis.segments.len(), 1);
        assert!(analysis.segments[0].direction[0] > 0.99);
    }
}

/// CMU 07_01: two left and two right heel strikes in 2.6 s (the third left landing falls after
/// the last frame).
#[test]
fn cmu_07_01_heel_strikes() {
    check_file("mocap-cmu-07_01/07_01.c3d", ["LHEE", "RHEE"], [2, 2]);
}

/// OpenSim Rajagopal walk: two left and two right heel strikes in 2.4 s, the first right one
/// 0.26 s after the first frame.
#[test]
fn rajagopal_heel_strikes() {
    check_file(
        "mocap-opensim-rajagopal-walk/Rajagopal__motion_capture_walk.trc",
        ["L.Heel", "R.Heel"],
        [2, 2],
    );
}

/// Both detectors agree on the walk's parameters within a few per cent.
#[test]
fn detectors_agree_on_parameters() {
    for file in [
        "mocap-cmu-07_01/07_01.c3d",
        "mocap-opensim-rajagopal-walk/Rajagopal__motion_capture_walk.trc",
    ] {
        let Some((_, zeni)) = analyse_file(file, EventMethod::Coordinate) else {
            return;
        };
        let Some((_, velocity)) = analyse_file(file, EventMethod::Velocity) else {
            return;
        };
        let c = trigait_gait::compare(&zeni.summary, &velocity.summary);
        assert!(c.stride_length_m.unwrap().abs() < 0.02, "{file}: {c:?}");
        assert!(c.cadence_pct.unwrap().abs() < 2.0, "{file}: {c:?}");
        assert!(c.step_width_m.unwrap().abs() < 0.03, "{file}: {c:?}");
    }
}
