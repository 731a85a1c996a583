//! Depth metrics over the dataflow: `dataflows/depth.yml` runs three
//! simulated sensors and one replay of the real Panoptic frames into the `depth-metrics` node;
//! the tests read its `depth-metrics.json` and `depth.rrd` back. Also `trigait depth-metrics
//! --rrd` on simulated PNGs.

// Test helpers outside `#[test]` functions panic on failure by design (clippy.toml allows it
// only inside them).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use common::{Rrd, f, run_graph};
use serde_json::Value;

const GRAPH: &str = "dataflows/depth.yml";
const MAPS: [&str; 5] = [
    "depth",
    "accuracy_zones",
    "entropy",
    "edge_band",
    "structural_residual",
];

fn report() -> (common::Run, Value) {
    let run = run_graph(GRAPH);
    let path = run.out_dir.join("depth-metrics.json");
    let text = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("{}: {e}\n--- log ---\n{}", path.display(), run.log));
    let v = serde_json::from_str(&text).unwrap();
    (run, v)
}

fn within(measured: f64, truth: f64, rel: f64) -> bool {
    (measured - truth).abs() <= rel * truth.abs()
}

/// Every sensor's frames arrived at its configured rate with none lost between source and
/// metrics: the count matches rate × the span of the sensor-clock stamps, the arrival rate
/// matches the configured one within 15 %, there are no sequence gaps and no refused frames,
/// and each sensor streamed for at least 6 s of the 12 s run.
#[test]
fn depth_frames_arrive_from_every_sensor() {
    let (_, v) = report();
    for (sensor, rate) in [("k1", 10.0), ("k2", 10.0), ("k3", 10.0), ("panoptic", 5.0)] {
        let e = &v["sensors"][sensor];
        let n = f(&e["frames_analysed"]);
        let span_s = (f(&e["last_local_stamp_nanos"]) - f(&e["first_local_stamp_nanos"])) * 1e-9;
        eprintln!(
            "{sensor}: {n} frames over {span_s:.2} s, arrival {:.2} Hz, gaps {}",
            f(&e["arrival_rate_hz"]),
            e["seq_gaps"]
        );
        assert!(n >= rate * 6.0, "{sensor}: only {n} frames: {e}");
        assert!(
            (n - (rate * span_s + 1.0)).abs() <= 0.1 * n,
            "{sensor}: {n} frames but the stamps span {span_s} s at {rate} Hz"
        );
        assert!(
            within(f(&e["arrival_rate_hz"]), rate, 0.15),
            "{sensor}: {e}"
        );
        assert_eq!(e["seq_gaps"], 0, "{sensor}");
        assert_eq!(e["malformed"], 0, "{sensor}");
        assert_eq!(e["wrong_size"], 0, "{sensor}");
        assert_eq!(e["frames_received"], e["frames_analysed"], "{sensor}");
        assert_eq!(e["report"]["frames"], e["frames_analysed"], "{sensor}");
    }
}

/// The metrics computed over the dataflow recover what the simulator injected, within the
/// library tests' 10 %: the temporal noise sd (injected σ plus the 1-mm quantisation's 1/√12)
/// of all three simulated sensors, the ring amplitude and period of the two wall sensors and
/// the wall distance.
#[test]
fn metrics_over_the_dataflow_recover_the_injected_noise() {
    let (_, v) = report();
    for (sensor, sd) in [("k1", 1.5), ("k2", 1.2), ("k3", 2.5)] {
        let acc = &v["sensors"][sensor]["report"]["accuracy"];
        let expected = (sd * sd + 1.0_f64 / 12.0).sqrt();
        let temporal = f(&acc["temporal_sd_mm"]);
        eprintln!("{sensor}: temporal sd {temporal:.3} mm (expected {expected:.3})");
        assert!(within(temporal, expected, 0.10), "{sensor}: {acc}");
    }
    for (sensor, amp, period, dist) in [("k2", 3.0, 40.0, 2.0), ("k3", 1.5, 25.0, 3.0)] {
        let s = &v["sensors"][sensor]["report"]["structural_noise"];
        eprintln!(
            "{sensor}: rings {:.3} mm / {:.2} px, plane at {:.4} m",
            f(&s["ring_amplitude_mm"]),
            f(&s["ring_period_px"]),
            f(&s["plane_distance_m"])
        );
        assert!(
            within(f(&s["ring_amplitude_mm"]), amp, 0.10),
            "{sensor}: {s}"
        );
        assert!(
            within(f(&s["ring_period_px"]), period, 0.10),
            "{sensor}: {s}"
        );
        assert!(
            (f(&s["plane_distance_m"]) - dist).abs() < 0.005,
            "{sensor}: {s}"
        );
    }
}

/// k1 images the floor from its thesis-rig pose, (−2.3, 2.135, 1.5) m looking at (0, 0, 0.5):
/// the plane the metrics fit is the floor, where the optical axis would meet it
/// (1.5 m · |d| / 1.0 m along the axis) at 90° minus the sensor's pitch — numbers that come
/// from the pose, not from anything the node was told about the floor.
#[test]
fn floor_scene_follows_the_rig_pose() {
    let (_, v) = report();
    let d = [2.3_f64, -2.135, -1.0];
    let len = d.iter().map(|x| x * x).sum::<f64>().sqrt();
    let axis_m = 1.5 * len / 1.0;
    let tilt_deg = 90.0 - (1.0 / len).asin().to_degrees();
    let s = &v["sensors"]["k1"]["report"]["structural_noise"];
    eprintln!(
        "k1 floor: plane at {:.3} m (expected {axis_m:.3}), tilt {:.2} deg (expected {tilt_deg:.2})",
        f(&s["plane_distance_m"]),
        f(&s["plane_tilt_deg"])
    );
    assert!((f(&s["plane_distance_m"]) - axis_m).abs() < 0.05, "{s}");
    assert!((f(&s["plane_tilt_deg"]) - tilt_deg).abs() < 1.0, "{s}");
    // Above the horizon and beyond 4.5 m there is no data: well under the whole image.
    let valid = f(&v["sensors"]["k1"]["report"]["valid_share"]);
    assert!(valid > 0.2 && valid < 0.8, "{valid}");
}

/// The real Panoptic frames arrive unchanged: the valid-pixel share the node reports equals
/// the mean over exactly the files it received (file `seq mod 10`), read here from the PNGs.
#[test]
fn replayed_real_frames_arrive_unchanged() {
    let (_, v) = report();
    let dir = common::workspace().join("../shared/data/kinect-v2-panoptic-10-sensors");
    let e = &v["sensors"]["panoptic"];
    let first = e["first_seq"].as_u64().unwrap();
    let n = e["frames_analysed"].as_u64().unwrap();
    let shares: Vec<f64> = (0..10)
        .map(|i| {
            trigait_depth::io::read_depth_png(&dir.join(format!("depth_{i:05}.png")))
                .unwrap()
                .valid_share()
        })
        .collect();
    let expected = (first..first + n)
        .map(|s| shares[(s % 10) as usize])
        .sum::<f64>()
        / n as f64;
    let got = f(&e["report"]["valid_share"]);
    assert!((got - expected).abs() < 1e-9, "{got} vs {expected}");
}

/// `RERUN: rrd` wrote `depth.rrd` with, per sensor, one image row per map and one scalar row per
/// report number for every report the JSON counts, and each map's legend once (static).
#[test]
fn depth_rrd_holds_the_maps() {
    let (run, v) = report();
    let Rrd {
        temporal, statics, ..
    } = Rrd::read(&run.out_dir.join("depth.rrd"));
    for sensor in ["k1", "k2", "k3"] {
        let reports = v["sensors"][sensor]["reports_written"].as_u64().unwrap();
        assert!(reports >= 2, "{sensor}: {reports} reports");
        for map in MAPS {
            let entity = format!("depth/{sensor}/maps/{map}");
            assert_eq!(
                temporal.get(&entity).copied(),
                Some(reports),
                "{entity}: {temporal:?}"
            );
            assert!(
                statics.contains_key(&format!("{entity}/legend")),
                "{entity}"
            );
        }
        for scalar in ["temporal_sd_mm", "ring_amplitude_mm", "valid_share"] {
            let entity = format!("depth/{sensor}/metrics/{scalar}");
            assert_eq!(temporal.get(&entity).copied(), Some(reports), "{entity}");
        }
    }
    let reports = v["sensors"]["panoptic"]["reports_written"]
        .as_u64()
        .unwrap();
    assert_eq!(
        temporal.get("depth/panoptic/maps/depth").copied(),
        Some(reports)
    );
}

fn scratch(name: &str) -> PathBuf {
    common::scratch_dir("depth-graph", name)
}

fn write_wall_frames(dir: &Path, frames: usize) {
    use trigait_depth::sim::{Scene, SimParams, Simulator};
    let params = SimParams {
        noise_sd_mm: 1.5,
        ring_amplitude_mm: 3.0,
        ring_period_px: 40.0,
        seed: 9,
        ..SimParams::default()
    };
    let mut sim = Simulator::new(&Scene::wall(2.0), params).unwrap();
    for i in 0..frames {
        trigait_depth::io::write_depth_png(&dir.join(format!("f{i:03}.png")), &sim.next_frame())
            .unwrap();
    }
}

/// `trigait depth-metrics DIR --rrd FILE` writes a recording rerun reads back, holding the five
/// maps of the sequence and its scalars once each; the ring amplitude logged is the one in the
/// JSON (same code path). An `--rrd` path under a regular file is a clear error.
#[test]
fn cli_rrd_writes_the_maps() {
    let dir = scratch("cli");
    let frames = dir.join("frames");
    std::fs::create_dir_all(&frames).unwrap();
    write_wall_frames(&frames, 12);
    let rrd = dir.join("maps.rrd");
    let out = Command::new(env!("CARGO_BIN_EXE_trigait"))
        .args(["depth-metrics", "--json", "--rrd"])
        .arg(&rrd)
        .arg(&frames)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["frames"], 12);
    assert!(within(
        f(&v["structural_noise"]["ring_amplitude_mm"]),
        3.0,
        0.10
    ));
    let Rrd {
        temporal, statics, ..
    } = Rrd::read(&rrd);
    for map in MAPS {
        let entity = format!("depth/sequence/maps/{map}");
        assert_eq!(
            temporal.get(&entity).copied(),
            Some(1),
            "{entity}: {temporal:?}"
        );
        assert!(statics.contains_key(&format!("{entity}/legend")));
    }
    assert_eq!(
        temporal
            .get("depth/sequence/metrics/ring_amplitude_mm")
            .copied(),
        Some(1)
    );

    let file = dir.join("plain-file");
    std::fs::write(&file, "x").unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_trigait"))
        .args(["depth-metrics", "--rrd"])
        .arg(file.join("sub/maps.rrd"))
        .arg(&frames)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--rrd") && !err.contains("panicked"), "{err}");
}
