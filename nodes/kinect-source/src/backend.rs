//! The frame sources behind `kinect-source`: what a backend must give the event loop is the next
//! capture instant, the frame captured then, and the sensor clock for NTP replies.

use eyre::{Context, bail, eyre};
use nalgebra::Point3;
use rand_chacha::ChaCha8Rng;
use trigait_kinect::NoiseModel;
use trigait_motion::SdkFrame;
use trigait_rig::Rig;
use trigait_sim::Simulator;
use trigait_skeleton::{Joint, JointSample, MotionClip, SkeletonFrame, TrackingState};
use trigait_sync::sim::SimClock;

use crate::config::{self, Backend, Config};

/// Spacing of ground-truth samples, ns: fine enough that interpolating them at any fusion
/// instant is exact to well under a millimetre.
pub const TRUTH_STEP_NANOS: i64 = 2_000_000;

/// One capture.
#[derive(Debug, Clone)]
pub struct Captured {
    /// The frame as the sensor reports it (camera frame, sensor clock).
    pub frame: SkeletonFrame,
    /// True capture instant on the server clock (simulation only).
    pub true_nanos: Option<i64>,
    /// Ground truth since the previous capture, world frame, one row per instant (simulation).
    pub truth: Vec<SkeletonFrame>,
}

/// The sensor's clock: the host clock (the "server" clock on one host) seen through a simulated
/// offset, drift and jitter, drift counted from the node's start.
#[derive(Debug, Clone)]
pub struct SensorClock {
    clock: SimClock,
    start_nanos: i64,
    rng: ChaCha8Rng,
}

impl SensorClock {
    /// A clock that starts drifting at `start_nanos`.
    #[must_use]
    pub fn new(config: &Config, start_nanos: i64, rng: ChaCha8Rng) -> Self {
        Self {
            clock: SimClock::new(config.clock_offset_nanos, config.clock_drift_ppm)
                .with_jitter_nanos(config.clock_jitter_nanos),
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

/// A frame source.
#[derive(Debug)]
pub enum Source {
    /// The simulator playing an endless walk.
    Sim(Box<SimSource>),
    /// A recorded SDK skeleton file.
    Replay(ReplaySource),
}

/// The simulated sensor.
#[derive(Debug)]
pub struct SimSource {
    sim: Simulator,
    index: usize,
    id: String,
    rng: ChaCha8Rng,
    lap_nanos: i64,
    period_nanos: i64,
    next_nanos: i64,
    seq: u64,
    last_truth_nanos: Option<i64>,
}

/// The replayed sensor.
#[derive(Debug)]
pub struct ReplaySource {
    id: String,
    frames: Vec<SdkFrame>,
    at: usize,
    fast: bool,
    looped: bool,
    period_nanos: i64,
    next_nanos: i64,
    seq: u64,
}

/// Host time, ns since the UNIX epoch (the server clock of a one-host graph).
#[must_use]
pub fn now_nanos() -> i64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| i64::try_from(d.as_nanos()).unwrap_or(i64::MAX))
}

impl Source {
    /// Builds the configured backend; errors name the node and the key at fault.
    pub fn new(config: &Config, now: i64) -> eyre::Result<Self> {
        match &config.backend {
            Backend::Sim { motion, walk_secs } => Ok(Source::Sim(Box::new(SimSource::new(
                config, motion, *walk_secs, now,
            )?))),
            Backend::Replay { file, fast, looped } => {
                let frames = trigait_motion::read_sdk_skeletons(file).with_context(|| {
                    format!("kinect-source: {}={}", config::REPLAY_FILE, file.display())
                })?;
                let period_nanos = config.period_nanos();
                Ok(Source::Replay(ReplaySource {
                    id: config.sensor_id.clone(),
                    frames,
                    at: 0,
                    fast: *fast,
                    looped: *looped,
                    period_nanos,
                    next_nanos: now,
                    seq: 0,
                }))
            }
            Backend::Freenect2 => {
                if cfg!(feature = "freenect2") {
                    bail!(
                        "kinect-source: {}=freenect2 runs its own event loop (freenect2::run), not as a Source",
                        config::BACKEND
                    )
                }
                bail!(
                    "kinect-source: {}=freenect2, but this binary was not built with freenect2 \
                     (rebuild with `cargo build --release -p trigait-kinect-source-node --features freenect2`)",
                    config::BACKEND
                )
            }
        }
    }

    /// Host time of the next capture; `None` when the source has nothing more to send.
    #[must_use]
    pub fn next_due(&self) -> Option<i64> {
        match self {
            Source::Sim(s) => Some(s.next_nanos),
            Source::Replay(r) => (r.at < r.frames.len()).then_some(r.next_nanos),
        }
    }

    /// Captures the frame due now; `clock` stamps it.
    pub fn capture(&mut self, now: i64, clock: &mut SensorClock) -> Option<Captured> {
        match self {
            Source::Sim(s) => Some(s.capture(clock)),
            Source::Replay(r) => r.capture(now, clock),
        }
    }
}

impl SimSource {
    fn new(config: &Config, motion: &str, walk_secs: f64, now: i64) -> eyre::Result<Self> {
        let rig = Rig::from_spec(&config.rig)
            .map_err(|e| eyre!("kinect-source: {}={:?}: {e}", config::RIG, config.rig))?;
        let index = rig
            .sensors
            .iter()
            .position(|s| s.id == config.sensor_id)
            .ok_or_else(|| {
                eyre!(
                    "kinect-source: {}={:?} is not in rig {:?} (sensors: {})",
                    config::SENSOR_ID,
                    config.sensor_id,
                    rig.name,
                    rig.sensors
                        .iter()
                        .map(|s| s.id.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            })?;
        let clip = load_lap(motion, walk_secs, config.all_joints)
            .with_context(|| format!("kinect-source: {}={motion:?}", config::MOTION))?;
        let lap_nanos = (clip.duration_secs() * 1e9).round() as i64;
        let joints: Vec<Joint> = if config.all_joints {
            Joint::ALL.to_vec()
        } else {
            Joint::LEGS.to_vec()
        };
        let sim = Simulator::new(&rig, clip, &joints, &NoiseModel::default());
        if sim.joints().is_empty() {
            bail!(
                "kinect-source: {}={motion:?} defines none of the joints to report",
                config::MOTION
            );
        }
        let period_nanos = config.period_nanos();
        let phase_nanos = config.frame_phase_nanos.unwrap_or_else(|| {
            (period_nanos as f64 * index as f64 / rig.sensors.len() as f64).round() as i64
        });
        let phase_nanos = phase_nanos.rem_euclid(period_nanos);
        Ok(SimSource {
            rng: Simulator::sensor_rng(config.seed, index),
            sim,
            index,
            id: config.sensor_id.clone(),
            lap_nanos: lap_nanos.max(1),
            period_nanos,
            next_nanos: next_on_grid(now, period_nanos, phase_nanos),
            seq: 0,
            last_truth_nanos: None,
        })
    }

    fn clip_secs(&self, true_nanos: i64) -> f64 {
        true_nanos.rem_euclid(self.lap_nanos) as f64 * 1e-9
    }

    fn capture(&mut self, clock: &mut SensorClock) -> Captured {
        let t = self.next_nanos;
        let local = clock.local(t);
        let frame = self.sim.frame(
            self.index,
            self.seq,
            self.clip_secs(t),
            local,
            &mut self.rng,
        );
        let from = self
            .last_truth_nanos
            .map_or(t - self.period_nanos, |l| l + 1);
        let mut truth = Vec::new();
        let mut g =
            from.div_euclid(TRUTH_STEP_NANOS) + i64::from(from.rem_euclid(TRUTH_STEP_NANOS) != 0);
        while g * TRUTH_STEP_NANOS <= t {
            let at = g * TRUTH_STEP_NANOS;
            truth.push(self.truth_at(at));
            self.last_truth_nanos = Some(at);
            g += 1;
        }
        self.seq += 1;
        self.next_nanos = t + self.period_nanos;
        Captured {
            frame,
            true_nanos: Some(t),
            truth,
        }
    }

    fn truth_at(&self, true_nanos: i64) -> SkeletonFrame {
        let truth = self.sim.truth(self.clip_secs(true_nanos));
        SkeletonFrame {
            sensor_id: format!("truth:{}", self.id),
            seq: u64::try_from(true_nanos / TRUTH_STEP_NANOS).unwrap_or(0),
            local_stamp_nanos: true_nanos,
            joints: truth
                .into_iter()
                .map(|(joint, p): (Joint, Point3<f64>)| JointSample {
                    joint,
                    position_in_kinect: p,
                    state: TrackingState::Tracked,
                })
                .collect(),
        }
    }
}

impl ReplaySource {
    fn capture(&mut self, now: i64, clock: &mut SensorClock) -> Option<Captured> {
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
            true_nanos: None,
            truth: Vec::new(),
        })
    }
}

/// The first instant `phase + k·period` at or after `now`.
#[must_use]
pub fn next_on_grid(now: i64, period_nanos: i64, phase_nanos: i64) -> i64 {
    let k = (now - phase_nanos).div_euclid(period_nanos);
    let t = k * period_nanos + phase_nanos;
    if t < now { t + period_nanos } else { t }
}

/// The motion as an endless lap: out and back along the walkway.
pub fn load_lap(motion: &str, walk_secs: f64, all_joints: bool) -> eyre::Result<MotionClip> {
    let clip = if motion.trim() == "walker" {
        let params = trigait_motion::WalkerParams {
            all_joints,
            ..trigait_motion::WalkerParams::default()
        };
        trigait_motion::walker(&params, walk_secs, 100.0).context("generating the walker")?
    } else {
        trigait_motion::load_motion(motion.trim()).context("loading the motion file")?
    };
    trigait_motion::there_and_back(&clip.placed_on_walkway()).context("turning the walk into a lap")
}
