//! `kinect-source` configuration, read from the `env:` block of the node in the dataflow YAML.
//!
//! | env var | type | default | meaning |
//! |---|---|---|---|
//! | `SENSOR_ID` | string | required | the sensor's id in the rig file (`k1`) |
//! | `RIG` | `thesis`, `ring-N` or a YAML path | `thesis` | sensor poses (the simulator needs them) |
//! | `BACKEND` | `sim`, `body-depth`, `replay`, `recording`, `freenect2` | `sim` | where frames come from (`body-depth`: simulated depth of the body instead of skeleton frames, [`crate::body_depth`]) |
//! | `MOTION` | `walker` or a C3D/TRC/CSV path | `walker` | what the simulated subject does (played there and back, endlessly, from the start of the walk when the dataflow is made, so every source of a graph and every run of it agree; `sim` and `body-depth`) |
//! | `WALK_SECS` | seconds | `2.5` | one-way duration of the embedded walker |
//! | `LANE_M` | metres, 0–3 | `0` | walk back on a second line this far to the side, turning for a second at either end (no joints reported while turning); `0`: back on the same line, turning on the spot. Every source of a graph needs the same value (`sim` and `body-depth`) |
//! | `JOINTS` | `legs` or `all` | `legs` | joints reported |
//! | `SEED` | integer | `1` | noise seed (each sensor has its own stream) |
//! | `FRAME_RATE_HZ` | Hz | `30` | capture rate |
//! | `FRAME_PHASE_MILLIS` | ms | sensor index × 11 | capture phase on the 30 Hz grid |
//! | `CLOCK_OFFSET_MILLIS` | ms | `0` | simulated clock offset to the server |
//! | `CLOCK_DRIFT_PPM` | ppm | `0` | simulated clock drift |
//! | `CLOCK_JITTER_MICROS` | µs | `20` | σ of every clock reading |
//! | `CLOCK_STEP_AT_SECS` | seconds ≥ 0 | none | set the simulated clock by `CLOCK_STEP_MILLIS` this long after the source starts (an NTP daemon or a person stepping the sensor PC's clock); `sim` and `replay` |
//! | `CLOCK_STEP_MILLIS` | ms | required with `CLOCK_STEP_AT_SECS` | the step (positive: the clock jumps forward), at most ±1 h |
//! | `REPLAY_FILE` | path | required for `replay` | Kinect v2 SDK skeleton text file (either format); where the person walks away from the sensor, left and right are swapped back (the SDK fits a front-facing skeleton to a back) |
//! | `REPLAY_SPEED` | `realtime` or `fast` (`recording`: also a speed-up factor ≥ 1) | `realtime` | play at 30 Hz (`recording`: on the recorded timeline) or as fast as possible (`recording`: 20× real time, the bounded speed dora delivers without loss) |
//! | `RECORDING` | path | required for `recording` | a trial recording's `frames.csv` (the recorder's); this source plays `SENSOR_ID`'s frames: in real time re-stamped by this node's clock, faster with the recorded stamps (then `sync` needs `TIMESTAMPS: recorded`) |
//! | `REPLAY_LOOP` | bool | `true` | start over at the end of the file |
//! | `GROUND_TRUTH` | bool | `true` for the rig's first sensor | send the simulated ground truth on `ground_truth` (one source per graph, so each instant is sent once) |
//! | `STOP_AFTER_FRAMES` | integer | none | stop after this many frames (tests: a source dying mid-run) |
//! | `STOP_AFTER_SECS` | seconds > 0 | none | stop this long after the first frame; when every source of a graph does, the graph ends on its own and every set reaches the recorder (a `dora stop` cannot promise that: nothing sent after a stop is delivered) |
//! | `DEPTH_RATE_HZ`, `DEPTH_*` | | off | the optional `depth` output: [`crate::depth`] |
//!
//! The rig is read and checked here, once (a missing file or a bad YAML stops the node before
//! it connects to dora).

use std::path::PathBuf;
use std::str::FromStr;

use eyre::{bail, eyre};
use trigait_node_config::{env_flag, env_number, env_number_where, env_parsed, env_rig, env_value};
use trigait_rig::Rig;

/// Env var names.
pub const SENSOR_ID: &str = "SENSOR_ID";
/// Env var: backend.
pub const BACKEND: &str = "BACKEND";
/// Env var: motion.
pub const MOTION: &str = "MOTION";
/// Env var: walker duration.
pub const WALK_SECS: &str = "WALK_SECS";
/// Env var: distance between the outbound and the return lane.
pub const LANE_M: &str = "LANE_M";
/// Env var: joints.
pub const JOINTS: &str = "JOINTS";
/// Env var: seed.
pub const SEED: &str = "SEED";
/// Env var: frame rate.
pub const FRAME_RATE_HZ: &str = "FRAME_RATE_HZ";
/// Env var: frame phase.
pub const FRAME_PHASE_MILLIS: &str = "FRAME_PHASE_MILLIS";
/// Env var: clock offset.
pub const CLOCK_OFFSET_MILLIS: &str = "CLOCK_OFFSET_MILLIS";
/// Env var: clock drift.
pub const CLOCK_DRIFT_PPM: &str = "CLOCK_DRIFT_PPM";
/// Env var: clock jitter.
pub const CLOCK_JITTER_MICROS: &str = "CLOCK_JITTER_MICROS";
/// Env var: replay file.
pub const REPLAY_FILE: &str = "REPLAY_FILE";
/// Env var: replay speed.
pub const REPLAY_SPEED: &str = "REPLAY_SPEED";
/// Env var: trial recording.
pub const RECORDING: &str = "RECORDING";
/// Env var: replay loop.
pub const REPLAY_LOOP: &str = "REPLAY_LOOP";
/// Env var: when the simulated clock steps, seconds after the source starts.
pub const CLOCK_STEP_AT_SECS: &str = "CLOCK_STEP_AT_SECS";
/// Env var: the simulated clock step, ms.
pub const CLOCK_STEP_MILLIS: &str = "CLOCK_STEP_MILLIS";
/// Env var: stop after N frames.
pub const STOP_AFTER_FRAMES: &str = "STOP_AFTER_FRAMES";
/// Env var: stop this many seconds after the first frame.
pub const STOP_AFTER_SECS: &str = "STOP_AFTER_SECS";
/// Env var: whether this simulated source sends the ground truth.
pub const GROUND_TRUTH: &str = "GROUND_TRUTH";

/// Where frames come from.
#[derive(Debug, Clone, PartialEq)]
pub enum Backend {
    /// The simulator.
    Sim {
        /// `walker` or a motion file.
        motion: String,
        /// One-way walker duration, seconds.
        walk_secs: f64,
        /// Distance between the outbound and the return lane, metres (0: the same line).
        lane_m: f64,
    },
    /// The simulator's body rendered as depth (`depth` output, no skeleton frames).
    BodyDepth {
        /// `walker` or a motion file.
        motion: String,
        /// One-way walker duration, seconds.
        walk_secs: f64,
        /// Distance between the outbound and the return lane, metres (0: the same line).
        lane_m: f64,
    },
    /// A recorded SDK skeleton file.
    Replay {
        /// The file.
        file: PathBuf,
        /// As fast as possible instead of at the frame rate.
        fast: bool,
        /// Start over at the end.
        looped: bool,
    },
    /// One sensor of a trial recording (`trigait-recording`).
    Recording {
        /// Its `frames.csv`.
        file: PathBuf,
        /// How fast.
        pace: trigait_sim::stream::Pace,
    },
    /// A real Kinect v2 through libfreenect2.
    Freenect2,
}

/// The value of `BACKEND`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BackendName {
    /// `sim`.
    Sim,
    /// `body-depth`.
    BodyDepth,
    /// `replay`.
    Replay,
    /// `recording`.
    Recording,
    /// `freenect2`.
    Freenect2,
}

impl FromStr for BackendName {
    type Err = &'static str;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "sim" => Ok(Self::Sim),
            "body-depth" => Ok(Self::BodyDepth),
            "replay" => Ok(Self::Replay),
            "recording" => Ok(Self::Recording),
            "freenect2" => Ok(Self::Freenect2),
            _ => Err("expected `sim`, `body-depth`, `replay`, `recording` or `freenect2`"),
        }
    }
}

/// The value of `JOINTS`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JointSet {
    /// `legs`: the joints the thesis tracks.
    Legs,
    /// `all`: the 25 Kinect v2 joints.
    All,
}

impl FromStr for JointSet {
    type Err = &'static str;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "legs" => Ok(Self::Legs),
            "all" => Ok(Self::All),
            _ => Err("expected `legs` or `all`"),
        }
    }
}

/// The value of `REPLAY_SPEED`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReplaySpeed {
    /// `realtime`: at the frame rate.
    Realtime,
    /// `fast`: as fast as possible.
    Fast,
}

impl FromStr for ReplaySpeed {
    type Err = &'static str;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "realtime" => Ok(Self::Realtime),
            "fast" => Ok(Self::Fast),
            _ => Err("expected `realtime` or `fast`"),
        }
    }
}

/// A step of the simulated sensor clock.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ClockStep {
    /// When, ns after the source starts.
    pub after_start_nanos: i64,
    /// How far, ns (positive: forward).
    pub step_nanos: i64,
}

/// The largest clock step accepted, ms (an hour: beyond that the simulation tests nothing the
/// filter does not already treat as a step).
const MAX_STEP_MILLIS: f64 = 3_600_000.0;

/// The node's configuration.
#[derive(Debug, Clone, PartialEq)]
pub struct Config {
    /// Sensor id.
    pub sensor_id: String,
    /// The rig, read from `RIG`.
    pub rig: Rig,
    /// Backend.
    pub backend: Backend,
    /// Report all 25 joints instead of the legs.
    pub all_joints: bool,
    /// Noise seed.
    pub seed: u64,
    /// Capture rate, Hz.
    pub frame_rate_hz: f64,
    /// Capture phase, ns (`None`: from the sensor's index in the rig).
    pub frame_phase_nanos: Option<i64>,
    /// Clock offset, ns.
    pub clock_offset_nanos: i64,
    /// Clock drift, ppm.
    pub clock_drift_ppm: f64,
    /// Clock jitter σ, ns.
    pub clock_jitter_nanos: f64,
    /// A scheduled clock step (`None`: the clock never steps).
    pub clock_step: Option<ClockStep>,
    /// Stop after this many frames.
    pub stop_after_frames: Option<u64>,
    /// Stop this long after the first frame, ns.
    pub stop_after_nanos: Option<i64>,
    /// Send the ground truth (`None`: only the rig's first sensor does).
    pub ground_truth: Option<bool>,
    /// The optional depth output (`None`: off).
    pub depth: Option<crate::depth::DepthConfig>,
}

/// Every variable the node reads, to spot a misspelt one.
const SETTINGS: &[&str] = &[
    SENSOR_ID,
    BACKEND,
    MOTION,
    WALK_SECS,
    LANE_M,
    JOINTS,
    SEED,
    FRAME_RATE_HZ,
    FRAME_PHASE_MILLIS,
    CLOCK_OFFSET_MILLIS,
    CLOCK_DRIFT_PPM,
    CLOCK_JITTER_MICROS,
    REPLAY_FILE,
    REPLAY_SPEED,
    RECORDING,
    REPLAY_LOOP,
    CLOCK_STEP_AT_SECS,
    CLOCK_STEP_MILLIS,
    STOP_AFTER_FRAMES,
    STOP_AFTER_SECS,
    GROUND_TRUTH,
    trigait_node_config::RIG,
    crate::depth::DEPTH_RATE_HZ,
    crate::depth::DEPTH_DIR,
    crate::depth::DEPTH_LOOP,
    crate::depth::DEPTH_SCENE,
    crate::depth::DEPTH_NOISE_SD_MM,
    crate::depth::DEPTH_QUANTISATION_MM,
    crate::depth::DEPTH_RING_MM,
    crate::depth::DEPTH_RING_PERIOD_PX,
    crate::freenect2::FREENECT2_INDEX,
    crate::freenect2::FREENECT2_IR,
    crate::freenect2::FREENECT2_PIPELINE,
    crate::freenect2::FREENECT2_RESCAN_MILLIS,
    crate::freenect2::FREENECT2_SERIAL,
    crate::freenect2::FREENECT2_STALL_MILLIS,
    crate::freenect2::FREENECT2_STATUS_MILLIS,
];

const NODE: &str = "kinect-source";

/// `REPLAY_SPEED` of a recording: `realtime`, `fast` or a speed-up factor.
fn replay_pace(
    lookup: &impl Fn(&str) -> Option<String>,
) -> eyre::Result<trigait_sim::stream::Pace> {
    use trigait_sim::stream::Pace;
    match lookup(REPLAY_SPEED).as_deref().map(str::trim) {
        None | Some("realtime") => Ok(Pace::RealTime),
        Some("fast") => Ok(Pace::FAST),
        Some(other) => match other.parse::<f64>() {
            Ok(f) if f.is_finite() && (1.0..=1000.0).contains(&f) => Ok(Pace::Faster(f)),
            _ => bail!(
                "{NODE}: {REPLAY_SPEED}={other:?} is invalid: expected `realtime`, `fast` or a speed-up factor within 1–1000"
            ),
        },
    }
}

impl Config {
    /// Whether `frames_sent` frames end the run (`STOP_AFTER_FRAMES`); says so in the log when
    /// they do.
    pub fn frame_limit_reached(&self, frames_sent: u64) -> bool {
        let reached = self.stop_after_frames == Some(frames_sent);
        if reached {
            tracing::info!("stopping after {frames_sent} frames ({STOP_AFTER_FRAMES})");
        }
        reached
    }

    /// From the process environment.
    pub fn from_env() -> eyre::Result<Self> {
        trigait_node_config::warn_misspelt_settings(NODE, SETTINGS);
        Self::from_lookup(|k| std::env::var(k).ok())
    }

    /// From any lookup (tests).
    pub fn from_lookup(lookup: impl Fn(&str) -> Option<String>) -> eyre::Result<Self> {
        let sensor_id = lookup(SENSOR_ID)
            .filter(|s| !s.trim().is_empty())
            .ok_or_else(|| eyre!("{NODE}: {SENSOR_ID} is required (the sensor's id in the rig)"))?
            .trim()
            .to_owned();
        let rig = env_rig(NODE, &lookup)?;
        let walk_secs = || {
            env_number_where(
                NODE,
                &lookup,
                WALK_SECS,
                2.5,
                |v| v > 0.5,
                "a duration above 0.5 s",
            )
        };
        let motion = || lookup(MOTION).unwrap_or_else(|| "walker".into());
        let lane_m = || {
            env_number_where(
                NODE,
                &lookup,
                LANE_M,
                0.0,
                |v| (0.0..=3.0).contains(&v),
                "a distance within 0–3 m",
            )
        };
        let backend = match env_parsed(NODE, &lookup, BACKEND, BackendName::Sim)? {
            BackendName::Sim => Backend::Sim {
                motion: motion(),
                walk_secs: walk_secs()?,
                lane_m: lane_m()?,
            },
            BackendName::BodyDepth => Backend::BodyDepth {
                motion: motion(),
                walk_secs: walk_secs()?,
                lane_m: lane_m()?,
            },
            BackendName::Replay => Backend::Replay {
                file: lookup(REPLAY_FILE).map(PathBuf::from).ok_or_else(|| {
                    eyre!("{NODE}: {REPLAY_FILE} is required with {BACKEND}=replay")
                })?,
                fast: env_parsed(NODE, &lookup, REPLAY_SPEED, ReplaySpeed::Realtime)?
                    == ReplaySpeed::Fast,
                looped: env_flag(NODE, &lookup, REPLAY_LOOP, true)?,
            },
            BackendName::Recording => Backend::Recording {
                file: lookup(RECORDING).map(PathBuf::from).ok_or_else(|| {
                    eyre!("{NODE}: {RECORDING} is required with {BACKEND}=recording")
                })?,
                pace: replay_pace(&lookup)?,
            },
            BackendName::Freenect2 => Backend::Freenect2,
        };
        let all_joints = env_parsed(NODE, &lookup, JOINTS, JointSet::Legs)? == JointSet::All;
        let frame_rate_hz = env_number_where(
            NODE,
            &lookup,
            FRAME_RATE_HZ,
            30.0,
            |v| (1.0..=1000.0).contains(&v),
            "a rate within 1–1000 Hz",
        )?;
        let phase = env_value(
            NODE,
            &lookup,
            FRAME_PHASE_MILLIS,
            |v: &f64| v.is_finite(),
            "a finite number of milliseconds",
        )?;
        let offset = env_number(NODE, &lookup, CLOCK_OFFSET_MILLIS, 0.0)?;
        let drift = env_number_where(
            NODE,
            &lookup,
            CLOCK_DRIFT_PPM,
            0.0,
            |v| v.abs() <= 500.0,
            "a drift within ±500 ppm",
        )?;
        let jitter = env_number_where(
            NODE,
            &lookup,
            CLOCK_JITTER_MICROS,
            20.0,
            |v| v >= 0.0,
            "a number of microseconds ≥ 0",
        )?;
        let clock_step = clock_step(&lookup)?;
        let stop_after_frames = env_value(
            NODE,
            &lookup,
            STOP_AFTER_FRAMES,
            |_| true,
            "a whole number of frames",
        )?;
        let stop_after_secs = env_value(
            NODE,
            &lookup,
            STOP_AFTER_SECS,
            |s: &f64| *s > 0.0 && *s <= 1e6,
            "seconds more than 0 and at most 1000000 (to run until stopped, leave it out)",
        )?;
        Ok(Config {
            sensor_id,
            rig,
            all_joints,
            seed: env_value(NODE, &lookup, SEED, |_| true, "a whole number")?.unwrap_or(1),
            frame_rate_hz,
            frame_phase_nanos: phase.map(|ms| (ms * 1e6).round() as i64),
            clock_offset_nanos: (offset * 1e6).round() as i64,
            clock_drift_ppm: drift,
            clock_jitter_nanos: jitter * 1e3,
            clock_step,
            stop_after_frames,
            stop_after_nanos: stop_after_secs.map(|s| (s * 1e9).round() as i64),
            ground_truth: lookup(GROUND_TRUTH)
                .is_some()
                .then(|| env_flag(NODE, &lookup, GROUND_TRUTH, false))
                .transpose()?,
            depth: match (&backend, crate::depth::DepthConfig::from_lookup(&lookup)?) {
                (Backend::BodyDepth { .. }, Some(_)) => bail!(
                    "{NODE}: {}=body-depth sends its depth frames on `depth` itself; {} (the lab-target depth stream) cannot be set with it",
                    BACKEND,
                    crate::depth::DEPTH_RATE_HZ
                ),
                (_, depth) => depth,
            },
            backend,
        })
    }

    /// Frame period, ns.
    #[must_use]
    pub fn period_nanos(&self) -> i64 {
        (1e9 / self.frame_rate_hz).round() as i64
    }
}

/// `CLOCK_STEP_AT_SECS` and `CLOCK_STEP_MILLIS`: both or neither.
fn clock_step(lookup: &impl Fn(&str) -> Option<String>) -> eyre::Result<Option<ClockStep>> {
    let at = env_value(
        NODE,
        lookup,
        CLOCK_STEP_AT_SECS,
        |v: &f64| v.is_finite() && *v >= 0.0 && *v <= 1e6,
        "a number of seconds within 0–1000000",
    )?;
    let step = env_value(
        NODE,
        lookup,
        CLOCK_STEP_MILLIS,
        |v: &f64| v.is_finite() && v.abs() <= MAX_STEP_MILLIS,
        "a step in ms within ±3600000 (an hour)",
    )?;
    match (at, step) {
        (None, None) => Ok(None),
        (Some(at), Some(ms)) => Ok(Some(ClockStep {
            after_start_nanos: (at * 1e9).round() as i64,
            step_nanos: (ms * 1e6).round() as i64,
        })),
        (Some(_), None) => {
            bail!("{NODE}: {CLOCK_STEP_AT_SECS} is set but {CLOCK_STEP_MILLIS} (the step) is not")
        }
        (None, Some(_)) => {
            bail!("{NODE}: {CLOCK_STEP_MILLIS} is set but {CLOCK_STEP_AT_SECS} (when) is not")
        }
    }
}
