//! Scenario tests on a synthetic walker whose events and parameters are known exactly.
#![allow(clippy::unwrap_used)] // a test that cannot unwrap has failed

mod common;

use approx::assert_relative_eq;
use common::{Piece, TrueEvent, Walk};
use nalgebra::Point3;
use trigait_gait::filter::Filter;
use trigait_gait::{
    Error, EventKind, EventMethod, ExclusionReason, Foot, GaitAnalysis, GaitParams, Tolerances,
    analyse, compare,
};
use trigait_skeleton::{Joint, MotionClip};

fn params(method: EventMethod) -> GaitParams {
    let mut p = GaitParams::default();
    p.events.method = method;
    p
}

/// Every true heel strike (toe off) at least `margin` seconds from the clip ends is matched by
/// exactly one detected one within `tol` seconds, and nothing else is detected.
fn assert_events_match(
    analysis: &GaitAnalysis,
    truth: &[TrueEvent],
    duration: f64,
    margin: f64,
    tol: f64,
    heel_strike: bool,
) {
    let kind = if heel_strike {
        EventKind::HeelStrike
    } else {
        EventKind::ToeOff
    };
    for foot in Foot::BOTH {
        let found: Vec<f64> = analysis
            .events_of(foot, kind)
            .map(|e| e.time_secs)
            .collect();
        let expected: Vec<f64> = truth
            .iter()
            .filter(|e| e.foot == foot && e.heel_strike == heel_strike)
            .map(|e| e.time_secs)
            .collect();
        for t in expected
            .iter()
            .filter(|t| **t > margin && **t < duration - margin)
        {
            let hits = found.iter().filter(|f| (*f - t).abs() <= tol).count();
            assert_eq!(hits, 1, "{foot:?} {kind:?} at {t:.3} s: found {found:?}");
        }
        for f in &found {
            assert!(
                expected.iter().any(|t| (f - t).abs() <= tol),
                "spurious {foot:?} {kind:?} at {f:.3} s; truth {expected:?}"
            );
        }
    }
}

/// Both detectors find every heel strike and toe off of a straight walk, and the parameters are
/// the walker's: stride length, cadence, speed, step length and width, stance and double support.
#[test]
fn straight_walk_parameters() {
    let walk = Walk::default();
    let (clip, truth) = walk.build();
    for method in [EventMethod::Coordinate, EventMethod::Velocity] {
        let a = analyse(&clip, &params(method)).unwrap();
        assert_eq!(a.segments.len(), 1, "{method:?}: {:?}", a.excluded);
        assert_events_match(&a, &truth, walk.duration_secs, 0.05, 0.04, true);
        assert_events_match(&a, &truth, walk.duration_secs, 0.05, 0.04, false);
        let s = &a.summary;
        assert!(
            s.left_strides >= 3 && s.right_strides >= 3,
            "{method:?} {s:?}"
        );
        assert_relative_eq!(
            s.stride_length_m.mean.unwrap(),
            walk.stride_length_m(),
            epsilon = 0.01
        );
        assert_relative_eq!(
            s.cadence_steps_per_min.mean.unwrap(),
            walk.cadence(),
            max_relative = 0.01
        );
        assert_relative_eq!(s.speed_mps.mean.unwrap(), walk.speed_mps, epsilon = 0.02);
        assert_relative_eq!(
            s.step_length_m.mean.unwrap(),
            walk.stride_length_m() / 2.0,
            epsilon = 0.01
        );
        assert_relative_eq!(
            s.step_width_m.mean.unwrap(),
            walk.step_width_m,
            epsilon = 0.01
        );
        assert_relative_eq!(
            s.stance_pct.mean.unwrap(),
            walk.stance_fraction * 100.0,
            epsilon = 6.0
        );
        let ds = 2.0 * (walk.stance_fraction - 0.5) * 100.0;
        assert_relative_eq!(s.double_support_pct.mean.unwrap(), ds, epsilon = 8.0);
        assert!(s.stride_length_m.asymmetry_pct.unwrap() < 1.0);
        // The walking direction was estimated: +X here.
        let d = a.segments[0].direction;
        assert_relative_eq!(d[0], 1.0, epsilon = 1e-3);
    }
}

/// The same walk in any direction gives the same parameters: nothing assumes +X.
#[test]
fn direction_is_estimated() {
    let reference = analyse(&Walk::default().build().0, &GaitParams::default()).unwrap();
    for heading in [2.3, -1.2, std::f64::consts::PI] {
        let walk = Walk {
            heading_rad: heading,
            ..Walk::default()
        };
        let a = analyse(&walk.build().0, &GaitParams::default()).unwrap();
        let d = a.segments[0].direction;
        assert_relative_eq!(d[0], heading.cos(), epsilon = 1e-3);
        assert_relative_eq!(d[1], heading.sin(), epsilon = 1e-3);
        let c = compare(&reference.summary, &a.summary);
        assert!(
            c.within(&Tolerances {
                stride_length_m: 0.002,
                cadence_pct: 0.1,
                step_width_m: 0.002
            }),
            "{c:?}"
        );
    }
}

/// A walk with a U-turn: the turn is excluded and reported, both straight legs give strides,
/// with opposite walking directions.
#[test]
fn turn_is_excluded_and_reported() {
    let walk = Walk {
        duration_secs: 12.0,
        path: vec![
            Piece::Straight(5.0),
            Piece::Arc(0.8, std::f64::consts::PI),
            Piece::Straight(20.0),
        ],
        ..Walk::default()
    };
    let (clip, _) = walk.build();
    let a = analyse(&clip, &GaitParams::default()).unwrap();
    assert_eq!(a.segments.len(), 2, "{:?}", a.excluded);
    let turning: f64 = a
        .excluded
        .iter()
        .filter(|p| p.reason == ExclusionReason::Turning)
        .map(|p| p.end_secs - p.start_secs)
        .sum();
    // The arc takes 0.8·π / 1.3 ≈ 1.9 s.
    assert!(turning > 1.0, "{:?}", a.excluded);
    let (d0, d1) = (a.segments[0].direction, a.segments[1].direction);
    assert!(d0[0] * d1[0] + d0[1] * d1[1] < -0.99);
    for segment in 0..2 {
        assert!(a.strides.iter().filter(|s| s.segment == segment).count() >= 2);
    }
    assert_relative_eq!(
        a.summary.stride_length_m.mean.unwrap(),
        walk.stride_length_m(),
        epsilon = 0.02
    );
    // No stride spans the turn.
    for s in &a.strides {
        let seg = &a.segments[s.segment];
        assert!(s.start_secs >= seg.start_secs && s.end_secs <= seg.end_secs);
    }
}

/// Six leg joints only (no feet): the ankles stand in for heels and toes and the parameters hold.
#[test]
fn legs_only() {
    let walk = Walk {
        with_feet: false,
        ..Walk::default()
    };
    let (clip, truth) = walk.build();
    assert_eq!(clip.joints(), &Joint::LEGS);
    let a = analyse(&clip, &GaitParams::default()).unwrap();
    assert_events_match(&a, &truth, walk.duration_secs, 0.05, 0.04, true);
    assert_relative_eq!(
        a.summary.stride_length_m.mean.unwrap(),
        walk.stride_length_m(),
        epsilon = 0.01
    );
}

/// With 1 cm position noise at 30 Hz (a Kinect), a 6 Hz Butterworth or the One-Euro filter
/// keeps the parameters within the issue's tolerances of the clean walk.
#[test]
fn noisy_kinect_rate_walk_with_filters() {
    let clean = Walk {
        rate_hz: 30.0,
        ..Walk::default()
    };
    let reference = analyse(&clean.build().0, &GaitParams::default()).unwrap();
    let noisy = Walk {
        noise_m: 0.01,
        ..clean.clone()
    };
    let (clip, _) = noisy.build();
    for filter in [
        Filter::Butterworth { cutoff_hz: 6.0 },
        "one-euro".parse().unwrap(),
    ] {
        let filtered = filter.apply(&clip).unwrap();
        for method in [EventMethod::Coordinate, EventMethod::Velocity] {
            let a = analyse(&filtered, &params(method)).unwrap();
            let c = compare(&reference.summary, &a.summary);
            assert!(c.within(&Tolerances::ISSUE_5), "{filter} {method:?}: {c:?}");
        }
    }
}

/// A standing subject is a clear error, not a panic and not made-up strides.
#[test]
fn standing_subject_is_an_error() {
    let clip = MotionClip::from_fn("standing", 30.0, 5.0, Joint::LEGS.to_vec(), |j, t| {
        let sway = 0.005 * (3.0 * t).sin();
        let (y, z) = match j {
            Joint::HipLeft => (0.09, 0.92),
            Joint::HipRight => (-0.09, 0.92),
            Joint::KneeLeft => (0.09, 0.5),
            Joint::KneeRight => (-0.09, 0.5),
            Joint::AnkleLeft => (0.09, 0.08),
            _ => (-0.09, 0.08),
        };
        Some(Point3::new(sway, y, z))
    })
    .unwrap();
    let err = analyse(&clip, &GaitParams::default()).unwrap_err();
    let Error::NoWalking { standing_secs, .. } = err else {
        panic!("expected NoWalking, got {err:?}");
    };
    assert!(standing_secs > 4.9);
    assert!(
        err_text(&clip).contains("standing 5.0"),
        "{}",
        err_text(&clip)
    );
}

fn err_text(clip: &MotionClip) -> String {
    analyse(clip, &GaitParams::default())
        .unwrap_err()
        .to_string()
}

/// A walk too short for two strides names what it found.
#[test]
fn too_few_strides() {
    let walk = Walk {
        duration_secs: 1.5,
        ..Walk::default()
    };
    let params = GaitParams {
        min_strides: 2,
        ..GaitParams::default()
    };
    let err = analyse(&walk.build().0, &params).unwrap_err();
    assert!(
        matches!(err, Error::TooFewStrides { got, need: 2, .. } if got < 2),
        "{err:?}"
    );
    assert!(err.to_string().contains("complete strides"));
}

/// Gaps and NaN become excluded gap phases; the rest is still analysed. All-NaN is NoWalking.
/// A NaN run of 0.06 s is short enough to be bridged (counted), the 0.31 s ankle gap is not.
#[test]
fn gaps_and_nan() {
    let walk = Walk {
        duration_secs: 8.0,
        ..Walk::default()
    };
    let (clip, _) = walk.build();
    let joints = clip.joints().to_vec();
    let frames: Vec<Vec<Option<Point3<f64>>>> = (0..clip.frame_count())
        .map(|f| {
            joints
                .iter()
                .map(|j| {
                    let p = clip.position(f, *j);
                    match (f, j) {
                        (300..=330, Joint::AnkleLeft) => None,
                        (500..=505, _) => Some(Point3::new(f64::NAN, 0.0, 0.0)),
                        _ => p,
                    }
                })
                .collect()
        })
        .collect();
    let gappy = MotionClip::new("gappy", clip.rate_hz(), joints.clone(), frames).unwrap();
    let a = analyse(&gappy, &GaitParams::default()).unwrap();
    let gaps: Vec<_> = a
        .excluded
        .iter()
        .filter(|p| p.reason == ExclusionReason::Gap)
        .collect();
    assert_eq!(gaps.len(), 1, "{:?}", a.excluded);
    assert_eq!(gaps[0].frames, 31);
    assert!(a.quality.bridged_samples >= 6 * 5, "{:?}", a.quality);
    assert!(a.segments.len() >= 2);
    assert_relative_eq!(
        a.summary.stride_length_m.mean.unwrap(),
        walk.stride_length_m(),
        epsilon = 0.01
    );
    let nan = MotionClip::new(
        "nan",
        100.0,
        joints.clone(),
        vec![vec![Some(Point3::new(f64::NAN, 0.0, 0.0)); joints.len()]; 200],
    )
    .unwrap();
    assert!(matches!(
        analyse(&nan, &GaitParams::default()),
        Err(Error::NoWalking { gap_secs, .. }) if gap_secs > 1.9
    ));
}

/// Without ankles there is nothing to analyse: a typed error naming the joint.
#[test]
fn missing_joints() {
    let (clip, _) = Walk::default().build();
    let hips = clip.select(&[Joint::HipLeft, Joint::HipRight]);
    let err = analyse(&hips, &GaitParams::default()).unwrap_err();
    assert!(
        matches!(
            err,
            Error::MissingJoint {
                joint: Joint::AnkleLeft,
                ..
            }
        ),
        "{err:?}"
    );
    assert!(err.to_string().contains("ankle_left"));
    let single = MotionClip::new(
        "one",
        100.0,
        Joint::LEGS.to_vec(),
        vec![vec![Some(Point3::origin()); 6]],
    )
    .unwrap();
    assert!(analyse(&single, &GaitParams::default()).is_err());
}

/// `compare` reports signed differences, and `within` enforces each tolerance.
#[test]
fn comparison() {
    let base = Walk::default();
    let longer = Walk {
        speed_mps: base.speed_mps * 1.03,
        ..base.clone()
    };
    let r = analyse(&base.build().0, &GaitParams::default()).unwrap();
    let e = analyse(&longer.build().0, &GaitParams::default()).unwrap();
    let same = compare(&r.summary, &r.summary);
    assert_eq!(same.stride_length_m, Some(0.0));
    assert!(same.within(&Tolerances::ISSUE_5));
    let c = compare(&r.summary, &e.summary);
    // 3 % faster at the same cadence: strides 4.3 cm longer.
    assert_relative_eq!(
        c.stride_length_m.unwrap(),
        0.03 * base.stride_length_m(),
        epsilon = 0.005
    );
    assert!(c.cadence_pct.unwrap().abs() < 0.5);
    assert!(!c.within(&Tolerances::ISSUE_5));
}

/// `clip` with every joint missing in `frames` (a tracker dropout).
fn with_dropout(clip: &MotionClip, frames: std::ops::Range<usize>) -> MotionClip {
    let joints = clip.joints().to_vec();
    let positions: Vec<Vec<Option<Point3<f64>>>> = (0..clip.frame_count())
        .map(|f| {
            joints
                .iter()
                .map(|j| {
                    (!frames.contains(&f))
                        .then(|| clip.position(f, *j))
                        .flatten()
                })
                .collect()
        })
        .collect();
    MotionClip::new("dropout", clip.rate_hz(), joints, positions).unwrap()
}

/// A 0.1 s tracker dropout (3 frames at 30 Hz) in mid-walk is bridged by interpolation
/// (counted in the data quality): the strides around it survive with the same parameters; with
/// bridging off (cleaning and segmentation) it splits the segment and costs strides.
#[test]
fn short_dropout_is_bridged() {
    let walk = Walk {
        rate_hz: 30.0,
        duration_secs: 5.0,
        ..Walk::default()
    };
    let (clip, _) = walk.build();
    let reference = analyse(&clip, &GaitParams::default()).unwrap();
    let dropout = with_dropout(&clip, 75..78);
    let a = analyse(&dropout, &GaitParams::default()).unwrap();
    assert_eq!(a.segments.len(), 1, "{:?}", a.excluded);
    assert!(a.excluded.is_empty(), "{:?}", a.excluded);
    assert_eq!(a.quality.missing_samples, 3 * 5, "{:?}", a.quality);
    assert_eq!(a.quality.bridged_samples, 3 * 5, "{:?}", a.quality);
    assert!(
        a.summary.strides + 1 >= reference.summary.strides,
        "{:?}",
        a.summary
    );
    let c = compare(&reference.summary, &a.summary);
    assert!(c.within(&Tolerances::ISSUE_5), "{c:?}");

    let mut strict = GaitParams::default();
    strict.segments.max_bridged_gap_secs = 0.0;
    strict.clean.max_bridged_gap_secs = 0.0;
    let split = analyse(&dropout, &strict).unwrap();
    assert_eq!(split.segments.len(), 2);
    assert!(split.summary.strides < a.summary.strides);
}

/// A dropout right at a sharp reversal (the simulated walker turns on the spot at the end of
/// the walkway) is not bridged: the headings on its two sides disagree, so the two legs stay
/// two segments with opposite directions and no stride spans the turn.
#[test]
fn dropout_at_a_reversal_is_not_bridged() {
    let walk = Walk {
        rate_hz: 30.0,
        duration_secs: 8.0,
        path: vec![
            Piece::Straight(4.0),
            Piece::Arc(0.05, std::f64::consts::PI),
            Piece::Straight(20.0),
        ],
        ..Walk::default()
    };
    let (clip, _) = walk.build();
    // The arc starts after 4 m at 1.3 m/s ≈ 3.08 s ≈ frame 92 and lasts ≈ 0.12 s.
    let turn = (4.0 / walk.speed_mps * 30.0) as usize;
    let dropped = with_dropout(&clip, turn..turn + 3);
    let a = analyse(&dropped, &GaitParams::default()).unwrap();
    assert_eq!(a.segments.len(), 2, "{:?}", a.excluded);
    let (d0, d1) = (a.segments[0].direction, a.segments[1].direction);
    assert!(d0[0] * d1[0] + d0[1] * d1[1] < -0.9, "{d0:?} {d1:?}");
    for s in &a.strides {
        let seg = &a.segments[s.segment];
        assert!(s.start_secs >= seg.start_secs && s.end_secs <= seg.end_secs);
    }
}
