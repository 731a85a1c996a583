use nalgebra::{Isometry3, Matrix3, Point3, Vector3};

use crate::{Error, Result};

/// One sensor's report of one joint, with everything an estimator needs to weigh it.
#[derive(Debug, Clone, PartialEq)]
pub struct Observation {
    /// The sensor's pose: maps camera-space points into the world.
    pub world_from_kinect: Isometry3<f64>,
    /// The joint as the sensor reported it, in its camera space (metres).
    pub position_in_kinect: Point3<f64>,
    /// Noise covariance of `position_in_kinect` in camera space (m²), from the sensor model.
    pub covariance_in_kinect: Matrix3<f64>,
}

impl Observation {
    /// Builds an observation.
    #[must_use]
    pub fn new(
        world_from_kinect: Isometry3<f64>,
        position_in_kinect: Point3<f64>,
        covariance_in_kinect: Matrix3<f64>,
    ) -> Self {
        Self {
            world_from_kinect,
            position_in_kinect,
            covariance_in_kinect,
        }
    }

    /// The sensor's optical centre in the world: the centre of its range sphere.
    #[must_use]
    pub fn sensor_in_world(&self) -> Point3<f64> {
        Point3::from(self.world_from_kinect.translation.vector)
    }

    /// The reported joint in the world.
    #[must_use]
    pub fn position_in_world(&self) -> Point3<f64> {
        self.world_from_kinect * self.position_in_kinect
    }

    /// The noise covariance rotated into the world frame.
    #[must_use]
    pub fn covariance_in_world(&self) -> Matrix3<f64> {
        let r = self.world_from_kinect.rotation.to_rotation_matrix();
        r.matrix() * self.covariance_in_kinect * r.matrix().transpose()
    }

    /// Distance from the optical centre to the joint: the sphere radius of trilateration.
    #[must_use]
    pub fn range_m(&self) -> f64 {
        self.position_in_kinect.coords.norm()
    }

    /// Standard deviation of [`Observation::range_m`]: the covariance projected on the ray.
    #[must_use]
    pub fn range_sigma_m(&self) -> f64 {
        let u = self.position_in_kinect.coords / self.range_m();
        (u.transpose() * self.covariance_in_kinect * u)[(0, 0)]
            .max(0.0)
            .sqrt()
    }

    /// The sensor's optical axis (+z of camera space) in the world.
    #[must_use]
    pub fn axis_in_world(&self) -> Vector3<f64> {
        self.world_from_kinect.rotation * Vector3::z()
    }

    /// Checks what every estimator relies on: finite numbers, a positive definite covariance and
    /// a joint that is not at the optical centre.
    ///
    /// # Errors
    /// [`Error::NonFinite`], [`Error::BadCovariance`] or [`Error::SensorAtTarget`], naming `index`.
    pub fn validate(&self, index: usize) -> Result<()> {
        let iso = self.world_from_kinect.to_homogeneous();
        let finite = iso.iter().all(|v| v.is_finite())
            && self.position_in_kinect.coords.iter().all(|v| v.is_finite())
            && self.covariance_in_kinect.iter().all(|v| v.is_finite());
        if !finite {
            return Err(Error::NonFinite { index });
        }
        let c = &self.covariance_in_kinect;
        let symmetric = (c - c.transpose()).amax() <= 1e-12 * c.amax().max(f64::MIN_POSITIVE);
        if !symmetric || c.cholesky().is_none() {
            return Err(Error::BadCovariance { index });
        }
        let range_m = self.range_m();
        if range_m < 1e-6 {
            return Err(Error::SensorAtTarget { index, range_m });
        }
        Ok(())
    }
}

/// Validates every observation of a slice.
pub(crate) fn validate_all(observations: &[Observation]) -> Result<()> {
    observations
        .iter()
        .enumerate()
        .try_for_each(|(i, o)| o.validate(i))
}
