//! Cramér–Rao bounds: the smallest covariance any unbiased estimator can reach for a geometry
//! and noise model, the yardstick `trigait eval` measures every method against.
//!
//! Two data models, matching the two kinds of estimator:
//! - [`full`]: each sensor reports the joint as a 3-D point with Gaussian noise Σᵢ (what a
//!   Kinect gives). Fisher information `Σ Rᵢ Σᵢ⁻¹ Rᵢᵀ`; `Fusion` attains it.
//! - [`range_only`]: each sensor contributes only its range, with variance `uᵢᵀ Σᵢ uᵢ` along the
//!   ray `uᵢ` (what trilateration uses). Information `Σ uᵢ uᵢᵀ / σᵢ²`; `Nls` attains it
//!   asymptotically.
//!
//! Both ignore the information carried by the dependence of Σᵢ on the joint's position (the
//! noise grows with distance); for Kinect noise of millimetres to centimetres at metres of
//! range that term is below 10⁻⁴ of the position term.
//!
//! Pass observations built at the *true* joint position (noise-free `position_in_kinect`, the
//! sensor model's covariance there): the bound is a property of the geometry, not of a sample.

use nalgebra::Matrix3;

use crate::Observation;

/// Fisher information of full 3-D observations.
#[must_use]
pub fn full_information(at_truth: &[Observation]) -> Matrix3<f64> {
    at_truth
        .iter()
        .filter_map(|o| o.covariance_in_world().try_inverse())
        .sum()
}

/// Fisher information of range-only observations.
#[must_use]
pub fn range_only_information(at_truth: &[Observation]) -> Matrix3<f64> {
    at_truth
        .iter()
        .map(|o| {
            let u = (o.position_in_world() - o.sensor_in_world()).normalize();
            let sigma = o.range_sigma_m();
            u * u.transpose() / (sigma * sigma)
        })
        .sum()
}

/// Cramér–Rao bound of full 3-D observations; `None` when no sensor sees the joint.
#[must_use]
pub fn full(at_truth: &[Observation]) -> Option<Matrix3<f64>> {
    invert(full_information(at_truth))
}

/// Cramér–Rao bound of range-only observations; `None` when the ranges do not determine the
/// joint (fewer than three sensors, or the joint in the plane of a planar rig).
#[must_use]
pub fn range_only(at_truth: &[Observation]) -> Option<Matrix3<f64>> {
    invert(range_only_information(at_truth))
}

fn invert(information: Matrix3<f64>) -> Option<Matrix3<f64>> {
    let s = information.singular_values();
    let well_posed = s.min() > 1e-12 * s.max();
    if !well_posed {
        return None;
    }
    information
        .try_inverse()
        .filter(|c| c.iter().all(|v| v.is_finite()))
}

/// The root of the bound's trace: the smallest achievable 3-D RMSE (metres).
#[must_use]
pub fn rmse_bound_m(bound: &Matrix3<f64>) -> f64 {
    bound.trace().max(0.0).sqrt()
}
