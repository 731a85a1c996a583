//! [`SyncBuffer`]: frames in (sensor-local stamps), aligned sets out (server time).

use std::collections::{BTreeMap, BTreeSet, VecDeque};

use nalgebra::{Point3, Vector3};
use trigait_skeleton::{Joint, JointSample, SkeletonFrame, TrackingState};

use crate::filter::{ClockFilter, SampleOutcome, ServerTime};
use crate::params::{Interpolation, Policy, SyncParams};
use crate::{Error, NtpSample, Result};

/// A frame placed on the server clock.
#[derive(Debug, Clone, PartialEq)]
pub struct TimedFrame {
    /// The frame as the sensor sent it (sensor-local stamp, camera-frame joints).
    pub frame: SkeletonFrame,
    /// Capture time on the server clock, nanoseconds.
    pub server_stamp_nanos: i64,
    /// Uncertainty of `server_stamp_nanos`, nanoseconds.
    pub time_uncertainty_nanos: i64,
}

/// One sensor's contribution to an [`AlignedSet`].
#[derive(Debug, Clone, PartialEq)]
pub struct SensorView {
    /// Joints at the set's instant, in this sensor's camera frame (metres), sorted by joint.
    /// Only `Tracked`/`Inferred` joints; a resampled joint is `Inferred` if either sample was.
    pub joints: Vec<JointSample>,
    /// Estimated resampling error of each joint, metres, same order as `joints`: for `linear`
    /// the local second difference × (t − t₀)(t₁ − t)/2 (≤ |a|·dt²/8), for `cubic-hermite` the
    /// effect of the third difference on the finite-difference tangents; `Some(0.0)` for a
    /// sample taken as is (`slots`, or a frame exactly at the instant); `None` when there were
    /// too few samples to estimate it.
    pub interpolation_error_m: Vec<Option<f64>>,
    /// Sequence numbers of the frames used.
    pub frame_seqs: Vec<u64>,
    /// Capture time of the nearest frame used minus the set's stamp, nanoseconds (`slots`: how
    /// far the sensor's frame is from the fusion instant; `interpolate`: how far the nearest real
    /// sample is).
    pub skew_nanos: i64,
    /// Clock-sync uncertainty of the frames used (the largest), nanoseconds.
    pub time_uncertainty_nanos: i64,
}

/// Every sensor's joints at one server instant: what crosses the `sync → trilaterate` edge.
#[derive(Debug, Clone, PartialEq)]
pub struct AlignedSet {
    /// Counter of sets emitted by this buffer, from 0.
    pub seq: u64,
    /// The instant the set describes, server clock, nanoseconds. Strictly increasing.
    pub stamp_nanos: i64,
    /// The policy that built the set.
    pub policy: Policy,
    /// Per sensor that contributed.
    pub sensors: BTreeMap<String, SensorView>,
    /// Sensors expected but absent from this set, sorted.
    pub missing: Vec<String>,
    /// The largest clock-sync uncertainty among the sensors, nanoseconds.
    pub time_uncertainty_nanos: i64,
}

impl AlignedSet {
    /// Every expected sensor contributed.
    #[must_use]
    pub fn is_complete(&self) -> bool {
        self.missing.is_empty()
    }

    /// The largest |skew| among the sensors, nanoseconds.
    #[must_use]
    pub fn max_abs_skew_nanos(&self) -> i64 {
        self.sensors
            .values()
            .map(|v| v.skew_nanos.saturating_abs())
            .max()
            .unwrap_or(0)
    }
}

/// Running totals of a [`SyncBuffer`], for logs and the recorder's `summary.json`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SyncCounters {
    /// Frames given to `push`/`push_timed`.
    pub frames_in: u64,
    /// Frames from a sensor id the buffer was not built with (dropped).
    pub frames_unknown_sensor: u64,
    /// Frames before their sensor's clock filter was synchronised (dropped).
    pub frames_unsynchronised: u64,
    /// Frames whose `seq` was already buffered (dropped).
    pub frames_duplicate: u64,
    /// Frames that arrived after a set they belonged to was emitted (kept for later sets).
    pub frames_late: u64,
    /// Frames dropped because a sensor's buffer was full.
    pub frames_evicted: u64,
    /// Frames dropped because they were captured after the server's present (see
    /// [`SyncParams::max_future_nanos`](crate::SyncParams::max_future_nanos)).
    pub frames_from_future: u64,
    /// NTP samples given to `push_ntp`.
    pub ntp_in: u64,
    /// NTP samples rejected (any reason).
    pub ntp_rejected: u64,
    /// Clock steps detected.
    pub clock_steps: u64,
    /// Sets emitted.
    pub sets_out: u64,
    /// Sets emitted with at least one sensor missing.
    pub sets_incomplete: u64,
    /// Instants (`interpolate`) or cycles (`slots`) skipped because no sensor had data there.
    pub sets_empty: u64,
    /// Sets sent without waiting for a sensor whose next frame was overdue
    /// ([`SyncParams::frame_wait_margin_nanos`](crate::SyncParams::frame_wait_margin_nanos)).
    pub sets_overdue: u64,
    /// Sets sent because their latency deadline passed
    /// ([`SyncParams::latency_deadline_nanos`](crate::SyncParams::latency_deadline_nanos)).
    pub sets_deadline: u64,
}

/// Why a set went out when it did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Release {
    /// Every sensor had the frames after the instant that its resampling needs.
    Frames,
    /// Some sensor's next frame was overdue, or will not come (its stream ended,
    /// [`SyncBuffer::end_of_stream`]), and was not waited for
    /// ([`SyncParams::frame_wait_margin_nanos`](crate::SyncParams::frame_wait_margin_nanos)).
    Overdue,
    /// The latency deadline passed
    /// ([`SyncParams::latency_deadline_nanos`](crate::SyncParams::latency_deadline_nanos)).
    Deadline,
}

impl Release {
    /// Every name, as [`Release::name`] gives them.
    pub const NAMES: &'static [&'static str] = &["frames", "overdue", "deadline"];

    /// A short name for logs and metadata.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Release::Frames => "frames",
            Release::Overdue => "overdue",
            Release::Deadline => "deadline",
        }
    }
}

/// Releases remembered for [`SyncBuffer::release_of`].
const RELEASES_KEPT: usize = 4096;

/// Recent transport delays kept per sensor for [`SensorState::usual_lag_nanos`].
const LAG_SAMPLES: usize = 16;

#[derive(Debug, Clone)]
struct SensorState {
    slot: usize,
    clock: ClockFilter,
    frames: VecDeque<TimedFrame>,
    first_stamp: Option<i64>,
    newest_stamp: Option<i64>,
    /// Arrival clock − capture stamp of the newest frames (those pushed after an
    /// [`SyncBuffer::advance_to`]), oldest first.
    lags: VecDeque<i64>,
    /// The sensor has sent its last frame ([`SyncBuffer::end_of_stream`]).
    ended: bool,
}

impl SensorState {
    /// The sensor's frame period: the median interval between its buffered frames, if it has
    /// two with different stamps.
    fn frame_period_nanos(&self) -> Option<i64> {
        let mut intervals: Vec<i64> = self
            .frames
            .iter()
            .zip(self.frames.iter().skip(1))
            .map(|(a, b)| b.server_stamp_nanos.saturating_sub(a.server_stamp_nanos))
            .filter(|&d| d > 0)
            .collect();
        median(&mut intervals)
    }

    /// How long the sensor's frames usually take to arrive after their capture (median of
    /// the recent ones; 0 when unknown).
    fn usual_lag_nanos(&self) -> i64 {
        let mut lags: Vec<i64> = self.lags.iter().copied().collect();
        median(&mut lags).unwrap_or(0).max(0)
    }
}

/// The median (the lower of the middle two), `None` for no values.
fn median(values: &mut [i64]) -> Option<i64> {
    if values.is_empty() {
        return None;
    }
    let mid = (values.len() - 1) / 2;
    Some(*values.select_nth_unstable(mid).1)
}

/// Aligns the frames of N sensors on the server clock and groups them into [`AlignedSet`]s
/// (DESIGN.md, Time; thesis §6.4.1–6.4.2). Generic over the number of sensors; state per sensor in
/// a `BTreeMap`, so output never depends on the order of ids or of arrival among sensors.
///
/// Time only moves with the data: "now" is the newest server-mapped capture stamp pushed, or what
/// [`SyncBuffer::advance_to`] was told (a node calls it on a timer so a set still goes out when
/// every source has stopped).
#[derive(Debug, Clone)]
pub struct SyncBuffer {
    params: SyncParams,
    sensors: BTreeMap<String, SensorState>,
    /// Next instant index (`interpolate`) or cycle index (`slots`) to emit.
    next: Option<i64>,
    now_nanos: Option<i64>,
    /// The newest server-clock reading given to `advance_to` (not moved by frame stamps).
    clock_nanos: Option<i64>,
    last_stamp_nanos: Option<i64>,
    seq: u64,
    counters: SyncCounters,
    /// Why each of the latest sets went out, by set seq, oldest first.
    releases: VecDeque<(u64, Release)>,
}

impl SyncBuffer {
    /// A buffer for `sensor_ids`. Under `slots`, sensor i of this list sends in slot i (thesis
    /// k₁, k₂, k₃, …); under `interpolate` the order does not matter.
    pub fn new<I, S>(sensor_ids: I, params: SyncParams) -> Result<Self>
    where
        I: IntoIterator<Item = S>,
        S: Into<String>,
    {
        params.validate()?;
        let mut sensors = BTreeMap::new();
        for (slot, id) in sensor_ids.into_iter().enumerate() {
            let id: String = id.into();
            let state = SensorState {
                slot,
                clock: ClockFilter::new(params.clock.clone())?,
                frames: VecDeque::new(),
                first_stamp: None,
                newest_stamp: None,
                lags: VecDeque::new(),
                ended: false,
            };
            if sensors.insert(id.clone(), state).is_some() {
                return Err(Error::DuplicateSensor { sensor_id: id });
            }
        }
        if sensors.is_empty() {
            return Err(Error::NoSensors);
        }
        Ok(SyncBuffer {
            params,
            sensors,
            next: None,
            now_nanos: None,
            clock_nanos: None,
            last_stamp_nanos: None,
            seq: 0,
            counters: SyncCounters::default(),
            releases: VecDeque::new(),
        })
    }

    /// The parameters in use.
    #[must_use]
    pub fn params(&self) -> &SyncParams {
        &self.params
    }

    /// The running totals.
    #[must_use]
    pub fn counters(&self) -> &SyncCounters {
        &self.counters
    }

    /// Why set `seq` went out when it did (the latest few thousand sets are remembered).
    #[must_use]
    pub fn release_of(&self, seq: u64) -> Option<Release> {
        let at = self.releases.partition_point(|&(s, _)| s < seq);
        self.releases
            .get(at)
            .filter(|&&(s, _)| s == seq)
            .map(|&(_, r)| r)
    }

    /// Tells the buffer `sensor_id` has sent its last frame (its source ended its stream, or
    /// its input closed), and returns the sets that became ready: from now on no set waits for
    /// that sensor's next frame, which will not come, and its frames so far still count where
    /// they reach. An unknown sensor is an error.
    pub fn end_of_stream(
        &mut self,
        sensor_id: &str,
    ) -> Result<impl Iterator<Item = AlignedSet> + use<>> {
        let Some(state) = self.sensors.get_mut(sensor_id) else {
            return Err(self.unknown(sensor_id));
        };
        state.ended = true;
        Ok(self.drain().into_iter())
    }

    /// Sensor ids, sorted.
    pub fn sensor_ids(&self) -> impl Iterator<Item = &str> {
        self.sensors.keys().map(String::as_str)
    }

    /// The clock filter of `sensor_id` (for its [`ClockFilter::estimate`]).
    #[must_use]
    pub fn clock(&self, sensor_id: &str) -> Option<&ClockFilter> {
        self.sensors.get(sensor_id).map(|s| &s.clock)
    }

    fn unknown(&self, sensor_id: &str) -> Error {
        Error::UnknownSensor {
            sensor_id: sensor_id.to_owned(),
            known: self.sensors.keys().cloned().collect(),
        }
    }

    /// Feeds one NTP exchange with `sensor_id` to that sensor's clock filter.
    pub fn push_ntp(&mut self, sensor_id: &str, sample: NtpSample) -> Result<SampleOutcome> {
        let Some(state) = self.sensors.get_mut(sensor_id) else {
            return Err(self.unknown(sensor_id));
        };
        self.counters.ntp_in += 1;
        let outcome = state.clock.push(sample);
        match outcome {
            SampleOutcome::Rejected(_) => self.counters.ntp_rejected += 1,
            SampleOutcome::Step { .. } => self.counters.clock_steps += 1,
            SampleOutcome::Accepted(_) => {}
        }
        Ok(outcome)
    }

    /// Server time of a sensor-local stamp, if that sensor is synchronised.
    #[must_use]
    pub fn server_from_local(&self, sensor_id: &str, local_nanos: i64) -> Option<ServerTime> {
        self.sensors
            .get(sensor_id)?
            .clock
            .server_from_local(local_nanos)
    }

    /// Maps `frame` to server time with its sensor's clock filter, buffers it, and returns the
    /// sets that became ready. Errors (frame dropped and counted): unknown sensor, sensor not
    /// synchronised yet.
    pub fn push(
        &mut self,
        frame: SkeletonFrame,
    ) -> Result<impl Iterator<Item = AlignedSet> + use<>> {
        let mapped = match self.sensors.get(&frame.sensor_id) {
            None => {
                self.counters.frames_in += 1;
                self.counters.frames_unknown_sensor += 1;
                return Err(self.unknown(&frame.sensor_id));
            }
            Some(state) => state.clock.server_from_local(frame.local_stamp_nanos),
        };
        let Some(mapped) = mapped else {
            self.counters.frames_in += 1;
            self.counters.frames_unsynchronised += 1;
            return Err(Error::NotSynchronised {
                sensor_id: frame.sensor_id,
                seq: frame.seq,
            });
        };
        self.push_timed(TimedFrame {
            frame,
            server_stamp_nanos: mapped.server_nanos,
            time_uncertainty_nanos: mapped.uncertainty_nanos,
        })
    }

    /// Buffers a frame already on the server clock (replays, tests, an external sync) and
    /// returns the sets that became ready. Errors (frame dropped and counted): unknown sensor,
    /// captured after the server's present ([`SyncBuffer::advance_to`]).
    pub fn push_timed(
        &mut self,
        timed: TimedFrame,
    ) -> Result<impl Iterator<Item = AlignedSet> + use<>> {
        self.counters.frames_in += 1;
        let Some(state) = self.sensors.get_mut(&timed.frame.sensor_id) else {
            self.counters.frames_unknown_sensor += 1;
            return Err(self.unknown(&timed.frame.sensor_id));
        };
        if state.frames.iter().any(|f| f.frame.seq == timed.frame.seq) {
            self.counters.frames_duplicate += 1;
            return Ok(Vec::new().into_iter());
        }
        let stamp = timed.server_stamp_nanos;
        if let Some(clock) = self.clock_nanos {
            let lead_nanos = stamp.saturating_sub(clock);
            if lead_nanos > self.params.max_future_nanos {
                self.counters.frames_from_future += 1;
                return Err(Error::FrameFromFuture {
                    sensor_id: timed.frame.sensor_id,
                    seq: timed.frame.seq,
                    lead_nanos,
                });
            }
        }
        if self.last_stamp_nanos.is_some_and(|last| stamp <= last) {
            self.counters.frames_late += 1;
        }
        let at = state
            .frames
            .partition_point(|f| f.server_stamp_nanos <= stamp);
        state.frames.insert(at, timed);
        while state.frames.len() > self.params.max_frames_per_sensor {
            state.frames.pop_front();
            self.counters.frames_evicted += 1;
        }
        if let Some(clock) = self.clock_nanos {
            state.lags.push_back(clock.saturating_sub(stamp));
            if state.lags.len() > LAG_SAMPLES {
                state.lags.pop_front();
            }
        }
        state.first_stamp = Some(state.first_stamp.map_or(stamp, |s| s.min(stamp)));
        state.newest_stamp = Some(state.newest_stamp.map_or(stamp, |s| s.max(stamp)));
        self.now_nanos = Some(self.now_nanos.map_or(stamp, |n| n.max(stamp)));
        Ok(self.drain().into_iter())
    }

    /// Tells the buffer the server clock reads `now_nanos` (the `sync` node *is* the server
    /// clock): sets whose deadline passed go out even while every source is silent, and from now
    /// on a frame stamped more than [`SyncParams::max_future_nanos`] after the newest reading is
    /// rejected as impossible, so one garbage stamp cannot drag the schedule into the future.
    /// Call it before each `push` or on a timer faster than `max_future_nanos`.
    pub fn advance_to(&mut self, now_nanos: i64) -> impl Iterator<Item = AlignedSet> + use<> {
        self.clock_nanos = Some(self.clock_nanos.map_or(now_nanos, |n| n.max(now_nanos)));
        self.now_nanos = Some(self.now_nanos.map_or(now_nanos, |n| n.max(now_nanos)));
        self.drain().into_iter()
    }

    /// Emits every set the buffered frames can still make (end of stream).
    pub fn flush(&mut self) -> impl Iterator<Item = AlignedSet> + use<> {
        let newest = self.sensors.values().filter_map(|s| s.newest_stamp).max();
        match newest {
            Some(newest) => {
                let until = newest
                    .saturating_add(self.params.latency_deadline_nanos)
                    .saturating_add(self.params.max_extrapolation_nanos)
                    .saturating_add(1);
                self.now_nanos = Some(self.now_nanos.map_or(until, |n| n.max(until)));
                self.drain().into_iter()
            }
            None => Vec::new().into_iter(),
        }
    }

    // ---- schedule -------------------------------------------------------------------------

    fn cycle_nanos(&self) -> i64 {
        let n = i64::try_from(self.sensors.len()).unwrap_or(i64::MAX);
        self.params.slot_nanos.saturating_mul(n.saturating_add(1))
    }

    /// The set's stamp for index `k`: fusion instant, or start of the fusion slot.
    fn stamp_of(&self, k: i64) -> i64 {
        match self.params.policy {
            Policy::Interpolate => self.instant(k),
            Policy::Slots => {
                let n = i64::try_from(self.sensors.len()).unwrap_or(i64::MAX);
                self.cycle_start(k)
                    .saturating_add(self.params.slot_nanos.saturating_mul(n))
            }
        }
    }

    fn cycle_start(&self, k: i64) -> i64 {
        saturate(
            i128::from(self.params.slot_origin_nanos)
                + i128::from(k) * i128::from(self.cycle_nanos()),
        )
    }

    fn slot_end(&self, k: i64, slot: usize) -> i64 {
        let i = i128::try_from(slot).unwrap_or(i128::MAX / 4) + 1;
        saturate(i128::from(self.cycle_start(k)) + i * i128::from(self.params.slot_nanos))
    }

    /// Fusion rate in millihertz, so instants are exact integers for rates like 30 or 29.97 Hz.
    fn rate_millihertz(&self) -> i128 {
        ((self.params.fusion_rate_hz * 1000.0).round() as i128).max(1)
    }

    fn instant(&self, k: i64) -> i64 {
        let offset = (i128::from(k) * 1_000_000_000_000).div_euclid(self.rate_millihertz());
        saturate(i128::from(self.params.fusion_origin_nanos) + offset)
    }

    /// Smallest index whose stamp is ≥ `t`.
    fn first_index_at_or_after(&self, t: i64) -> i64 {
        let mut k = match self.params.policy {
            Policy::Interpolate => {
                let rel = i128::from(t) - i128::from(self.params.fusion_origin_nanos);
                saturate((rel * self.rate_millihertz()).div_euclid(1_000_000_000_000))
            }
            Policy::Slots => {
                let rel = i128::from(t) - i128::from(self.params.slot_origin_nanos);
                saturate(rel.div_euclid(i128::from(self.cycle_nanos().max(1))))
            }
        };
        // The estimate is off by at most one either way; settle it exactly.
        while k > i64::MIN && self.stamp_of(k - 1) >= t {
            k -= 1;
        }
        while k < i64::MAX && self.stamp_of(k) < t {
            k += 1;
        }
        k
    }

    /// Smallest index whose set can use a frame captured at `t`.
    fn first_index_using(&self, t: i64) -> i64 {
        match self.params.policy {
            Policy::Interpolate => {
                self.first_index_at_or_after(t.saturating_sub(self.params.max_extrapolation_nanos))
            }
            Policy::Slots => {
                let rel = i128::from(t) - i128::from(self.params.slot_origin_nanos);
                saturate(rel.div_euclid(i128::from(self.cycle_nanos().max(1))))
            }
        }
    }

    // ---- emission -------------------------------------------------------------------------

    fn drain(&mut self) -> Vec<AlignedSet> {
        let mut out = Vec::new();
        while let Some(k) = self.next.or_else(|| self.start_index()) {
            self.next = Some(k);
            let Some(release) = self.ready(k) else {
                break;
            };
            match self.build(k) {
                Some(set) => {
                    self.counters.sets_out += 1;
                    match release {
                        Release::Frames => {}
                        Release::Overdue => self.counters.sets_overdue += 1,
                        Release::Deadline => self.counters.sets_deadline += 1,
                    }
                    if !set.is_complete() {
                        self.counters.sets_incomplete += 1;
                    }
                    self.releases.push_back((set.seq, release));
                    if self.releases.len() > RELEASES_KEPT {
                        self.releases.pop_front();
                    }
                    self.last_stamp_nanos = Some(set.stamp_nanos);
                    self.seq += 1;
                    out.push(set);
                    self.next = Some(k.saturating_add(1));
                }
                None => {
                    // Nothing anywhere near this instant: jump to the next frame, if any.
                    let stamp = self.stamp_of(k);
                    let upcoming = self
                        .sensors
                        .values()
                        .filter_map(|s| {
                            s.frames
                                .iter()
                                .map(|f| f.server_stamp_nanos)
                                .find(|&t| t > stamp)
                        })
                        .min();
                    let Some(upcoming) = upcoming else { break };
                    let jump = self.first_index_using(upcoming).max(k.saturating_add(1));
                    self.counters.sets_empty += u64::try_from(jump - k).unwrap_or(0);
                    self.next = Some(jump);
                }
            }
            if let Some(k) = self.next {
                self.prune(k);
            }
        }
        out
    }

    /// Where to start once every sensor has sent a frame, or the deadline passed since the first.
    fn start_index(&self) -> Option<i64> {
        let firsts: Vec<i64> = self
            .sensors
            .values()
            .filter_map(|s| s.first_stamp)
            .collect();
        let earliest = *firsts.iter().min()?;
        let latest = *firsts.iter().max()?;
        let everyone = firsts.len() == self.sensors.len();
        let waited = self
            .now_nanos
            .is_some_and(|now| now >= earliest.saturating_add(self.params.latency_deadline_nanos));
        (everyone || waited).then(|| match self.params.policy {
            Policy::Interpolate => self.first_index_at_or_after(latest),
            Policy::Slots => self.first_index_using(latest),
        })
    }

    /// Whether set `k` may go out now, and why: every sensor has the frames it needs, or the
    /// ones that lack them are overdue, or the deadline passed.
    fn ready(&self, k: i64) -> Option<Release> {
        let stamp = self.stamp_of(k);
        if self
            .now_nanos
            .is_some_and(|now| now >= stamp.saturating_add(self.params.latency_deadline_nanos))
        {
            return Some(Release::Deadline);
        }
        let mut release = Release::Frames;
        for s in self.sensors.values() {
            let has_frames = match self.params.policy {
                Policy::Interpolate => self.resample_is_final(s, stamp),
                Policy::Slots => s
                    .newest_stamp
                    .is_some_and(|t| t >= self.slot_end(k, s.slot)),
            };
            if has_frames {
                continue;
            }
            if !self.is_overdue(s) {
                return None;
            }
            release = Release::Overdue;
        }
        Some(release)
    }

    /// Whether the sensor's next frame is later than expected by more than
    /// [`SyncParams::frame_wait_margin_nanos`]: its newest frame plus one frame period plus its
    /// usual transport delay is that far behind the present. Asked only once the sets have
    /// started ([`Self::start_index`] waits up to the deadline for every sensor's first frame),
    /// so a sensor that has still sent nothing the buffer could use (silent, or not yet
    /// synchronised) holds no set back, and neither does one whose stream has ended.
    fn is_overdue(&self, s: &SensorState) -> bool {
        if s.ended {
            return true;
        }
        let Some(newest) = s.newest_stamp else {
            return true;
        };
        let Some(now) = self.now_nanos else {
            return false;
        };
        let period = s
            .frame_period_nanos()
            .unwrap_or_else(|| self.params.fusion_period_nanos());
        let expected = newest
            .saturating_add(period)
            .saturating_add(s.usual_lag_nanos());
        now >= expected.saturating_add(self.params.frame_wait_margin_nanos)
    }

    /// Whether this sensor's resampling at `t` has what it waits for: its frames after `t` (one
    /// for linear, two for cubic Hermite). With [`SyncParams::bridge_gaps`], also every joint
    /// seen near `t` needs its own samples after `t`, unless the newest frame is already so far
    /// past its last sample that a later one would exceed the gap limit.
    fn resample_is_final(&self, s: &SensorState, t: i64) -> bool {
        let need = match self.params.interpolation {
            Interpolation::Linear => 1,
            Interpolation::CubicHermite => 2,
        };
        let Some(newest) = s.newest_stamp.filter(|&n| n >= t) else {
            return false;
        };
        if !self.params.bridge_gaps {
            // Frames are kept in stamp order.
            let after = s
                .frames
                .iter()
                .rev()
                .take_while(|f| f.server_stamp_nanos >= t)
                .count();
            return after >= need;
        }
        let gap = self.params.max_gap_nanos;
        let near_from = t.saturating_sub(gap);
        let mut last_seen: BTreeMap<Joint, (i64, usize)> = BTreeMap::new();
        for f in s
            .frames
            .iter()
            .filter(|f| f.server_stamp_nanos >= near_from)
        {
            for sample in usable(&f.frame) {
                let entry = last_seen.entry(sample.joint).or_insert((i64::MIN, 0));
                entry.0 = entry.0.max(f.server_stamp_nanos);
                if f.server_stamp_nanos >= t {
                    entry.1 += 1;
                }
            }
        }
        last_seen
            .values()
            .all(|&(last, after)| after >= need || newest.saturating_sub(last) > gap)
    }

    fn prune(&mut self, next: i64) {
        let keep_from = match self.params.policy {
            Policy::Interpolate => self
                .stamp_of(next)
                .saturating_sub(self.params.max_gap_nanos.saturating_mul(2)),
            Policy::Slots => self
                .cycle_start(next)
                .saturating_sub(self.params.slot_max_frame_age_nanos),
        };
        for s in self.sensors.values_mut() {
            while s
                .frames
                .front()
                .is_some_and(|f| f.server_stamp_nanos < keep_from)
            {
                s.frames.pop_front();
            }
        }
    }

    fn build(&self, k: i64) -> Option<AlignedSet> {
        let stamp = self.stamp_of(k);
        let mut sensors = BTreeMap::new();
        let mut missing = Vec::new();
        for (id, state) in &self.sensors {
            let view = match self.params.policy {
                Policy::Slots => self.slot_view(k, stamp, state),
                Policy::Interpolate => resample(&state.frames, stamp, &self.params),
            };
            match view {
                Some(v) if !v.joints.is_empty() => {
                    sensors.insert(id.clone(), v);
                }
                _ => missing.push(id.clone()),
            }
        }
        if sensors.is_empty() {
            return None;
        }
        let time_uncertainty_nanos = sensors
            .values()
            .map(|v: &SensorView| v.time_uncertainty_nanos)
            .max()
            .unwrap_or(0);
        Some(AlignedSet {
            seq: self.seq,
            stamp_nanos: stamp,
            policy: self.params.policy,
            sensors,
            missing,
            time_uncertainty_nanos,
        })
    }

    /// Thesis §6.4.2: the newest frame captured before the end of the sensor's slot, if it is
    /// not older than `slot_max_frame_age_nanos`.
    fn slot_view(&self, k: i64, stamp: i64, state: &SensorState) -> Option<SensorView> {
        let end = self.slot_end(k, state.slot);
        let oldest = end.saturating_sub(self.params.slot_max_frame_age_nanos);
        let f = state
            .frames
            .iter()
            .rev()
            .find(|f| f.server_stamp_nanos < end && f.server_stamp_nanos >= oldest)?;
        let joints: Vec<JointSample> = usable(&f.frame).collect();
        Some(SensorView {
            interpolation_error_m: vec![Some(0.0); joints.len()],
            joints,
            frame_seqs: vec![f.frame.seq],
            skew_nanos: f.server_stamp_nanos.saturating_sub(stamp),
            time_uncertainty_nanos: f.time_uncertainty_nanos,
        })
    }
}

fn saturate(v: i128) -> i64 {
    i64::try_from(v).unwrap_or(if v < 0 { i64::MIN } else { i64::MAX })
}

fn usable(frame: &SkeletonFrame) -> impl Iterator<Item = JointSample> + '_ {
    let mut seen = BTreeSet::new();
    let mut joints: Vec<JointSample> = frame
        .joints
        .iter()
        .filter(|s| s.is_measured() && seen.insert(s.joint))
        .copied()
        .collect();
    joints.sort_by_key(|s| s.joint);
    joints.into_iter()
}

/// One usable sample of one joint.
#[derive(Debug, Clone, Copy)]
struct Knot {
    t: i64,
    p: Point3<f64>,
    state: TrackingState,
    seq: u64,
    uncertainty: i64,
}

/// Seconds between two stamps (f64, exact enough at any absolute epoch).
fn secs(from: i64, to: i64) -> f64 {
    (i128::from(to) - i128::from(from)) as f64 * 1e-9
}

/// Second divided difference ×2 (≈ acceleration) through three knots.
fn second_derivative(a: &Knot, b: &Knot, c: &Knot) -> Option<Vector3<f64>> {
    let (h0, h1) = (secs(a.t, b.t), secs(b.t, c.t));
    if h0 <= 0.0 || h1 <= 0.0 {
        return None;
    }
    Some(((c.p - b.p) / h1 - (b.p - a.p) / h0) * (2.0 / (h0 + h1)))
}

/// The `interpolate` policy for one sensor at instant `t`.
fn resample(frames: &VecDeque<TimedFrame>, t: i64, params: &SyncParams) -> Option<SensorView> {
    let window = params.max_gap_nanos.saturating_mul(2);
    let near: Vec<&TimedFrame> = frames
        .iter()
        .filter(|f| (i128::from(f.server_stamp_nanos) - i128::from(t)).abs() <= i128::from(window))
        .collect();
    let joint_ids: BTreeSet<Joint> = near
        .iter()
        .flat_map(|f| f.frame.joints.iter())
        .filter(|s| s.is_measured())
        .map(|s| s.joint)
        .collect();

    let mut joints = Vec::new();
    let mut errors = Vec::new();
    let mut seqs = BTreeSet::new();
    let mut nearest: Option<i64> = None;
    let mut uncertainty = 0;
    for joint in joint_ids {
        let knots: Vec<Knot> = near
            .iter()
            .filter_map(|f| {
                f.frame.joint(joint).map(|s| Knot {
                    t: f.server_stamp_nanos,
                    p: s.position_in_kinect,
                    state: s.state,
                    seq: f.frame.seq,
                    uncertainty: f.time_uncertainty_nanos,
                })
            })
            .collect();
        let Some((position, state, error, used)) = resample_joint(&knots, t, params) else {
            continue;
        };
        joints.push(JointSample {
            joint,
            position_in_kinect: position,
            state,
        });
        errors.push(error);
        for knot in used {
            seqs.insert(knot.seq);
            uncertainty = uncertainty.max(knot.uncertainty);
            let skew = knot.t.saturating_sub(t);
            if nearest.is_none_or(|n| skew.saturating_abs() < n.saturating_abs()) {
                nearest = Some(skew);
            }
        }
    }
    Some(SensorView {
        joints,
        interpolation_error_m: errors,
        frame_seqs: seqs.into_iter().collect(),
        skew_nanos: nearest?,
        time_uncertainty_nanos: uncertainty,
    })
}

type Resampled = (Point3<f64>, TrackingState, Option<f64>, Vec<Knot>);

/// Resamples one joint's knots (sorted by time) at `t`; `None` if the rules forbid it.
fn resample_joint(knots: &[Knot], t: i64, params: &SyncParams) -> Option<Resampled> {
    let gap_ok = |a: &Knot, b: &Knot| b.t.saturating_sub(a.t) <= params.max_gap_nanos;
    let after = knots.partition_point(|k| k.t < t);
    // Exactly on a knot.
    if let Some(k) = knots.get(after).filter(|k| k.t == t) {
        return Some((k.p, k.state, Some(0.0), vec![*k]));
    }
    let before = after.checked_sub(1);
    match (before.and_then(|i| knots.get(i)), knots.get(after)) {
        (Some(a), Some(b)) if gap_ok(a, b) => {
            let prev = before
                .and_then(|i| i.checked_sub(1))
                .and_then(|i| knots.get(i))
                .filter(|p| gap_ok(p, a));
            let next = knots.get(after + 1).filter(|n| gap_ok(b, n));
            let h = secs(a.t, b.t);
            let s = secs(a.t, t) / h;
            // Lagrange remainder of the chord: f''·(t − t₀)(t₁ − t)/2.
            let chord_factor = secs(a.t, t) * secs(t, b.t) / 2.0;
            let chord_error = prev
                .and_then(|p| second_derivative(p, a, b))
                .or_else(|| next.and_then(|n| second_derivative(a, b, n)))
                .map(|acc| acc.norm() * chord_factor);
            let (p, error) = match params.interpolation {
                Interpolation::Linear => (a.p + (b.p - a.p) * s, chord_error),
                Interpolation::CubicHermite => {
                    let chord = (b.p - a.p) / h;
                    let m0 = prev.map_or(chord, |p| (b.p - p.p) / secs(p.t, b.t));
                    let m1 = next.map_or(chord, |n| (n.p - a.p) / secs(a.t, n.t));
                    let (s2, s3) = (s * s, s * s * s);
                    let h00 = 2.0 * s3 - 3.0 * s2 + 1.0;
                    let h10 = s3 - 2.0 * s2 + s;
                    let h01 = -2.0 * s3 + 3.0 * s2;
                    let h11 = s3 - s2;
                    let p = Point3::from(
                        a.p.coords * h00 + m0 * (h10 * h) + b.p.coords * h01 + m1 * (h11 * h),
                    );
                    // Central-difference tangents are off by ≈ f'''·h²/6; their weight in the
                    // Hermite basis is h·(|h10| + |h11|).
                    let error = match (prev, next) {
                        (Some(p0), Some(n)) => third_derivative(p0, a, b, n)
                            .map(|jerk| jerk.norm() * h * h / 6.0 * h * (h10.abs() + h11.abs())),
                        _ => chord_error,
                    };
                    (p, error)
                }
            };
            let mut used = vec![*a, *b];
            if params.interpolation == Interpolation::CubicHermite {
                used.extend(prev.copied());
                used.extend(next.copied());
            }
            Some((p, a.state.min(b.state), error, used))
        }
        (Some(a), _) if t.saturating_sub(a.t) <= params.max_extrapolation_nanos => {
            let i = before?;
            let p = knots.get(i.checked_sub(1)?).filter(|p| gap_ok(p, a))?;
            let q = i
                .checked_sub(2)
                .and_then(|j| knots.get(j))
                .filter(|q| gap_ok(q, p));
            extrapolate(p, a, q, t)
        }
        (_, Some(b)) if b.t.saturating_sub(t) <= params.max_extrapolation_nanos => {
            let n = knots.get(after + 1).filter(|n| gap_ok(b, n))?;
            let q = knots.get(after + 2).filter(|q| gap_ok(n, q));
            extrapolate(n, b, q, t)
        }
        _ => None,
    }
}

/// Linear extrapolation from `far` through `near` to `t`; error from the second difference with
/// `third` (the knot beyond `far`) when there is one. `None` if the two knots share a stamp.
fn extrapolate(far: &Knot, near: &Knot, third: Option<&Knot>, t: i64) -> Option<Resampled> {
    let h = secs(far.t, near.t);
    if h == 0.0 {
        return None;
    }
    let p = near.p + (near.p - far.p) * (secs(near.t, t) / h);
    let error = third.and_then(|q| {
        let (a, b, c) = if q.t < far.t {
            (q, far, near)
        } else {
            (near, far, q)
        };
        second_derivative(a, b, c)
            .map(|acc| acc.norm() * (secs(far.t, t) * secs(near.t, t)).abs() / 2.0)
    });
    Some((p, near.state.min(far.state), error, vec![*far, *near]))
}

/// Third derivative (6 × third divided difference) through four knots in time order.
fn third_derivative(a: &Knot, b: &Knot, c: &Knot, d: &Knot) -> Option<Vector3<f64>> {
    let dd1 = |x: &Knot, y: &Knot| {
        let h = secs(x.t, y.t);
        (h > 0.0).then(|| (y.p - x.p) / h)
    };
    let (ab, bc, cd) = (dd1(a, b)?, dd1(b, c)?, dd1(c, d)?);
    let abc = (bc - ab) / secs(a.t, c.t);
    let bcd = (cd - bc) / secs(b.t, d.t);
    let abcd = (bcd - abc) / secs(a.t, d.t);
    Some(abcd * 6.0)
}
