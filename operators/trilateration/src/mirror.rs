//! Which of the two mirror solutions of a planar range-only problem is the joint.
//!
//! Spheres centred on sensors that lie in one plane intersect in two points, mirror images
//! through that plane (thesis §4.1, Fig. 4.1b: the "virtual point"). GPS discards the mirror by
//! its distance from the earth; a multi-Kinect rig can discard it because a sensor only reports
//! joints in front of its lens. Two rules, tried in order:
//!
//! 1. **Viewing side** — when the sensors' optical axes, averaged, point clearly out of the
//!    plane (tripods pitched down at the legs), the joint is on that side.
//! 2. **Bearing vote** — otherwise (sensors looking along the plane, e.g. a rig at hip height
//!    that sees hips above and ankles below it) the reported positions themselves vote: the
//!    joint is on the side where the sensors saw it. Only the sign is taken from the bearing, so
//!    the range-only estimate stays range-only in magnitude.

use nalgebra::{Point3, Vector3};

use crate::Observation;

/// Mean axis component along the normal above which the viewing side decides (about 6°).
pub const VIEWING_SIDE_MIN: f64 = 0.1;

/// +1 if the joint is on the `normal` side of the plane through `plane_point`, else −1.
#[must_use]
pub fn side(normal: &Vector3<f64>, plane_point: &Point3<f64>, observations: &[Observation]) -> f64 {
    let count = observations.len().max(1) as f64;
    let viewing: f64 = observations
        .iter()
        .map(|o| o.axis_in_world().dot(normal))
        .sum::<f64>()
        / count;
    if viewing.abs() >= VIEWING_SIDE_MIN {
        return viewing.signum();
    }
    let vote: f64 = observations
        .iter()
        .map(|o| (o.position_in_world() - plane_point).dot(normal))
        .sum();
    if vote < 0.0 { -1.0 } else { 1.0 }
}
