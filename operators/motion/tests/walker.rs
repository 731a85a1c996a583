//! The parametric walker measured back: gait numbers, geometry, and normal-gait angle shapes.
#![allow(clippy::unwrap_used)] // tests may unwrap (STYLE.md §6); helpers outside #[test] fns need saying so

mod common;

use common::{measure, range, segment_lengths, stances};
use nalgebra::Vector3;
use trigait_motion::{Error, Joint, MotionClip, WalkerParams, walker};

const RATE: f64 = 200.0;

fn clip(params: &WalkerParams, secs: f64) -> MotionClip {
    walker(params, secs, RATE).unwrap()
}

/// Variants to run the geometric checks on (at least 3, so no check passes on an empty list).
fn examples() -> Vec<WalkerParams> {
    let v = vec![
        WalkerParams::default(),
        WalkerParams {
            cadence_steps_per_min: 120.0,
            step_length_m: 0.78,
            ..WalkerParams::for_height(1.85)
        },
        WalkerParams {
            cadence_steps_per_min: 90.0,
            step_length_m: 0.55,
            ..WalkerParams::for_height(1.60)
        },
    ];
    assert!(v.len() >= 3);
    v
}

/// Sagittal angles of the right leg in degrees: thigh from vertical (+ = flexion), knee
/// flexion, and ankle dorsiflexion (+) / plantarflexion (−) from the shank and the foot's pitch.
///
/// The foot's pitch is measured from the ankle → `Foot` vector against its direction with the
/// foot flat on the floor (which is the first frame's, a heel strike, rotated back by the pitch
/// the walker uses there).
fn right_leg_angles(clip: &MotionClip, p: &WalkerParams, f: usize) -> (f64, f64, f64) {
    let g = |j| clip.position(f, j).unwrap();
    let (h, k, a, foot) = (
        g(Joint::HipRight),
        g(Joint::KneeRight),
        g(Joint::AnkleRight),
        g(Joint::FootRight),
    );
    let thigh = k - h;
    let shank = a - k;
    let sagittal = |v: Vector3<f64>| v.z.atan2(v.x).to_degrees();
    let flat = sagittal(
        clip.position(0, Joint::FootRight).unwrap() - clip.position(0, Joint::AnkleRight).unwrap(),
    ) - p.heel_strike_pitch_deg;
    let pitch = sagittal(foot - a) - flat;
    let shank_lean = (-shank).x.atan2(-shank.z).to_degrees();
    (
        thigh.x.atan2(-thigh.z).to_degrees(),
        thigh.angle(&shank).to_degrees(),
        shank_lean + pitch,
    )
}

/// Step length, cadence and speed measured from the ankles and pelvis match the parameters.
#[test]
fn measured_gait_matches_parameters() {
    for p in examples() {
        let c = clip(&p, 6.0);
        let g = measure(&c, 0.15);
        assert!(g.steps >= 6, "{g:?}");
        let rel = |a: f64, b: f64| (a - b).abs() / b;
        assert!(
            rel(g.step_length_m, p.step_length_m) < 0.01,
            "{g:?} vs {p:?}"
        );
        assert!(
            rel(g.cadence_steps_per_min, p.cadence_steps_per_min) < 0.02,
            "{g:?}"
        );
        assert!(rel(g.speed_m_per_s, p.speed_m_per_s()) < 0.01, "{g:?}");
        assert!(
            (p.speed_m_per_s() - p.step_length_m * p.cadence_steps_per_min / 60.0).abs() < 1e-12
        );
    }
}

/// Thigh and shank keep their lengths exactly; ankles and feet never go below the floor.
#[test]
fn rigid_segments_and_floor() {
    for p in examples() {
        let c = clip(&p, 4.0);
        for (a, b, len) in [
            (Joint::HipLeft, Joint::KneeLeft, p.thigh_m),
            (Joint::KneeLeft, Joint::AnkleLeft, p.shank_m),
            (Joint::HipRight, Joint::KneeRight, p.thigh_m),
            (Joint::KneeRight, Joint::AnkleRight, p.shank_m),
        ] {
            let (lo, hi) = range(&segment_lengths(&c, a, b));
            assert!(
                (lo - len).abs() < 1e-9 && (hi - len).abs() < 1e-9,
                "{a}-{b} {lo}..{hi}"
            );
        }
        for j in [
            Joint::AnkleLeft,
            Joint::AnkleRight,
            Joint::FootLeft,
            Joint::FootRight,
        ] {
            for f in 0..c.frame_count() {
                let z = c.position(f, j).unwrap().z;
                assert!(z > 0.0, "{j} at z = {z} in frame {f}");
            }
        }
    }
}

/// The stance foot stays put: ankle still through foot-flat, and each stance covers little
/// ground while the pelvis moves on.
#[test]
fn stance_foot_is_planted() {
    let p = WalkerParams::default();
    let c = clip(&p, 4.0);
    for ankle in [Joint::AnkleLeft, Joint::AnkleRight] {
        // Exactly still (foot flat) for at least 20 % of the cycle each stride.
        let flat = stances(&c, ankle, 1e-6, (0.2 * p.cycle_secs() * RATE) as usize);
        assert!(flat.len() >= 3, "{ankle}: {} flat periods", flat.len());
        let rolling = stances(&c, ankle, 0.6, 10);
        for s in rolling
            .iter()
            .filter(|s| s.first > 0 && s.last + 1 < c.frame_count())
        {
            let xs: Vec<f64> = (s.first..=s.last)
                .map(|f| c.position(f, ankle).unwrap().x)
                .collect();
            let (lo, hi) = range(&xs);
            let pelvis = c.position(s.last, Joint::SpineBase).unwrap().x
                - c.position(s.first, Joint::SpineBase).unwrap().x;
            assert!(
                hi - lo < 0.15 && pelvis > 0.4,
                "{ankle}: ankle {:.3} m, pelvis {pelvis:.3} m",
                hi - lo
            );
        }
    }
}

/// Hip and knee curves have the shape of normal gait (Winter 2009, Perry & Burnfield 2010):
/// thigh +20…+40° flexion near heel strike and terminal swing, 5–20° extension in late stance;
/// knee ~15–20° loading bump, near-straight mid-stance, ~60° swing peak near 73 % of the cycle;
/// ankle plantarflexion in loading and at toe-off, dorsiflexion in late stance.
#[test]
fn joint_angles_look_like_normal_gait() {
    let p = WalkerParams::default();
    let c = clip(&p, 2.0 * p.cycle_secs());
    let per_cycle = (p.cycle_secs() * RATE).round() as usize;
    // Right leg over its second cycle (right heel strike at t = 0, T, 2T).
    let mut hip = Vec::new();
    let mut knee = Vec::new();
    let mut ankle = Vec::new();
    for f in per_cycle..2 * per_cycle {
        let (h, k, a) = right_leg_angles(&c, &p, f);
        hip.push(h);
        knee.push(k);
        ankle.push(a);
    }
    let at = |v: &[f64], phase: f64| v[(phase * per_cycle as f64) as usize];
    let window = |v: &[f64], a: f64, b: f64| {
        range(&v[(a * per_cycle as f64) as usize..(b * per_cycle as f64) as usize])
    };
    let (hip_min, hip_max) = range(&hip);
    assert!((25.0..40.0).contains(&hip_max), "hip max {hip_max:.1}");
    assert!((-20.0..-5.0).contains(&hip_min), "hip min {hip_min:.1}");
    assert!(
        (15.0..32.0).contains(&at(&hip, 0.0)),
        "hip at heel strike {:.1}",
        at(&hip, 0.0)
    );
    let (_, bump) = window(&knee, 0.05, 0.25);
    assert!((12.0..22.0).contains(&bump), "loading bump {bump:.1}");
    let (mid, _) = window(&knee, 0.3, 0.45);
    assert!(mid < 8.0 && mid < bump - 6.0, "mid-stance knee {mid:.1}");
    let (_, swing) = window(&knee, 0.6, 1.0);
    assert!((55.0..70.0).contains(&swing), "swing peak {swing:.1}");
    let peak_phase = knee
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.total_cmp(b.1))
        .map(|(i, _)| i as f64 / per_cycle as f64)
        .unwrap();
    assert!(
        (0.65..0.8).contains(&peak_phase),
        "swing peak at {peak_phase:.2}"
    );
    let to = at(&knee, p.stance_fraction);
    assert!((25.0..50.0).contains(&to), "knee at toe-off {to:.1}");

    // Ankle: ~neutral at heel strike, plantarflexes in loading, dorsiflexes as the shank rolls
    // over the foot, plantarflexes ~15° around toe-off, back near neutral in mid-swing.
    assert!(
        at(&ankle, 0.0).abs() < 5.0,
        "ankle at heel strike {:.1}",
        at(&ankle, 0.0)
    );
    let (loading, _) = window(&ankle, 0.0, 0.15);
    assert!(
        (-12.0..-3.0).contains(&loading),
        "loading plantarflexion {loading:.1}"
    );
    let (_, dorsi) = window(&ankle, 0.3, 0.55);
    assert!(
        (5.0..20.0).contains(&dorsi),
        "stance dorsiflexion {dorsi:.1}"
    );
    let (plantar, _) = window(&ankle, 0.55, 0.7);
    assert!(
        (-25.0..-8.0).contains(&plantar),
        "toe-off plantarflexion {plantar:.1}"
    );
    let (lo, hi) = window(&ankle, 0.75, 0.85);
    assert!(lo > -8.0 && hi < 10.0, "mid-swing ankle {lo:.1}..{hi:.1}");
}

/// The pelvis bobs 2–6 cm (twice a cycle, lowest in double support), sways toward the stance
/// foot by the set amount, and progresses along +X.
#[test]
fn pelvis_moves_like_walking() {
    let p = WalkerParams::default();
    let c = clip(&p, 2.0 * p.cycle_secs());
    let sb: Vec<_> = (0..c.frame_count())
        .map(|f| c.position(f, Joint::SpineBase).unwrap())
        .collect();
    let (zlo, zhi) = range(&sb.iter().map(|p| p.z).collect::<Vec<_>>());
    assert!(
        (0.02..0.06).contains(&(zhi - zlo)),
        "vertical excursion {:.3}",
        zhi - zlo
    );
    assert!((0.8..1.0).contains(&zhi), "pelvis height {zhi:.3}");
    let (ylo, yhi) = range(&sb.iter().map(|p| p.y).collect::<Vec<_>>());
    assert!((yhi - p.pelvis_sway_m).abs() < 1e-3 && (ylo + p.pelvis_sway_m).abs() < 1e-3);
    let per_cycle = (p.cycle_secs() * RATE).round() as usize;
    let z = |phase: f64| sb[(phase * per_cycle as f64) as usize].z;
    assert!(
        z(0.3) > z(0.02) + 0.015 && z(0.8) > z(0.52) + 0.015,
        "not highest at mid-stance"
    );
    // During right stance the pelvis is on the right (−Y).
    assert!(sb[per_cycle / 4].y < -0.01);
    let v = (sb.last().unwrap().x - sb[0].x) / c.duration_secs();
    assert!((v - p.speed_m_per_s()).abs() < 1e-9);
}

/// Left and right legs are the same motion half a cycle apart, mirrored across the walk line.
#[test]
fn legs_are_half_a_cycle_apart() {
    let p = WalkerParams::default();
    let c = clip(&p, 3.0);
    let half = p.cycle_secs() / 2.0;
    for (l, r) in [
        (Joint::HipLeft, Joint::HipRight),
        (Joint::KneeLeft, Joint::KneeRight),
        (Joint::AnkleLeft, Joint::AnkleRight),
        (Joint::FootLeft, Joint::FootRight),
    ] {
        for i in 0..100 {
            let t = i as f64 * 0.01;
            let right = c.position_at(r, t).unwrap();
            let left = c.position_at(l, t + half).unwrap();
            // position_at interpolates linearly between 5 ms frames; allow for that.
            let expected = Vector3::new(right.x + p.step_length_m, -right.y, right.z);
            assert!(
                (left.coords - expected).norm() < 2e-3,
                "{l} at {t}: {left} vs {expected}"
            );
        }
    }
}

/// With the flag, all 25 Kinect joints come out, gap-free and stacked head over pelvis.
#[test]
fn all_joints_flag() {
    let p = WalkerParams {
        all_joints: true,
        ..WalkerParams::default()
    };
    let c = walker(&p, 1.0, 30.0).unwrap();
    assert_eq!(c.joints(), Joint::ALL);
    for j in Joint::ALL {
        assert_eq!(c.missing_frames(j), 0, "{j}");
    }
    let f = 10;
    let z = |j| c.position(f, j).unwrap().z;
    assert!(z(Joint::Head) > z(Joint::Neck) && z(Joint::Neck) > z(Joint::SpineShoulder));
    assert!(
        z(Joint::SpineShoulder) > z(Joint::SpineMid) && z(Joint::SpineMid) > z(Joint::SpineBase)
    );
    assert!(
        (1.5..1.75).contains(&z(Joint::Head)),
        "head at {:.2}",
        z(Joint::Head)
    );
    assert!(
        c.position(f, Joint::ShoulderLeft).unwrap().y
            > c.position(f, Joint::ShoulderRight).unwrap().y
    );
    let legs_only = walker(&WalkerParams::default(), 1.0, 30.0).unwrap();
    assert_eq!(legs_only.joints().len(), 9);
    // The legs are the same with or without the upper body.
    assert_eq!(
        legs_only.position(f, Joint::KneeLeft),
        c.position(f, Joint::KneeLeft)
    );
}

/// Impossible parameters are typed errors, not panics or NaNs.
#[test]
fn bad_parameters_are_errors() {
    let too_long = WalkerParams {
        step_length_m: 5.0,
        ..WalkerParams::default()
    };
    assert!(matches!(
        walker(&too_long, 1.0, 30.0),
        Err(Error::BadParameter {
            name: "step_length_m",
            ..
        })
    ));
    let nan = WalkerParams {
        cadence_steps_per_min: f64::NAN,
        ..WalkerParams::default()
    };
    assert!(matches!(
        walker(&nan, 1.0, 30.0),
        Err(Error::BadParameter {
            name: "cadence_steps_per_min",
            ..
        })
    ));
    assert!(matches!(
        walker(&WalkerParams::default(), 1.0, 0.0),
        Err(Error::Clip(_))
    ));
    assert!(matches!(
        walker(&WalkerParams::default(), -1.0, 30.0),
        Err(Error::BadParameter {
            name: "duration_secs",
            ..
        })
    ));
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(48))]

    /// Over the range of healthy adult walking (1.5–1.95 m tall, 80–130 steps/min, steps of
    /// 0.3–0.42 × height), the walker always succeeds, keeps segments rigid, stays above the
    /// floor, bends the knee only forward within 0–90°, and moves at step length × cadence.
    #[test]
    fn walker_invariants(
        height in 1.5f64..1.95,
        cadence in 80f64..130.0,
        step_ratio in 0.30f64..0.42,
        stance in 0.55f64..0.65,
    ) {
        let p = WalkerParams {
            cadence_steps_per_min: cadence,
            step_length_m: step_ratio * height,
            stance_fraction: stance,
            ..WalkerParams::for_height(height)
        };
        let c = walker(&p, 2.5, 60.0).unwrap();
        for f in 0..c.frame_count() {
            for (hip, knee, ankle, foot) in [
                (Joint::HipLeft, Joint::KneeLeft, Joint::AnkleLeft, Joint::FootLeft),
                (Joint::HipRight, Joint::KneeRight, Joint::AnkleRight, Joint::FootRight),
            ] {
                let g = |j| c.position(f, j).unwrap();
                let (h, k, a) = (g(hip), g(knee), g(ankle));
                proptest::prop_assert!(((k - h).norm() - p.thigh_m).abs() < 1e-9);
                proptest::prop_assert!(((a - k).norm() - p.shank_m).abs() < 1e-9);
                proptest::prop_assert!(a.z > 0.0 && g(foot).z > 0.0);
                let flexion = (k - h).angle(&(a - k)).to_degrees();
                proptest::prop_assert!((0.0..90.0).contains(&flexion), "knee {flexion}");
                // The knee is in front of the hip–ankle line (it bends forward).
                let axis = (a - h).normalize();
                let off = (k - h) - axis * axis.dot(&(k - h));
                proptest::prop_assert!(off.x >= -1e-9);
            }
        }
        let first = c.position(0, Joint::SpineBase).unwrap();
        let last = c.position(c.frame_count() - 1, Joint::SpineBase).unwrap();
        let v = (last.x - first.x) / c.duration_secs();
        proptest::prop_assert!((v - p.step_length_m * cadence / 60.0).abs() < 1e-9);
    }
}
