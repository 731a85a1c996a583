use nalgebra::{Matrix3, Point3, Vector3};
use serde::{Deserialize, Serialize};
use trigait_skeleton::{Joint, TrackingState};

use crate::Intrinsics;

/// Noise of a Kinect v2 skeleton joint, split along and across the sensor's ray.
///
/// A joint's **range** (distance along the ray) comes from the time-of-flight depth of the
/// limb's surface plus the tracker's guess of how far the joint centre sits behind it; its
/// **lateral** position comes from where the tracker puts the joint in the image. So:
///
/// ```text
/// σ_range   = g · √(σ_tof(z, θ)² + σ_centre²)
/// σ_lateral = g · n_px · z / f
/// g         = joint_gain · (1 + off_axis_gain · c²) · state_gain
/// ```
///
/// with `z` the depth, `θ` the incidence angle of the ray on the limb's surface
/// ([`limb_incidence_rad`]), `f` the focal length, `c` the position in thesis §5.1.1's elliptical
/// accuracy cone (0 on the axis, 1 at the image edge) and `state_gain` the inflation of inferred
/// joints and of joints beyond the working range. Both components are Gaussian and independent
/// from frame to frame; systematic per-sensor offsets of the body tracker are not modelled (no
/// estimator could remove them without a reference, so they would only shift every method's
/// error equally).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NoiseModel {
    /// Nearest depth the body tracker works at: 0.5 m (Microsoft's specification, thesis
    /// Table 6.1 "recommended distance 0.5m-4.5m").
    pub min_depth_m: f64,
    /// Far end of the tracker's working range: 4.5 m (same source). Joints beyond it are still
    /// reported up to `max_depth_m`, flagged inferred and with `beyond_range_gain`.
    pub max_working_depth_m: f64,
    /// Farthest depth reported at all: 8 m, the depth camera's maximum range.
    pub max_depth_m: f64,
    /// Time-of-flight axial noise, mm: `a + b·z + c·z² + d·z^1.5·θ²/(π/2 − θ)²` (z in m, θ the
    /// incidence angle). Defaults a, b, c, d = 1.5, −0.5, 0.3, 0.1 are Fankhauser et al. 2015
    /// ("Kinect v2 for mobile robot navigation: evaluation and modeling", ICAR): ≈ 1.3 mm at
    /// 1 m and 2.7 mm at 3 m facing the sensor, +2 mm at 3 m for a surface at 60°.
    pub tof_axial_mm: [f64; 4],
    /// Standard deviation of the joint centre's depth behind the visible surface: 10 mm, about a
    /// fifth of a knee's radius — the frame-to-frame scatter of the body tracker's depth for a
    /// still subject reported by Wang et al. 2015 ("Evaluation of pose tracking accuracy in the
    /// first and second generations of Microsoft Kinect", ICHI), of the order of 1 cm for the
    /// lower limbs.
    pub joint_centre_sigma_m: f64,
    /// Image-plane scatter of a tracked joint: 2 pixels, the width of the depth discontinuity
    /// band the tracker's per-pixel classifier works on (thesis §5.1.4: 1–2 zero pixels along
    /// edges). At 3 m that is 17 mm across the ray.
    pub lateral_pixels: f64,
    /// Growth of both components towards the edge of the view: 1.0, i.e. doubled on the ellipse
    /// through the image edges (thesis §5.1.1, Fig. 5.2: accuracy degrades from the centre of
    /// the elliptical 70°×60° cone outwards).
    pub off_axis_gain: f64,
    /// Extra scatter of the distal joints, whose limbs are thin and fast: ankles ×1.5 and feet
    /// ×2 (Wang et al. 2015 report the largest errors at ankles and feet); hips and knees ×1.
    pub ankle_gain: f64,
    /// See [`NoiseModel::ankle_gain`].
    pub foot_gain: f64,
    /// Inflation of an inferred joint (occluded: position guessed by the body model): ×3.
    pub inferred_gain: f64,
    /// Inflation beyond `max_working_depth_m`: ×2.
    pub beyond_range_gain: f64,
}

impl Default for NoiseModel {
    fn default() -> Self {
        Self {
            min_depth_m: 0.5,
            max_working_depth_m: 4.5,
            max_depth_m: 8.0,
            tof_axial_mm: [1.5, -0.5, 0.3, 0.1],
            joint_centre_sigma_m: 0.010,
            lateral_pixels: 2.0,
            off_axis_gain: 1.0,
            ankle_gain: 1.5,
            foot_gain: 2.0,
            inferred_gain: 3.0,
            beyond_range_gain: 2.0,
        }
    }
}

impl NoiseModel {
    /// Time-of-flight axial standard deviation at depth `z_m` on a surface hit at
    /// `incidence_rad` (0 = facing the sensor; clamped at 80°, where the fit stops), metres.
    #[must_use]
    pub fn tof_sigma_m(&self, z_m: f64, incidence_rad: f64) -> f64 {
        let [a, b, c, d] = self.tof_axial_mm;
        let theta = incidence_rad.abs().min(MAX_INCIDENCE_RAD);
        let grazing = theta * theta / (std::f64::consts::FRAC_PI_2 - theta).powi(2);
        (a + b * z_m + c * z_m * z_m + d * z_m.max(0.0).powf(1.5) * grazing).max(0.1) * 1e-3
    }

    /// Gain of a joint class (distal joints scatter more).
    #[must_use]
    pub fn joint_gain(&self, joint: Joint) -> f64 {
        match joint {
            Joint::AnkleLeft | Joint::AnkleRight => self.ankle_gain,
            Joint::FootLeft | Joint::FootRight => self.foot_gain,
            _ => 1.0,
        }
    }

    /// Whether a depth is beyond the working range (but still reported).
    #[must_use]
    pub fn beyond_working_range(&self, z_m: f64) -> bool {
        z_m > self.max_working_depth_m
    }

    /// `(σ_range, σ_lateral)` in metres of `joint` at `point_in_kinect` reported with `state`,
    /// its limb's surface hit at `incidence_rad`.
    #[must_use]
    pub fn sigmas_m(
        &self,
        intrinsics: &Intrinsics,
        joint: Joint,
        point_in_kinect: &Point3<f64>,
        state: TrackingState,
        incidence_rad: f64,
    ) -> (f64, f64) {
        let z = point_in_kinect.z.max(1e-3);
        let cone = intrinsics.cone_radius(point_in_kinect).min(2.0);
        let mut gain = self.joint_gain(joint) * (1.0 + self.off_axis_gain * cone * cone);
        if state == TrackingState::Inferred {
            gain *= self.inferred_gain;
        }
        if self.beyond_working_range(z) {
            gain *= self.beyond_range_gain;
        }
        let range = self
            .tof_sigma_m(z, incidence_rad)
            .hypot(self.joint_centre_sigma_m);
        let lateral = self.lateral_pixels * intrinsics.pixel_size_m(z);
        (gain * range, gain * lateral)
    }

    /// Covariance in camera space (m²): `σ_range²` along the ray to the point, `σ_lateral²` in the
    /// two directions across it.
    #[must_use]
    pub fn covariance_in_kinect(
        &self,
        intrinsics: &Intrinsics,
        joint: Joint,
        point_in_kinect: &Point3<f64>,
        state: TrackingState,
        incidence_rad: f64,
    ) -> Matrix3<f64> {
        let (range, lateral) =
            self.sigmas_m(intrinsics, joint, point_in_kinect, state, incidence_rad);
        let u = point_in_kinect
            .coords
            .try_normalize(1e-9)
            .unwrap_or_else(nalgebra::Vector3::z);
        let along = u * u.transpose();
        along * (range * range) + (Matrix3::identity() - along) * (lateral * lateral)
    }
}

/// Incidence angles beyond this are clamped: the Fankhauser fit diverges at grazing incidence.
pub const MAX_INCIDENCE_RAD: f64 = 80.0 * std::f64::consts::PI / 180.0;

/// The limb whose surface the sensor's depth measures for `joint`, as (joint, neighbour):
/// the thigh for hips, the shank for knees and ankles, the foot for feet.
#[must_use]
pub fn limb_of(joint: Joint) -> Option<(Joint, Joint)> {
    Some(match joint {
        Joint::HipLeft => (Joint::HipLeft, Joint::KneeLeft),
        Joint::HipRight => (Joint::HipRight, Joint::KneeRight),
        Joint::KneeLeft => (Joint::KneeLeft, Joint::AnkleLeft),
        Joint::KneeRight => (Joint::KneeRight, Joint::AnkleRight),
        Joint::AnkleLeft => (Joint::AnkleLeft, Joint::KneeLeft),
        Joint::AnkleRight => (Joint::AnkleRight, Joint::KneeRight),
        Joint::FootLeft => (Joint::FootLeft, Joint::AnkleLeft),
        Joint::FootRight => (Joint::FootRight, Joint::AnkleRight),
        _ => return None,
    })
}

/// The axis of `joint`'s limb from whatever positions `position` knows (true ones in the
/// simulator, the same frame's reported ones at a receiver); `None` if either end is unknown.
#[must_use]
pub fn limb_axis(
    joint: Joint,
    position: impl Fn(Joint) -> Option<Point3<f64>>,
) -> Option<Vector3<f64>> {
    let (a, b) = limb_of(joint)?;
    Some(position(b)? - position(a)?)
}

/// Incidence angle of the ray to `point` on a cylindrical limb along `limb_axis` (both in one
/// frame, the ray from that frame's origin): the visible surface's normal is the ray's
/// direction with its component along the axis removed, so θ = asin(|ray · axis|). A limb seen
/// side-on gives 0; looking down the limb gives grazing incidence. 0 when the axis is unknown.
#[must_use]
pub fn limb_incidence_rad(point: &Point3<f64>, limb_axis: Option<Vector3<f64>>) -> f64 {
    let (Some(ray), Some(axis)) = (
        point.coords.try_normalize(1e-9),
        limb_axis.and_then(|a| a.try_normalize(1e-9)),
    ) else {
        return 0.0;
    };
    ray.dot(&axis).abs().min(1.0).asin()
}

#[cfg(test)]
mod tests {
    use approx::assert_relative_eq;

    use super::*;

    /// The published time-of-flight curve: ≈1.3 mm at 1 m, 2.7 mm at 3 m.
    #[test]
    fn tof_curve_matches_fankhauser() {
        let m = NoiseModel::default();
        assert_relative_eq!(m.tof_sigma_m(1.0, 0.0), 1.3e-3, epsilon = 1e-9);
        assert_relative_eq!(m.tof_sigma_m(3.0, 0.0), 2.7e-3, epsilon = 1e-9);
        // At 60° the incidence term adds 0.1·3^1.5·(π/3)²/(π/6)² = 2.08 mm at 3 m.
        let sixty = 60f64.to_radians();
        assert_relative_eq!(
            m.tof_sigma_m(3.0, sixty),
            2.7e-3 + 0.4 * 27f64.sqrt() * 1e-3,
            epsilon = 1e-9
        );
        assert!(m.tof_sigma_m(3.0, 1.55) == m.tof_sigma_m(3.0, MAX_INCIDENCE_RAD));
    }

    /// A limb seen side-on is hit square-on; looking along it, at grazing incidence.
    #[test]
    fn limb_incidence() {
        let p = Point3::new(0.0, 0.0, 3.0);
        assert_relative_eq!(limb_incidence_rad(&p, Some(Vector3::y())), 0.0);
        let tilted = Vector3::new(0.0, 1.0, 1.0);
        assert_relative_eq!(
            limb_incidence_rad(&p, Some(tilted)),
            std::f64::consts::FRAC_PI_4,
            epsilon = 1e-12
        );
        assert_relative_eq!(limb_incidence_rad(&p, None), 0.0);
        assert_eq!(
            limb_of(Joint::KneeLeft),
            Some((Joint::KneeLeft, Joint::AnkleLeft))
        );
        assert_eq!(limb_of(Joint::Head), None);
    }

    /// Noise grows with distance, towards the image edge, for ankles, and when inferred; the
    /// covariance has exactly the stated variances along and across the ray.
    #[test]
    fn sigmas_grow_as_documented() {
        let m = NoiseModel::default();
        let k = Intrinsics::default();
        let near = Point3::new(0.0, 0.0, 1.5);
        let far = Point3::new(0.0, 0.0, 3.5);
        let edge = Point3::new(0.6 * 3.5 * k.half_fov_x_rad().tan(), 0.0, 3.5);
        let s = |j, p: &Point3<f64>, st| m.sigmas_m(&k, j, p, st, 0.0);
        let tracked = TrackingState::Tracked;
        assert!(s(Joint::KneeLeft, &far, tracked).0 > s(Joint::KneeLeft, &near, tracked).0);
        assert!(s(Joint::KneeLeft, &far, tracked).1 > s(Joint::KneeLeft, &near, tracked).1);
        assert!(s(Joint::KneeLeft, &edge, tracked).1 > s(Joint::KneeLeft, &far, tracked).1);
        assert_relative_eq!(
            s(Joint::AnkleLeft, &far, tracked).1 / s(Joint::KneeLeft, &far, tracked).1,
            1.5
        );
        assert_relative_eq!(
            s(Joint::KneeLeft, &far, TrackingState::Inferred).0
                / s(Joint::KneeLeft, &far, tracked).0,
            3.0
        );
        let beyond = Point3::new(0.0, 0.0, 5.0);
        let inside = Point3::new(0.0, 0.0, 4.4);
        assert!(
            s(Joint::HipLeft, &beyond, tracked).1 > 1.9 * s(Joint::HipLeft, &inside, tracked).1
        );

        let p = Point3::new(0.4, -0.3, 2.5);
        let c = m.covariance_in_kinect(&k, Joint::HipRight, &p, tracked, 0.0);
        let (range, lateral) = s(Joint::HipRight, &p, tracked);
        let u = p.coords.normalize();
        let across = u.cross(&nalgebra::Vector3::y()).normalize();
        assert_relative_eq!(
            (u.transpose() * c * u)[(0, 0)],
            range * range,
            epsilon = 1e-15
        );
        assert_relative_eq!(
            (across.transpose() * c * across)[(0, 0)],
            lateral * lateral,
            epsilon = 1e-15
        );
        // At 3.5 m the body tracker is more precise along the ray than across it.
        let (range, lateral) = s(Joint::KneeLeft, &far, tracked);
        assert!(range < lateral);
    }
}
