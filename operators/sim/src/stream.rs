//! Sensors as the timed streams a dataflow source sends: when the next frame is due on the host
//! clock, the frame captured then (camera frame, stamped by the sensor's own clock), and — for
//! one simulated sensor of the rig — the ground truth since the previous frame.
//!
//! - [`SimulatedSensor`]: the [`Simulator`] playing an endless lap (out and back along the
//!   walkway) at the sensor's frame rate and phase.
//! - [`ReplayedSensor`]: a recorded Kinect v2 SDK skeleton file played back at the frame rate
//!   or as fast as possible, optionally looped.
//! - [`RecordedSensor`]: one sensor's frames of a trial recording (`trigait-recording`) played
//!   back on the recorded timeline, in real time or as fast as possible, each frame carrying
//!   where the recording's `sync` placed it on the server clock ([`RecordedPlacement`]).
//! - [`SensorClock`]: the host clock (the server clock of a one-host graph) seen through a
//!   simulated offset, drift and jitter ([`crate::clock::SimClock`]), which stamps both.

use rand_chacha::ChaCha8Rng;
use trigait_kinect::NoiseModel;
use trigait_motion::SdkFrame;
use trigait_rig::Rig;
use trigait_schema::{FrameTiming, GroundTruth};
use trigait_skeleton::{Joint, MotionClip, SkeletonFrame};

use crate::Simulator;
use crate::clock::SimClock;

/// Spacing of ground-truth instants, ns: fine enough that interpolating them at any fusion
/// instant is exact to well under a millimetre.
pub const TRUTH_STEP_NANOS: i64 = 2_000_000;

/// Why a stream cannot be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum StreamError {
    /// The sensor id is not in the rig.
    #[error("{sensor:?} is not in rig {rig:?} (sensors: {known})")]
    UnknownSensor {
        /// The id asked for.
        sensor: String,
        /// The rig's name.
        rig: String,
        /// The rig's sensor ids, comma-separated.
        known: String,
    },
    /// The motion has none of the joints to report.
    #[error("motion {motion:?} defines none of the joints to report")]
    NoJoints {
        /// The motion's name.
        motion: String,
    },
    /// A frame rate that is not a positive number of nanoseconds per frame.
    #[error("frame period {period_nanos} ns is not positive")]
    BadPeriod {
        /// The period asked for.
        period_nanos: i64,
    },
}

/// One capture.
#[derive(Debug, Clone)]
pub struct Captured {
    /// The frame as the sensor reports it (camera frame, sensor clock).
    pub frame: SkeletonFrame,
    /// True capture instant on the server clock (simulation only).
    pub true_stamp_nanos: Option<i64>,
    /// Ground truth since the previous capture, one entry per instant (the truth-sending
    /// simulated sensor only).
    pub truth: Vec<GroundTruth>,
    /// Where and when the recording's `sync` placed the frame on the server clock (replayed
    /// recordings only).
    pub recorded: Option<RecordedPlacement>,
}

/// A recorded frame's place on the recording's server clock.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RecordedPlacement {
    /// Server-clock capture stamp, ns (`None`: the sensor was not synchronised then).
    pub server_stamp_nanos: Option<i64>,
    /// Its uncertainty, ns.
    pub uncertainty_nanos: i64,
    /// Server clock when the recording's `sync` received the frame, ns (`None`: not recorded).
    pub received_nanos: Option<i64>,
}

/// The sensor's clock: the host clock seen through a simulated offset, drift and jitter, drift
/// counted from the stream's start.
#[derive(Debug, Clone)]
pub struct SensorClock {
    clock: SimClock,
    start_nanos: i64,
    rng: ChaCha8Rng,
}

impl SensorClock {
    /// `clock` starting to drift at host time `start_nanos`, its jitter drawn from `rng`.
    #[must_use]
    pub fn new(clock: SimClock, start_nanos: i64, rng: ChaCha8Rng) -> Self {
        Self {
            clock,
            start_nanos,
            rng,
        }
    }

    /// What the sensor clock reads at host time `true_nanos`.
    pub fn local(&mut self, true_nanos: i64) -> i64 {
        self.start_nanos
            + self
                .clock
                .local_from_true(true_nanos - self.start_nanos, &mut self.rng)
    }
}

/// How a simulated sensor runs.
#[derive(Debug, Clone, PartialEq)]
pub struct SimulatedSensorParams {
    /// The sensor's id in the rig.
    pub sensor_id: String,
    /// Joints reported (those the motion lacks are dropped).
    pub joints: Vec<Joint>,
    /// Noise seed (each sensor of the rig draws its own stream from it).
    pub seed: u64,
    /// Frame period, ns.
    pub period_nanos: i64,
    /// Capture phase on the frame grid, ns (`None`: the sensor's share of a period by its
    /// index in the rig, so the sensors of a rig capture evenly staggered).
    pub phase_nanos: Option<i64>,
    /// Whether this sensor sends the ground truth (`None`: only the rig's first sensor does,
    /// so each true instant is sent once per graph).
    pub ground_truth: Option<bool>,
}

/// A simulated sensor playing `lap` endlessly.
#[derive(Debug, Clone)]
pub struct SimulatedSensor {
    sim: Simulator,
    index: usize,
    rng: ChaCha8Rng,
    lap_nanos: i64,
    /// Host time at which the lap starts (its phase at instant t is t − this, modulo the lap).
    lap_epoch_nanos: i64,
    period_nanos: i64,
    next_nanos: i64,
    seq: u64,
    sends_truth: bool,
    last_truth_nanos: Option<i64>,
}

impl SimulatedSensor {
    /// The sensor `params.sensor_id` of `rig` watching `lap` (a motion on the walkway that
    /// ends where it starts, e.g. [`lap`]), its first frame due at or after host time `now`.
    ///
    /// # Errors
    /// [`StreamError`]: a sensor the rig lacks, a motion without the joints, a bad period.
    pub fn new(
        rig: &Rig,
        lap: MotionClip,
        params: &SimulatedSensorParams,
        now: i64,
    ) -> Result<Self, StreamError> {
        let index = rig
            .sensors
            .iter()
            .position(|s| s.id == params.sensor_id)
            .ok_or_else(|| StreamError::UnknownSensor {
                sensor: params.sensor_id.clone(),
                rig: rig.name.clone(),
                known: rig
                    .sensors
                    .iter()
                    .map(|s| s.id.as_str())
                    .collect::<Vec<_>>()
                    .join(", "),
            })?;
        if params.period_nanos <= 0 {
            return Err(StreamError::BadPeriod {
                period_nanos: params.period_nanos,
            });
        }
        let lap_nanos = (lap.duration_secs() * 1e9).round() as i64;
        let name = lap.name().to_owned();
        let sim = Simulator::new(rig, lap, &params.joints, &NoiseModel::default());
        if sim.joints().is_empty() {
            return Err(StreamError::NoJoints { motion: name });
        }
        let period = params.period_nanos;
        let phase = params.phase_nanos.unwrap_or_else(|| {
            (period as f64 * index as f64 / rig.sensors.len() as f64).round() as i64
        });
        Ok(Self {
            rng: Simulator::sensor_rng(params.seed, index),
            sim,
            index,
            lap_nanos: lap_nanos.max(1),
            lap_epoch_nanos: 0,
            period_nanos: period,
            next_nanos: next_on_grid(now, period, phase.rem_euclid(period)),
            seq: 0,
            sends_truth: params.ground_truth.unwrap_or(index == 0),
            last_truth_nanos: None,
        })
    }

    /// Host time of the next capture.
    #[must_use]
    pub fn next_due(&self) -> i64 {
        self.next_nanos
    }

    /// Moves the first capture to the first instant of this sensor's grid at or after host
    /// time `now`, so that a source which took time to get ready (loading the motion, building
    /// a renderer, connecting to the daemon) starts its stream then, not with a backlog of
    /// instants already past. Does nothing once a frame has been captured, or to an earlier
    /// `now`.
    pub fn begin_at(&mut self, now: i64) {
        if self.seq == 0 && now > self.next_nanos {
            let phase = self.next_nanos.rem_euclid(self.period_nanos);
            self.next_nanos = next_on_grid(now, self.period_nanos, phase);
        }
    }

    /// Starts the lap at host time `epoch_nanos` instead of at the Unix epoch's multiples of
    /// its length. Every source of a graph is its own process, and they agree on where the
    /// body is at an instant only through a shared start; counted from when the graph was
    /// made, every run of a graph also walks the same part of the lap in its first seconds,
    /// so two graphs run one after the other are scored on the same walking (not one on a
    /// turn and the other on a stride). Does nothing once a frame has been captured (the body
    /// would jump).
    pub fn start_lap_at(&mut self, epoch_nanos: i64) {
        if self.seq == 0 {
            self.lap_epoch_nanos = epoch_nanos;
        }
    }

    /// Whether this sensor sends the ground truth.
    #[must_use]
    pub fn sends_truth(&self) -> bool {
        self.sends_truth
    }

    /// Where in the lap (seconds) the body is at host time `true_nanos`.
    #[must_use]
    pub fn lap_secs(&self, true_nanos: i64) -> f64 {
        (true_nanos - self.lap_epoch_nanos).rem_euclid(self.lap_nanos) as f64 * 1e-9
    }

    /// Captures the frame due ([`Self::next_due`]), stamped by `clock`, with the ground truth
    /// on the [`TRUTH_STEP_NANOS`] grid since the previous capture (up to its instant).
    pub fn capture(&mut self, clock: &mut SensorClock) -> Captured {
        let t = self.next_nanos;
        let local = clock.local(t);
        let frame = self
            .sim
            .frame(self.index, self.seq, self.lap_secs(t), local, &mut self.rng);
        let mut truth = Vec::new();
        if self.sends_truth {
            let from = self
                .last_truth_nanos
                .map_or(t - self.period_nanos, |l| l + 1);
            let mut g = from.div_euclid(TRUTH_STEP_NANOS)
                + i64::from(from.rem_euclid(TRUTH_STEP_NANOS) != 0);
            while g * TRUTH_STEP_NANOS <= t {
                let at = g * TRUTH_STEP_NANOS;
                truth.push(GroundTruth {
                    true_stamp_nanos: at,
                    position_in_world: self.sim.truth(self.lap_secs(at)),
                });
                self.last_truth_nanos = Some(at);
                g += 1;
            }
        }
        self.seq += 1;
        self.next_nanos = t + self.period_nanos;
        Captured {
            frame,
            true_stamp_nanos: Some(t),
            truth,
            recorded: None,
        }
    }
}

/// A recorded skeleton file played back as sensor `sensor_id`.
#[derive(Debug, Clone)]
pub struct ReplayedSensor {
    id: String,
    frames: Vec<SdkFrame>,
    at: usize,
    fast: bool,
    looped: bool,
    period_nanos: i64,
    next_nanos: i64,
    seq: u64,
}

impl ReplayedSensor {
    /// `frames` as sensor `sensor_id`, one every `period_nanos` from host time `now` (or as
    /// fast as asked for when `fast`), from the start again at the end when `looped`.
    #[must_use]
    pub fn new(
        sensor_id: String,
        frames: Vec<SdkFrame>,
        period_nanos: i64,
        fast: bool,
        looped: bool,
        now: i64,
    ) -> Self {
        Self {
            id: sensor_id,
            frames,
            at: 0,
            fast,
            looped,
            period_nanos,
            next_nanos: now,
            seq: 0,
        }
    }

    /// Host time of the next frame; `None` when the file is played out.
    #[must_use]
    pub fn next_due(&self) -> Option<i64> {
        (self.at < self.frames.len()).then_some(self.next_nanos)
    }

    /// The first frame goes out at host time `now` rather than at the time the sensor was
    /// made (see [`SimulatedSensor::begin_at`]). Does nothing once a frame has been sent.
    pub fn begin_at(&mut self, now: i64) {
        if self.seq == 0 {
            self.next_nanos = self.next_nanos.max(now);
        }
    }

    /// Whether every frame has been played (never when looped): the last one sent ended the
    /// stream.
    #[must_use]
    pub fn played_out(&self) -> bool {
        self.at >= self.frames.len()
    }

    /// The next recorded frame, stamped at host time `now` by `clock`.
    pub fn capture(&mut self, now: i64, clock: &mut SensorClock) -> Option<Captured> {
        let recorded = self.frames.get(self.at)?;
        let frame = SkeletonFrame {
            sensor_id: self.id.clone(),
            seq: self.seq,
            local_stamp_nanos: clock.local(now),
            joints: recorded.joints.clone(),
        };
        self.seq += 1;
        self.at += 1;
        if self.at == self.frames.len() && self.looped {
            self.at = 0;
        }
        self.next_nanos = if self.fast {
            now
        } else {
            self.next_nanos + self.period_nanos
        };
        Some(Captured {
            frame,
            true_stamp_nanos: None,
            truth: Vec::new(),
            recorded: None,
        })
    }
}

/// How fast a recording plays.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Pace {
    /// On the recorded timeline, each frame re-stamped by the node's own sensor clock at its
    /// due instant, so `sync` synchronises it afresh, as a live sensor's (the recorded clock
    /// jitter is not reproduced; the recorded placement still rides along).
    RealTime,
    /// The recorded timeline this many times faster, every frame keeping its recorded
    /// sensor-local stamp: only a `sync` that places frames on their recorded server stamps
    /// can align them.
    Faster(f64),
}

impl Pace {
    /// `fast`: sending a whole trial at once overflowed dora's queues and lost frames (its
    /// direct path drops silently), so "as fast as possible" is this bounded speed-up.
    pub const FAST: Pace = Pace::Faster(20.0);
}

/// One sensor of a trial recording played back. Frames keep their recorded `seq`, joints and
/// true stamp, and carry their recorded server placement ([`Captured::recorded`]). The
/// timeline is the recording's server clock: frame `i` is due at host time
/// `start + (tᵢ − origin) / speed`, `tᵢ` its server stamp (a frame recorded before its sensor
/// was synchronised is placed with that sensor's first recorded mapping), `origin` shared by
/// every sensor of the recording so that their sources stay in step ([`Pace`]).
///
/// A dataflow delivers nothing sent before the receiver listens: faster than real time, the
/// play starts when the receiver shows it is there ([`Self::receiver_ready`]: `sync`'s first
/// NTP request), or [`FAST_START_TIMEOUT_NANOS`] after the stream was made without one.
#[derive(Debug, Clone)]
pub struct RecordedSensor {
    frames: Vec<FrameTiming>,
    /// Recorded time of each frame after the origin, ns (non-decreasing).
    offsets_nanos: Vec<i64>,
    at: usize,
    pace: Pace,
    made_nanos: i64,
    start_nanos: Option<i64>,
    /// Faster than real time: the host time until which the source stays after its last
    /// frame (set then), so the frames still queued for the receiver reach it.
    linger_until: Option<i64>,
    done: bool,
}

/// How long a recording played faster than real time keeps its source alive after the last
/// frame, ns: a dataflow node that exits with frames still queued for a slower receiver
/// loses them (measured: the last third of a sensor's frames at 20× real time).
pub const FAST_LINGER_NANOS: i64 = 2_000_000_000;

/// How long a recording played faster than real time waits for its receiver, ns.
pub const FAST_START_TIMEOUT_NANOS: i64 = 10_000_000_000;

impl RecordedSensor {
    /// The frames of `sensor_id` in `recording` (in recorded order), the timeline from
    /// `origin_nanos` on the recording's server clock ([`recording_origin`]); made at host
    /// time `now` (in real time the play starts then). No frame is allowed: the source then
    /// ends at once.
    #[must_use]
    pub fn new(
        recording: &[FrameTiming],
        sensor_id: &str,
        origin_nanos: i64,
        pace: Pace,
        now: i64,
    ) -> Self {
        let frames: Vec<FrameTiming> = recording
            .iter()
            .filter(|f| f.sensor_id == sensor_id)
            .cloned()
            .collect();
        // Server minus local of the sensor's first synchronised frame, for frames before it.
        let first_mapping = frames
            .iter()
            .find_map(|f| Some(f.server_stamp_nanos? - f.local_stamp_nanos));
        let mut offsets_nanos = Vec::with_capacity(frames.len());
        let mut last = 0;
        for f in &frames {
            let t = f.server_stamp_nanos.unwrap_or_else(|| {
                f.local_stamp_nanos
                    .saturating_add(first_mapping.unwrap_or(origin_nanos - f.local_stamp_nanos))
            });
            last = t.saturating_sub(origin_nanos).max(last);
            offsets_nanos.push(last);
        }
        Self {
            frames,
            offsets_nanos,
            at: 0,
            pace,
            made_nanos: now,
            start_nanos: (pace == Pace::RealTime).then_some(now),
            linger_until: None,
            done: false,
        }
    }

    /// Frames of this sensor in the recording.
    #[must_use]
    pub fn len(&self) -> usize {
        self.frames.len()
    }

    /// Whether the recording has no frame of this sensor.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }

    /// Host time of the next frame (after the last, faster than real time: the end of the
    /// linger, [`FAST_LINGER_NANOS`]); `None` when played out.
    #[must_use]
    pub fn next_due(&self) -> Option<i64> {
        if self.done {
            return None;
        }
        if self.at == self.frames.len() {
            return self.linger_until;
        }
        let offset = *self.offsets_nanos.get(self.at)?;
        let Some(start) = self.start_nanos else {
            return Some(self.made_nanos.saturating_add(FAST_START_TIMEOUT_NANOS));
        };
        let offset = match self.pace {
            Pace::RealTime => offset,
            Pace::Faster(speed) => (offset as f64 / speed.max(1e-9)).round() as i64,
        };
        Some(start.saturating_add(offset))
    }

    /// Whether every recorded frame has been played: the last one sent ended the stream
    /// (faster than real time the source still lingers, [`Self::next_due`]).
    #[must_use]
    pub fn played_out(&self) -> bool {
        self.at >= self.frames.len()
    }

    /// In real time, the play starts at host time `now` rather than at the time the sensor was
    /// made (see [`SimulatedSensor::begin_at`]). Does nothing once a frame has been played, or
    /// faster than real time, where the receiver starts the play ([`Self::receiver_ready`]).
    pub fn begin_at(&mut self, now: i64) {
        if self.at == 0 && self.pace == Pace::RealTime {
            self.made_nanos = self.made_nanos.max(now);
            self.start_nanos = Some(self.made_nanos);
        }
    }

    /// The receiver of the frames is listening: faster than real time, the play starts at
    /// host time `now`.
    pub fn receiver_ready(&mut self, now: i64) {
        self.start_nanos.get_or_insert(now);
    }

    /// The next recorded frame; in real time stamped by `clock` at its due instant.
    pub fn capture(&mut self, clock: &mut SensorClock) -> Option<Captured> {
        let due = self.next_due()?;
        // Waited for the receiver in vain: start now.
        self.start_nanos.get_or_insert(due);
        let Some(recorded) = self.frames.get(self.at) else {
            self.done = true;
            return None;
        };
        self.at += 1;
        if self.at == self.frames.len() {
            match self.pace {
                Pace::RealTime => self.done = true,
                Pace::Faster(_) => self.linger_until = Some(due.saturating_add(FAST_LINGER_NANOS)),
            }
        }
        let frame = SkeletonFrame {
            sensor_id: recorded.sensor_id.clone(),
            seq: recorded.seq,
            local_stamp_nanos: match self.pace {
                Pace::RealTime => clock.local(due),
                Pace::Faster(_) => recorded.local_stamp_nanos,
            },
            joints: recorded.joints.clone(),
        };
        Some(Captured {
            frame,
            true_stamp_nanos: recorded.true_stamp_nanos,
            truth: Vec::new(),
            recorded: Some(RecordedPlacement {
                server_stamp_nanos: recorded.server_stamp_nanos,
                uncertainty_nanos: recorded.uncertainty_nanos.unwrap_or(0),
                received_nanos: recorded.received_nanos,
            }),
        })
    }
}

/// The origin of a recording's timeline: its earliest server stamp (its earliest local stamp
/// when no frame was synchronised), shared by the [`RecordedSensor`]s of every sensor.
#[must_use]
pub fn recording_origin(recording: &[FrameTiming]) -> i64 {
    recording
        .iter()
        .filter_map(|f| f.server_stamp_nanos)
        .min()
        .or_else(|| recording.iter().map(|f| f.local_stamp_nanos).min())
        .unwrap_or(0)
}

/// The first instant `phase + k·period` at or after `now`.
#[must_use]
pub fn next_on_grid(now: i64, period_nanos: i64, phase_nanos: i64) -> i64 {
    let k = (now - phase_nanos).div_euclid(period_nanos);
    let t = k * period_nanos + phase_nanos;
    if t < now { t + period_nanos } else { t }
}

/// `clip` placed on the walkway as an endless lap: out and back.
///
/// # Errors
/// As [`trigait_motion::there_and_back`].
pub fn lap(clip: &MotionClip) -> trigait_motion::Result<MotionClip> {
    trigait_motion::there_and_back(&clip.placed_on_walkway())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The grid: the first instant at or after `now`, on `phase + k·period`.
    #[test]
    fn capture_grid() {
        assert_eq!(next_on_grid(100, 30, 5), 125);
        assert_eq!(next_on_grid(125, 30, 5), 125);
        assert_eq!(next_on_grid(-7, 30, 5), 5);
    }

    fn walker_lap() -> MotionClip {
        let walk =
            trigait_motion::walker(&trigait_motion::WalkerParams::default(), 2.5, 100.0).unwrap();
        lap(&walk).unwrap()
    }

    fn params(id: &str) -> SimulatedSensorParams {
        SimulatedSensorParams {
            sensor_id: id.into(),
            joints: Joint::LEGS.to_vec(),
            seed: 1,
            period_nanos: 33_333_333,
            phase_nanos: None,
            ground_truth: None,
        }
    }

    /// Only the rig's first sensor sends truth by default, every 2 ms with no hole or overlap
    /// up to each capture; the others send none unless asked; an unknown sensor is an error
    /// naming the rig's sensors.
    #[test]
    fn truth_is_sent_once_per_instant() {
        let rig = Rig::builtin("thesis").unwrap();
        let start = 1_700_000_000_000_000_000;
        let clock = || {
            SensorClock::new(
                SimClock::new(-40_000_000, 0.0),
                start,
                Simulator::sensor_rng(1, 0),
            )
        };
        let mut k1 = SimulatedSensor::new(&rig, walker_lap(), &params("k1"), start).unwrap();
        let mut k2 = SimulatedSensor::new(&rig, walker_lap(), &params("k2"), start).unwrap();
        assert!(k1.sends_truth() && !k2.sends_truth());
        let (mut c1, mut c2) = (clock(), clock());
        let mut last = None;
        for _ in 0..20 {
            let due = k1.next_due();
            let cap = k1.capture(&mut c1);
            assert_eq!(cap.frame.local_stamp_nanos - due, -40_000_000);
            for row in &cap.truth {
                if let Some(l) = last {
                    assert_eq!(row.true_stamp_nanos - l, TRUTH_STEP_NANOS);
                }
                last = Some(row.true_stamp_nanos);
                assert_eq!(row.position_in_world.len(), 6);
            }
            assert!(last.unwrap() <= due && due - last.unwrap() < TRUTH_STEP_NANOS);
            assert!(k2.capture(&mut c2).truth.is_empty());
        }
        let forced = SimulatedSensorParams {
            ground_truth: Some(true),
            ..params("k3")
        };
        let mut k3 = SimulatedSensor::new(&rig, walker_lap(), &forced, start).unwrap();
        assert!(!k3.capture(&mut clock()).truth.is_empty());
        let err = SimulatedSensor::new(&rig, walker_lap(), &params("k9"), start).unwrap_err();
        assert!(err.to_string().contains("k1, k2, k3"), "{err}");
    }

    /// Two sensors of a graph started at one epoch place the body alike at an instant, the
    /// lap's phase counting from that epoch: the truth at the epoch is the lap's first pose,
    /// whatever the host time; once a frame is out, the epoch no longer moves.
    #[test]
    fn the_lap_starts_at_the_epoch_given() {
        let rig = Rig::builtin("thesis").unwrap();
        let lap_nanos = (walker_lap().duration_secs() * 1e9).round() as i64;
        for epoch in [1_700_000_000_123_456_789_i64, 1_700_000_003_000_000_000] {
            let mut k1 = SimulatedSensor::new(&rig, walker_lap(), &params("k1"), epoch).unwrap();
            let mut k2 = SimulatedSensor::new(&rig, walker_lap(), &params("k2"), epoch).unwrap();
            k1.start_lap_at(epoch);
            k2.start_lap_at(epoch);
            assert_eq!(k1.lap_secs(epoch), 0.0);
            assert!((k2.lap_secs(epoch + 1_500_000_000) - 1.5).abs() < 1e-9);
            assert_eq!(k1.lap_secs(epoch + lap_nanos), 0.0);
            assert_eq!(k1.lap_secs(epoch + 7), k2.lap_secs(epoch + 7));
            let start = walker_lap().position_at(Joint::AnkleLeft, 0.0).unwrap();
            let truth = k1.sim.truth(k1.lap_secs(epoch));
            assert!((truth[&Joint::AnkleLeft] - start).norm() < 1e-9);
            let mut clock =
                SensorClock::new(SimClock::new(0, 0.0), epoch, Simulator::sensor_rng(1, 0));
            k1.capture(&mut clock);
            k1.start_lap_at(epoch + 1_000_000_000);
            assert_eq!(k1.lap_secs(epoch), 0.0, "moved after a capture");
        }
    }

    /// A source begun after it was made starts on its grid at the later instant, with seq 0;
    /// an earlier instant or a begin after the first capture changes nothing. A replay and a
    /// real-time recording start their first frame then too.
    #[test]
    fn begin_at_moves_only_the_first_capture() {
        let rig = Rig::builtin("thesis").unwrap();
        let start = 1_700_000_000_000_000_000;
        let period = 33_333_333;
        let mut clock = SensorClock::new(SimClock::new(0, 0.0), start, Simulator::sensor_rng(1, 0));
        let mut k2 = SimulatedSensor::new(&rig, walker_lap(), &params("k2"), start).unwrap();
        let made = k2.next_due();
        k2.begin_at(start - 1_000_000_000);
        assert_eq!(k2.next_due(), made, "an earlier start changes nothing");
        let later = start + 500_000_000;
        k2.begin_at(later);
        let first = k2.next_due();
        assert!(
            first >= later && first < later + period,
            "{first} vs {later}"
        );
        assert_eq!(
            (first - made).rem_euclid(period),
            0,
            "off the sensor's grid"
        );
        let c = k2.capture(&mut clock);
        assert_eq!((c.frame.seq, c.true_stamp_nanos), (0, Some(first)));
        k2.begin_at(later + 10 * period);
        assert_eq!(k2.next_due(), first + period, "begun twice");

        let sdk = SdkFrame {
            frame_number: 0,
            time_ms: None,
            joints: Vec::new(),
        };
        let mut replay = ReplayedSensor::new(
            "k1".into(),
            vec![sdk.clone(), sdk],
            period,
            false,
            false,
            start,
        );
        replay.begin_at(later);
        assert_eq!(replay.next_due(), Some(later));
        replay.capture(later, &mut clock).unwrap();
        replay.begin_at(later + 10 * period);
        assert_eq!(replay.next_due(), Some(later + period));

        let recording = vec![FrameTiming {
            sensor_id: "k1".into(),
            seq: 0,
            local_stamp_nanos: 0,
            server_stamp_nanos: Some(0),
            uncertainty_nanos: Some(0),
            offset_nanos: None,
            drift_ppm: None,
            true_stamp_nanos: None,
            received_nanos: None,
            joints: Vec::new(),
        }];
        let mut live = RecordedSensor::new(&recording, "k1", 0, Pace::RealTime, start);
        live.begin_at(later);
        assert_eq!(live.next_due(), Some(later));
        let mut fast = RecordedSensor::new(&recording, "k1", 0, Pace::FAST, start);
        fast.begin_at(later);
        assert_eq!(
            fast.next_due(),
            Some(start + FAST_START_TIMEOUT_NANOS),
            "faster than real time the receiver starts the play"
        );
    }

    /// A recording's sensor plays in recorded order on the shared timeline: in real time at
    /// `start + (server − origin)`, re-stamped by the node's clock; 20× faster only once the
    /// receiver is ready, keeping the recorded local stamps and placements; played out with
    /// the last frame, then lingers and ends.
    #[test]
    fn recorded_sensor_keeps_the_recorded_placement() {
        let origin = 1_000_000_000_000;
        let frame = |sensor: &str, seq: u64, server: Option<i64>| FrameTiming {
            sensor_id: sensor.into(),
            seq,
            local_stamp_nanos: origin + 35_000_000 + seq as i64 * 33_333_333,
            server_stamp_nanos: server,
            uncertainty_nanos: server.map(|_| 40_000),
            offset_nanos: None,
            drift_ppm: None,
            true_stamp_nanos: None,
            received_nanos: Some(server.unwrap_or(origin) + 2_000_000),
            joints: Vec::new(),
        };
        let recording = vec![
            frame("k1", 0, None),
            frame("k2", 0, Some(origin + 10_000_000)),
            frame("k1", 1, Some(origin + 33_333_333)),
            frame("k1", 2, Some(origin + 66_666_666)),
        ];
        assert_eq!(recording_origin(&recording), origin + 10_000_000);
        let start = 5_000_000_000_000;
        let mut clock = SensorClock::new(SimClock::new(0, 0.0), start, Simulator::sensor_rng(1, 0));
        let mut live = RecordedSensor::new(&recording, "k1", origin, Pace::RealTime, start);
        assert_eq!(live.len(), 3);
        // The unsynchronised first frame is placed with the sensor's first mapping.
        assert_eq!(live.next_due(), Some(start));
        let c = live.capture(&mut clock).unwrap();
        assert_eq!(c.frame.seq, 0);
        assert_eq!(
            c.recorded,
            Some(RecordedPlacement {
                server_stamp_nanos: None,
                uncertainty_nanos: 0,
                received_nanos: Some(origin + 2_000_000),
            })
        );
        assert_eq!(live.next_due(), Some(start + 33_333_333));
        let c = live.capture(&mut clock).unwrap();
        assert_eq!(c.frame.local_stamp_nanos, start + 33_333_333);
        assert_eq!(
            c.recorded,
            Some(RecordedPlacement {
                server_stamp_nanos: Some(origin + 33_333_333),
                uncertainty_nanos: 40_000,
                received_nanos: Some(origin + 35_333_333),
            })
        );
        assert!(!live.played_out());
        live.capture(&mut clock).unwrap();
        assert!(live.played_out());
        assert_eq!(live.next_due(), None);

        let mut fast = RecordedSensor::new(&recording, "k1", origin, Pace::FAST, start);
        assert_eq!(fast.next_due(), Some(start + FAST_START_TIMEOUT_NANOS));
        fast.receiver_ready(start + 7);
        assert_eq!(fast.next_due(), Some(start + 7));
        let seqs: Vec<_> = (0..3)
            .map(|_| {
                let c = fast.capture(&mut clock).unwrap();
                assert_eq!(
                    c.frame.local_stamp_nanos,
                    recording[0].local_stamp_nanos + c.frame.seq as i64 * 33_333_333
                );
                c.frame.seq
            })
            .collect();
        assert_eq!(seqs, [0, 1, 2]);
        // Played out (the third frame said it ended the stream), yet still lingering.
        assert!(fast.played_out());
        let linger = fast.next_due().unwrap();
        assert_eq!(linger, start + 7 + 3_333_333 + FAST_LINGER_NANOS);
        assert!(fast.capture(&mut clock).is_none());
        assert_eq!(fast.next_due(), None);
        assert!(RecordedSensor::new(&recording, "k9", origin, Pace::FAST, start).is_empty());
    }
}
