//! Self-occlusion: one leg hiding a joint of the other from a sensor.
//!
//! Walking past a sensor side-on, the near leg covers the far leg's knee and ankle for part of
//! every stride; the Kinect body tracker then reports those joints as *inferred* (guessed from
//! the body model). Limbs are modelled as capsules (segments with a radius); a joint is hidden
//! when the line of sight to it passes through a capsule of the other leg in front of it.

use nalgebra::Point3;
use trigait_skeleton::{Joint, Side};

/// A limb segment with a radius.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Capsule {
    /// One end of the segment (proximal joint).
    pub a: Point3<f64>,
    /// The other end (distal joint).
    pub b: Point3<f64>,
    /// Limb radius, metres.
    pub radius_m: f64,
}

/// Thigh radius: 8 cm, from a mid-thigh circumference of ≈ 50 cm (adult anthropometry, e.g.
/// the ANSUR II survey means for men and women).
pub const THIGH_RADIUS_M: f64 = 0.08;
/// Shank radius: 5.5 cm, from a calf circumference of ≈ 36 cm (same source).
pub const SHANK_RADIUS_M: f64 = 0.055;
/// Foot radius: 4 cm (foot height at the instep ≈ 7–8 cm).
pub const FOOT_RADIUS_M: f64 = 0.04;

/// The capsules of the leg on the other side from `joint` (empty for centre joints), built from
/// whichever of that leg's joints `position` knows.
#[must_use]
pub fn other_leg(joint: Joint, position: impl Fn(Joint) -> Option<Point3<f64>>) -> Vec<Capsule> {
    let (hip, knee, ankle, foot) = match joint.side() {
        Side::Left => (
            Joint::HipRight,
            Joint::KneeRight,
            Joint::AnkleRight,
            Joint::FootRight,
        ),
        Side::Right => (
            Joint::HipLeft,
            Joint::KneeLeft,
            Joint::AnkleLeft,
            Joint::FootLeft,
        ),
        Side::Centre => return Vec::new(),
    };
    [
        (hip, knee, THIGH_RADIUS_M),
        (knee, ankle, SHANK_RADIUS_M),
        (ankle, foot, FOOT_RADIUS_M),
    ]
    .into_iter()
    .filter_map(|(a, b, radius_m)| {
        Some(Capsule {
            a: position(a)?,
            b: position(b)?,
            radius_m,
        })
    })
    .collect()
}

/// Whether the line of sight from `eye` to `target` passes through one of `occluders` before it
/// reaches the target (a capsule touching the target from behind does not hide it).
#[must_use]
pub fn hidden(eye: &Point3<f64>, target: &Point3<f64>, occluders: &[Capsule]) -> bool {
    let length = (target - eye).norm();
    occluders.iter().any(|c| {
        let (s, _, distance) = closest_between_segments(eye, target, &c.a, &c.b);
        distance < c.radius_m && s * length < length - c.radius_m
    })
}

/// Closest points of segments p1–q1 and p2–q2: `(s, t, distance)` with the points at
/// `p1 + s (q1 − p1)` and `p2 + t (q2 − p2)` (Ericson, *Real-Time Collision Detection*, §5.1.9).
#[must_use]
pub fn closest_between_segments(
    p1: &Point3<f64>,
    q1: &Point3<f64>,
    p2: &Point3<f64>,
    q2: &Point3<f64>,
) -> (f64, f64, f64) {
    const EPS: f64 = 1e-12;
    let d1 = q1 - p1;
    let d2 = q2 - p2;
    let r = p1 - p2;
    let a = d1.norm_squared();
    let e = d2.norm_squared();
    let f = d2.dot(&r);
    let (s, t) = if a <= EPS && e <= EPS {
        (0.0, 0.0)
    } else if a <= EPS {
        (0.0, (f / e).clamp(0.0, 1.0))
    } else {
        let c = d1.dot(&r);
        if e <= EPS {
            ((-c / a).clamp(0.0, 1.0), 0.0)
        } else {
            let b = d1.dot(&d2);
            let denom = a * e - b * b;
            let mut s = if denom > EPS {
                ((b * f - c * e) / denom).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let mut t = (b * s + f) / e;
            if t < 0.0 {
                t = 0.0;
                s = (-c / a).clamp(0.0, 1.0);
            } else if t > 1.0 {
                t = 1.0;
                s = ((b - c) / a).clamp(0.0, 1.0);
            }
            (s, t)
        }
    };
    let distance = ((p1 + d1 * s) - (p2 + d2 * t)).norm();
    (s, t, distance)
}

#[cfg(test)]
mod tests {
    use approx::assert_relative_eq;

    use super::*;

    /// Crossing and parallel segments have the textbook closest points.
    #[test]
    fn segment_distance() {
        let o = Point3::origin();
        let (s, t, d) = closest_between_segments(
            &o,
            &Point3::new(2.0, 0.0, 0.0),
            &Point3::new(1.0, -1.0, 0.5),
            &Point3::new(1.0, 1.0, 0.5),
        );
        assert_relative_eq!(s, 0.5);
        assert_relative_eq!(t, 0.5);
        assert_relative_eq!(d, 0.5);
        let (_, _, d) = closest_between_segments(
            &o,
            &Point3::new(1.0, 0.0, 0.0),
            &Point3::new(3.0, 0.0, 0.0),
            &Point3::new(4.0, 0.0, 0.0),
        );
        assert_relative_eq!(d, 2.0);
    }

    /// A sensor looking side-on at a standing walker: the near leg hides the far knee; from the
    /// front both knees are visible, and a leg behind the target hides nothing.
    #[test]
    fn near_leg_hides_far_knee() {
        // Walker at the origin facing +X, left leg at y = +0.1, right leg at y = −0.1.
        let pos = |j: Joint| -> Option<Point3<f64>> {
            let y = if j.side() == Side::Left { 0.1 } else { -0.1 };
            let z = match j {
                Joint::HipLeft | Joint::HipRight => 0.9,
                Joint::KneeLeft | Joint::KneeRight => 0.5,
                Joint::AnkleLeft | Joint::AnkleRight => 0.08,
                _ => return None,
            };
            Some(Point3::new(0.0, y, z))
        };
        let right_side_sensor = Point3::new(0.0, -3.0, 0.5);
        let front_sensor = Point3::new(3.0, 0.0, 0.5);
        let knee_left = pos(Joint::KneeLeft).unwrap();
        let knee_right = pos(Joint::KneeRight).unwrap();
        let right_leg = other_leg(Joint::KneeLeft, pos);
        let left_leg = other_leg(Joint::KneeRight, pos);
        assert_eq!(
            right_leg.len(),
            2,
            "hip–knee and knee–ankle; no foot joint known"
        );
        assert!(hidden(&right_side_sensor, &knee_left, &right_leg));
        assert!(!hidden(&right_side_sensor, &knee_right, &left_leg));
        assert!(!hidden(&front_sensor, &knee_left, &right_leg));
        assert!(other_leg(Joint::SpineBase, pos).is_empty());
    }
}
