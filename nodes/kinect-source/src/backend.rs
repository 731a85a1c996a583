//! The frame sources behind `kinect-source`: what a backend must give the event loop is the next
//! capture instant, the frame captured then, and the sensor clock for NTP replies. The streams
//! themselves are [`trigait_sim::stream`]; this module builds the configured one.

use eyre::{Context, bail, eyre};
use trigait_sim::clock::SimClock;
use trigait_sim::stream::{
    Pace, RecordedSensor, ReplayedSensor, SimulatedSensor, SimulatedSensorParams, recording_origin,
};
use trigait_skeleton::{Joint, MotionClip};

pub use trigait_sim::stream::{Captured, SensorClock};

use crate::config::{self, Backend, Config};

/// A frame source.
#[derive(Debug)]
pub enum Source {
    /// The simulator playing an endless walk.
    Sim(Box<SimulatedSensor>),
    /// The simulator's body rendered as depth.
    BodyDepth(Box<crate::body_depth::BodyDepthSensor>),
    /// A recorded SDK skeleton file.
    Replay(ReplayedSensor),
    /// One sensor of a trial recording.
    Recording(RecordedSensor),
}

/// Host time, ns since the UNIX epoch (the server clock of a one-host graph).
#[must_use]
pub fn now_nanos() -> i64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| i64::try_from(d.as_nanos()).unwrap_or(i64::MAX))
}

/// The sensor clock `config` asks for, drifting from host time `start_nanos` and stepped, if
/// `config` schedules a step, that long after it.
#[must_use]
pub fn sensor_clock(config: &Config, start_nanos: i64) -> SensorClock {
    let mut clock = SimClock::new(config.clock_offset_nanos, config.clock_drift_ppm)
        .with_jitter_nanos(config.clock_jitter_nanos);
    if let Some(step) = config.clock_step {
        clock = clock.with_step_at(step.after_start_nanos, step.step_nanos);
    }
    SensorClock::new(
        clock,
        start_nanos,
        trigait_sim::Simulator::sensor_rng(config.seed ^ 0x5eed_c10c, 0),
    )
}

impl Source {
    /// Builds the configured backend; errors name the node and the key at fault.
    pub fn new(config: &Config, now: i64) -> eyre::Result<Self> {
        match &config.backend {
            Backend::BodyDepth {
                motion,
                walk_secs,
                lane_m,
            } => {
                let sim = Self::new(
                    &Config {
                        backend: Backend::Sim {
                            motion: motion.clone(),
                            walk_secs: *walk_secs,
                            lane_m: *lane_m,
                        },
                        ..config.clone()
                    },
                    now,
                )?;
                let Source::Sim(sim) = sim else {
                    bail!(
                        "kinect-source: the simulated source of {}=body-depth",
                        config::BACKEND
                    )
                };
                let lap = load_lap(motion, *walk_secs, *lane_m, config.all_joints)
                    .with_context(|| format!("kinect-source: {}={motion:?}", config::MOTION))?;
                let seed = config.seed
                    ^ 0xb0d7_u64.rotate_left(23)
                    ^ crate::depth::hash(&config.sensor_id);
                Ok(Source::BodyDepth(Box::new(
                    crate::body_depth::BodyDepthSensor::new(
                        *sim,
                        lap,
                        &config.rig,
                        &config.sensor_id,
                        seed,
                    )?,
                )))
            }
            Backend::Sim {
                motion,
                walk_secs,
                lane_m,
            } => {
                let lap = load_lap(motion, *walk_secs, *lane_m, config.all_joints)
                    .with_context(|| format!("kinect-source: {}={motion:?}", config::MOTION))?;
                let params = SimulatedSensorParams {
                    sensor_id: config.sensor_id.clone(),
                    joints: if config.all_joints {
                        Joint::ALL.to_vec()
                    } else {
                        Joint::LEGS.to_vec()
                    },
                    seed: config.seed,
                    period_nanos: config.period_nanos(),
                    phase_nanos: config.frame_phase_nanos,
                    ground_truth: config.ground_truth,
                };
                let sensor = SimulatedSensor::new(&config.rig, lap, &params, now).map_err(|e| {
                    eyre!(
                        "kinect-source: {}={:?}, {}={:?}: {e}",
                        config::SENSOR_ID,
                        config.sensor_id,
                        config::MOTION,
                        motion
                    )
                })?;
                Ok(Source::Sim(Box::new(sensor)))
            }
            Backend::Replay { file, fast, looped } => {
                let log = trigait_motion::read_sdk_log(file).with_context(|| {
                    format!("kinect-source: {}={}", config::REPLAY_FILE, file.display())
                })?;
                if let Some(cut) = log.cut_last_line {
                    tracing::warn!("{}: {cut}", file.display());
                }
                let mut frames = log.frames;
                // The SDK labels a back as a front: walking away, its sides are swapped back
                // here, in this sensor's own camera frame, before sync ever pairs them.
                let rate_hz = 1e9 / config.period_nanos() as f64;
                let swapped = trigait_motion::swap_sides_walking_away(&mut frames, rate_hz);
                if swapped > 0 {
                    tracing::info!(
                        "{}: left and right swapped back in {swapped} of {} frames walking away from the sensor",
                        file.display(),
                        frames.len()
                    );
                }
                Ok(Source::Replay(ReplayedSensor::new(
                    config.sensor_id.clone(),
                    frames,
                    config.period_nanos(),
                    *fast,
                    *looped,
                    now,
                )))
            }
            Backend::Recording { file, pace } => recording_source(config, file, *pace, now),
            Backend::Freenect2 => {
                if cfg!(feature = "freenect2") {
                    bail!(
                        "kinect-source: {}=freenect2 runs its own event loop (freenect2::run), not as a Source",
                        config::BACKEND
                    )
                }
                bail!(
                    "kinect-source: {}=freenect2, but this binary was not built with freenect2 \
                     (rebuild with `cargo build --release --workspace --features trigait-kinect-source-node/freenect2`; see the README)",
                    config::BACKEND
                )
            }
        }
    }

    /// Host time of the next capture; `None` when the source has nothing more to send.
    #[must_use]
    pub fn next_due(&self) -> Option<i64> {
        match self {
            Source::Sim(s) => Some(s.next_due()),
            Source::BodyDepth(s) => Some(s.next_due()),
            Source::Replay(r) => r.next_due(),
            Source::Recording(r) => r.next_due(),
        }
    }

    /// Whether a replayed file has sent its last frame (a live or simulated sensor never has).
    pub fn played_out(&self) -> bool {
        match self {
            Source::Sim(_) | Source::BodyDepth(_) => false,
            Source::Replay(r) => r.played_out(),
            Source::Recording(r) => r.played_out(),
        }
    }

    /// The frames' receiver has shown it listens (an NTP request came): a recording played
    /// as fast as possible starts then.
    pub fn receiver_ready(&mut self, now: i64) {
        if let Source::Recording(r) = self {
            r.receiver_ready(now);
        }
    }

    /// The depth frame of the last capture, for a source that sends depth instead of
    /// skeleton frames (`body-depth`); `None` for the others.
    pub fn take_depth(&mut self) -> Option<trigait_schema::DepthFrameMessage> {
        match self {
            Source::BodyDepth(s) => s.take_depth(),
            _ => None,
        }
    }

    /// Starts a simulated lap at host time `epoch_nanos` ([`SimulatedSensor::start_lap_at`]):
    /// the instant the dataflow was made, shared by every source of the graph. Before
    /// [`Self::begin_at`]; recordings and replays play from their own start.
    pub fn start_lap_at(&mut self, epoch_nanos: i64) {
        match self {
            Source::Sim(s) => s.start_lap_at(epoch_nanos),
            Source::BodyDepth(s) => s.start_lap_at(epoch_nanos),
            Source::Replay(_) | Source::Recording(_) => {}
        }
    }

    /// Starts the stream at host time `now`: the first frame is due then (on the sensor's
    /// frame grid), not when the source was built. Building it may take a while (a motion or
    /// recording to load, a renderer to set up), and the node connects to the daemon after
    /// it; a body-depth source would otherwise skip the instants missed meanwhile, and the
    /// others send them in a burst. Call once, just before the event loop.
    pub fn begin_at(&mut self, now: i64) {
        match self {
            Source::Sim(s) => s.begin_at(now),
            Source::BodyDepth(s) => s.begin_at(now),
            Source::Replay(r) => r.begin_at(now),
            Source::Recording(r) => r.begin_at(now),
        }
    }

    /// What the backend lost or could not render, for the node's closing report; `None` when
    /// it has nothing to say.
    #[must_use]
    pub fn losses(&self) -> Option<String> {
        match self {
            Source::BodyDepth(s) => Some(format!(
                "{} instants skipped because the host was behind ({} before the first frame), {} rendered as the empty room or sent empty (no body pose at that instant, or no render thread)",
                s.skipped, s.skipped_at_start, s.render_failures
            )),
            _ => None,
        }
    }

    /// Captures the frame due now; `clock` stamps it.
    pub fn capture(&mut self, now: i64, clock: &mut SensorClock) -> Option<Captured> {
        match self {
            Source::Sim(s) => Some(s.capture(clock)),
            Source::BodyDepth(s) => Some(s.capture(now, clock)),
            Source::Replay(r) => r.capture(now, clock),
            Source::Recording(r) => r.capture(clock),
        }
    }
}

/// `config.sensor_id`'s frames of the recording `file`; a recording without them is an error
/// naming the sensors it has.
fn recording_source(
    config: &Config,
    file: &std::path::Path,
    pace: Pace,
    now: i64,
) -> eyre::Result<Source> {
    let frames = trigait_recording::read_frames(file)
        .with_context(|| format!("kinect-source: {}={}", config::RECORDING, file.display()))?;
    let sensor = RecordedSensor::new(
        &frames,
        &config.sensor_id,
        recording_origin(&frames),
        pace,
        now,
    );
    if frames.is_empty() {
        bail!(
            "kinect-source: {}={}: the recording holds no frames (only its header)",
            config::RECORDING,
            file.display()
        );
    }
    if sensor.is_empty() {
        bail!(
            "kinect-source: {}={}: no frames of {}={:?} (the recording has {})",
            config::RECORDING,
            file.display(),
            config::SENSOR_ID,
            config.sensor_id,
            trigait_recording::sensor_ids(&frames).join(", ")
        );
    }
    Ok(Source::Recording(sensor))
}

/// How long the walker turns at either end of a two-lane walk, seconds: a person pacing a
/// walkway takes about two steps to turn round.
const TURN_SECS: f64 = 1.0;

/// The motion as an endless lap: out and back along the walkway, on the same line
/// (`lane_m = 0`) or back on a second line `lane_m` to the side.
pub fn load_lap(
    motion: &str,
    walk_secs: f64,
    lane_m: f64,
    all_joints: bool,
) -> eyre::Result<MotionClip> {
    let clip = if motion.trim() == "walker" {
        let params = trigait_motion::WalkerParams {
            all_joints,
            ..trigait_motion::WalkerParams::default()
        };
        trigait_motion::walker(&params, walk_secs, 100.0).context("generating the walker")?
    } else {
        trigait_motion::load_motion(motion.trim()).context("loading the motion file")?
    };
    if lane_m > 0.0 {
        trigait_motion::walkway_loop(&clip.placed_on_walkway(), lane_m, TURN_SECS)
    } else {
        trigait_sim::stream::lap(&clip)
    }
    .context("turning the walk into a lap")
}
