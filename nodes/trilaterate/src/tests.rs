//! `trilaterate` contracts: the estimator comes from YAML with errors naming node, key and
//! value; a set is fused with the rig's noise model and a joint too few sensors saw is listed
//! as skipped with the reason; malformed sets are counted, never fatal.

use std::collections::BTreeMap;

use dora_node_api::integration_testing::{TestingOptions, drain_outputs};
use dora_node_api::serde_json;
use nalgebra::Point3;
use trigait_node_testing::{arrow_file, chain, init_node, lookup, output_arrays, scratch_dir};
use trigait_rig::Rig;
use trigait_schema::{FusedPose, Message};
use trigait_skeleton::{Joint, JointSample, TrackingState};
use trigait_sync::{AlignedSet, Policy, SensorView};
use trigait_trilateration::Method;

use crate::config::Config;
use crate::{fuse_set, on_aligned_set, pose_fuser, unwired_sensors};

/// Defaults to fusion on the thesis rig; `ROBUST` wraps it.
#[test]
fn config_defaults() {
    let c = Config::from_lookup(lookup(&[])).unwrap();
    assert_eq!(c.params.method, Method::Fusion);
    assert_eq!(c.estimator_name(), "fusion");
    assert_eq!(c.rig.name, "thesis");
    let c = Config::from_lookup(lookup(&[("METHOD", "linear"), ("ROBUST", "true")])).unwrap();
    assert_eq!(c.estimator_name(), "linear+robust");
}

/// Unknown estimator, bad ROBUST, malformed rig file: errors name node, key and value.
#[test]
fn config_errors_name_node_key_and_value() {
    let text = chain(&Config::from_lookup(lookup(&[("METHOD", "kalman")])).unwrap_err());
    assert!(text.starts_with("trilaterate: METHOD=\"kalman\""), "{text}");
    assert!(text.contains("geometric, linear, nls, fusion"), "{text}");
    // The name the estimator goes by in the output is not a METHOD: ROBUST is named.
    let text = chain(&Config::from_lookup(lookup(&[("METHOD", "fusion+robust")])).unwrap_err());
    assert!(text.contains("ROBUST: \"true\""), "{text}");
    for key in ["ROBUST", "RESAMPLING_WEIGHTS"] {
        let text = chain(&Config::from_lookup(lookup(&[(key, "maybe")])).unwrap_err());
        assert!(
            text.starts_with("trilaterate: ") && text.contains(key) && text.contains("maybe"),
            "{text}"
        );
    }
    let dir = scratch_dir("trilaterate-test");
    let rig = dir.join("bad-rig.yml");
    std::fs::write(&rig, "sensors:\n  - id: a\n    position: [0, 0]\n").unwrap();
    let text = chain(&Config::from_lookup(lookup(&[("RIG", rig.to_str().unwrap())])).unwrap_err());
    assert!(
        text.starts_with("trilaterate: RIG=") && text.contains("bad-rig.yml"),
        "{text}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

fn view(joints: Vec<JointSample>) -> SensorView {
    let n = joints.len();
    SensorView {
        joints,
        interpolation_error_m: vec![Some(0.0); n],
        frame_seqs: vec![1],
        skew_nanos: 0,
        time_uncertainty_nanos: 0,
    }
}

/// Three sensors seeing a knee exactly: fused at the truth with a small covariance and all
/// three named; an ankle only one sensor saw is fused by `fusion` but skipped by `linear`
/// with the reason; a joint seen before and by nobody now is skipped too.
#[test]
fn fuses_and_skips_with_reasons() {
    let rig = Rig::from_spec("thesis").unwrap();
    let knee = Point3::new(0.3, 0.1, 0.5);
    let ankle = Point3::new(0.2, -0.1, 0.1);
    let mut sensors = BTreeMap::new();
    for (i, s) in rig.sensors.iter().enumerate() {
        let mut joints = vec![JointSample {
            joint: Joint::KneeLeft,
            position_in_kinect: s.world_from_kinect.inverse_transform_point(&knee),
            state: TrackingState::Tracked,
        }];
        if i == 0 {
            joints.push(JointSample {
                joint: Joint::AnkleLeft,
                position_in_kinect: s.world_from_kinect.inverse_transform_point(&ankle),
                state: TrackingState::Inferred,
            });
        }
        sensors.insert(s.id.clone(), view(joints));
    }
    let set = AlignedSet {
        seq: 4,
        stamp_nanos: 123,
        policy: Policy::Interpolate,
        sensors,
        missing: vec![],
        time_uncertainty_nanos: 0,
    };
    let fusion = Config::from_lookup(lookup(&[])).unwrap();
    let mut fuser = pose_fuser(&fusion);
    let (pose, unknown) = fuse_set(&mut fuser, &set);
    assert!(unknown.is_empty());
    assert_eq!((pose.set_seq, pose.stamp_nanos), (4, 123));
    let k = &pose.joints[&Joint::KneeLeft];
    assert!((k.position - knee).norm() < 1e-6, "{}", k.position);
    assert_eq!(k.sensors_used, ["k1", "k2", "k3"]);
    assert!(k.covariance.trace() > 0.0 && k.covariance.trace() < 0.01);
    assert!(
        pose.joints.contains_key(&Joint::AnkleLeft),
        "fusion needs one sensor"
    );

    let linear = Config::from_lookup(lookup(&[("METHOD", "linear")])).unwrap();
    let mut fuser = pose_fuser(&linear);
    let (pose, _) = fuse_set(&mut fuser, &set);
    assert!((pose.joints[&Joint::KneeLeft].position - knee).norm() < 1e-6);
    let reason = &pose.skipped[&Joint::AnkleLeft];
    assert!(
        reason.contains("too few sensors") && reason.contains("k1"),
        "{reason}"
    );

    let mut later = set.clone();
    for v in later.sensors.values_mut() {
        v.joints.retain(|s| s.joint == Joint::KneeLeft);
    }
    let (pose, _) = fuse_set(&mut fuser, &later);
    assert!(pose.skipped[&Joint::AnkleLeft].contains("no sensor saw it"));
}

/// One sensor's knee is 6 cm off and `sync` says its resampling may be 5 cm off: weighed by
/// that estimate it pulls the fused knee less than with `RESAMPLING_WEIGHTS=false`, and the
/// covariance says so.
#[test]
fn resampling_error_widens_the_covariance() {
    let rig = Rig::from_spec("thesis").unwrap();
    let knee = Point3::new(0.3, 0.1, 0.5);
    let mut sensors = BTreeMap::new();
    for (i, s) in rig.sensors.iter().enumerate() {
        let (seen, error) = if i == 0 {
            (knee + nalgebra::Vector3::new(0.06, 0.0, 0.0), 0.05)
        } else {
            (knee, 0.002)
        };
        let mut v = view(vec![JointSample {
            joint: Joint::KneeLeft,
            position_in_kinect: s.world_from_kinect.inverse_transform_point(&seen),
            state: TrackingState::Tracked,
        }]);
        v.interpolation_error_m = vec![Some(error)];
        sensors.insert(s.id.clone(), v);
    }
    let set = AlignedSet {
        seq: 0,
        stamp_nanos: 0,
        policy: Policy::Interpolate,
        sensors,
        missing: vec![],
        time_uncertainty_nanos: 0,
    };
    let on = Config::from_lookup(lookup(&[])).unwrap();
    assert!(on.resampling_weights);
    let off = Config::from_lookup(lookup(&[("RESAMPLING_WEIGHTS", "false")])).unwrap();
    let fuse = |c: &Config| fuse_set(&mut pose_fuser(c), &set).0.joints[&Joint::KneeLeft].clone();
    let (weighed, ignored) = (fuse(&on), fuse(&off));
    let (e_on, e_off) = (
        (weighed.position - knee).norm(),
        (ignored.position - knee).norm(),
    );
    assert!(e_on < 0.5 * e_off, "{e_on} vs {e_off}");
    assert!(weighed.covariance.trace() > ignored.covariance.trace());
}

/// A five-sensor rig under a graph whose `sync` reads three (a five-sensor recording replayed
/// by the three-source replay graph): the two it never hears of are named.
#[test]
fn rig_sensors_without_a_source_are_named() {
    let rig = Rig::from_spec("ring-5").unwrap();
    let ids: Vec<String> = rig.sensors.iter().map(|s| s.id.clone()).collect();
    let mut sensors = BTreeMap::new();
    sensors.insert(ids[0].clone(), view(Vec::new()));
    let set = AlignedSet {
        seq: 0,
        stamp_nanos: 0,
        policy: Policy::Slots,
        sensors,
        missing: vec![ids[1].clone(), ids[2].clone()],
        time_uncertainty_nanos: 0,
    };
    assert_eq!(unwired_sensors(&rig, &set), ids[3..].to_vec());
    let thesis = Rig::from_spec("thesis").unwrap();
    let mut all = set.clone();
    all.missing = Vec::new();
    for s in &thesis.sensors {
        all.sensors.insert(s.id.clone(), view(Vec::new()));
    }
    assert!(unwired_sensors(&thesis, &all).is_empty());
}

/// A set from a sensor the rig does not know is fused without it, and that sensor is named.
#[test]
fn unknown_sensor_is_left_out() {
    let rig = Rig::from_spec("thesis").unwrap();
    let mut sensors = BTreeMap::new();
    sensors.insert(
        "k7".to_owned(),
        view(vec![JointSample {
            joint: Joint::HipLeft,
            position_in_kinect: Point3::new(0.0, 0.0, 2.0),
            state: TrackingState::Tracked,
        }]),
    );
    let set = AlignedSet {
        seq: 0,
        stamp_nanos: 0,
        policy: Policy::Slots,
        sensors,
        missing: vec![],
        time_uncertainty_nanos: 0,
    };
    assert_eq!(rig.name, "thesis");
    let c = Config::from_lookup(lookup(&[])).unwrap();
    let (pose, unknown) = fuse_set(&mut pose_fuser(&c), &set);
    assert_eq!(unknown, ["k7"]);
    assert!(pose.joints.is_empty());
    assert!(pose.skipped.contains_key(&Joint::HipLeft));
}

/// A malformed aligned set is counted and skipped; nothing is sent for it.
#[test]
fn malformed_set_is_skipped() {
    let (node, events, mut rx) = init_node(
        serde_json::json!({
            "id": "trilaterate",
            "events": [
                {"time_offset_secs": 0.0, "type": "Input", "id": "aligned_set", "data": [1, 2, 3]},
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

/// The node and `trigait eval` run one fusion: the same simulated snapshots, encoded as the
/// aligned sets `sync` would send and given to the node's `aligned_set` handler, come out as
/// the very poses (bit for bit: position, covariance, sensors used) that eval's per-snapshot
/// path ([`trigait_eval::observe_snapshot`], then the estimator) scores, for every method.
#[test]
fn node_and_eval_fuse_identically() {
    use trigait_kinect::NoiseModel;
    use trigait_sim::Simulator;

    let rig = Rig::from_spec("thesis").unwrap();
    let walker = trigait_motion::walker(&trigait_motion::WalkerParams::default(), 0.5, 30.0)
        .unwrap()
        .placed_on_walkway();
    let sim = Simulator::new(&rig, walker, &Joint::LEGS, &NoiseModel::default());
    let fusion = trigait_fusion::FusionRig::from_sensors(sim.sensors().to_vec());
    let mut rngs: Vec<_> = (0..3).map(|s| Simulator::sensor_rng(3, s)).collect();
    for method in ["geometric", "linear", "nls", "fusion"] {
        for robust in ["false", "true"] {
            let config =
                Config::from_lookup(lookup(&[("METHOD", method), ("ROBUST", robust)])).unwrap();
            let mut fuser = pose_fuser(&config);
            let mut compared = 0;
            for k in 0_u32..15 {
                let snapshot = sim.snapshot(f64::from(k) / 30.0, &mut rngs);
                let sensors: BTreeMap<String, SensorView> = sim
                    .sensors()
                    .iter()
                    .enumerate()
                    .map(|(i, s)| (s.id.clone(), view(snapshot.samples(&sim, i))))
                    .map(|(id, mut v)| {
                        v.interpolation_error_m = vec![None; v.joints.len()];
                        (id, v)
                    })
                    .collect();
                let set = AlignedSet {
                    seq: k.into(),
                    stamp_nanos: i64::from(k) * 33_333_333,
                    policy: Policy::Slots,
                    sensors,
                    missing: vec![],
                    time_uncertainty_nanos: 0,
                };
                let array = set.encode().unwrap();
                let (_, pose, unknown) = on_aligned_set(&mut fuser, array.as_ref()).unwrap();
                assert!(unknown.is_empty());
                let eval = trigait_eval::observe_snapshot(&fusion, &sim, &snapshot)
                    .estimate(&config.params);
                for (joint, fused) in &eval.joints {
                    match (&fused.result, pose.joints.get(joint)) {
                        (Ok(e), Some(node)) => {
                            assert_eq!(e.position, node.position, "{method} {joint}");
                            assert_eq!(e.covariance, node.covariance, "{method} {joint}");
                            let ids: Vec<String> = fused
                                .sensors_used()
                                .iter()
                                .map(|i| rig.sensors[*i].id.clone())
                                .collect();
                            assert_eq!(ids, node.sensors_used);
                            compared += 1;
                        }
                        (Err(_), None) => assert!(pose.skipped.contains_key(joint)),
                        (e, n) => panic!("{method} {joint}: eval {e:?}, node {n:?}"),
                    }
                }
                assert_eq!(pose.joints.len() + pose.skipped.len(), eval.joints.len());
            }
            assert!(
                compared > 15 * 3,
                "{method}: only {compared} joints compared"
            );
        }
    }
}

/// The loop's happy path: an aligned set in on `aligned_set` comes out as one `fused_pose`
/// carrying the set's seq, stamp and missing sensor, its knee fused at the truth from all
/// three sensors.
#[test]
fn aligned_set_in_fused_pose_out() {
    let rig = Rig::from_spec("thesis").unwrap();
    let knee = Point3::new(0.3, 0.1, 0.5);
    let sensors: BTreeMap<String, SensorView> = rig
        .sensors
        .iter()
        .map(|s| {
            let sample = JointSample {
                joint: Joint::KneeLeft,
                position_in_kinect: s.world_from_kinect.inverse_transform_point(&knee),
                state: TrackingState::Tracked,
            };
            (s.id.clone(), view(vec![sample]))
        })
        .collect();
    let set = AlignedSet {
        seq: 0,
        stamp_nanos: 5,
        policy: Policy::Interpolate,
        sensors,
        missing: vec!["k4".into()],
        time_uncertainty_nanos: 0,
    };
    let dir = scratch_dir("trilaterate-loop");
    let file = arrow_file(&dir, "set", set.encode().unwrap());
    let (node, events, mut rx) = init_node(
        serde_json::json!({
            "id": "trilaterate",
            "events": [
                {"time_offset_secs": 0.0, "type": "Input", "id": "aligned_set", "path": file, "column": "msg"},
                {"time_offset_secs": 0.01, "type": "Stop"}
            ]
        }),
        TestingOptions::default(),
    );
    let counters = crate::run(Config::from_lookup(lookup(&[])).unwrap(), node, events).unwrap();
    assert_eq!((counters.poses_sent, counters.joints_fused), (1, 1));
    assert_eq!(counters.malformed, 0);
    let outputs = drain_outputs(&mut rx);
    let poses: Vec<FusedPose> = output_arrays(&outputs, "fused_pose")
        .iter()
        .map(|a| FusedPose::decode(a.as_ref()).unwrap())
        .collect();
    assert_eq!(poses.len(), 1, "{outputs:?}");
    let pose = &poses[0];
    assert_eq!((pose.set_seq, pose.stamp_nanos), (0, 5));
    assert_eq!(pose.missing_sensors, ["k4"]);
    assert!(pose.skipped.is_empty(), "{:?}", pose.skipped);
    let k = &pose.joints[&Joint::KneeLeft];
    assert!((k.position - knee).norm() < 1e-6, "{}", k.position);
    assert_eq!(k.sensors_used, ["k1", "k2", "k3"]);
    assert_eq!(k.estimator, "fusion");
    std::fs::remove_dir_all(&dir).ok();
}
