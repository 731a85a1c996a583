//! `filter` contracts: configuration errors name node, key and value; a pose keeps everything
//! but its positions, a NaN joint moves to `skipped`; malformed inputs are counted, never fatal.

use std::collections::BTreeMap;

use dora_node_api::integration_testing::{TestingOptions, drain_outputs};
use dora_node_api::serde_json;
use nalgebra::{Matrix3, Point3};
use trigait_gait::filter::OneEuroParams;
use trigait_gait::stream::{LowPassParams, PoseFilter, StreamFilter};
use trigait_node_testing::{chain, init_node, input_event, lookup, output_arrays, scratch_dir};
use trigait_schema::{FusedJoint, FusedPose, Message};
use trigait_skeleton::Joint;

use crate::config::Config;
use crate::{NON_FINITE_REASON, filter_pose};

/// Defaults: One-Euro with the paper-style defaults and a 0.2 s gap; `lowpass` and `none`
/// select the others with their own keys.
#[test]
fn config_defaults_and_kinds() {
    let c = Config::from_lookup(lookup(&[])).unwrap();
    assert_eq!(
        c.params.filter,
        StreamFilter::OneEuro(OneEuroParams::default())
    );
    assert!((c.params.max_gap_secs - 0.2).abs() < 1e-12);
    let c = Config::from_lookup(lookup(&[
        ("FILTER", "lowpass"),
        ("LOWPASS_CUTOFF_HZ", "4"),
        ("LOWPASS_ORDER", "4"),
    ]))
    .unwrap();
    assert_eq!(
        c.params.filter,
        StreamFilter::LowPass(LowPassParams {
            cutoff_hz: 4.0,
            order: 4
        })
    );
    let c =
        Config::from_lookup(lookup(&[("FILTER", "one-euro"), ("ONE_EURO_BETA", "0.5")])).unwrap();
    let StreamFilter::OneEuro(p) = c.params.filter else {
        panic!("not one-euro");
    };
    assert!((p.beta - 0.5).abs() < 1e-12);
    assert_eq!(
        Config::from_lookup(lookup(&[("FILTER", "none")]))
            .unwrap()
            .params
            .filter,
        StreamFilter::None
    );
}

/// Unknown filter, bad numbers: errors start with the node and name key and value.
#[test]
fn config_errors_name_node_key_and_value() {
    let text = chain(&Config::from_lookup(lookup(&[("FILTER", "kalman")])).unwrap_err());
    assert!(text.starts_with("filter: FILTER=\"kalman\""), "{text}");
    assert!(text.contains("one-euro, lowpass or none"), "{text}");
    for (kind, key, raw) in [
        ("one-euro", "ONE_EURO_MIN_CUTOFF_HZ", "0"),
        ("one-euro", "ONE_EURO_BETA", "-1"),
        ("one-euro", "ONE_EURO_DERIVATIVE_CUTOFF_HZ", "fast"),
        ("lowpass", "LOWPASS_CUTOFF_HZ", "NaN"),
        ("lowpass", "LOWPASS_ORDER", "2.5"),
        ("lowpass", "LOWPASS_ORDER", "9"),
        ("none", "MAX_GAP_SECS", "-0.1"),
    ] {
        let text =
            chain(&Config::from_lookup(lookup(&[("FILTER", kind), (key, raw)])).unwrap_err());
        assert!(
            text.starts_with(&format!("filter: {key}={raw:?}")),
            "{text}"
        );
    }
}

fn pose(seq: u64, x: f64) -> FusedPose {
    let mut joints = BTreeMap::new();
    for (joint, dx) in [(Joint::KneeLeft, 0.0), (Joint::AnkleLeft, 0.1)] {
        joints.insert(
            joint,
            FusedJoint {
                position: Point3::new(x + dx, 0.2, 0.5),
                covariance: Matrix3::identity() * 1e-4,
                sensors_used: vec!["k1".into(), "k2".into()],
                residual_m: 0.003,
                condition_number: 2.5,
                estimator: "fusion".into(),
            },
        );
    }
    let mut skipped = BTreeMap::new();
    skipped.insert(Joint::HipRight, "too few sensors".to_owned());
    FusedPose {
        set_seq: seq,
        stamp_nanos: 1_700_000_000_000_000_000 + seq as i64 * 33_333_333,
        joints,
        skipped,
        missing_sensors: Vec::new(),
    }
}

/// Only positions change: seq, stamp, covariance, sensors, residual, condition number,
/// estimator and the skipped list pass through; the output is smoother than the input.
/// A NaN joint is moved to `skipped` with the reason, the others still go through.
#[test]
fn filters_positions_only_and_rejects_nan() {
    let config = Config::from_lookup(lookup(&[])).unwrap();
    let mut filter = PoseFilter::new(config.params).unwrap();
    let mut last_out = 0.0;
    for seq in 0..30 {
        let raw = pose(seq, if seq % 2 == 0 { 0.01 } else { -0.01 });
        let mut out = raw.clone();
        assert_eq!(filter_pose(&mut filter, &mut out), 0);
        assert_eq!(
            (out.set_seq, out.stamp_nanos),
            (raw.set_seq, raw.stamp_nanos)
        );
        assert_eq!(out.skipped, raw.skipped);
        for (joint, f) in &out.joints {
            let r = &raw.joints[joint];
            assert_eq!(
                (
                    &f.covariance,
                    &f.sensors_used,
                    f.residual_m,
                    f.condition_number,
                    &f.estimator
                ),
                (
                    &r.covariance,
                    &r.sensors_used,
                    r.residual_m,
                    r.condition_number,
                    &r.estimator
                )
            );
        }
        last_out = out.joints[&Joint::KneeLeft].position.x;
    }
    // ±1 cm alternating jitter at rest is cut below 2 mm.
    assert!(last_out.abs() < 0.002, "{last_out}");

    let mut bad = pose(30, 0.0);
    if let Some(j) = bad.joints.get_mut(&Joint::AnkleLeft) {
        j.position.y = f64::NAN;
    }
    assert_eq!(filter_pose(&mut filter, &mut bad), 1);
    assert!(!bad.joints.contains_key(&Joint::AnkleLeft));
    assert_eq!(bad.skipped[&Joint::AnkleLeft], NON_FINITE_REASON);
    assert!(
        bad.joints[&Joint::KneeLeft]
            .position
            .iter()
            .all(|v| v.is_finite())
    );
}

/// A malformed input is counted and skipped; nothing is sent for it and the node ends cleanly.
#[test]
fn malformed_pose_is_skipped() {
    let (node, events, mut rx) = init_node(
        serde_json::json!({
            "id": "filter",
            "events": [
                {"time_offset_secs": 0.0, "type": "Input", "id": "fused_pose", "data": [1, 2, 3]},
                {"time_offset_secs": 0.01, "type": "Stop"}
            ]
        }),
        TestingOptions::default(),
    );
    let counters = crate::run(Config::from_lookup(lookup(&[])).unwrap(), node, events).unwrap();
    assert_eq!(counters.malformed, 1);
    assert_eq!(counters.poses_sent, 0);
    assert!(drain_outputs(&mut rx).is_empty());
}

/// The loop's happy path, checked against the closed form: with `ONE_EURO_BETA=0` the
/// One-Euro filter is a first-order low-pass of fixed cut-off f_c, so after a 10 cm step of
/// the knee at 30 Hz its output is 0.1·(1 − (1 − α)ᵐ) m, m poses after the step, with
/// α = 1/(1 + τ/Δt) and τ = 1/(2π f_c) (Casiez et al. 2012). Each `fused_pose` in
/// comes out once, in order, with its seq, stamp, covariance, sensors, diagnostics, skipped
/// joints and missing sensors as they came in; the still hip stays where it is.
#[test]
fn poses_in_smoothed_poses_out() {
    const PERIOD: i64 = 33_333_333;
    const CUTOFF_HZ: f64 = 2.0;
    const STEP_AT: u64 = 5;
    let joint = |x: f64, sensors: &[&str]| FusedJoint {
        position: Point3::new(x, 0.2, 0.5),
        covariance: Matrix3::new(1e-4, 2e-6, 0.0, 2e-6, 3e-4, 1e-6, 0.0, 1e-6, 5e-4),
        sensors_used: sensors.iter().map(|s| (*s).to_owned()).collect(),
        residual_m: 0.004,
        condition_number: 3.5,
        estimator: "fusion".into(),
    };
    let poses: Vec<FusedPose> = (0..20_u64)
        .map(|seq| {
            let knee = if seq < STEP_AT { 0.0 } else { 0.1 };
            FusedPose {
                set_seq: 100 + seq,
                stamp_nanos: 1_700_000_000_000_000_000 + seq as i64 * PERIOD,
                joints: BTreeMap::from([
                    (Joint::KneeLeft, joint(knee, &["k1", "k2"])),
                    (Joint::HipLeft, joint(-0.3, &["k1", "k2", "k3"])),
                ]),
                skipped: BTreeMap::from([(Joint::AnkleLeft, "too few sensors".to_owned())]),
                missing_sensors: vec!["k3".into()],
            }
        })
        .collect();
    let dir = scratch_dir("filter-loop");
    let mut events: Vec<serde_json::Value> = poses
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let t = i as f64 * 0.002;
            input_event(
                &dir,
                &format!("pose{i}"),
                t,
                "fused_pose",
                p.encode().unwrap(),
            )
        })
        .collect();
    events.push(serde_json::json!({"time_offset_secs": 0.05, "type": "Stop"}));
    let (node, events, mut rx) = init_node(
        serde_json::json!({"id": "filter", "events": events}),
        TestingOptions::default(),
    );
    let config = Config::from_lookup(lookup(&[
        ("ONE_EURO_BETA", "0"),
        ("ONE_EURO_MIN_CUTOFF_HZ", "2"),
    ]))
    .unwrap();
    let counters = crate::run(config, node, events).unwrap();
    assert_eq!((counters.poses_sent, counters.malformed), (20, 0));
    let out: Vec<FusedPose> = output_arrays(&drain_outputs(&mut rx), "fused_pose")
        .iter()
        .map(|a| FusedPose::decode(a.as_ref()).unwrap())
        .collect();
    assert_eq!(out.len(), poses.len());

    let tau = 1.0 / (2.0 * std::f64::consts::PI * CUTOFF_HZ);
    let alpha = 1.0 / (1.0 + tau / (PERIOD as f64 * 1e-9));
    for (seq, (raw, smooth)) in poses.iter().zip(&out).enumerate() {
        assert_eq!(
            (smooth.set_seq, smooth.stamp_nanos),
            (raw.set_seq, raw.stamp_nanos)
        );
        assert_eq!(smooth.skipped, raw.skipped);
        assert_eq!(smooth.missing_sensors, raw.missing_sensors);
        assert_eq!(
            smooth.joints.keys().collect::<Vec<_>>(),
            raw.joints.keys().collect::<Vec<_>>()
        );
        for (j, f) in &smooth.joints {
            let r = &raw.joints[j];
            assert_eq!(f.covariance, r.covariance, "{j}");
            assert_eq!(f.sensors_used, r.sensors_used, "{j}");
            assert_eq!(
                (f.residual_m, f.condition_number, &f.estimator),
                (r.residual_m, r.condition_number, &r.estimator)
            );
            assert!((f.position.y - 0.2).abs() < 1e-12 && (f.position.z - 0.5).abs() < 1e-12);
        }
        let hip = smooth.joints[&Joint::HipLeft].position.x;
        assert!((hip + 0.3).abs() < 1e-12, "seq {seq}: hip {hip}");
        let expected = match (seq as u64).checked_sub(STEP_AT) {
            None => 0.0,
            Some(m) => 0.1 * (1.0 - (1.0 - alpha).powi(m as i32 + 1)),
        };
        let knee = smooth.joints[&Joint::KneeLeft].position.x;
        assert!(
            (knee - expected).abs() < 1e-9,
            "seq {seq}: knee {knee}, closed form {expected}"
        );
    }
    // The step is followed, not copied: the first pose after it is about a third of the way
    // (α ≈ 0.295 at 2 Hz and 30 Hz), the last within 1 mm of the input.
    let first = out[STEP_AT as usize].joints[&Joint::KneeLeft].position.x;
    assert!((0.02..0.04).contains(&first), "{first}");
    let last = out[19].joints[&Joint::KneeLeft].position.x;
    assert!((0.099..0.1).contains(&last), "{last}");
    std::fs::remove_dir_all(&dir).ok();
}
