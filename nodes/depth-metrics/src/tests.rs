//! Contracts of the `depth-metrics` node's config and per-sensor state.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use trigait_depth::sim::{Scene, SimParams, Simulator};
use trigait_depth_rerun::Sink;
use trigait_node_testing::lookup;
use trigait_schema::{ArrayRef, DepthFrameMessage, Message, NtpExchange};

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
    assert_eq!(sensors.push("k1", ntp.as_ref(), 0).0, Pushed::Refused);
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
    let (p, why) = sensors.push("k1", small.as_ref(), 0);
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

    let dir = std::env::temp_dir().join("trigait-depth-metrics-node-test");
    let path = dir.join("depth-metrics.json");
    sensors.write_json(&path).unwrap();
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    assert_eq!(v["sensors"]["k1"]["frames_analysed"], 30);
    assert_eq!(v["sensors"]["k1"]["report"]["frames"], 30);
}
