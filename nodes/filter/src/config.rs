//! `filter` configuration, read from the node's `env:` block.
//!
//! | env var | type | default | meaning |
//! |---|---|---|---|
//! | `FILTER` | `one-euro`, `lowpass`, `none` | `one-euro` | which causal filter smooths each joint |
//! | `ONE_EURO_MIN_CUTOFF_HZ` | Hz > 0 | `1.0` | One-Euro cut-off at rest (Casiez et al. 2012 `fcmin`) |
//! | `ONE_EURO_BETA` | ≥ 0, Hz per m/s | `2.0` | One-Euro cut-off increase with speed: a 4 m/s swinging ankle is filtered at 9 Hz |
//! | `ONE_EURO_DERIVATIVE_CUTOFF_HZ` | Hz > 0 | `1.0` | One-Euro cut-off of its speed estimate (the paper's `dcutoff`) |
//! | `LOWPASS_CUTOFF_HZ` | Hz > 0 | `6.0` | `lowpass`: −3 dB cut-off of the causal Butterworth (below half the pose rate) |
//! | `LOWPASS_ORDER` | 1–8 | `2` | `lowpass`: filter order (sections of two) |
//! | `MAX_GAP_SECS` | s > 0 | `0.2` | a joint silent for longer restarts its filter instead of being dragged across the gap |
//!
//! The names carry a prefix because `dora run` also gives a node's `env:` to its `build:` line,
//! where a bare `ORDER` or `BETA` could be read by some crate's build script.
//!
//! Port: input `fused_pose`, output `fused_pose` (the same `FusedPose` message, so the node can
//! be put between `trilaterate` and `recorder`, or taken out, by YAML alone).

use std::str::FromStr;

use eyre::bail;
use trigait_gait::filter::OneEuroParams;
use trigait_gait::stream::{LowPassParams, StreamFilter, StreamParams};
use trigait_node_config::{env_number_where, env_parsed};

/// Env var: filter kind.
pub const FILTER: &str = "FILTER";
/// Env var: One-Euro minimum cut-off.
pub const MIN_CUTOFF_HZ: &str = "ONE_EURO_MIN_CUTOFF_HZ";
/// Env var: One-Euro beta.
pub const BETA: &str = "ONE_EURO_BETA";
/// Env var: One-Euro derivative cut-off.
pub const DERIVATIVE_CUTOFF_HZ: &str = "ONE_EURO_DERIVATIVE_CUTOFF_HZ";
/// Env var: low-pass cut-off.
pub const CUTOFF_HZ: &str = "LOWPASS_CUTOFF_HZ";
/// Env var: low-pass order.
pub const ORDER: &str = "LOWPASS_ORDER";
/// Env var: largest bridged gap.
pub const MAX_GAP_SECS: &str = "MAX_GAP_SECS";

const NODE: &str = "filter";

/// The `FILTER` names: which causal filter, before its own keys are read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    OneEuro,
    LowPass,
    None,
}

impl FromStr for Kind {
    type Err = &'static str;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.to_ascii_lowercase().as_str() {
            "one-euro" | "one_euro" | "oneeuro" => Ok(Kind::OneEuro),
            "lowpass" | "low-pass" | "butterworth" => Ok(Kind::LowPass),
            "none" | "off" => Ok(Kind::None),
            _ => Err("expected one-euro, lowpass or none \
                 (the zero-lag Butterworth needs the whole recording: `trigait gait --filter`)"),
        }
    }
}

/// The node's configuration.
#[derive(Debug, Clone, PartialEq)]
pub struct Config {
    /// Filter parameters.
    pub params: StreamParams,
}

impl Config {
    /// From the process environment.
    pub fn from_env() -> eyre::Result<Self> {
        Self::from_lookup(|k| std::env::var(k).ok())
    }

    /// From any lookup (tests).
    pub fn from_lookup(lookup: impl Fn(&str) -> Option<String>) -> eyre::Result<Self> {
        let positive = |v: f64| v > 0.0;
        let filter = match env_parsed(NODE, &lookup, FILTER, Kind::OneEuro)? {
            Kind::OneEuro => {
                let d = OneEuroParams::default();
                StreamFilter::OneEuro(OneEuroParams {
                    min_cutoff_hz: env_number_where(
                        NODE,
                        &lookup,
                        MIN_CUTOFF_HZ,
                        d.min_cutoff_hz,
                        positive,
                        "a cut-off in Hz above 0",
                    )?,
                    beta: env_number_where(
                        NODE,
                        &lookup,
                        BETA,
                        d.beta,
                        |v| v >= 0.0,
                        "a number ≥ 0",
                    )?,
                    derivative_cutoff_hz: env_number_where(
                        NODE,
                        &lookup,
                        DERIVATIVE_CUTOFF_HZ,
                        d.derivative_cutoff_hz,
                        positive,
                        "a cut-off in Hz above 0",
                    )?,
                })
            }
            Kind::LowPass => {
                let d = LowPassParams::default();
                let order = env_number_where(
                    NODE,
                    &lookup,
                    ORDER,
                    d.order as f64,
                    |v| v.fract() == 0.0 && (1.0..=8.0).contains(&v),
                    "an integer order from 1 to 8",
                )? as usize;
                StreamFilter::LowPass(LowPassParams {
                    cutoff_hz: env_number_where(
                        NODE,
                        &lookup,
                        CUTOFF_HZ,
                        d.cutoff_hz,
                        positive,
                        "a cut-off in Hz above 0 (and below half the pose rate)",
                    )?,
                    order,
                })
            }
            Kind::None => StreamFilter::None,
        };
        let max_gap_secs = env_number_where(
            NODE,
            &lookup,
            MAX_GAP_SECS,
            StreamParams::default().max_gap_secs,
            positive,
            "a number of seconds above 0",
        )?;
        let params = StreamParams {
            filter,
            max_gap_secs,
        };
        if let Err(e) = params.validate() {
            bail!("{NODE}: {e}");
        }
        Ok(Config { params })
    }
}
