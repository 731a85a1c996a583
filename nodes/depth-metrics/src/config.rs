//! `depth-metrics` configuration, read from the node's `env:` block.
//!
//! | env var | type | default | meaning |
//! |---|---|---|---|
//! | `OUTPUT_DIR` | path | `out` | where `depth-metrics.json` (and `depth.rrd`) go |
//! | `REPORT_EVERY_FRAMES` | integer ≥ 1 | `30` | a sensor's report is recomputed and written every N of its frames (and at the end) |
//! | `RERUN` | `off` (or any false flag word: `false`, `no`, `0`), `rrd`, a `.rrd` path or a `rerun+http://…/proxy` url | `off` | log the maps and scalars to rerun (`rrd` = `OUTPUT_DIR/depth.rrd`) |
//! | `TARGET_DISTANCE_M` | metres | fitted | true distance of a fronto-parallel target (§3.1); otherwise a plane is fitted |
//! | `ENTROPY_WINDOW` | frames ≥ 2 | `30` | frames per entropy window (§3.3, thesis: 30) |
//! | `FRAME_STRIDE` | integer ≥ 1 | `30` | resolution (§3.2) and edge noise (§3.4) on every N-th frame |
//!
//! Inputs: `depth_<sensor>` per source (any number; the sensor id is the suffix, as `sync` reads
//! `frame_<sensor>`).

use std::path::PathBuf;

use eyre::bail;
use trigait_depth::MetricsParams;
use trigait_depth_rerun::Sink;
use trigait_node_config::{env_value, flag_word};

/// Env var: output folder.
pub const OUTPUT_DIR: &str = "OUTPUT_DIR";
/// Env var: report period in frames.
pub const REPORT_EVERY_FRAMES: &str = "REPORT_EVERY_FRAMES";
/// Env var: rerun sink.
pub const RERUN: &str = "RERUN";
/// Env var: target distance.
pub const TARGET_DISTANCE_M: &str = "TARGET_DISTANCE_M";
/// Env var: entropy window.
pub const ENTROPY_WINDOW: &str = "ENTROPY_WINDOW";
/// Env var: frame stride of the single-frame metrics.
pub const FRAME_STRIDE: &str = "FRAME_STRIDE";

/// File name of the JSON report inside `OUTPUT_DIR`.
pub const REPORT_FILE: &str = "depth-metrics.json";
/// File name of the recording inside `OUTPUT_DIR` with `RERUN=rrd`.
pub const RRD_FILE: &str = "depth.rrd";

const NODE: &str = "depth-metrics";

/// The node's configuration.
#[derive(Debug, Clone)]
pub struct Config {
    /// Output folder.
    pub output_dir: PathBuf,
    /// Report period, frames per sensor.
    pub report_every: usize,
    /// Rerun sink, if any.
    pub rerun: Option<Sink>,
    /// Metric parameters (shared by every sensor).
    pub params: MetricsParams,
}

/// `key` as an integer of at least `min`, `default` when unset.
fn integer(
    lookup: &impl Fn(&str) -> Option<String>,
    key: &str,
    default: usize,
    min: usize,
) -> eyre::Result<usize> {
    let expected = format!("an integer ≥ {min}");
    Ok(env_value(NODE, lookup, key, |v| *v >= min, &expected)?.unwrap_or(default))
}

impl Config {
    /// From the process environment.
    pub fn from_env() -> eyre::Result<Self> {
        Self::from_lookup(|k| std::env::var(k).ok())
    }

    /// From any lookup (tests).
    pub fn from_lookup(lookup: impl Fn(&str) -> Option<String>) -> eyre::Result<Self> {
        let output_dir = PathBuf::from(lookup(OUTPUT_DIR).unwrap_or_else(|| "out".into()));
        let report_every = integer(&lookup, REPORT_EVERY_FRAMES, 30, 1)?;
        let rerun = match lookup(RERUN).as_deref().map(str::trim) {
            None | Some("" | "off") => None,
            Some(spec) => match flag_word(spec) {
                Some(false) => None,
                Some(true) => bail!(
                    "{NODE}: {RERUN}={spec:?} is invalid: expected off, false, rrd, a .rrd path or a rerun+http:// url"
                ),
                None => Some(Sink::from_spec(spec, &output_dir.join(RRD_FILE))),
            },
        };
        let mut params = MetricsParams {
            entropy_window: integer(&lookup, ENTROPY_WINDOW, 30, 2)?,
            frame_metric_stride: integer(&lookup, FRAME_STRIDE, 30, 1)?,
            ..MetricsParams::default()
        };
        if let Some(d) = env_value(
            NODE,
            &lookup,
            TARGET_DISTANCE_M,
            |d: &f64| *d > 0.0 && d.is_finite(),
            "a positive distance in metres",
        )? {
            params.accuracy.target_distance_m = Some(d);
        }
        Ok(Self {
            output_dir,
            report_every,
            rerun,
            params,
        })
    }
}
