//! Treadmill walking: the pelvis stays put and the belt carries the stance foot backwards.
//!
//! Overground, a stance foot rests on the floor and the pelvis travels; on a treadmill the pelvis
//! rests and the stance foot travels backwards at the belt speed. Adding the belt's travel back
//! to every landmark, p'(t) = p(t) + v·t along the walking direction, turns the one into the
//! other (a treadmill is an inertial frame moving at −v). The same segmentation, events and
//! parameters then apply unchanged, and stride length, step length and speed come out
//! belt-corrected: the distance the walker would have covered on the floor.
//!
//! **Detection** ([`TreadmillMode::Auto`]): the pelvis stays within [`MAX_PELVIS_TRAVEL_M`]
//! of its median position over nearly all of the clip (a walk out and back ends where it
//! began, but it went somewhere; one pelvis sample thrown off by a tracker does not count),
//! while both heels swing back and forth relative to it
//! by at least [`MIN_FOOT_EXCURSION_M`] along one horizontal axis (periodic feet), the feet
//! pass each other along that axis (each is ahead of the other by at least
//! [`MIN_PASSING_M`] at times: walking, not a leg moved out to the side and back) and the stance
//! heel moves steadily along that axis. **Belt speed**, unless declared, is the median
//! horizontal velocity of the heels along that axis over the samples where the heel is within
//! [`STANCE_HEIGHT_M`] of its stance level and moving backwards: a stance foot on a belt moves
//! with the belt. The walking direction is opposite to the belt's motion.

use nalgebra::{Matrix2, Vector2};
use serde::{Deserialize, Serialize};

use crate::physics::Heights;
use crate::signal::Landmarks;

/// Whether the clip is treadmill walking.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TreadmillMode {
    /// Decide from the motion (fixed pelvis, periodic feet).
    #[default]
    Auto,
    /// Overground walking: never correct.
    Overground,
    /// A treadmill, at this belt speed (m/s) if given, else estimated from the feet.
    Treadmill {
        /// The belt speed (m/s) when known.
        belt_speed_mps: Option<f64>,
    },
}

/// How a treadmill clip was corrected.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Treadmill {
    /// Whether treadmill walking was declared (true) or detected (false).
    pub declared: bool,
    /// Belt speed used for the correction (m/s).
    pub belt_speed_mps: f64,
    /// Whether the belt speed was estimated from the stance feet (false: given).
    pub speed_estimated: bool,
    /// Horizontal unit walking direction (the belt moves the opposite way).
    pub walking_direction: [f64; 2],
    /// Stance samples the estimate rests on (0 when the speed was given).
    pub stance_samples: usize,
    /// How far the pelvis ranged, horizontally (m): the distance from its median position
    /// that all but [`PELVIS_OUTSIDE_SHARE`] of its samples keep within. Under
    /// [`MAX_PELVIS_TRAVEL_M`] on a treadmill, so more, on a declared one, says the walk
    /// probably went over the ground.
    #[serde(default)]
    pub pelvis_travel_m: f64,
}

/// The pelvis stays within this (m, horizontally) of its median position on a treadmill, in
/// all but [`PELVIS_OUTSIDE_SHARE`] of the samples.
pub const MAX_PELVIS_TRAVEL_M: f64 = 0.5;
/// The share of pelvis samples that may lie farther than [`MAX_PELVIS_TRAVEL_M`] from its
/// median position on a treadmill (tracker outliers).
pub const PELVIS_OUTSIDE_SHARE: f64 = 0.05;
/// Each heel's back-and-forth excursion relative to the pelvis (5th–95th percentile range along
/// the walking axis) is at least this on a treadmill (m): half a normal stride is ≈ 0.6 m.
pub const MIN_FOOT_EXCURSION_M: f64 = 0.25;
/// In walking each foot overtakes the other once per stride, so the left-minus-right heel
/// distance along the walking axis swings from about −1 to +1 step length (≈ ±0.6 m). Legs moved
/// out to the side and back, or a kick in place, keep one foot on its own side: that difference
/// keeps its sign. The 10th and 90th percentiles must lie at least this far (m) on either side of
/// zero — a third of a short (0.3 m) step, far above the 1–2 cm of tracker noise.
pub const MIN_PASSING_M: f64 = 0.1;
/// Heel samples within this height of the heel's stance level count as stance (m).
pub const STANCE_HEIGHT_M: f64 = 0.03;
/// A belt slower than this (m/s) is no treadmill walk (stepping in place): the median velocity of
/// all low heel samples along the axis must reach it, as must the estimate.
const MIN_BELT_SPEED_MPS: f64 = 0.2;

fn percentile(values: &mut [f64], q: f64) -> Option<f64> {
    if values.is_empty() {
        return None;
    }
    values.sort_by(f64::total_cmp);
    Some(values[((values.len() - 1) as f64 * q).round() as usize])
}

/// Whether the heels overtake each other along `axis` (see [`MIN_PASSING_M`]).
fn feet_pass(l: &Landmarks, axis: &Vector2<f64>) -> bool {
    let mut ahead: Vec<f64> = l.heel[0]
        .iter()
        .zip(&l.heel[1])
        .filter_map(|(a, b)| {
            let d = a.as_ref()? - b.as_ref()?;
            Some(Vector2::new(d.x, d.y).dot(axis))
        })
        .collect();
    let low = percentile(&mut ahead, 0.1);
    let high = percentile(&mut ahead, 0.9);
    matches!((low, high), (Some(a), Some(b)) if a <= -MIN_PASSING_M && b >= MIN_PASSING_M)
}

/// The principal horizontal axis of the heels' motion relative to the pelvis.
fn foot_axis(l: &Landmarks) -> Option<Vector2<f64>> {
    let rel: Vec<Vector2<f64>> = (0..2)
        .flat_map(|s| {
            l.heel[s].iter().zip(&l.pelvis).filter_map(|(h, p)| {
                let d = h.as_ref()? - p.as_ref()?;
                Some(Vector2::new(d.x, d.y))
            })
        })
        .collect();
    if rel.len() < 10 {
        return None;
    }
    let mean = rel.iter().sum::<Vector2<f64>>() / rel.len() as f64;
    let cov = rel
        .iter()
        .map(|v| (v - mean) * (v - mean).transpose())
        .sum::<Matrix2<f64>>();
    let eig = cov.symmetric_eigen();
    let k = if eig.eigenvalues[0] >= eig.eigenvalues[1] {
        0
    } else {
        1
    };
    let axis = eig.eigenvectors.column(k).into_owned();
    (axis.norm() > 1e-9).then(|| axis.normalize())
}

/// Detects (for `Auto`) or applies (for `Treadmill`) the treadmill correction, in place.
/// Returns what was done, `None` for overground.
pub(crate) fn correct(
    landmarks: &mut Landmarks,
    heights: &Heights,
    mode: TreadmillMode,
) -> Option<Treadmill> {
    let declared = match mode {
        TreadmillMode::Overground => return None,
        TreadmillMode::Auto => false,
        TreadmillMode::Treadmill { .. } => true,
    };
    let pelvis: Vec<Vector2<f64>> = landmarks
        .pelvis
        .iter()
        .flatten()
        .map(|p| Vector2::new(p.x, p.y))
        .collect();
    let middle = Vector2::new(
        percentile(&mut pelvis.iter().map(|p| p.x).collect::<Vec<_>>(), 0.5)?,
        percentile(&mut pelvis.iter().map(|p| p.y).collect::<Vec<_>>(), 0.5)?,
    );
    let travel = percentile(
        &mut pelvis
            .iter()
            .map(|p| (p - middle).norm())
            .collect::<Vec<_>>(),
        1.0 - PELVIS_OUTSIDE_SHARE,
    )?;
    if !declared && travel > MAX_PELVIS_TRAVEL_M {
        return None;
    }
    let axis = foot_axis(landmarks)?;
    if !declared && !feet_pass(landmarks, &axis) {
        return None;
    }
    let rate = landmarks.rate_hz;
    let mut velocities = Vec::new();
    for side in 0..2 {
        let heel = &landmarks.heel[side];
        let pelvis = &landmarks.pelvis;
        let mut rel: Vec<f64> = heel
            .iter()
            .zip(pelvis)
            .filter_map(|(h, p)| {
                let d = h.as_ref()? - p.as_ref()?;
                Some(Vector2::new(d.x, d.y).dot(&axis))
            })
            .collect();
        let excursion = percentile(&mut rel.clone(), 0.95)? - percentile(&mut rel, 0.05)?;
        if !declared && excursion < MIN_FOOT_EXCURSION_M {
            return None;
        }
        for f in 1..heel.len().saturating_sub(1) {
            let (Some(a), Some(b)) = (heel[f - 1], heel[f + 1]) else {
                continue;
            };
            let low = heights.heel[side][f].is_some_and(|h| h < STANCE_HEIGHT_M);
            if low {
                velocities.push(Vector2::new(b.x - a.x, b.y - a.y).dot(&axis) * rate / 2.0);
            }
        }
    }
    // Stance on a belt moves one way; pick the sign the majority of low samples move with.
    let backwards = velocities.iter().filter(|v| **v < 0.0).count();
    let sign = if backwards * 2 >= velocities.len() {
        -1.0
    } else {
        1.0
    };
    let mut stance: Vec<f64> = velocities
        .iter()
        .map(|v| v * sign)
        .filter(|v| *v > 0.0)
        .collect();
    let stance_samples = stance.len();
    // A foot resting on a still floor moves as often forwards as backwards (tracker jitter), so
    // the median of the positive speeds alone would read its noise as a belt: on a belt the
    // median of *all* low samples moves with it, in place it stays near zero.
    let mut signed: Vec<f64> = velocities.iter().map(|v| v * sign).collect();
    let belt_like = percentile(&mut signed, 0.5).is_some_and(|v| v >= MIN_BELT_SPEED_MPS);
    if !declared && !belt_like {
        return None;
    }
    let estimated = percentile(&mut stance, 0.5);
    let (belt_speed, speed_estimated) = match mode {
        TreadmillMode::Treadmill {
            belt_speed_mps: Some(v),
        } => (v, false),
        _ => (estimated?, true),
    };
    if !declared && (belt_speed < MIN_BELT_SPEED_MPS || stance_samples < 10) {
        return None;
    }
    // The belt moves along `sign · axis`; the walker faces the other way.
    let walking = -sign * axis;
    let velocity = nalgebra::Vector3::new(walking.x, walking.y, 0.0) * belt_speed;
    let tracks = std::iter::once(&mut landmarks.pelvis)
        .chain(landmarks.heel.iter_mut())
        .chain(landmarks.toe.iter_mut());
    for track in tracks {
        for (f, p) in track.iter_mut().enumerate() {
            if let Some(p) = p.as_mut() {
                *p += velocity * (f as f64 / rate);
            }
        }
    }
    Some(Treadmill {
        declared,
        belt_speed_mps: belt_speed,
        speed_estimated,
        walking_direction: [walking.x, walking.y],
        stance_samples: if speed_estimated { stance_samples } else { 0 },
        pelvis_travel_m: travel,
    })
}
