//! `recorder`: the end of the graph. Logs everything to rerun (an `.rrd` file by default, a
//! live viewer when `RERUN_CONNECT` is set), keeps the thesis ring buffer, and writes into
//! `OUTPUT_DIR` as it goes when asked (`LIVE_UPDATE_SECS`, [`config`]): it then appends the new frames to
//! `trajectory.csv`, rewrites `summary.json` (`"complete": false`) and flushes the `.rrd`, so
//! a recorder killed mid-run loses at most the last half second. When the graph ends it
//! writes `trajectory.txt` (thesis format), `trajectory.csv`/`.trc`/`.c3d` (the run as a motion
//! the CLI reads) and the final `summary.json` whole.
//! Configuration: [`config`]; entity paths: [`viz`].

mod blueprint;
mod config;
mod export;
mod gait;
mod recording;
mod stats;
#[cfg(test)]
mod tests;
mod viz;

use dora_node_api::arrow_v59::array::Array;
use dora_node_api::{DoraNode, Event, EventStream, MetadataParameters, get_integer_param};
use eyre::Context;
use tracing::{error, info, warn};
use trigait_node_config::RigStamp;
use trigait_schema::{FrameTiming, FusedPose, GroundTruth, Message, ports};

use crate::config::Config;
use crate::export::{LiveFiles, Ring, write_summary, write_trajectory};
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
            _ => Input::Unknown(id),
        }
    }
}

/// The recording and what is accumulated for the files written at the end.
struct Recorder {
    rec: viz::Viz,
    gait: gait::Gait,
    stats: Stats,
    ring: Ring,
    trajectory: trigait_fusion::Trajectory,
    live: LiveFiles,
    recording: Option<recording::Recording>,
    last_update_nanos: i64,
    update_errors: u64,
}

/// The event loop; returns the summary it wrote.
pub fn run(config: Config, _node: DoraNode, mut events: EventStream) -> eyre::Result<Summary> {
    std::fs::create_dir_all(&config.out_dir)
        .with_context(|| format!("recorder: creating OUTPUT_DIR={}", config.out_dir.display()))?;
    let rec = viz::open(&config)?;
    viz::send_blueprint(&rec, &config.rig).context("recorder: sending the default blueprint")?;
    viz::log_static(&rec, &config.rig).context("recorder: logging the rig")?;
    let mut r = Recorder {
        gait: gait::Gait::new(&rec).context("recorder: logging the gait styles")?,
        rec,
        stats: Stats::new(config.warmup_nanos),
        ring: Ring::new(config.ring_capacity),
        trajectory: trigait_fusion::Trajectory::new(),
        live: LiveFiles::start(&config.out_dir).context("recorder: OUTPUT_DIR")?,
        recording: config
            .record_frames
            .then(|| recording::Recording::start(&config.out_dir, &config.rig))
            .transpose()
            .context("recorder: starting the raw recording")?,
        last_update_nanos: now_nanos(),
        update_errors: 0,
    };
    let stamp = RigStamp::new("recorder", &config.rig);
    let mut rerun_errors = 0_u64;
    while let Some(event) = events.recv() {
        let now = now_nanos();
        match event {
            Event::Input { id, metadata, data } => {
                let array = data.as_array();
                let array = array.as_ref();
                let input = Input::parse(id.as_str());
                if matches!(input, Input::FusedPose | Input::FrameTiming) {
                    stamp.check_params(&metadata.parameters)?;
                }
                let logged = match input {
                    Input::FusedPose => r.on_pose(&metadata.parameters, array, now),
                    Input::FrameTiming => r.on_timing(array, now),
                    Input::GroundTruth => {
                        r.on_truth(array);
                        Ok(())
                    }
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
            Event::Error(e) => warn!("event stream error: {e}"),
            _ => {}
        }
        count_drops(&mut r.stats, &mut events);
        if config
            .live_update_nanos
            .is_some_and(|period| now - r.last_update_nanos >= period)
        {
            r.update(&config, now);
        }
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
            .and_then(|()| self.gait.push(&pose));
        self.ring.push(&pose);
        self.trajectory.push(&pose);
        if let Some(recording) = &mut self.recording {
            recording.push_pose(&pose);
        }
        self.stats.push_pose(pose, now, sent);
        logged
    }

    /// `sync`'s frame timings: every frame it received with its placement on the server clock
    /// (NTP error, clock estimates, counts and gaps per source) and its raw joints.
    fn on_timing(&mut self, array: &dyn Array, now: i64) -> eyre::Result<()> {
        match FrameTiming::decode_many(array) {
            Ok(rows) => {
                for row in &rows {
                    self.stats.push_frame(&row.sensor_id, row.seq, now);
                }
                self.stats.push_timing(&rows);
                if let Some(recording) = &mut self.recording {
                    recording.push_frames(&rows);
                }
                viz::log_timing(&self.rec, &rows)?;
                rows.iter()
                    .try_for_each(|row| viz::log_raw(&self.rec, row, now))
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

    /// Brings the files up to date: new frames appended to `trajectory.csv`, `summary.json`
    /// of the run so far, the recording flushed. A failure is logged (the first, then
    /// counted) and the run goes on; the final write reports it again.
    fn update(&mut self, config: &Config, now: i64) {
        self.last_update_nanos = now;
        let summary = self.stats.summary(now, false);
        let updated = self
            .live
            .update_trajectory(&self.trajectory)
            .and_then(|()| {
                self.recording
                    .as_mut()
                    .map_or(Ok(()), recording::Recording::flush)
            })
            .and_then(|()| write_summary(&config.out_dir, &summary).map(|_| ()));
        if let Err(e) = updated {
            self.update_errors += 1;
            if self.update_errors == 1 {
                error!(
                    "recorder: updating the files while the run goes failed (further failures counted): {e:#}"
                );
            }
        }
        // Asks rerun's sink thread to write out what it holds, without waiting for it: a
        // blocking flush (a disk or a viewer that is slow) would delay the poses behind it.
        if let Err(e) = self.rec.flush_async() {
            warn!("flushing the recording: {e}");
        }
    }

    /// Writes the exports and the final `summary.json`, flushes the recording.
    fn finish(mut self, config: &Config) -> eyre::Result<Summary> {
        if self.update_errors > 1 {
            warn!(
                "{} updates of the files while the run went failed",
                self.update_errors
            );
        }
        let mut summary = self.stats.summary(now_nanos(), true);
        let (gait_report, gait_logged) = self.gait.finish();
        summary.gait = Some(gait_report);
        if let Err(e) = gait_logged {
            error!("rerun logging of the gait report failed: {e:#}");
        }
        self.ring
            .write(&config.out_dir)
            .context("recorder: writing the thesis text export")?;
        write_trajectory(&config.out_dir, &self.trajectory)
            .context("recorder: writing the trajectory files")?;
        if let Some(recording) = &mut self.recording {
            recording
                .flush()
                .context("recorder: writing the raw recording")?;
        }
        let path = write_summary(&config.out_dir, &summary).context("recorder")?;
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
