//! Synthetic checks of what real recordings break: a treadmill, running, a tracker jump, a hop,
//! a missing foot joint. The walker of `common` knows its events and parameters exactly.
#![allow(clippy::unwrap_used)] // a test that cannot unwrap has failed

mod common;

use common::{TrueEvent, Walk};
use nalgebra::{Point3, Vector3};
use trigait_gait::{
    Error, EventKind, EventMethod, Foot, GaitAnalysis, GaitParams, HeelSource, Landmarks, analyse,
    analyse_landmarks,
};
use trigait_skeleton::{Joint, MotionClip};

/// `clip` with every sample moved by `f(frame, joint, p)`.
fn mapped(clip: &MotionClip, f: impl Fn(usize, Joint, Point3<f64>) -> Point3<f64>) -> MotionClip {
    let frames = (0..clip.frame_count())
        .map(|i| {
            clip.joints()
                .iter()
                .map(|j| clip.position(i, *j).map(|p| f(i, *j, p)))
                .collect()
        })
        .collect();
    MotionClip::new(clip.name(), clip.rate_hz(), clip.joints().to_vec(), frames).unwrap()
}

fn mean(stat: &trigait_gait::Stat) -> f64 {
    stat.mean.unwrap()
}

fn nearest_error(a: &GaitAnalysis, e: &TrueEvent) -> Option<f64> {
    let kind = if e.heel_strike {
        EventKind::HeelStrike
    } else {
        EventKind::ToeOff
    };
    a.events_of(e.foot, kind)
        .map(|d| d.time_secs - e.time_secs)
        .min_by(|x, y| x.abs().total_cmp(&y.abs()))
}

/// The walker on a treadmill (positions minus the belt's travel) gives the overground
/// parameters: treadmill detected, belt speed estimated, strides belt-corrected.
#[test]
fn treadmill_matches_overground() {
    let walk = Walk {
        duration_secs: 8.0,
        ..Walk::default()
    };
    let (over, _) = walk.build();
    let v = walk.speed_mps;
    let rate = walk.rate_hz;
    let belt = mapped(&over, |i, _, p| p - Vector3::x() * v * (i as f64 / rate));
    let a = analyse(&over, &GaitParams::default()).unwrap();
    let b = analyse(&belt, &GaitParams::default()).unwrap();
    assert!(a.treadmill.is_none());
    let t = b.treadmill.expect("treadmill detected");
    assert!(!t.declared && t.speed_estimated);
    println!(
        "belt {:.4} m/s (true {v}); stride {:.4} vs {:.4} m; cadence {:.3} vs {:.3}; width {:.4} vs {:.4}",
        t.belt_speed_mps,
        mean(&b.summary.stride_length_m),
        mean(&a.summary.stride_length_m),
        mean(&b.summary.cadence_steps_per_min),
        mean(&a.summary.cadence_steps_per_min),
        mean(&b.summary.step_width_m),
        mean(&a.summary.step_width_m),
    );
    assert!((t.belt_speed_mps - v).abs() < 0.02 * v);
    assert!(t.walking_direction[0] > 0.99);
    assert!((mean(&b.summary.stride_length_m) - mean(&a.summary.stride_length_m)).abs() < 0.02);
    assert!((mean(&b.summary.step_length_m) - mean(&a.summary.step_length_m)).abs() < 0.02);
    assert!((mean(&b.summary.speed_mps) - mean(&a.summary.speed_mps)).abs() < 0.02);
    let cadence = mean(&a.summary.cadence_steps_per_min);
    assert!((mean(&b.summary.cadence_steps_per_min) - cadence).abs() < 0.005 * cadence);
    assert!((mean(&b.summary.step_width_m) - mean(&a.summary.step_width_m)).abs() < 0.005);
    assert!(b.summary.strides + 1 >= a.summary.strides);
}

/// A walk out and back ends where it began, but it went somewhere: no treadmill. On a clock
/// running ten times fast (a stroll played as a 13 m/s dash, through the 6 Hz skeleton filter,
/// which then smooths the stance feet into the body's motion) it was taken for one on a 12 m/s
/// belt when the pelvis was judged by where it ended alone. Now the clip is never a treadmill,
/// and what comes out is an error or a flagged time base.
#[test]
fn out_and_back_is_no_treadmill_at_any_clock() {
    let walk = Walk {
        duration_secs: 10.0,
        ..Walk::default()
    };
    let (out, _) = walk.build();
    let pelvis = |i: usize| {
        let (l, r) = (
            out.position(i, Joint::HipLeft).unwrap(),
            out.position(i, Joint::HipRight).unwrap(),
        );
        nalgebra::center(&l, &r)
    };
    let middle = nalgebra::center(&pelvis(0), &pelvis(out.frame_count() - 1));
    // Back: the same walk turned 180° about the vertical through the middle of the path.
    let back = mapped(&out, |_, _, p| {
        Point3::new(2.0 * middle.x - p.x, 2.0 * middle.y - p.y, p.z)
    });
    let n = out.frame_count();
    let frames: Vec<Vec<Option<Point3<f64>>>> = (0..2 * n)
        .map(|i| {
            let (clip, k) = if i < n { (&out, i) } else { (&back, i - n) };
            clip.joints().iter().map(|j| clip.position(k, *j)).collect()
        })
        .collect();
    for scale in [1.0, 10.0] {
        let rate = walk.rate_hz * scale;
        let clip = MotionClip::new("lap", rate, out.joints().to_vec(), frames.clone()).unwrap();
        let params = GaitParams {
            filter: trigait_gait::filter::skeleton_filter(rate),
            ..GaitParams::default()
        };
        match analyse(&clip, &params) {
            Ok(a) => {
                assert!(a.treadmill.is_none(), "at {scale}x: {:?}", a.treadmill);
                assert_eq!(
                    a.timing.implausible,
                    scale > 1.0,
                    "at {scale}x: {:?}",
                    a.timing
                );
            }
            Err(e) => assert!(
                scale > 1.0 && matches!(e, Error::NoWalking { .. }),
                "at {scale}x: {e}"
            ),
        }
    }
}

/// A treadmill declared on an overground walk (with a slow belt: left to estimate it, the
/// swinging heels near the floor read as a belt and the walk may come out standing) is
/// corrected as declared, but the notes say the pelvis went somewhere, which it does not on a
/// treadmill.
#[test]
fn a_treadmill_declared_overground_is_questioned() {
    let walk = Walk {
        duration_secs: 6.0,
        ..Walk::default()
    };
    let (over, _) = walk.build();
    let params = GaitParams {
        treadmill: trigait_gait::TreadmillMode::Treadmill {
            belt_speed_mps: Some(0.1),
        },
        ..GaitParams::default()
    };
    let a = analyse(&over, &params).unwrap();
    let t = a.treadmill.expect("declared");
    assert!(t.declared && t.pelvis_travel_m > 2.5, "{t:?}");
    let notes = trigait_gait::report::quality_notes(&[], &a);
    assert!(
        notes
            .iter()
            .any(|n| n.contains("is this an overground walk?")),
        "{notes:?}"
    );
    let on_belt = analyse(&over, &GaitParams::default()).unwrap();
    assert!(
        !trigait_gait::report::quality_notes(&[], &on_belt)
            .iter()
            .any(|n| n.contains("overground walk?"))
    );
}

/// A running walker (35 % stance, flight phases): running is detected, the velocity method is
/// chosen, and its events are within 25 ms of the truth.
#[test]
fn running_chooses_velocity_method() {
    let run = Walk {
        speed_mps: 3.5,
        stride_time_secs: 0.7,
        stance_fraction: 0.35,
        step_width_m: 0.06,
        lift_m: 0.3,
        duration_secs: 4.0,
        ..Walk::default()
    };
    let (clip, truth) = run.build();
    let a = analyse(&clip, &GaitParams::default()).unwrap();
    assert!(a.running, "flight phases: {:?}", a.flights);
    assert!(!a.flights.is_empty());
    assert_eq!(a.method, EventMethod::Velocity);
    let mut worst: f64 = 0.0;
    let mut matched = 0;
    for e in &truth {
        if e.time_secs < 0.3 || e.time_secs > run.duration_secs - 0.3 {
            continue;
        }
        let err = nearest_error(&a, e).unwrap();
        worst = worst.max(err.abs());
        matched += 1;
    }
    println!(
        "running: {matched} events, worst |error| {:.1} ms",
        worst * 1e3
    );
    assert!(matched >= 16);
    assert!(worst < 0.025, "worst {worst}");
    let cadence = mean(&a.summary.cadence_steps_per_min);
    assert!(
        (cadence - run.cadence()).abs() < 0.01 * run.cadence(),
        "{cadence}"
    );
    // Walking has no flight and keeps the coordinate method.
    let walk = analyse(&Walk::default().build().0, &GaitParams::default()).unwrap();
    assert!(!walk.running && walk.flights.is_empty());
    assert_eq!(walk.method, EventMethod::Coordinate);
}

/// A one-frame 0.5 m jump of the whole skeleton (a tracker snapping to another body) at 30 Hz
/// changes cadence by less than 1 % and is counted as rejected, unfiltered and with the filter
/// `trigait gait` gives skeletons: the filter runs after the cleaning, so it never sees the jump
/// to smear it over the neighbouring frames.
#[test]
fn one_frame_jump_is_rejected() {
    let walk = Walk {
        rate_hz: 30.0,
        duration_secs: 8.0,
        noise_m: 0.005,
        ..Walk::default()
    };
    let (clip, _) = walk.build();
    let filtered = GaitParams {
        filter: trigait_gait::filter::SKELETON_FILTER,
        ..GaitParams::default()
    };
    let mut jumped_frames = 0;
    for params in [GaitParams::default(), filtered] {
        let clean = analyse(&clip, &params).unwrap();
        assert_eq!(clean.quality.rejected(), 0, "{:?}", clean.quality);
        for bad in [40usize, 95, 151, 200] {
            let jumped = mapped(&clip, |i, _, p| {
                if i == bad {
                    p + Vector3::new(0.3, 0.4, 0.0)
                } else {
                    p
                }
            });
            let a = analyse(&jumped, &params).unwrap();
            let c0 = mean(&clean.summary.cadence_steps_per_min);
            let c1 = mean(&a.summary.cadence_steps_per_min);
            println!(
                "filter {}, jump at frame {bad}: cadence {c1:.2} vs {c0:.2}, strides {} vs {}, \
                 rejected {}",
                params.filter,
                a.summary.strides,
                clean.summary.strides,
                a.quality.rejected()
            );
            assert!((c1 - c0).abs() < 0.01 * c0);
            assert_eq!(a.summary.strides, clean.summary.strides);
            assert!(a.quality.rejected() >= 5, "{:?}", a.quality);
            assert!(a.quality.bridged_samples >= a.quality.rejected());
            jumped_frames += 1;
        }
    }
    assert_eq!(jumped_frames, 8);
}

/// Two-footed forward hops with a 0.3 m flight: no strides (the feet do not alternate, said in
/// the error), and with that check off, still no event inside a flight phase.
#[test]
fn hops_give_no_strides_and_no_events_in_flight() {
    let rate = 100.0;
    let hop = 0.6; // s per hop: 0.3 s on the floor, 0.3 s in the air
    let n = 500;
    let mut pelvis = Vec::new();
    let mut heel = [Vec::new(), Vec::new()];
    let mut toe = [Vec::new(), Vec::new()];
    for i in 0..n {
        let t = i as f64 / rate;
        let k = (t / hop).floor();
        let phase = t / hop - k;
        // Feet planted for the first half, flying 0.6 m forward in the second.
        let (advance, lift) = if phase < 0.5 {
            (0.0, 0.0)
        } else {
            let s = (phase - 0.5) * 2.0;
            (
                (1.0 - (std::f64::consts::PI * s).cos()) / 2.0,
                (std::f64::consts::PI * s).sin(),
            )
        };
        let x = 0.6 * (k + advance);
        // The pelvis travels steadily, so the feet move back and forth relative to it, together.
        pelvis.push(Some(Point3::new(0.6 * t / hop, 0.0, 0.95 + 0.3 * lift)));
        for (s, y) in [(0, 0.1), (1, -0.1)] {
            heel[s].push(Some(Point3::new(x, y, 0.05 + 0.3 * lift)));
            toe[s].push(Some(Point3::new(x + 0.2, y, 0.03 + 0.3 * lift)));
        }
    }
    let l = Landmarks {
        rate_hz: rate,
        pelvis,
        heel,
        toe,
        heel_source: HeelSource::HeelMarker,
    };
    match analyse_landmarks(&l, &GaitParams::default()) {
        Err(Error::NoWalking {
            not_alternating_secs,
            ..
        }) => assert!(not_alternating_secs > 3.0, "{not_alternating_secs}"),
        other => panic!("expected no walking, got {other:?}"),
    }
    let params = GaitParams {
        max_alternation_correlation: 1.0,
        ..GaitParams::default()
    };
    if let Ok(a) = analyse_landmarks(&l, &params) {
        assert!(a.flights.len() >= 6, "{:?}", a.flights);
        for e in &a.events {
            for f in &a.flights {
                let inside =
                    e.frame > f.first_frame as f64 + 1.0 && e.frame < f.last_frame as f64 - 1.0;
                assert!(!inside, "{e:?} inside {f:?}");
            }
        }
        println!(
            "hops with the alternation check off: {} flights, {} events kept, {} dropped",
            a.flights.len(),
            a.events.len(),
            a.rejected_events
        );
    }
}

/// Losing the foot joints in a third of the frames (Kinect: often the foot) costs no stride:
/// toes are optional per frame.
#[test]
fn missing_foot_joint_keeps_strides() {
    let walk = Walk {
        rate_hz: 30.0,
        duration_secs: 6.0,
        ..Walk::default()
    };
    let (clip, _) = walk.build();
    let full = analyse(&clip, &GaitParams::default()).unwrap();
    let frames = (0..clip.frame_count())
        .map(|i| {
            clip.joints()
                .iter()
                .map(|j| {
                    let foot = matches!(j, Joint::FootLeft | Joint::FootRight);
                    if foot && (i / 5) % 3 == 0 {
                        None
                    } else {
                        clip.position(i, *j)
                    }
                })
                .collect()
        })
        .collect();
    let holey = MotionClip::new("holey", 30.0, clip.joints().to_vec(), frames).unwrap();
    let a = analyse(&holey, &GaitParams::default()).unwrap();
    println!(
        "foot joint missing in a third of frames: strides {} vs {}",
        a.summary.strides, full.summary.strides
    );
    assert!(a.summary.strides >= full.summary.strides);
    assert!(a.excluded.is_empty(), "{:?}", a.excluded);
}

/// A walk too short for a stride of either foot still gives cadence, step length and width
/// from its steps, and says so.
#[test]
fn steps_when_no_stride() {
    let walk = Walk {
        duration_secs: 1.2,
        first_left_hs_secs: 0.1,
        ..Walk::default()
    };
    let (clip, _) = walk.build();
    let mut params = GaitParams::default();
    params.segments.min_segment_secs = 0.5;
    let a = analyse(&clip, &params).unwrap();
    assert_eq!(a.summary.strides, 0);
    assert!(a.summary.steps >= 1);
    let c = &a.summary.cadence_steps_per_min;
    assert!(c.from_steps);
    assert!((c.mean.unwrap() - walk.cadence()).abs() < 0.02 * walk.cadence());
    let w = &a.summary.step_width_m;
    assert!(w.from_steps && (w.mean.unwrap() - walk.step_width_m).abs() < 0.01);
    let _ = Foot::Left;
}
