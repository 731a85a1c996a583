//! Calibrates a rig from the walk itself: every sensor's pose (world ← sensor) from the joint
//! tracks each sensor reported of one walking person, with no props and no tape measure, and a
//! plain answer when the walk cannot determine it.
//!
//! The input is, per sensor, its skeleton frames in its own camera space (Kinect v2: x left,
//! y up, z out of the lens) stamped with synchronised time. [`calibrate`] then
//!
//! 1. checks each frame's **handedness**: a Kinect body tracker that sees a person from behind
//!    labels the left leg as the right one. In the sensor's own frame the person's left is
//!    `up × forward` (up from the ankles to the hips, forward the pelvis velocity), so a frame
//!    whose left hip lies on the right is relabelled and counted ([`SensorResult::swapped_frames`]);
//! 2. resamples every sensor's tracks onto one time grid (cubic Hermite, never across a gap or an
//!    impossible jump), since free-running sensors do not capture at the same instants;
//! 3. finds an **initial guess**: from the data, each pair of sensors aligned by weighted
//!    Kabsch/Umeyama inside a RANSAC over common instants and the pairs chained along a
//!    maximum-overlap spanning tree; or from a rough rig file ([`Initial::Rig`]);
//! 4. runs the **joint adjustment** ([`adjust`]): Levenberg–Marquardt over all poses, the
//!    unknown joint positions and optionally a residual clock offset per sensor, weighted by
//!    the Kinect noise model, with reports beyond the 99.9 % χ² gate dropped as outliers;
//! 5. fixes the **world frame from the data** ([`gauge`]), the same way whether or not a rough rig
//!    was given: z up normal to the plane the pelvis moves in, the floor (z = 0) below the
//!    stance ankles, x along the walk, origin on the floor below the mean pelvis position;
//! 6. says **why** when something is off ([`Finding`]): a walk that leaves a rotation
//!    unobservable, a sensor that saw too little, a sensor with left and right swapped, a
//!    sensor inconsistent with the others; and gives each pose's uncertainty in millimetres and
//!    degrees, from the inverse of the adjustment's normal equations plus the world frame's own
//!    uncertainty.
//!
//! What a walk can determine: the sensors relative to each other need only joints that are not
//! all on one line, which a walking body always gives. The world frame needs the floor, whose
//! tilt across the walk is only as good as the path's spread across the walk: a turn or a
//! second line to the side, not a straight line (see [`gauge`]).

#![warn(missing_docs)]

pub mod adjust;
mod align;
pub mod gauge;
mod interp;
mod rigfile;

use std::collections::BTreeSet;

use nalgebra::{Isometry3, Matrix3, Point3, Vector3};
use serde::Serialize;
use trigait_kinect::{Intrinsics, NoiseModel, Sensor};
use trigait_rig::Rig;
use trigait_skeleton::{Joint, JointSample, TrackingState};

pub use gauge::{Gauge, Tracks};
pub use rigfile::{rig_file, yaw_pitch_roll_deg};
/// How far from its sensor a joint report can be and still have been measured.
pub use trigait_skeleton::MAX_REPORT_RANGE_M;

use adjust::{Obs, Problem};
use interp::{JointTrack, Limits};

/// Why a rig could not be calibrated.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// Fewer than two sensors: one sensor has nothing to be calibrated against.
    #[error("calibration needs at least two sensors, got {got}")]
    TooFewSensors {
        /// Sensors given.
        got: usize,
    },
    /// Two tracks carry the same sensor id.
    #[error("sensor {id:?} is given twice")]
    DuplicateSensor {
        /// The id.
        id: String,
    },
    /// The rough rig has no sensor of this id.
    #[error("the rough rig has no sensor {id:?}")]
    NotInRig {
        /// The id.
        id: String,
    },
    /// Too little walking to fix the world frame or anything else.
    #[error(
        "too little motion: the pelvis moved {path_m:.2} m along the walk, need at least {need_m} m \
         (walk past the sensors, turn, and walk back on a line to the side)"
    )]
    TooLittleMotion {
        /// Pelvis path length along the walk, metres.
        path_m: f64,
        /// Minimum, metres.
        need_m: f64,
    },
    /// Joints the method needs are missing.
    #[error("the tracks lack {what}")]
    MissingJoints {
        /// What is missing.
        what: &'static str,
    },
    /// No floor could be found.
    #[error(
        "no floor: only {stance_samples} stance ankle samples (the feet must be tracked while on the floor)"
    )]
    NoFloor {
        /// Stance samples found.
        stance_samples: usize,
    },
    /// A decomposition of the walk's geometry did not converge: the reports hold numbers no
    /// sensor could have measured, which [`MAX_REPORT_RANGE_M`] did not catch.
    #[error("the {what} could not be computed: the reports hold values no sensor could measure")]
    NonFinite {
        /// What could not be computed.
        what: &'static str,
    },
    /// More than a tenth of a sensor's joint reports are positions no sensor could measure.
    #[error(
        "sensor {id:?}: {impossible} of its {reports} joint reports are positions no sensor could \
         measure (not finite, behind it, or farther than {MAX_REPORT_RANGE_M} m): is the \
         recording corrupted, or in other units than metres?"
    )]
    ImpossibleReports {
        /// The sensor.
        id: String,
        /// Reports left out.
        impossible: usize,
        /// Its measured (tracked or inferred) reports.
        reports: usize,
    },
    /// No pair of sensors saw enough of the walk at the same time.
    #[error("no two sensors saw the walk together for {need} instants (best: {best})")]
    NoOverlap {
        /// Best common instants of a pair.
        best: usize,
        /// Needed.
        need: usize,
    },
}

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, Error>;

/// One skeleton frame of one sensor: joints in its camera space at a synchronised time.
#[derive(Debug, Clone, PartialEq)]
pub struct TrackFrame {
    /// Capture time on the common (synchronised) clock, seconds.
    pub t_secs: f64,
    /// The joints reported.
    pub joints: Vec<JointSample>,
}

impl TrackFrame {
    /// The frame with every left joint labelled right and vice versa.
    #[must_use]
    pub fn mirrored(&self) -> TrackFrame {
        TrackFrame {
            t_secs: self.t_secs,
            joints: self
                .joints
                .iter()
                .map(|s| JointSample {
                    joint: s.joint.mirrored(),
                    ..*s
                })
                .collect(),
        }
    }

    fn get(&self, joint: Joint) -> Option<Point3<f64>> {
        self.joints
            .iter()
            .find(|s| s.joint == joint && s.is_measured())
            .map(|s| s.position_in_kinect)
    }
}

/// Everything one sensor reported of the walk.
#[derive(Debug, Clone, PartialEq)]
pub struct SensorTrack {
    /// The sensor's id (as in rig files).
    pub id: String,
    /// Its frames, in any order.
    pub frames: Vec<TrackFrame>,
}

/// Where the adjustment starts.
#[derive(Debug, Clone, Copy)]
pub enum Initial<'a> {
    /// From the data: pairwise alignment (RANSAC + Kabsch) chained over a spanning tree.
    FromData,
    /// From a rough rig (sensors matched by id), e.g. a tape-measured one.
    Rig(&'a Rig),
}

/// Settings of [`calibrate`]; the defaults suit Kinect v2 skeletons at 30 Hz.
#[derive(Debug, Clone)]
pub struct Params {
    /// Joints used: the six leg joints.
    pub joints: Vec<Joint>,
    /// Rate of the common time grid, Hz: the Kinect v2 frame rate.
    pub grid_hz: f64,
    /// Longest gap in a track that is interpolated across: 0.1 s, three frames at 30 Hz.
    pub max_gap_secs: f64,
    /// Fastest a joint moves between two frames, m/s: a walking ankle peaks near 4 m/s, so a
    /// faster jump is a tracking error or a cut.
    pub max_joint_speed_mps: f64,
    /// Estimate a residual clock offset per sensor (on top of NTP), relative to the reference.
    pub time_offsets: bool,
    /// Largest residual clock offset allowed, seconds.
    pub max_time_offset_secs: f64,
    /// Ankle joint height above the floor, metres; `None`: from the tracked leg length.
    pub ankle_height_m: Option<f64>,
    /// Sensor model the reports are weighted by.
    pub noise: NoiseModel,
    /// Depth camera geometry of the model.
    pub intrinsics: Intrinsics,
    /// RANSAC: an instant agrees with a pairwise alignment when its median joint distance is
    /// below this, metres.
    pub ransac_threshold_m: f64,
    /// RANSAC hypotheses per pair.
    pub ransac_hypotheses: usize,
    /// Fewest grid instants a sensor must share with the others (≥ 3 joints each) to be
    /// calibrated.
    pub min_common_instants: usize,
    /// χ² gate (3 degrees of freedom) beyond which a report is an outlier: 16.27, 99.9 %.
    pub gate_chi2: f64,
    /// Position uncertainty (1σ, any axis) beyond which a pose is reported as not determined.
    pub tolerance_position_m: f64,
    /// Rotation uncertainty (1σ, any axis) beyond which a pose is reported as not determined.
    pub tolerance_rotation_rad: f64,
    /// Fewest metres (standard deviation) the stance feet must spread across the walk for the
    /// floor's tilt across it to count as observed.
    pub min_stance_spread_m: f64,
    /// Iteration limit of each Levenberg–Marquardt run.
    pub max_iterations: usize,
}

impl Default for Params {
    fn default() -> Self {
        Self {
            joints: Joint::LEGS.to_vec(),
            grid_hz: 30.0,
            max_gap_secs: 0.1,
            max_joint_speed_mps: 12.0,
            time_offsets: false,
            max_time_offset_secs: 0.1,
            ankle_height_m: None,
            noise: NoiseModel::default(),
            intrinsics: Intrinsics::default(),
            ransac_threshold_m: 0.1,
            ransac_hypotheses: 64,
            min_common_instants: 30,
            gate_chi2: 16.27,
            tolerance_position_m: 0.01,
            tolerance_rotation_rad: 0.5f64.to_radians(),
            min_stance_spread_m: 0.2,
            max_iterations: 100,
        }
    }
}

/// One sensor's result.
#[derive(Debug, Clone, Serialize)]
pub struct SensorResult {
    /// The sensor's id.
    pub id: String,
    /// Its pose, camera space → world; `None` when it could not be calibrated.
    #[serde(skip)]
    pub world_from_kinect: Option<Isometry3<f64>>,
    /// Whether it was the adjustment's fixed reference.
    pub reference: bool,
    /// 1σ uncertainty of the position along world x, y, z, metres.
    pub position_sigma_m: [f64; 3],
    /// 1σ uncertainty of the orientation about world x, y, z, radians.
    pub rotation_sigma_rad: [f64; 3],
    /// Residual clock offset (added to its timestamps), seconds; 0 when not estimated.
    pub time_offset_secs: f64,
    /// 1σ of the clock offset, seconds.
    pub time_offset_sigma_secs: f64,
    /// Reports used in the adjustment.
    pub reports: usize,
    /// Reports dropped as outliers by the χ² gate.
    pub outliers: usize,
    /// RMS distance between its reports and the adjusted joints, metres.
    pub residual_rms_m: f64,
    /// RMS noise-normalised residual per coordinate: about 1 when the sensor agrees with the
    /// others as its noise model says.
    pub normalised_rms: f64,
    /// Frames received.
    pub frames: usize,
    /// Frames whose left/right labels were swapped (and were corrected).
    pub swapped_frames: usize,
    /// Frames whose handedness could not be checked (standing, turning, hips not tracked).
    pub unchecked_frames: usize,
    /// Joint reports left out as impossible: not finite, behind the sensor, or farther than
    /// [`MAX_REPORT_RANGE_M`].
    pub impossible_reports: usize,
}

/// What kind of problem a [`Finding`] is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum FindingKind {
    /// The walk leaves a degree of freedom of the world frame (and so of every pose)
    /// undetermined.
    Unobservable,
    /// A sensor's pose is less certain than the tolerance.
    PoorlyDetermined,
    /// A sensor saw too little of the walk together with the others to be calibrated.
    SawTooLittle,
    /// A sensor reported left and right swapped.
    LeftRightSwapped,
    /// A sensor disagrees with the others more than its noise allows.
    Inconsistent,
    /// A sensor reported joints no sensor could have measured; they were left out.
    ImpossibleReports,
}

/// A diagnosis, with the sensor it concerns and what to do.
#[derive(Debug, Clone, Serialize)]
pub struct Finding {
    /// What kind.
    pub kind: FindingKind,
    /// The sensor, if it concerns one.
    pub sensor: Option<String>,
    /// The explanation, with numbers and advice.
    pub message: String,
}

/// The calibrated rig and how it was found.
#[derive(Debug, Clone, Serialize)]
pub struct Calibration {
    /// One result per input track, in input order.
    pub sensors: Vec<SensorResult>,
    /// The world frame found in the walk.
    pub gauge: Gauge,
    /// Diagnoses; empty when everything is determined within tolerance.
    pub findings: Vec<Finding>,
    /// First instant of the time grid, seconds.
    pub grid_start_secs: f64,
    /// Grid period, seconds.
    pub grid_period_secs: f64,
    /// Where the adjustment started: `data` or `rig`.
    pub initial: &'static str,
    /// Levenberg–Marquardt iterations, all runs.
    pub iterations: usize,
    /// The adjusted joint positions on the grid, world frame.
    #[serde(skip)]
    pub joints_in_world: Tracks,
}

impl Calibration {
    /// Whether every sensor was calibrated and nothing was found unobservable or poorly
    /// determined.
    #[must_use]
    pub fn determined(&self) -> bool {
        self.sensors.iter().all(|s| s.world_from_kinect.is_some())
            && !self.findings.iter().any(|f| {
                matches!(
                    f.kind,
                    FindingKind::Unobservable | FindingKind::PoorlyDetermined
                )
            })
    }
}

/// A track after cleaning: per joint column, the samples as [`JointTrack`]s.
struct Cleaned {
    tracks: Vec<JointTrack>,
    frames: usize,
    swapped: usize,
    unchecked: usize,
    impossible: usize,
    /// Measured reports, impossible ones included.
    reports: usize,
}

/// Speed below which the walking direction is too uncertain to check handedness, m/s.
const MIN_HANDEDNESS_SPEED_MPS: f64 = 0.3;

/// Most sweeps an SVD or an eigen-decomposition may take. nalgebra's plain `svd()` and
/// `symmetric_eigen()` iterate until they converge, which a NaN or an overflow never does: a
/// bounded one gives up and the caller treats the matrix as degenerate instead of hanging.
pub(crate) const MAX_DECOMPOSITION_ITERATIONS: usize = 10_000;

/// Half-window over which the pelvis velocity is measured for the handedness check, seconds.
const HANDEDNESS_WINDOW_SECS: f64 = 0.2;
/// The hips must lie at least this far to one side to decide handedness, metres (hip joint
/// centres are about 0.18 m apart).
const HANDEDNESS_MARGIN_M: f64 = 0.06;

/// Whether each frame is labelled mirror-wise (`Some(true)`), correctly, or cannot be checked.
fn handedness(frames: &[TrackFrame]) -> Vec<Option<bool>> {
    let pelvis: Vec<Option<Point3<f64>>> = frames
        .iter()
        .map(|f| {
            Some(nalgebra::center(
                &f.get(Joint::HipLeft)?,
                &f.get(Joint::HipRight)?,
            ))
        })
        .collect();
    frames
        .iter()
        .enumerate()
        .map(|(i, f)| {
            let (hl, hr) = (f.get(Joint::HipLeft)?, f.get(Joint::HipRight)?);
            let ankles = nalgebra::center(&f.get(Joint::AnkleLeft)?, &f.get(Joint::AnkleRight)?);
            let up = (nalgebra::center(&hl, &hr) - ankles).try_normalize(1e-9)?;
            let t = f.t_secs;
            let lo = (0..i)
                .rev()
                .take_while(|j| frames[*j].t_secs >= t - HANDEDNESS_WINDOW_SECS)
                .filter(|j| pelvis[*j].is_some())
                .last()
                .unwrap_or(i);
            let hi = (i + 1..frames.len())
                .take_while(|j| frames[*j].t_secs <= t + HANDEDNESS_WINDOW_SECS)
                .filter(|j| pelvis[*j].is_some())
                .last()
                .unwrap_or(i);
            let dt = frames[hi].t_secs - frames[lo].t_secs;
            if dt < HANDEDNESS_WINDOW_SECS {
                return None;
            }
            let v = (pelvis[hi]? - pelvis[lo]?) / dt;
            // A walking pelvis moves at most ~3 m/s; faster is a cut in the recording.
            let v = v - up * up.dot(&v);
            if v.norm() < MIN_HANDEDNESS_SPEED_MPS || v.norm() > 3.0 {
                return None;
            }
            let left = up.cross(&v).normalize();
            let side = (hl - hr).dot(&left);
            (side.abs() >= HANDEDNESS_MARGIN_M).then_some(side < 0.0)
        })
        .collect()
}

fn clean(track: &SensorTrack, joints: &[Joint]) -> Cleaned {
    let (mut impossible, mut reports) = (0, 0);
    let mut frames: Vec<TrackFrame> = track
        .frames
        .iter()
        .filter(|f| f.t_secs.is_finite())
        .map(|f| TrackFrame {
            t_secs: f.t_secs,
            joints: f
                .joints
                .iter()
                .filter(|s| s.is_measured())
                .filter(|s| {
                    let possible = s.is_possible();
                    impossible += usize::from(!possible);
                    reports += 1;
                    possible
                })
                .copied()
                .collect(),
        })
        .collect();
    frames.sort_by(|a, b| a.t_secs.total_cmp(&b.t_secs));
    frames.dedup_by(|a, b| a.t_secs == b.t_secs);
    let hand = handedness(&frames);
    let mut swapped = 0;
    let mut unchecked = 0;
    for (f, h) in frames.iter_mut().zip(&hand) {
        match h {
            Some(true) => {
                *f = f.mirrored();
                swapped += 1;
            }
            Some(false) => {}
            None => unchecked += 1,
        }
    }
    let tracks = joints
        .iter()
        .map(|j| {
            let mut jt = JointTrack::default();
            for f in &frames {
                if let Some(s) = f.joints.iter().find(|s| s.joint == *j) {
                    jt.t.push(f.t_secs);
                    jt.p.push(s.position_in_kinect);
                    jt.inferred.push(s.state == TrackingState::Inferred);
                }
            }
            jt
        })
        .collect();
    Cleaned {
        tracks,
        frames: frames.len(),
        swapped,
        unchecked,
        impossible,
        reports,
    }
}

/// A sensor's sample of one joint at one grid instant, with its weight.
#[derive(Debug, Clone, Copy)]
struct GridSample {
    position: Point3<f64>,
    velocity: Vector3<f64>,
    inferred: bool,
    information: Matrix3<f64>,
}

/// Calibrates the sensors of `tracks` from one walk; see the crate documentation.
///
/// # Errors
/// See [`Error`]: fewer than two sensors, duplicate ids, a sensor missing from the rough rig,
/// too little motion, no floor, no overlap between sensors; [`Error::ImpossibleReports`] when
/// the calibration fails and a sensor's reports were more than a tenth impossible.
pub fn calibrate(
    tracks: &[SensorTrack],
    initial: Initial<'_>,
    params: &Params,
) -> Result<Calibration> {
    let ns = tracks.len();
    if ns < 2 {
        return Err(Error::TooFewSensors { got: ns });
    }
    let mut ids = BTreeSet::new();
    for t in tracks {
        if !ids.insert(t.id.as_str()) {
            return Err(Error::DuplicateSensor { id: t.id.clone() });
        }
    }
    let cleaned: Vec<Cleaned> = tracks.iter().map(|t| clean(t, &params.joints)).collect();
    // Impossible reports are left out and the calibration goes on without them; if it then
    // fails, a sensor with many of them is the likelier cause than what failed.
    let impossible = tracks
        .iter()
        .zip(&cleaned)
        .find(|(_, c)| 10 * c.impossible > c.reports)
        .map(|(t, c)| Error::ImpossibleReports {
            id: t.id.clone(),
            impossible: c.impossible,
            reports: c.reports,
        });
    calibrate_cleaned(tracks, cleaned, initial, params).map_err(|e| match e {
        // A rig without the sensor is the user's configuration, whatever the reports hold.
        Error::NotInRig { .. } => e,
        _ => impossible.unwrap_or(e),
    })
}

/// [`calibrate`] once the reports are cleaned.
fn calibrate_cleaned(
    tracks: &[SensorTrack],
    cleaned: Vec<Cleaned>,
    initial: Initial<'_>,
    params: &Params,
) -> Result<Calibration> {
    let ns = tracks.len();
    let limits = Limits {
        max_gap_secs: params.max_gap_secs,
        max_speed_mps: params.max_joint_speed_mps,
    };
    let joints = &params.joints;
    let nj = joints.len();
    let (t0, t1) = cleaned
        .iter()
        .flat_map(|c| c.tracks.iter().flat_map(|t| t.t.iter().copied()))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), t| {
            (lo.min(t), hi.max(t))
        });
    if !t0.is_finite() || t1 - t0 <= 1.0 {
        return Err(Error::TooLittleMotion {
            path_m: 0.0,
            need_m: gauge::MIN_PATH_M,
        });
    }
    let dt = 1.0 / params.grid_hz;
    let nk = ((t1 - t0) / dt).floor() as usize + 1;
    let models: Vec<Sensor> = tracks
        .iter()
        .map(|t| {
            let mut s = Sensor::new(t.id.clone(), Isometry3::identity());
            s.noise = params.noise.clone();
            s.intrinsics = params.intrinsics;
            s
        })
        .collect();
    // grid[s][k * nj + c]
    let grid: Vec<Vec<Option<GridSample>>> = cleaned
        .iter()
        .zip(&models)
        .map(|(c, model)| {
            let mut out = vec![None; nk * nj];
            for k in 0..nk {
                let t = t0 + k as f64 * dt;
                let at: Vec<Option<interp::Sample>> =
                    c.tracks.iter().map(|tr| tr.at(t, &limits)).collect();
                for (col, joint) in joints.iter().enumerate() {
                    let Some(s) = at[col] else { continue };
                    let position = |j: Joint| {
                        let i = joints.iter().position(|x| *x == j)?;
                        at[i].map(|s| s.position)
                    };
                    let state = if s.inferred {
                        TrackingState::Inferred
                    } else {
                        TrackingState::Tracked
                    };
                    let limb = trigait_kinect::limb_axis(*joint, position);
                    let cov = model.covariance_in_kinect(*joint, &s.position, state, limb);
                    let Some(information) = cov.try_inverse() else {
                        continue;
                    };
                    out[k * nj + col] = Some(GridSample {
                        position: s.position,
                        velocity: s.velocity,
                        inferred: s.inferred,
                        information,
                    });
                }
            }
            out
        })
        .collect();
    let seen = |s: usize, k: usize| (0..nj).filter(|c| grid[s][k * nj + c].is_some()).count();

    // Initial poses (frame ← kinect) and which sensors can be calibrated.
    let (mut poses, calibratable, initial_name) = match initial {
        Initial::Rig(rig) => {
            let mut poses = Vec::with_capacity(ns);
            for t in tracks {
                let s = rig
                    .sensors
                    .iter()
                    .find(|s| s.id == t.id)
                    .ok_or_else(|| Error::NotInRig { id: t.id.clone() })?;
                poses.push(s.world_from_kinect);
            }
            let ok: Vec<bool> = (0..ns)
                .map(|s| {
                    (0..nk)
                        .filter(|k| seen(s, *k) >= 3 && (0..ns).any(|o| o != s && seen(o, *k) >= 3))
                        .count()
                        >= params.min_common_instants
                })
                .collect();
            (poses, ok, "rig")
        }
        Initial::FromData => {
            let (poses, ok) = initial_from_data(&grid, ns, nk, nj, params)?;
            (poses, ok, "data")
        }
    };
    if calibratable.iter().filter(|c| **c).count() < 2 {
        return Err(Error::NoOverlap {
            best: 0,
            need: params.min_common_instants,
        });
    }
    let samples = |s: usize| grid[s].iter().flatten().count();
    let reference = (0..ns)
        .filter(|s| calibratable[*s])
        .max_by_key(|s| samples(*s))
        .unwrap_or(0);

    // Points: every (instant, joint) two or more calibratable sensors saw.
    let mut points = Vec::new();
    let mut obs = Vec::new();
    let mut by_point = vec![0];
    let mut point_of = vec![None; nk * nj];
    for k in 0..nk {
        for c in 0..nj {
            let who: Vec<usize> = (0..ns)
                .filter(|s| calibratable[*s] && grid[*s][k * nj + c].is_some())
                .collect();
            if who.len() < 2 {
                continue;
            }
            let p = points.len();
            point_of[k * nj + c] = Some(p);
            let mut mean = Vector3::zeros();
            for s in &who {
                let Some(g) = grid[*s][k * nj + c] else {
                    continue;
                };
                mean += (poses[*s] * g.position).coords;
                obs.push(Obs {
                    sensor: *s,
                    point: p,
                    t_secs: t0 + k as f64 * dt,
                    track: c,
                    information: g.information,
                    measured: g.position,
                    velocity: g.velocity,
                    active: true,
                });
            }
            points.push(Point3::from(mean / who.len() as f64));
            by_point.push(obs.len());
        }
    }
    let counts: Vec<(usize, usize, usize, usize)> = cleaned
        .iter()
        .map(|c| (c.frames, c.swapped, c.unchecked, c.impossible))
        .collect();
    let track_refs: Vec<Vec<JointTrack>> = cleaned.into_iter().map(|c| c.tracks).collect();
    let mut problem = Problem {
        poses: poses.clone(),
        offsets: vec![0.0; ns],
        free: (0..ns).map(|s| calibratable[s] && s != reference).collect(),
        points,
        obs,
        by_point,
        tracks: &track_refs,
        limits,
        time_offsets: false,
        max_offset_secs: params.max_time_offset_secs,
    };
    let mut iterations = 0;
    let mut gate_and_solve = |problem: &mut Problem<'_>| {
        let mut solve = problem.solve(params.max_iterations);
        iterations += solve.iterations;
        for _ in 0..3 {
            let chi2 = problem.chi2();
            let mut changed = false;
            for (o, c) in problem.obs.iter_mut().zip(chi2) {
                let active = c <= params.gate_chi2;
                changed |= active != o.active;
                o.active = active;
            }
            if !changed {
                break;
            }
            solve = problem.solve(params.max_iterations);
            iterations += solve.iterations;
        }
        solve
    };
    let mut solve = gate_and_solve(&mut problem);
    if params.time_offsets {
        problem.time_offsets = true;
        solve = gate_and_solve(&mut problem);
    }
    poses.clone_from(&problem.poses);

    // Joint tracks in the frame: adjusted points, else the single sensor's report.
    let mut positions = vec![vec![None; nj]; nk];
    for k in 0..nk {
        for c in 0..nj {
            positions[k][c] = match point_of[k * nj + c] {
                Some(p) => Some(problem.points[p]),
                None => (0..ns)
                    .filter(|s| calibratable[*s])
                    .find_map(|s| grid[s][k * nj + c].map(|g| poses[s] * g.position)),
            };
        }
    }
    let in_frame = Tracks {
        dt_secs: dt,
        joints: joints.clone(),
        positions,
    };
    let gauge = gauge::gauge(&in_frame, params.ankle_height_m)?;
    let g = gauge.world_from_frame;
    let gr = *g.rotation.to_rotation_matrix().matrix();

    // Per-sensor statistics.
    let chi2 = problem.chi2();
    let mut results = Vec::with_capacity(ns);
    let rot_gauge = Matrix3::from_diagonal(&Vector3::from(gauge.rotation_sigma_rad).map(|v| v * v));
    let pos_gauge = Matrix3::from_diagonal(&Vector3::from(gauge.origin_sigma_m).map(|v| v * v));
    for s in 0..ns {
        let mine: Vec<(usize, &Obs)> = problem
            .obs
            .iter()
            .enumerate()
            .filter(|(_, o)| o.sensor == s)
            .collect();
        let active: Vec<&(usize, &Obs)> = mine.iter().filter(|(_, o)| o.active).collect();
        let n_active = active.len().max(1) as f64;
        let sq: f64 = active
            .iter()
            .map(|(_, o)| {
                (problem.poses[s].inverse_transform_point(&problem.points[o.point]) - o.measured)
                    .norm_squared()
            })
            .sum();
        let chi: f64 = active.iter().map(|(i, _)| chi2[*i]).sum();
        let dof = (3.0 * n_active - if problem.free[s] { 6.0 } else { 0.0 }).max(1.0);
        let scale = (chi / dof).max(1.0);
        let cov = &solve.covariance[s];
        let r = *problem.poses[s].rotation.to_rotation_matrix().matrix();
        let theta = cov.fixed_view::<3, 3>(0, 0).into_owned() * scale;
        let centre = cov.fixed_view::<3, 3>(3, 3).into_owned() * scale;
        let world_pose = g * problem.poses[s];
        let p = world_pose.translation.vector;
        let skew = Matrix3::new(0.0, -p.z, p.y, p.z, 0.0, -p.x, -p.y, p.x, 0.0);
        let rot_world = gr * r * theta * (gr * r).transpose() + rot_gauge;
        let pos_world =
            gr * centre * gr.transpose() + skew * rot_gauge * skew.transpose() + pos_gauge;
        let diag = |m: &Matrix3<f64>| [m[(0, 0)].sqrt(), m[(1, 1)].sqrt(), m[(2, 2)].sqrt()];
        results.push(SensorResult {
            id: tracks[s].id.clone(),
            world_from_kinect: calibratable[s].then_some(world_pose),
            reference: s == reference,
            position_sigma_m: diag(&pos_world),
            rotation_sigma_rad: diag(&rot_world),
            time_offset_secs: problem.offsets[s],
            time_offset_sigma_secs: if problem.time_offsets {
                (cov[(6, 6)] * scale).sqrt()
            } else {
                0.0
            },
            reports: active.len(),
            outliers: mine.len() - active.len(),
            residual_rms_m: (sq / n_active).sqrt(),
            normalised_rms: (chi / (3.0 * n_active)).sqrt(),
            frames: counts[s].0,
            swapped_frames: counts[s].1,
            unchecked_frames: counts[s].2,
            impossible_reports: counts[s].3,
        });
    }
    let findings = diagnose(&results, &gauge, params);
    Ok(Calibration {
        sensors: results,
        gauge,
        findings,
        grid_start_secs: t0,
        grid_period_secs: dt,
        initial: initial_name,
        iterations,
        joints_in_world: in_frame.transformed(&g),
    })
}

/// Pairwise alignment of every pair, chained along the maximum-overlap spanning tree from the
/// sensor with the most samples. Returns poses in that sensor's frame and which sensors the
/// tree reached.
fn initial_from_data(
    grid: &[Vec<Option<GridSample>>],
    ns: usize,
    nk: usize,
    nj: usize,
    params: &Params,
) -> Result<(Vec<Isometry3<f64>>, Vec<bool>)> {
    let weight = |g: &GridSample| -> f64 { if g.inferred { 1.0 / 9.0 } else { 1.0 } };
    let mut edges: Vec<(usize, usize, align::Alignment)> = Vec::new();
    let mut best = 0;
    for a in 0..ns {
        for b in a + 1..ns {
            let instants: Vec<align::Instant> = (0..nk)
                .filter_map(|k| {
                    let pairs: Vec<align::Pair> = (0..nj)
                        .filter_map(|c| {
                            let (ga, gb) = (grid[a][k * nj + c]?, grid[b][k * nj + c]?);
                            Some(align::Pair {
                                a: ga.position,
                                b: gb.position,
                                weight: weight(&ga).min(weight(&gb)),
                            })
                        })
                        .collect();
                    (pairs.len() >= 3).then_some(pairs)
                })
                .collect();
            let Some(al) = align::ransac(
                &instants,
                params.ransac_threshold_m,
                params.ransac_hypotheses,
            ) else {
                continue;
            };
            best = best.max(al.inliers);
            if al.inliers >= params.min_common_instants {
                edges.push((a, b, al));
            }
        }
    }
    let samples = |s: usize| grid[s].iter().flatten().count();
    let root = (0..ns)
        .filter(|s| edges.iter().any(|(a, b, _)| a == s || b == s))
        .max_by_key(|s| samples(*s))
        .ok_or(Error::NoOverlap {
            best,
            need: params.min_common_instants,
        })?;
    let mut poses = vec![Isometry3::identity(); ns];
    let mut reached = vec![false; ns];
    reached[root] = true;
    // Prim: repeatedly take the strongest edge from the tree to a new sensor.
    loop {
        let next = edges
            .iter()
            .filter(|(a, b, _)| reached[*a] != reached[*b])
            .max_by_key(|(_, _, al)| al.inliers);
        let Some((a, b, al)) = next else { break };
        if reached[*a] {
            poses[*b] = poses[*a] * al.a_from_b;
            reached[*b] = true;
        } else {
            poses[*a] = poses[*b] * al.a_from_b.inverse();
            reached[*a] = true;
        }
    }
    Ok((poses, reached))
}

fn deg(rad: f64) -> f64 {
    rad.to_degrees()
}

const AXES: [&str; 3] = ["x (along the walk)", "y (across the walk)", "z (vertical)"];

fn diagnose(results: &[SensorResult], gauge: &Gauge, params: &Params) -> Vec<Finding> {
    let mut out = Vec::new();
    let across = gauge.stance_spread_m[1];
    if across < params.min_stance_spread_m {
        let worst = results
            .iter()
            .filter(|r| r.world_from_kinect.is_some())
            .map(|r| {
                let p = r
                    .world_from_kinect
                    .map_or(Vector3::zeros(), |w| w.translation.vector);
                (
                    r.id.clone(),
                    (p.y * p.y + p.z * p.z).sqrt() * gauge.rotation_sigma_rad[0],
                )
            })
            .max_by(|a, b| a.1.total_cmp(&b.1));
        out.push(Finding {
            kind: FindingKind::Unobservable,
            sensor: None,
            message: format!(
                "rotation about the walking direction (x) is not observable: the stance feet \
                 spread only {:.2} m across the walk (need {:.2} m), so the floor's tilt across \
                 the walkway rests on the step width and on the two ankles being at the same \
                 height (±{:.2}° from the noise alone{}); walk a second line at least 1 m to the \
                 side of the first, or turn",
                across,
                params.min_stance_spread_m,
                deg(gauge.rotation_sigma_rad[0]),
                worst.map_or_else(String::new, |(id, m)| format!(
                    ", {:.0} mm at sensor {id}",
                    m * 1e3
                )),
            ),
        });
    }
    for r in results {
        let id = Some(r.id.clone());
        if r.impossible_reports > 0 {
            out.push(Finding {
                kind: FindingKind::ImpossibleReports,
                sensor: id.clone(),
                message: format!(
                    "sensor {} reported {} joint position(s) no sensor could measure (not \
                     finite, behind it, or farther than {MAX_REPORT_RANGE_M} m): left out; is \
                     the recording corrupted, or in other units than metres?",
                    r.id, r.impossible_reports
                ),
            });
        }
        if r.world_from_kinect.is_none() {
            out.push(Finding {
                kind: FindingKind::SawTooLittle,
                sensor: id,
                message: format!(
                    "sensor {} saw the walk together with the others for fewer than {} instants \
                     (three joints or more): not calibrated; aim it at the walkway",
                    r.id, params.min_common_instants
                ),
            });
            continue;
        }
        let (pa, pmax) = r
            .position_sigma_m
            .iter()
            .enumerate()
            .fold(
                (0, 0.0),
                |acc, (i, v)| if *v > acc.1 { (i, *v) } else { acc },
            );
        let (ra, rmax) = r
            .rotation_sigma_rad
            .iter()
            .enumerate()
            .fold(
                (0, 0.0),
                |acc, (i, v)| if *v > acc.1 { (i, *v) } else { acc },
            );
        if pmax > params.tolerance_position_m || rmax > params.tolerance_rotation_rad {
            out.push(Finding {
                kind: FindingKind::PoorlyDetermined,
                sensor: id.clone(),
                message: format!(
                    "sensor {}: pose determined to ±{:.1} mm along {} and ±{:.2}° about {} \
                     (tolerance {:.0} mm, {:.2}°)",
                    r.id,
                    pmax * 1e3,
                    AXES[pa],
                    deg(rmax),
                    AXES[ra],
                    params.tolerance_position_m * 1e3,
                    deg(params.tolerance_rotation_rad)
                ),
            });
        }
        if r.time_offset_sigma_secs > 0.002 {
            out.push(Finding {
                kind: FindingKind::PoorlyDetermined,
                sensor: id.clone(),
                message: format!(
                    "sensor {}: clock offset determined only to ±{:.1} ms; on a straight walk at \
                     constant speed it trades against a shift along the walk — walk back the other way",
                    r.id,
                    r.time_offset_sigma_secs * 1e3
                ),
            });
        }
        let checked = r.frames.saturating_sub(r.unchecked_frames);
        if r.swapped_frames > 0 && checked > 0 {
            let share = r.swapped_frames as f64 / checked as f64;
            if share >= 0.02 {
                out.push(Finding {
                    kind: FindingKind::LeftRightSwapped,
                    sensor: id.clone(),
                    message: if share > 0.5 {
                        format!(
                            "sensor {} reports left and right swapped in {:.0} % of the frames \
                             that could be checked (corrected here): is its output mirrored?",
                            r.id,
                            share * 100.0
                        )
                    } else {
                        format!(
                            "sensor {} swapped left and right in {:.0} % of the frames that \
                             could be checked (corrected here; a body tracker seeing the walker \
                             from behind does this)",
                            r.id,
                            share * 100.0
                        )
                    },
                });
            }
        }
        let total = r.reports + r.outliers;
        let outlier_share = r.outliers as f64 / total.max(1) as f64;
        if r.normalised_rms > 2.0 || outlier_share > 0.2 {
            out.push(Finding {
                kind: FindingKind::Inconsistent,
                sensor: id,
                message: format!(
                    "sensor {} disagrees with the others: residual {:.0} mm RMS, {:.1}× its noise \
                     model, {:.0} % of its reports rejected",
                    r.id,
                    r.residual_rms_m * 1e3,
                    r.normalised_rms,
                    outlier_share * 100.0
                ),
            });
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use nalgebra::{Isometry3, Vector3};
    use trigait_motion::{WalkerParams, walker, walkway_laps};
    use trigait_rig::Rig;
    use trigait_skeleton::{Joint, JointSample, TrackingState};

    use super::*;

    /// Noise-free reports of the walker (out and back on two lanes) by the sensors of `rig`,
    /// every joint at every frame, each sensor at its own phase.
    fn exact_tracks(rig: &Rig) -> (Vec<SensorTrack>, trigait_skeleton::MotionClip) {
        let pass = walker(&WalkerParams::default(), 2.5, 120.0)
            .unwrap()
            .placed_on_walkway();
        let clip = walkway_laps(&pass, 1.0, 1.0, 1).unwrap();
        let tracks = rig
            .sensors
            .iter()
            .enumerate()
            .map(|(s, sensor)| {
                let phase = 0.01 * s as f64;
                let frames = (0..)
                    .map(|i| phase + f64::from(i) / 30.0)
                    .take_while(|t| *t <= clip.duration_secs())
                    .map(|t| TrackFrame {
                        t_secs: t,
                        joints: Joint::LEGS
                            .iter()
                            .filter_map(|j| {
                                let p = clip.position_at(*j, t)?;
                                Some(JointSample {
                                    joint: *j,
                                    position_in_kinect: sensor
                                        .world_from_kinect
                                        .inverse_transform_point(&p),
                                    state: TrackingState::Tracked,
                                })
                            })
                            .collect(),
                    })
                    .filter(|f| !f.joints.is_empty())
                    .collect();
                SensorTrack {
                    id: sensor.id.clone(),
                    frames,
                }
            })
            .collect();
        (tracks, clip)
    }

    fn truth_gauge(clip: &trigait_skeleton::MotionClip, c: &Calibration) -> Isometry3<f64> {
        let positions = (0..c.joints_in_world.positions.len())
            .map(|k| {
                let t = c.grid_start_secs + k as f64 * c.grid_period_secs;
                // The truth at the instants the calibration had each joint, so both frames are
                // fixed from the same samples.
                Joint::LEGS
                    .iter()
                    .enumerate()
                    .map(|(col, j)| {
                        c.joints_in_world.positions[k][col].and(clip.position_at(*j, t))
                    })
                    .collect()
            })
            .collect();
        let truth = Tracks {
            dt_secs: c.grid_period_secs,
            joints: Joint::LEGS.to_vec(),
            positions,
        };
        gauge::gauge(&truth, None).unwrap().world_from_frame
    }

    /// Noise-free reports give the true rig (in the walk's own world frame) to well under a
    /// millimetre, from the data alone and from a rig moved 30 cm and turned 20°; no handedness
    /// is flipped, and the walk's frame is the motion's own within 0.6° (its mean heading is not
    /// exactly its start-to-end direction).
    #[test]
    fn exact_data_give_the_true_rig() {
        let rig = Rig::builtin("ring-5").unwrap();
        let (tracks, clip) = exact_tracks(&rig);
        let mut rough = rig.clone();
        for (i, s) in rough.sensors.iter_mut().enumerate() {
            let turn = Isometry3::new(
                Vector3::new(0.3, -0.1 * i as f64, 0.1),
                Vector3::z() * if i % 2 == 0 { 0.35 } else { -0.35 },
            );
            s.world_from_kinect = turn * s.world_from_kinect;
        }
        for initial in [Initial::FromData, Initial::Rig(&rough)] {
            let c = calibrate(&tracks, initial, &Params::default()).unwrap();
            let g = truth_gauge(&clip, &c);
            assert!(
                g.rotation.angle() < 0.01,
                "truth frame turned {}",
                g.rotation.angle()
            );
            for (s, t) in c.sensors.iter().zip(&rig.sensors) {
                let est = s.world_from_kinect.unwrap();
                let t = g * t.world_from_kinect;
                eprintln!(
                    "{} {:.2} mm {:.4} deg",
                    s.id,
                    (est.translation.vector - t.translation.vector).norm() * 1e3,
                    (est.rotation.inverse() * t.rotation).angle().to_degrees()
                );
                assert!(
                    (est.translation.vector - t.translation.vector).norm() < 1e-3,
                    "{s:?}"
                );
                assert!((est.rotation.inverse() * t.rotation).angle() < 0.02f64.to_radians());
                assert_eq!(s.swapped_frames, 0);
            }
            assert!(
                c.findings
                    .iter()
                    .all(|f| f.kind != FindingKind::Unobservable),
                "{:?}",
                c.findings
            );
        }
    }

    /// Bad input is a typed error, not a panic.
    #[test]
    fn rejects_bad_input() {
        let rig = Rig::builtin("thesis").unwrap();
        let (tracks, _) = exact_tracks(&rig);
        assert!(matches!(
            calibrate(&tracks[..1], Initial::FromData, &Params::default()),
            Err(Error::TooFewSensors { got: 1 })
        ));
        let mut dup = tracks.clone();
        dup[1].id = dup[0].id.clone();
        assert!(matches!(
            calibrate(&dup, Initial::FromData, &Params::default()),
            Err(Error::DuplicateSensor { .. })
        ));
        let other = Rig::builtin("ring-3").unwrap();
        let mut renamed = tracks.clone();
        renamed[0].id = "elsewhere".into();
        assert!(matches!(
            calibrate(&renamed, Initial::Rig(&other), &Params::default()),
            Err(Error::NotInRig { .. })
        ));
        let short: Vec<SensorTrack> = tracks
            .iter()
            .map(|t| SensorTrack {
                id: t.id.clone(),
                frames: t.frames[..20].to_vec(),
            })
            .collect();
        assert!(matches!(
            calibrate(&short, Initial::FromData, &Params::default()),
            Err(Error::TooLittleMotion { .. })
        ));
        // One joint of one sensor impossible in every frame (NaN, or finite but overflowing
        // once squared, which hung an unbounded SVD): left out, counted and reported.
        for bad in [f64::NAN, 1e300] {
            let mut odd = tracks.clone();
            for f in &mut odd[0].frames {
                f.joints[0].position_in_kinect.x = bad;
            }
            let c = calibrate(&odd, Initial::FromData, &Params::default()).unwrap();
            assert_eq!(c.sensors[0].impossible_reports, odd[0].frames.len());
            assert_eq!(c.sensors[1].impossible_reports, 0);
            assert!(
                c.findings
                    .iter()
                    .any(|f| f.kind == FindingKind::ImpossibleReports
                        && f.sensor.as_deref() == Some(odd[0].id.as_str())),
                "{:?}",
                c.findings
            );
        }
        // Every report of a sensor in millimetres: the others are calibrated without it, and
        // the findings say why it was not; with one other sensor left nothing can be, and the
        // error says why rather than what then failed.
        let mut mm = tracks;
        for f in &mut mm[0].frames {
            for j in &mut f.joints {
                j.position_in_kinect.coords *= 1000.0;
            }
        }
        let c = calibrate(&mm, Initial::FromData, &Params::default()).unwrap();
        assert!(c.sensors[0].world_from_kinect.is_none());
        assert!(c.sensors[1..].iter().all(|s| s.world_from_kinect.is_some()));
        assert_eq!(
            c.findings[0].kind,
            FindingKind::ImpossibleReports,
            "{:?}",
            c.findings
        );
        let e = calibrate(&mm[..2], Initial::FromData, &Params::default()).unwrap_err();
        assert!(
            matches!(&e, Error::ImpossibleReports { id, .. } if *id == mm[0].id),
            "{e}"
        );
    }

    /// The rig file's yaw/pitch/roll give back the rotation.
    #[test]
    fn rig_file_round_trip() {
        let rig = Rig::builtin("ring-4").unwrap();
        for s in &rig.sensors {
            let tilt = s.world_from_kinect.rotation
                * nalgebra::UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 0.07);
            let ypr = yaw_pitch_roll_deg(&tilt);
            let yaml = format!(
                "sensors:\n  - id: a\n    position: [0, 0, 1]\n    yaw_pitch_roll_deg: [{}, {}, {}]\n",
                ypr[0], ypr[1], ypr[2]
            );
            let back = Rig::from_yaml_str(&yaml, "t").unwrap();
            assert!((back.sensors[0].world_from_kinect.rotation.inverse() * tilt).angle() < 1e-9);
        }
    }
}
