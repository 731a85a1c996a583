//! Gait analysis over a growing stream of timestamped poses, for a recorder that logs events
//! while the walk goes on and reports the parameters when it ends.
//!
//! The offline pipeline ([`crate::analyse`]) needs a uniformly sampled [`MotionClip`]. The
//! stream's poses carry server-clock stamps on the fusion grid (30 Hz for the `interpolate`
//! policy, one per slot cycle for `slots`), so the clip is rebuilt from the stamps: the sample
//! interval is the median of the intervals between consecutive stamps, each pose goes to the
//! nearest grid frame (an error of at most half an interval for a jittered stamp) and a missing
//! pose is a gap, which the segmentation reports or bridges as it does for a marker file.
//!
//! **Settled events.** Every [`LiveGaitParams::analyse_every_secs`] the whole retained window is
//! analysed again, as [`crate::analyse`] does it (cleaning, the airborne, swing and
//! short-contact checks), and only events that analysis keeps are reported: a foot in the air,
//! a foot that did not swing or a contact too short to be one is never marked. An event is
//! reported once it lies [`LiveGaitParams::settle_secs`] before the newest pose, because the
//! segmentation looks half a velocity window ahead and a turning point at the very end of the
//! data is not yet a peak.
//! Later analyses find the same event again, within a frame; one of the same foot and kind
//! closer than half the minimum event separation to one already reported is the same event and
//! is not reported twice. A reported event stays reported, though a later analysis of the longer
//! window may still drop it (a segment found not to alternate, a walk found to be a run): the
//! counts in [`LiveReport`] are the final analysis's. At the end ([`LiveGait::finish`]) the
//! remaining events are reported and the parameters computed.

use std::collections::BTreeMap;
use std::sync::Arc;

use nalgebra::Point3;
use serde::{Deserialize, Serialize};
use trigait_skeleton::{Joint, MotionClip};

use crate::params::{analyse_detection, detect};
use crate::segment::{ExclusionReason, Segmentation};
use crate::{
    EventKind, EventMethod, Foot, GaitAnalysis, GaitEvent, GaitParams, Landmarks, Result, Summary,
};

/// Tuning of [`LiveGait`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LiveGaitParams {
    /// The analysis itself (segmentation, event method, minimum strides, filter); the default
    /// is [`GaitParams::default`], which filters nothing (the recorder asks for the skeleton
    /// stream's low-pass, as `trigait gait` runs one). A filter the stream's rate cannot carry
    /// is left out ([`crate::filter::Filter::or_none_at`]); the report names the one that ran.
    pub gait: GaitParams,
    /// Stream time (s) between two analyses. Default 1 s.
    pub analyse_every_secs: f64,
    /// Age (s) behind the newest pose at which an event is final. Default 1.5 s: more than
    /// half the 1 s velocity window of the segmentation plus the 0.4 s event separation.
    pub settle_secs: f64,
    /// Stream time (s) kept; older poses are forgotten (their events stay reported). Default
    /// 600 s, 18 000 poses at 30 Hz.
    pub window_secs: f64,
}

impl Default for LiveGaitParams {
    fn default() -> Self {
        Self {
            gait: GaitParams::default(),
            analyse_every_secs: 1.0,
            settle_secs: 1.5,
            window_secs: 600.0,
        }
    }
}

/// A gait event on the stream's clock.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TimedEvent {
    /// Which foot.
    pub foot: Foot,
    /// Heel strike or toe off.
    pub kind: EventKind,
    /// When, on the stamps' clock (ns).
    pub stamp_nanos: i64,
    /// Where the event's joint was (the ankle for a heel strike, the toe stand-in for a toe
    /// off) at the nearest frame, if tracked there.
    pub position: Option<Point3<f64>>,
}

/// Events per foot.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct FootCounts {
    /// Left foot.
    pub left: usize,
    /// Right foot.
    pub right: usize,
}

impl FootCounts {
    fn count<'a>(events: impl Iterator<Item = (Foot, EventKind)> + 'a, kind: EventKind) -> Self {
        let mut c = Self::default();
        for (foot, k) in events {
            if k == kind {
                match foot {
                    Foot::Left => c.left += 1,
                    Foot::Right => c.right += 1,
                }
            }
        }
        c
    }
}

/// The end-of-stream report (the recorder's `summary.json` `gait` section).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LiveReport {
    /// Event detector: the one the final analysis used, or the configured one (`auto` by
    /// default) when there was no analysis.
    pub method: EventMethod,
    /// Sample rate found from the stamps (Hz); `None` with too few poses.
    pub rate_hz: Option<f64>,
    /// The low-pass filter the analysis ran on the landmarks after the cleaning (`none`,
    /// `butterworth:6hz`, …): the configured one, or none where the stream's rate cannot carry
    /// its cut-off ([`crate::filter::Filter::or_none_at`]).
    #[serde(default)]
    pub filter: String,
    /// Stream time analysed (s).
    pub analysed_secs: f64,
    /// Heel strikes per foot the final analysis of the window kept (after cleaning and the
    /// airborne, swing and short-contact checks): the events `parameters` rest on.
    pub heel_strikes: FootCounts,
    /// Toe offs per foot kept the same way.
    pub toe_offs: FootCounts,
    /// Events reported while streaming and at the end (what was logged), both kinds.
    pub events_reported: FootCounts,
    /// Straight walking segments the final analysis kept (after cleaning; segments whose feet
    /// do not alternate are left out).
    pub segments: usize,
    /// Time in those segments (s).
    pub walking_secs: f64,
    /// Time excluded as standing (s).
    pub standing_secs: f64,
    /// Time excluded as turning (s).
    pub turning_secs: f64,
    /// Time excluded for gaps (s).
    pub gap_secs: f64,
    /// Time excluded because the feet did not alternate (hops, shuffling) (s).
    #[serde(default)]
    pub not_alternating_secs: f64,
    /// Complete strides (both feet).
    pub strides: usize,
    /// Mean cadence (steps/min) over the strides.
    pub cadence_steps_per_min: Option<f64>,
    /// Mean stride length (m).
    pub stride_length_m: Option<f64>,
    /// Mean walking speed (m/s).
    pub speed_mps: Option<f64>,
    /// Mean step width (m).
    pub step_width_m: Option<f64>,
    /// Every parameter with sd and asymmetry, when there were enough strides.
    pub parameters: Option<Summary>,
    /// Why there are no parameters (too little walking, too few strides, missing joints).
    pub reason: Option<String>,
    /// Joint samples with a non-finite coordinate that were skipped.
    pub non_finite_skipped: u64,
}

/// The full analysis of the poses retained so far ([`LiveGait::analysis`]), with what maps its
/// clip time back onto the stream's clock.
#[derive(Debug)]
pub struct LiveAnalysis {
    /// The retained poses on a uniform grid (clip time 0 = `first_nanos`).
    pub clip: MotionClip,
    /// Stamp (ns) of the clip's frame 0.
    pub first_nanos: i64,
    /// Events and strides ending after this stamp (ns) may still move or vanish as poses come
    /// ([`LiveGaitParams::settle_secs`] behind the newest pose).
    pub settled_until_nanos: i64,
    /// The analysis of `clip`, or why there is none yet.
    pub analysis: Result<GaitAnalysis>,
}

impl LiveAnalysis {
    /// The stream stamp (ns) of clip time `secs`.
    #[must_use]
    pub fn stamp_nanos(&self, secs: f64) -> i64 {
        self.first_nanos + (secs * 1e9).round() as i64
    }
}

/// Gait analysis over a growing stream of poses. See the module docs.
#[derive(Debug, Clone)]
pub struct LiveGait {
    params: LiveGaitParams,
    samples: BTreeMap<i64, BTreeMap<Joint, Point3<f64>>>,
    last_analysis_nanos: Option<i64>,
    last_reported: BTreeMap<(Foot, EventKind), i64>,
    reported: Vec<TimedEvent>,
    non_finite: u64,
    /// The analysis of the poses as they are now; dropped when a pose comes.
    latest: Option<Latest>,
}

/// A clip rebuilt from the stamps and where its frame 0 lies.
struct Grid {
    clip: MotionClip,
    first_nanos: i64,
}

/// One analysis of the retained poses: the events it kept and its walking segments (`None`
/// when the poses lack the joints an analysis needs), and the analysis itself.
#[derive(Debug, Clone)]
struct Latest {
    analysis: Arc<LiveAnalysis>,
    events: Vec<GaitEvent>,
    segmentation: Option<Segmentation>,
}

impl LiveGait {
    /// An empty stream.
    #[must_use]
    pub fn new(params: LiveGaitParams) -> Self {
        Self {
            params,
            samples: BTreeMap::new(),
            last_analysis_nanos: None,
            last_reported: BTreeMap::new(),
            reported: Vec::new(),
            non_finite: 0,
            latest: None,
        }
    }

    /// Every event reported so far, in report order.
    #[must_use]
    pub fn reported(&self) -> &[TimedEvent] {
        &self.reported
    }

    /// Adds the joints of the pose at `stamp_nanos`; non-finite positions are skipped and
    /// counted. Poses older than the window behind the newest are forgotten.
    pub fn push<'a>(
        &mut self,
        stamp_nanos: i64,
        joints: impl IntoIterator<Item = (Joint, &'a Point3<f64>)>,
    ) {
        let mut row = BTreeMap::new();
        for (joint, p) in joints {
            if p.iter().all(|v| v.is_finite()) {
                row.insert(joint, *p);
            } else {
                self.non_finite += 1;
            }
        }
        self.samples.insert(stamp_nanos, row);
        self.latest = None;
        if let Some((&newest, _)) = self.samples.last_key_value() {
            let horizon = newest.saturating_sub((self.params.window_secs * 1e9) as i64);
            while self
                .samples
                .first_key_value()
                .is_some_and(|(t, _)| *t < horizon)
            {
                self.samples.pop_first();
            }
        }
    }

    /// Runs the analysis when due and returns the events it kept that became final since the
    /// last call.
    pub fn poll(&mut self) -> Vec<TimedEvent> {
        let Some((&newest, _)) = self.samples.last_key_value() else {
            return Vec::new();
        };
        let every = (self.params.analyse_every_secs * 1e9) as i64;
        if self
            .last_analysis_nanos
            .is_some_and(|last| newest - last < every)
        {
            return Vec::new();
        }
        self.last_analysis_nanos = Some(newest);
        let Some(latest) = self.refresh().cloned() else {
            return Vec::new();
        };
        let a = &latest.analysis;
        self.take_new(
            &a.clip,
            a.first_nanos,
            &latest.events,
            Some(a.settled_until_nanos),
        )
    }

    /// The full analysis (strides, parameters) of everything retained, for a running display;
    /// `None` with fewer than [`MIN_POSES`] poses. Right after [`Self::poll`] ran one, it is that
    /// analysis; otherwise it costs an offline analysis of the window, so call it when a poll
    /// reported a heel strike, not on every pose.
    pub fn analysis(&mut self) -> Option<Arc<LiveAnalysis>> {
        self.refresh().map(|l| Arc::clone(&l.analysis))
    }

    /// The analysis of the poses as they are now, run if a pose came since the last one.
    fn refresh(&mut self) -> Option<&Latest> {
        if self.latest.is_none() {
            let newest = *self.samples.last_key_value()?.0;
            let grid = self.grid()?;
            let gait = &GaitParams {
                filter: self.params.gait.filter.or_none_at(grid.clip.rate_hz()),
                ..self.params.gait
            };
            let detection = Landmarks::from_clip(&grid.clip).and_then(|l| detect(&l, gait));
            let (events, segmentation) = match &detection {
                Ok(d) => (d.events.clone(), Some(d.segmentation.clone())),
                Err(_) => (Vec::new(), None),
            };
            let analysis = detection.and_then(|d| analyse_detection(d, gait));
            self.latest = Some(Latest {
                analysis: Arc::new(LiveAnalysis {
                    settled_until_nanos: newest - (self.params.settle_secs * 1e9) as i64,
                    first_nanos: grid.first_nanos,
                    clip: grid.clip,
                    analysis,
                }),
                events,
                segmentation,
            });
        }
        self.latest.as_ref()
    }

    /// Analyses everything retained: reports the events not yet reported and the parameters
    /// (or why there are none).
    pub fn finish(&mut self) -> (Vec<TimedEvent>, LiveReport) {
        let method = self.params.gait.events.method;
        let Some(latest) = self.refresh().cloned() else {
            let report = LiveReport {
                method,
                rate_hz: None,
                filter: self.params.gait.filter.to_string(),
                analysed_secs: 0.0,
                heel_strikes: FootCounts::default(),
                toe_offs: FootCounts::default(),
                events_reported: self.reported_counts(),
                segments: 0,
                walking_secs: 0.0,
                standing_secs: 0.0,
                turning_secs: 0.0,
                gap_secs: 0.0,
                not_alternating_secs: 0.0,
                strides: 0,
                cadence_steps_per_min: None,
                stride_length_m: None,
                speed_mps: None,
                step_width_m: None,
                parameters: None,
                reason: Some(format!(
                    "too few poses to analyse ({} received, at least {MIN_POSES} needed)",
                    self.samples.len()
                )),
                non_finite_skipped: self.non_finite,
            };
            return (Vec::new(), report);
        };
        let live = &latest.analysis;
        let rate = live.clip.rate_hz();
        let (events, segmentation) = (&latest.events, latest.segmentation.as_ref());
        let new = self.take_new(&live.clip, live.first_nanos, events, None);
        let secs = |r| segmentation.map_or(0.0, |s| s.excluded_secs(r, rate));
        let kinds = || events.iter().map(|e| (e.foot, e.kind));
        let (strides, parameters, reason) = match &live.analysis {
            Ok(a) => (a.strides.len(), Some(a.summary.clone()), None),
            Err(e) => (0, None, Some(e.to_string())),
        };
        let report = LiveReport {
            method: live.analysis.as_ref().map_or(method, |a| a.method),
            rate_hz: Some(rate),
            filter: self.params.gait.filter.or_none_at(rate).to_string(),
            analysed_secs: live.clip.duration_secs(),
            heel_strikes: FootCounts::count(kinds(), EventKind::HeelStrike),
            toe_offs: FootCounts::count(kinds(), EventKind::ToeOff),
            events_reported: self.reported_counts(),
            segments: segmentation.map_or(0, |s| s.segments.len()),
            walking_secs: segmentation.map_or(0.0, |s| s.walking_secs(rate)),
            standing_secs: secs(ExclusionReason::Standing),
            turning_secs: secs(ExclusionReason::Turning),
            gap_secs: secs(ExclusionReason::Gap),
            not_alternating_secs: secs(ExclusionReason::NotAlternating),
            strides,
            cadence_steps_per_min: parameters
                .as_ref()
                .and_then(|p| p.cadence_steps_per_min.mean),
            stride_length_m: parameters.as_ref().and_then(|p| p.stride_length_m.mean),
            speed_mps: parameters.as_ref().and_then(|p| p.speed_mps.mean),
            step_width_m: parameters.as_ref().and_then(|p| p.step_width_m.mean),
            parameters,
            reason,
            non_finite_skipped: self.non_finite,
        };
        (new, report)
    }

    fn reported_counts(&self) -> FootCounts {
        let mut c = FootCounts::default();
        for e in &self.reported {
            match e.foot {
                Foot::Left => c.left += 1,
                Foot::Right => c.right += 1,
            }
        }
        c
    }

    /// Events of `clip` (frame 0 at `first_nanos`) not reported yet (and, with `limit`, not
    /// after it), reported now.
    fn take_new(
        &mut self,
        clip: &MotionClip,
        first_nanos: i64,
        events: &[GaitEvent],
        limit: Option<i64>,
    ) -> Vec<TimedEvent> {
        let same = (self.params.gait.events.min_separation_secs * 0.5 * 1e9) as i64;
        let mut out = Vec::new();
        for e in events {
            let stamp = first_nanos + (e.time_secs * 1e9).round() as i64;
            if limit.is_some_and(|l| stamp > l) {
                continue;
            }
            let key = (e.foot, e.kind);
            if self
                .last_reported
                .get(&key)
                .is_some_and(|last| stamp <= last + same)
            {
                continue;
            }
            let joint = match (e.foot, e.kind) {
                (Foot::Left, EventKind::HeelStrike) => Joint::AnkleLeft,
                (Foot::Right, EventKind::HeelStrike) => Joint::AnkleRight,
                (Foot::Left, EventKind::ToeOff) if clip.has(Joint::FootLeft) => Joint::FootLeft,
                (Foot::Right, EventKind::ToeOff) if clip.has(Joint::FootRight) => Joint::FootRight,
                (Foot::Left, EventKind::ToeOff) => Joint::AnkleLeft,
                (Foot::Right, EventKind::ToeOff) => Joint::AnkleRight,
            };
            let frame = e.frame.round().max(0.0) as usize;
            let event = TimedEvent {
                foot: e.foot,
                kind: e.kind,
                stamp_nanos: stamp,
                position: clip.position(frame, joint),
            };
            self.last_reported.insert(key, stamp);
            self.reported.push(event);
            out.push(event);
        }
        out
    }

    /// The retained poses on a uniform grid; `None` with fewer than [`MIN_POSES`] poses.
    fn grid(&self) -> Option<Grid> {
        if self.samples.len() < MIN_POSES {
            return None;
        }
        let stamps: Vec<i64> = self.samples.keys().copied().collect();
        let mut intervals: Vec<i64> = stamps.windows(2).map(|w| w[1] - w[0]).collect();
        intervals.sort_unstable();
        let period = *intervals.get(intervals.len() / 2)? as f64;
        let (first, last) = (*stamps.first()?, *stamps.last()?);
        let n = ((last - first) as f64 / period).round() as usize + 1;
        // Stamps so irregular that the grid would be mostly empty are no walk to analyse.
        if period <= 0.0 || n > 4 * stamps.len() {
            return None;
        }
        let joints: Vec<Joint> = {
            let mut all: Vec<Joint> = self
                .samples
                .values()
                .flat_map(|r| r.keys().copied())
                .collect();
            all.sort_unstable();
            all.dedup();
            all
        };
        let mut frames = vec![vec![None; joints.len()]; n];
        for (t, row) in &self.samples {
            let f = ((t - first) as f64 / period).round() as usize;
            let Some(frame) = frames.get_mut(f) else {
                continue;
            };
            for (joint, p) in row {
                if let Ok(col) = joints.binary_search(joint) {
                    frame[col] = Some(*p);
                }
            }
        }
        let clip = MotionClip::new("live stream", 1e9 / period, joints, frames).ok()?;
        Some(Grid {
            clip,
            first_nanos: first,
        })
    }
}

/// Fewest poses [`LiveGait`] analyses (one second at 30 Hz).
pub const MIN_POSES: usize = 30;

#[cfg(test)]
mod tests {
    use trigait_motion::{WalkerParams, there_and_back, walker};

    use super::*;

    /// Deterministic pseudo-noise in [−1, 1].
    fn noise(i: u64) -> f64 {
        let x = (i.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 11) as f64 / (1u64 << 53) as f64;
        2.0 * x - 1.0
    }

    /// The simulated sources' endless lap (2.5 s out, turn, back) sampled at 30 Hz on an
    /// epoch-sized clock for `secs`, with ±`noise_m` jitter and every `drop_every`-th pose lost.
    fn stream(
        secs: f64,
        noise_m: f64,
        drop_every: usize,
    ) -> Vec<(i64, BTreeMap<Joint, Point3<f64>>)> {
        let clip = walker(&WalkerParams::default(), 2.5, 100.0).unwrap();
        let lap = there_and_back(&clip.placed_on_walkway()).unwrap();
        let t0: i64 = 1_700_000_000_000_000_000;
        let period = 1e9 / 30.0;
        let n = (secs * 30.0) as usize;
        (0..n)
            .filter(|i| drop_every == 0 || i % drop_every != drop_every - 1)
            .map(|i| {
                let t = i as f64 / 30.0;
                let t_lap = t % lap.duration_secs();
                let row = lap
                    .joints()
                    .iter()
                    .enumerate()
                    .filter_map(|(k, j)| {
                        let p = lap.position_at(*j, t_lap)?;
                        let s = (i * 16 + k * 3) as u64;
                        let d = nalgebra::Vector3::new(noise(s), noise(s + 1), noise(s + 2));
                        Some((*j, p + d * noise_m))
                    })
                    .collect();
                (t0 + (i as f64 * period).round() as i64, row)
            })
            .collect()
    }

    fn feed(live: &mut LiveGait, rows: &[(i64, BTreeMap<Joint, Point3<f64>>)]) -> Vec<TimedEvent> {
        let mut events = Vec::new();
        for (t, row) in rows {
            live.push(*t, row.iter().map(|(j, p)| (*j, p)));
            events.extend(live.poll());
        }
        events
    }

    /// 12 s of the lap with 1 cm jitter and one pose in 20 lost: heel strikes of both feet
    /// are reported while streaming, never twice, in time order per foot, and the final
    /// cadence is the walker's 105 steps/min within 3 %.
    #[test]
    fn lap_gives_events_and_cadence() {
        let rows = stream(12.0, 0.01, 0);
        let mut live = LiveGait::new(LiveGaitParams::default());
        let streamed = feed(&mut live, &rows);
        let (rest, report) = live.finish();
        let hs = |foot| {
            streamed
                .iter()
                .chain(&rest)
                .filter(|e| e.foot == foot && e.kind == EventKind::HeelStrike)
                .map(|e| e.stamp_nanos)
                .collect::<Vec<_>>()
        };
        for foot in Foot::BOTH {
            let t = hs(foot);
            assert!(t.len() >= 3, "{foot:?}: {t:?}\n{report:#?}");
            assert!(
                t.windows(2).all(|w| w[1] - w[0] > 400_000_000),
                "{foot:?} reported twice: {t:?}"
            );
        }
        assert!(
            streamed
                .iter()
                .filter(|e| e.kind == EventKind::HeelStrike)
                .count()
                >= 4,
            "few events while streaming: {streamed:?}"
        );
        let cadence = report.cadence_steps_per_min.unwrap_or(f64::NAN);
        assert!((cadence / 105.0 - 1.0).abs() < 0.03, "{report:#?}");
        assert!(
            report.strides >= 2 && report.reason.is_none(),
            "{report:#?}"
        );
        assert!((report.rate_hz.unwrap() - 30.0).abs() < 0.01);
        assert_eq!(report.method, EventMethod::Coordinate);
        assert!(
            report.turning_secs + report.standing_secs > 0.5,
            "{report:#?}"
        );
        assert_eq!(
            report.events_reported.left + report.events_reported.right,
            streamed.len() + rest.len()
        );
    }

    /// A configured filter runs where the stream's rate carries it and is named in the report:
    /// at 30 Hz the 6 Hz low-pass changes the analysis of a jittery stream (its parameters are
    /// not the unfiltered ones) and keeps the walker's cadence; the same stream thinned to
    /// 10 Hz, too slow for a 6 Hz cut-off, is analysed unfiltered and says so, instead of
    /// failing.
    #[test]
    fn the_filter_that_ran_is_reported() {
        let rows = stream(12.0, 0.02, 0);
        let filtered = LiveGaitParams {
            gait: GaitParams {
                filter: crate::filter::SKELETON_FILTER,
                ..GaitParams::default()
            },
            ..LiveGaitParams::default()
        };
        let run = |params: LiveGaitParams, rows: &[(i64, BTreeMap<Joint, Point3<f64>>)]| {
            let mut live = LiveGait::new(params);
            feed(&mut live, rows);
            live.finish().1
        };
        let plain = run(LiveGaitParams::default(), &rows);
        let low_passed = run(filtered, &rows);
        assert_eq!(plain.filter, "none");
        assert_eq!(low_passed.filter, "butterworth:6hz");
        assert_ne!(plain.parameters, low_passed.parameters);
        let cadence = low_passed.cadence_steps_per_min.unwrap_or(f64::NAN);
        assert!((cadence / 105.0 - 1.0).abs() < 0.03, "{low_passed:#?}");
        let thinned: Vec<_> = rows.iter().step_by(3).cloned().collect();
        let slow = run(filtered, &thinned);
        assert!((slow.rate_hz.unwrap() - 10.0).abs() < 0.01, "{slow:#?}");
        assert_eq!(slow.filter, "none");
        assert!(slow.reason.is_none(), "{slow:#?}");
    }

    /// What the stream reports is what its analysis keeps. A left ankle (and foot) lifted
    /// 0.3 m over a heel strike's ±0.2 s leaves the horizontal motion the detector reads as it
    /// was, but no foot lands in the air: the airborne check drops that heel strike and it is
    /// not reported; every event reported is one of the final analysis's and every one it kept
    /// was reported (same foot and kind, within a frame); the report counts the heel strikes
    /// that analysis kept.
    #[test]
    fn reported_events_are_the_events_the_analysis_keeps() {
        let mut rows = stream(12.0, 0.005, 0);
        let mut probe = LiveGait::new(LiveGaitParams::default());
        feed(&mut probe, &rows);
        probe.finish();
        let lifted = probe
            .reported()
            .iter()
            .find(|e| {
                e.foot == Foot::Left
                    && e.kind == EventKind::HeelStrike
                    && e.stamp_nanos > rows[0].0 + 4_000_000_000
            })
            .unwrap()
            .stamp_nanos;
        for (t, row) in &mut rows {
            if (*t - lifted).abs() <= 200_000_000 {
                for j in [Joint::AnkleLeft, Joint::FootLeft] {
                    if let Some(p) = row.get_mut(&j) {
                        p.z += 0.3;
                    }
                }
            }
        }
        let mut live = LiveGait::new(LiveGaitParams::default());
        let mut reported = feed(&mut live, &rows);
        let (rest, report) = live.finish();
        reported.extend(rest);
        assert!(
            !reported.iter().any(|e| e.foot == Foot::Left
                && e.kind == EventKind::HeelStrike
                && (e.stamp_nanos - lifted).abs() < 200_000_000),
            "the heel strike in the air was reported: {reported:?}"
        );
        let a = live.analysis().unwrap();
        let analysis = a.analysis.as_ref().unwrap();
        // Dropped by the airborne check, not lost to a gap.
        assert!(analysis.rejected_events >= 1, "{analysis:#?}");
        let kept = &analysis.events;
        let frame = (1e9 / a.clip.rate_hz()) as i64;
        let matches = |e: &TimedEvent, k: &GaitEvent| {
            k.foot == e.foot
                && k.kind == e.kind
                && (a.stamp_nanos(k.time_secs) - e.stamp_nanos).abs() <= frame
        };
        for e in &reported {
            assert!(
                kept.iter().any(|k| matches(e, k)),
                "{e:?} is not one of the analysis's events"
            );
        }
        for k in kept {
            assert!(
                reported.iter().any(|e| matches(e, k)),
                "{k:?} was kept but not reported"
            );
        }
        let left_strikes = kept
            .iter()
            .filter(|k| k.foot == Foot::Left && k.kind == EventKind::HeelStrike)
            .count();
        assert_eq!(report.heel_strikes.left, left_strikes);
        assert!(left_strikes >= 3, "{report:#?}");
    }

    /// The running analysis of the lap so far has strides whose heel strikes map onto the
    /// stream's stamps, and knee flexion cycles that peak in swing; with too few poses there is
    /// none.
    #[test]
    fn running_analysis_maps_strides_onto_the_stream() {
        let rows = stream(8.0, 0.005, 0);
        let mut live = LiveGait::new(LiveGaitParams::default());
        assert!(live.analysis().is_none());
        feed(&mut live, &rows);
        let a = live.analysis().unwrap();
        let analysis = a.analysis.as_ref().unwrap();
        assert!(analysis.strides.len() >= 2, "{analysis:#?}");
        let (first, last) = (rows[0].0, rows[rows.len() - 1].0);
        assert_eq!(a.first_nanos, first);
        assert_eq!(a.settled_until_nanos, last - 1_500_000_000);
        for s in &analysis.strides {
            let (t0, t1) = (a.stamp_nanos(s.start_secs), a.stamp_nanos(s.end_secs));
            assert!(first <= t0 && t0 < t1 && t1 <= last);
        }
        let (cycles, _) = crate::flexion_cycles(&a.clip, analysis);
        assert!(!cycles.is_empty());
        for c in &cycles {
            let peak = c.knee_deg.iter().copied().fold(f64::MIN, f64::max);
            assert!((45.0..75.0).contains(&peak), "{peak}");
        }
    }

    /// Too little data, a standing subject, NaN: a report with a reason, never a panic.
    #[test]
    fn short_standing_and_nan_give_reasons() {
        let mut live = LiveGait::new(LiveGaitParams::default());
        let (_, report) = live.finish();
        assert!(report.reason.unwrap().contains("too few poses"));

        let mut live = LiveGait::new(LiveGaitParams::default());
        let still = Point3::new(1.0, 0.1, 0.9);
        let nan = Point3::new(f64::NAN, 0.0, 0.0);
        for i in 0..300_i64 {
            let joints = [
                (Joint::HipLeft, &still),
                (Joint::HipRight, &still),
                (Joint::AnkleLeft, &still),
                (Joint::AnkleRight, if i % 10 == 0 { &nan } else { &still }),
            ];
            live.push(i * 33_333_333, joints);
            assert!(live.poll().is_empty());
        }
        let (events, report) = live.finish();
        assert!(events.is_empty());
        assert_eq!(report.non_finite_skipped, 30);
        assert!(report.parameters.is_none());
        let reason = report.reason.clone().unwrap();
        assert!(reason.contains("no straight walking"), "{reason}");
        assert!(report.standing_secs > 8.5, "{report:#?}");
    }
}
