//! `recorder` contracts: configuration errors name node, key and value; the summary scores
//! fused poses against interpolated ground truth, counts dropped and incomplete sets and
//! source gaps, and reports NTP error shares; the ring keeps 1000 positions per joint and
//! exports them; an empty run still writes a valid summary and recording.

use std::collections::BTreeMap;

use dora_node_api::integration_testing::TestingOptions;
use dora_node_api::serde_json;
use nalgebra::{Matrix3, Point3};
use trigait_node_testing::{arrow_file, chain, init_node, lookup};
use trigait_schema::{FrameTiming, FusedJoint, FusedPose, GroundTruth};
use trigait_skeleton::Joint;

use crate::config::Config;
use crate::export::Ring;
use crate::stats::{Percentiles, Stats};

/// Defaults: `out/trigait.rrd`, no viewer, thesis rig, 1000 positions.
#[test]
fn config_defaults_and_errors() {
    let c = Config::from_lookup(lookup(&[])).unwrap();
    assert_eq!(c.rrd.unwrap(), std::path::Path::new("out/trigait.rrd"));
    assert!(c.connect.is_none());
    assert_eq!(c.ring_capacity, 1000);
    assert_eq!(c.warmup_nanos, 1_000_000_000);
    assert_eq!(c.live_update_nanos, Some(500_000_000));
    assert!(
        Config::from_lookup(lookup(&[("LIVE_UPDATE_SECS", "0")]))
            .unwrap()
            .live_update_nanos
            .is_none(),
        "0 turns live writing off"
    );
    assert!(
        Config::from_lookup(lookup(&[("RRD", "none")]))
            .unwrap()
            .rrd
            .is_none()
    );
    for (key, raw) in [
        ("RING_CAPACITY", "0"),
        ("RERUN_CONNECT", "localhost:9876"),
        ("RIG", "ring-2"),
        ("WARMUP_SECS", "-1"),
        ("LIVE_UPDATE_SECS", "0.05"),
    ] {
        let text = chain(&Config::from_lookup(lookup(&[(key, raw)])).unwrap_err());
        assert!(
            text.starts_with("recorder: ") && text.contains(key) && text.contains(raw),
            "{text}"
        );
    }
}

/// A replay told to write into the folder of the recording it plays is refused before it
/// overwrites it; another folder is fine.
#[test]
fn a_replay_does_not_write_over_its_recording() {
    let dir = std::env::temp_dir().join(format!("trigait-recorder-over-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("frames.csv"), "").unwrap();
    let recording = dir.join("frames.csv").display().to_string();
    let out = dir.display().to_string();
    let err = chain(
        &Config::from_lookup(lookup(&[("OUTPUT_DIR", &out), ("RECORDING", &recording)]))
            .unwrap_err(),
    );
    assert!(err.contains("overwrite the frames it plays"), "{err}");
    let other = dir.join("replayed").display().to_string();
    assert!(
        Config::from_lookup(lookup(&[("OUTPUT_DIR", &other), ("RECORDING", &recording)])).is_ok()
    );
    std::fs::remove_dir_all(&dir).ok();
}

fn truth_row(t: i64, x: f64) -> GroundTruth {
    GroundTruth {
        true_stamp_nanos: t,
        position_in_world: BTreeMap::from([(Joint::KneeLeft, Point3::new(x, 0.0, 0.5))]),
    }
}

fn pose(seq: u64, t: i64, x: f64) -> FusedPose {
    let mut joints = BTreeMap::new();
    joints.insert(
        Joint::KneeLeft,
        FusedJoint {
            position: Point3::new(x, 0.0, 0.5),
            covariance: Matrix3::identity() * 1e-4,
            sensors_used: vec!["k1".into(), "k2".into()],
            residual_m: 0.0,
            condition_number: 1.0,
            estimator: "fusion".into(),
        },
    );
    let mut skipped = BTreeMap::new();
    skipped.insert(Joint::AnkleLeft, "too few sensors".to_owned());
    FusedPose {
        set_seq: seq,
        stamp_nanos: t,
        joints,
        skipped,
        missing_sensors: Vec::new(),
    }
}

/// Truth of an instant already held is skipped, so the score is that of the first copy (a
/// stale or differing resend cannot move it).
#[test]
fn repeated_truth_counts_once() {
    let mut one = Stats::default();
    let mut many = Stats::default();
    let rows = |x0: f64| {
        (0..50)
            .map(|i| truth_row(i * 2_000_000, x0 + i as f64 * 0.002))
            .collect::<Vec<_>>()
    };
    one.push_truth(rows(0.0));
    many.push_truth(rows(0.0));
    many.push_truth(rows(0.0));
    many.push_truth(rows(0.5));
    assert_eq!(
        one.truth_at(Joint::KneeLeft, 15_000_000),
        many.truth_at(Joint::KneeLeft, 15_000_000)
    );
    for stats in [&mut one, &mut many] {
        stats.push_pose(pose(0, 15_000_000, 0.045), 20_000_000, None);
    }
    let (a, b) = (
        one.summary(30_000_000, true),
        many.summary(30_000_000, true),
    );
    assert_eq!(a.truth_samples, b.truth_samples);
    assert_eq!(a.rmse_all_m, b.rmse_all_m);
    assert!(
        (a.rmse_all_m.unwrap() - 0.03).abs() < 1e-9,
        "{:?}",
        a.rmse_all_m
    );
}

/// RMSE against truth interpolated at the fusion instant; seq gaps are dropped sets; missing
/// sensors make a set incomplete; latency and NTP shares are percentiles of what came in.
#[test]
fn summary_scores_and_counts() {
    let mut stats = Stats::default();
    // Truth moves 1 m/s along x, sampled every 2 ms.
    stats.push_truth(
        (0..50)
            .map(|i| truth_row(i * 2_000_000, i as f64 * 0.002))
            .collect(),
    );
    // Pose at 15 ms: truth x = 0.015; fused 3 cm off. Pose at 33 ms exact. Seq 2 never arrives.
    stats.push_pose(pose(0, 15_000_000, 0.045), 20_000_000, Some(18_000_000));
    let mut incomplete = pose(1, 33_000_000, 0.033);
    incomplete.missing_sensors = vec!["k2".into()];
    stats.push_pose(incomplete, 40_000_000, Some(36_000_000));
    stats.push_pose(pose(3, 60_000_000, 0.060), 66_000_000, Some(64_000_000));
    stats.push_timing(&[
        FrameTiming {
            sensor_id: "k1".into(),
            seq: 0,
            local_stamp_nanos: 0,
            server_stamp_nanos: None,
            uncertainty_nanos: None,
            offset_nanos: None,
            drift_ppm: None,
            true_stamp_nanos: Some(0),
            received_nanos: None,
            joints: Vec::new(),
        },
        FrameTiming {
            sensor_id: "k1".into(),
            seq: 1,
            local_stamp_nanos: 0,
            server_stamp_nanos: Some(1_000_300_000),
            uncertainty_nanos: Some(100_000),
            offset_nanos: Some(5_000_000),
            drift_ppm: Some(10.0),
            true_stamp_nanos: Some(1_000_000_000),
            received_nanos: None,
            joints: Vec::new(),
        },
        FrameTiming {
            sensor_id: "k1".into(),
            seq: 2,
            local_stamp_nanos: 0,
            server_stamp_nanos: Some(2_002_000_000),
            uncertainty_nanos: Some(100_000),
            offset_nanos: Some(5_000_000),
            drift_ppm: Some(10.0),
            true_stamp_nanos: Some(2_000_000_000),
            received_nanos: None,
            joints: Vec::new(),
        },
    ]);
    // Frames 2 and 3 of k1 never arrive.
    // Frame 1 reports a joint no sensor could have measured.
    for (seq, impossible, t) in [(0, 0, 0), (1, 1, 33_000_000), (4, 0, 400_000_000)] {
        stats.push_frame("k1", seq, impossible, t);
    }
    let s = stats.summary(1_000_000_000, true);
    assert_eq!((s.warmup.poses, s.warmup.latency_ms.count), (0, 0));
    assert_eq!(s.sets_fused, 3);
    assert_eq!(s.dropped_sets, 1);
    assert_eq!(s.incomplete_sets, 1);
    assert_eq!(s.joints_skipped, 3);
    assert_eq!(s.estimators.get("fusion"), Some(&3), "{:?}", s.estimators);
    let rmse = s.rmse_m["knee_left"];
    let expected = (0.03_f64.powi(2) / 3.0).sqrt();
    assert!((rmse - expected).abs() < 1e-9, "{rmse} vs {expected}");
    assert_eq!(s.truth_samples, 3);
    assert!((s.latency_ms.p50 - 2.0).abs() < 1e-9);
    let ntp = &s.ntp["k1"];
    assert_eq!((ntp.frames_checked, ntp.frames_unsynchronised), (2, 1));
    assert!((ntp.share_below_1ms - 0.5).abs() < 1e-12);
    assert_eq!(ntp.offset_ms, Some(5.0));
    // One gap between frames (33 → 400 ms) and one to the end (400 → 1000 ms).
    assert_eq!(s.gaps.len(), 2, "{:?}", s.gaps);
    assert!(
        s.gaps
            .iter()
            .any(|g| g.until_end && (g.duration_secs - 0.6).abs() < 1e-9)
    );
    assert_eq!(s.frames_in["k1"], 3);
    assert_eq!(s.frames_lost["k1"], 2);
    assert_eq!(s.impossible_joints["k1"], 1);
}

/// Percentiles of nothing are zeros, of one value that value.
#[test]
fn percentiles() {
    assert_eq!(Percentiles::of_nanos(&[]), Percentiles::default());
    let p = Percentiles::of_nanos(&[3_000_000]);
    assert_eq!((p.count, p.p50, p.p99, p.max), (1, 3.0, 3.0, 3.0));
    let v: Vec<i64> = (1..=100).map(|i| i * 1_000_000).collect();
    let p = Percentiles::of_nanos(&v);
    assert_eq!(
        (p.p50, p.p95, p.p99, p.max),
        (50.0, 95.0, 99.0, 100.0),
        "nearest rank"
    );
}

/// The ring keeps the newest `capacity` positions per joint; the text file has one line per
/// instant with x y z per joint.
#[test]
fn ring_and_exports() {
    let mut ring = Ring::new(1000);
    for i in 0..1200 {
        ring.push(&pose(i, i as i64 * 33_333_333, i as f64 * 0.001));
    }
    assert_eq!(ring.len(Joint::KneeLeft), 1000);
    let text = ring.thesis_text();
    let lines: Vec<&str> = text.lines().filter(|l| !l.starts_with('#')).collect();
    assert_eq!(lines.len(), 1000);
    let first: Vec<f64> = lines[0]
        .split_whitespace()
        .map(|v| v.parse().unwrap())
        .collect();
    assert_eq!(first, [0.0, 0.2, 0.0, 0.5]);
}

/// The whole run goes out through `trigait-motion`: the CSV, TRC and C3D read back with its
/// readers as the same 30 Hz trajectory, every pose on its frame (a lost set is a gap).
#[test]
fn trajectory_files_read_back() {
    let dir = std::env::temp_dir().join(format!("trigait-recorder-traj-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut trajectory = trigait_fusion::Trajectory::new();
    for i in (0..90).filter(|i| *i != 40) {
        trajectory.push(&pose(i, 5_000 + i as i64 * 33_333_333, i as f64 * 0.01));
    }
    crate::export::write_trajectory(&dir, &trajectory).unwrap();
    let clip = trigait_motion::read_csv(dir.join("trajectory.csv")).unwrap();
    assert!((clip.rate_hz() - 30.0).abs() < 1e-3, "{}", clip.rate_hz());
    assert_eq!(clip.frame_count(), 90);
    assert_eq!(clip.joints(), [Joint::KneeLeft]);
    assert!(clip.position(40, Joint::KneeLeft).is_none());
    let p = clip.position(41, Joint::KneeLeft).unwrap();
    assert!((p.x - 0.41).abs() < 1e-6 && (p.z - 0.5).abs() < 1e-6, "{p}");
    let trc = trigait_motion::read_trc(dir.join("trajectory.trc")).unwrap();
    assert_eq!(trc.frame_count(), 90);
    let c3d = trigait_motion::read_c3d(dir.join("trajectory.c3d")).unwrap();
    assert_eq!(c3d.frame_count(), 90);
    // One knee gives no gait: the report says which joint is missing.
    let report = std::fs::read_to_string(dir.join("report.html")).unwrap();
    trigait_gait::report::check_well_formed(&report).unwrap();
    assert!(
        report.contains("No gait parameters") && report.contains("ankle"),
        "{report}"
    );
    // Too few poses for a rate: no files, and an earlier run's are gone.
    let mut one = trigait_fusion::Trajectory::new();
    one.push(&pose(0, 0, 0.0));
    crate::export::write_trajectory(&dir, &one).unwrap();
    assert!(!dir.join("trajectory.csv").exists() && !dir.join("trajectory.c3d").exists());
    assert!(!dir.join("report.html").exists());
    std::fs::remove_dir_all(&dir).ok();
}

/// A run with no data still writes summary.json, the exports and a recording.
#[test]
fn empty_run_writes_outputs() {
    let dir = std::env::temp_dir().join(format!("trigait-recorder-test-{}", std::process::id()));
    let (node, events, _rx) = init_node(
        serde_json::json!({
            "id": "recorder",
            "events": [
                {"time_offset_secs": 0.0, "type": "Input", "id": "fused_pose", "data": [1]},
                {"time_offset_secs": 0.01, "type": "Stop"}
            ]
        }),
        TestingOptions::default(),
    );
    let out = dir.to_str().unwrap().to_owned();
    let config = Config::from_lookup(lookup(&[("OUTPUT_DIR", &out)])).unwrap();
    let summary = crate::run(config, node, events).unwrap();
    assert_eq!(summary.sets_fused, 0);
    assert_eq!(summary.malformed_inputs, 1);
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    assert_eq!(json["sets_fused"], 0);
    assert!(dir.join("trajectory.txt").exists());
    assert!(
        !dir.join("trajectory.csv").exists(),
        "no poses: no trajectory to read back"
    );
    assert!(std::fs::metadata(dir.join("trigait.rrd")).unwrap().len() > 0);
    std::fs::remove_dir_all(&dir).ok();
}

/// Poses recorded within the warm-up after the first go to `warmup`, the rest to `latency_ms`
/// and `age_ms`; a pose without a sent time counts as a pose but has no latency. What ended
/// each set's wait is counted, and the wait budget reported in ms.
#[test]
fn warmup_latency_is_reported_apart() {
    let mut stats = Stats::new(1_000_000_000);
    let ms = 1_000_000;
    // A slow start: 120 ms, then 2 ms. The warm-up runs from the first pose's recording (at
    // 120 ms): 1119 ms is still in it, 1120 ms is not.
    stats.push_pose(pose(0, 0, 0.0), 120 * ms, Some(0));
    stats.push_pose(pose(1, 33 * ms, 0.0), 1119 * ms, Some(1117 * ms));
    stats.push_pose(pose(2, 66 * ms, 0.0), 1120 * ms, None);
    for (seq, at) in [(3, 1200), (4, 1300)] {
        stats.push_pose(pose(seq, at * ms, 0.0), (at + 3) * ms, Some(at * ms));
    }
    let s = stats.summary(2_000 * ms, true);
    assert_eq!(s.warmup.poses, 2);
    assert_eq!(s.warmup.latency_ms.count, 2);
    assert!((s.warmup.latency_ms.max - 120.0).abs() < 1e-9);
    assert_eq!(s.latency_ms.count, 2);
    assert!((s.latency_ms.max - 3.0).abs() < 1e-9, "{:?}", s.latency_ms);
    assert!((s.warmup.secs - 1.0).abs() < 1e-12);
    assert_eq!((s.warmup.age_ms.count, s.age_ms.count), (2, 3));
    assert!(
        (s.warmup.age_ms.max - 1086.0).abs() < 1e-9,
        "{:?}",
        s.warmup.age_ms
    );
    assert!((s.age_ms.max - 1054.0).abs() < 1e-9, "{:?}", s.age_ms);
    assert!((s.age_ms.p50 - 3.0).abs() < 1e-9, "{:?}", s.age_ms);

    stats.push_sync_wait(Some("frames"), Some(&[10 * ms, 100 * ms]));
    stats.push_sync_wait(Some("overdue"), Some(&[10 * ms, 100 * ms]));
    stats.push_sync_wait(Some("frames"), None);
    stats.push_sync_wait(None, Some(&[1, 2, 3]));
    let w = stats.summary(2_000 * ms, true).sync_wait;
    assert_eq!(
        (w.frame_wait_margin_ms, w.deadline_ms),
        (Some(10.0), Some(100.0))
    );
    let released: Vec<(&str, u64)> = w.released.iter().map(|(k, v)| (k.as_str(), *v)).collect();
    assert_eq!(released, [("frames", 2), ("overdue", 1), ("unknown", 1)]);
}

/// Once a set says the run winds down, the poses after it go to `wind_down`, apart from the
/// steady state's latency and age; a pose still in the warm-up stays there.
#[test]
fn wind_down_latency_is_reported_apart() {
    let ms = 1_000_000;
    let mut stats = Stats::new(100 * ms);
    stats.push_pose(pose(0, 0, 0.0), 5 * ms, Some(4 * ms));
    for seq in 1..10 {
        let at = seq as i64 * 200 * ms;
        stats.push_pose(pose(seq, at, 0.0), at + 40 * ms, Some(at + 38 * ms));
    }
    stats.begin_wind_down();
    for seq in 10..12 {
        let at = seq as i64 * 200 * ms;
        stats.push_pose(pose(seq, at, 0.0), at + 90 * ms, Some(at + 50 * ms));
    }
    let s = stats.summary(3_000 * ms, true);
    assert_eq!((s.warmup.poses, s.wind_down.poses), (1, 2));
    assert_eq!((s.latency_ms.count, s.age_ms.count), (9, 9));
    assert!((s.latency_ms.max - 2.0).abs() < 1e-9, "{:?}", s.latency_ms);
    assert!((s.age_ms.max - 40.0).abs() < 1e-9, "{:?}", s.age_ms);
    assert_eq!(s.wind_down.latency_ms.count, 2);
    assert!((s.wind_down.latency_ms.max - 40.0).abs() < 1e-9);
    assert!((s.wind_down.age_ms.p50 - 90.0).abs() < 1e-9);
}

/// The loop's happy path: poses and ground truth in, scored in `summary.json` (3 cm off the
/// truth at every instant), and the trajectory written as a CSV the motion reader reads back.
#[test]
fn poses_and_truth_in_summary_and_trajectory_out() {
    use trigait_schema::Message;
    let dir = std::env::temp_dir().join(format!("trigait-recorder-loop-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let period = 33_333_333;
    let truth: Vec<GroundTruth> = (0..60)
        .map(|i| truth_row(i * 2_000_000, i as f64 * 0.002))
        .collect();
    let mut events = vec![serde_json::json!({
        "time_offset_secs": 0.0, "type": "Input", "id": "ground_truth",
        "path": arrow_file(&dir, "truth", GroundTruth::encode_many(&truth).unwrap()), "column": "msg"
    })];
    for i in 0..3_u64 {
        let t = i as i64 * period;
        let pose = pose(i, t, t as f64 * 1e-9 + 0.03);
        events.push(serde_json::json!({
            "time_offset_secs": 0.01 * (i + 1) as f64, "type": "Input", "id": "fused_pose",
            "path": arrow_file(&dir, &format!("pose{i}"), pose.encode().unwrap()), "column": "msg"
        }));
    }
    events.push(serde_json::json!({"time_offset_secs": 0.1, "type": "Stop"}));
    let (node, events, _rx) = init_node(
        serde_json::json!({"id": "recorder", "events": events}),
        TestingOptions::default(),
    );
    let out = dir.join("out");
    let config = Config::from_lookup(lookup(&[("OUTPUT_DIR", out.to_str().unwrap())])).unwrap();
    let summary = crate::run(config, node, events).unwrap();
    assert_eq!((summary.sets_fused, summary.truth_samples), (3, 3));
    assert_eq!(summary.malformed_inputs, 0);
    let rmse = summary.rmse_m["knee_left"];
    assert!((rmse - 0.03).abs() < 1e-9, "{rmse}");
    let clip = trigait_motion::read_csv(out.join("trajectory.csv")).unwrap();
    assert_eq!(clip.frame_count(), 3);
    assert!((clip.rate_hz() - 30.0).abs() < 1e-3);
    std::fs::remove_dir_all(&dir).ok();
}

/// By default the files are written as the run goes: while poses still come (for 1.5 s),
/// `summary.json` says `"complete": false` with poses in it and `trajectory.csv` and the raw
/// recording's `poses.csv` hold frames, all written by the writer thread; at the end the
/// summary is complete and the CSV holds every pose.
#[test]
fn files_are_written_while_the_run_goes() {
    use trigait_schema::Message;
    let dir = std::env::temp_dir().join(format!("trigait-recorder-live-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let period = 33_333_333;
    let n = 45_u64;
    let mut events = Vec::new();
    for i in 0..n {
        let t = i as i64 * period;
        let pose = pose(i, t, t as f64 * 1e-9);
        events.push(serde_json::json!({
            "time_offset_secs": i as f64 * period as f64 * 1e-9, "type": "Input", "id": "fused_pose",
            "path": arrow_file(&dir, &format!("pose{i}"), pose.encode().unwrap()), "column": "msg"
        }));
    }
    events.push(serde_json::json!({"time_offset_secs": 1.6, "type": "Stop"}));
    let (node, events, _rx) = init_node(
        serde_json::json!({"id": "recorder", "events": events}),
        TestingOptions::default(),
    );
    let out = dir.join("out");
    let config = Config::from_lookup(lookup(&[("OUTPUT_DIR", out.to_str().unwrap())])).unwrap();
    assert_eq!(config.live_update_nanos, Some(500_000_000), "on by default");
    let run = std::thread::spawn(move || crate::run(config, node, events));
    let mut seen = None;
    while !run.is_finished() {
        std::thread::sleep(std::time::Duration::from_millis(20));
        let Ok(text) = std::fs::read_to_string(out.join("summary.json")) else {
            continue;
        };
        let json: serde_json::Value = serde_json::from_str(&text).unwrap();
        if json["complete"] == false && json["sets_fused"].as_u64().unwrap() > 0 {
            let csv = std::fs::read_to_string(out.join("trajectory.csv")).unwrap_or_default();
            let poses = std::fs::read_to_string(out.join(trigait_recording::POSES_FILE)).unwrap();
            seen = Some((
                json["sets_fused"].as_u64().unwrap(),
                csv.lines().count().saturating_sub(1),
                poses.lines().count().saturating_sub(1),
            ));
            break;
        }
    }
    let summary = run.join().unwrap().unwrap();
    let (sets, csv_frames, pose_lines) = seen.expect("no live summary.json before the end");
    assert!(
        sets < n,
        "the live summary came before the last pose: {sets}"
    );
    // The CSV and the recording were appended in the same update as the summary (or later).
    assert!(
        csv_frames >= 2 && pose_lines >= 1,
        "{csv_frames} {pose_lines}"
    );
    assert_eq!(summary.sets_fused, n);
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(json["complete"], true);
    let clip = trigait_motion::read_csv(out.join("trajectory.csv")).unwrap();
    assert_eq!(clip.frame_count(), n as usize);
    let poses = std::fs::read_to_string(out.join(trigait_recording::POSES_FILE)).unwrap();
    assert_eq!(
        poses.lines().count() - 1,
        n as usize,
        "one line per pose (one joint)"
    );
    std::fs::remove_dir_all(&dir).ok();
}
