//! Helpers shared by the whole-graph tests (`tests/dataflow.rs` and the graph tests of the
//! filter, depth and multi-machine stages): locating the dora CLI and the venv's Python, building
//! the node binaries once, running a graph headless in its own folder under
//! `target/dataflow-tests/`, and reading its `summary.json` and `.rrd` back; and, for the CLI
//! tests, running the built `trigait` and a scratch folder per test.
//!
//! Every test binary that runs graphs takes [`LOCK`] around a run, so graphs in one binary run
//! one at a time and their latencies are not measured against each other (cargo runs the test
//! binaries themselves one after another).

// Test helpers outside `#[test]` functions panic on failure by design.
#![allow(clippy::unwrap_used, clippy::expect_used, dead_code)]

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::sync::{Mutex, OnceLock};

use serde_json::Value;

pub fn workspace() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The built CLI run as `trigait <subcommand> <args…>`, its output captured.
pub fn trigait_cli(subcommand: &str, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_trigait"))
        .arg(subcommand)
        .args(args)
        .output()
        .unwrap()
}

/// The JSON on a successful run's stdout; a failed run fails the test with its stderr.
pub fn stdout_json(out: &Output) -> Value {
    assert!(
        out.status.success(),
        "exit {:?}: {}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

/// An empty folder `trigait-<tag>-<pid>-<name>` in the temporary folder, for one test's files.
pub fn scratch_dir(tag: &str, name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("trigait-{tag}-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The dora CLI: `.venv/bin/dora` when the test script made it, else `dora` on PATH.
pub fn dora() -> PathBuf {
    let venv = workspace().join(".venv/bin/dora");
    if venv.exists() {
        venv
    } else {
        PathBuf::from("dora")
    }
}

pub fn python() -> PathBuf {
    let venv = workspace().join(".venv/bin/python");
    if venv.exists() {
        venv
    } else {
        PathBuf::from("python3")
    }
}

/// Removes what cargo sets for a test process (`CARGO_PKG_*`, `CARGO_MANIFEST_DIR`, `OUT_DIR`,
/// …) so the cargo that builds the nodes — here or under `dora run`'s `build:` lines — sees the
/// environment of a plain `cargo build`: build scripts that watch such variables would
/// otherwise recompile a large part of the dependency tree.
pub fn plain_env(cmd: &mut Command) -> &mut Command {
    const KEEP: [&str; 8] = [
        "CARGO_HOME",
        "CARGO_TARGET_DIR",
        "CARGO_BUILD_",
        "CARGO_PROFILE_",
        "CARGO_REGISTR",
        "CARGO_NET_",
        "CARGO_HTTP_",
        "CARGO_TERM_",
    ];
    for (key, _) in std::env::vars_os() {
        let key = key.to_string_lossy().into_owned();
        let cargo_set = key.starts_with("CARGO_") && !KEEP.iter().any(|k| key.starts_with(k));
        if cargo_set || key == "OUT_DIR" || key == "RUST_TEST_THREADS" {
            cmd.env_remove(&key);
        }
    }
    cmd
}

/// Builds the node binaries once (release, like the graphs' `build:` lines).
pub fn build_nodes() {
    static BUILT: OnceLock<()> = OnceLock::new();
    BUILT.get_or_init(|| {
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        let mut cmd = Command::new(cargo);
        plain_env(&mut cmd);
        // The same command as the graphs' `build:` lines, so `dora run` finds it done. With
        // `--all-targets` the dev-dependencies take part in feature unification exactly as in
        // `cargo test --workspace --release`, so this reuses the test build instead of
        // compiling dora and rerun a second time with other features.
        cmd.current_dir(workspace())
            .args(["build", "--release", "--workspace", "--all-targets"]);
        let status = cmd.status().expect("running cargo build for the nodes");
        assert!(status.success(), "building the node binaries failed");
    });
}

/// One graph run.
#[derive(Debug, Clone)]
pub struct Run {
    pub success: bool,
    pub log: String,
    pub out_dir: PathBuf,
}

impl Run {
    pub fn summary(&self) -> Value {
        let path = self.out_dir.join("summary.json");
        let text = std::fs::read_to_string(&path)
            .unwrap_or_else(|e| panic!("{}: {e}\n--- log ---\n{}", path.display(), self.log));
        serde_json::from_str(&text).expect("summary.json is JSON")
    }

    /// The recorder's `trajectory.csv`, read with the reader `trigait gait` uses.
    pub fn trajectory(&self) -> trigait_motion::MotionClip {
        let path = self.out_dir.join("trajectory.csv");
        trigait_motion::read_csv(&path)
            .unwrap_or_else(|e| panic!("{}: {e}\n--- log ---\n{}", path.display(), self.log))
    }

    /// Every set `sync` sent reached the recorder, the last ones at shutdown included: the
    /// count in sync's closing log line (`sets sent N`) is the recorder's `sets_fused` (a graph
    /// without `sync` or without a summary is not checked).
    pub fn assert_sets_delivered(&self) {
        let Some(sent) = sync_sets_sent(&self.log) else {
            return;
        };
        if !self.out_dir.join("summary.json").exists() {
            return;
        }
        let s = self.summary();
        assert_eq!(
            s["sets_fused"].as_u64(),
            Some(sent),
            "sync sent {sent} sets, the recorder recorded {}:\n{}",
            s["sets_fused"],
            self.log
        );
    }

    /// No set is lost: `summary.json` counts no gap in the set sequence, every pose with a
    /// fused joint is an instant of `trajectory.csv`, and dora reported no pose or timing
    /// dropped at the recorder. The result edges of every graph
    /// (sets, poses, timings) are `queue_policy: backpressure`, which keeps them off dora's
    /// lossy direct path. Raw frames and truth may be dropped on theirs; that is printed, not
    /// fatal.
    pub fn assert_no_sets_lost(&self) {
        self.assert_sets_delivered();
        let s = self.summary();
        assert_eq!(s["dropped_sets"].as_u64(), Some(0), "summary: {s:#}");
        let clip = self.trajectory();
        let instants = (0..clip.frame_count())
            .filter(|f| {
                clip.joints()
                    .iter()
                    .any(|j| clip.position(*f, *j).is_some())
            })
            .count() as u64;
        let poses = s["sets_fused"].as_u64().unwrap() - s["empty_poses"].as_u64().unwrap();
        assert_eq!(
            instants, poses,
            "instants in trajectory.csv vs poses: {s:#}"
        );
        let drops = s["input_drops"]
            .as_object()
            .expect("input_drops in summary.json");
        let results = ["fused_pose", "frame_timing"];
        assert!(
            results.iter().all(|input| !drops.contains_key(*input)),
            "dora dropped poses or timings at the recorder: {drops:?}"
        );
        if !drops.is_empty() {
            eprintln!("raw frames or truth dora dropped at the recorder: {drops:?}");
        }
    }

    /// The `.rrd` read back once (one Python start per run).
    pub fn rrd(&self) -> Rrd {
        Rrd::read(&self.out_dir.join("trigait.rrd"))
    }
}

/// What an `.rrd` holds, per entity path.
#[derive(Debug, Clone)]
pub struct Rrd {
    /// Temporal rows.
    pub temporal: BTreeMap<String, u64>,
    /// Static rows.
    pub statics: BTreeMap<String, u64>,
    /// Entity paths of the blueprint store (the default viewer layout; empty if none).
    pub blueprint: Vec<String>,
}

impl Rrd {
    pub fn read(rrd: &Path) -> Self {
        let v = rrd_json_of(rrd);
        Self {
            temporal: row_map(&v, "temporal"),
            statics: row_map(&v, "static"),
            blueprint: row_map(&v, "blueprint").into_keys().collect(),
        }
    }
}

/// The graph text with node paths, output folder and data paths made absolute for `dir`, and
/// without its build lines (the binaries are built once, by [`build_nodes`]).
pub fn localise(graph: &str, dir: &Path) -> String {
    let ws = workspace();
    let ws = ws.display();
    let mut text = graph
        .replace(
            "path: ../target/release/",
            &format!("path: {ws}/target/release/"),
        )
        .replace(
            "path: target/release/",
            &format!("path: {ws}/target/release/"),
        )
        .replace("../../shared/data", &format!("{ws}/../shared/data"));
    // [`build_nodes`] ran the graphs' one build line already; left in, dora would run it again
    // for every node, which on a loaded 2-core machine took half a minute per graph.
    let lines: Vec<String> = text
        .lines()
        .filter(|l| !l.trim_start().starts_with("build: cargo build"))
        .map(|l| match l.find("OUTPUT_DIR:") {
            Some(i) => format!("{}OUTPUT_DIR: {}", &l[..i], dir.join("out").display()),
            None => l.to_owned(),
        })
        .collect();
    text = lines.join("\n");
    text.push('\n');
    text
}

/// `dora run graph.yml` in `dir` for `run_for` (`"12s"`), output captured: the simulated
/// sources end the run themselves (`STOP_AFTER_SECS`, which every node inherits from `dora
/// run`'s environment unless its `env:` sets it), so the graph shuts down source first and
/// every set reaches the recorder; `--stop-after` is only a safety net 30 s later.
pub fn dora_run(dir: &Path, run_for: &str) -> Command {
    let secs: u64 = run_for
        .trim_end_matches('s')
        .parse()
        .expect("run_for is whole seconds like \"12s\"");
    let mut cmd = Command::new(dora());
    plain_env(&mut cmd)
        .current_dir(dir)
        .env("STOP_AFTER_SECS", secs.to_string())
        .args([
            "run",
            "graph.yml",
            "--stop-after",
            &format!("{}s", secs + 30),
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    cmd
}

/// Starts `graph` headless in a fresh folder for `run_for` ([`dora_run`]).
pub fn spawn_graph(name: &str, graph: &str, run_for: &str) -> (Child, PathBuf) {
    build_nodes();
    let dir = workspace().join("target/dataflow-tests").join(name);
    std::fs::remove_dir_all(&dir).ok();
    std::fs::create_dir_all(&dir).expect("creating the test folder");
    let yml = dir.join("graph.yml");
    std::fs::write(&yml, localise(graph, &dir)).expect("writing the graph");
    let child = dora_run(&dir, run_for)
        .spawn()
        .expect("starting `dora run` (is the dora CLI installed? scripts/test.sh installs it)");
    (child, dir)
}

pub fn finish(child: Child, dir: PathBuf) -> Run {
    let out = child.wait_with_output().expect("waiting for dora run");
    let log = format!(
        "{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    std::fs::write(dir.join("dora-run.log"), &log).ok();
    Run {
        success: out.status.success(),
        log,
        out_dir: dir.join("out"),
    }
}

pub static LOCK: Mutex<()> = Mutex::new(());

/// Runs a committed graph (cached: tests that need the same run share it).
pub fn run_graph(file: &str) -> Run {
    static CACHE: OnceLock<Mutex<HashMap<String, Run>>> = OnceLock::new();
    let cache = CACHE.get_or_init(|| Mutex::new(HashMap::new()));
    let _guard = LOCK.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(run) = cache.lock().unwrap_or_else(|e| e.into_inner()).get(file) {
        return run.clone();
    }
    let run = run_committed(file);
    cache
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .insert(file.to_owned(), run.clone());
    run
}

/// Runs a committed graph once more, not from the cache (the cached run is left as it was).
pub fn run_graph_again(file: &str) -> Run {
    let _guard = LOCK.lock().unwrap_or_else(|e| e.into_inner());
    run_committed(file)
}

/// One headless run of a committed graph; the caller holds [`LOCK`].
fn run_committed(file: &str) -> Run {
    let graph = std::fs::read_to_string(workspace().join(file)).expect("reading the graph");
    let name = file.replace(['/', '.'], "-");
    // `dataflow.yml` carries the RMSE acceptance (within 1.2x of `trigait eval`): over 12 s,
    // 2.4 laps of the 5 s walker, which part of a lap the run ends in moved the RMSE between
    // 20.2 and 25.9 mm in ten runs (eval: 19.0); five 24 s runs stayed within 20.6-21.8 mm.
    let stop_after = if file == "dataflow.yml" { "24s" } else { "12s" };
    let (child, dir) = spawn_graph(&name, &graph, stop_after);
    let run = finish(child, dir);
    assert!(run.success, "dora run {file} failed:\n{}", run.log);
    run.assert_sets_delivered();
    run
}

/// The `N` of sync's closing log line `… sets sent N (…`, if the log has one.
pub fn sync_sets_sent(log: &str) -> Option<u64> {
    let rest = &log[log.rfind("sets sent ")? + "sets sent ".len()..];
    rest.split(|c: char| !c.is_ascii_digit())
        .next()?
        .parse()
        .ok()
}

/// Median |second difference| (mm) of the hip trajectories over consecutive aligned sets, in a
/// recorder's `trajectory.csv`; with the count of differences. Hips move smoothly (≈ 1 m/s², ≈
/// 1 mm per frame² at 30 Hz), so this is mostly pose jitter; the median ignores the
/// instantaneous turn at each end of the simulated walkway, which is a real (and equal) jump in
/// both graphs.
pub fn hip_jitter_mm(clip: &trigait_motion::MotionClip) -> (f64, usize) {
    use trigait_skeleton::Joint;
    let hips = [Joint::HipLeft, Joint::HipRight];
    assert!(
        hips.iter().all(|j| clip.joints().contains(j)),
        "hip_left and hip_right in trajectory.csv: {:?}",
        clip.joints()
    );
    let mut d2 = Vec::new();
    for joint in hips {
        for f in 0..clip.frame_count().saturating_sub(2) {
            let (Some(p), Some(a), Some(b)) = (
                clip.position(f, joint),
                clip.position(f + 1, joint),
                clip.position(f + 2, joint),
            ) else {
                continue;
            };
            for k in 0..3 {
                d2.push(((b[k] - 2.0 * a[k] + p[k]) * 1e3).abs());
            }
        }
    }
    assert!(d2.len() > 1000, "only {} second differences", d2.len());
    d2.sort_by(f64::total_cmp);
    (d2[d2.len() / 2], d2.len())
}

pub fn f(v: &Value) -> f64 {
    v.as_f64().unwrap_or(f64::NAN)
}

/// The pid of the process of graph run `dir` (dora's working directory for its nodes) whose
/// command line contains `binary` and, if given, whose environment holds `env` (`SENSOR_ID=k2`);
/// waits for it up to a minute.
pub fn node_pid(dir: &Path, binary: &str, env: Option<&str>) -> u32 {
    let start = std::time::Instant::now();
    loop {
        let found = pids().into_iter().find(|pid| {
            let cwd = std::fs::read_link(format!("/proc/{pid}/cwd")).unwrap_or_default();
            let cmd = std::fs::read(format!("/proc/{pid}/cmdline")).unwrap_or_default();
            let environ = std::fs::read(format!("/proc/{pid}/environ")).unwrap_or_default();
            cwd == dir
                && String::from_utf8_lossy(&cmd).contains(binary)
                && env.is_none_or(|env| environ.split(|b| *b == 0).any(|kv| kv == env.as_bytes()))
        });
        if let Some(pid) = found {
            return pid;
        }
        assert!(
            start.elapsed() < std::time::Duration::from_secs(60),
            "no {binary} process ({env:?}) in {}",
            dir.display()
        );
        std::thread::sleep(std::time::Duration::from_millis(100));
    }
}

/// Waits until the run in `dir` has streamed (its `.rrd` passed 300 kB: poses are being
/// recorded), up to a minute.
pub fn wait_until_streaming(dir: &Path) {
    let start = std::time::Instant::now();
    let rrd = dir.join("out/trigait.rrd");
    while std::fs::metadata(&rrd).map_or(0, |m| m.len()) < 300_000 {
        assert!(
            start.elapsed() < std::time::Duration::from_secs(60),
            "the graph never streamed"
        );
        std::thread::sleep(std::time::Duration::from_millis(100));
    }
}

/// Sends SIGKILL to `pid`.
pub fn kill_9(pid: u32) {
    let status = Command::new("kill")
        .args(["-9", &pid.to_string()])
        .status()
        .expect("running kill");
    assert!(status.success(), "kill -9 {pid} failed");
}

pub fn pids() -> Vec<u32> {
    std::fs::read_dir("/proc")
        .into_iter()
        .flatten()
        .flatten()
        .filter_map(|e| e.file_name().to_string_lossy().parse().ok())
        .collect()
}

/// What `scripts/rrd_rows.py` prints for any `.rrd`: temporal, static and blueprint rows per
/// entity path.
pub fn rrd_json_of(rrd: &Path) -> Value {
    python_json("scripts/rrd_rows.py", rrd)
}

/// What `scripts/rrd_blueprint.py` prints for an `.rrd`: the views of its default layout
/// (class, name, origin, content queries, properties), the viewport, and every annotation
/// context with the keypoints it declares and the keypoints the points log.
pub fn rrd_blueprint_of(rrd: &Path) -> Value {
    python_json("scripts/rrd_blueprint.py", rrd)
}

fn python_json(script: &str, rrd: &Path) -> Value {
    let out = Command::new(python())
        .arg(workspace().join(script))
        .arg(rrd)
        .output()
        .unwrap_or_else(|e| panic!("running {script}: {e}"));
    assert!(
        out.status.success(),
        "reading {} back with {script} failed: {}",
        rrd.display(),
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("{script} prints JSON: {e}"))
}

fn row_map(v: &Value, key: &str) -> BTreeMap<String, u64> {
    v[key]
        .as_object()
        .map(|o| {
            o.iter()
                .map(|(k, n)| (k.clone(), n.as_u64().unwrap_or(0)))
                .collect()
        })
        .unwrap_or_default()
}
