//! What `summary.json` reports, accumulated as the recording runs: fused-pose error against the
//! simulator's ground truth (scored by [`trigait_scoring`], the rules `trigait eval` uses), NTP mapping error per sensor, end-to-end latency, dropped and
//! incomplete sets, and gaps in each source's stream.

use std::collections::{BTreeMap, VecDeque};

use nalgebra::Point3;
use serde::Serialize;
use trigait_schema::{FrameTiming, FusedPose, GroundTruth};
use trigait_scoring::{PositionErrors, TruthTrack};
use trigait_skeleton::Joint;

/// Ground truth older than this behind the newest sample is forgotten, ns.
const TRUTH_HORIZON_NANOS: i64 = 5_000_000_000;
/// Truth samples further apart than this around an instant are not interpolated, ns.
const TRUTH_MAX_SPAN_NANOS: i64 = 20_000_000;
/// A source silent for longer than this (arrival to arrival) has a gap, ns.
pub const GAP_NANOS: i64 = 150_000_000;

/// Running totals.
#[derive(Debug)]
pub struct Stats {
    warmup_nanos: i64,
    first_pose_nanos: Option<i64>,
    pose_stamps_nanos: Option<(i64, i64)>,
    warmup_poses: u64,
    winding_down: bool,
    wind_down_poses: u64,
    samples: Samples,
    handed: Handed,
    truth: TruthTrack,
    pending: VecDeque<FusedPose>,
    errors: PositionErrors,
    empty_poses: u64,
    joints_by_sensors_used: BTreeMap<usize, u64>,
    poses_without_truth: u64,
    timing: BTreeMap<String, SensorTiming>,
    sets: u64,
    last_seq: Option<u64>,
    dropped_sets: u64,
    incomplete_sets: u64,
    joints_fused: u64,
    joints_skipped: u64,
    skip_reasons: BTreeMap<String, u64>,
    estimators: BTreeMap<String, u64>,
    sync_wait: SyncWait,
    frames: BTreeMap<String, SensorFrames>,
    /// Inputs that could not be decoded.
    pub malformed: u64,
    /// Messages dora dropped per input (queue overflow), as reported by
    /// `EventStream::drain_drop_counts`.
    pub input_drops: BTreeMap<String, u64>,
}

#[derive(Debug, Default)]
struct SensorTiming {
    unsynchronised: u64,
    last_offset_nanos: Option<i64>,
    last_drift_ppm: Option<f64>,
    /// True capture time of the sensor's first mapped frame (the start of its warm-up).
    first_mapped_true_nanos: Option<i64>,
    /// Frames after the warm-up mapped more than [`WRONG_NANOS`] wrong.
    wrong: u64,
    /// True capture times of the first and the last of them.
    wrong_span: Option<(i64, i64)>,
}

/// A frame mapped further than this from its true capture time is mapped wrong, ns (the
/// thesis' synchronisation target, §6.4.1).
pub const WRONG_NANOS: i64 = 1_000_000;

#[derive(Debug, Default)]
struct SensorFrames {
    count: u64,
    last_seq: Option<u64>,
    seq_gaps: u64,
    impossible_joints: u64,
    last_arrival_nanos: Option<i64>,
    gaps: Vec<Gap>,
}

/// A stretch without frames from one source.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Gap {
    /// The source.
    pub sensor: String,
    /// When the last frame before the gap arrived, ns since the epoch.
    pub from_nanos: i64,
    /// Length, seconds (to the next frame, or to the end of the run).
    pub duration_secs: f64,
    /// Whether the source never came back (stopped or killed).
    pub until_end: bool,
}

/// `summary.json`.
#[derive(Debug, Clone, Serialize)]
pub struct Summary {
    /// Whether the run ended and this is its final summary; `false` in the summary rewritten
    /// as the run goes (what a killed recorder leaves behind).
    pub complete: bool,
    /// When this summary was written, ns since the epoch.
    pub written_at_nanos: i64,
    /// Fusion instant of the first pose recorded, server clock, ns since the epoch.
    pub first_pose_stamp_nanos: Option<i64>,
    /// Fusion instant of the newest pose recorded, server clock, ns since the epoch.
    pub last_pose_stamp_nanos: Option<i64>,
    /// Raw frames received per source.
    pub frames_in: BTreeMap<String, u64>,
    /// Frames a source sent that never reached the recorder (gaps in its frame sequence
    /// numbers, counted from 0), as `sync` saw them: it forwards every frame it receives in
    /// `frame_timing`.
    pub frames_lost: BTreeMap<String, u64>,
    /// Joint reports per source that no sensor could have measured (not finite, behind it or
    /// farther than [`trigait_skeleton::MAX_REPORT_RANGE_M`]): recorded as they came, left out
    /// of the fusion by `sync`.
    pub impossible_joints: BTreeMap<String, u64>,
    /// Fused poses received.
    pub sets_fused: u64,
    /// Sets never received (gaps in the set sequence).
    pub dropped_sets: u64,
    /// Sets that lacked at least one sensor.
    pub incomplete_sets: u64,
    /// Joints fused in all poses.
    pub joints_fused: u64,
    /// Joints skipped, by reason.
    pub joints_skipped: u64,
    /// Poses with no joint fused (every joint skipped).
    pub empty_poses: u64,
    /// Fused joints by the number of sensors the estimate used.
    pub joints_by_sensors_used: BTreeMap<usize, u64>,
    /// Fused joints by the estimator that fused them (`trilaterate`'s `METHOD`, `+robust`
    /// with `ROBUST`): what ran, whatever the YAML was meant to say.
    pub estimators: BTreeMap<String, u64>,
    /// Skip reasons and their counts.
    pub skip_reasons: BTreeMap<String, u64>,
    /// Per-joint RMSE against ground truth, metres (simulated sources only).
    pub rmse_m: BTreeMap<String, f64>,
    /// RMSE over all joints, metres.
    pub rmse_all_m: Option<f64>,
    /// RMSE per world axis (x, y, z), metres.
    pub rmse_xyz_m: Option<[f64; 3]>,
    /// Joint estimates compared with ground truth.
    pub truth_samples: u64,
    /// Poses for which no ground truth was at hand.
    pub poses_without_truth: u64,
    /// NTP mapping error per sensor.
    pub ntp: BTreeMap<String, NtpSummary>,
    /// End-to-end latency in the steady state (after [`Self::warmup`]), newest contributing
    /// frame sent → pose recorded, ms.
    pub latency_ms: Percentiles,
    /// The poses of the first moments, whose latency is not the steady state's.
    pub warmup: Warmup,
    /// The poses of the run's last moments, once a source has ended its stream as planned.
    pub wind_down: WindDown,
    /// Pose age when recorded (recorder clock − fusion instant) in the steady state (after
    /// [`Self::warmup`]), ms; includes the wait for the frame after the instant that
    /// interpolation needs.
    pub age_ms: Percentiles,
    /// How long `sync` let the sets wait, and why each went out when it did.
    pub sync_wait: SyncWait,
    /// Gaps in the sources' streams.
    pub gaps: Vec<Gap>,
    /// Inputs that could not be decoded.
    pub malformed_inputs: u64,
    /// Messages dora reported dropped per input (queue overflow at the recorder).
    pub input_drops: BTreeMap<String, u64>,
    /// Gait events and spatiotemporal parameters of the fused walk ([`crate::gait`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gait: Option<trigait_gait::LiveReport>,
}

/// The start of a run, reported apart: on their first messages dora opens its daemon-path
/// connections and zenoh its routes, and `sync` works through the frames that queued while it
/// started, so the first poses come late (about 100 ms at 16 sensors on 2 cores) whatever the
/// steady-state latency is.
#[derive(Debug, Clone, Serialize)]
pub struct Warmup {
    /// Its length after the first pose, seconds (`WARMUP_SECS`).
    pub secs: f64,
    /// Poses recorded in it.
    pub poses: u64,
    /// Their end-to-end latency, ms.
    pub latency_ms: Percentiles,
    /// Their age when recorded, ms: the first sets wait until every sensor is synchronised.
    pub age_ms: Percentiles,
}

/// The end of a run, reported apart: from the set on which `sync` says a source has sent its
/// planned last frame (`trigait.wind_down`), the sources are shutting down (16 processes
/// exiting on 2 cores delay the last frames by tens of ms) and `sync` sends the sets that
/// waited for the ended sources, so these poses say nothing about the steady state.
#[derive(Debug, Clone, Default, Serialize)]
pub struct WindDown {
    /// Poses recorded in it.
    pub poses: u64,
    /// Their end-to-end latency, ms.
    pub latency_ms: Percentiles,
    /// Their age when recorded, ms.
    pub age_ms: Percentiles,
}

/// `sync`'s wait budget and what ended each set's wait, from the sets' metadata
/// (`trigait.sync_wait_budget_nanos`, `trigait.sync_release`).
#[derive(Debug, Clone, Default, Serialize, PartialEq)]
pub struct SyncWait {
    /// How late a sensor's expected frame may be before a set stops waiting for it, ms.
    pub frame_wait_margin_ms: Option<f64>,
    /// The longest a set waits for its sensors, ms.
    pub deadline_ms: Option<f64>,
    /// Poses by what ended their set's wait: `frames` (every sensor's frames after the instant
    /// were in), `overdue` (a sensor's frame was overdue and not waited for), `deadline`, `end`
    /// (the sources ended); `unknown` when the set carried no reason.
    pub released: BTreeMap<String, u64>,
}

/// NTP error of one sensor.
#[derive(Debug, Clone, Serialize)]
pub struct NtpSummary {
    /// Frames mapped to the server clock with a known true capture time.
    pub frames_checked: u64,
    /// Frames before the sensor was synchronised.
    pub frames_unsynchronised: u64,
    /// |mapped − true| percentiles, ms.
    pub abs_error_ms: Percentiles,
    /// Share of checked frames with |error| < 1 ms.
    pub share_below_1ms: f64,
    /// Frames mapped more than 1 ms wrong, not counting the sensor's warm-up (frames captured
    /// within `WARMUP_SECS` of its first mapped one, while the filter has few samples): the
    /// frames a clock step or a congested link left wrong.
    pub frames_over_1ms: u64,
    /// True capture time from the first to the last of those frames, seconds (`None`: none):
    /// how long the mapping stayed wrong, if it was wrong in one stretch.
    pub over_1ms_span_secs: Option<f64>,
    /// Last offset estimate (sensor − server), ms.
    pub offset_ms: Option<f64>,
    /// Last drift estimate, ppm.
    pub drift_ppm: Option<f64>,
}

/// p50/p99/max of a sample, ms, by the one percentile rule.
pub use trigait_scoring::Percentiles;

/// The latency and age samples of one part of a run (the warm-up, the steady state or the
/// wind-down), ns, in arrival order.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PhaseSamples {
    latency_nanos: Vec<i64>,
    age_nanos: Vec<i64>,
}

impl PhaseSamples {
    #[cfg(test)]
    fn is_empty(&self) -> bool {
        self.latency_nanos.is_empty() && self.age_nanos.is_empty()
    }

    fn absorb(&mut self, newer: PhaseSamples) {
        self.latency_nanos.extend(newer.latency_nanos);
        self.age_nanos.extend(newer.age_nanos);
    }

    /// How many of each series there are: `(latency, age)`.
    fn lens(&self) -> (usize, usize) {
        (self.latency_nanos.len(), self.age_nanos.len())
    }

    /// The samples after the first `(latency, age)`.
    fn since(&self, (latency, age): (usize, usize)) -> PhaseSamples {
        PhaseSamples {
            latency_nanos: tail(&self.latency_nanos, latency),
            age_nanos: tail(&self.age_nanos, age),
        }
    }

    /// Their percentiles, ms: `(latency, age)`.
    fn percentiles(&self) -> (Percentiles, Percentiles) {
        (
            Percentiles::of_nanos(&self.latency_nanos),
            Percentiles::of_nanos(&self.age_nanos),
        )
    }
}

/// `v` after its first `from` values.
fn tail(v: &[i64], from: usize) -> Vec<i64> {
    v.get(from..).unwrap_or_default().to_vec()
}

/// The samples whose percentiles `summary.json` reports: end-to-end latency and age in the
/// steady state, the warm-up and the wind-down, and each sensor's |NTP mapping error|, ns, in
/// arrival order.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Samples {
    steady: PhaseSamples,
    warmup: PhaseSamples,
    wind_down: PhaseSamples,
    ntp_abs_err_nanos: BTreeMap<String, Vec<i64>>,
}

/// How many of each series of [`Samples`] were handed on already.
#[derive(Debug, Clone, Default)]
pub struct Handed {
    steady: (usize, usize),
    warmup: (usize, usize),
    wind_down: (usize, usize),
    ntp: BTreeMap<String, usize>,
}

impl Samples {
    /// Whether no series holds a sample.
    #[cfg(test)]
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.steady.is_empty()
            && self.warmup.is_empty()
            && self.wind_down.is_empty()
            && self.ntp_abs_err_nanos.values().all(Vec::is_empty)
    }

    /// Appends `newer`'s samples after these.
    pub fn absorb(&mut self, newer: Samples) {
        self.steady.absorb(newer.steady);
        self.warmup.absorb(newer.warmup);
        self.wind_down.absorb(newer.wind_down);
        for (sensor, errors) in newer.ntp_abs_err_nanos {
            self.ntp_abs_err_nanos
                .entry(sensor)
                .or_default()
                .extend(errors);
        }
    }

    /// The samples after those `handed` counts.
    fn since(&self, handed: &Handed) -> Samples {
        Samples {
            steady: self.steady.since(handed.steady),
            warmup: self.warmup.since(handed.warmup),
            wind_down: self.wind_down.since(handed.wind_down),
            ntp_abs_err_nanos: self
                .ntp_abs_err_nanos
                .iter()
                .map(|(id, v)| {
                    let from = handed.ntp.get(id).copied().unwrap_or(0);
                    (id.clone(), tail(v, from))
                })
                .collect(),
        }
    }

    /// What every series holds now.
    fn handed(&self) -> Handed {
        Handed {
            steady: self.steady.lens(),
            warmup: self.warmup.lens(),
            wind_down: self.wind_down.lens(),
            ntp: self
                .ntp_abs_err_nanos
                .iter()
                .map(|(id, v)| (id.clone(), v.len()))
                .collect(),
        }
    }

    /// Sets the percentiles of `summary` (and each sensor's `frames_checked` and
    /// `share_below_1ms`) from these samples: O(n log n) in the samples.
    pub fn fill(&self, summary: &mut Summary) {
        (summary.latency_ms, summary.age_ms) = self.steady.percentiles();
        (summary.warmup.latency_ms, summary.warmup.age_ms) = self.warmup.percentiles();
        (summary.wind_down.latency_ms, summary.wind_down.age_ms) = self.wind_down.percentiles();
        for (id, errors) in &self.ntp_abs_err_nanos {
            let Some(ntp) = summary.ntp.get_mut(id) else {
                continue;
            };
            let below = errors.iter().filter(|e| **e < WRONG_NANOS).count();
            ntp.frames_checked = errors.len() as u64;
            ntp.abs_error_ms = Percentiles::of_nanos(errors);
            ntp.share_below_1ms = if errors.is_empty() {
                0.0
            } else {
                below as f64 / errors.len() as f64
            };
        }
    }
}

impl Default for Stats {
    fn default() -> Self {
        Self::new(0)
    }
}

impl Stats {
    /// Totals whose latency percentiles leave out the poses recorded less than `warmup_nanos`
    /// after the first ([`Warmup`]).
    pub fn new(warmup_nanos: i64) -> Self {
        Self {
            warmup_nanos,
            first_pose_nanos: None,
            pose_stamps_nanos: None,
            warmup_poses: 0,
            winding_down: false,
            wind_down_poses: 0,
            samples: Samples::default(),
            handed: Handed::default(),
            truth: TruthTrack::new(TRUTH_HORIZON_NANOS, TRUTH_MAX_SPAN_NANOS),
            pending: VecDeque::new(),
            errors: PositionErrors::default(),
            empty_poses: 0,
            joints_by_sensors_used: BTreeMap::new(),
            poses_without_truth: 0,
            timing: BTreeMap::new(),
            sets: 0,
            last_seq: None,
            dropped_sets: 0,
            incomplete_sets: 0,
            joints_fused: 0,
            joints_skipped: 0,
            skip_reasons: BTreeMap::new(),
            estimators: BTreeMap::new(),
            sync_wait: SyncWait::default(),
            frames: BTreeMap::new(),
            malformed: 0,
            input_drops: BTreeMap::new(),
        }
    }

    /// Ground truth, one entry per true instant (an instant already held is skipped).
    pub fn push_truth(&mut self, rows: Vec<GroundTruth>) {
        let mut fresh = false;
        for row in rows {
            fresh |= self
                .truth
                .insert(row.true_stamp_nanos, row.position_in_world);
        }
        if fresh {
            self.score_pending(false);
        }
    }

    /// True position of `joint` at `at_nanos`, interpolated between the truth samples around it.
    #[must_use]
    pub fn truth_at(&self, joint: Joint, at_nanos: i64) -> Option<Point3<f64>> {
        self.truth.at(joint, at_nanos)
    }

    /// From now on the run winds down ([`WindDown`]): the poses that follow are reported
    /// apart from the steady state.
    pub fn begin_wind_down(&mut self) {
        self.winding_down = true;
    }

    /// A fused pose recorded at `now_nanos`; `trigger_sent_nanos` comes from the metadata
    /// `sync` attached.
    pub fn push_pose(&mut self, pose: FusedPose, now_nanos: i64, trigger_sent_nanos: Option<i64>) {
        self.sets += 1;
        let stamp = pose.stamp_nanos;
        let (first, last) = self.pose_stamps_nanos.get_or_insert((stamp, stamp));
        *first = (*first).min(stamp);
        *last = (*last).max(stamp);
        match self.last_seq {
            // Sync numbers its sets from 0: a first pose with seq k means k sets never came.
            None => self.dropped_sets += pose.set_seq,
            Some(last) if pose.set_seq > last + 1 => self.dropped_sets += pose.set_seq - last - 1,
            Some(_) => {}
        }
        self.last_seq = Some(self.last_seq.map_or(pose.set_seq, |l| l.max(pose.set_seq)));
        if !pose.missing_sensors.is_empty() {
            self.incomplete_sets += 1;
        }
        let first = *self.first_pose_nanos.get_or_insert(now_nanos);
        let warming_up = now_nanos - first < self.warmup_nanos;
        self.warmup_poses += u64::from(warming_up);
        let winding_down = self.winding_down && !warming_up;
        self.wind_down_poses += u64::from(winding_down);
        let phase = if warming_up {
            &mut self.samples.warmup
        } else if winding_down {
            &mut self.samples.wind_down
        } else {
            &mut self.samples.steady
        };
        if let Some(sent) = trigger_sent_nanos {
            phase.latency_nanos.push(now_nanos - sent);
        }
        phase.age_nanos.push(now_nanos - pose.stamp_nanos);
        self.joints_fused += pose.joints.len() as u64;
        self.joints_skipped += pose.skipped.len() as u64;
        self.empty_poses += u64::from(pose.joints.is_empty());
        for fused in pose.joints.values() {
            *self
                .joints_by_sensors_used
                .entry(fused.sensors_used.len())
                .or_default() += 1;
            *self.estimators.entry(fused.estimator.clone()).or_default() += 1;
        }
        for reason in pose.skipped.values() {
            *self.skip_reasons.entry(reason.clone()).or_default() += 1;
        }
        if !self.truth.is_empty() {
            self.pending.push_back(pose);
        }
        self.score_pending(false);
    }

    fn score_pending(&mut self, at_end: bool) {
        let newest = self.truth.newest_nanos();
        while let Some(pose) = self.pending.front() {
            if !at_end && newest.is_none_or(|n| n < pose.stamp_nanos) {
                break;
            }
            let Some(pose) = self.pending.pop_front() else {
                break;
            };
            let mut any = false;
            for (joint, fused) in &pose.joints {
                let Some(truth) = self.truth_at(*joint, pose.stamp_nanos) else {
                    continue;
                };
                any = true;
                self.errors.push(*joint, fused.position - truth);
            }
            if !any {
                self.poses_without_truth += 1;
            }
        }
    }

    /// What `sync` said of a pose's set: why it went out when it did, and its wait budget
    /// (`[frame wait margin, deadline]`, ns).
    pub fn push_sync_wait(&mut self, release: Option<&str>, budget_nanos: Option<&[i64]>) {
        *self
            .sync_wait
            .released
            .entry(release.unwrap_or("unknown").to_owned())
            .or_default() += 1;
        if let Some(&[margin, deadline]) = budget_nanos {
            self.sync_wait.frame_wait_margin_ms = Some(margin as f64 * 1e-6);
            self.sync_wait.deadline_ms = Some(deadline as f64 * 1e-6);
        }
    }

    /// Frame timings from `sync`.
    pub fn push_timing(&mut self, rows: &[FrameTiming]) {
        for row in rows {
            let t = self.timing.entry(row.sensor_id.clone()).or_default();
            match (
                row.server_stamp_nanos,
                row.error_nanos(),
                row.true_stamp_nanos,
            ) {
                (None, _, _) => t.unsynchronised += 1,
                (Some(_), Some(err), Some(true_nanos)) => {
                    self.samples
                        .ntp_abs_err_nanos
                        .entry(row.sensor_id.clone())
                        .or_default()
                        .push(err.abs());
                    let first = *t.first_mapped_true_nanos.get_or_insert(true_nanos);
                    if err.abs() > WRONG_NANOS && true_nanos - first >= self.warmup_nanos {
                        t.wrong += 1;
                        t.wrong_span =
                            Some(t.wrong_span.map_or((true_nanos, true_nanos), |(a, b)| {
                                (a.min(true_nanos), b.max(true_nanos))
                            }));
                    }
                }
                (Some(_), _, _) => {}
            }
            if row.offset_nanos.is_some() {
                t.last_offset_nanos = row.offset_nanos;
                t.last_drift_ppm = row.drift_ppm;
            }
        }
    }

    /// A raw frame of `sensor` arrived at `now_nanos` with `impossible_joints` joint reports
    /// no sensor could have measured.
    pub fn push_frame(&mut self, sensor: &str, seq: u64, impossible_joints: u64, now_nanos: i64) {
        let f = self.frames.entry(sensor.to_owned()).or_default();
        f.count += 1;
        f.impossible_joints += impossible_joints;
        match f.last_seq {
            // Sources number their frames from 0 and start sending only once every node of the
            // graph is up, so a first frame with seq k means k frames never arrived.
            None => f.seq_gaps += seq,
            Some(last) if seq > last + 1 => f.seq_gaps += seq - last - 1,
            Some(_) => {}
        }
        f.last_seq = Some(seq);
        if let Some(last) = f.last_arrival_nanos
            && now_nanos - last > GAP_NANOS
        {
            f.gaps.push(Gap {
                sensor: sensor.to_owned(),
                from_nanos: last,
                duration_secs: (now_nanos - last) as f64 * 1e-9,
                until_end: false,
            });
        }
        f.last_arrival_nanos = Some(now_nanos);
    }

    /// The summary at `end_nanos`: the final one (`at_end`: every pose scored, whether its
    /// ground truth came or not), or one of the run so far (poses whose ground truth has not
    /// come yet wait for the next). Sorts every sample for its percentiles: O(n log n).
    #[must_use]
    pub fn summary(&mut self, end_nanos: i64, at_end: bool) -> Summary {
        let mut summary = self.counts(end_nanos, at_end);
        self.samples.fill(&mut summary);
        summary
    }

    /// The summary of the run so far at `end_nanos` without its percentiles, and the samples
    /// that came since the last call: what the writer thread needs to bring `summary.json` up
    /// to date ([`Samples::fill`] on every sample it was handed), at a cost on the event loop
    /// that grows with what is new (and the RMSE's sum over the errors), not with sorting
    /// every sample.
    pub fn live(&mut self, end_nanos: i64) -> (Summary, Samples) {
        let summary = self.counts(end_nanos, false);
        let new = self.samples.since(&self.handed);
        self.handed = self.samples.handed();
        (summary, new)
    }

    /// [`Self::summary`] with every percentile left at its default (and `frames_checked`
    /// and `share_below_1ms` at 0): what is counted, not sorted.
    fn counts(&mut self, end_nanos: i64, at_end: bool) -> Summary {
        self.score_pending(at_end);
        let mut gaps = Vec::new();
        for (sensor, f) in &self.frames {
            gaps.extend(f.gaps.iter().cloned());
            if let Some(last) = f.last_arrival_nanos
                && end_nanos - last > GAP_NANOS
            {
                gaps.push(Gap {
                    sensor: sensor.clone(),
                    from_nanos: last,
                    duration_secs: (end_nanos - last) as f64 * 1e-9,
                    until_end: true,
                });
            }
        }
        Summary {
            complete: at_end,
            written_at_nanos: end_nanos,
            first_pose_stamp_nanos: self.pose_stamps_nanos.map(|(first, _)| first),
            last_pose_stamp_nanos: self.pose_stamps_nanos.map(|(_, last)| last),
            frames_in: self
                .frames
                .iter()
                .map(|(k, f)| (k.clone(), f.count))
                .collect(),
            frames_lost: self
                .frames
                .iter()
                .map(|(k, f)| (k.clone(), f.seq_gaps))
                .collect(),
            impossible_joints: self
                .frames
                .iter()
                .map(|(k, f)| (k.clone(), f.impossible_joints))
                .collect(),
            sets_fused: self.sets,
            dropped_sets: self.dropped_sets,
            incomplete_sets: self.incomplete_sets,
            joints_fused: self.joints_fused,
            joints_skipped: self.joints_skipped,
            empty_poses: self.empty_poses,
            joints_by_sensors_used: self.joints_by_sensors_used.clone(),
            estimators: self.estimators.clone(),
            skip_reasons: self.skip_reasons.clone(),
            rmse_m: self
                .errors
                .per_joint_rmse_m()
                .into_iter()
                .map(|(j, r)| (j.name().to_owned(), r))
                .collect(),
            rmse_all_m: (!self.errors.is_empty()).then(|| self.errors.rmse_m()),
            rmse_xyz_m: (!self.errors.is_empty()).then(|| self.errors.rmse_xyz_m()),
            truth_samples: self.errors.count() as u64,
            poses_without_truth: self.poses_without_truth,
            ntp: self
                .timing
                .iter()
                .map(|(id, t)| {
                    (
                        id.clone(),
                        NtpSummary {
                            frames_checked: 0,
                            frames_unsynchronised: t.unsynchronised,
                            abs_error_ms: Percentiles::default(),
                            share_below_1ms: 0.0,
                            frames_over_1ms: t.wrong,
                            over_1ms_span_secs: t.wrong_span.map(|(a, b)| (b - a) as f64 * 1e-9),
                            offset_ms: t.last_offset_nanos.map(|o| o as f64 * 1e-6),
                            drift_ppm: t.last_drift_ppm,
                        },
                    )
                })
                .collect(),
            latency_ms: Percentiles::default(),
            warmup: Warmup {
                secs: self.warmup_nanos as f64 * 1e-9,
                poses: self.warmup_poses,
                latency_ms: Percentiles::default(),
                age_ms: Percentiles::default(),
            },
            wind_down: WindDown {
                poses: self.wind_down_poses,
                ..WindDown::default()
            },
            age_ms: Percentiles::default(),
            sync_wait: self.sync_wait.clone(),
            gaps,
            malformed_inputs: self.malformed,
            input_drops: self.input_drops.clone(),
            gait: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A frame of `sensor` captured at true time `true_nanos`, mapped `err_nanos` off.
    fn timing(sensor: &str, seq: u64, true_nanos: i64, err_nanos: i64) -> FrameTiming {
        FrameTiming {
            sensor_id: sensor.into(),
            seq,
            local_stamp_nanos: true_nanos,
            server_stamp_nanos: Some(true_nanos + err_nanos),
            uncertainty_nanos: Some(100_000),
            offset_nanos: Some(0),
            drift_ppm: Some(0.0),
            true_stamp_nanos: Some(true_nanos),
            received_nanos: None,
            joints: Vec::new(),
        }
    }

    /// Frames mapped more than 1 ms wrong are counted per sensor after its warm-up (1 s from
    /// its first mapped frame), with the true-time span from the first to the last; 1 ms
    /// exactly is not wrong, and a sensor mapped well throughout reports none.
    #[test]
    fn counts_frames_mapped_over_1ms_after_the_warmup() {
        let mut stats = Stats::new(1_000_000_000);
        let period = 33_333_333;
        let rows: Vec<FrameTiming> = (0..150_u64)
            .flat_map(|seq| {
                let t = 500_000_000 + seq as i64 * period;
                let err = match t - 500_000_000 {
                    // Warm-up: a rough first fit.
                    d if d < 400_000_000 => 3_000_000,
                    // A +1 s step, 7 frames before the filter catches up.
                    d if (3_000_000_000..3_000_000_000 + 7 * period).contains(&d) => -1_000_000_000,
                    _ => 200_000,
                };
                [
                    timing("k1", seq, t, err),
                    timing("k2", seq, t + 1, -300_000),
                ]
            })
            .collect();
        stats.push_timing(&rows);
        stats.push_timing(&[timing("k1", 150, 5_600_000_000, 1_000_000)]);
        let s = stats.summary(6_000_000_000, true);
        let (k1, k2) = (&s.ntp["k1"], &s.ntp["k2"]);
        assert_eq!(k1.frames_checked, 151);
        assert_eq!(k1.frames_over_1ms, 7, "{k1:?}");
        let span = k1.over_1ms_span_secs.unwrap();
        assert!((span - 6.0 * period as f64 * 1e-9).abs() < 1e-9, "{span}");
        assert_eq!((k2.frames_over_1ms, k2.over_1ms_span_secs), (0, None));
    }

    /// The writer thread's summary — counts from [`Stats::live`], percentiles filled from
    /// every sample it was handed in pieces — is the summary of the run so far, whatever the
    /// pieces (sensors appearing between updates included).
    #[test]
    fn live_pieces_fill_the_same_summary() {
        let mut stats = Stats::new(100);
        let mut handed = Samples::default();
        let mut live = None;
        for step in 0..5_i64 {
            for k in 0..7_i64 {
                let seq = (step * 7 + k) as u64;
                let t = 1_000 + step * 1_000 + k * 10;
                stats.push_timing(&[timing("k1", seq, t, (k - 3) * 700_000)]);
                if step >= 2 {
                    stats.push_timing(&[timing("k2", seq, t, k * 300_000)]);
                }
                let pose = FusedPose {
                    set_seq: seq,
                    stamp_nanos: t,
                    joints: BTreeMap::new(),
                    skipped: BTreeMap::new(),
                    missing_sensors: Vec::new(),
                };
                stats.push_pose(pose, t + 50 + k * k, Some(t - k));
            }
            let (mut summary, new) = stats.live(10_000);
            handed.absorb(new);
            handed.fill(&mut summary);
            live = Some(summary);
        }
        let live = serde_json::to_value(live.unwrap()).unwrap();
        let whole = serde_json::to_value(stats.summary(10_000, false)).unwrap();
        assert_eq!(live, whole);
        assert_eq!(whole["ntp"]["k2"]["frames_checked"], 21);
        assert!(whole["latency_ms"]["count"].as_u64().unwrap() > 20);
        // Nothing new since: an empty piece.
        assert!(stats.live(10_000).1.is_empty());
    }
}
