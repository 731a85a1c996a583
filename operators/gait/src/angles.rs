//! Sagittal hip and knee flexion over each gait cycle, normalised to 0–100 % of the stride: the
//! kinematic curves a gait lab reads first (Winter 2009, §3.4; Perry & Burnfield 2010).
//!
//! Only joint centres are tracked (hips, knees, ankles; thesis §6.4.4), so the angles are those
//! the centres define, in the sagittal plane of the stride (vertical × walking direction):
//! - **knee flexion**: the thigh (hip → knee) against the shank (knee → ankle); 0° with the leg
//!   straight, positive when the shank swings back relative to the thigh;
//! - **hip flexion**: the thigh against the downward vertical, positive with the knee ahead of
//!   the hip. The pelvis is not tracked, so this is the thigh's inclination, which equals the
//!   clinical hip flexion when the pelvis is upright (its tilt in normal walking is a few degrees).
//!
//! A cycle runs from one heel strike of a foot to its next ([`crate::Stride`]); its curve is
//! sampled at [`CYCLE_SAMPLES`] points, 0 %, 1 %, …, 100 %, from the clip linearly interpolated.

use nalgebra::{Point3, Vector2, Vector3};
use serde::{Deserialize, Serialize};
use trigait_skeleton::{Joint, MotionClip};

use crate::{Foot, GaitAnalysis};

/// Samples per normalised cycle: 0 % to 100 % in steps of 1 %.
pub const CYCLE_SAMPLES: usize = 101;

/// One foot's hip and knee flexion over one gait cycle.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FlexionCycle {
    /// The foot whose heel strikes bound the cycle (the leg measured).
    pub foot: Foot,
    /// Time of the opening heel strike (s, clip time).
    pub start_secs: f64,
    /// Time of the closing heel strike (s, clip time).
    pub end_secs: f64,
    /// Knee flexion (degrees) at 0 %, 1 %, …, 100 % of the cycle.
    pub knee_deg: Vec<f64>,
    /// Hip flexion, as the thigh's inclination (degrees), at 0 %, 1 %, …, 100 %.
    pub hip_deg: Vec<f64>,
}

/// Hip and knee flexion (degrees) of one leg from its joint centres, in the sagittal plane
/// spanned by the vertical and the horizontal walking direction `forward` (need not be unit).
///
/// `None` when `forward` has no horizontal extent or a segment has no length in that plane.
#[must_use]
pub fn sagittal_flexion_deg(
    hip: &Point3<f64>,
    knee: &Point3<f64>,
    ankle: &Point3<f64>,
    forward: &Vector2<f64>,
) -> Option<(f64, f64)> {
    let norm = forward.norm();
    if !(norm.is_finite() && norm > 1e-9) {
        return None;
    }
    let f = Vector3::new(forward.x / norm, forward.y / norm, 0.0);
    // Inclination of a downward segment from the downward vertical, + forward.
    let inclination = |v: Vector3<f64>| {
        let (along, down) = (v.dot(&f), -v.z);
        (along.hypot(down) > 1e-9).then(|| along.atan2(down).to_degrees())
    };
    let thigh = inclination(knee - hip)?;
    let shank = inclination(ankle - knee)?;
    Some((thigh, thigh - shank))
}

/// The flexion cycles of every complete stride of `analysis` (which was computed on `clip`),
/// in stride order. A stride is left out when a hip, knee or ankle of its leg is missing at one
/// of its samples; the second value counts those.
#[must_use]
pub fn flexion_cycles(clip: &MotionClip, analysis: &GaitAnalysis) -> (Vec<FlexionCycle>, usize) {
    let mut cycles = Vec::new();
    let mut skipped = 0;
    for stride in &analysis.strides {
        let Some(segment) = analysis.segments.get(stride.segment) else {
            skipped += 1;
            continue;
        };
        let forward = segment.direction().into_inner();
        let (hip, knee, ankle) = match stride.foot {
            Foot::Left => (Joint::HipLeft, Joint::KneeLeft, Joint::AnkleLeft),
            Foot::Right => (Joint::HipRight, Joint::KneeRight, Joint::AnkleRight),
        };
        let span = stride.end_secs - stride.start_secs;
        let curve: Option<Vec<(f64, f64)>> = (0..CYCLE_SAMPLES)
            .map(|i| {
                let t = stride.start_secs + span * i as f64 / (CYCLE_SAMPLES - 1) as f64;
                sagittal_flexion_deg(
                    &clip.position_at(hip, t)?,
                    &clip.position_at(knee, t)?,
                    &clip.position_at(ankle, t)?,
                    &forward,
                )
            })
            .collect();
        match curve {
            Some(curve) if span > 0.0 => cycles.push(FlexionCycle {
                foot: stride.foot,
                start_secs: stride.start_secs,
                end_secs: stride.end_secs,
                hip_deg: curve.iter().map(|(h, _)| *h).collect(),
                knee_deg: curve.iter().map(|(_, k)| *k).collect(),
            }),
            _ => skipped += 1,
        }
    }
    (cycles, skipped)
}

/// The point-wise mean of curves sampled alike ([`CYCLE_SAMPLES`] points each); `None` for no
/// curves or curves of different lengths.
#[must_use]
pub fn mean_curve<'a>(curves: impl IntoIterator<Item = &'a [f64]>) -> Option<Vec<f64>> {
    let mut sum: Option<Vec<f64>> = None;
    let mut n = 0_usize;
    for c in curves {
        match &mut sum {
            None => sum = Some(c.to_vec()),
            Some(s) if s.len() == c.len() => s.iter_mut().zip(c).for_each(|(a, b)| *a += b),
            Some(_) => return None,
        }
        n += 1;
    }
    sum.map(|s| s.into_iter().map(|v| v / n as f64).collect())
}

#[cfg(test)]
mod tests {
    use approx::assert_relative_eq;
    use trigait_motion::{WalkerParams, walker};

    use super::*;
    use crate::{GaitParams, analyse};

    /// A leg posed from known thigh and shank inclinations along a diagonal walking direction
    /// gives those angles back, whatever the side offset across the direction.
    #[test]
    fn posed_leg_gives_its_angles_back() {
        let forward = Vector2::new(3.0, -4.0);
        let f = Vector3::new(0.6, -0.8, 0.0);
        let across = Vector3::new(0.8, 0.6, 0.0);
        for (thigh_deg, knee_deg) in [(0.0, 0.0), (25.0, 5.0), (-12.0, 40.0), (30.0, 65.0)] {
            let hip = Point3::new(1.0, 2.0, 0.9);
            let dir = |deg: f64| {
                let r = f64::to_radians(deg);
                f * r.sin() - Vector3::z() * r.cos()
            };
            let knee = hip + dir(thigh_deg) * 0.43 + across * 0.02;
            let ankle = knee + dir(thigh_deg - knee_deg) * 0.43 - across * 0.03;
            let (h, k) = sagittal_flexion_deg(&hip, &knee, &ankle, &forward).unwrap();
            assert_relative_eq!(h, thigh_deg, epsilon = 1e-9);
            assert_relative_eq!(k, knee_deg, epsilon = 1e-9);
        }
        let p = Point3::origin();
        assert!(sagittal_flexion_deg(&p, &p, &p, &forward).is_none());
        assert!(sagittal_flexion_deg(&p, &p, &p, &Vector2::zeros()).is_none());
    }

    /// The parametric walker's strides, found by the event detection, give the normal-gait
    /// curves its own tests measure frame by frame: knee swing peak 55–70° at 65–80 % of the
    /// cycle, near straight at mid-stance, hip 25–40° flexion to 5–20° extension.
    #[test]
    fn walker_cycles_look_like_normal_gait() {
        let clip = walker(&WalkerParams::default(), 8.0, 100.0)
            .unwrap()
            .placed_on_walkway();
        let analysis = analyse(&clip, &GaitParams::default()).unwrap();
        let (cycles, skipped) = flexion_cycles(&clip, &analysis);
        assert_eq!(skipped, 0);
        assert_eq!(cycles.len(), analysis.strides.len());
        assert!(cycles.len() >= 4, "{} cycles", cycles.len());
        for c in &cycles {
            assert_eq!(c.knee_deg.len(), CYCLE_SAMPLES);
            let (i_peak, peak) = c
                .knee_deg
                .iter()
                .copied()
                .enumerate()
                .max_by(|a, b| a.1.total_cmp(&b.1))
                .unwrap();
            assert!(
                (55.0..70.0).contains(&peak),
                "{:?} knee peak {peak:.1}",
                c.foot
            );
            assert!(
                (65..=80).contains(&i_peak),
                "{:?} peak at {i_peak} %",
                c.foot
            );
            let mid = c.knee_deg[30..45].iter().copied().fold(f64::MAX, f64::min);
            assert!(mid < 10.0, "{:?} mid-stance knee {mid:.1}", c.foot);
            let hip_max = c.hip_deg.iter().copied().fold(f64::MIN, f64::max);
            let hip_min = c.hip_deg.iter().copied().fold(f64::MAX, f64::min);
            assert!((25.0..40.0).contains(&hip_max), "hip max {hip_max:.1}");
            assert!((-20.0..-5.0).contains(&hip_min), "hip min {hip_min:.1}");
        }
        let mean = mean_curve(cycles.iter().map(|c| c.knee_deg.as_slice())).unwrap();
        assert_eq!(mean.len(), CYCLE_SAMPLES);
        assert!(mean_curve(std::iter::empty()).is_none());
        assert!(mean_curve([[1.0].as_slice(), [1.0, 2.0].as_slice()]).is_none());
    }
}
