//! `depth-metrics`: the thesis's five Kinect v2 depth metrics (ch. 3, results §5.1) on the live
//! depth stream of every sensor. Each `depth_<sensor>` input feeds that
//! sensor's [`trigait_depth::SequenceAnalyzer`] — the code `trigait depth-metrics` runs on PNG
//! files — and every `REPORT_EVERY_FRAMES` frames the sensor's report is recomputed, written to
//! `OUTPUT_DIR/depth-metrics.json` and, with `RERUN`, its maps and scalars logged to rerun
//! through [`trigait_depth_rerun`]. Each `status_<sensor>` input (a `sensor_status`, optional)
//! gives that sensor's device state: a change is logged to rerun and the report file's `devices`
//! holds each sensor's state and degraded time ([`devices`]). A malformed message or a frame of
//! the wrong size is counted and skipped. A frame's camera is the pinhole its source stamped
//! (`trigait.depth_pinhole`, an undistorted real frame; the entry's `pinhole`), otherwise the
//! nominal Kinect v2 camera ([`trigait_node_config::depth_camera`]). Configuration: [`config`].

mod config;
mod devices;
mod state;
#[cfg(test)]
mod tests;

use dora_node_api::{DoraNode, Event, EventStream};
use eyre::Context;
use tracing::{info, warn};
use trigait_depth_rerun::RecordingStream;
use trigait_schema::{Message, SensorStatus, ports};

use crate::config::Config;
use crate::devices::Devices;
use crate::state::{Pushed, Sensors};

fn main() -> eyre::Result<()> {
    trigait_node_log::init("depth-metrics");
    let config = Config::from_env()?;
    let (node, events) =
        DoraNode::init_from_env().context("depth-metrics: connecting to the dora daemon")?;
    run(config, node, events).map(|_| ())
}

/// Totals over all inputs.
#[derive(Debug, Default, Clone, PartialEq, Eq)]
pub struct Counters {
    /// Frames analysed.
    pub analysed: u64,
    /// Messages refused (malformed or wrong size).
    pub refused: u64,
    /// Device state reports received.
    pub statuses: u64,
    /// Inputs whose id is not `depth_<sensor>` or `status_<sensor>`.
    pub unknown: u64,
}

fn now_nanos() -> i64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| i64::try_from(d.as_nanos()).unwrap_or(i64::MAX))
}

/// The event loop.
pub fn run(config: Config, _node: DoraNode, mut events: EventStream) -> eyre::Result<Counters> {
    let rec: Option<RecordingStream> = config
        .rerun
        .as_ref()
        .map(|sink| trigait_depth_rerun::open("trigait-depth", sink))
        .transpose()
        .map_err(|e| eyre::eyre!("depth-metrics: {}: {e}", config::RERUN))?;
    let json = config.output_dir.join(config::REPORT_FILE);
    let mut sensors = Sensors::new(config.params, config.report_every);
    let mut counters = Counters::default();
    let mut devices = Devices::default();
    while let Some(event) = events.recv() {
        trigait_node_log::warn_drops(&mut events);
        match event {
            Event::Input { id, data, .. }
                if ports::sensor_of(id.as_str(), ports::STATUS_INPUT_PREFIX).is_some() =>
            {
                match SensorStatus::decode(data.as_array().as_ref()) {
                    Ok(status) => {
                        counters.statuses += 1;
                        if devices.push(&status) {
                            info!("{}: {}", status.sensor_id, status.detail);
                            if let Some(rec) = &rec {
                                trigait_depth_rerun::log_device_state(
                                    rec,
                                    &status.sensor_id,
                                    status.stamp_nanos,
                                    status.is_degraded(),
                                    &status.detail,
                                )?;
                            }
                            sensors.write_json(&json, &devices)?;
                        }
                    }
                    Err(e) => {
                        counters.refused += 1;
                        warn!(
                            input = id.as_str(),
                            "skipping a malformed sensor_status: {e}"
                        );
                    }
                }
            }
            Event::Input { id, data, metadata } => {
                let Some(sensor) = ports::sensor_of(id.as_str(), ports::DEPTH_INPUT_PREFIX) else {
                    counters.unknown += 1;
                    warn!(input = id.as_str(), "ignoring an unknown input");
                    continue;
                };
                let camera = trigait_node_config::depth_camera(&metadata.parameters);
                match sensors.push(sensor, data.as_array().as_ref(), camera, now_nanos()) {
                    (Pushed::Refused, why) => {
                        counters.refused += 1;
                        warn!(%sensor, "skipping a frame: {}", why.unwrap_or_default());
                    }
                    (Pushed::Analysed, _) => counters.analysed += 1,
                    (Pushed::ReportDue, _) => {
                        counters.analysed += 1;
                        sensors.report(sensor, rec.as_ref())?;
                        sensors.write_json(&json, &devices)?;
                    }
                }
            }
            Event::InputClosed { id } => {
                if let Some(sensor) = ports::sensor_of(id.as_str(), ports::DEPTH_INPUT_PREFIX)
                    && sensors.report(sensor, rec.as_ref())?
                {
                    sensors.write_json(&json, &devices)?;
                }
            }
            Event::Stop(_) => {}
            Event::Error(e) => warn!("event stream error: {e}"),
            _ => {}
        }
    }
    sensors.report_all(rec.as_ref())?;
    sensors.write_json(&json, &devices)?;
    // Dropping the stream flushes the .rrd footer.
    drop(rec);
    info!(
        "{} frames analysed, {} refused, {} unknown inputs, {} device states; report in {}",
        counters.analysed,
        counters.refused,
        counters.unknown,
        counters.statuses,
        json.display()
    );
    Ok(counters)
}
