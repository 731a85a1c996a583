//! The multi-machine graph (`dataflows/multi-machine.yml`, dora `deploy: machine:`) started the
//! way the thesis deployment is (§6.2): a `dora coordinator`, one `dora daemon` per machine and
//! `dora start`, here with two daemons on loopback — `sensors` runs the three sources (the
//! graph's `kinect1..3`), `server` runs sync, trilaterate and recorder — so every frame and every
//! NTP exchange crosses from one daemon to the other over zenoh, as it would over a LAN.

// Test helpers outside `#[test]` functions panic on failure by design.
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use common::{LOCK, Run, build_nodes, dora, f, localise, plain_env, workspace};
use serde_json::Value;

/// Kills the coordinator and daemons when the test ends, also when it fails.
struct Cluster {
    children: Vec<Child>,
    port: u16,
}

impl Drop for Cluster {
    fn drop(&mut self) {
        for child in &mut self.children {
            child.kill().ok();
            child.wait().ok();
        }
    }
}

impl Cluster {
    fn start(dir: &Path) -> Self {
        // Ports of our own, so a dora already running on the defaults is not disturbed.
        let base = 20_000 + u16::try_from(std::process::id() % 20_000).unwrap();
        let port = base;
        let zenoh = format!("tcp/127.0.0.1:{}", base + 3);
        let spawn = |args: Vec<String>, log: &str| -> Child {
            let log = std::fs::File::create(dir.join(log)).unwrap();
            plain_env(&mut Command::new(dora()))
                .current_dir(dir)
                // The simulated sources end the run 12 s after their first frame (the nodes
                // inherit their daemon's environment), so the graph shuts down source first
                // and every set reaches the recorder.
                .env("STOP_AFTER_SECS", "12")
                .args(args)
                .stdout(log.try_clone().unwrap())
                .stderr(log)
                .spawn()
                .expect("starting dora (scripts/test.sh installs the CLI)")
        };
        let mut cluster = Cluster {
            children: Vec::new(),
            port,
        };
        cluster.children.push(spawn(
            vec![
                "coordinator".into(),
                "--port".into(),
                port.to_string(),
                "--store".into(),
                "memory".into(),
            ],
            "coordinator.log",
        ));
        std::thread::sleep(Duration::from_secs(1));
        for (i, machine) in ["server", "sensors"].into_iter().enumerate() {
            cluster.children.push(spawn(
                vec![
                    "daemon".into(),
                    "--machine-id".into(),
                    machine.into(),
                    "--coordinator-port".into(),
                    port.to_string(),
                    "--local-listen-port".into(),
                    (base + 1 + u16::try_from(i).unwrap()).to_string(),
                    "--zenoh-peer".into(),
                    zenoh.clone(),
                ],
                &format!("daemon-{machine}.log"),
            ));
        }
        std::thread::sleep(Duration::from_secs(2));
        cluster
    }

    /// The machine whose daemon `pid` descends from (`/proc/<pid>/stat`, parent by parent).
    fn daemon_of(&self, mut pid: u32) -> Option<&'static str> {
        let daemons: Vec<(u32, &'static str)> = self.children[1..]
            .iter()
            .map(Child::id)
            .zip(["server", "sensors"])
            .collect();
        for _ in 0..16 {
            if let Some((_, machine)) = daemons.iter().find(|(d, _)| *d == pid) {
                return Some(machine);
            }
            let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
            // `pid (comm) state ppid …`; comm may hold spaces, so split after its `)`.
            pid = stat
                .rsplit_once(')')?
                .1
                .split_whitespace()
                .nth(1)?
                .parse()
                .ok()?;
        }
        None
    }

    fn cli(&self, dir: &Path, args: &[&str]) -> (bool, String) {
        let out = plain_env(&mut Command::new(dora()))
            .current_dir(dir)
            .args(args)
            .args(["--coordinator-port", &self.port.to_string()])
            .stdin(Stdio::null())
            .output()
            .expect("running the dora CLI");
        (
            out.status.success(),
            format!(
                "{}{}",
                String::from_utf8_lossy(&out.stdout),
                String::from_utf8_lossy(&out.stderr)
            ),
        )
    }
}

#[test]
fn multi_machine_graph_runs_on_two_daemons() {
    let _guard = LOCK.lock().unwrap_or_else(|e| e.into_inner());
    build_nodes();
    let dir = workspace().join("target/dataflow-tests/multi-machine");
    std::fs::remove_dir_all(&dir).ok();
    std::fs::create_dir_all(&dir).unwrap();
    let graph = std::fs::read_to_string(workspace().join("dataflows/multi-machine.yml")).unwrap();
    assert!(graph.contains("machine: kinect1") && graph.contains("machine: server"));
    // Three sensor PCs become one `sensors` daemon; the binaries are built already, so the
    // daemons get no build lines to run.
    let text: String = localise(&graph, &dir)
        .lines()
        .filter(|l| !l.trim_start().starts_with("build:"))
        .map(|l| {
            if l.trim_start().starts_with("machine: kinect") {
                l.split("machine:").next().unwrap_or_default().to_owned() + "machine: sensors"
            } else {
                l.to_owned()
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    std::fs::write(dir.join("graph.yml"), text + "\n").unwrap();

    let cluster = Cluster::start(&dir);
    let (ok, log) = cluster.cli(
        &dir,
        &["start", "graph.yml", "--name", "trigait-mm", "--detach"],
    );
    assert!(ok, "dora start failed:\n{log}");
    std::thread::sleep(Duration::from_secs(6));
    // Where each node runs: its process descends from the daemon of its machine.
    let (ok, nodes) = cluster.cli(
        &dir,
        &[
            "node",
            "list",
            "--dataflow",
            "trigait-mm",
            "--format",
            "json",
        ],
    );
    assert!(ok, "dora node list failed:\n{nodes}");
    let placed: Vec<(String, Option<&str>)> = nodes
        .lines()
        .filter_map(|l| serde_json::from_str::<Value>(l).ok())
        .map(|n| {
            let pid = n["pid"].as_str().and_then(|p| p.parse().ok()).unwrap_or(0);
            (
                n["node"].as_str().unwrap_or_default().to_owned(),
                cluster.daemon_of(pid),
            )
        })
        .collect();
    // The recorder rewrites summary.json as the run goes; the final one says `complete`.
    let out_dir = dir.join("out");
    let summary = out_dir.join("summary.json");
    let complete = || {
        std::fs::read_to_string(&summary)
            .ok()
            .and_then(|t| serde_json::from_str::<Value>(&t).ok())
            .is_some_and(|s| s["complete"] == true)
    };
    let start = Instant::now();
    while !complete() && start.elapsed() < Duration::from_secs(40) {
        std::thread::sleep(Duration::from_millis(200));
    }
    let (_, list_log) = cluster.cli(&dir, &["list"]);
    // The daemons keep each node's output in `_work/<daemon>/out/<dataflow>/log_<node>.jsonl`.
    let sync_log = find_file(&dir.join("_work"), "log_sync.jsonl")
        .and_then(|p| std::fs::read_to_string(p).ok())
        .unwrap_or_default();
    drop(cluster);
    let run = Run {
        success: true,
        log: format!("{log}\n{list_log}\n{sync_log}"),
        out_dir,
    };
    let s = run.summary();
    assert_eq!(s["complete"], true, "the run did not end on its own: {s:#}");
    assert!(
        common::sync_sets_sent(&sync_log).is_some(),
        "no closing line of sync in its daemon log"
    );
    run.assert_sets_delivered();
    eprintln!(
        "multi-machine on loopback: sets {}, RMSE {:.4} m, latency {:#}",
        s["sets_fused"],
        f(&s["rmse_all_m"]),
        s["latency_ms"]
    );
    assert!(s["sets_fused"].as_u64().unwrap() >= 200, "{s:#}");
    for k in ["k1", "k2", "k3"] {
        assert!(s["frames_in"][k].as_u64().unwrap_or(0) >= 200, "{k}: {s:#}");
        // Synchronised across daemons: the NTP exchange crossed zenoh and converged.
        let ntp = &s["ntp"][k];
        assert!(f(&ntp["abs_error_ms"]["p50"]) < 1.0, "{k}: {ntp:#}");
    }
    assert!(f(&s["rmse_all_m"]) < 0.05, "{s:#}");
    let temporal = run.rrd().temporal;
    assert_eq!(
        temporal.get("world/fused").copied(),
        s["sets_fused"].as_u64()
    );
    // Each node ran on the daemon its machine names.
    for (machine, node) in [
        ("sensors", "k1"),
        ("sensors", "k2"),
        ("sensors", "k3"),
        ("server", "sync"),
        ("server", "trilaterate"),
        ("server", "recorder"),
    ] {
        assert!(
            placed.contains(&(node.to_owned(), Some(machine))),
            "{node} not on {machine}: {placed:?}\n{nodes}"
        );
    }
}

/// The first file named `name` under `dir`, depth first.
fn find_file(dir: &Path, name: &str) -> Option<std::path::PathBuf> {
    for entry in std::fs::read_dir(dir).ok()?.flatten() {
        let path = entry.path();
        if path.is_dir() {
            if let Some(found) = find_file(&path, name) {
                return Some(found);
            }
        } else if path.file_name().is_some_and(|n| n == name) {
            return Some(path);
        }
    }
    None
}
