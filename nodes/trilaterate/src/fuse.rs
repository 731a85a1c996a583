//! One aligned set → one fused pose: per joint, one observation per sensor that saw it
//! ([`trigait_sim::observation`]: weighted by the Kinect noise model at the reported position,
//! the same code `trigait eval` runs), then the configured estimator.
//!
//! Under `interpolate` a sensor's joint is resampled to the set's instant, and `sync` estimates
//! the error that adds (`interpolation_error_m`: the local second difference × (t − t₀)(t₁ − t)/2).
//! The noise model knows nothing of it, so by default that estimate is added to the
//! observation's covariance as an isotropic σ: a sensor whose frames straddle a heel strike,
//! where the ankle's velocity turns within a frame, then weighs less than one whose frame lies
//! close to the instant.

use std::collections::{BTreeMap, BTreeSet};

use nalgebra::Matrix3;
use trigait_kinect::Sensor;
use trigait_schema::{FusedJoint, FusedPose};
use trigait_sim::observation;
use trigait_skeleton::Joint;
use trigait_sync::AlignedSet;
use trigait_trilateration::{Error as EstimateError, Observation, Params, estimate};

/// The rig's sensors by id.
#[derive(Debug, Clone)]
pub struct Fuser {
    sensors: BTreeMap<String, Sensor>,
    params: Params,
    estimator: String,
    /// Every joint any set has carried so far: one missing from a set is reported as skipped.
    seen: BTreeSet<Joint>,
    /// Whether `sync`'s resampling-error estimate widens the covariance (module docs).
    weigh_resampling: bool,
}

impl Fuser {
    /// A fuser for `rig` with `params`, reporting `estimator` as its name.
    #[must_use]
    pub fn new(rig: &trigait_rig::Rig, params: Params, estimator: String) -> Self {
        let sensors = rig
            .sensors
            .iter()
            .map(|s| (s.id.clone(), Sensor::new(s.id.clone(), s.world_from_kinect)))
            .collect();
        Self {
            sensors,
            params,
            estimator,
            seen: BTreeSet::new(),
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

    /// Fuses every joint of `set`; a sensor the rig does not know is left out and named in
    /// the returned list.
    #[must_use]
    pub fn fuse(&mut self, set: &AlignedSet) -> (FusedPose, Vec<String>) {
        let unknown: Vec<String> = set
            .sensors
            .keys()
            .filter(|id| !self.sensors.contains_key(*id))
            .cloned()
            .collect();
        let joints: BTreeSet<Joint> = set
            .sensors
            .values()
            .flat_map(|v| v.joints.iter().map(|s| s.joint))
            .collect();
        self.seen.extend(joints.iter().copied());
        let mut pose = FusedPose {
            set_seq: set.seq,
            stamp_nanos: set.stamp_nanos,
            joints: BTreeMap::new(),
            skipped: BTreeMap::new(),
        };
        for joint in joints {
            let mut ids = Vec::new();
            let mut observations = Vec::new();
            for (id, view) in &set.sensors {
                let (Some(sensor), Some((index, sample))) = (
                    self.sensors.get(id),
                    view.joints
                        .iter()
                        .enumerate()
                        .find(|(_, s)| s.joint == joint),
                ) else {
                    continue;
                };
                // The position and the limb axis (for the depth noise's incidence term) come
                // from the same sensor's reported joints.
                let Some(o) = observation(sensor, joint, sample.state, |j| {
                    view.joints
                        .iter()
                        .find(|s| s.joint == j)
                        .map(|s| s.position_in_kinect)
                }) else {
                    continue;
                };
                let resampling_m = view
                    .interpolation_error_m
                    .get(index)
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
                observations.push(o);
                ids.push(id.clone());
            }
            match estimate(&observations, &self.params) {
                Ok(e) => {
                    let used = if e.diagnostics.used.is_empty() {
                        ids.clone()
                    } else {
                        e.diagnostics
                            .used
                            .iter()
                            .filter_map(|i| ids.get(*i).cloned())
                            .collect()
                    };
                    pose.joints.insert(
                        joint,
                        FusedJoint {
                            position: e.position,
                            covariance: e.covariance,
                            sensors_used: used,
                            residual_m: e.diagnostics.residual_rms_m,
                            condition_number: e.diagnostics.condition_number,
                            estimator: self.estimator.clone(),
                        },
                    );
                }
                Err(err) => {
                    let reason = match &err {
                        EstimateError::TooFewSensors { got, need, .. } => format!(
                            "too few sensors: {got} saw it ({}), {} needs {need}",
                            ids.join(", "),
                            self.estimator
                        ),
                        other => other.to_string(),
                    };
                    pose.skipped.insert(joint, reason);
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
        (pose, unknown)
    }
}
