//! `sync` configuration, read from the node's `env:` block.
//!
//! | env var | type | default | meaning |
//! |---|---|---|---|
//! | `POLICY` | `interpolate` or `slots` | `interpolate` | how frames become aligned sets |
//! | `INTERPOLATION` | `linear` or `cubic-hermite` | `linear` | resampling under `interpolate` |
//! | `FUSION_RATE_HZ` | Hz | `30` | fusion instants under `interpolate` |
//! | `SLOT_MILLIS` | ms | `15` | slot length under `slots` (cycle = (n+1) slots) |
//! | `LATENCY_DEADLINE_MILLIS` | ms | `100` | a set goes out incomplete after this at the latest (must exceed transport delay) |
//! | `FRAME_WAIT_MARGIN_MILLIS` | ms, ≥ 0 | `10` | a set waits for a sensor's next frame until it is this late (its newest frame + its frame period + its usual transport delay + this); then it goes out without waiting for it |
//! | `BRIDGE_GAPS` | true/false | `false` | `interpolate`: also wait (up to the deadline) for a joint the frames after an instant lack, so gaps up to 100 ms are interpolated across, at the cost of up to 100 ms of age for the sets inside them |
//! | `NTP_INTERVAL_MILLIS` | ms | `100` | one NTP exchange per sensor this often |
//! | `TIMESTAMPS` | `ntp` or `recorded` | `ntp` | `recorded`: replaying a trial recording (`kinect-source` `BACKEND: recording`), place each frame on the server stamp the recording's `sync` gave it (`trigait.recorded_server_stamp_nanos`) instead of mapping it with NTP, and take the frames in the order the recording's `sync` received them, its clock moved to each frame's recorded arrival (`trigait.recorded_received_nanos`) instead of the host clock (NTP requests still go out, as the sign that sync listens): with the recorded run's parameters (the same `POLICY`, `FUSION_RATE_HZ`, `LATENCY_DEADLINE_MILLIS`, …) it then makes the same sets from the same frames at any replay speed, the deadline decisions included; a frame recorded unsynchronised is dropped as it was then |
//! | `SENSORS` | comma list | from the `frame_<id>` inputs | sensor ids, in slot order |
//!
//! Inputs: `frame_<id>` and `ntp_<id>` per source, `tick` (a `dora/timer/millis/N` timer, ≤ 20 ms).

use eyre::{bail, eyre};
use trigait_node_config::{env_flag, env_number_where, env_parsed, env_value};
use trigait_sync::{Interpolation, Policy, SyncParams};

/// Env var: policy.
pub const POLICY: &str = "POLICY";
/// Env var: interpolation.
pub const INTERPOLATION: &str = "INTERPOLATION";
/// Env var: fusion rate.
pub const FUSION_RATE_HZ: &str = "FUSION_RATE_HZ";
/// Env var: slot length.
pub const SLOT_MILLIS: &str = "SLOT_MILLIS";
/// Env var: latency deadline.
pub const LATENCY_DEADLINE_MILLIS: &str = "LATENCY_DEADLINE_MILLIS";
/// Env var: how late a sensor's next frame may be before a set stops waiting for it.
pub const FRAME_WAIT_MARGIN_MILLIS: &str = "FRAME_WAIT_MARGIN_MILLIS";
/// Env var: wait for joints to reappear and interpolate across their gaps.
pub const BRIDGE_GAPS: &str = "BRIDGE_GAPS";
/// Env var: NTP interval.
pub const NTP_INTERVAL_MILLIS: &str = "NTP_INTERVAL_MILLIS";
/// Env var: where frames are placed on the server clock.
pub const TIMESTAMPS: &str = "TIMESTAMPS";
/// Env var: sensor ids.
pub const SENSORS: &str = "SENSORS";

/// Every variable the node reads, to spot a misspelt one.
const SETTINGS: &[&str] = &[
    POLICY,
    INTERPOLATION,
    FUSION_RATE_HZ,
    SLOT_MILLIS,
    LATENCY_DEADLINE_MILLIS,
    FRAME_WAIT_MARGIN_MILLIS,
    BRIDGE_GAPS,
    NTP_INTERVAL_MILLIS,
    TIMESTAMPS,
    SENSORS,
];

const NODE: &str = "sync";

/// The node's configuration.
#[derive(Debug, Clone)]
pub struct Config {
    /// The sync parameters.
    pub params: SyncParams,
    /// NTP exchange period per sensor, ns.
    pub ntp_interval_nanos: i64,
    /// Sensor ids given explicitly (else from the inputs).
    pub sensors: Option<Vec<String>>,
    /// Frames carry the server stamps of a recording ([`TIMESTAMPS`] `recorded`).
    pub recorded_time: bool,
}

/// `key` in milliseconds (positive), as nanoseconds.
fn millis(lookup: &impl Fn(&str) -> Option<String>, key: &str, default: f64) -> eyre::Result<i64> {
    let v = env_number_where(
        NODE,
        lookup,
        key,
        default,
        |v| v > 0.0,
        "a positive number of milliseconds",
    )?;
    Ok((v * 1e6).round() as i64)
}

impl Config {
    /// From the process environment.
    pub fn from_env() -> eyre::Result<Self> {
        trigait_node_config::warn_misspelt_settings(NODE, SETTINGS);
        Self::from_lookup(|k| std::env::var(k).ok())
    }

    /// From any lookup (tests).
    pub fn from_lookup(lookup: impl Fn(&str) -> Option<String>) -> eyre::Result<Self> {
        let defaults = SyncParams::default();
        let defaults_bridge = defaults.bridge_gaps;
        let defaults_margin_ms = defaults.frame_wait_margin_nanos as f64 * 1e-6;
        let policy: Policy = env_parsed(NODE, &lookup, POLICY, defaults.policy)?;
        let interpolation: Interpolation =
            env_parsed(NODE, &lookup, INTERPOLATION, defaults.interpolation)?;
        let mut params = defaults
            .with_policy(policy)
            .with_interpolation(interpolation);
        if let Some(hz) = env_value(NODE, &lookup, FUSION_RATE_HZ, |_| true, "a rate in Hz")? {
            params = params.with_fusion_rate_hz(hz);
        }
        params = params
            .with_slot_nanos(millis(&lookup, SLOT_MILLIS, 15.0)?)
            .with_latency_deadline_nanos(millis(&lookup, LATENCY_DEADLINE_MILLIS, 100.0)?)
            .with_bridge_gaps(env_flag(NODE, &lookup, BRIDGE_GAPS, defaults_bridge)?);
        let margin_ms = env_number_where(
            NODE,
            &lookup,
            FRAME_WAIT_MARGIN_MILLIS,
            defaults_margin_ms,
            |v| v >= 0.0,
            "a number of milliseconds, 0 or more",
        )?;
        params = params.with_frame_wait_margin_nanos((margin_ms * 1e6).round() as i64);
        let recorded_time = match lookup(TIMESTAMPS).as_deref().map(str::trim) {
            None | Some("ntp") => false,
            Some("recorded") => true,
            Some(other) => {
                bail!("{NODE}: {TIMESTAMPS}={other:?} is invalid: expected `ntp` or `recorded`")
            }
        };
        params
            .validate()
            .map_err(|e| eyre!("{NODE}: invalid sync parameters ({POLICY}, {FUSION_RATE_HZ}, {SLOT_MILLIS}, {LATENCY_DEADLINE_MILLIS}, {FRAME_WAIT_MARGIN_MILLIS}): {e}"))?;
        let sensors = match lookup(SENSORS) {
            None => None,
            Some(raw) => {
                let ids: Vec<String> = raw
                    .split(',')
                    .map(|s| s.trim().to_owned())
                    .filter(|s| !s.is_empty())
                    .collect();
                if ids.is_empty() {
                    bail!("{NODE}: {SENSORS}={raw:?} names no sensor");
                }
                Some(ids)
            }
        };
        Ok(Config {
            params,
            ntp_interval_nanos: millis(&lookup, NTP_INTERVAL_MILLIS, 100.0)?,
            sensors,
            recorded_time,
        })
    }
}
