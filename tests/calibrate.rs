//! `trigait calibrate` as a command (its output, and how it ends when the reader goes away),
//! and `dataflows/calibrate.yml`, the graph that calibrates the rig from a live run.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::process::{Command, Stdio};

use common::{LOCK, finish, spawn_graph, workspace};

fn trigait() -> Command {
    Command::new(env!("CARGO_BIN_EXE_trigait"))
}

/// Runs `args` with its stdout a pipe whose reader is already closed (`… | head -1` once head
/// has its line): the command ends as it would have, without a panic or an error.
fn survives_a_closed_pipe(args: &[&str]) {
    let mut child = trigait()
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{args:?}: {:?}\n{stderr}", out.status);
    assert!(
        !stderr.contains("panic") && !stderr.contains("error"),
        "{args:?}: {stderr}"
    );
}

/// `trigait calibrate --json | head -1` and the table the same way; `trigait eval` shares the
/// writer.
#[test]
fn closed_stdout_ends_quietly() {
    survives_a_closed_pipe(&["calibrate", "--json"]);
    survives_a_closed_pipe(&["calibrate"]);
    survives_a_closed_pipe(&["eval", "--trials", "1", "--json"]);
}

/// `trigait calibrate --json` reports the fusion RMSE of a fresh draw of the walk with the
/// calibrated rig and with the true rig; on ring-6 from a rig 30 cm and 20° off, the first is
/// within 1.1× the second.
#[test]
fn reports_fusion_rmse_within_the_bound() {
    let out = trigait()
        .args(["calibrate", "--rig", "ring-6", "--laps", "3", "--json"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let calibrated = report["fusion_rmse_calibrated_m"].as_f64().unwrap();
    let truth = report["fusion_rmse_true_m"].as_f64().unwrap();
    eprintln!("fusion RMSE {calibrated:.5} m vs {truth:.5} m");
    assert!(truth > 0.005 && calibrated <= 1.1 * truth, "{report:#}");
    assert_eq!(report["poses"].as_array().unwrap().len(), 6);
}

/// `dataflows/calibrate.yml` on a 10 s run of the simulated walk, calibrating from the data
/// alone after 8 s: it writes `out/rig.calibrated.yml`, a rig file the graphs read, whose
/// sensors lie at the true rig's distances from each other within 2 cm (what the walk fixes
/// whatever the world frame), and `out/calibration.json`, the report. The simulated walk comes
/// back on a second lane 1 m to the side, so the floor's tilt across the walk is observed: no
/// rotation is reported unobservable, and each sensor's height lies within 3σ (its reported
/// uncertainty) and 3 cm of the truth.
#[test]
fn calibrate_graph_writes_the_calibrated_rig() {
    let _guard = LOCK.lock().unwrap_or_else(|e| e.into_inner());
    let graph = std::fs::read_to_string(workspace().join("dataflows/calibrate.yml")).unwrap();
    let (child, dir) = spawn_graph("calibrate-graph", &graph, "10s");
    let run = finish(child, dir);
    assert!(run.success, "calibrate.yml failed:\n{}", run.log);
    let path = run.out_dir.join("rig.calibrated.yml");
    let text = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("{}: {e}\n{}", path.display(), run.log));
    let got = trigait_rig::Rig::from_yaml_str(&text, "rig.calibrated.yml").unwrap();
    let truth = trigait_rig::Rig::builtin("thesis").unwrap();
    let position = |rig: &trigait_rig::Rig, id: &str| {
        rig.sensors
            .iter()
            .find(|s| s.id == id)
            .unwrap_or_else(|| panic!("{id} missing in {text}"))
            .world_from_kinect
            .translation
            .vector
    };
    let report: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(run.out_dir.join("calibration.json")).unwrap(),
    )
    .unwrap();
    let findings = report["findings"].as_array().unwrap();
    assert!(
        !findings.iter().any(|f| f["kind"] == "unobservable"),
        "{findings:#?}"
    );
    for id in ["k1", "k2", "k3"] {
        let (g, t) = (position(&got, id), position(&truth, id));
        let sensor = report["sensors"]
            .as_array()
            .unwrap()
            .iter()
            .find(|s| s["id"] == id)
            .unwrap();
        let sigma_z = sensor["position_sigma_m"][2].as_f64().unwrap();
        eprintln!("{id}: calibrated {g:.3?}, true {t:.3?}, σz {sigma_z:.3} m");
        assert!(
            (g.z - t.z).abs() < (3.0 * sigma_z + 0.005).min(0.03),
            "{id}: height {:.3} m, truth {:.3} m, σ {sigma_z:.3} m",
            g.z,
            t.z
        );
    }
    for (a, b) in [("k1", "k2"), ("k1", "k3"), ("k2", "k3")] {
        let d = (position(&got, a) - position(&got, b)).norm();
        let t = (position(&truth, a) - position(&truth, b)).norm();
        eprintln!("{a}-{b}: {d:.4} m, truth {t:.4} m");
        assert!((d - t).abs() < 0.02, "{a}-{b}: {d:.3} m, truth {t:.3} m");
    }
    // The recorder kept the raw trial next to it.
    assert!(run.out_dir.join("frames.csv").exists());
}

/// `trigait calibrate --rrd` writes a rerun recording the viewer reads back (rerun-sdk's
/// reader, `scripts/rrd_rows.py`): every sensor and its track before (the rough rig) and after,
/// and the adjusted joints.
#[test]
fn rrd_shows_sensors_and_tracks_before_and_after() {
    let rrd = workspace().join("target/calibrate-tests/view.rrd");
    std::fs::remove_file(&rrd).ok();
    let out = trigait()
        .args(["calibrate", "--rig", "ring-6", "--rrd"])
        .arg(&rrd)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let rows = common::rrd_json_of(&rrd);
    let static_rows = rows["static"].as_object().unwrap();
    let mut expected = vec!["after/joints".to_owned()];
    for stage in ["before", "after"] {
        for k in 1..=6 {
            for what in ["sensors/k{k}", "sensors/k{k}/view", "tracks/k{k}"] {
                expected.push(format!("{stage}/{}", what.replace("{k}", &k.to_string())));
            }
        }
    }
    for path in &expected {
        assert!(
            static_rows.contains_key(path.as_str()),
            "{path} missing: {static_rows:?}"
        );
    }
}
