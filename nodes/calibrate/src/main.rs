//! `calibrate`: the rig from the first seconds of a run. Collects every sensor's frames from
//! `sync`'s `frame_timing` (camera-space joints on the server clock), and once
//! `CALIBRATE_SECS` of synchronised frames are in (or the run ends first), hands them to the
//! calibration operator (`trigait-calibration`, through `trigait-recording`'s tracks, the same
//! path as `trigait calibrate --recording`) and writes the calibrated rig to
//! `OUTPUT_DIR/rig.calibrated.yml`, a rig file every graph's `RIG` reads, and the whole report
//! (poses, uncertainties, residuals, findings: what `trigait calibrate --json` prints) to
//! `OUTPUT_DIR/calibration.json`. A calibration that fails, or whose poses the walk does not
//! determine, is logged with the reason (the findings); the rig is written when every sensor
//! has a pose (the report says how well determined), and not otherwise.
//!
//! | env var | default | meaning |
//! |---|---|---|
//! | `CALIBRATE_SECS` | `10` | seconds of synchronised frames to calibrate from (server clock) |
//! | `START` | `rig` | `rig`: start the adjustment from `RIG` (a tape-measured rig); `data`: from the walk alone (pairwise alignment) |
//! | `RIG` | `thesis` | the rough rig to start from (`thesis`, `ring-N` or a rig file) |
//! | `OUTPUT_DIR` | `out` | where `rig.calibrated.yml` goes |
//!
//! Input: `frame_timing` (from `sync`). No outputs.

use std::path::PathBuf;

use dora_node_api::{DoraNode, Event};
use eyre::{Context, bail};
use tracing::{info, warn};
use trigait_node_config::{env_number_where, env_rig};
use trigait_schema::{FrameTiming, Message, ports};

const NODE: &str = "calibrate";
/// The rig file written into `OUTPUT_DIR`.
pub const CALIBRATED_RIG_FILE: &str = "rig.calibrated.yml";
/// The report written into `OUTPUT_DIR`.
pub const REPORT_FILE: &str = "calibration.json";

/// The node's configuration.
#[derive(Debug, Clone)]
pub struct Config {
    /// Seconds of synchronised frames to collect, server clock.
    pub secs: f64,
    /// The rough rig to start from (`None`: from the data).
    pub start: Option<trigait_rig::Rig>,
    /// The rig file to write.
    pub output: PathBuf,
    /// The report to write.
    pub report: PathBuf,
}

impl Config {
    /// From any lookup (the process environment in the node).
    ///
    /// # Errors
    /// A bad `CALIBRATE_SECS`, `START` or `RIG`, naming the variable.
    pub fn from_lookup(lookup: impl Fn(&str) -> Option<String>) -> eyre::Result<Self> {
        let secs = env_number_where(
            NODE,
            &lookup,
            "CALIBRATE_SECS",
            10.0,
            |v| v > 0.0,
            "a positive number of seconds",
        )?;
        let start = match lookup("START").as_deref().map(str::trim) {
            None | Some("rig") => Some(env_rig(NODE, &lookup)?),
            Some("data") => None,
            Some(other) => bail!("{NODE}: START={other:?} is invalid: expected `rig` or `data`"),
        };
        let dir = PathBuf::from(
            lookup("OUTPUT_DIR")
                .unwrap_or_else(|| "out".to_owned())
                .trim(),
        );
        Ok(Self {
            secs,
            start,
            output: dir.join(CALIBRATED_RIG_FILE),
            report: dir.join(REPORT_FILE),
        })
    }
}

fn main() -> eyre::Result<()> {
    trigait_node_log::init(NODE);
    let config = Config::from_lookup(|k| std::env::var(k).ok())?;
    let (_node, mut events) =
        DoraNode::init_from_env().context("calibrate: connecting to the dora daemon")?;
    let mut frames: Vec<FrameTiming> = Vec::new();
    let mut first: Option<i64> = None;
    let mut done = false;
    while let Some(event) = events.recv() {
        trigait_node_log::warn_drops(&mut events);
        match event {
            Event::Input { id, data, .. } if id.as_str() == ports::FRAME_TIMING => {
                if done {
                    continue;
                }
                match FrameTiming::decode_many(data.as_array().as_ref()) {
                    Ok(batch) => frames.extend(batch),
                    Err(e) => {
                        warn!("skipping a malformed frame_timing: {e}");
                        continue;
                    }
                }
                let newest = frames.iter().filter_map(|f| f.server_stamp_nanos).max();
                first = first.or_else(|| frames.iter().filter_map(|f| f.server_stamp_nanos).min());
                if let (Some(a), Some(b)) = (first, newest)
                    && (b - a) as f64 * 1e-9 >= config.secs
                {
                    calibrate_and_write(&config, &frames);
                    done = true;
                    frames = Vec::new();
                }
            }
            Event::Input { id, .. } => warn!(input = id.as_str(), "ignoring an unknown input"),
            Event::Error(e) => warn!("event stream error: {e}"),
            _ => {}
        }
    }
    if !done {
        warn!(
            "the run ended before {} s of synchronised frames; calibrating from what came",
            config.secs
        );
        calibrate_and_write(&config, &frames);
    }
    Ok(())
}

/// Calibrates from `frames` and writes the rig; every outcome is logged, none stops the graph.
fn calibrate_and_write(config: &Config, frames: &[FrameTiming]) {
    let tracks = trigait_recording::calibration_tracks(frames);
    let initial = config
        .start
        .as_ref()
        .map_or(trigait_calibration::Initial::FromData, |rig| {
            trigait_calibration::Initial::Rig(rig)
        });
    let calibration = match trigait_calibration::calibrate(
        &tracks,
        initial,
        &trigait_calibration::Params::default(),
    ) {
        Ok(c) => c,
        Err(e) => {
            warn!("no calibration from {} frames: {e}", frames.len());
            return;
        }
    };
    for f in &calibration.findings {
        warn!("{}", f.message);
    }
    let report = serde_json::to_string_pretty(&calibration)
        .map_err(std::io::Error::other)
        .and_then(|text| {
            if let Some(dir) = config.report.parent() {
                std::fs::create_dir_all(dir)?;
            }
            std::fs::write(&config.report, text + "\n")
        });
    if let Err(e) = report {
        warn!("writing {}: {e}", config.report.display());
    }
    for s in &calibration.sensors {
        info!(
            sensor = s.id.as_str(),
            residual_mm = s.residual_rms_m * 1e3,
            sigma_mm = ?s.position_sigma_m.map(|v| (v * 1e4).round() / 10.0),
            "calibrated: {}",
            s.world_from_kinect.map_or_else(
                || "no pose".to_owned(),
                |p| format!("{:.3?}", p.translation.vector.as_slice())
            )
        );
    }
    if calibration
        .sensors
        .iter()
        .any(|s| s.world_from_kinect.is_none())
    {
        warn!(
            "not writing {}: a sensor has no pose",
            config.output.display()
        );
        return;
    }
    match trigait_recording::write_calibrated_rig(&config.output, "calibrated", &calibration) {
        Ok(()) => info!(
            "wrote {} ({} sensors, {} iterations)",
            config.output.display(),
            calibration.sensors.len(),
            calibration.iterations
        ),
        Err(e) => warn!("writing the calibrated rig: {e}"),
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use trigait_node_testing::lookup;

    use super::*;

    /// Defaults, the data start, and bad values named.
    #[test]
    fn config() {
        let c = Config::from_lookup(lookup(&[])).unwrap();
        assert_eq!(c.secs, 10.0);
        assert_eq!(c.start.unwrap().name, "thesis");
        assert_eq!(c.output, PathBuf::from("out/rig.calibrated.yml"));
        let c = Config::from_lookup(lookup(&[
            ("START", "data"),
            ("CALIBRATE_SECS", "4.5"),
            ("OUTPUT_DIR", "/tmp/x"),
        ]))
        .unwrap();
        assert!(c.start.is_none());
        assert_eq!(c.secs, 4.5);
        assert_eq!(c.output, PathBuf::from("/tmp/x/rig.calibrated.yml"));
        for (k, v) in [
            ("CALIBRATE_SECS", "-1"),
            ("START", "tape"),
            ("RIG", "ring-0"),
        ] {
            let pairs: &'static [(&'static str, &'static str)] = Box::leak(Box::new([(k, v)]));
            let err = Config::from_lookup(lookup(pairs)).unwrap_err().to_string();
            assert!(err.contains(k) || err.contains("RIG"), "{err}");
        }
    }
}
