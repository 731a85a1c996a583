//! `recorder` configuration, read from the node's `env:` block.
//!
//! | env var | type | default | meaning |
//! |---|---|---|---|
//! | `OUTPUT_DIR` | path | `out` | where `summary.json`, `trajectory.txt` (thesis format), `trajectory.csv`/`.trc`/`.c3d` and the gait report `report.html` go |
//! | `RRD` | path or `none` | `<OUTPUT_DIR>/trigait.rrd` | the rerun recording file |
//! | `RERUN_CONNECT` | gRPC url | none | also stream to a running viewer (`rerun+http://127.0.0.1:9876/proxy`); never blocks when none is there |
//! | `RIG` | `thesis`, `ring-N` or YAML path | `thesis` | sensor poses drawn as axes and frusta; must be the sources' rig (checked against the stamp on every pose and timing; a mismatch stops the node naming both) |
//! | `RING_CAPACITY` | integer | `1000` | positions kept per joint (thesis: 1000) for the thesis text export |
//! | `RECORD_FRAMES` | bool | `true` | also write the raw recording: `frames.csv` (every frame of every sensor, sensor-local and server time), `poses.csv` (every fused joint at its absolute instant) and `rig.yml` ([`crate::recording`]) |
//! | `WARMUP_SECS` | seconds ≥ 0 | `1` | poses this soon after the first are warm-up: their latency is reported apart from the steady state (`summary.json`: `warmup`) |
//! | `LIVE_UPDATE_SECS` | seconds, 0 or 0.1–60 | `0.5` | bring `trajectory.csv`, `summary.json` (`"complete": false`), the raw recording and the `.rrd` up to date this often while the run goes, so a killed recorder loses at most about that much; the writes run on a writer thread, never on the event loop ([`crate::writer`]); `0`: only at the end |
//! | `RECORDING` | path | none | in a replay graph, the recording its sources play: an `OUTPUT_DIR` that is its folder is refused, as the replay's own recording would overwrite it |
//!
//! Inputs: `fused_pose`, `frame_timing` (every raw frame `sync` received, joints included) and
//! `ground_truth` (from the one simulated source that sends it; optional) — the same three
//! whatever the number of sensors.

use std::path::{Path, PathBuf};

use eyre::bail;
use trigait_node_config::{env_flag, env_number_where, env_rig, env_value};
use trigait_rig::Rig;

/// Env var: output directory.
pub const OUTPUT_DIR: &str = "OUTPUT_DIR";
/// Env var: rrd path.
pub const RRD: &str = "RRD";
/// Env var: viewer url.
pub const RERUN_CONNECT: &str = "RERUN_CONNECT";
/// Env var: ring capacity.
pub const RING_CAPACITY: &str = "RING_CAPACITY";
/// Env var: write the raw recording.
pub const RECORD_FRAMES: &str = "RECORD_FRAMES";
/// Env var: warm-up length.
pub const WARMUP_SECS: &str = "WARMUP_SECS";
/// Env var: how often the files are updated while the run goes.
pub const LIVE_UPDATE_SECS: &str = "LIVE_UPDATE_SECS";
/// Env var: the recording a replay graph plays (the sources' `RECORDING`).
pub const RECORDING: &str = "RECORDING";

/// How often the files are updated while the run goes unless told, seconds: a kill loses at
/// most this plus the time the writer thread takes.
pub const DEFAULT_LIVE_UPDATE_SECS: f64 = 0.5;

/// Every variable the node reads, to spot a misspelt one.
const SETTINGS: &[&str] = &[
    OUTPUT_DIR,
    RRD,
    RERUN_CONNECT,
    RING_CAPACITY,
    RECORD_FRAMES,
    WARMUP_SECS,
    LIVE_UPDATE_SECS,
    RECORDING,
    trigait_node_config::RIG,
];

const NODE: &str = "recorder";

/// The node's configuration.
#[derive(Debug, Clone)]
pub struct Config {
    /// Output directory.
    pub out_dir: PathBuf,
    /// The `.rrd` file, if any.
    pub rrd: Option<PathBuf>,
    /// A viewer to stream to, if any.
    pub connect: Option<String>,
    /// The rig.
    pub rig: Rig,
    /// Positions kept per joint.
    pub ring_capacity: usize,
    /// Warm-up after the first pose, ns ([`crate::stats::Stats::new`]).
    pub warmup_nanos: i64,
    /// How often the files are updated while the run goes, ns (`None`: only at the end).
    pub live_update_nanos: Option<i64>,
    /// Write the raw recording ([`crate::recording`]).
    pub record_frames: bool,
}

impl Config {
    /// From the process environment.
    pub fn from_env() -> eyre::Result<Self> {
        trigait_node_config::warn_misspelt_settings(NODE, SETTINGS);
        Self::from_lookup(|k| std::env::var(k).ok())
    }

    /// From any lookup (tests).
    pub fn from_lookup(lookup: impl Fn(&str) -> Option<String>) -> eyre::Result<Self> {
        let out_dir = PathBuf::from(lookup(OUTPUT_DIR).unwrap_or_else(|| "out".into()));
        let rrd = match lookup(RRD) {
            None => Some(out_dir.join("trigait.rrd")),
            Some(s) if s.trim() == "none" => None,
            Some(s) => Some(PathBuf::from(s)),
        };
        let connect = lookup(RERUN_CONNECT).filter(|s| !s.trim().is_empty());
        if let Some(url) = &connect
            && !(url.starts_with("rerun+http://")
                || url.starts_with("rerun+https://")
                || url.starts_with("rerun://"))
        {
            bail!(
                "{NODE}: {RERUN_CONNECT}={url:?} is invalid: expected a rerun gRPC proxy url like rerun+http://127.0.0.1:9876/proxy"
            );
        }
        if let Some(recording) = lookup(RECORDING).filter(|s| !s.trim().is_empty()) {
            check_not_over(&out_dir, Path::new(recording.trim()))?;
        }
        let rig = env_rig(NODE, &lookup)?;
        let ring_capacity = env_value(
            NODE,
            &lookup,
            RING_CAPACITY,
            |n: &usize| *n > 0,
            "a positive integer",
        )?
        .unwrap_or(1000);
        let warmup_secs = env_number_where(
            NODE,
            &lookup,
            WARMUP_SECS,
            1.0,
            |s| (0.0..=3600.0).contains(&s),
            "seconds between 0 and 3600",
        )?;
        let live_update_secs = env_number_where(
            NODE,
            &lookup,
            LIVE_UPDATE_SECS,
            DEFAULT_LIVE_UPDATE_SECS,
            |s| s == 0.0 || (0.1..=60.0).contains(&s),
            "0 (off) or seconds between 0.1 and 60",
        )?;
        Ok(Config {
            out_dir,
            rrd,
            connect,
            rig,
            ring_capacity,
            warmup_nanos: (warmup_secs * 1e9).round() as i64,
            live_update_nanos: (live_update_secs > 0.0)
                .then(|| (live_update_secs * 1e9).round() as i64),
            record_frames: env_flag(NODE, &lookup, RECORD_FRAMES, true)?,
        })
    }
}

/// A replay writes its own recording (`frames.csv`, `poses.csv`, `rig.yml`) into `out_dir`:
/// into the folder of the `recording` it plays, it would overwrite the frames it reads and the
/// rig they were made with.
///
/// # Errors
/// `out_dir` is the recording's folder.
fn check_not_over(out_dir: &Path, recording: &Path) -> eyre::Result<()> {
    let folder = if recording.is_dir() {
        Some(recording)
    } else {
        recording.parent()
    };
    let same = match (
        out_dir.canonicalize(),
        folder.map(|f| {
            if f.as_os_str().is_empty() {
                Path::new(".")
            } else {
                f
            }
            .canonicalize()
        }),
    ) {
        (Ok(a), Some(Ok(b))) => a == b,
        _ => false,
    };
    if same {
        bail!(
            "{NODE}: {OUTPUT_DIR}={} is the folder of the recording being replayed ({RECORDING}={}): \
             the replay would overwrite the frames it plays; give it another {OUTPUT_DIR}",
            out_dir.display(),
            recording.display()
        );
    }
    Ok(())
}
