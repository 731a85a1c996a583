//! Every committed graph is a valid dora dataflow without running it (`dora validate`: the
//! descriptor, and every input wired to an output its node declares), including the graphs
//! for hardware no test machine has; and `dataflows/freenect2.yml` has the wiring of
//! `dataflows/depth-tracking.yml` with real sensors.

// Test helpers outside `#[test]` functions panic on failure by design.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use serde_yaml::Value;

mod common;

use common::{dora, workspace};

/// `dataflow.yml` and every `.yml` in `dataflows/`.
fn graphs() -> Vec<PathBuf> {
    let mut files = vec![workspace().join("dataflow.yml")];
    let mut dir: Vec<PathBuf> = std::fs::read_dir(workspace().join("dataflows"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "yml"))
        .collect();
    dir.sort();
    files.extend(dir);
    files
}

/// `dora validate` on `file`: its success and what it printed.
fn validate(file: &Path) -> (bool, String) {
    let out = Command::new(dora())
        .args(["validate", "--offline"])
        .arg(file)
        .env("RUST_BACKTRACE", "0")
        .output()
        .expect("running dora validate (is the dora CLI on PATH or in .venv?)");
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    (out.status.success(), text)
}

/// Every graph passes; a graph with one input renamed to an output nobody declares does not
/// (so a pass means the wiring was checked).
#[test]
fn every_graph_passes_dora_validate() {
    let files = graphs();
    assert!(files.len() >= 12, "{files:?}");
    let mut failed = Vec::new();
    for file in &files {
        let (ok, text) = validate(file);
        if !ok || !text.contains("wiring OK") {
            failed.push(format!("{}:\n{text}", file.display()));
        }
    }
    assert!(failed.is_empty(), "{}", failed.join("\n"));

    let good = std::fs::read_to_string(workspace().join("dataflows/freenect2.yml")).unwrap();
    let bad = good.replacen("source: k2/depth", "source: k2/depth_mm", 1);
    assert_ne!(good, bad);
    let dir = std::env::temp_dir().join(format!("trigait-graphs-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("miswired.yml");
    std::fs::write(&path, bad).unwrap();
    let (ok, text) = validate(&path);
    let _ = std::fs::remove_dir_all(&dir);
    assert!(!ok, "a miswired graph passed:\n{text}");
    assert!(text.contains("k2/depth_mm"), "{text}");
}

fn load(file: &str) -> Value {
    serde_yaml::from_str(&std::fs::read_to_string(workspace().join(file)).unwrap()).unwrap()
}

/// The nodes of a graph by id.
fn nodes(graph: &Value) -> BTreeMap<String, Value> {
    graph["nodes"]
        .as_sequence()
        .unwrap()
        .iter()
        .map(|n| (n["id"].as_str().unwrap().to_owned(), n.clone()))
        .collect()
}

/// Each input of a node as `name → source` (`queue_size` and policy aside).
fn inputs(node: &Value) -> BTreeMap<String, String> {
    node["inputs"]
        .as_mapping()
        .map(|m| {
            m.iter()
                .map(|(k, v)| {
                    let source = v.as_str().or_else(|| v["source"].as_str()).unwrap();
                    (k.as_str().unwrap().to_owned(), source.to_owned())
                })
                .collect()
        })
        .unwrap_or_default()
}

fn outputs(node: &Value) -> Vec<String> {
    node["outputs"]
        .as_sequence()
        .map(|s| s.iter().map(|o| o.as_str().unwrap().to_owned()).collect())
        .unwrap_or_default()
}

fn binary(node: &Value) -> &str {
    node["path"].as_str().unwrap().rsplit('/').next().unwrap()
}

fn env<'a>(node: &'a Value, key: &str) -> Option<&'a str> {
    node["env"][key].as_str()
}

/// The real-sensor graph is the depth-tracking graph with `freenect2` sources: the same nodes
/// running the same binaries, wired the same way (a tracker per sensor on its source's
/// depth, sync on the trackers' frames and the sources' NTP replies, trilaterate, recorder),
/// minus the simulated ground truth, with trackers for mirrored images and a fitted floor,
/// plus `depth-metrics` on the real depth and device status.
#[test]
fn freenect2_graph_has_the_depth_tracking_wiring() {
    let sim = nodes(&load("dataflows/depth-tracking.yml"));
    let real = nodes(&load("dataflows/freenect2.yml"));
    let mut real_ids: Vec<&String> = real.keys().collect();
    real_ids.retain(|id| *id != "depth-metrics");
    assert_eq!(real_ids, sim.keys().collect::<Vec<_>>());
    for (id, s) in &sim {
        let r = &real[id];
        assert_eq!(binary(r), binary(s), "{id}");
        let mut expected = inputs(s);
        if id == "recorder" {
            assert_eq!(
                expected.remove("ground_truth").as_deref(),
                Some("k1/ground_truth")
            );
        }
        assert_eq!(inputs(r), expected, "{id}'s inputs");
        if binary(s) == "trigait-kinect-source-node" {
            assert_eq!(env(r, "BACKEND"), Some("freenect2"), "{id}");
            assert_eq!(env(r, "SENSOR_ID"), Some(id.as_str()));
            let outs = outputs(r);
            for o in ["depth", "ntp_reply", "status"] {
                assert!(
                    outs.iter().any(|x| x == o),
                    "{id} lacks output {o}: {outs:?}"
                );
            }
        }
        if binary(s) == "trigait-leg-tracker-node" {
            assert_eq!(env(r, "SENSOR_ID"), env(s, "SENSOR_ID"), "{id}");
            assert_eq!(
                env(r, "MIRRORED"),
                Some("true"),
                "{id}: libfreenect2 mirrors"
            );
            assert_eq!(env(r, "FLOOR"), Some("fit"), "{id}");
            assert_eq!(outputs(r), outputs(s), "{id}");
        }
        if id == "sync" || id == "trilaterate" {
            assert_eq!(outputs(r), outputs(s), "{id}");
            for key in ["POLICY", "FUSION_RATE_HZ", "METHOD"] {
                assert_eq!(env(r, key), env(s, key), "{id}: {key}");
            }
        }
    }
    let metrics = inputs(&real["depth-metrics"]);
    for k in ["k1", "k2", "k3"] {
        assert_eq!(metrics[&format!("depth_{k}")], format!("{k}/depth"));
        assert_eq!(metrics[&format!("status_{k}")], format!("{k}/status"));
    }
    // The rig is one and the same wherever a node names it.
    let rigs: std::collections::BTreeSet<&str> =
        real.values().filter_map(|n| env(n, "RIG")).collect();
    assert_eq!(rigs.len(), 1, "{rigs:?}");
}
