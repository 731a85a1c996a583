use nalgebra::{Isometry3, Matrix3, Point3, Vector3};
use rand::Rng;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};
use trigait_skeleton::{Joint, TrackingState};

use crate::occlusion::{self, Capsule};
use crate::{Intrinsics, NoiseModel};

/// Why a sensor does or does not report a joint.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Visibility {
    /// Outside the 70.6° × 60° field of view or behind the sensor.
    OutOfView,
    /// Nearer than the 0.5 m minimum depth.
    TooClose,
    /// Beyond the depth camera's maximum range.
    TooFar,
    /// Reported; flags say whether the other leg hides it and whether it lies beyond the 4.5 m
    /// working range.
    Seen {
        /// Hidden behind the other leg: the tracker infers it.
        occluded: bool,
        /// Beyond the tracker's working range: reported with inflated noise.
        beyond_working_range: bool,
    },
}

impl Visibility {
    /// The SDK tracking state this visibility produces.
    #[must_use]
    pub fn state(self) -> TrackingState {
        match self {
            Visibility::Seen { occluded: true, .. } => TrackingState::Inferred,
            Visibility::Seen { .. } => TrackingState::Tracked,
            _ => TrackingState::NotTracked,
        }
    }
}

/// What a sensor reports about one joint.
#[derive(Debug, Clone, PartialEq)]
pub struct Report {
    /// Why it is (not) reported.
    pub visibility: Visibility,
    /// The noisy position in camera space; `None` when not tracked.
    pub position_in_kinect: Option<Point3<f64>>,
}

impl Report {
    /// The SDK tracking state of this report.
    #[must_use]
    pub fn state(&self) -> TrackingState {
        self.visibility.state()
    }
}

/// One Kinect v2 placed in the world.
#[derive(Debug, Clone, PartialEq)]
pub struct Sensor {
    /// Id from the rig file.
    pub id: String,
    /// Pose: camera space → world.
    pub world_from_kinect: Isometry3<f64>,
    /// Depth camera geometry.
    pub intrinsics: Intrinsics,
    /// Skeleton-joint noise.
    pub noise: NoiseModel,
}

impl Sensor {
    /// A sensor with default intrinsics and noise.
    #[must_use]
    pub fn new(id: impl Into<String>, world_from_kinect: Isometry3<f64>) -> Self {
        Self {
            id: id.into(),
            world_from_kinect,
            intrinsics: Intrinsics::default(),
            noise: NoiseModel::default(),
        }
    }

    /// The optical centre in the world.
    #[must_use]
    pub fn position_in_world(&self) -> Point3<f64> {
        Point3::from(self.world_from_kinect.translation.vector)
    }

    /// Whether and how this sensor sees a joint at `joint_in_world`, with `occluders` the limbs
    /// that may hide it (see [`occlusion::other_leg`]).
    #[must_use]
    pub fn visibility(&self, joint_in_world: &Point3<f64>, occluders: &[Capsule]) -> Visibility {
        let p = self
            .world_from_kinect
            .inverse_transform_point(joint_in_world);
        if !self.intrinsics.in_view(&p) {
            return Visibility::OutOfView;
        }
        if p.z < self.noise.min_depth_m {
            return Visibility::TooClose;
        }
        if p.z > self.noise.max_depth_m {
            return Visibility::TooFar;
        }
        Visibility::Seen {
            occluded: occlusion::hidden(&self.position_in_world(), joint_in_world, occluders),
            beyond_working_range: self.noise.beyond_working_range(p.z),
        }
    }

    /// The noise covariance (camera space, m²) of `joint` reported at `point_in_kinect` with
    /// `state`, its limb along `limb_axis_in_kinect` (from the same frame's reported joints, see
    /// [`crate::limb_of`]; `None` if unknown): what a receiver uses to weigh the report.
    #[must_use]
    pub fn covariance_in_kinect(
        &self,
        joint: Joint,
        point_in_kinect: &Point3<f64>,
        state: TrackingState,
        limb_axis_in_kinect: Option<Vector3<f64>>,
    ) -> Matrix3<f64> {
        let incidence = crate::limb_incidence_rad(point_in_kinect, limb_axis_in_kinect);
        self.noise
            .covariance_in_kinect(&self.intrinsics, joint, point_in_kinect, state, incidence)
    }

    /// A noisy report of `joint` at `joint_in_world`, drawn from the noise model at the true
    /// position, with the joint's limb along `limb_axis_in_world` (for the incidence angle).
    pub fn observe(
        &self,
        joint: Joint,
        joint_in_world: &Point3<f64>,
        limb_axis_in_world: Option<Vector3<f64>>,
        occluders: &[Capsule],
        rng: &mut impl Rng,
    ) -> Report {
        let visibility = self.visibility(joint_in_world, occluders);
        let state = visibility.state();
        if state == TrackingState::NotTracked {
            return Report {
                visibility,
                position_in_kinect: None,
            };
        }
        let truth = self
            .world_from_kinect
            .inverse_transform_point(joint_in_world);
        let limb_axis =
            limb_axis_in_world.map(|a| self.world_from_kinect.inverse_transform_vector(&a));
        let covariance = self.covariance_in_kinect(joint, &truth, state, limb_axis);
        let white = Vector3::new(
            rng.sample(StandardNormal),
            rng.sample(StandardNormal),
            rng.sample(StandardNormal),
        );
        let noise = covariance
            .cholesky()
            .map_or_else(Vector3::zeros, |c| c.l() * white);
        Report {
            visibility,
            position_in_kinect: Some(truth + noise),
        }
    }
}

#[cfg(test)]
mod tests {
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    use super::*;

    fn sensor_at(eye: Point3<f64>, look_at: Point3<f64>) -> Sensor {
        Sensor::new("k", Isometry3::face_towards(&eye, &look_at, &Vector3::z()))
    }

    /// Depth limits and field of view decide whether a joint is reported.
    #[test]
    fn visibility_by_range_and_view() {
        let s = sensor_at(Point3::new(0.0, 0.0, 1.0), Point3::new(5.0, 0.0, 1.0));
        let seen = |x: f64, y: f64| s.visibility(&Point3::new(x, y, 1.0), &[]);
        assert_eq!(seen(0.3, 0.0), Visibility::TooClose);
        assert_eq!(
            seen(3.0, 0.0),
            Visibility::Seen {
                occluded: false,
                beyond_working_range: false
            }
        );
        assert_eq!(
            seen(6.0, 0.0),
            Visibility::Seen {
                occluded: false,
                beyond_working_range: true
            }
        );
        assert_eq!(seen(9.0, 0.0), Visibility::TooFar);
        assert_eq!(seen(2.0, 2.0), Visibility::OutOfView);
        assert_eq!(seen(-2.0, 0.0), Visibility::OutOfView);
        assert_eq!(seen(6.0, 0.0).state(), TrackingState::Tracked);
    }

    /// Reports are unbiased and scatter with the modelled covariance along and across the ray.
    #[test]
    fn observations_follow_the_model() {
        let s = sensor_at(Point3::new(0.0, 0.0, 1.5), Point3::new(3.0, 0.0, 0.5));
        let joint = Point3::new(3.0, 0.2, 0.5);
        let truth = s.world_from_kinect.inverse_transform_point(&joint);
        let cov = s.covariance_in_kinect(Joint::KneeLeft, &truth, TrackingState::Tracked, None);
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let n = 20_000;
        let mut mean = Vector3::zeros();
        let mut second = Matrix3::zeros();
        for _ in 0..n {
            let r = s.observe(Joint::KneeLeft, &joint, None, &[], &mut rng);
            let e = r.position_in_kinect.unwrap() - truth;
            mean += e / n as f64;
            second += e * e.transpose() / n as f64;
        }
        assert!(
            mean.norm() < 4.0 * (cov.trace() / n as f64).sqrt(),
            "bias {mean:?}"
        );
        let u = truth.coords.normalize();
        let along = (u.transpose() * second * u)[(0, 0)] / (u.transpose() * cov * u)[(0, 0)];
        assert!(
            (along - 1.0).abs() < 0.05,
            "variance ratio along the ray {along}"
        );
        assert!((second.trace() / cov.trace() - 1.0).abs() < 0.05);
    }

    /// The same seed gives the same reports.
    #[test]
    fn deterministic_with_seed() {
        let s = sensor_at(Point3::new(0.0, 0.0, 1.5), Point3::new(3.0, 0.0, 0.5));
        let joint = Point3::new(3.0, 0.2, 0.5);
        let draw = |seed| {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            s.observe(Joint::AnkleLeft, &joint, None, &[], &mut rng)
                .position_in_kinect
        };
        assert_eq!(draw(5), draw(5));
        assert_ne!(draw(5), draw(6));
    }
}
