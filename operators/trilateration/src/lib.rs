//! Locates one joint at one instant from what several depth sensors report about it, and says
//! how good the answer is.
//!
//! Every estimator takes a slice of [`Observation`]s (one per sensor: the sensor's pose, the joint
//! in the sensor's camera frame and that observation's 3×3 noise covariance) and returns an
//! [`Estimate`]: a world position, a 3×3 covariance and [`Diagnostics`]. The family runs from the
//! thesis methods to the statistically efficient one:
//!
//! | [`Method`] | uses | source |
//! |---|---|---|
//! | `Geometric` | 3 ranges, rig from pairwise distances | thesis §4.2.1, eq. 4.2–4.5 (eq. 4.4 erratum fixed) |
//! | `Linear` | n ≥ 3 ranges, `Ax = b` via SVD pseudo-inverse | thesis §4.2.2, eq. 4.10–4.15 |
//! | `Nls` | n ≥ 3 ranges weighted by their variance, Levenberg–Marquardt | maximum likelihood for range-only data |
//! | `Fusion` | n ≥ 1 full 3-D observations with anisotropic covariance | maximum likelihood for the Kinect noise model |
//!
//! [`robust`] wraps any of them and drops sensors whose observation is statistically inconsistent
//! with the rest (an occluded or mis-tracked joint), down to the minimum the method needs.
//!
//! Range-only methods see a sensor as a sphere centre and a radius `|p|` (the distance from the
//! optical centre to the joint); they discard the bearing, which is why `Fusion` beats them. Three
//! sensors always lie in one plane, so range-only solutions come in mirror pairs about it; the
//! pair is resolved to the side the sensors look at ([`mirror`]).
//!
//! [`crb`] gives the Cramér–Rao bound of both data models for a geometry, the yardstick
//! `trigait eval` divides every RMSE by.
//!
//! Frames: `world` (right-handed, Z up, metres) and `kinect` (Kinect v2 camera space: x left,
//! y up, z out of the lens). Poses are `world_from_kinect`.

#![warn(missing_docs)]

pub mod crb;
mod estimators;
pub mod mirror;
mod observation;
pub mod thesis;

pub use estimators::{
    Diagnostics, Estimate, Method, Params, UnknownMethod, estimate, fusion, geometric, linear, nls,
    robust,
};
pub use observation::Observation;

/// Why no position could be computed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// Fewer usable observations than the method needs.
    #[error("{method} needs at least {need} sensors, got {got}")]
    TooFewSensors {
        /// The method that was asked for.
        method: Method,
        /// Observations given.
        got: usize,
        /// Observations needed.
        need: usize,
    },
    /// An observation holds NaN or infinity.
    #[error("observation {index} is not finite")]
    NonFinite {
        /// Index of the observation in the input slice.
        index: usize,
    },
    /// An observation's covariance is not symmetric positive definite.
    #[error("observation {index} has a covariance that is not positive definite")]
    BadCovariance {
        /// Index of the observation in the input slice.
        index: usize,
    },
    /// A sensor reports the joint at its own optical centre (zero range).
    #[error("observation {index} puts the joint at the sensor (range {range_m} m)")]
    SensorAtTarget {
        /// Index of the observation in the input slice.
        index: usize,
        /// The reported range.
        range_m: f64,
    },
    /// The sensors are (nearly) collinear or coincident: the position is not determined.
    #[error(
        "the sensor geometry is degenerate for {method}: rank {rank} (condition number {condition_number:.3e})"
    )]
    Degenerate {
        /// The method that was asked for.
        method: Method,
        /// Numerical rank of the geometry.
        rank: usize,
        /// Ratio of largest to smallest singular value.
        condition_number: f64,
    },
    /// The iterative solver did not converge; the best estimate so far is returned with it.
    #[error("{method} did not converge in {iterations} iterations (step {last_step_m:.3e} m)")]
    NotConverged {
        /// The method that was asked for.
        method: Method,
        /// Iterations run.
        iterations: usize,
        /// Length of the last step.
        last_step_m: f64,
        /// The best estimate found.
        estimate: nalgebra::Point3<f64>,
    },
}

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, Error>;
