//! Spatiotemporal gait parameters per stride and summarised.

use serde::{Deserialize, Serialize};
use trigait_skeleton::MotionClip;

use crate::events::{detect_in_tracks, heel_at};
use crate::segment::{
    ExcludedPhase, ExclusionReason, Segmentation, WalkingSegment, segment_tracks,
};
use crate::signal::{Tracks, horizontal, mean_sd};
use crate::{Error, EventKind, EventParams, Foot, GaitEvent, Result, SegmentParams};

/// One stride: from a heel strike of `foot` to its next heel strike in the same segment.
///
/// Positions are those of the heel stand-in (ankle) at each foot's own heel strike, as in
/// OpenCap's gait analysis; the walking direction is the segment's ([`WalkingSegment`]).
/// Parameters that need the other foot's events inside the stride are `None` when those events
/// were not all seen in the expected order (opposite toe off, opposite heel strike, own toe off).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Stride {
    /// The foot whose two heel strikes bound the stride.
    pub foot: Foot,
    /// Index of the walking segment.
    pub segment: usize,
    /// Time of the first heel strike (s).
    pub start_secs: f64,
    /// Time of the second heel strike (s).
    pub end_secs: f64,
    /// Stride time: between the two heel strikes (s).
    pub stride_time_secs: f64,
    /// Stride length: displacement of the heel between its two heel strikes, along the walking
    /// direction (m).
    pub stride_length_m: f64,
    /// Walking speed over the stride: stride length / stride time (m/s).
    pub speed_mps: f64,
    /// Cadence over the stride: two steps per stride time (steps/min).
    pub cadence_steps_per_min: f64,
    /// Step length of the step that ends the stride: from the opposite heel at its heel strike
    /// inside the stride to this heel at the stride's closing heel strike, along the walking
    /// direction (m).
    pub step_length_m: Option<f64>,
    /// Step width: distance of the opposite heel at its heel strike inside the stride from the
    /// line through this foot's two heel-strike positions, in the horizontal plane (m).
    pub step_width_m: Option<f64>,
    /// Stance: from the first heel strike to this foot's toe off, in % of the stride time.
    pub stance_pct: Option<f64>,
    /// Swing: from this foot's toe off to the closing heel strike, in % (100 − stance).
    pub swing_pct: Option<f64>,
    /// Double support: both feet on the floor, from the first heel strike to the opposite toe
    /// off plus from the opposite heel strike to this foot's toe off, in % of the stride time.
    pub double_support_pct: Option<f64>,
}

/// Mean, sample standard deviation and left/right asymmetry of one parameter over strides.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Stat {
    /// Number of strides with a value.
    pub n: usize,
    /// Mean over all strides; `None` without values.
    pub mean: Option<f64>,
    /// Sample standard deviation (n − 1); `None` below two values.
    pub sd: Option<f64>,
    /// Mean over left strides.
    pub left: Option<f64>,
    /// Mean over right strides.
    pub right: Option<f64>,
    /// Symmetry index of Robinson et al. (1987): |L − R| / ((L + R)/2) × 100 (%); `None` unless
    /// both sides have values and their mean is not zero.
    pub asymmetry_pct: Option<f64>,
}

impl Stat {
    fn of(strides: &[Stride], value: impl Fn(&Stride) -> Option<f64>) -> Self {
        let all: Vec<f64> = strides.iter().filter_map(&value).collect();
        let side = |foot: Foot| -> Option<f64> {
            let v: Vec<f64> = strides
                .iter()
                .filter(|s| s.foot == foot)
                .filter_map(&value)
                .collect();
            mean_sd(&v).0
        };
        let (mean, sd) = mean_sd(&all);
        let (left, right) = (side(Foot::Left), side(Foot::Right));
        let asymmetry_pct = match (left, right) {
            (Some(l), Some(r)) if (l + r).abs() > 1e-12 => {
                Some((l - r).abs() / ((l + r) / 2.0).abs() * 100.0)
            }
            _ => None,
        };
        Self {
            n: all.len(),
            mean,
            sd,
            left,
            right,
            asymmetry_pct,
        }
    }
}

/// The spatiotemporal parameters summarised over strides ([`Stride`] defines each).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    /// Complete strides, both feet.
    pub strides: usize,
    /// Complete left strides.
    pub left_strides: usize,
    /// Complete right strides.
    pub right_strides: usize,
    /// Stride length (m).
    pub stride_length_m: Stat,
    /// Step length (m).
    pub step_length_m: Stat,
    /// Step width (m).
    pub step_width_m: Stat,
    /// Cadence (steps/min).
    pub cadence_steps_per_min: Stat,
    /// Walking speed (m/s).
    pub speed_mps: Stat,
    /// Stride time (s).
    pub stride_time_secs: Stat,
    /// Stance (% of stride).
    pub stance_pct: Stat,
    /// Swing (% of stride).
    pub swing_pct: Stat,
    /// Double support (% of stride).
    pub double_support_pct: Stat,
}

/// Summarises strides: mean, sd and asymmetry of every parameter.
#[must_use]
pub fn summarise(strides: &[Stride]) -> Summary {
    Summary {
        strides: strides.len(),
        left_strides: strides.iter().filter(|s| s.foot == Foot::Left).count(),
        right_strides: strides.iter().filter(|s| s.foot == Foot::Right).count(),
        stride_length_m: Stat::of(strides, |s| Some(s.stride_length_m)),
        step_length_m: Stat::of(strides, |s| s.step_length_m),
        step_width_m: Stat::of(strides, |s| s.step_width_m),
        cadence_steps_per_min: Stat::of(strides, |s| Some(s.cadence_steps_per_min)),
        speed_mps: Stat::of(strides, |s| Some(s.speed_mps)),
        stride_time_secs: Stat::of(strides, |s| Some(s.stride_time_secs)),
        stance_pct: Stat::of(strides, |s| s.stance_pct),
        swing_pct: Stat::of(strides, |s| s.swing_pct),
        double_support_pct: Stat::of(strides, |s| s.double_support_pct),
    }
}

/// Strides from events: every pair of consecutive heel strikes of one foot inside one segment.
///
/// The partial strides before the first and after the last heel strike of each foot give no
/// parameters (their length and duration are unknown); their events still count and are shown.
///
/// # Errors
/// [`Error::MissingJoint`] without ankles or a pelvis.
pub fn strides(
    clip: &MotionClip,
    segmentation: &Segmentation,
    events: &[GaitEvent],
) -> Result<Vec<Stride>> {
    let tracks = Tracks::from_clip(clip)?;
    Ok(strides_in_tracks(&tracks, segmentation, events))
}

fn strides_in_tracks(
    tracks: &Tracks,
    segmentation: &Segmentation,
    events: &[GaitEvent],
) -> Vec<Stride> {
    let mut out = Vec::new();
    for (index, segment) in segmentation.segments.iter().enumerate() {
        let of = |foot: Foot, kind: EventKind| -> Vec<f64> {
            let mut v: Vec<f64> = events
                .iter()
                .filter(|e| e.segment == index && e.foot == foot && e.kind == kind)
                .map(|e| e.frame)
                .collect();
            v.sort_by(f64::total_cmp);
            v
        };
        for foot in Foot::BOTH {
            let strikes = of(foot, EventKind::HeelStrike);
            let own_off = of(foot, EventKind::ToeOff);
            let other_strikes = of(foot.other(), EventKind::HeelStrike);
            let other_off = of(foot.other(), EventKind::ToeOff);
            for pair in strikes.windows(2) {
                let [a, b] = [pair[0], pair[1]];
                if let Some(stride) = stride(
                    tracks,
                    segment,
                    index,
                    foot,
                    (a, b),
                    &own_off,
                    &other_strikes,
                    &other_off,
                ) {
                    out.push(stride);
                }
            }
        }
    }
    out.sort_by(|a, b| a.start_secs.total_cmp(&b.start_secs));
    out
}

fn first_between(frames: &[f64], a: f64, b: f64) -> Option<f64> {
    frames.iter().copied().find(|f| *f > a && *f < b)
}

#[allow(clippy::too_many_arguments)]
fn stride(
    tracks: &Tracks,
    segment: &WalkingSegment,
    segment_index: usize,
    foot: Foot,
    (a, b): (f64, f64),
    own_off: &[f64],
    other_strikes: &[f64],
    other_off: &[f64],
) -> Option<Stride> {
    let d = segment.direction();
    let pa = heel_at(tracks, foot, a)?;
    let pb = heel_at(tracks, foot, b)?;
    let stride_time = (b - a) / tracks.rate_hz;
    if stride_time <= 0.0 {
        return None;
    }
    let stride_vec = horizontal(&(pb - pa));
    let stride_length = stride_vec.dot(&d);
    let other_hs = first_between(other_strikes, a, b);
    let (step_length, step_width) = match other_hs.and_then(|h| heel_at(tracks, foot.other(), h)) {
        Some(po) => {
            let step = horizontal(&(pb - po)).dot(&d);
            let rel = horizontal(&(po - pa));
            let width = if stride_vec.norm() > 1e-6 {
                stride_vec.perp(&rel).abs() / stride_vec.norm()
            } else {
                rel.dot(&segment.left()).abs()
            };
            (Some(step), Some(width))
        }
        None => (None, None),
    };
    // Phases need: HS(a) < TO(other) < HS(other) < TO(own) < HS(b).
    let own_to = first_between(own_off, a, b);
    let stance = own_to.map(|t| (t - a) / (b - a) * 100.0);
    let double_support = match (first_between(other_off, a, b), other_hs, own_to) {
        (Some(oto), Some(ohs), Some(to)) if oto < ohs && ohs < to => {
            Some(((oto - a) + (to - ohs)) / (b - a) * 100.0)
        }
        _ => None,
    };
    Some(Stride {
        foot,
        segment: segment_index,
        start_secs: a / tracks.rate_hz,
        end_secs: b / tracks.rate_hz,
        stride_time_secs: stride_time,
        stride_length_m: stride_length,
        speed_mps: stride_length / stride_time,
        cadence_steps_per_min: 120.0 / stride_time,
        step_length_m: step_length,
        step_width_m: step_width,
        stance_pct: stance,
        swing_pct: stance.map(|s| 100.0 - s),
        double_support_pct: double_support,
    })
}

/// Everything [`analyse`] needs to know.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct GaitParams {
    /// Straight-walking segmentation.
    pub segments: SegmentParams,
    /// Event detection.
    pub events: EventParams,
    /// Fewest complete strides (both feet together) for a result. Default 2.
    pub min_strides: usize,
}

impl Default for GaitParams {
    fn default() -> Self {
        Self {
            segments: SegmentParams::default(),
            events: EventParams::default(),
            min_strides: 2,
        }
    }
}

/// The full result of a gait analysis.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GaitAnalysis {
    /// Sample rate of the analysed clip (Hz).
    pub rate_hz: f64,
    /// Duration of the analysed clip (s).
    pub duration_secs: f64,
    /// Event detector used.
    pub method: crate::EventMethod,
    /// Straight walking segments.
    pub segments: Vec<WalkingSegment>,
    /// Excluded standing, turning, gap and too-short phases.
    pub excluded: Vec<ExcludedPhase>,
    /// All detected events, by time.
    pub events: Vec<GaitEvent>,
    /// Complete strides, by start time.
    pub strides: Vec<Stride>,
    /// Parameters summarised over `strides`.
    pub summary: Summary,
}

impl GaitAnalysis {
    /// Events of one foot and kind, by time.
    pub fn events_of(&self, foot: Foot, kind: EventKind) -> impl Iterator<Item = &GaitEvent> {
        self.events
            .iter()
            .filter(move |e| e.foot == foot && e.kind == kind)
    }
}

/// Segments, detects events, builds strides and summarises them.
///
/// # Errors
/// [`Error::MissingJoint`], [`Error::BadParameter`]; [`Error::NoWalking`] when no straight
/// walking segment is found (standing subject, gaps everywhere, a turn-only clip);
/// [`Error::TooFewStrides`] below [`GaitParams::min_strides`] complete strides.
pub fn analyse(clip: &MotionClip, params: &GaitParams) -> Result<GaitAnalysis> {
    params.segments.validate()?;
    params.events.validate()?;
    let tracks = Tracks::from_clip(clip)?;
    let rate = clip.rate_hz();
    let segmentation = segment_tracks(&tracks, &params.segments);
    if segmentation.segments.is_empty() {
        return Err(Error::NoWalking {
            duration_secs: tracks.len() as f64 / rate,
            standing_secs: segmentation.excluded_secs(ExclusionReason::Standing, rate),
            turning_secs: segmentation.excluded_secs(ExclusionReason::Turning, rate),
            gap_secs: segmentation.excluded_secs(ExclusionReason::Gap, rate),
            short_secs: segmentation.excluded_secs(ExclusionReason::TooShort, rate),
            min_segment_secs: params.segments.min_segment_secs,
        });
    }
    let events = detect_in_tracks(&tracks, &segmentation, &params.events);
    let strides = strides_in_tracks(&tracks, &segmentation, &events);
    if strides.len() < params.min_strides {
        let count = |foot| {
            events
                .iter()
                .filter(|e| e.foot == foot && e.kind == EventKind::HeelStrike)
                .count()
        };
        return Err(Error::TooFewStrides {
            got: strides.len(),
            need: params.min_strides,
            heel_strikes_left: count(Foot::Left),
            heel_strikes_right: count(Foot::Right),
            walking_secs: segmentation.walking_secs(rate),
            standing_secs: segmentation.excluded_secs(ExclusionReason::Standing, rate),
            turning_secs: segmentation.excluded_secs(ExclusionReason::Turning, rate),
            gap_secs: segmentation.excluded_secs(ExclusionReason::Gap, rate),
        });
    }
    let summary = summarise(&strides);
    Ok(GaitAnalysis {
        rate_hz: rate,
        duration_secs: clip.duration_secs(),
        method: params.events.method,
        segments: segmentation.segments,
        excluded: segmentation.excluded,
        events,
        strides,
        summary,
    })
}

/// How far an estimate may be from the reference for [`Comparison::within`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Tolerances {
    /// Largest |Δ mean stride length| (m).
    pub stride_length_m: f64,
    /// Largest |Δ mean cadence| relative to the reference (%).
    pub cadence_pct: f64,
    /// Largest |Δ mean step width| (m).
    pub step_width_m: f64,
}

impl Tolerances {
    /// What the simulated Kinect pipeline must meet against the markers: stride length
    /// within 3 cm, cadence within 2 %, step width within 2 cm.
    pub const ISSUE_5: Tolerances = Tolerances {
        stride_length_m: 0.03,
        cadence_pct: 2.0,
        step_width_m: 0.02,
    };
}

impl Default for Tolerances {
    fn default() -> Self {
        Self::ISSUE_5
    }
}

/// Mean parameters of an estimate against a reference (estimate − reference).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Comparison {
    /// Δ mean stride length (m).
    pub stride_length_m: Option<f64>,
    /// Δ mean step length (m).
    pub step_length_m: Option<f64>,
    /// Δ mean step width (m).
    pub step_width_m: Option<f64>,
    /// Δ mean cadence relative to the reference (%).
    pub cadence_pct: Option<f64>,
    /// Δ mean walking speed (m/s).
    pub speed_mps: Option<f64>,
    /// Δ mean stride time (s).
    pub stride_time_secs: Option<f64>,
    /// Δ mean stance (percentage points).
    pub stance_pct: Option<f64>,
    /// Δ mean double support (percentage points).
    pub double_support_pct: Option<f64>,
}

impl Comparison {
    /// Whether stride length, cadence and step width are all known and within `tol`.
    #[must_use]
    pub fn within(&self, tol: &Tolerances) -> bool {
        let ok = |d: Option<f64>, limit: f64| d.is_some_and(|d| d.abs() <= limit);
        ok(self.stride_length_m, tol.stride_length_m)
            && ok(self.cadence_pct, tol.cadence_pct)
            && ok(self.step_width_m, tol.step_width_m)
    }
}

/// Compares the mean parameters of `estimate` with those of `reference`, e.g. the simulated
/// Kinect pipeline against the markers of the same walk.
#[must_use]
pub fn compare(reference: &Summary, estimate: &Summary) -> Comparison {
    let diff = |r: &Stat, e: &Stat| Some(e.mean? - r.mean?);
    let cadence_pct = match (
        reference.cadence_steps_per_min.mean,
        estimate.cadence_steps_per_min.mean,
    ) {
        (Some(r), Some(e)) if r.abs() > 1e-12 => Some((e - r) / r * 100.0),
        _ => None,
    };
    Comparison {
        stride_length_m: diff(&reference.stride_length_m, &estimate.stride_length_m),
        step_length_m: diff(&reference.step_length_m, &estimate.step_length_m),
        step_width_m: diff(&reference.step_width_m, &estimate.step_width_m),
        cadence_pct,
        speed_mps: diff(&reference.speed_mps, &estimate.speed_mps),
        stride_time_secs: diff(&reference.stride_time_secs, &estimate.stride_time_secs),
        stance_pct: diff(&reference.stance_pct, &estimate.stance_pct),
        double_support_pct: diff(&reference.double_support_pct, &estimate.double_support_pct),
    }
}
