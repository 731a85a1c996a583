//! Straight walking segments: the walking direction is estimated from the pelvis path, and
//! standing, turning and gaps are cut out and reported.

use nalgebra::{Point3, Unit, Vector2};
use serde::{Deserialize, Serialize};
use trigait_skeleton::MotionClip;

use crate::signal::{Tracks, horizontal};
use crate::{Error, Result};

/// Thresholds that decide what counts as straight walking.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SegmentParams {
    /// The pelvis must move at least this fast (horizontal, m/s) for the subject to be walking;
    /// slower is *standing*. Default 0.3 m/s, well below slow pathological gait (≈ 0.6 m/s) and
    /// well above the pelvis sway of a standing person.
    pub min_speed_mps: f64,
    /// Heading changes faster than this (rad/s) are *turning*. Default 0.6 rad/s (≈ 34 °/s): a
    /// 180° turn takes 1–3 s (> 60 °/s), while the stride-averaged heading of straight walking
    /// wanders by a few degrees per second.
    pub max_turn_rate_rad_per_s: f64,
    /// The pelvis velocity is its displacement over this centred window (s), so the lateral
    /// sway and the speed fluctuation within a stride average out. Default 1.0 s ≈ one stride.
    pub velocity_window_secs: f64,
    /// Walking runs shorter than this (s) are dropped as too short. Default 0.8 s.
    pub min_segment_secs: f64,
    /// Gaps (missing joints) up to this long (s) between walking frames do not split a segment,
    /// unless the walking direction differs across the gap by more than the turn rate allows
    /// over one velocity window (a dropout at a reversal).
    /// No event is detected in or next to such a gap, and the gap is still reported, but a
    /// stride whose two heel strikes were both seen may span it. Default 0.1 s (3 Kinect
    /// frames): a tracker dropout in mid-stance should not cost two strides. 0 splits at every
    /// gap.
    pub max_bridged_gap_secs: f64,
}

impl Default for SegmentParams {
    fn default() -> Self {
        Self {
            min_speed_mps: 0.3,
            max_turn_rate_rad_per_s: 0.6,
            velocity_window_secs: 1.0,
            min_segment_secs: 0.8,
            max_bridged_gap_secs: 0.1,
        }
    }
}

impl SegmentParams {
    pub(crate) fn validate(&self) -> Result<()> {
        let positive = |name, value: f64| {
            if value.is_finite() && value > 0.0 {
                Ok(())
            } else {
                Err(Error::BadParameter {
                    name,
                    value,
                    expected: "a positive finite number",
                })
            }
        };
        positive("min_speed_mps", self.min_speed_mps)?;
        positive("max_turn_rate_rad_per_s", self.max_turn_rate_rad_per_s)?;
        positive("velocity_window_secs", self.velocity_window_secs)?;
        positive("min_segment_secs", self.min_segment_secs)?;
        if self.max_bridged_gap_secs.is_finite() && self.max_bridged_gap_secs >= 0.0 {
            Ok(())
        } else {
            Err(Error::BadParameter {
                name: "max_bridged_gap_secs",
                value: self.max_bridged_gap_secs,
                expected: "a non-negative finite number of seconds",
            })
        }
    }
}

/// One straight stretch of walking, in which the walking direction is constant.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WalkingSegment {
    /// First frame (inclusive).
    pub first_frame: usize,
    /// Last frame (inclusive).
    pub last_frame: usize,
    /// Time of the first frame (s).
    pub start_secs: f64,
    /// Time of the last frame (s).
    pub end_secs: f64,
    /// Horizontal unit walking direction in the world frame: from the pelvis position at the
    /// segment start to the one at its end.
    pub direction: [f64; 2],
    /// Pelvis displacement along `direction` divided by the segment duration (m/s).
    pub speed_mps: f64,
}

impl WalkingSegment {
    /// The walking direction as a horizontal unit vector.
    #[must_use]
    pub fn direction(&self) -> Unit<Vector2<f64>> {
        Unit::new_normalize(Vector2::new(self.direction[0], self.direction[1]))
    }

    /// The horizontal unit vector to the walker's left (direction turned +90° about Z).
    #[must_use]
    pub fn left(&self) -> Unit<Vector2<f64>> {
        Unit::new_normalize(Vector2::new(-self.direction[1], self.direction[0]))
    }

    /// Whether `frame` lies inside the segment.
    #[must_use]
    pub fn contains(&self, frame: f64) -> bool {
        frame >= self.first_frame as f64 && frame <= self.last_frame as f64
    }
}

/// Why a stretch of the clip was left out of the gait parameters.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ExclusionReason {
    /// The pelvis moved slower than [`SegmentParams::min_speed_mps`].
    Standing,
    /// The heading changed faster than [`SegmentParams::max_turn_rate_rad_per_s`].
    Turning,
    /// A needed joint was missing (gap or NaN in the input).
    Gap,
    /// Walking, but for less than [`SegmentParams::min_segment_secs`].
    TooShort,
    /// The pelvis travelled, but the feet did not alternate (hopping, jumping, shuffling with
    /// both feet together): not gait, so no strides.
    NotAlternating,
}

impl ExclusionReason {
    /// Lower-case name used in tables and JSON.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            ExclusionReason::Standing => "standing",
            ExclusionReason::Turning => "turning",
            ExclusionReason::Gap => "gap",
            ExclusionReason::TooShort => "too_short",
            ExclusionReason::NotAlternating => "not_alternating",
        }
    }
}

/// A stretch of the clip excluded from the parameters, and why.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ExcludedPhase {
    /// Why it was excluded.
    pub reason: ExclusionReason,
    /// Time of its first frame (s).
    pub start_secs: f64,
    /// Time of its last frame (s).
    pub end_secs: f64,
    /// Frames in it.
    pub frames: usize,
}

/// The result of [`segment_walk`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Segmentation {
    /// Straight walking segments, in time order.
    pub segments: Vec<WalkingSegment>,
    /// Everything else, in time order.
    pub excluded: Vec<ExcludedPhase>,
}

impl Segmentation {
    /// Total time in walking segments (s), counted in frames.
    #[must_use]
    pub fn walking_secs(&self, rate_hz: f64) -> f64 {
        self.segments
            .iter()
            .map(|s| (s.last_frame - s.first_frame + 1) as f64 / rate_hz)
            .fold(0.0, |a, b| a + b)
    }

    /// Total excluded time for `reason` (s), counted in frames.
    #[must_use]
    pub fn excluded_secs(&self, reason: ExclusionReason, rate_hz: f64) -> f64 {
        self.excluded
            .iter()
            .filter(|p| p.reason == reason)
            .map(|p| p.frames as f64 / rate_hz)
            .fold(0.0, |a, b| a + b) // `sum()` of nothing is −0.0, printed "-0.00"
    }

    /// The segment holding `frame`, if any.
    #[must_use]
    pub fn segment_of(&self, frame: f64) -> Option<usize> {
        self.segments.iter().position(|s| s.contains(frame))
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Class {
    Walking,
    Excluded(ExclusionReason),
}

/// Cuts `clip` into straight walking segments and excluded phases.
///
/// Per frame, the pelvis velocity is its horizontal displacement over a centred window of
/// [`SegmentParams::velocity_window_secs`] (truncated at gaps and at the clip ends), which
/// averages out the sway within a stride. A frame is *standing* when that speed is below
/// [`SegmentParams::min_speed_mps`], *turning* when the heading of that velocity changes faster
/// than [`SegmentParams::max_turn_rate_rad_per_s`] (measured over half a window), a *gap* when
/// the pelvis or a heel (ankle) is missing (one heel suffices while the other foot is out of
/// view at an end of the clip, see [`crate::Landmarks::complete_frames`]), and *walking*
/// otherwise. Gaps up to
/// [`SegmentParams::max_bridged_gap_secs`] between walking frames are bridged (and reported).
/// Runs of walking frames at least [`SegmentParams::min_segment_secs`] long become
/// [`WalkingSegment`]s; the
/// walking direction of each is its pelvis start-to-end direction, so it is estimated, not
/// assumed, and holds for that straight stretch only.
///
/// # Errors
/// [`Error::MissingJoint`] without ankles or a pelvis, [`Error::BadParameter`] for invalid
/// thresholds. An empty segmentation is not an error here; [`crate::analyse`] reports it.
pub fn segment_walk(clip: &MotionClip, params: &SegmentParams) -> Result<Segmentation> {
    params.validate()?;
    let tracks = Tracks::from_clip(clip)?;
    Ok(segment_tracks(&tracks, params))
}

pub(crate) fn segment_tracks(tracks: &Tracks, params: &SegmentParams) -> Segmentation {
    let n = tracks.len();
    let rate = tracks.rate_hz;
    let complete = tracks.complete_frames();
    // Bounds of the run of complete frames holding each frame.
    let mut run_start = vec![0usize; n];
    let mut run_end = vec![0usize; n];
    let mut f = 0;
    while f < n {
        if !complete[f] {
            f += 1;
            continue;
        }
        let start = f;
        while f < n && complete[f] {
            f += 1;
        }
        for g in start..f {
            run_start[g] = start;
            run_end[g] = f - 1;
        }
    }
    let half = ((params.velocity_window_secs * rate / 2.0).round() as usize).max(1);
    let velocity = |f: usize| -> Option<Vector2<f64>> {
        if !complete.get(f).copied().unwrap_or(false) {
            return None;
        }
        let a = f.saturating_sub(half).max(run_start[f]);
        let b = (f + half).min(run_end[f]);
        if b <= a {
            return None;
        }
        let pa = tracks.pelvis.get(a).copied().flatten()?;
        let pb = tracks.pelvis.get(b).copied().flatten()?;
        Some(horizontal(&(pb - pa)) * rate / (b - a) as f64)
    };
    let velocities: Vec<Option<Vector2<f64>>> = (0..n).map(velocity).collect();
    let quarter = (half / 2).max(1);
    let classes: Vec<Class> = (0..n)
        .map(|f| {
            let Some(v) = velocities[f] else {
                return Class::Excluded(ExclusionReason::Gap);
            };
            if v.norm() < params.min_speed_mps {
                return Class::Excluded(ExclusionReason::Standing);
            }
            let a = f.saturating_sub(quarter).max(run_start[f]);
            let b = (f + quarter).min(run_end[f]);
            if let (Some(va), Some(vb)) = (velocities[a], velocities[b])
                && b > a
                && va.norm() >= params.min_speed_mps
                && vb.norm() >= params.min_speed_mps
            {
                let turn = va.perp(&vb).atan2(va.dot(&vb));
                let turn_rate = turn.abs() * rate / (b - a) as f64;
                if turn_rate > params.max_turn_rate_rad_per_s {
                    return Class::Excluded(ExclusionReason::Turning);
                }
            }
            Class::Walking
        })
        .collect();

    // Short gaps between walking frames are bridged: the walk goes on across them.
    let max_gap = (params.max_bridged_gap_secs * rate + 1e-9).floor() as usize;
    let mut bridged = vec![false; n];
    let mut f = 0;
    while f < n {
        if classes[f] != Class::Excluded(ExclusionReason::Gap) {
            f += 1;
            continue;
        }
        let start = f;
        while f < n && classes[f] == Class::Excluded(ExclusionReason::Gap) {
            f += 1;
        }
        let walking_around = start > 0
            && classes[start - 1] == Class::Walking
            && classes.get(f) == Some(&Class::Walking);
        // The turn check above cannot see across a gap (velocities stay within a run of
        // complete frames), so a dropout at a sharp reversal would join the two legs. Bridge
        // only when the headings on both sides agree to within what straight walking may turn
        // over one velocity window.
        let same_heading = match (velocities[start.saturating_sub(1)], velocities.get(f)) {
            (Some(va), Some(Some(vb))) => {
                va.perp(vb).atan2(va.dot(vb)).abs()
                    <= params.max_turn_rate_rad_per_s * params.velocity_window_secs
            }
            _ => false,
        };
        if walking_around && same_heading && f - start <= max_gap {
            bridged[start..f].iter_mut().for_each(|b| *b = true);
        }
    }

    let mut segmentation = Segmentation {
        segments: Vec::new(),
        excluded: Vec::new(),
    };
    let min_frames = (params.min_segment_secs * rate).ceil() as usize;
    let walking_like = |f: usize| classes[f] == Class::Walking || bridged[f];
    let mut f = 0;
    while f < n {
        let start = f;
        if walking_like(f) {
            while f < n && walking_like(f) {
                f += 1;
            }
            let end = f - 1;
            let segment = if end + 1 - start >= min_frames.max(2) {
                walking_segment(tracks, start, end)
            } else {
                None
            };
            let walking_reason = if segment.is_some() {
                None
            } else if end + 1 - start >= min_frames.max(2) {
                Some(ExclusionReason::Standing)
            } else {
                Some(ExclusionReason::TooShort)
            };
            segmentation.segments.extend(segment);
            // Report the bridged gaps, and the walking itself when it was too short.
            let mut g = start;
            while g <= end {
                let run = g;
                let gap = bridged[g];
                while g <= end && bridged[g] == gap {
                    g += 1;
                }
                let reason = if gap {
                    Some(ExclusionReason::Gap)
                } else {
                    walking_reason
                };
                if let Some(reason) = reason {
                    segmentation.excluded.push(phase(reason, run, g - 1, rate));
                }
            }
        } else {
            let class = classes[f];
            while f < n && classes[f] == class && !walking_like(f) {
                f += 1;
            }
            if let Class::Excluded(reason) = class {
                segmentation
                    .excluded
                    .push(phase(reason, start, f - 1, rate));
            }
        }
    }
    segmentation
}

fn phase(reason: ExclusionReason, first: usize, last: usize, rate: f64) -> ExcludedPhase {
    ExcludedPhase {
        reason,
        start_secs: first as f64 / rate,
        end_secs: last as f64 / rate,
        frames: last + 1 - first,
    }
}

fn walking_segment(tracks: &Tracks, first: usize, last: usize) -> Option<WalkingSegment> {
    let a: Point3<f64> = tracks.pelvis.get(first).copied().flatten()?;
    let b: Point3<f64> = tracks.pelvis.get(last).copied().flatten()?;
    let travel = horizontal(&(b - a));
    let distance = travel.norm();
    if distance < 1e-6 {
        return None;
    }
    let direction = travel / distance;
    let duration = (last - first) as f64 / tracks.rate_hz;
    Some(WalkingSegment {
        first_frame: first,
        last_frame: last,
        start_secs: first as f64 / tracks.rate_hz,
        end_secs: last as f64 / tracks.rate_hz,
        direction: [direction.x, direction.y],
        speed_mps: distance / duration,
    })
}
