//! Rig calibration against a simulated world: a walk played through simulated Kinect v2
//! sensors on a true rig (the same simulator as `trigait eval`), calibrated by
//! `trigait-calibration` from what the sensors report, and scored against the truth.
//!
//! The calibration sees only the reports, each in its sensor's camera space, and starts from a
//! rough rig — the true one with every sensor moved and turned — or from the data alone. It fixes
//! the world frame from the walk ([`trigait_calibration::gauge`]), so the truth is compared after
//! fixing its frame the same way from the true joint positions at the same instants: what is
//! scored is what the data determine, not where a lab happened to put its origin. The fusion
//! RMSE of a fresh draw of the same walk is compared between the true and the calibrated rig.

#![warn(missing_docs)]

use std::time::Instant;

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;
use trigait_calibration::{Calibration, Initial, Params, SensorTrack, TrackFrame, Tracks};
use trigait_fusion::FusionRig;
use trigait_kinect::NoiseModel;
use trigait_rig::{Rig, SensorPose};
use trigait_sim::Simulator;
use trigait_skeleton::{Joint, MotionClip};
use trigait_trilateration::{Method, Params as FusionParams, estimate};

/// Why a scenario could not be run.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The rig could not be loaded.
    #[error(transparent)]
    Rig(#[from] trigait_rig::Error),
    /// The motion could not be loaded or laid out.
    #[error(transparent)]
    Motion(#[from] trigait_motion::Error),
    /// The calibration failed.
    #[error("calibrating: {0}")]
    Calibration(#[from] trigait_calibration::Error),
    /// Anything else about the scenario, explained.
    #[error("{0}")]
    Scenario(String),
}

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, Error>;

/// One simulated calibration run.
#[derive(Debug, Clone)]
pub struct Scenario {
    /// Motion spec (`walker` or a file).
    pub motion: String,
    /// True rig spec.
    pub rig: String,
    /// (metres, degrees) of the rough rig's perturbation.
    pub perturb: (f64, f64),
    /// Start from the data instead of the rough rig.
    pub from_data: bool,
    /// `None`: a single straight pass; `Some(lane)`: out and back, lanes `lane` m apart.
    pub lane_m: Option<f64>,
    /// Out-and-back laps.
    pub laps: usize,
    /// Gap per turn, seconds.
    pub turn_secs: f64,
    /// Sensor with left/right swapped.
    pub swap: Option<String>,
    /// Seed.
    pub seed: u64,
}

impl Scenario {
    /// The acceptance walk: three out-and-back laps on lanes 1 m apart (1 s turns), from a
    /// rough rig with every sensor moved 30 cm and turned 20°, no sensor swapped.
    pub fn acceptance(motion: &str, rig: &str, seed: u64) -> Self {
        Self {
            motion: motion.to_owned(),
            rig: rig.to_owned(),
            perturb: (0.3, 20.0),
            from_data: false,
            lane_m: Some(1.0),
            laps: 3,
            turn_secs: 1.0,
            swap: None,
            seed,
        }
    }
}

/// How the calibrated rig compares with the truth.
#[derive(Debug, Clone, Serialize)]
pub struct SensorScore {
    /// Sensor id.
    pub id: String,
    /// Distance of the calibrated from the true optical centre, metres.
    pub position_error_m: f64,
    /// Angle between calibrated and true orientation, radians.
    pub rotation_error_rad: f64,
    /// Same for the rough rig the calibration started from.
    pub rough_position_error_m: f64,
    /// Same for the rough rig.
    pub rough_rotation_error_rad: f64,
    /// Distance of the calibrated from the true optical centre after the one rigid motion
    /// that best maps the true centres onto the calibrated ones, metres: the error of the
    /// rig's own geometry, whatever the world frame (the part of
    /// [`SensorScore::position_error_m`] the floor and the walking direction do not explain).
    pub shape_error_m: f64,
}

/// The calibration's world frame against the truth's, both fixed from the walk the same way:
/// the one rigid motion that best maps the true poses (in the truth's frame) onto the
/// calibrated ones. With the rig's own geometry right, this is what is left of the error.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct FrameError {
    /// Rotation about world x (the floor's tilt across the walk), y (its tilt along the walk)
    /// and z (the walking direction), radians.
    pub rotation_rad: [f64; 3],
    /// Where the truth's origin lies in the calibration's world frame, metres.
    pub origin_m: [f64; 3],
}

/// A scenario's outcome.
#[derive(Debug, Clone, Serialize)]
pub struct Outcome {
    /// Motion name.
    pub motion: String,
    /// True rig name.
    pub rig: String,
    /// Duration of the walk, seconds.
    pub duration_secs: f64,
    /// The calibration.
    pub calibration: Calibration,
    /// Per-sensor comparison with the truth (in the world frame the walk defines).
    pub scores: Vec<SensorScore>,
    /// How far the walk's world frame lies from the motion's own (lab) frame: translation,
    /// metres, and rotation, radians. Not an error: the lab's origin is not in the data.
    pub frame_offset_m: f64,
    /// See [`Outcome::frame_offset_m`].
    pub frame_rotation_rad: f64,
    /// The part of the error that is the world frame's.
    pub frame_error: FrameError,
    /// Angle between the floor the walk defines (fixed from the true joints) and the motion's
    /// own floor, radians: how level the walk's frame is in the lab.
    pub floor_tilt_rad: f64,
    /// Fusion RMSE on a fresh draw of the same walk with the true rig, metres.
    pub fusion_rmse_true_m: f64,
    /// The same with the calibrated rig.
    pub fusion_rmse_calibrated_m: f64,
    /// Joint samples in the RMSE.
    pub fusion_samples: usize,
    /// Wall time of the calibration, seconds (one core).
    pub calibrate_secs: f64,
    /// Wall time of fusing every joint of the calibration's own frames once with the true
    /// rig: the same-run baseline [`Outcome::calibrate_secs`] is compared with.
    pub fusion_pass_secs: f64,
    /// What the sensors reported, the calibration's input.
    #[serde(skip)]
    pub tracks: Vec<SensorTrack>,
    /// The rough rig the calibration started from (also when it started from the data).
    #[serde(skip)]
    pub rough: Rig,
}

/// The sensors' tracks of `sim`'s walk under `seed`: each sensor at its own phase and 30 Hz,
/// what it reports in camera space, stamped with the (synchronised) capture time.
#[must_use]
pub fn sensor_tracks(sim: &Simulator, seed: u64, swap: Option<&str>) -> Vec<SensorTrack> {
    sim.sensors()
        .iter()
        .enumerate()
        .map(|(s, sensor)| {
            let mut rng = Simulator::sensor_rng(seed, s);
            let frames = sim
                .capture_times(seed, s)
                .map(|(seq, t)| {
                    let f = sim.frame(s, seq, t, 0, &mut rng);
                    let frame = TrackFrame {
                        t_secs: t,
                        joints: f.joints,
                    };
                    if swap == Some(sensor.id.as_str()) {
                        frame.mirrored()
                    } else {
                        frame
                    }
                })
                .filter(|f| !f.joints.is_empty())
                .collect();
            SensorTrack {
                id: sensor.id.clone(),
                frames,
            }
        })
        .collect()
}

/// `rig` with every sensor moved `metres` in a random direction and turned `degrees` left or
/// right about the vertical through it.
#[must_use]
pub fn perturbed(rig: &Rig, metres: f64, degrees: f64, seed: u64) -> Rig {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x0070_6572_7475_7262);
    Rig {
        name: format!("{} perturbed", rig.name),
        sensors: rig
            .sensors
            .iter()
            .map(|s| {
                let dir = loop {
                    let v = Vector3::new(
                        rng.random_range(-1.0..1.0),
                        rng.random_range(-1.0..1.0),
                        rng.random_range(-1.0..1.0),
                    );
                    if let Some(u) = v.try_normalize(1e-3).filter(|_| v.norm() <= 1.0) {
                        break u;
                    }
                };
                let sign = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
                let yaw = UnitQuaternion::from_axis_angle(
                    &Vector3::z_axis(),
                    sign * degrees.to_radians(),
                );
                let p = s.world_from_kinect.translation.vector + dir * metres;
                SensorPose {
                    id: s.id.clone(),
                    world_from_kinect: Isometry3::from_parts(
                        Translation3::from(p),
                        yaw * s.world_from_kinect.rotation,
                    ),
                }
            })
            .collect(),
    }
}

/// The walk of `scenario` on the walkway.
fn walk(scenario: &Scenario) -> Result<MotionClip> {
    let pass = if scenario.motion == "walker" {
        trigait_motion::walker(&trigait_motion::WalkerParams::default(), 2.5, 120.0)?
    } else {
        let path = std::path::Path::new(&scenario.motion);
        if !path.exists() {
            return Err(Error::Scenario(format!(
                "motion {:?} is neither `walker` nor an existing C3D/TRC file",
                scenario.motion
            )));
        }
        trigait_motion::load_motion(path)?
    }
    .placed_on_walkway();
    Ok(match scenario.lane_m {
        Some(lane) => trigait_motion::walkway_laps(&pass, lane, scenario.turn_secs, scenario.laps)?,
        None => pass,
    })
}

/// The true joint positions on the calibration's time grid, where the calibration had them.
fn truth_tracks(clip: &MotionClip, calibration: &Calibration) -> Tracks {
    let n = calibration.joints_in_world.positions.len();
    let joints = calibration.joints_in_world.joints.clone();
    let positions = (0..n)
        .map(|k| {
            let t = calibration.grid_start_secs + k as f64 * calibration.grid_period_secs;
            // Only where the calibration had the joint: both frames from the same instants.
            joints
                .iter()
                .enumerate()
                .map(|(c, j)| {
                    calibration.joints_in_world.positions[k][c].and(clip.position_at(*j, t))
                })
                .collect()
        })
        .collect();
    Tracks {
        dt_secs: calibration.grid_period_secs,
        joints,
        positions,
    }
}

/// Per point, the distance of `to[i]` from `from[i]` after the rigid motion (Kabsch, no
/// scale) that best maps `from` onto `to` in the least-squares sense.
#[must_use]
pub fn rigid_residuals(from: &[Vector3<f64>], to: &[Vector3<f64>]) -> Vec<f64> {
    let n = from.len().min(to.len());
    if n == 0 {
        return Vec::new();
    }
    let mean = |v: &[Vector3<f64>]| v[..n].iter().sum::<Vector3<f64>>() / n as f64;
    let (fm, tm) = (mean(from), mean(to));
    let mut h = nalgebra::Matrix3::zeros();
    for (a, b) in from.iter().zip(to) {
        h += (a - fm) * (b - tm).transpose();
    }
    // Bounded: an unbounded SVD never converges on a NaN.
    let Some(svd) = h.try_svd(true, true, f64::EPSILON, 10_000) else {
        return vec![f64::INFINITY; n];
    };
    let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else {
        return vec![f64::INFINITY; n];
    };
    let mut d = nalgebra::Matrix3::identity();
    if (v_t.transpose() * u.transpose()).determinant() < 0.0 {
        d[(2, 2)] = -1.0;
    }
    let r = v_t.transpose() * d * u.transpose();
    from.iter()
        .zip(to)
        .map(|(a, b)| (r * (a - fm) + tm - b).norm())
        .collect()
}

/// The rigid motion from truth to estimate over `pairs` of (true, estimated) poses: the mean
/// rotation (of nearly equal ones) and the translation that best fits the centres under it.
fn frame_error(pairs: &[(Isometry3<f64>, Isometry3<f64>)]) -> FrameError {
    if pairs.is_empty() {
        return FrameError::default();
    }
    let n = pairs.len() as f64;
    let first = pairs[0].1.rotation * pairs[0].0.rotation.inverse();
    let mean_delta = pairs
        .iter()
        .map(|(t, c)| (first.inverse() * c.rotation * t.rotation.inverse()).scaled_axis())
        .sum::<Vector3<f64>>()
        / n;
    let r = first * UnitQuaternion::from_scaled_axis(mean_delta);
    let d = pairs
        .iter()
        .map(|(t, c)| c.translation.vector - r * t.translation.vector)
        .sum::<Vector3<f64>>()
        / n;
    let rv = r.scaled_axis();
    FrameError {
        rotation_rad: [rv.x, rv.y, rv.z],
        origin_m: [d.x, d.y, d.z],
    }
}

/// Angle between the orientations of two poses, radians.
#[must_use]
pub fn rotation_angle(a: &Isometry3<f64>, b: &Isometry3<f64>) -> f64 {
    (a.rotation.inverse() * b.rotation).angle()
}

/// Plays `scenario`, calibrates, and scores the result.
///
/// # Errors
/// Bad motion or rig, or a calibration error.
pub fn simulate(scenario: &Scenario) -> Result<Outcome> {
    let truth = Rig::from_spec(&scenario.rig)?;
    if let Some(id) = &scenario.swap
        && !truth.sensors.iter().any(|s| &s.id == id)
    {
        return Err(Error::Scenario(format!(
            "--swap {id:?}: rig {:?} has no such sensor",
            truth.name
        )));
    }
    let clip = walk(scenario)?;
    let sim = Simulator::new(&truth, clip, &Joint::LEGS, &NoiseModel::default());
    let tracks = sensor_tracks(&sim, scenario.seed, scenario.swap.as_deref());
    let rough = perturbed(
        &truth,
        scenario.perturb.0,
        scenario.perturb.1,
        scenario.seed,
    );
    let initial = if scenario.from_data {
        Initial::FromData
    } else {
        Initial::Rig(&rough)
    };
    let params = Params::default();
    let start = Instant::now();
    let calibration = trigait_calibration::calibrate(&tracks, initial, &params)?;
    let calibrate_secs = start.elapsed().as_secs_f64();

    // The truth in the frame the walk defines, fixed the same way from the true joints.
    let true_gauge =
        trigait_calibration::gauge::gauge(&truth_tracks(sim.motion(), &calibration), None)?;
    let g = true_gauge.world_from_frame;
    let mut scores: Vec<SensorScore> = calibration
        .sensors
        .iter()
        .zip(&truth.sensors)
        .zip(&rough.sensors)
        .map(|((c, t), r)| {
            let t_w = g * t.world_from_kinect;
            let r_w = g * r.world_from_kinect;
            let (pe, re) = c
                .world_from_kinect
                .map_or((f64::INFINITY, f64::INFINITY), |c| {
                    (
                        (c.translation.vector - t_w.translation.vector).norm(),
                        rotation_angle(&c, &t_w),
                    )
                });
            SensorScore {
                id: c.id.clone(),
                position_error_m: pe,
                rotation_error_rad: re,
                rough_position_error_m: (r_w.translation.vector - t_w.translation.vector).norm(),
                rough_rotation_error_rad: rotation_angle(&r_w, &t_w),
                shape_error_m: f64::INFINITY,
            }
        })
        .collect();
    let placed: Vec<(Vector3<f64>, Vector3<f64>)> = calibration
        .sensors
        .iter()
        .zip(&truth.sensors)
        .filter_map(|(c, t)| {
            Some((
                t.world_from_kinect.translation.vector,
                c.world_from_kinect?.translation.vector,
            ))
        })
        .collect();
    if placed.len() == scores.len() {
        let (from, to): (Vec<_>, Vec<_>) = placed.into_iter().unzip();
        for (score, e) in scores.iter_mut().zip(rigid_residuals(&from, &to)) {
            score.shape_error_m = e;
        }
    }

    let frame_error = frame_error(
        &calibration
            .sensors
            .iter()
            .zip(&truth.sensors)
            .filter_map(|(c, t)| Some((g * t.world_from_kinect, c.world_from_kinect?)))
            .collect::<Vec<_>>(),
    );

    // Fusion on a fresh draw: true rig vs calibrated rig (mapped back into the lab frame).
    let lab_from_world = g.inverse();
    let calibrated: Vec<Option<Isometry3<f64>>> = calibration
        .sensors
        .iter()
        .map(|s| s.world_from_kinect.map(|p| lab_from_world * p))
        .collect();
    let fusion_seed = scenario.seed.wrapping_add(1_000_003);
    let mut rngs: Vec<ChaCha8Rng> = (0..truth.sensors.len())
        .map(|i| Simulator::sensor_rng(fusion_seed, i))
        .collect();
    let fusion = FusionParams::new(Method::Fusion);
    let fusion_rig = FusionRig::from_sensors(sim.sensors().to_vec());
    let (mut sq_true, mut sq_cal, mut samples) = (0.0, 0.0, 0usize);
    let duration_secs = sim.motion().duration_secs();
    let frames = (duration_secs * 30.0).floor() as usize;
    for f in 0..=frames {
        let snap = sim.snapshot(f as f64 / 30.0, &mut rngs);
        let observed = trigait_eval::observe_snapshot(&fusion_rig, &sim, &snap);
        for joint in sim.joints() {
            let Some(truth_p) = snap.truth.get(joint) else {
                continue;
            };
            let Some(seen) = observed.joints.get(joint) else {
                continue;
            };
            let (idx, obs) = (&seen.sensors, &seen.observations);
            let cal: Vec<_> = idx
                .iter()
                .zip(obs)
                .filter_map(|(i, o)| {
                    let mut o = o.clone();
                    o.world_from_kinect = calibrated[*i]?;
                    Some(o)
                })
                .collect();
            let (Ok(a), Ok(b)) = (estimate(obs, &fusion), estimate(&cal, &fusion)) else {
                continue;
            };
            sq_true += (a.position - truth_p).norm_squared();
            sq_cal += (b.position - truth_p).norm_squared();
            samples += 1;
        }
    }
    if samples == 0 {
        return Err(Error::Scenario(
            "no joint sample could be fused to score the rig".into(),
        ));
    }
    // Same-run baseline: one fusion pass over the calibration's own frames with the true rig.
    let start = Instant::now();
    let mut fused = 0usize;
    for (s, track) in tracks.iter().enumerate() {
        let sensor = &sim.sensors()[s];
        for frame in &track.frames {
            for j in &frame.joints {
                if let Some(o) = trigait_fusion::observation(sensor, j.joint, j.state, |q| {
                    frame
                        .joints
                        .iter()
                        .find(|x| x.joint == q)
                        .map(|x| x.position_in_kinect)
                }) {
                    fused += usize::from(estimate(std::slice::from_ref(&o), &fusion).is_ok());
                }
            }
        }
    }
    let fusion_pass_secs = start.elapsed().as_secs_f64();
    if fused == 0 {
        return Err(Error::Scenario(
            "the baseline fusion pass fused nothing".into(),
        ));
    }
    Ok(Outcome {
        motion: sim.motion().name().to_owned(),
        rig: truth.name.clone(),
        duration_secs,
        calibration,
        scores,
        frame_offset_m: g.translation.vector.norm(),
        frame_rotation_rad: g.rotation.angle(),
        frame_error,
        floor_tilt_rad: (g.rotation.inverse() * Vector3::z()).angle(&Vector3::z()),
        fusion_rmse_true_m: (sq_true / samples as f64).sqrt(),
        fusion_rmse_calibrated_m: (sq_cal / samples as f64).sqrt(),
        fusion_samples: samples,
        calibrate_secs,
        fusion_pass_secs,
        tracks,
        rough,
    })
}
