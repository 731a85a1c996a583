//! Contracts of the `depth-metrics` node's config and per-sensor state.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use dora_node_api::integration_testing::{TestingOptions, drain_outputs};
use trigait_depth::Intrinsics;
use trigait_depth::sim::{Scene, SimParams, Simulator};
use trigait_depth_rerun::Sink;
use trigait_node_testing::{init_node, input_event, lookup, scratch_dir};
use trigait_schema::{ArrayRef, DepthFrameMessage, Message, NtpExchange, SensorStatus};

use crate::config::Config;
use crate::state::{Pushed, Sensors};

fn message(sim: &mut Simulator, seq: u64) -> ArrayRef {
    DepthFrameMessage {
        sensor_id: "k1".into(),
        seq,
        local_stamp_nanos: seq as i64 * 33_333_333,
        width: 512,
        height: 424,
        depth_mm: sim.next_frame().as_mm().to_vec(),
    }
    .encode()
    .unwrap()
}

/// A frame's stamped pinhole (an undistorted real frame's `trigait.depth_pinhole`) is the
/// camera the metrics use and goes into the sensor's entry; unstamped frames are the nominal
/// camera; a change of camera starts the analysis afresh.
#[test]
fn stamped_pinhole_is_the_metrics_camera() {
    let mut sim = Simulator::new(&Scene::wall(2.0), SimParams::default()).unwrap();
    let mut sensors = Sensors::new(trigait_depth::MetricsParams::default(), 100);
    let plain = dora_node_api::MetadataParameters::default();
    for seq in 0..3 {
        let camera = trigait_node_config::depth_camera(&plain);
        assert_eq!(camera, Intrinsics::default());
        let pushed = sensors.push("k1", message(&mut sim, seq).as_ref(), camera, 0);
        assert_eq!(pushed.0, Pushed::Analysed);
    }
    assert_eq!(sensors.entry("k1").unwrap().pinhole, None);
    let k = [365.456, 365.456, 254.878, 205.395];
    let mut stamped = dora_node_api::MetadataParameters::default();
    stamped.insert(
        trigait_schema::ports::DEPTH_PINHOLE.to_owned(),
        trigait_node_config::pinhole_parameter(k),
    );
    for seq in 3..5 {
        let camera = trigait_node_config::depth_camera(&stamped);
        assert_eq!(camera, Intrinsics::pinhole(k[0], k[1], k[2], k[3]));
        let pushed = sensors.push("k1", message(&mut sim, seq).as_ref(), camera, 0);
        assert_eq!(pushed.0, Pushed::Analysed);
    }
    assert!(sensors.report("k1", None).unwrap());
    let e = sensors.entry("k1").unwrap();
    assert_eq!(e.pinhole, Some(k));
    assert_eq!(e.frames_analysed, 5);
    assert_eq!(e.report.as_ref().unwrap().frames, 2, "analysis restarted");
}

/// Defaults, the rerun sink forms, and errors that name the variable.
#[test]
fn config_defaults_and_errors() {
    let c = Config::from_lookup(lookup(&[])).unwrap();
    assert_eq!(c.report_every, 30);
    assert!(c.rerun.is_none());
    let c = Config::from_lookup(lookup(&[("RERUN", "rrd"), ("OUTPUT_DIR", "o")])).unwrap();
    assert_eq!(c.rerun, Some(Sink::File("o/depth.rrd".into())));
    let c = Config::from_lookup(lookup(&[("RERUN", "rerun+http://127.0.0.1:9876/proxy")])).unwrap();
    assert!(matches!(c.rerun, Some(Sink::Connect(_))));
    for (k, v) in [
        ("REPORT_EVERY_FRAMES", "0"),
        ("REPORT_EVERY_FRAMES", "x"),
        ("ENTROPY_WINDOW", "1"),
        ("TARGET_DISTANCE_M", "-2"),
    ] {
        let err = Config::from_lookup(lookup(&[(k, v)])).unwrap_err();
        assert!(err.to_string().contains(k), "{k}={v}: {err}");
    }
}

/// Frames of a simulated wall are analysed, a report falls due every N frames and recovers the
/// injected noise; another message type and a frame of the wrong size are counted and skipped,
/// and sequence gaps are counted.
#[test]
fn frames_are_analysed_and_bad_ones_counted() {
    let sim_params = SimParams {
        noise_sd_mm: 2.0,
        seed: 4,
        ..SimParams::default()
    };
    let mut sim = Simulator::new(&Scene::wall(2.0), sim_params).unwrap();
    let mut sensors = Sensors::new(trigait_depth::MetricsParams::default(), 10);
    let mut due = 0;
    for seq in 0..30 {
        // Skip seq 7: one frame lost upstream.
        let seq = if seq >= 7 { seq + 1 } else { seq };
        match sensors.push(
            "k1",
            message(&mut sim, seq).as_ref(),
            Intrinsics::default(),
            seq as i64 * 100_000_000,
        ) {
            (Pushed::ReportDue, _) => {
                due += 1;
                assert!(sensors.report("k1", None).unwrap());
            }
            (Pushed::Analysed, _) => {}
            (Pushed::Refused, why) => panic!("{why:?}"),
        }
    }
    assert_eq!(due, 3);
    let ntp = NtpExchange::request("k1", 1, 2).encode().unwrap();
    assert_eq!(
        sensors.push("k1", ntp.as_ref(), Intrinsics::default(), 0).0,
        Pushed::Refused
    );
    let small = DepthFrameMessage {
        sensor_id: "k1".into(),
        seq: 99,
        local_stamp_nanos: 0,
        width: 4,
        height: 2,
        depth_mm: vec![1000; 8],
    }
    .encode()
    .unwrap();
    let (p, why) = sensors.push("k1", small.as_ref(), Intrinsics::default(), 0);
    assert_eq!(p, Pushed::Refused);
    assert!(why.unwrap().contains("4x2"));
    // Nothing new since the last report: no report.
    assert!(!sensors.report("k1", None).unwrap());
    let e = sensors.entry("k1").unwrap();
    assert_eq!(
        (
            e.frames_received,
            e.frames_analysed,
            e.malformed,
            e.wrong_size
        ),
        (32, 30, 1, 1)
    );
    assert_eq!((e.seq_gaps, e.reports_written), (1, 3));
    // 30 frames over seq 0..=30 at 0.1 s: 29 intervals in 3.0 s.
    assert!((e.arrival_rate_hz.unwrap() - 29.0 / 3.0).abs() < 1e-9);
    let acc = e.report.as_ref().unwrap().accuracy.as_ref().unwrap();
    let expected = (2.0_f64 * 2.0 + 1.0 / 12.0).sqrt();
    let sd = acc.temporal_sd_mm.unwrap();
    assert!((sd - expected).abs() < 0.1 * expected, "{sd}");

    let dir = scratch_dir("depth-metrics-node-test");
    let path = dir.join("depth-metrics.json");
    sensors
        .write_json(&path, &crate::devices::Devices::default())
        .unwrap();
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    assert_eq!(v["sensors"]["k1"]["frames_analysed"], 30);
    assert_eq!(v["sensors"]["k1"]["report"]["frames"], 30);
}

/// `RERUN` is off for every false word of the shared flag syntax; `true` says what it wants.
#[test]
fn rerun_off_words() {
    for off in ["off", "false", "no", "0", ""] {
        let c = Config::from_lookup(lookup(&[("RERUN", off)])).unwrap();
        assert!(c.rerun.is_none(), "RERUN={off:?}");
    }
    let err = Config::from_lookup(lookup(&[("RERUN", "true")])).unwrap_err();
    assert!(
        err.to_string().starts_with("depth-metrics: RERUN=\"true\""),
        "{err}"
    );
}

/// The loop's happy path: depth frames of two simulated sensors (a wall at 2 m with 2 mm noise
/// on `depth_k1`, one at 3 m with 4 mm on `depth_k2`, which loses frame 4) go through `run`
/// and come out in `OUTPUT_DIR/depth-metrics.json`: every frame counted and analysed, the gap
/// counted, a report every 5 frames and one at the end, each wall's distance fitted and its
/// noise recovered as the temporal SD (σ with the 1 mm quantisation, √(σ² + 1/12)); a
/// malformed message and an input that is not `depth_<sensor>` are counted, nothing else.
#[test]
fn depth_frames_in_report_out() {
    let dir = scratch_dir("depth-metrics-loop");
    let walls = [("k1", 2.0, 2.0, 1), ("k2", 3.0, 4.0, 2)];
    let mut events = Vec::new();
    for (k, (id, distance, noise, seed)) in walls.iter().enumerate() {
        let params = SimParams {
            noise_sd_mm: *noise,
            seed: *seed,
            ..SimParams::default()
        };
        let mut sim = Simulator::new(&Scene::wall(*distance), params).unwrap();
        for seq in (0..13_u64).filter(|s| *id == "k1" || *s != 4) {
            let message = DepthFrameMessage {
                sensor_id: (*id).to_owned(),
                seq,
                local_stamp_nanos: seq as i64 * 33_333_333,
                width: 512,
                height: 424,
                depth_mm: sim.next_frame().as_mm().to_vec(),
            };
            let t = seq as f64 * 0.004 + k as f64 * 0.002;
            let input = format!("depth_{id}");
            events.push(input_event(
                &dir,
                &format!("{id}_{seq}"),
                t,
                &input,
                message.encode().unwrap(),
            ));
        }
    }
    events.push(serde_json::json!(
        {"time_offset_secs": 0.06, "type": "Input", "id": "depth_k3", "data": [1, 2, 3]}
    ));
    events.push(serde_json::json!(
        {"time_offset_secs": 0.06, "type": "Input", "id": "frame_k1", "data": [1]}
    ));
    // k2's device stalls for 1.5 s (reported twice while it lasts) and comes back.
    let s = 1_000_000_000_i64;
    for (i, (state, since, at)) in [
        (SensorStatus::STREAMING, 0, 0),
        (SensorStatus::STALLED, 2 * s, 2 * s),
        (SensorStatus::STALLED, 2 * s, 3 * s),
        (SensorStatus::STREAMING, 7 * s / 2, 7 * s / 2),
    ]
    .into_iter()
    .enumerate()
    {
        let status = SensorStatus {
            sensor_id: "k2".into(),
            stamp_nanos: at,
            state: state.into(),
            detail: format!("k2 {state}"),
            since_nanos: since,
            lost_frames: 45 * i as u64,
        };
        events.push(input_event(
            &dir,
            &format!("status_{i}"),
            0.01 + i as f64 * 0.01,
            "status_k2",
            status.encode().unwrap(),
        ));
    }
    events.push(serde_json::json!({"time_offset_secs": 0.07, "type": "Stop"}));
    let (node, stream, mut rx) = init_node(
        serde_json::json!({"id": "depth-metrics", "events": events}),
        TestingOptions::default(),
    );
    let out = dir.join("out");
    let config = Config::from_lookup(lookup(&[
        ("OUTPUT_DIR", out.to_str().unwrap()),
        ("REPORT_EVERY_FRAMES", "5"),
    ]))
    .unwrap();
    let counters = crate::run(config, node, stream).unwrap();
    assert_eq!(
        (
            counters.analysed,
            counters.refused,
            counters.unknown,
            counters.statuses
        ),
        (25, 1, 1, 4)
    );
    assert!(drain_outputs(&mut rx).is_empty(), "the node has no outputs");

    let text = std::fs::read_to_string(out.join("depth-metrics.json")).unwrap();
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(v["report_every_frames"], 5);
    let k2 = &v["devices"]["k2"];
    assert_eq!(k2["state"], "streaming", "{k2}");
    assert_eq!(
        (&k2["degraded_spells"], &k2["reports"]),
        (&1.into(), &4.into())
    );
    assert!(
        (k2["degraded_secs"].as_f64().unwrap() - 1.5).abs() < 1e-9,
        "{k2}"
    );
    assert_eq!(k2["lost_frames"], 135);
    let k3 = &v["sensors"]["k3"];
    assert_eq!(
        (&k3["frames_received"], &k3["malformed"]),
        (&1.into(), &1.into())
    );
    for (id, distance, noise, _) in walls {
        let e = &v["sensors"][id];
        let frames = if id == "k1" { 13 } else { 12 };
        assert_eq!(e["frames_received"], frames, "{id}");
        assert_eq!(e["frames_analysed"], frames, "{id}");
        assert_eq!(e["seq_gaps"], u64::from(id == "k2"), "{id}");
        // At 5 and 10 frames, then the rest at the end.
        assert_eq!(e["reports_written"], 3, "{id}");
        assert_eq!(e["report"]["frames"], frames, "{id}");
        let accuracy = &e["report"]["accuracy"];
        let fitted = accuracy["target_distance_m"].as_f64().unwrap();
        assert!((fitted - distance).abs() < 0.02, "{id}: wall at {fitted} m");
        let sd = accuracy["temporal_sd_mm"].as_f64().unwrap();
        let expected = (noise * noise + 1.0 / 12.0_f64).sqrt();
        assert!(
            (sd - expected).abs() < 0.1 * expected,
            "{id}: temporal SD {sd} mm, injected {expected}"
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}
