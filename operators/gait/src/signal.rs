//! Small signal helpers shared by segmentation and event detection.

use nalgebra::{Point3, Vector2, Vector3};
use serde::{Deserialize, Serialize};
use trigait_skeleton::{Joint, MotionClip};

use crate::{Error, Foot, Result};

/// What stands in for the heel in the event and step-width computations.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum HeelSource {
    /// A calcaneus marker: the definition gait labs use for step width.
    HeelMarker,
    /// The ankle joint centre (skeletons, joint-centre files): it sits a few centimetres medial
    /// and above the heel, so step width reads wider than the heel-marker definition.
    AnkleCentre,
}

impl HeelSource {
    /// How tables and reports name it.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            HeelSource::HeelMarker => "heel markers",
            HeelSource::AnkleCentre => "ankle centres",
        }
    }
}

/// The trajectories gait analysis reads, one entry per frame (`None` = gap), in the world frame
/// (metres, Z up).
///
/// Built from joint centres by [`Landmarks::from_clip`] (ankles for heels, `Foot*` joints for
/// toes), or directly from skin markers (heel, toe and pelvis markers, as Zeni et al. 2008 used
/// them) by whoever reads the markers.
#[derive(Debug, Clone, PartialEq)]
pub struct Landmarks {
    /// Frames per second.
    pub rate_hz: f64,
    /// Pelvis path: hip mid-point, `SpineBase`, or the centroid of the pelvis markers.
    pub pelvis: Vec<Option<Point3<f64>>>,
    /// Heels (or their stand-ins), left then right.
    pub heel: [Vec<Option<Point3<f64>>>; 2],
    /// Toes (or their stand-ins, the ankles when nothing better exists), left then right.
    /// Optional per frame: a missing toe only means no toe off is detected there.
    pub toe: [Vec<Option<Point3<f64>>>; 2],
    /// What `heel` holds.
    pub heel_source: HeelSource,
}

/// The internal name of [`Landmarks`].
pub(crate) type Tracks = Landmarks;

impl Landmarks {
    /// Landmarks of a joint-centre clip: pelvis = hip mid-point (else `SpineBase`), heels =
    /// ankles, toes = `FootLeft`/`FootRight` where the clip has them (frame by frame: a frame
    /// without its foot joint keeps the ankle as toe only if the clip has no foot joint at all).
    ///
    /// # Errors
    /// [`Error::MissingJoint`] without ankles or a pelvis.
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
                let hip_mid = match (
                    clip.position(f, Joint::HipLeft),
                    clip.position(f, Joint::HipRight),
                ) {
                    (Some(l), Some(r)) => Some(nalgebra::center(&l, &r)),
                    _ => None,
                };
                if hips && clip.has(Joint::SpineBase) {
                    // Hips preferred; SpineBase bridges a frame that lost a hip (a Kinect
                    // reports SpineBase between the hips, so the two paths agree within a few cm
                    // and the per-frame fallback stays far below a step).
                    hip_mid.or_else(|| clip.position(f, Joint::SpineBase))
                } else if hips {
                    hip_mid
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
            heel_source: HeelSource::AnkleCentre,
        })
    }

    /// Number of frames.
    #[must_use]
    pub fn len(&self) -> usize {
        self.pelvis.len()
    }

    /// Whether there are no frames.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.pelvis.is_empty()
    }

    /// Per frame, whether it can be analysed: the pelvis and both heels have a sample, or one
    /// heel has and the other foot is out of view at an end of the clip (before its first or
    /// after its last sample: not yet in, or already out of, the capture volume), so that foot's
    /// last events are still found. A heel missing between samples is a dropout, a gap, and so
    /// is a foot never seen.
    #[must_use]
    pub fn complete_frames(&self) -> Vec<bool> {
        let seen = |v: &Vec<Option<Point3<f64>>>| {
            let first = v.iter().position(Option::is_some);
            let last = v.iter().rposition(Option::is_some);
            first.zip(last)
        };
        let spans = [seen(&self.heel[0]), seen(&self.heel[1])];
        (0..self.len())
            .map(|f| {
                let ok = |v: &Vec<Option<Point3<f64>>>| v.get(f).copied().flatten().is_some();
                let present = [ok(&self.heel[0]), ok(&self.heel[1])];
                let out_of_view =
                    |k: usize| spans[k].is_some_and(|(first, last)| f < first || f > last);
                ok(&self.pelvis)
                    && present.iter().any(|p| *p)
                    && (0..2).all(|k| present[k] || out_of_view(k))
            })
            .collect()
    }

    pub(crate) fn time(&self, frame: f64) -> f64 {
        frame / self.rate_hz
    }

    /// Checks the shape: a positive rate and tracks of one length.
    pub(crate) fn validate(&self) -> Result<()> {
        if !(self.rate_hz.is_finite() && self.rate_hz > 0.0) {
            return Err(Error::BadParameter {
                name: "rate_hz",
                value: self.rate_hz,
                expected: "a positive frame rate",
            });
        }
        let n = self.len();
        let lengths = self.heel.iter().chain(self.toe.iter()).map(Vec::len);
        for len in lengths {
            if len != n {
                return Err(Error::BadParameter {
                    name: "landmark track length",
                    value: len as f64,
                    expected: "every track as long as the pelvis track",
                });
            }
        }
        Ok(())
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
