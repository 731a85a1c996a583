//! Outlier rejection and short-gap bridging on the landmark tracks, before any event is sought.
//!
//! Skeleton trackers fail in ways markers do not: a body tracker may snap a joint, or the whole
//! skeleton, onto another body or a piece of furniture for one to a few frames (a jump of 0.3 m
//! or more, thesis §6.4.4 on Kinect joint errors), and the occluded leg's joints are often
//! *inferred* far from the real limb. One such frame read as a foot position makes a false
//! extremum and a false stride. So, per track:
//!
//! 1. **Jumps**: a sample further than [`CleanParams::max_jump_m`] from the coordinate-wise
//!    median of its neighbours within ±[`CleanParams::window_secs`] is rejected (a Hampel
//!    filter with an absolute threshold; the median of a window survives up to half the window
//!    of consecutive outliers, and follows smooth motion — a monotone coordinate's median *is*
//!    the centre sample).
//! 2. **Merged legs** (skeletons only): a body tracker that loses the occluded leg may put
//!    its joints onto the visible one for several frames — the Kinect's trailing ankle, walking
//!    towards it, snaps half a metre forward onto the stance ankle and stays there. Two ankle
//!    centres closer than [`MERGED_ANKLES_M`] while one of them arrived faster than
//!    [`MAX_ANKLE_SPEED_M_S`] (and the other did not) is that snap: the arriving leg's samples are rejected for as
//!    long as the two stay together. A swinging foot that passes the stance foot closely comes
//!    in smoothly and is kept; heel markers never snap and are not checked.
//! 3. **Limb lengths**: a heel further from the pelvis than the track's median distance by more
//!    than [`CleanParams::max_limb_change`] (relative), or a toe whose distance from its heel
//!    differs from the median foot length by more than that, is rejected: legs do not stretch
//!    (they do shorten, when the knee flexes) and feet keep their length.
//! 4. **Bridging**: gaps up to [`CleanParams::max_bridged_gap_secs`] (rejected samples and
//!    dropouts alike) are filled by linear interpolation between their neighbours; longer gaps
//!    stay gaps, so nothing long is invented.
//!
//! Every rejected and bridged sample is counted in [`DataQuality`].

use nalgebra::Point3;
use serde::{Deserialize, Serialize};

use crate::signal::Landmarks;
use crate::{Error, Result};

/// Tuning of [`clean`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CleanParams {
    /// Largest distance (m) of a sample from the median of its window. Default 0.15 m: the
    /// smooth motion of a swinging foot keeps the window median within a few centimetres of the
    /// sample even at 30 Hz, and a tracker snap is 0.3 m or more.
    pub max_jump_m: f64,
    /// Half-width of the median window (s). Default 0.1 s (3 Kinect frames), so up to three
    /// consecutive bad frames are caught.
    pub window_secs: f64,
    /// Largest relative change of the pelvis–heel and heel–toe distances from their medians.
    /// Default 0.3: the pelvis–heel distance of walking varies by about ±10 %. The leg may
    /// shorten freely (knee flexion brings the heel up in running), only not stretch.
    pub max_limb_change: f64,
    /// Longest gap (s) filled by linear interpolation. Default 0.1 s.
    pub max_bridged_gap_secs: f64,
}

impl Default for CleanParams {
    fn default() -> Self {
        Self {
            max_jump_m: 0.15,
            window_secs: 0.1,
            max_limb_change: 0.3,
            max_bridged_gap_secs: 0.1,
        }
    }
}

impl CleanParams {
    pub(crate) fn validate(&self) -> Result<()> {
        for (name, value, ok) in [
            ("max_jump_m", self.max_jump_m, self.max_jump_m > 0.0),
            ("window_secs", self.window_secs, self.window_secs > 0.0),
            (
                "max_limb_change",
                self.max_limb_change,
                self.max_limb_change > 0.0,
            ),
            (
                "max_bridged_gap_secs",
                self.max_bridged_gap_secs,
                self.max_bridged_gap_secs >= 0.0,
            ),
        ] {
            if !(value.is_finite() && ok) {
                return Err(Error::BadParameter {
                    name,
                    value,
                    expected: "a positive finite number",
                });
            }
        }
        Ok(())
    }
}

/// What [`clean`] did to the input, for the report's data-quality notes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct DataQuality {
    /// Samples (over all tracks) in the input.
    pub samples: usize,
    /// Samples missing in the input (dropouts, NaN).
    pub missing_samples: usize,
    /// Samples rejected as single-frame (or few-frame) jumps.
    pub rejected_jumps: usize,
    /// Samples rejected for a leg or foot length far from its median.
    pub rejected_limb_length: usize,
    /// Ankle samples rejected because the tracker put that leg onto the other one.
    #[serde(default)]
    pub rejected_merged_legs: usize,
    /// Samples filled by linear interpolation across short gaps.
    pub bridged_samples: usize,
    /// Samples still missing after bridging.
    pub remaining_gaps: usize,
}

impl DataQuality {
    /// All rejected samples.
    #[must_use]
    pub fn rejected(&self) -> usize {
        self.rejected_jumps + self.rejected_limb_length + self.rejected_merged_legs
    }
}

type Track = Vec<Option<Point3<f64>>>;

/// Rejects outliers and bridges short gaps in every track of `landmarks`, in place.
///
/// # Errors
/// [`Error::BadParameter`] for invalid tuning.
pub fn clean(landmarks: &mut Landmarks, params: &CleanParams) -> Result<DataQuality> {
    params.validate()?;
    let mut q = DataQuality::default();
    let half = ((params.window_secs * landmarks.rate_hz).round() as usize).max(2);
    let max_gap = (params.max_bridged_gap_secs * landmarks.rate_hz + 1e-9).floor() as usize;
    let tracks = std::iter::once(&mut landmarks.pelvis)
        .chain(landmarks.heel.iter_mut())
        .chain(landmarks.toe.iter_mut());
    for track in tracks {
        q.samples += track.len();
        q.missing_samples += track.iter().filter(|p| p.is_none()).count();
        q.rejected_jumps += reject_jumps(track, half, params.max_jump_m);
    }
    if landmarks.heel_source == crate::HeelSource::AnkleCentre {
        let [left, right] = &mut landmarks.heel;
        q.rejected_merged_legs += reject_merged_legs(left, right, landmarks.rate_hz);
    }
    // Leg and foot lengths, against the median of the (jump-free) track.
    for side in 0..2 {
        let pelvis = landmarks.pelvis.clone();
        q.rejected_limb_length += reject_lengths(
            &mut landmarks.heel[side],
            &pelvis,
            params.max_limb_change,
            false,
        );
        let heel = landmarks.heel[side].clone();
        // A toe track that *is* the heel track (no foot joint) has length 0 throughout.
        if heel != landmarks.toe[side] {
            q.rejected_limb_length += reject_lengths(
                &mut landmarks.toe[side],
                &heel,
                params.max_limb_change,
                true,
            );
        }
    }
    let tracks = std::iter::once(&mut landmarks.pelvis)
        .chain(landmarks.heel.iter_mut())
        .chain(landmarks.toe.iter_mut());
    for track in tracks {
        q.bridged_samples += bridge(track, max_gap);
        q.remaining_gaps += track.iter().filter(|p| p.is_none()).count();
    }
    Ok(q)
}

/// The median of `values` (sorted in place; not empty).
pub(crate) fn median(values: &mut [f64]) -> f64 {
    values.sort_by(f64::total_cmp);
    let n = values.len();
    if n % 2 == 1 {
        values[n / 2]
    } else {
        (values[n / 2 - 1] + values[n / 2]) / 2.0
    }
}

/// Hampel-style rejection against the coordinate-wise window median; returns the count.
fn reject_jumps(track: &mut Track, half: usize, max_jump: f64) -> usize {
    let n = track.len();
    let original = track.clone();
    let mut rejected = 0;
    let mut buffers: [Vec<f64>; 3] = [Vec::new(), Vec::new(), Vec::new()];
    for i in 0..n {
        let Some(p) = original[i] else { continue };
        // A symmetric window (pairs of samples j frames before and after, both present), so a
        // steadily moving sample is its window's median also near the clip's ends and gaps.
        let k = half.min(i).min(n - 1 - i);
        for buffer in &mut buffers {
            buffer.clear();
        }
        for (axis, buffer) in buffers.iter_mut().enumerate() {
            buffer.push(p[axis]);
        }
        for j in 1..=k {
            if let (Some(a), Some(b)) = (original[i - j], original[i + j]) {
                for (axis, buffer) in buffers.iter_mut().enumerate() {
                    buffer.push(a[axis]);
                    buffer.push(b[axis]);
                }
            }
        }
        // Too few neighbours to tell a jump from motion.
        if buffers[0].len() < 3 {
            continue;
        }
        let m = Point3::new(
            median(&mut buffers[0]),
            median(&mut buffers[1]),
            median(&mut buffers[2]),
        );
        if (p - m).norm() > max_jump {
            track[i] = None;
            rejected += 1;
        }
    }
    rejected
}

/// Ankle centres closer than this (m) are one leg seen twice, if one of them jumped there: the
/// ankles are ≈ 7 cm thick and pass each other a step width (ankle centres 0.1–0.2 m) apart.
pub const MERGED_ANKLES_M: f64 = 0.10;

/// Faster than this (m/s) an ankle does not move in walking (its swing peaks near 2.5× the
/// walking speed, 3–4 m/s); the snap onto the other leg covered 0.58 m in 62 ms (9 m/s).
pub const MAX_ANKLE_SPEED_M_S: f64 = 6.0;

/// The speed (m/s) at which `track` arrived at frame `f` from its last sample before `f`.
fn arrival_speed(track: &Track, f: usize, rate_hz: f64) -> Option<f64> {
    let p = track[f]?;
    let (before, q) = track[..f]
        .iter()
        .enumerate()
        .rev()
        .find_map(|(i, q)| Some((i, (*q)?)))?;
    Some((p - q).norm() * rate_hz / (f - before) as f64)
}

/// Rejects the ankle samples of a leg that snapped onto the other leg (see the module
/// documentation); returns the count.
fn reject_merged_legs(left: &mut Track, right: &mut Track, rate_hz: f64) -> usize {
    let n = left.len().min(right.len());
    let together = |f: usize| matches!((left[f], right[f]), (Some(a), Some(b)) if (a - b).norm() < MERGED_ANKLES_M);
    let mut rejected = 0;
    for run in trigait_skeleton::frame_runs(n, together) {
        let speeds = [
            arrival_speed(left, run.start, rate_hz),
            arrival_speed(right, run.start, rate_hz),
        ];
        let fast = |s: Option<f64>| s.is_some_and(|s| s > MAX_ANKLE_SPEED_M_S);
        // Both arriving that fast is the whole skeleton jumping (the jump filter's business),
        // not one leg put onto the other.
        let snapped = match speeds.map(fast) {
            [true, false] => &mut *left,
            [false, true] => &mut *right,
            _ => continue,
        };
        for sample in &mut snapped[run] {
            *sample = None;
            rejected += 1;
        }
    }
    rejected
}

/// Smallest allowed length change (m), so tracker noise on a short foot is no violation.
const MIN_LENGTH_SLACK_M: f64 = 0.06;

/// Rejects samples of `track` whose distance from `anchor` differs from the median distance by
/// more than `max_change` (relative, at least [`MIN_LENGTH_SLACK_M`]); returns the count.
/// `shorter` also rejects samples closer than that (rigid segments).
fn reject_lengths(track: &mut Track, anchor: &Track, max_change: f64, shorter: bool) -> usize {
    let mut lengths: Vec<f64> = track
        .iter()
        .zip(anchor)
        .filter_map(|(p, a)| Some((p.as_ref()? - a.as_ref()?).norm()))
        .collect();
    if lengths.len() < 10 {
        return 0;
    }
    let typical = median(&mut lengths);
    if typical < 0.05 {
        return 0;
    }
    let mut rejected = 0;
    for (p, a) in track.iter_mut().zip(anchor) {
        if let (Some(q), Some(a)) = (p.as_ref(), a.as_ref())
            && {
                let change = (q - a).norm() - typical;
                let change = if shorter { change.abs() } else { change };
                change > (max_change * typical).max(MIN_LENGTH_SLACK_M)
            }
        {
            *p = None;
            rejected += 1;
        }
    }
    rejected
}

/// Fills interior gaps of at most `max_gap` samples linearly; returns the filled count.
fn bridge(track: &mut Track, max_gap: usize) -> usize {
    let n = track.len();
    let mut filled = 0;
    for gap in trigait_skeleton::frame_runs(n, |f| track[f].is_none()) {
        let (start, i) = (gap.start, gap.end);
        let len = i - start;
        if start == 0 || i == n || len > max_gap {
            continue;
        }
        if let (Some(a), Some(b)) = (track[start - 1], track[i]) {
            for (k, slot) in track[start..i].iter_mut().enumerate() {
                let t = (k + 1) as f64 / (len + 1) as f64;
                *slot = Some(a + (b - a) * t);
            }
            filled += len;
        }
    }
    filled
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(n: usize, speed: f64, rate: f64) -> Track {
        (0..n)
            .map(|i| Some(Point3::new(speed * i as f64 / rate, 0.0, 0.9)))
            .collect()
    }

    /// A one-frame 0.5 m jump is rejected and bridged; smooth fast motion is untouched.
    #[test]
    fn jump_rejected_motion_kept() {
        let mut t = line(60, 4.0, 30.0);
        let truth = t[20];
        t[20] = t[20].map(|p| p + nalgebra::Vector3::new(0.0, 0.5, 0.0));
        assert_eq!(reject_jumps(&mut t, 3, 0.15), 1);
        assert_eq!(bridge(&mut t, 3), 1);
        assert!((t[20].unwrap() - truth.unwrap()).norm() < 1e-9);
        let mut smooth = line(60, 4.0, 30.0);
        assert_eq!(reject_jumps(&mut smooth, 3, 0.15), 0);
    }

    /// An ankle that jumps onto the other and stays there is rejected for as long as it stays;
    /// one that swings past the other, however closely, is kept.
    #[test]
    fn a_leg_snapped_onto_the_other_is_rejected() {
        let rate = 30.0;
        let stance: Track = (0..30).map(|_| Some(Point3::new(0.0, 0.1, 0.1))).collect();
        // Swinging past at 3 m/s, 4 cm to the side.
        let swing: Track = (0..30)
            .map(|i| Some(Point3::new(-0.5 + 3.0 * i as f64 / rate, 0.06, 0.1)))
            .collect();
        let (mut a, mut b) = (stance.clone(), swing.clone());
        assert_eq!(reject_merged_legs(&mut a, &mut b, rate), 0);
        assert_eq!((a, b), (stance.clone(), swing));
        // Trailing 0.5 m behind, then snapped onto the stance ankle for frames 10..17.
        let snapped: Track = (0..30)
            .map(|i| {
                Some(if (10..17).contains(&i) {
                    Point3::new(0.03, 0.12, 0.1)
                } else {
                    Point3::new(-0.5, -0.1, 0.1)
                })
            })
            .collect();
        let (mut a, mut b) = (stance.clone(), snapped);
        assert_eq!(reject_merged_legs(&mut a, &mut b, rate), 7);
        assert_eq!(a, stance);
        assert!(b[10..17].iter().all(Option::is_none));
        assert!(b[9].is_some() && b[17].is_some());
        // Both ankles jumping together into 8 cm of each other (the whole skeleton glitched)
        // is no merged leg.
        let track = |before: f64, after: f64, y: f64| -> Track {
            (0..30)
                .map(|i| Some(Point3::new(if i < 10 { before } else { after }, y, 0.1)))
                .collect()
        };
        let (mut a, mut b) = (track(0.0, 0.4, 0.0), track(0.8, 0.4, 0.08));
        assert_eq!(reject_merged_legs(&mut a, &mut b, rate), 0);
    }

    /// Gaps longer than the limit, and gaps at the ends, are left alone.
    #[test]
    fn long_gaps_stay() {
        let mut t = line(40, 1.0, 100.0);
        for s in &mut t[10..25] {
            *s = None;
        }
        t[0] = None;
        assert_eq!(bridge(&mut t, 10), 0);
        assert_eq!(t.iter().filter(|p| p.is_none()).count(), 16);
    }
}
