//! `recorder`: the end of the graph. Logs everything to rerun (an `.rrd` file by default, a
//! live viewer when `RERUN_CONNECT` is set), keeps the thesis ring buffer, and when the graph
//! stops writes `trajectory.txt`, `trajectory.csv` and `summary.json` into `OUTPUT_DIR`.
//! Configuration: [`config`]; entity paths: [`viz`].

mod config;
mod export;
mod gait;
mod stats;
#[cfg(test)]
mod tests;
mod viz;

use dora_node_api::{DoraNode, Event, EventStream, get_integer_param};
use eyre::Context;
use tracing::{error, info, warn};
use trigait_schema::{FrameTiming, FusedPose, Message, SkeletonFrameMessage, ports};

use crate::config::Config;
use crate::export::Ring;
use crate::stats::{Stats, Summary};

fn main() -> eyre::Result<()> {
    trigait_node_log::init("recorder");
    let config = Config::from_env()?;
    let (node, events) =
        DoraNode::init_from_env().context("recorder: connecting to the dora daemon")?;
    run(config, node, events).map(|_| ())
}

fn now_nanos() -> i64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| i64::try_from(d.as_nanos()).unwrap_or(i64::MAX))
}

/// The event loop; returns the summary it wrote.
pub fn run(config: Config, _node: DoraNode, mut events: EventStream) -> eyre::Result<Summary> {
    std::fs::create_dir_all(&config.out_dir)
        .with_context(|| format!("recorder: creating OUTPUT_DIR={}", config.out_dir.display()))?;
    let rec = viz::open(&config)?;
    viz::send_blueprint(&rec).context("recorder: sending the default blueprint")?;
    viz::log_static(&rec, &config.rig).context("recorder: logging the rig")?;
    let mut gait = gait::Gait::new(&rec).context("recorder: logging the gait styles")?;
    let mut stats = Stats::new(config.warmup_nanos);
    let mut ring = Ring::new(config.ring_capacity);
    let mut rerun_errors = 0_u64;
    while let Some(event) = events.recv() {
        let now = now_nanos();
        match event {
            Event::Input { id, metadata, data } => {
                let id = id.as_str();
                let array = data.as_array().as_ref();
                let logged = if id == ports::FUSED_POSE {
                    match FusedPose::decode(array) {
                        Ok(pose) => {
                            let truth: Vec<_> = pose
                                .joints
                                .keys()
                                .filter_map(|j| stats.truth_at(*j, pose.stamp_nanos))
                                .collect();
                            let sent =
                                get_integer_param(&metadata.parameters, ports::TRIGGER_SENT_NANOS);
                            let latency = sent.map(|sent| now - sent);
                            let logged = viz::log_pose(&rec, &pose, &truth, latency)
                                .and_then(|()| gait.push(&rec, &pose));
                            ring.push(&pose);
                            stats.push_pose(
                                pose,
                                now,
                                sent,
                                get_integer_param(&metadata.parameters, ports::MISSING_SENSORS),
                            );
                            logged
                        }
                        Err(e) => {
                            stats.malformed += 1;
                            warn!("skipping a malformed fused pose: {e}");
                            Ok(())
                        }
                    }
                } else if id == ports::FRAME_TIMING {
                    match FrameTiming::decode_many(array) {
                        Ok(rows) => {
                            stats.push_timing(&rows);
                            viz::log_timing(&rec, &rows)
                        }
                        Err(e) => {
                            stats.malformed += 1;
                            warn!("skipping malformed frame timings: {e}");
                            Ok(())
                        }
                    }
                } else if let Some(sensor) = ports::sensor_of(id, ports::TRUTH_INPUT_PREFIX) {
                    match SkeletonFrameMessage::decode_many(array) {
                        Ok(rows) => {
                            stats.push_truth(rows.into_iter().map(|m| m.frame).collect());
                            Ok(())
                        }
                        Err(e) => {
                            stats.malformed += 1;
                            warn!(%sensor, "skipping malformed ground truth: {e}");
                            Ok(())
                        }
                    }
                } else if let Some(sensor) = ports::sensor_of(id, ports::FRAME_INPUT_PREFIX) {
                    match SkeletonFrameMessage::decode(array) {
                        Ok(m) => {
                            stats.push_frame(sensor, m.frame.seq, now);
                            viz::log_raw(&rec, &m.frame, now)
                        }
                        Err(e) => {
                            stats.malformed += 1;
                            warn!(%sensor, "skipping a malformed frame: {e}");
                            Ok(())
                        }
                    }
                } else {
                    warn!(input = id, "ignoring an unknown input");
                    Ok(())
                };
                if let Err(e) = logged {
                    rerun_errors += 1;
                    if rerun_errors == 1 {
                        error!("rerun logging failed (further failures counted): {e:#}");
                    }
                }
            }
            Event::InputClosed { id } => {
                if let Some(sensor) = ports::sensor_of(id.as_str(), ports::FRAME_INPUT_PREFIX) {
                    warn!(%sensor, "source stopped");
                    stats.source_closed(sensor, now);
                }
            }
            Event::Error(e) => warn!("event stream error: {e}"),
            _ => {}
        }
        count_drops(&mut stats, &mut events);
    }
    count_drops(&mut stats, &mut events);
    let mut summary = stats.summary(now_nanos());
    let (gait_report, gait_logged) = gait.finish(&rec);
    summary.gait = Some(gait_report);
    if let Err(e) = gait_logged {
        error!("rerun logging of the gait report failed: {e:#}");
    }
    ring.write(&config.out_dir)
        .context("recorder: writing the trajectory exports")?;
    let path = config.out_dir.join("summary.json");
    let json =
        serde_json::to_string_pretty(&summary).context("recorder: serialising the summary")?;
    std::fs::write(&path, json).with_context(|| format!("recorder: writing {}", path.display()))?;
    rec.flush_blocking().ok();
    drop(rec);
    info!(
        "{} poses, RMSE {} m, latency p50 {:.2} ms p99 {:.2} ms (after warm-up); wrote {}",
        summary.sets_fused,
        summary
            .rmse_all_m
            .map_or_else(|| "n/a".to_owned(), |r| format!("{r:.4}")),
        summary.latency_ms.p50,
        summary.latency_ms.p99,
        path.display()
    );
    Ok(summary)
}

/// Adds the messages dora dropped on the recorder's inputs since the last call to the summary
/// (and logs them); called after every event and once more after the last.
fn count_drops(stats: &mut Stats, events: &mut EventStream) {
    for (id, n) in trigait_node_log::warn_drops(events) {
        *stats.input_drops.entry(id.to_string()).or_default() += n;
    }
}
