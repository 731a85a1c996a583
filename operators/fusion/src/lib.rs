//! One instant, fused: every sensor's joint samples of that instant (camera frame) become one
//! [`Observation`] per sensor and joint, weighed by the Kinect v2 noise model at the *reported*
//! position (what a receiver knows: range σ along the ray, lateral σ across it, the limb's
//! incidence from the neighbouring joints the same sensor reported; thesis §3.3 and §5.2), widened by
//! the resampling error `sync` estimated for it, then the configured estimator (thesis §4.2)
//! gives the joint in the world frame.
//!
//! This is the one place that happens. The dataflow's `trilaterate` node, `trigait eval` and
//! `trigait gait --kinect-sim` all go through [`FusionRig::observe`] and
//! [`Observed::estimate`] — [`fuse_instant`] is exactly those two calls, and
//! [`PoseFuser`] (the node's state) adds only the bookkeeping of a stream of poses — so a
//! number from `trigait eval` and a pose from the graph come from the same code.
//!
//! Resampling error: under the `interpolate` policy a sensor's joint is resampled to the
//! set's instant, and `sync` estimates the error that adds (the local second difference ×
//! (t − t₀)(t₁ − t)/2). The noise model knows nothing of it, so by default that estimate is
//! added to the observation's covariance as an isotropic σ: a sensor whose frames straddle a
//! heel strike, where the ankle's velocity turns within a frame, then weighs less than one
//! whose frame lies close to the instant.

#![warn(missing_docs)]

mod trajectory;

pub use trajectory::{FrameGrid, Trajectory, TrajectoryError};

use std::collections::{BTreeMap, BTreeSet};

use nalgebra::{Matrix3, Point3};
use trigait_kinect::{NoiseModel, Sensor};
use trigait_rig::Rig;
use trigait_schema::{FusedJoint, FusedPose};
use trigait_skeleton::{Joint, JointSample, TrackingState};
use trigait_trilateration::{Error as EstimateError, Estimate, Observation, Params, estimate};

/// What one sensor reported at the instant being fused.
#[derive(Debug, Clone, Copy)]
pub struct SensorSamples<'a> {
    /// The sensor's id in the rig.
    pub sensor_id: &'a str,
    /// Its joints at the instant, in its camera frame (metres).
    pub joints: &'a [JointSample],
    /// Estimated resampling error of each joint, metres, in the order of `joints` (`sync`'s
    /// `interpolation_error_m`); may be shorter or empty where nothing was resampled.
    pub resampling_error_m: &'a [Option<f64>],
}

/// The rig's sensors with their noise model: what turns a sample into an observation.
#[derive(Debug, Clone)]
pub struct FusionRig {
    sensors: Vec<Sensor>,
    weigh_resampling: bool,
}

impl FusionRig {
    /// The sensors of `rig`, each with `noise`, weighing the resampling error (module docs).
    #[must_use]
    pub fn new(rig: &Rig, noise: &NoiseModel) -> Self {
        Self::from_sensors(
            rig.sensors
                .iter()
                .map(|s| {
                    let mut sensor = Sensor::new(s.id.clone(), s.world_from_kinect);
                    sensor.noise = noise.clone();
                    sensor
                })
                .collect(),
        )
    }

    /// Modelled sensors as they are (e.g. a simulator's), in rig order.
    #[must_use]
    pub fn from_sensors(sensors: Vec<Sensor>) -> Self {
        Self {
            sensors,
            weigh_resampling: true,
        }
    }

    /// Whether `sync`'s resampling-error estimate widens each observation's covariance
    /// (default: yes; module docs).
    #[must_use]
    pub fn with_resampling_weights(mut self, weigh: bool) -> Self {
        self.weigh_resampling = weigh;
        self
    }

    /// The sensors, in rig order: [`JointObservations::sensors`] indexes this.
    #[must_use]
    pub fn sensors(&self) -> &[Sensor] {
        &self.sensors
    }

    /// The estimator inputs of one instant: per joint any sensor reported, one observation per
    /// sensor that reported it, sensors in rig order. Samples of a sensor the rig does not know
    /// are left out and its id is listed in [`Observed::unknown_sensors`]. A sample marked
    /// `NotTracked` is no measurement (the Kinect SDK and the leg tracker put such a joint
    /// wherever their model left it): it is left out too, also as a neighbour giving a limb's
    /// axis, and a joint no sensor tracks is not among the joints.
    #[must_use]
    pub fn observe(&self, samples: &[SensorSamples<'_>]) -> Observed {
        let mut unknown_sensors: Vec<String> = samples
            .iter()
            .filter(|s| !self.sensors.iter().any(|r| r.id == s.sensor_id))
            .map(|s| s.sensor_id.to_owned())
            .collect();
        unknown_sensors.sort();
        unknown_sensors.dedup();
        let reported = measured_joints(samples);
        let mut joints = BTreeMap::new();
        for joint in reported {
            let mut seen = JointObservations::default();
            for (index, sensor) in self.sensors.iter().enumerate() {
                let Some(view) = samples.iter().find(|s| s.sensor_id == sensor.id) else {
                    continue;
                };
                let Some((k, sample)) = view
                    .joints
                    .iter()
                    .enumerate()
                    .find(|(_, s)| s.joint == joint && s.is_measured())
                else {
                    continue;
                };
                // The limb axis (the depth noise's incidence term) comes from the same
                // sensor's measured joints.
                let Some(o) = observation(sensor, joint, sample.state, |j| {
                    view.joints
                        .iter()
                        .find(|s| s.joint == j && s.is_measured())
                        .map(|s| s.position_in_kinect)
                }) else {
                    continue;
                };
                let resampling_m = view
                    .resampling_error_m
                    .get(k)
                    .copied()
                    .flatten()
                    .filter(|e| self.weigh_resampling && e.is_finite() && *e > 0.0);
                let o = match resampling_m {
                    Some(e) => Observation {
                        covariance_in_kinect: o.covariance_in_kinect
                            + Matrix3::identity() * (e * e),
                        ..o
                    },
                    None => o,
                };
                seen.sensors.push(index);
                seen.states.push(sample.state);
                seen.observations.push(o);
            }
            joints.insert(joint, seen);
        }
        Observed {
            joints,
            unknown_sensors,
        }
    }
}

/// One sensor's estimator input for `joint`: where the sensor has it (`position(joint)`, in
/// its camera frame) weighed by the sensor's noise model there, for its tracking `state` and
/// the limb axis from the neighbouring joints it has (`position` again). `None` when
/// `position(joint)` is.
#[must_use]
pub fn observation(
    sensor: &Sensor,
    joint: Joint,
    state: TrackingState,
    position: impl Fn(Joint) -> Option<Point3<f64>>,
) -> Option<Observation> {
    let p = position(joint)?;
    let limb = trigait_kinect::limb_axis(joint, &position);
    let covariance = sensor.covariance_in_kinect(joint, &p, state, limb);
    Some(Observation::new(sensor.world_from_kinect, p, covariance))
}

/// The joints some sensor measured (reported other than `NotTracked`).
fn measured_joints(samples: &[SensorSamples<'_>]) -> BTreeSet<Joint> {
    samples
        .iter()
        .flat_map(|s| s.joints.iter())
        .filter(|j| j.is_measured())
        .map(|j| j.joint)
        .collect()
}

/// The observations of one joint at one instant.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct JointObservations {
    /// Index into [`FusionRig::sensors`] of each observation's sensor, ascending.
    pub sensors: Vec<usize>,
    /// Each sensor's tracking state of the joint.
    pub states: Vec<TrackingState>,
    /// One per sensor that measured the joint (reported it other than `NotTracked`).
    pub observations: Vec<Observation>,
}

/// The estimator inputs of one instant ([`FusionRig::observe`]).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Observed {
    /// Per joint some sensor measured.
    pub joints: BTreeMap<Joint, JointObservations>,
    /// Ids of sensors the rig does not know (their samples were left out), sorted.
    pub unknown_sensors: Vec<String>,
}

impl Observed {
    /// Every joint through the estimator of `params`.
    #[must_use]
    pub fn estimate(&self, params: &Params) -> FusedInstant {
        FusedInstant {
            joints: self
                .joints
                .iter()
                .map(|(joint, seen)| {
                    let fused = JointFusion {
                        sensors: seen.sensors.clone(),
                        result: estimate(&seen.observations, params),
                    };
                    (*joint, fused)
                })
                .collect(),
        }
    }

    /// The same sensors' observations of `joint` placed at its *true* position (`truth`, world
    /// frame) with the model's covariance there — the geometry the Cramér–Rao bound is
    /// evaluated on. The limb axis comes from the true neighbours.
    #[must_use]
    pub fn at_truth(
        &self,
        rig: &FusionRig,
        joint: Joint,
        truth: &BTreeMap<Joint, Point3<f64>>,
    ) -> Vec<Observation> {
        let (Some(seen), true) = (self.joints.get(&joint), truth.contains_key(&joint)) else {
            return Vec::new();
        };
        seen.sensors
            .iter()
            .zip(&seen.states)
            .filter_map(|(index, state)| {
                let sensor = rig.sensors.get(*index)?;
                observation(sensor, joint, *state, |j| {
                    let p = truth.get(&j)?;
                    Some(sensor.world_from_kinect.inverse_transform_point(p))
                })
            })
            .collect()
    }
}

/// One joint through the estimator.
#[derive(Debug, Clone, PartialEq)]
pub struct JointFusion {
    /// Index into [`FusionRig::sensors`] of each observation given to the estimator.
    pub sensors: Vec<usize>,
    /// The estimate, or why there is none.
    pub result: Result<Estimate, EstimateError>,
}

impl JointFusion {
    /// Indices into [`FusionRig::sensors`] of the sensors the estimate used (all that were
    /// given when the estimator does not say).
    #[must_use]
    pub fn sensors_used(&self) -> Vec<usize> {
        match &self.result {
            Ok(e) if !e.diagnostics.used.is_empty() => e
                .diagnostics
                .used
                .iter()
                .filter_map(|i| self.sensors.get(*i).copied())
                .collect(),
            _ => self.sensors.clone(),
        }
    }
}

/// Every joint of one instant through the estimator ([`Observed::estimate`]).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FusedInstant {
    /// Per joint some sensor measured.
    pub joints: BTreeMap<Joint, JointFusion>,
}

/// Observes and estimates one instant: [`FusionRig::observe`] then [`Observed::estimate`].
#[must_use]
pub fn fuse_instant(
    rig: &FusionRig,
    samples: &[SensorSamples<'_>],
    params: &Params,
) -> (FusedInstant, Observed) {
    let observed = rig.observe(samples);
    (observed.estimate(params), observed)
}

/// A stream of instants fused into [`FusedPose`]s: [`fuse_instant`] plus the memory of which
/// joints earlier instants carried, so a joint that vanishes is reported as skipped rather
/// than silently missing.
#[derive(Debug, Clone)]
pub struct PoseFuser {
    rig: FusionRig,
    params: Params,
    estimator: String,
    seen: BTreeSet<Joint>,
}

impl PoseFuser {
    /// Fuses with `params` on `rig`, naming the estimator `estimator` in every joint.
    #[must_use]
    pub fn new(rig: FusionRig, params: Params, estimator: String) -> Self {
        Self {
            rig,
            params,
            estimator,
            seen: BTreeSet::new(),
        }
    }

    /// The fused pose of instant `set_seq` at `stamp_nanos` (server clock), whose set lacked
    /// `missing_sensors`, and the ids of sensors in `samples` the rig does not know (left out).
    pub fn fuse(
        &mut self,
        set_seq: u64,
        stamp_nanos: i64,
        samples: &[SensorSamples<'_>],
        missing_sensors: Vec<String>,
    ) -> (FusedPose, Vec<String>) {
        let (fused, observed) = fuse_instant(&self.rig, samples, &self.params);
        self.seen.extend(measured_joints(samples));
        let id = |i: &usize| self.rig.sensors.get(*i).map(|s| s.id.clone());
        let mut pose = FusedPose {
            set_seq,
            stamp_nanos,
            joints: BTreeMap::new(),
            skipped: BTreeMap::new(),
            missing_sensors,
        };
        for (joint, f) in &fused.joints {
            match &f.result {
                Ok(e) => {
                    pose.joints.insert(
                        *joint,
                        FusedJoint {
                            position: e.position,
                            covariance: e.covariance,
                            sensors_used: f.sensors_used().iter().filter_map(id).collect(),
                            residual_m: e.diagnostics.residual_rms_m,
                            condition_number: e.diagnostics.condition_number,
                            estimator: self.estimator.clone(),
                        },
                    );
                }
                Err(err) => {
                    let reason = match err {
                        EstimateError::TooFewSensors { got, need, .. } => {
                            let ids: Vec<String> = f.sensors.iter().filter_map(id).collect();
                            format!(
                                "too few sensors: {got} saw it ({}), {} needs {need}",
                                ids.join(", "),
                                self.estimator
                            )
                        }
                        other => other.to_string(),
                    };
                    pose.skipped.insert(*joint, reason);
                }
            }
        }
        for joint in &self.seen {
            if !pose.joints.contains_key(joint) && !pose.skipped.contains_key(joint) {
                pose.skipped.insert(
                    *joint,
                    "too few sensors: no sensor saw it in this set".into(),
                );
            }
        }
        (pose, observed.unknown_sensors)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use trigait_trilateration::Method;

    fn sample(joint: Joint, p: Point3<f64>) -> JointSample {
        JointSample {
            joint,
            position_in_kinect: p,
            state: TrackingState::Tracked,
        }
    }

    /// The thesis rig, its fusion with the default noise, and a knee in the world.
    fn thesis_and_knee() -> (Rig, FusionRig, Point3<f64>) {
        let rig = Rig::from_spec("thesis").unwrap();
        let fusion = FusionRig::new(&rig, &NoiseModel::default());
        (rig, fusion, Point3::new(0.3, 0.1, 0.5))
    }

    /// Each rig sensor's samples, in rig order.
    fn views<'a>(rig: &'a Rig, joints: &'a [Vec<JointSample>]) -> Vec<SensorSamples<'a>> {
        rig.sensors
            .iter()
            .zip(joints)
            .map(|(s, j)| SensorSamples {
                sensor_id: &s.id,
                joints: j,
                resampling_error_m: &[],
            })
            .collect()
    }

    /// Three sensors see a knee exactly: each observation carries its sensor's pose, the
    /// estimate lands on the truth, and a sensor the rig does not know is named and left out.
    #[test]
    fn observes_in_rig_order_and_names_unknown_sensors() {
        let (rig, fusion, knee) = thesis_and_knee();
        let joints: Vec<Vec<JointSample>> = rig
            .sensors
            .iter()
            .map(|s| {
                vec![sample(
                    Joint::KneeLeft,
                    s.world_from_kinect.inverse_transform_point(&knee),
                )]
            })
            .collect();
        let stray = vec![sample(Joint::KneeLeft, Point3::new(0.0, 0.0, 2.0))];
        // Reverse order in, rig order out.
        let mut samples = views(&rig, &joints);
        samples.reverse();
        samples.push(SensorSamples {
            sensor_id: "k9",
            joints: &stray,
            resampling_error_m: &[],
        });
        let (fused, observed) = fuse_instant(&fusion, &samples, &Params::new(Method::Fusion));
        assert_eq!(observed.unknown_sensors, ["k9"]);
        let seen = &observed.joints[&Joint::KneeLeft];
        assert_eq!(seen.sensors, [0, 1, 2]);
        for (i, o) in seen.sensors.iter().zip(&seen.observations) {
            assert_eq!(o.world_from_kinect, rig.sensors[*i].world_from_kinect);
        }
        let knee_fused = fused.joints[&Joint::KneeLeft].result.as_ref().unwrap();
        assert!((knee_fused.position - knee).norm() < 1e-6);
        let truth = BTreeMap::from([(Joint::KneeLeft, knee)]);
        let at_truth = observed.at_truth(&fusion, Joint::KneeLeft, &truth);
        assert_eq!(at_truth.len(), 3);
        assert!((at_truth[0].position_in_world() - knee).norm() < 1e-12);
    }

    /// A sample marked `NotTracked` is no measurement: a knee put 0.5 m off by one sensor's
    /// model leaves the fused knee where the two tracking sensors put it, and a joint no sensor
    /// tracks has no estimate.
    #[test]
    fn not_tracked_samples_are_left_out() {
        let (rig, fusion, knee) = thesis_and_knee();
        let joints: Vec<Vec<JointSample>> = rig
            .sensors
            .iter()
            .enumerate()
            .map(|(i, s)| {
                let k = s.world_from_kinect.inverse_transform_point(&knee);
                let mut knee_sample = sample(Joint::KneeLeft, k);
                let mut ankle =
                    sample(Joint::AnkleLeft, k + nalgebra::Vector3::new(0.0, -0.4, 0.0));
                ankle.state = TrackingState::NotTracked;
                if i == 2 {
                    knee_sample.position_in_kinect += nalgebra::Vector3::new(0.5, 0.0, 0.0);
                    knee_sample.state = TrackingState::NotTracked;
                }
                vec![knee_sample, ankle]
            })
            .collect();
        let samples = views(&rig, &joints);
        let (fused, observed) = fuse_instant(&fusion, &samples, &Params::new(Method::Fusion));
        assert_eq!(observed.joints[&Joint::KneeLeft].sensors, vec![0, 1]);
        let k = fused.joints[&Joint::KneeLeft].result.as_ref().unwrap();
        assert!((k.position - knee).norm() < 1e-9, "{:?}", k.position);
        assert!(!observed.joints.contains_key(&Joint::AnkleLeft));
        assert!(!fused.joints.contains_key(&Joint::AnkleLeft));
    }

    /// A resampling error widens that observation's covariance by e² per axis, and not when
    /// weighing it is switched off.
    #[test]
    fn resampling_error_adds_to_the_covariance() {
        let rig = Rig::from_spec("thesis").unwrap();
        let p = Point3::new(0.1, 0.0, 2.5);
        let joints = vec![sample(Joint::HipLeft, p)];
        let samples = [SensorSamples {
            sensor_id: "k1",
            joints: &joints,
            resampling_error_m: &[Some(0.05)],
        }];
        let cov = |weigh: bool| {
            FusionRig::new(&rig, &NoiseModel::default())
                .with_resampling_weights(weigh)
                .observe(&samples)
                .joints[&Joint::HipLeft]
                .observations[0]
                .covariance_in_kinect
        };
        let d = cov(true) - cov(false);
        assert!((d - Matrix3::identity() * 0.0025).norm() < 1e-15, "{d}");
    }
}
