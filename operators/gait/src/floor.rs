//! Levelling the floor before any height is read.
//!
//! Marker labs calibrate the floor to z = 0, but a skeleton tracker reports joints in its own
//! camera frame: a Kinect v2 is usually pitched down by 5–20°, so once its Y axis is taken as
//! up, the floor rises or falls by tan(pitch) per metre of distance from the sensor (thesis
//! §6.4.4 on the camera frame). A walk towards the sensor then drifts in height by 10–30 cm,
//! far faster than a stance level over ±1 s can follow, and the height gates see flight phases
//! and airborne feet in plain walking. Horizontal lengths shrink by cos(pitch) as well.
//!
//! The floor plane is fitted from where the feet rest: samples of the heel and toe tracks that
//! stand still (3-D speed over ±0.1 s below [`STILL_MPS`]) lie a constant height above the
//! floor, a different constant for each landmark, so one shared slope and one offset per track
//! are fitted by least squares (with a second pass without the worst residuals). The slope is
//! only fitted along horizontal directions the resting points span by at least
//! [`MIN_SPREAD_M`] (a straight walk fixes the slope along the walk, not across it), and the
//! landmarks are rotated so the fitted floor becomes horizontal when its tilt exceeds
//! [`MIN_TILT_DEG`]. Treadmill walking (the stance foot moves with the belt) and stepping in
//! place give no spread and are left as they are.

use nalgebra::{Matrix2, Point3, Rotation3, Vector2, Vector3};
use serde::{Deserialize, Serialize};

use crate::signal::Landmarks;

/// A foot sample is at rest below this 3-D speed (m/s): a stance foot moves at a few cm/s, a
/// swinging one at 1–5 m/s, and over ±0.1 s Kinect jitter of ≈ 1 cm gives ≈ 0.1 m/s.
pub const STILL_MPS: f64 = 0.25;

/// The resting points must spread at least this far (m, standard deviation along a horizontal
/// direction) for the slope along it to be fitted: about a 1.2 m stretch of walk.
pub const MIN_SPREAD_M: f64 = 0.35;

/// Tilts below this (degrees) are left alone: a lab floor is level to within it, and so is the
/// fit's own uncertainty on marker data.
pub const MIN_TILT_DEG: f64 = 1.0;

/// Tilts above this (degrees) are not believed: no tracker is mounted that steeply, so the fit
/// has latched onto something else (stairs, a ramp walk, a wrong up axis).
pub const MAX_TILT_DEG: f64 = 30.0;

/// What levelling found and did.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FloorLevel {
    /// Tilt of the fitted floor against the horizontal (degrees).
    pub tilt_deg: f64,
    /// Unit normal of the fitted floor in the input frame.
    pub normal: [f64; 3],
    /// Resting foot samples the fit rests on.
    pub samples: usize,
    /// Whether the landmarks were rotated (tilt between [`MIN_TILT_DEG`] and
    /// [`MAX_TILT_DEG`]).
    pub applied: bool,
}

/// Resting samples of one track: positions where the 3-D speed over ±`half` frames is below
/// [`STILL_MPS`].
fn resting(track: &[Option<Point3<f64>>], half: usize, rate: f64) -> Vec<Point3<f64>> {
    let n = track.len();
    (half..n.saturating_sub(half))
        .filter_map(|f| {
            let p = track[f]?;
            let a = track[f - half]?;
            let b = track[f + half]?;
            let speed = (b - a).norm() * rate / (2 * half) as f64;
            (speed < STILL_MPS).then_some(p)
        })
        .collect()
}

/// Fits the floor under the resting feet of `landmarks` and, when it is tilted, rotates every
/// landmark so it is level. `None` when the feet never rest over a long enough stretch.
pub(crate) fn level(landmarks: &mut Landmarks) -> Option<FloorLevel> {
    let rate = landmarks.rate_hz;
    let half = ((0.1 * rate).round() as usize).max(1);
    // Each track's resting points, centred on their own mean (one offset per track).
    let mut points: Vec<(Vector2<f64>, f64)> = Vec::new();
    for track in landmarks.heel.iter().chain(landmarks.toe.iter()) {
        let rest = resting(track, half, rate);
        if rest.len() < 5 {
            continue;
        }
        let mean = rest.iter().map(|p| p.coords).sum::<Vector3<f64>>() / rest.len() as f64;
        points.extend(
            rest.iter()
                .map(|p| (Vector2::new(p.x - mean.x, p.y - mean.y), p.z - mean.z)),
        );
    }
    if points.len() < 20 {
        return None;
    }
    // The horizontal directions the points span.
    let cov = points
        .iter()
        .map(|(h, _)| h * h.transpose())
        .sum::<Matrix2<f64>>()
        / points.len() as f64;
    let eig = cov.symmetric_eigen();
    let axes: Vec<Vector2<f64>> = (0..2)
        .filter(|&k| eig.eigenvalues[k].max(0.0).sqrt() >= MIN_SPREAD_M)
        .map(|k| eig.eigenvectors.column(k).into_owned())
        .collect();
    if axes.is_empty() {
        return None;
    }
    let fit = |points: &[(Vector2<f64>, f64)]| -> Vector2<f64> {
        // Least squares of z on the coordinates along each spanned axis (the data are centred
        // per track, so no intercept).
        axes.iter().fold(Vector2::zeros(), |g, axis| {
            let (mut su, mut suz) = (0.0, 0.0);
            for (h, z) in points {
                let u = h.dot(axis);
                su += u * u;
                suz += u * z;
            }
            if su > 1e-12 { g + axis * (suz / su) } else { g }
        })
    };
    let mut gradient = fit(&points);
    // Second pass without the points furthest from the plane (a toe rolling, a heel rising).
    let mut residuals: Vec<f64> = points
        .iter()
        .map(|(h, z)| (z - gradient.dot(h)).abs())
        .collect();
    residuals.sort_by(f64::total_cmp);
    let limit = residuals[(residuals.len() - 1) * 9 / 10].max(0.01);
    let inliers: Vec<(Vector2<f64>, f64)> = points
        .iter()
        .copied()
        .filter(|(h, z)| (z - gradient.dot(h)).abs() <= limit)
        .collect();
    if inliers.len() >= 20 {
        gradient = fit(&inliers);
    }
    let normal = Vector3::new(-gradient.x, -gradient.y, 1.0).normalize();
    let tilt_deg = normal.z.clamp(-1.0, 1.0).acos().to_degrees();
    let applied = (MIN_TILT_DEG..=MAX_TILT_DEG).contains(&tilt_deg);
    if applied {
        let rotation =
            Rotation3::rotation_between(&normal, &Vector3::z()).unwrap_or_else(Rotation3::identity);
        rotate(landmarks, &rotation);
    }
    Some(FloorLevel {
        tilt_deg,
        normal: [normal.x, normal.y, normal.z],
        samples: inliers.len(),
        applied,
    })
}

fn rotate(landmarks: &mut Landmarks, rotation: &Rotation3<f64>) {
    let tracks = std::iter::once(&mut landmarks.pelvis)
        .chain(landmarks.heel.iter_mut())
        .chain(landmarks.toe.iter_mut());
    for track in tracks {
        for p in track.iter_mut().flatten() {
            *p = rotation * *p;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Feet resting at stations along a walk on a floor tilted by 12° about the across axis:
    /// the fit finds the tilt and levelling makes the stations' heights equal.
    #[test]
    fn tilted_walk_is_levelled() {
        let rate = 30.0;
        let tilt = 12f64.to_radians();
        let tilted = Rotation3::from_axis_angle(&Vector3::y_axis(), tilt);
        // Each foot alternates 0.4 s at rest with 0.4 s of swing, 0.6 m further each stride.
        let n = 150;
        let track = |offset: f64, lateral: f64, height: f64| -> Vec<Option<Point3<f64>>> {
            (0..n)
                .map(|f| {
                    let t = f as f64 / rate + offset;
                    let stride = (t / 0.8).floor();
                    let phase = t / 0.8 - stride;
                    let x = if phase < 0.5 {
                        stride * 1.2
                    } else {
                        stride * 1.2 + (phase - 0.5) / 0.5 * 1.2
                    };
                    let z = if phase < 0.5 {
                        height
                    } else {
                        height + 0.1 * ((phase - 0.5) / 0.5 * std::f64::consts::PI).sin()
                    };
                    Some(tilted * Point3::new(x, lateral, z))
                })
                .collect()
        };
        let mut l = Landmarks {
            rate_hz: rate,
            pelvis: (0..n)
                .map(|f| Some(tilted * Point3::new(f as f64 / rate * 1.5, 0.0, 0.9)))
                .collect(),
            heel: [track(0.0, 0.1, 0.08), track(0.4, -0.1, 0.08)],
            toe: [track(0.0, 0.1, 0.03), track(0.4, -0.1, 0.03)],
            heel_source: crate::HeelSource::AnkleCentre,
        };
        let level = level(&mut l).expect("a floor");
        assert!(level.applied);
        assert!((level.tilt_deg - 12.0).abs() < 0.3, "{level:?}");
        let rest = resting(&l.heel[0], 3, rate);
        let (lo, hi) = rest
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                (a.min(p.z), b.max(p.z))
            });
        assert!(hi - lo < 0.01, "resting heel heights span {:.3} m", hi - lo);
    }

    /// Feet resting in one place (stepping in place) give no slope and are left alone.
    #[test]
    fn no_spread_no_levelling() {
        let n = 120;
        let still = |z: f64| -> Vec<Option<Point3<f64>>> {
            (0..n).map(|_| Some(Point3::new(2.0, 0.1, z))).collect()
        };
        let mut l = Landmarks {
            rate_hz: 30.0,
            pelvis: still(0.9),
            heel: [still(0.1), still(0.1)],
            toe: [still(0.05), still(0.05)],
            heel_source: crate::HeelSource::AnkleCentre,
        };
        let before = l.clone();
        assert!(level(&mut l).is_none());
        assert_eq!(l, before);
    }
}
