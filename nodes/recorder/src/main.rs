//! `recorder`: the end of the graph. Logs everything to rerun (an `.rrd` file by default, a
//! live viewer when `RERUN_CONNECT` is set), keeps the thesis ring buffer, and writes into
//! `OUTPUT_DIR` as it goes (every `LIVE_UPDATE_SECS`, 0.5 s by default, [`config`]): its writer
//! thread ([`writer`]) appends the new frames to `trajectory.csv` and the raw recording,
//! rewrites `summary.json` (`"complete": false`) and flushes the `.rrd`, so a recorder killed
//! mid-run loses at most the last second while the disk keeps up, and the event loop never
//! waits for the disk. When the graph ends it writes `trajectory.txt` (thesis format),
//! `trajectory.csv`/`.trc`/`.c3d` (the run as a motion the CLI reads) and the final
//! `summary.json` whole.
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
mod writer;

use dora_node_api::arrow_v59::array::Array;
use dora_node_api::{
    DoraNode, Event, EventStream, MetadataParameters, Parameter, get_integer_param,
    get_string_param,
};
use eyre::Context;
use tracing::{error, info, warn};
use trigait_node_config::RigStamp;
use trigait_schema::{FrameTiming, FusedPose, GroundTruth, Message, ports};

use crate::config::Config;
use crate::export::{LiveTrajectory, Ring, write_summary, write_trajectory};
use crate::stats::{Stats, Summary};
use crate::writer::{Update, Writer};

fn main() -> eyre::Result<()> {
    trigait_node_log::init("recorder");
    let config = Config::from_env()?;
    let (node, events) =
        DoraNode::init_from_env().context("recorder: connecting to the dora daemon")?;
    trigait_node_config::check_inputs(
        "recorder",
        node.node_config().inputs.keys().map(|id| id.as_str()),
        &[ports::FUSED_POSE],
        &[ports::FRAME_TIMING, ports::GROUND_TRUTH],
    )?;
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
    live_csv: LiveTrajectory,
    /// Lines of the raw recording not handed to the writer yet (`None`: no raw recording).
    lines: Option<recording::Lines>,
    writer: Writer,
    last_update_nanos: i64,
    /// The longest a live update took on the event loop.
    longest_update: std::time::Duration,
}

/// The event loop; returns the summary it wrote.
pub fn run(config: Config, _node: DoraNode, mut events: EventStream) -> eyre::Result<Summary> {
    std::fs::create_dir_all(&config.out_dir)
        .with_context(|| format!("recorder: creating OUTPUT_DIR={}", config.out_dir.display()))?;
    let rec = viz::open(&config)?;
    viz::send_blueprint(&rec, &config.rig).context("recorder: sending the default blueprint")?;
    viz::log_static(&rec, &config.rig).context("recorder: logging the rig")?;
    export::clear_earlier_run(&config.out_dir).context("recorder: OUTPUT_DIR")?;
    let recording = config
        .record_frames
        .then(|| recording::Recording::start(&config.out_dir, &config.rig))
        .transpose()
        .context("recorder: starting the raw recording")?;
    let mut r = Recorder {
        gait: gait::Gait::new(&rec).context("recorder: logging the gait styles")?,
        stats: Stats::new(config.warmup_nanos),
        ring: Ring::new(config.ring_capacity),
        trajectory: trigait_fusion::Trajectory::new(),
        live_csv: LiveTrajectory::default(),
        lines: recording.is_some().then(recording::Lines::default),
        writer: Writer::spawn(writer::Files {
            csv: export::LiveCsv::new(&config.out_dir),
            recording,
            rec: rerun::RecordingStream::clone(&rec),
            dir: config.out_dir.clone(),
        })
        .context("recorder")?,
        rec,
        last_update_nanos: now_nanos(),
        longest_update: std::time::Duration::ZERO,
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
            r.update(now);
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
        let budget = match params.get(ports::SYNC_WAIT_BUDGET_NANOS) {
            Some(Parameter::ListInt(budget)) => Some(budget.as_slice()),
            _ => None,
        };
        self.stats
            .push_sync_wait(get_string_param(params, ports::SYNC_RELEASE), budget);
        if matches!(params.get(ports::WIND_DOWN), Some(Parameter::Bool(true))) {
            self.stats.begin_wind_down();
        }
        let logged = viz::log_pose(&self.rec, &pose, &truth, sent.map(|sent| now - sent))
            .and_then(|()| self.gait.push(&pose));
        self.ring.push(&pose);
        self.trajectory.push(&pose);
        if let Some(lines) = &mut self.lines {
            lines.push_pose(&pose);
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
                    let impossible = row.joints.iter().filter(|j| !j.is_possible()).count();
                    self.stats
                        .push_frame(&row.sensor_id, row.seq, impossible as u64, now);
                }
                self.stats.push_timing(&rows);
                if let Some(lines) = &mut self.lines {
                    lines.push_frames(&rows);
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

    /// Hands the writer thread what is new since the last update: the new frames of
    /// `trajectory.csv`, the new lines of the raw recording, the summary so far (its
    /// percentiles are sorted on the thread) and the new samples. Never waits ([`writer`]).
    fn update(&mut self, now: i64) {
        let started = std::time::Instant::now();
        self.last_update_nanos = now;
        let (summary, samples) = self.stats.live(now);
        self.writer.offer(Update {
            csv: self.live_csv.take_rows(&self.trajectory),
            lines: self.lines.as_mut().map(std::mem::take).unwrap_or_default(),
            samples,
            summary: Some(summary),
        });
        self.longest_update = self.longest_update.max(started.elapsed());
    }

    /// Writes the exports and the final `summary.json`, flushes the recording.
    /// The writer thread is handed the rest of the raw recording and joined first, so that no
    /// update of its lands after (or between) the final files.
    fn finish(mut self, config: &Config) -> eyre::Result<Summary> {
        let last = Update {
            lines: self.lines.take().unwrap_or_default(),
            ..Update::default()
        };
        let writes = self
            .writer
            .finish(last)
            .context("recorder: writing the raw recording")?;
        if writes.failed > 1 {
            warn!(
                "{} updates of the files while the run went failed",
                writes.failed
            );
        }
        info!(
            "{} updates written by the writer thread (the longest in {:.1} ms), {} merged into a later one while it was behind; the event loop spent at most {:.3} ms handing one over",
            writes.written,
            writes.longest_write.as_secs_f64() * 1e3,
            writes.coalesced,
            self.longest_update.as_secs_f64() * 1e3
        );
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
