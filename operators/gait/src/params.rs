//! Spatiotemporal gait parameters per stride and summarised.

use nalgebra::{Unit, Vector2};
use serde::{Deserialize, Serialize};
use trigait_skeleton::MotionClip;

use crate::clean::{CleanParams, DataQuality};
use crate::events::{detect_in_tracks, edge_heel_strikes, heel_at, swing_seen};
use crate::physics::{self, FlightPhase, PhysicsParams};
use crate::segment::{
    ExcludedPhase, ExclusionReason, Segmentation, WalkingSegment, segment_tracks,
};
use crate::signal::{HeelSource, Landmarks, Tracks, horizontal, mean_sd, sample};
use crate::treadmill::{self, Treadmill, TreadmillMode};
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
    /// How far the pelvis moved along the walking direction between the two heel strikes (m);
    /// `None` where the pelvis is not seen at either. Over a stride the body travels one
    /// stride length.
    #[serde(default)]
    pub pelvis_travel_m: Option<f64>,
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
    /// Whether the figure rests on single steps (heel strike to the other foot's heel strike)
    /// because no complete stride gave it; `n` then counts steps.
    #[serde(default)]
    pub from_steps: bool,
}

impl Stat {
    fn of(strides: &[Stride], value: impl Fn(&Stride) -> Option<f64>) -> Self {
        Self::of_footed(strides.iter().map(|s| (s.foot, value(s))), false)
    }

    /// `self`, or when it has no value, the same figure from single steps.
    fn or_steps(self, steps: &[Step], value: impl Fn(&Step) -> Option<f64>) -> Self {
        if self.n > 0 {
            return self;
        }
        Self::of_footed(steps.iter().map(|s| (s.foot, value(s))), true)
    }

    /// Mean, SD, per-foot means and asymmetry of the values present, each with its foot.
    fn of_footed(samples: impl Iterator<Item = (Foot, Option<f64>)>, from_steps: bool) -> Self {
        let samples: Vec<(Foot, f64)> = samples.filter_map(|(f, v)| Some((f, v?))).collect();
        let all: Vec<f64> = samples.iter().map(|(_, v)| *v).collect();
        let side = |foot: Foot| -> Option<f64> {
            let v: Vec<f64> = samples
                .iter()
                .filter(|(f, _)| *f == foot)
                .map(|(_, v)| *v)
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
            from_steps,
        }
    }
}

/// One step: from a heel strike of one foot to the next heel strike of the other, inside one
/// segment. Steps give cadence, step length and width where a walk is too short for strides.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Step {
    /// The foot whose heel strike ends the step.
    pub foot: Foot,
    /// Index of the walking segment.
    pub segment: usize,
    /// Time of the opening heel strike (s).
    pub start_secs: f64,
    /// Time of the closing heel strike (s).
    pub end_secs: f64,
    /// Step time (s).
    pub step_time_secs: f64,
    /// Cadence of this step: 60 / step time (steps/min).
    pub cadence_steps_per_min: f64,
    /// Heel-to-heel distance along the segment's walking direction (m).
    pub step_length_m: Option<f64>,
    /// Heel-to-heel distance across the segment's walking direction (m).
    pub step_width_m: Option<f64>,
    /// How far the pelvis moved along the walking direction between the two heel strikes (m);
    /// `None` where the pelvis is not seen at either. Over a step the body travels about one
    /// step length, so the two disagreeing shows events in the wrong place.
    #[serde(default)]
    pub pelvis_travel_m: Option<f64>,
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
    /// Single steps (heel strike to the other foot's heel strike).
    #[serde(default)]
    pub steps: usize,
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

/// One parameter of a [`Summary`] as its tables show it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SummaryRow<'a> {
    /// The parameter and its unit, e.g. `"stride length (m)"`.
    pub label: &'static str,
    /// Its figures.
    pub stat: &'a Stat,
    /// Decimals shown: millimetres for lengths and speed, milliseconds for times, tenths for
    /// cadence and percentages.
    pub digits: usize,
    /// Whether the figure scales with the clip's time base (a duration, or something per
    /// second or minute): wrong with it when the frame rate is wrong. Lengths and the phase
    /// percentages are not.
    pub timed: bool,
}

impl Summary {
    /// Every parameter in the order, with the labels and decimals, that every table of them
    /// uses: `trigait gait`'s text, the HTML report and the recorder's live table.
    #[must_use]
    pub fn rows(&self) -> [SummaryRow<'_>; 9] {
        let row = |label, stat, digits, timed| SummaryRow {
            label,
            stat,
            digits,
            timed,
        };
        [
            row("stride length (m)", &self.stride_length_m, 3, false),
            row("step length (m)", &self.step_length_m, 3, false),
            row("step width (m)", &self.step_width_m, 3, false),
            row("cadence (steps/min)", &self.cadence_steps_per_min, 1, true),
            row("speed (m/s)", &self.speed_mps, 3, true),
            row("stride time (s)", &self.stride_time_secs, 3, true),
            row("stance (%)", &self.stance_pct, 1, false),
            row("swing (%)", &self.swing_pct, 1, false),
            row("double support (%)", &self.double_support_pct, 1, false),
        ]
    }
}

/// Summarises strides: mean, sd and asymmetry of every parameter.
#[must_use]
pub fn summarise(strides: &[Stride]) -> Summary {
    summarise_with_steps(strides, &[])
}

/// Summarises strides, and where no stride gives a figure (cadence, step length, step width,
/// stride time), the single steps: a 10 m walkway may show one stride or none, yet several
/// steps. [`Stat::from_steps`] says which figures rest on steps.
#[must_use]
pub fn summarise_with_steps(strides: &[Stride], steps: &[Step]) -> Summary {
    let mut s = summarise_strides(strides);
    s.cadence_steps_per_min = s
        .cadence_steps_per_min
        .or_steps(steps, |st| Some(st.cadence_steps_per_min));
    s.step_length_m = s.step_length_m.or_steps(steps, |st| st.step_length_m);
    s.step_width_m = s.step_width_m.or_steps(steps, |st| st.step_width_m);
    s.steps = steps.len();
    s
}

fn summarise_strides(strides: &[Stride]) -> Summary {
    Summary {
        steps: 0,
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

/// Steps from events: each heel strike followed, before its own foot's next one, by a heel strike
/// of the other foot in the same segment.
fn steps_in_tracks(
    tracks: &Tracks,
    segmentation: &Segmentation,
    events: &[GaitEvent],
) -> Vec<Step> {
    let mut out = Vec::new();
    for (index, segment) in segmentation.segments.iter().enumerate() {
        let d = segment.direction();
        let left = segment.left();
        let strikes: Vec<&GaitEvent> = events
            .iter()
            .filter(|e| e.segment == index && e.kind == EventKind::HeelStrike)
            .collect();
        for pair in strikes.windows(2) {
            let (a, b) = (pair[0], pair[1]);
            if a.foot == b.foot {
                continue;
            }
            let time = (b.frame - a.frame) / tracks.rate_hz;
            if time <= 0.0 {
                continue;
            }
            let positions = heel_at(tracks, a.foot, a.frame).zip(heel_at(tracks, b.foot, b.frame));
            let (length, width) = match positions {
                Some((pa, pb)) => {
                    let v = horizontal(&(pb - pa));
                    (Some(v.dot(&d)), Some(v.dot(&left).abs()))
                }
                None => (None, None),
            };
            out.push(Step {
                foot: b.foot,
                segment: index,
                start_secs: a.time_secs,
                end_secs: b.time_secs,
                step_time_secs: time,
                cadence_steps_per_min: 60.0 / time,
                step_length_m: length,
                step_width_m: width,
                pelvis_travel_m: pelvis_travel(tracks, &d, a.frame, b.frame),
            });
        }
    }
    out
}

fn first_between(frames: &[f64], a: f64, b: f64) -> Option<f64> {
    frames.iter().copied().find(|f| *f > a && *f < b)
}

/// The shortest ground contact of a running foot, s: elite sprinters' last 80–100 ms.
const MIN_RUNNING_CONTACT_SECS: f64 = 0.08;

/// The shortest ground contact of a walking foot, s. Walking keeps a foot down for more than
/// half the stride (0.5–0.8 s), and even elite race walkers, at up to 4 m/s the fastest
/// walking there is, stay on the ground close to 0.3 s per step (Hanley 2014).
const MIN_WALKING_CONTACT_SECS: f64 = 0.25;

/// Resolves each heel strike whose own foot's next event in its segment is a toe off less than
/// `min_contact_secs` later, and returns how many events it dropped.
///
/// No foot lands and leaves that quickly, so one of the two is noise: on a noisy stream a
/// one-frame wobble of the ankle peaks like a heel strike in late stance (a segment's first
/// frames: one 0.44 s stride among sixteen put a walker's cadence 9 % high) or dips like a toe
/// off in early stance (a segment's last frames). The one whose peak stands out less goes;
/// without both prominences (the velocity method), the heel strike goes, as the toe off ends a
/// stance that began at a heel strike before.
fn drop_short_contacts(events: &mut Vec<GaitEvent>, rate_hz: f64, min_contact_secs: f64) -> usize {
    let mut order: Vec<usize> = (0..events.len()).collect();
    order.sort_by(|&a, &b| {
        let (ea, eb) = (&events[a], &events[b]);
        (ea.foot, ea.segment)
            .cmp(&(eb.foot, eb.segment))
            .then(ea.frame.total_cmp(&eb.frame))
    });
    let mut dropped = vec![false; events.len()];
    // The last kept event of the same foot and segment.
    let mut previous: Option<usize> = None;
    for i in order {
        let e = &events[i];
        // The heel strike this toe off follows too soon, and whether the toe off is the
        // less prominent of the two.
        let short = previous
            .filter(|&p| {
                let hs = &events[p];
                hs.foot == e.foot
                    && hs.segment == e.segment
                    && hs.kind == EventKind::HeelStrike
                    && e.kind == EventKind::ToeOff
                    && (e.frame - hs.frame) / rate_hz < min_contact_secs
            })
            .map(|p| {
                let fainter = matches!(
                    (events[p].prominence_m, e.prominence_m),
                    (Some(h), Some(t)) if t < h
                );
                (p, fainter)
            });
        match short {
            Some((_, true)) => dropped[i] = true,
            Some((p, false)) => {
                dropped[p] = true;
                previous = Some(i);
            }
            None => previous = Some(i),
        }
    }
    let count = dropped.iter().filter(|d| **d).count();
    let mut flags = dropped.into_iter();
    events.retain(|_| !flags.next().unwrap_or(false));
    count
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
        pelvis_travel_m: pelvis_travel(tracks, &d, a, b),
    })
}

/// The pelvis's displacement along `direction` from frame `a` to frame `b` (m), `None` where it
/// is not seen at either.
fn pelvis_travel(tracks: &Tracks, direction: &Unit<Vector2<f64>>, a: f64, b: f64) -> Option<f64> {
    let pa = sample(&tracks.pelvis, a)?;
    let pb = sample(&tracks.pelvis, b)?;
    Some(horizontal(&(pb - pa)).dot(direction))
}

/// Everything [`analyse`] needs to know.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct GaitParams {
    /// Straight-walking segmentation.
    pub segments: SegmentParams,
    /// Event detection.
    pub events: EventParams,
    /// Fewest complete strides (both feet together) for a result. Default 0: figures then rest
    /// on single steps where no stride exists, and the result says so; at least one step or
    /// stride is always needed.
    pub min_strides: usize,
    /// Outlier rejection and gap bridging before the events.
    pub clean: CleanParams,
    /// Airborne checks and flight phases.
    pub physics: PhysicsParams,
    /// Treadmill or overground.
    pub treadmill: TreadmillMode,
    /// Left and right heel signals must correlate below this (−1 = perfect alternation) for a
    /// segment to be gait. Default −0.3: walking and running give −0.8 to −1, two-footed hops
    /// and jumps +0.5 to +1.
    pub max_alternation_correlation: f64,
    /// Low-pass filter of the landmarks, applied after the cleaning: a tracker's jump is
    /// rejected as the outlier it is before a filter could smear it over its neighbours and
    /// make it look like motion. Default none (marker data needs none); `trigait gait` filters
    /// skeleton streams by default.
    #[serde(default)]
    pub filter: crate::filter::Filter,
}

impl Default for GaitParams {
    fn default() -> Self {
        Self {
            segments: SegmentParams::default(),
            events: EventParams::default(),
            min_strides: 0,
            clean: CleanParams::default(),
            physics: PhysicsParams::default(),
            treadmill: TreadmillMode::Auto,
            max_alternation_correlation: -0.3,
            filter: crate::filter::Filter::None,
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
    /// Event detector used (never `Auto`: the one it chose).
    pub method: crate::EventMethod,
    /// Whether the clip was found to be running (flight phases), which chose the velocity
    /// method when the method was `Auto`.
    pub running: bool,
    /// Flight phases (both feet off the floor), in time order.
    pub flights: Vec<FlightPhase>,
    /// The treadmill correction applied, if any: stride and step length and speed are then
    /// belt-corrected.
    pub treadmill: Option<Treadmill>,
    /// What stood in for the heels (event detection and step width).
    pub heel_source: HeelSource,
    /// Rejected and bridged samples.
    pub quality: DataQuality,
    /// The floor fitted under the resting feet, and whether the landmarks were rotated to
    /// level it (a tracker's camera frame is tilted); `None` when the feet never rested over a
    /// long enough stretch (treadmill, stepping in place).
    #[serde(default)]
    pub floor: Option<crate::floor::FloorLevel>,
    /// Events the detectors proposed that were dropped because the foot was airborne.
    pub rejected_events: usize,
    /// Events dropped because a heel strike and its own toe off came sooner after each other
    /// than a foot leaves the floor (0.25 s walking, 80 ms running): the less prominent of the
    /// two.
    #[serde(default)]
    pub short_contacts: usize,
    /// Events dropped because the foot did not swing next to them: a heel strike whose foot
    /// had not moved forward [`crate::events::MIN_SWING_TRAVEL_M`] in the
    /// [`crate::events::SWING_WINDOW_SECS`] before it, a toe off whose foot did not in that time
    /// after it (a tracker's ankle wobbling in stance).
    #[serde(default)]
    pub stationary_events: usize,
    /// Single steps, by start time.
    pub steps: Vec<Step>,
    /// Straight walking segments.
    pub segments: Vec<WalkingSegment>,
    /// Excluded standing, turning, gap and too-short phases.
    pub excluded: Vec<ExcludedPhase>,
    /// All detected events, by time.
    pub events: Vec<GaitEvent>,
    /// Complete strides, by start time.
    pub strides: Vec<Stride>,
    /// Strides left out of every figure because their length and the pelvis's travel between
    /// their heel strikes disagree ([`MAX_TRAVEL_MISMATCH_M`]): one of their events is not
    /// where the foot landed.
    #[serde(default)]
    pub inconsistent_strides: Vec<Stride>,
    /// Steps left out likewise.
    #[serde(default)]
    pub inconsistent_steps: Vec<Step>,
    /// Parameters summarised over `strides`.
    pub summary: Summary,
    /// Whether the swings and steps keep a human rhythm at `rate_hz` (a wrong time base
    /// shows here first).
    #[serde(default)]
    pub timing: crate::Timing,
}

impl GaitAnalysis {
    /// Events of one foot and kind, by time.
    pub fn events_of(&self, foot: Foot, kind: EventKind) -> impl Iterator<Item = &GaitEvent> {
        self.events
            .iter()
            .filter(move |e| e.foot == foot && e.kind == kind)
    }
}

/// Segments, detects events, builds strides and summarises them; see [`analyse_landmarks`].
///
/// # Errors
/// As [`analyse_landmarks`], and [`Error::MissingJoint`] without ankles or a pelvis.
pub fn analyse(clip: &MotionClip, params: &GaitParams) -> Result<GaitAnalysis> {
    let landmarks = Landmarks::from_clip(clip)?;
    analyse_landmarks(&landmarks, params)
}

/// Steps 1–5 of [`analyse_landmarks`]: the cleaned tracks, their walking segments and the events
/// the parameters rest on, with what was dropped on the way. Without a walking segment there are
/// no events; [`analyse_landmarks`] then says why there is no walking. A live analysis reports
/// these events as they settle, so what it shows is what its parameters use.
#[derive(Debug, Clone)]
pub(crate) struct Detection {
    /// The tracks after cleaning, floor levelling and any treadmill correction.
    pub(crate) tracks: Tracks,
    pub(crate) quality: DataQuality,
    pub(crate) floor: Option<crate::floor::FloorLevel>,
    pub(crate) flights: Vec<FlightPhase>,
    pub(crate) treadmill: Option<Treadmill>,
    pub(crate) segmentation: Segmentation,
    pub(crate) running: bool,
    pub(crate) method: crate::EventMethod,
    /// Proposed events dropped because the foot was airborne.
    pub(crate) rejected_events: usize,
    /// Proposed events dropped as one of a too short contact.
    pub(crate) short_contacts: usize,
    /// Proposed events dropped because the foot was not seen swinging next to them.
    pub(crate) stationary_events: usize,
    /// The events kept, in time order.
    pub(crate) events: Vec<GaitEvent>,
}

/// Every landmark track of `tracks` filtered by `filter`, gaps kept.
fn filter_tracks(tracks: &mut Tracks, filter: &crate::filter::Filter) -> Result<()> {
    if *filter == crate::filter::Filter::None {
        return Ok(());
    }
    let rate = tracks.rate_hz;
    let [h0, h1] = &mut tracks.heel;
    let [t0, t1] = &mut tracks.toe;
    for track in [&mut tracks.pelvis, h0, h1, t0, t1] {
        *track = filter.apply_track(track, rate)?;
    }
    Ok(())
}

/// The events of landmark tracks: steps 1–5 of [`analyse_landmarks`] ([`Detection`]).
///
/// # Errors
/// [`Error::BadParameter`], or invalid landmarks.
pub(crate) fn detect(landmarks: &Landmarks, params: &GaitParams) -> Result<Detection> {
    params.segments.validate()?;
    params.events.validate()?;
    params.physics.validate()?;
    landmarks.validate()?;
    let mut tracks = landmarks.clone();
    let quality = crate::clean::clean(&mut tracks, &params.clean)?;
    filter_tracks(&mut tracks, &params.filter)?;
    let floor = crate::floor::level(&mut tracks);
    let heights = physics::heights(&tracks, &params.physics);
    let treadmill = treadmill::correct(&mut tracks, &heights, params.treadmill);
    let rate = tracks.rate_hz;
    let mut segmentation = segment_tracks(&tracks, &params.segments);
    exclude_non_alternating(
        &tracks,
        &mut segmentation,
        params.max_alternation_correlation,
    );
    let walking_frames: usize = segmentation
        .segments
        .iter()
        .map(|s| s.last_frame - s.first_frame + 1)
        .sum();
    let flight_frames: usize = segmentation
        .segments
        .iter()
        .map(|s| heights.flight_frames(s.first_frame, s.last_frame))
        .sum();
    let flight_count = heights
        .flights
        .iter()
        .filter(|p| {
            segmentation
                .segments
                .iter()
                .any(|s| p.first_frame <= s.last_frame && p.last_frame >= s.first_frame)
        })
        .count();
    let walking_secs = walking_frames as f64 / rate;
    let running = walking_frames > 0
        && flight_frames as f64 >= crate::events::RUNNING_FLIGHT_FRACTION * walking_frames as f64
        && flight_count as f64 >= crate::events::RUNNING_MIN_FLIGHTS_PER_SEC * walking_secs;
    let proposed = detect_in_tracks(&tracks, &segmentation, &params.events, running);
    let proposed_count = proposed.len();
    let mut events: Vec<GaitEvent> = proposed
        .into_iter()
        .filter(|e| {
            heights.allows(
                e.foot,
                e.kind == EventKind::HeelStrike,
                e.frame,
                params.physics.event_gate_m,
                running,
            )
        })
        .collect();
    let rejected_events = proposed_count - events.len();
    let before = events.len();
    events.retain(|e| swing_seen(&tracks, &segmentation, e));
    let stationary_events = before - events.len();
    let method = params.events.method.for_clip(running);
    if tracks.heel_source == HeelSource::HeelMarker {
        // Edge candidates skip the swing check: `refine_heel_strikes` keeps one only where the
        // heel marker is seen still swinging (faster than 0.5 m/s) and then landing.
        let edges = if method == crate::EventMethod::Coordinate {
            let separation = params.events.min_separation_secs * rate;
            edge_heel_strikes(&tracks, &segmentation, &params.events)
                .into_iter()
                .filter(|e| {
                    heights.allows(e.foot, true, e.frame, params.physics.event_gate_m, running)
                        && !events.iter().any(|o| {
                            o.foot == e.foot
                                && o.kind == EventKind::HeelStrike
                                && (o.frame - e.frame).abs() < separation
                        })
                })
                .collect()
        } else {
            Vec::new()
        };
        refine_heel_strikes(&tracks, &mut events, edges, treadmill.is_some());
        if !running {
            refine_toe_offs(&tracks, &mut events);
        }
    }
    let min_contact_secs = if running {
        MIN_RUNNING_CONTACT_SECS
    } else {
        MIN_WALKING_CONTACT_SECS
    };
    let short_contacts = drop_short_contacts(&mut events, rate, min_contact_secs);
    Ok(Detection {
        tracks,
        quality,
        floor,
        flights: heights.flights,
        treadmill,
        segmentation,
        running,
        method,
        rejected_events,
        short_contacts,
        stationary_events,
        events,
    })
}

/// The full analysis of landmark tracks:
///
/// 1. outliers rejected and short gaps bridged ([`crate::clean()`]), then the
///    [`GaitParams::filter`], and the floor levelled when the landmarks' frame is tilted
///    ([`crate::floor`]);
/// 2. stance levels and flight phases ([`crate::physics`]);
/// 3. the treadmill correction when declared or detected ([`crate::treadmill`]);
/// 4. straight walking segments; a segment whose feet do not alternate is excluded
///    ([`ExclusionReason::NotAlternating`]);
/// 5. events (method chosen for walking or running when `Auto`), dropping any whose foot is
///    airborne, any whose foot does not swing next to it (a heel strike must end a swing, a
///    toe off start one: [`crate::events::MIN_SWING_TRAVEL_M`]), and one of each heel strike
///    and toe off too close together for a contact;
/// 6. strides, steps and their summary.
///
/// # Errors
/// [`Error::BadParameter`]; [`Error::NoWalking`] when no straight, alternating walking segment
/// is found (standing subject, gaps everywhere, a turn-only clip, hopping);
/// [`Error::TooFewStrides`] below [`GaitParams::min_strides`] complete strides, or with neither
/// a stride nor a step.
pub fn analyse_landmarks(landmarks: &Landmarks, params: &GaitParams) -> Result<GaitAnalysis> {
    analyse_detection(detect(landmarks, params)?, params)
}

/// Step 6 of [`analyse_landmarks`]: strides, steps and their summary from the events found.
///
/// # Errors
/// As [`analyse_landmarks`], but for bad parameters.
pub(crate) fn analyse_detection(d: Detection, params: &GaitParams) -> Result<GaitAnalysis> {
    let rate = d.tracks.rate_hz;
    let segmentation = d.segmentation;
    if segmentation.segments.is_empty() {
        return Err(Error::NoWalking {
            duration_secs: d.tracks.len() as f64 / rate,
            standing_secs: segmentation.excluded_secs(ExclusionReason::Standing, rate),
            turning_secs: segmentation.excluded_secs(ExclusionReason::Turning, rate),
            gap_secs: segmentation.excluded_secs(ExclusionReason::Gap, rate),
            short_secs: segmentation.excluded_secs(ExclusionReason::TooShort, rate),
            not_alternating_secs: segmentation.excluded_secs(ExclusionReason::NotAlternating, rate),
            min_segment_secs: params.segments.min_segment_secs,
        });
    }
    let events = d.events;
    let (strides, inconsistent_strides): (Vec<Stride>, Vec<Stride>) =
        strides_in_tracks(&d.tracks, &segmentation, &events)
            .into_iter()
            .partition(|s| travel_agrees(s.stride_length_m, s.pelvis_travel_m));
    let (steps, inconsistent_steps): (Vec<Step>, Vec<Step>) =
        steps_in_tracks(&d.tracks, &segmentation, &events)
            .into_iter()
            .partition(|s| {
                s.step_length_m
                    .is_none_or(|l| travel_agrees(l, s.pelvis_travel_m))
            });
    let strides: Vec<Stride> = strides
        .into_iter()
        .map(|s| without_doubtful_steps(s, &inconsistent_steps))
        .collect();
    if strides.len() < params.min_strides || (strides.is_empty() && steps.is_empty()) {
        let count = |foot| {
            events
                .iter()
                .filter(|e| e.foot == foot && e.kind == EventKind::HeelStrike)
                .count()
        };
        return Err(Error::TooFewStrides {
            got: strides.len(),
            need: params.min_strides,
            steps: steps.len(),
            heel_strikes_left: count(Foot::Left),
            heel_strikes_right: count(Foot::Right),
            walking_secs: segmentation.walking_secs(rate),
            standing_secs: segmentation.excluded_secs(ExclusionReason::Standing, rate),
            turning_secs: segmentation.excluded_secs(ExclusionReason::Turning, rate),
            gap_secs: segmentation.excluded_secs(ExclusionReason::Gap, rate),
        });
    }
    let summary = summarise_with_steps(&strides, &steps);
    let walking_speeds: Vec<f64> = if d.running {
        Vec::new()
    } else {
        strides.iter().map(|s| s.speed_mps).collect()
    };
    let timing = crate::timing::check(&events, &steps, &walking_speeds, rate);
    Ok(GaitAnalysis {
        rate_hz: rate,
        duration_secs: d.tracks.len().saturating_sub(1) as f64 / rate,
        method: d.method,
        running: d.running,
        flights: d.flights,
        treadmill: d.treadmill,
        heel_source: d.tracks.heel_source,
        quality: d.quality,
        floor: d.floor,
        rejected_events: d.rejected_events,
        short_contacts: d.short_contacts,
        stationary_events: d.stationary_events,
        segments: segmentation.segments,
        excluded: segmentation.excluded,
        events,
        strides,
        steps,
        inconsistent_strides,
        inconsistent_steps,
        summary,
        timing,
    })
}

/// `stride` without the figures it takes from the other foot's heel strike inside it (step
/// length, step width, double support) when a left-out step begins or ends inside it: that
/// heel strike may be the one that is not a landing. The stride's own length and times rest
/// on its own two heel strikes and stay.
fn without_doubtful_steps(stride: Stride, left_out: &[Step]) -> Stride {
    let inside = |t: f64| t > stride.start_secs && t < stride.end_secs;
    if left_out
        .iter()
        .any(|s| inside(s.start_secs) || inside(s.end_secs))
    {
        Stride {
            step_length_m: None,
            step_width_m: None,
            double_support_pct: None,
            ..stride
        }
    } else {
        stride
    }
}

/// Largest disagreement (m) between a step's or stride's length and how far the pelvis moved
/// between its heel strikes, before they are taken as the events being wrong; beyond
/// [`MAX_TRAVEL_MISMATCH_SHARE`] of the pelvis's travel too.
///
/// Over a step the body travels about the step length, whatever the clock: the two differ only
/// by how far the pelvis sits behind each leading heel at its strike, which differs between
/// the sides in a limp. On every recording in `shared/data` (force-plate walks of adults and
/// children, a split-belt treadmill, CMU, OpenSim, and the Kinect SDK logs with every filter
/// `trigait gait` offers) the two are within 0.10 m for steps and within 9 % for strides. A
/// heel strike put on a Kinect ankle's wobble gave a step of 0.58 m in 0.26 s while the pelvis
/// moved 0.21 m (2.8 times less): the step's rhythm and length were both the wobble's.
pub const MAX_TRAVEL_MISMATCH_M: f64 = 0.2;

/// See [`MAX_TRAVEL_MISMATCH_M`]: a stride, longer, may differ from the pelvis's travel by this
/// share of it (on the recordings, at most 9 %). A heel strike put in the middle of a stance
/// shortens the time, and so the travel, but not the heel-to-heel length.
pub const MAX_TRAVEL_MISMATCH_SHARE: f64 = 0.25;

/// Whether a heel-to-heel `length` agrees with the pelvis's `travel` between the same heel
/// strikes; an unknown travel agrees (nothing to check against).
fn travel_agrees(length: f64, travel: Option<f64>) -> bool {
    travel.is_none_or(|t| {
        (length - t).abs() <= MAX_TRAVEL_MISMATCH_M.max(MAX_TRAVEL_MISMATCH_SHARE * t.abs())
    })
}

/// The heel marker stops descending this slowly (m/s) when it lands: well below the swing's
/// 0.3–0.6 m/s descent, above marker jitter at 100 Hz.
const HEEL_LANDED_MPS: f64 = 0.02;

/// A heel marker moving horizontally faster than this (m/s) is still swinging, not on the
/// floor: the heel-contact threshold of Ghoussayni et al. (2004), who applied it to the heel
/// marker's sagittal speed (here the horizontal part; the vertical part is the other landing
/// condition). At the 20 N instants of the force-plate recordings in `shared/data` the heel
/// marker moves at 0.07–0.49 m/s overground and 0.28–0.59 m/s relative to the belt.
///
/// Not chosen from the recordings, but checked on all of them (sweep of 0.3–1.0 m/s): 0.3
/// loses treadmill contacts and puts BTS 21 ms late, 0.4 puts BTS's cadence off by 1.6 %; from
/// 0.6 up the plate contacts are unchanged, but a child's off-plate strike that the lab
/// labelled moves early (HC039A17's cadence +0.96 % at 0.6, +1.3 % at 0.8, +1.6 % at 1.0).
const HEEL_SLIDING_MPS: f64 = 0.5;

/// On a treadmill the heel marker has landed once it is within this height (m) of its lowest
/// point over the [`HEEL_STANCE_LOW_SECS`] after the candidate: the last millimetre of the
/// 1–3 mm it sinks after meeting the belt. Swept on the treadmill recording's 21 contacts:
/// heel-strike mean |error| 6.0 ms at 0.5 mm, 5.1 ms at 1 mm, 5.6 ms at 1.5 mm, 6.6 ms at 2 mm
/// (which also puts the last contact more than 30 ms early), 7.8 ms at 3 mm.
const BELT_LANDED_M: f64 = 0.001;

/// How far after the candidate the heel's early-stance low is looked for (s): within the
/// stance that follows, before heel rise.
const HEEL_STANCE_LOW_SECS: f64 = 0.3;

/// How far after the coordinate method's heel strike the landing is sought (s).
const HEEL_LANDING_SEARCH_SECS: f64 = 0.12;

/// Where the heel marker of `foot` lands after the candidate at `frame`: `(frame, seen)`, with
/// `seen` true when the heel was still swinging at the first frame searched (moving
/// horizontally faster than [`HEEL_SLIDING_MPS`]), so that the whole landing was observed.
/// `None` when no landing is found within [`HEEL_LANDING_SEARCH_SECS`].
fn heel_landing(tracks: &Tracks, foot: Foot, frame: f64, on_belt: bool) -> Option<(f64, bool)> {
    let rate = tracks.rate_hz;
    let track = &tracks.heel[foot.index()];
    let at = |f: usize| track.get(f).copied().flatten();
    let start = frame.floor().max(1.0) as usize;
    let search = (HEEL_LANDING_SEARCH_SECS * rate).ceil() as usize;
    let low = (start..=start + (HEEL_STANCE_LOW_SECS * rate).round() as usize)
        .filter_map(|f| at(f).map(|p| p.z))
        .fold(f64::INFINITY, f64::min);
    // (the landing condition's quantity that must fall below its limit, horizontal speed):
    // overground the downward speed, on a belt the height above the early-stance low.
    let state = |f: usize| -> Option<(f64, f64)> {
        let (a, here, b) = (at(f.checked_sub(1)?)?, at(f)?, at(f + 1)?);
        let descent = if on_belt {
            here.z - low
        } else {
            -(b.z - a.z) * rate / 2.0
        };
        Some((descent, horizontal(&(b - a)).norm() * rate / 2.0))
    };
    let limit = if on_belt {
        BELT_LANDED_M
    } else {
        HEEL_LANDED_MPS
    };
    let landed = |s: (f64, f64)| s.0 <= limit && s.1 <= HEEL_SLIDING_MPS;
    let swinging = state(start)?.1 > HEEL_SLIDING_MPS;
    let mut previous: Option<(f64, f64)> = None;
    for f in start..=start + search {
        let s = state(f)?;
        if landed(s) {
            let Some(q) = previous else {
                return Some((f as f64, false));
            };
            // Linear interpolation of whichever condition was met last.
            let cross = |a: f64, b: f64, limit: f64| {
                if a > limit && b < a {
                    ((a - limit) / (a - b)).clamp(0.0, 1.0)
                } else {
                    0.0
                }
            };
            let frac = cross(q.0, s.0, limit).max(cross(q.1, s.1, HEEL_SLIDING_MPS));
            return Some(((f - 1) as f64 + frac, swinging));
        }
        previous = Some(s);
    }
    None
}

/// Moves each heel strike found on a heel *marker* to where the marker lands, and adds the
/// `edges` candidates ([`crate::events::edge_heel_strikes`]) whose landing is seen.
///
/// The coordinate method marks the instant the heel is furthest ahead of the pelvis, which on
/// force plates comes 40–50 ms before the vertical force reaches 20 N (measured on the four
/// force-plate recordings in `shared/data`, for heel markers and ankle centres alike): the heel
/// is still coming down. The landing is the first instant, within
/// [`HEEL_LANDING_SEARCH_SECS`] after the candidate, at which the marker is down and no longer
/// sliding: its horizontal speed is at most [`HEEL_SLIDING_MPS`] (Ghoussayni et al.'s heel
/// contact) and
///
/// - overground, it has stopped descending (downward speed below [`HEEL_LANDED_MPS`]): the
///   heels measured land gently (at most 0.06 m/s down at the 20 N instant: the children, the
///   CGM2 and the BTS walks) after skimming the floor within 1 mm for 8–28 ms, so a height
///   rule is early there;
/// - on a treadmill (`on_belt`), it is within [`BELT_LANDED_M`] of its lowest point over the
///   following [`HEEL_STANCE_LOW_SECS`]: on the belt the heel meets the plate still descending
///   at 0.08–0.2 m/s and sinks up to 2 mm more over the next 10–20 ms, so where it stops is
///   late there (14 ms mean |error|). A single rule for both was not found: a vertical-speed
///   threshold that fits the treadmill (−0.08 m/s) is 13–21 ms early on the gentle CGM2
///   landings, the height rule 8–28 ms early overground, and the peak of the heel's upward
///   acceleration (the impact) is 50 ms early on the CGM2 landings, which have none.
///
/// The speed gate matters where a heel reaches its lowest point while still swinging forward
/// (1.8 m/s at one of the children's off-plate strikes, HC039A17 at 1.61 s; it stops 35 ms
/// later, where the lab labelled the strike); of the overground plate contacts it moves one
/// (BTS, from 6 to 1 ms early). Zeni et al.'s candidate refined by a heel-speed condition is
/// also how Bonci et al. (2022) detect contacts.
///
/// Linear interpolation between frames of the condition met last; without a landing the
/// candidate stays. An edge candidate is kept only if the heel is seen to land after it: still
/// swinging (faster than [`HEEL_SLIDING_MPS`]) at the first frame searched, and landed within
/// the search. A heel at rest that settles by a millimetre as the recording begins (the CGM2
/// walk's left heel, 0.06 m/s down at 0.03 m/s forward) is no landing seen. Skeleton ankles
/// are too noisy in height for this and keep the coordinate-method instant.
fn refine_heel_strikes(
    tracks: &Tracks,
    events: &mut Vec<GaitEvent>,
    edges: Vec<GaitEvent>,
    on_belt: bool,
) {
    let rate = tracks.rate_hz;
    let moved = |e: &mut GaitEvent, frame: f64| {
        let frame = frame.max(e.frame);
        e.frame = frame;
        e.time_secs = frame / rate;
    };
    for e in events
        .iter_mut()
        .filter(|e| e.kind == EventKind::HeelStrike)
    {
        if let Some((frame, _)) = heel_landing(tracks, e.foot, e.frame, on_belt) {
            moved(e, frame);
        }
    }
    for mut e in edges {
        if let Some((frame, true)) = heel_landing(tracks, e.foot, e.frame, on_belt) {
            moved(&mut e, frame);
            events.push(e);
        }
    }
    events.sort_by(|a, b| a.time_secs.total_cmp(&b.time_secs));
}

/// A toe marker this far (m) above its lowest point over the preceding
/// [`TOE_STANCE_SECS`] has lifted off the floor: above the 1–3 mm it rolls in late stance on
/// a shoe's toe, below the 1–2 cm a met-head marker is raised by the time the toe leaves.
const TOE_LIFTED_M: f64 = 0.008;

/// A toe marker moving forward faster than this (m/s, horizontal) is no longer rolling over
/// the toes: in late stance it rolls at 0.2–0.8 m/s, in early swing it reaches 2–3 m/s.
const TOE_MOVING_MPS: f64 = 1.2;

/// How far back the toe marker's stance height is looked for (s): within the stance it ends.
const TOE_STANCE_SECS: f64 = 0.3;

/// The window around the coordinate method's toe off searched for the lift-off (s before,
/// s after).
const TOE_SEARCH_SECS: (f64, f64) = (0.1, 0.2);

/// Moves each walking toe off found on a toe *marker* to where the marker is both lifted and
/// moving: the first instant in [`TOE_SEARCH_SECS`] around the candidate at which it is
/// [`TOE_LIFTED_M`] above its stance height and moves forward at [`TOE_MOVING_MPS`] (linear
/// interpolation of whichever condition is met last).
///
/// The coordinate method marks the instant the toe is furthest behind the pelvis, which on the
/// force-plate recordings in `shared/data` lies 30 ms before to 13 ms after the vertical force
/// falls below 20 N, depending on where the marker sits (on the toes, on the 2nd or 5th met
/// head) and how fast the subject walks. Height alone fails for a met-head marker, which rises
/// as the heel comes up (25–40 ms early on the treadmill recording); speed alone fails for a
/// marker high on the forefoot, which already moves fast while the toes still push (18 ms early
/// on the CGM2 recording); together they fall within 1 frame on average on each recording
/// (validated from 0.9 to 1.5 m/s). Without such an instant the candidate stays.
fn refine_toe_offs(tracks: &Tracks, events: &mut [GaitEvent]) {
    let rate = tracks.rate_hz;
    let look = (TOE_STANCE_SECS * rate).round() as usize;
    let (before, after) = (TOE_SEARCH_SECS.0 * rate, TOE_SEARCH_SECS.1 * rate);
    for e in events.iter_mut().filter(|e| e.kind == EventKind::ToeOff) {
        let track = &tracks.toe[e.foot.index()];
        let at = |f: usize| track.get(f).copied().flatten();
        // (height above the lowest point of the preceding stance window, horizontal speed)
        let state = |f: usize| -> Option<(f64, f64)> {
            let here = at(f)?;
            let (a, b) = (at(f.checked_sub(1)?)?, at(f + 1)?);
            let speed = horizontal(&(b - a)).norm() * rate / 2.0;
            let low = (f.saturating_sub(look)..=f)
                .filter_map(|g| at(g).map(|q| q.z))
                .fold(f64::INFINITY, f64::min);
            Some((here.z - low, speed))
        };
        let off = |s: (f64, f64)| s.0 >= TOE_LIFTED_M && s.1 >= TOE_MOVING_MPS;
        let start = (e.frame - before).floor().max(1.0) as usize;
        let end = (e.frame + after).ceil().max(0.0) as usize;
        let mut previous: Option<(f64, f64)> = None;
        for f in start..=end {
            let Some(s) = state(f) else {
                previous = None;
                continue;
            };
            if off(s) {
                if let Some(q) = previous {
                    let cross = |a: f64, b: f64, limit: f64| {
                        if a < limit && b > a {
                            ((limit - a) / (b - a)).clamp(0.0, 1.0)
                        } else {
                            0.0
                        }
                    };
                    let frac = cross(q.0, s.0, TOE_LIFTED_M).max(cross(q.1, s.1, TOE_MOVING_MPS));
                    let frame = (f - 1) as f64 + frac;
                    e.frame = frame;
                    e.time_secs = frame / rate;
                }
                break;
            }
            previous = Some(s);
        }
    }
}

/// Pearson correlation of two equally long series; `None` without variance.
fn correlation(a: &[f64], b: &[f64]) -> Option<f64> {
    let n = a.len().min(b.len());
    if n < 3 {
        return None;
    }
    let (ma, mb) = (
        a[..n].iter().sum::<f64>() / n as f64,
        b[..n].iter().sum::<f64>() / n as f64,
    );
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for i in 0..n {
        let (x, y) = (a[i] - ma, b[i] - mb);
        sab += x * y;
        saa += x * x;
        sbb += y * y;
    }
    (saa > 1e-12 && sbb > 1e-12).then(|| sab / (saa * sbb).sqrt())
}

/// Moves segments whose left and right heels do not alternate (relative to the pelvis, along
/// the walking direction) to the excluded phases.
fn exclude_non_alternating(tracks: &Tracks, segmentation: &mut Segmentation, max_corr: f64) {
    let mut kept = Vec::new();
    for segment in std::mem::take(&mut segmentation.segments) {
        let d = segment.direction();
        let (mut l, mut r) = (Vec::new(), Vec::new());
        for f in segment.first_frame..=segment.last_frame {
            let rel = |s: usize| -> Option<f64> {
                let h = tracks.heel[s].get(f).copied().flatten()?;
                let p = tracks.pelvis.get(f).copied().flatten()?;
                Some(horizontal(&(h - p)).dot(&d))
            };
            if let (Some(a), Some(b)) = (rel(0), rel(1)) {
                l.push(a);
                r.push(b);
            }
        }
        // No variance at all: the feet do not move relative to the pelvis, no stepping either.
        match correlation(&l, &r).or(Some(1.0)) {
            Some(c) if c > max_corr => segmentation.excluded.push(ExcludedPhase {
                reason: ExclusionReason::NotAlternating,
                start_secs: segment.start_secs,
                end_secs: segment.end_secs,
                frames: segment.last_frame - segment.first_frame + 1,
            }),
            _ => kept.push(segment),
        }
    }
    segmentation.segments = kept;
    segmentation
        .excluded
        .sort_by(|a, b| a.start_secs.total_cmp(&b.start_secs));
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

#[cfg(test)]
mod tests {
    use super::*;

    fn event(foot: Foot, kind: EventKind, frame: f64, segment: usize) -> GaitEvent {
        GaitEvent {
            foot,
            kind,
            time_secs: frame / 30.0,
            frame,
            segment,
            prominence_m: None,
        }
    }

    /// At the running limit (80 ms), heel strikes 2 and 1.5 frames (67 and 50 ms) before their
    /// own toe off go; those 3 frames (100 ms) before stay, with a toe off of the other foot
    /// between or without, as does one whose own toe off is in the next segment. At the
    /// walking limit (0.25 s) the 100 ms contacts go too.
    /// A stride round a left-out step loses the figures it takes from the other foot's heel
    /// strike inside it, and keeps its own; a stride elsewhere keeps everything.
    #[test]
    fn a_stride_round_a_left_out_step_keeps_only_its_own_figures() {
        let stride = Stride {
            foot: Foot::Right,
            segment: 0,
            start_secs: 10.0,
            end_secs: 11.1,
            stride_time_secs: 1.1,
            stride_length_m: 1.4,
            speed_mps: 1.4 / 1.1,
            cadence_steps_per_min: 120.0 / 1.1,
            step_length_m: Some(0.9),
            step_width_m: Some(0.1),
            stance_pct: Some(62.0),
            swing_pct: Some(38.0),
            double_support_pct: Some(24.0),
            pelvis_travel_m: Some(1.38),
        };
        let step = |start_secs: f64, end_secs: f64| Step {
            foot: Foot::Left,
            segment: 0,
            start_secs,
            end_secs,
            step_time_secs: end_secs - start_secs,
            cadence_steps_per_min: 60.0 / (end_secs - start_secs),
            step_length_m: Some(0.58),
            step_width_m: Some(0.1),
            pelvis_travel_m: Some(0.21),
        };
        let doubted = without_doubtful_steps(stride.clone(), &[step(10.0, 10.26)]);
        assert_eq!(
            (
                doubted.step_length_m,
                doubted.step_width_m,
                doubted.double_support_pct
            ),
            (None, None, None)
        );
        assert_eq!(doubted.stride_length_m, stride.stride_length_m);
        assert_eq!(doubted.stance_pct, stride.stance_pct);
        assert_eq!(
            without_doubtful_steps(stride.clone(), &[step(11.1, 11.4)]),
            stride
        );
    }

    #[test]
    fn short_contacts_lose_their_heel_strike() {
        use EventKind::{HeelStrike as Hs, ToeOff as To};
        use Foot::{Left, Right};
        let events = vec![
            event(Right, Hs, 4.0, 0),
            event(Right, To, 6.0, 0),
            event(Left, Hs, 10.0, 0),
            event(Right, To, 11.0, 0),
            event(Left, To, 13.0, 0),
            event(Right, Hs, 20.0, 0),
            event(Right, To, 23.0, 0),
            event(Left, Hs, 29.0, 0),
            event(Left, To, 30.0, 1),
            event(Left, Hs, 40.0, 1),
            event(Left, To, 41.5, 1),
        ];
        // Each limit drops the heel strikes at `gone` and nothing else.
        let drops = |limit: f64, gone: &[f64]| {
            let mut left = events.clone();
            let kept: Vec<GaitEvent> = events
                .iter()
                .copied()
                .filter(|e| !gone.contains(&e.frame))
                .collect();
            assert_eq!(drop_short_contacts(&mut left, 30.0, limit), gone.len());
            assert_eq!(left, kept);
        };
        drops(MIN_RUNNING_CONTACT_SECS, &[4.0, 40.0]);
        drops(MIN_WALKING_CONTACT_SECS, &[4.0, 10.0, 20.0, 40.0]);
    }

    /// Of a heel strike and a toe off too close together, the less prominent goes: a dip right
    /// after a clear heel strike is dropped, a faint peak right before a clear toe off too.
    #[test]
    fn the_less_prominent_of_a_short_contact_goes() {
        use EventKind::{HeelStrike as Hs, ToeOff as To};
        let with = |kind, frame, prominence| GaitEvent {
            prominence_m: Some(prominence),
            ..event(Foot::Right, kind, frame, 0)
        };
        let mut events = vec![
            with(Hs, 10.0, 0.30),
            with(To, 13.0, 0.05),
            with(To, 31.0, 0.40),
            with(Hs, 44.0, 0.04),
            with(To, 47.0, 0.30),
            with(Hs, 65.0, 0.35),
        ];
        let kept = [events[0], events[2], events[4], events[5]].to_vec();
        assert_eq!(
            drop_short_contacts(&mut events, 30.0, MIN_WALKING_CONTACT_SECS),
            2
        );
        assert_eq!(events, kept);
    }
}
