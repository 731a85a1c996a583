//! `recorder`: the end of the graph. Logs everything to rerun (an `.rrd` file by default, a
//! live viewer when `RERUN_CONNECT` is set), keeps the thesis ring buffer, and when the graph
//! stops writes `trajectory.txt` (thesis format), `trajectory.csv`/`.trc`/`.c3d` (the run as a
//! motion the CLI reads) and `summary.json` into `OUTPUT_DIR`.
//! Configuration: [`config`]; entity paths: [`viz`].

mod config;
mod export;
mod gait;
mod stats;
#[cfg(test)]
mod tests;
mod viz;

use dora_node_api::arrow_v59::array::Array;
use dora_node_api::{DoraNode, Event, EventStream, MetadataParameters, get_integer_param};
use eyre::Context;
use tracing::{error, info, warn};
use trigait_schema::{FrameTiming, FusedPose, GroundTruth, Message, SkeletonFrameMessage, ports};

use crate::config::Config;
use crate::export::{Ring, write_trajectory};
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

/// What an input id says the input is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Input<'a> {
    /// [`ports::FUSED_POSE`].
    FusedPose,
    /// [`ports::FRAME_TIMING`].
    FrameTiming,
    /// [`ports::GROUND_TRUTH`].
    GroundTruth,
    /// `frame_<sensor>`: a raw frame of one source.
    Frame(&'a str),
    /// Anything else (logged, ignored).
    Unknown(&'a str),
}

impl<'a> Input<'a> {
    /// The input `id` names.
    #[must_use]
    pub fn parse(id: &'a str) -> Self {
        match id {
            ports::FUSED_POSE => Input::FusedPose,
            ports::FRAME_TIMING => Input::FrameTiming,
            ports::GROUND_TRUTH => Input::GroundTruth,
            _ => ports::sensor_of(id, ports::FRAME_INPUT_PREFIX)
                .map_or(Input::Unknown(id), Input::Frame),
        }
    }
}

/// The recording and what is accumulated for the files written at the end.
struct Recorder {
    rec: rerun::RecordingStream,
    gait: gait::Gait,
    stats: Stats,
    ring: Ring,
    trajectory: trigait_fusion::Trajectory,
}

/// The event loop; returns the summary it wrote.
pub fn run(config: Config, _node: DoraNode, mut events: EventStream) -> eyre::Result<Summary> {
    std::fs::create_dir_all(&config.out_dir)
        .with_context(|| format!("recorder: creating OUTPUT_DIR={}", config.out_dir.display()))?;
    let rec = viz::open(&config)?;
    viz::send_blueprint(&rec).context("recorder: sending the default blueprint")?;
    viz::log_static(&rec, &config.rig).context("recorder: logging the rig")?;
    let mut r = Recorder {
        gait: gait::Gait::new(&rec).context("recorder: logging the gait styles")?,
        rec,
        stats: Stats::new(config.warmup_nanos),
        ring: Ring::new(config.ring_capacity),
        trajectory: trigait_fusion::Trajectory::new(),
    };
    let mut rerun_errors = 0_u64;
    while let Some(event) = events.recv() {
        let now = now_nanos();
        match event {
            Event::Input { id, metadata, data } => {
                let array = data.as_array();
                let array = array.as_ref();
                let logged = match Input::parse(id.as_str()) {
                    Input::FusedPose => r.on_pose(&metadata.parameters, array, now),
                    Input::FrameTiming => r.on_timing(array),
                    Input::GroundTruth => {
                        r.on_truth(array);
                        Ok(())
                    }
                    Input::Frame(sensor) => r.on_frame(sensor, array, now),
                    Input::Unknown(id) => {
                        warn!(input = id, "ignoring an unknown input");
                        Ok(())
                    }
                };
                if let Err(e) = logged {
                    rerun_errors += 1;
                    if rerun_errors == 1 {
                        error!("rerun logging failed (further failures counted): {e:#}");
                    }
                }
            }
            Event::InputClosed { id } => {
                if let Input::Frame(sensor) = Input::parse(id.as_str()) {
                    warn!(%sensor, "source stopped");
                    r.stats.source_closed(sensor, now);
                }
            }
            Event::Error(e) => warn!("event stream error: {e}"),
            _ => {}
        }
        count_drops(&mut r.stats, &mut events);
    }
    count_drops(&mut r.stats, &mut events);
    r.finish(&config)
}

impl Recorder {
    /// A fused pose: logged, buffered for the exports, scored; the metadata `sync` attached
    /// gives its latency and whether its set was complete. Errors are rerun's only.
    fn on_pose(
        &mut self,
        params: &MetadataParameters,
        array: &dyn Array,
        now: i64,
    ) -> eyre::Result<()> {
        let pose = match FusedPose::decode(array) {
            Ok(pose) => pose,
            Err(e) => {
                self.stats.malformed += 1;
                warn!("skipping a malformed fused pose: {e}");
                return Ok(());
            }
        };
        let truth: Vec<_> = pose
            .joints
            .keys()
            .filter_map(|j| self.stats.truth_at(*j, pose.stamp_nanos))
            .collect();
        let sent = get_integer_param(params, ports::TRIGGER_SENT_NANOS);
        let logged = viz::log_pose(&self.rec, &pose, &truth, sent.map(|sent| now - sent))
            .and_then(|()| self.gait.push(&self.rec, &pose));
        self.ring.push(&pose);
        self.trajectory.push(&pose);
        self.stats.push_pose(pose, now, sent);
        logged
    }

    /// `sync`'s frame timings: NTP error and clock estimates.
    fn on_timing(&mut self, array: &dyn Array) -> eyre::Result<()> {
        match FrameTiming::decode_many(array) {
            Ok(rows) => {
                self.stats.push_timing(&rows);
                viz::log_timing(&self.rec, &rows)
            }
            Err(e) => {
                self.stats.malformed += 1;
                warn!("skipping malformed frame timings: {e}");
                Ok(())
            }
        }
    }

    /// Ground truth of the simulated walk.
    fn on_truth(&mut self, array: &dyn Array) {
        match GroundTruth::decode_many(array) {
            Ok(rows) => self.stats.push_truth(rows),
            Err(e) => {
                self.stats.malformed += 1;
                warn!("skipping malformed ground truth: {e}");
            }
        }
    }

    /// A raw frame of `sensor`: counted for gaps and losses, logged.
    fn on_frame(&mut self, sensor: &str, array: &dyn Array, now: i64) -> eyre::Result<()> {
        match SkeletonFrameMessage::decode(array) {
            Ok(m) => {
                self.stats.push_frame(sensor, m.frame.seq, now);
                viz::log_raw(&self.rec, &m.frame, now)
            }
            Err(e) => {
                self.stats.malformed += 1;
                warn!(%sensor, "skipping a malformed frame: {e}");
                Ok(())
            }
        }
    }

    /// Writes the exports and `summary.json`, flushes the recording.
    fn finish(mut self, config: &Config) -> eyre::Result<Summary> {
        let mut summary = self.stats.summary(now_nanos());
        let (gait_report, gait_logged) = self.gait.finish(&self.rec);
        summary.gait = Some(gait_report);
        if let Err(e) = gait_logged {
            error!("rerun logging of the gait report failed: {e:#}");
        }
        self.ring
            .write(&config.out_dir)
            .context("recorder: writing the thesis text export")?;
        write_trajectory(&config.out_dir, &self.trajectory)
            .context("recorder: writing the trajectory files")?;
        let path = config.out_dir.join("summary.json");
        let json =
            serde_json::to_string_pretty(&summary).context("recorder: serialising the summary")?;
        std::fs::write(&path, json)
            .with_context(|| format!("recorder: writing {}", path.display()))?;
        self.rec.flush_blocking().ok();
        drop(self.rec);
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
}

/// Adds the messages dora dropped on the recorder's inputs since the last call to the summary
/// (and logs them); called after every event and once more after the last.
fn count_drops(stats: &mut Stats, events: &mut EventStream) {
    for (id, n) in trigait_node_log::warn_drops(events) {
        *stats.input_drops.entry(id.to_string()).or_default() += n;
    }
}
