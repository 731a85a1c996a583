//! Small signal helpers shared by segmentation and event detection.

use nalgebra::{Point3, Vector2, Vector3};
use trigait_skeleton::{Joint, MotionClip};

use crate::{Error, Foot, Result};

/// The trajectories gait analysis reads, one entry per frame (`None` = gap).
#[derive(Debug, Clone)]
pub(crate) struct Tracks {
    pub rate_hz: f64,
    /// Hip mid-point, else `SpineBase`.
    pub pelvis: Vec<Option<Point3<f64>>>,
    /// Heel stand-ins (ankles), left then right.
    pub heel: [Vec<Option<Point3<f64>>>; 2],
    /// Toe stand-ins (`Foot*` when present, else the ankles), left then right.
    pub toe: [Vec<Option<Point3<f64>>>; 2],
}

impl Tracks {
    pub fn from_clip(clip: &MotionClip) -> Result<Self> {
        for joint in [Joint::AnkleLeft, Joint::AnkleRight] {
            if !clip.has(joint) {
                return Err(Error::MissingJoint {
                    joint,
                    why: "the ankles stand in for the heels",
                });
            }
        }
        let hips = clip.has(Joint::HipLeft) && clip.has(Joint::HipRight);
        if !hips && !clip.has(Joint::SpineBase) {
            return Err(Error::MissingJoint {
                joint: Joint::HipLeft,
                why: "the pelvis path is the hip mid-point (or SpineBase)",
            });
        }
        let n = clip.frame_count();
        let pelvis = (0..n)
            .map(|f| {
                if hips {
                    match (
                        clip.position(f, Joint::HipLeft),
                        clip.position(f, Joint::HipRight),
                    ) {
                        (Some(l), Some(r)) => Some(nalgebra::center(&l, &r)),
                        _ => None,
                    }
                } else {
                    clip.position(f, Joint::SpineBase)
                }
            })
            .collect();
        let track = |j: Joint| (0..n).map(|f| clip.position(f, j)).collect::<Vec<_>>();
        let toe_joint = |foot: Foot| {
            let (toe, ankle) = match foot {
                Foot::Left => (Joint::FootLeft, Joint::AnkleLeft),
                Foot::Right => (Joint::FootRight, Joint::AnkleRight),
            };
            if clip.has(toe) { toe } else { ankle }
        };
        Ok(Self {
            rate_hz: clip.rate_hz(),
            pelvis,
            heel: [track(Joint::AnkleLeft), track(Joint::AnkleRight)],
            toe: [track(toe_joint(Foot::Left)), track(toe_joint(Foot::Right))],
        })
    }

    pub fn len(&self) -> usize {
        self.pelvis.len()
    }

    /// Whether every track has a sample at `frame`.
    pub fn complete(&self, frame: usize) -> bool {
        let ok = |v: &Vec<Option<Point3<f64>>>| v.get(frame).copied().flatten().is_some();
        ok(&self.pelvis) && self.heel.iter().all(ok) && self.toe.iter().all(ok)
    }

    pub fn time(&self, frame: f64) -> f64 {
        frame / self.rate_hz
    }
}

/// Horizontal part of a vector.
pub(crate) fn horizontal(v: &Vector3<f64>) -> Vector2<f64> {
    Vector2::new(v.x, v.y)
}

/// Linear interpolation of a track at fractional frame `f`; `None` in gaps or outside.
pub(crate) fn sample(track: &[Option<Point3<f64>>], f: f64) -> Option<Point3<f64>> {
    if !f.is_finite() || f < 0.0 {
        return None;
    }
    let i = f.floor() as usize;
    let a = track.get(i).copied().flatten()?;
    let frac = f - i as f64;
    if frac <= 1e-9 {
        return Some(a);
    }
    let b = track.get(i + 1).copied().flatten()?;
    Some(a + (b - a) * frac)
}

/// A local extremum found by [`extrema`]: fractional index and prominence.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Extremum {
    pub index: f64,
    pub prominence: f64,
}

/// Local maxima (or minima when `maxima` is false) of `values` with at least `min_prominence`
/// and at least `min_separation` samples apart (the more prominent one wins).
///
/// The prominence is the smaller of the drops on either side before the signal exceeds the
/// peak again or the slice ends (as in `scipy.signal.find_peaks`). A peak on the first or last
/// sample is never reported: it is not known to be a turning point. The index is refined to
/// sub-sample precision by a parabola through the peak and its neighbours.
pub(crate) fn extrema(
    values: &[f64],
    maxima: bool,
    min_prominence: f64,
    min_separation: f64,
) -> Vec<Extremum> {
    let sign = if maxima { 1.0 } else { -1.0 };
    let v: Vec<f64> = values.iter().map(|x| sign * x).collect();
    let n = v.len();
    let mut found: Vec<Extremum> = Vec::new();
    if n < 3 {
        return found;
    }
    let mut i = 1;
    while i + 1 < n {
        // A plateau counts once, at its middle.
        if v[i] > v[i - 1] {
            let mut j = i;
            while j + 1 < n && v[j + 1] == v[i] {
                j += 1;
            }
            if j + 1 < n && v[j + 1] < v[i] {
                let peak = v[i];
                let left = v[..i]
                    .iter()
                    .rev()
                    .take_while(|x| **x <= peak)
                    .fold(peak, |m, x| m.min(*x));
                let right = v[j + 1..]
                    .iter()
                    .take_while(|x| **x <= peak)
                    .fold(peak, |m, x| m.min(*x));
                let prominence = (peak - left).min(peak - right);
                if prominence >= min_prominence {
                    let mid = (i + j) as f64 / 2.0;
                    let index = if i == j {
                        let (a, b, c) = (v[i - 1], v[i], v[i + 1]);
                        let denom = a - 2.0 * b + c;
                        if denom < 0.0 {
                            mid + (0.5 * (a - c) / denom).clamp(-0.5, 0.5)
                        } else {
                            mid
                        }
                    } else {
                        mid
                    };
                    found.push(Extremum { index, prominence });
                }
            }
            i = j + 1;
        } else {
            i += 1;
        }
    }
    // Enforce the separation greedily, most prominent first.
    let mut order: Vec<usize> = (0..found.len()).collect();
    order.sort_by(|a, b| found[*b].prominence.total_cmp(&found[*a].prominence));
    let mut kept: Vec<Extremum> = Vec::new();
    for k in order {
        let e = found[k];
        if kept
            .iter()
            .all(|q| (q.index - e.index).abs() >= min_separation)
        {
            kept.push(e);
        }
    }
    kept.sort_by(|a, b| a.index.total_cmp(&b.index));
    kept
}

/// Mean and sample standard deviation (`None` below two values).
pub(crate) fn mean_sd(values: &[f64]) -> (Option<f64>, Option<f64>) {
    if values.is_empty() {
        return (None, None);
    }
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    if values.len() < 2 {
        return (Some(mean), None);
    }
    let var = values.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (Some(mean), Some(var.sqrt()))
}

#[cfg(test)]
mod tests {
    use approx::assert_relative_eq;

    use super::*;

    /// Sinusoid peaks are found at sub-sample precision; edges and small wiggles are not peaks.
    #[test]
    fn extrema_of_a_sinusoid() {
        let rate = 100.0;
        let values: Vec<f64> = (0..=300)
            .map(|i| {
                let t = f64::from(i) / rate;
                (std::f64::consts::TAU * t).sin() + 0.001 * (60.0 * t).sin()
            })
            .collect();
        let max = extrema(&values, true, 0.5, 40.0);
        let idx: Vec<f64> = max.iter().map(|e| e.index).collect();
        assert_eq!(idx.len(), 3, "{idx:?}");
        for (k, i) in idx.iter().enumerate() {
            assert_relative_eq!(*i, 25.0 + 100.0 * k as f64, epsilon = 0.3);
        }
        let min = extrema(&values, false, 0.5, 40.0);
        assert_eq!(min.len(), 3);
        assert_relative_eq!(min[0].index, 75.0, epsilon = 0.3);
        // A monotonic signal has no extrema, even at its ends.
        let ramp: Vec<f64> = (0..50).map(f64::from).collect();
        assert!(extrema(&ramp, true, 0.0, 1.0).is_empty());
        assert!(extrema(&ramp, false, 0.0, 1.0).is_empty());
    }

    /// Standard deviation uses n − 1 and needs two values.
    #[test]
    fn mean_and_sd() {
        assert_eq!(mean_sd(&[]), (None, None));
        assert_eq!(mean_sd(&[2.0]), (Some(2.0), None));
        let (m, s) = mean_sd(&[1.0, 2.0, 3.0, 4.0]);
        assert_relative_eq!(m.unwrap(), 2.5);
        assert_relative_eq!(s.unwrap(), (5.0f64 / 3.0).sqrt());
    }
}
