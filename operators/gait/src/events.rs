//! Heel strikes and toe offs from joint trajectories.

use nalgebra::Vector2;
use serde::{Deserialize, Serialize};
use trigait_skeleton::MotionClip;

use crate::segment::{Segmentation, WalkingSegment};
use crate::signal::{Tracks, extrema, horizontal, sample};
use crate::{Error, Result};

/// Left or right foot.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Foot {
    /// The left foot.
    Left,
    /// The right foot.
    Right,
}

impl Foot {
    /// Both feet, left first.
    pub const BOTH: [Foot; 2] = [Foot::Left, Foot::Right];

    /// The other foot.
    #[must_use]
    pub fn other(self) -> Foot {
        match self {
            Foot::Left => Foot::Right,
            Foot::Right => Foot::Left,
        }
    }

    /// `"left"` or `"right"`.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Foot::Left => "left",
            Foot::Right => "right",
        }
    }

    pub(crate) fn index(self) -> usize {
        match self {
            Foot::Left => 0,
            Foot::Right => 1,
        }
    }
}

/// Heel strike (initial contact) or toe off (final contact).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EventKind {
    /// The foot touches the floor: stance begins.
    HeelStrike,
    /// The foot leaves the floor: swing begins.
    ToeOff,
}

/// One gait event.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct GaitEvent {
    /// Which foot.
    pub foot: Foot,
    /// Heel strike or toe off.
    pub kind: EventKind,
    /// When (s from the first frame), refined between frames.
    pub time_secs: f64,
    /// Fractional frame index of `time_secs`.
    pub frame: f64,
    /// Index of the walking segment it lies in.
    pub segment: usize,
    /// How far the coordinate method's peak stands out of the foot-minus-pelvis signal (m):
    /// how sure the detector is of the event. `None` for the velocity method and for a heel
    /// strike at the start of a run, whose peak is cut short.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub prominence_m: Option<f64>,
}

/// How gait events are detected.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EventMethod {
    /// Zeni et al. (2008) coordinate method: the heel (ankle) position relative to the pelvis,
    /// along the walking direction, peaks at heel strike (the foot is furthest ahead), and the toe
    /// (foot, else ankle) position relative to the pelvis bottoms out at toe off (the foot is
    /// furthest behind). Needs no threshold and no vertical coordinate, so it tolerates floor
    /// height errors; Zeni et al. report heel-strike errors of 1–2 frames at 120 Hz against a
    /// force plate. Validated for walking only: in running the pelvis–foot relation it relies
    /// on shifts, and toe off comes late.
    Coordinate,
    /// Foot-velocity method after Ghoussayni et al. (2004): a foot is in stance while its
    /// horizontal speed is below a threshold. Heel strike is where the heel (ankle) speed falls
    /// below [`EventParams::heel_strike_speed_fraction`] × the segment's walking speed at the
    /// end of a swing, toe off where the toe (foot, else ankle) speed rises above
    /// [`EventParams::toe_off_speed_fraction`] × walking speed at the start of one. Scaling
    /// with walking speed keeps the thresholds right for slow and fast walkers. In running
    /// (flight phases found) the thresholds are [`EventParams::running_speed_fraction`]: a
    /// running foot is planted and still on the floor between its landing and take-off, so
    /// stance is where it stops, whatever the pelvis does.
    Velocity,
    /// The coordinate method for walking, the velocity method when the clip is running (flight
    /// phases in at least [`RUNNING_FLIGHT_FRACTION`] of the walking time, recurring at least
    /// [`RUNNING_MIN_FLIGHTS_PER_SEC`] times a second). The analysis says which it used.
    #[default]
    Auto,
}

/// Fraction of the walking time in flight (both feet off the floor) above which a clip is
/// running: walking has no flight at all, running 10–40 % of each stride.
pub const RUNNING_FLIGHT_FRACTION: f64 = 0.03;

/// Flight phases per second of walking time below which the flights are tracking noise, not
/// running: a runner is airborne between *every* two contacts, at 150 steps/min (2.5 steps/s) or
/// more, so even a tracker that misses half of the short flights sees 1.25 a second. A Kinect
/// ankle that lifts in terminal stance (heel off) while the other foot is still swinging, or a
/// far-range noisy pair of feet, gives isolated "flights" at a fraction of the step rate (the
/// CHU walking log: 3 in 5.4 s of walking, 0.55 /s, yet 10 % of its frames).
pub const RUNNING_MIN_FLIGHTS_PER_SEC: f64 = 1.25;

impl EventMethod {
    /// The detector run on a clip judged running (`running`) or walking: `Auto` picks the
    /// velocity method for running and the coordinate method for walking.
    pub(crate) fn for_clip(self, running: bool) -> Self {
        match self {
            EventMethod::Auto if running => EventMethod::Velocity,
            EventMethod::Auto => EventMethod::Coordinate,
            m => m,
        }
    }

    /// Name used on the command line and in JSON.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            EventMethod::Coordinate => "coordinate",
            EventMethod::Velocity => "velocity",
            EventMethod::Auto => "auto",
        }
    }
}

/// Tuning of the event detectors.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct EventParams {
    /// Which detector.
    pub method: EventMethod,
    /// Coordinate method: the smallest prominence (m) of a peak of the foot-minus-pelvis
    /// signal. Default 0.04 m: the signal swings ±0.2–0.4 m per stride, Kinect ankle noise is
    /// ≈ 1 cm, and a heel strike 50 ms before the clip ends already shows a 5 cm drop.
    pub min_prominence_m: f64,
    /// Both methods: events of the same kind and foot closer than this (s) are merged, keeping
    /// the more prominent. Default 0.4 s, below the shortest stride time of walking (≈ 0.8 s).
    pub min_separation_secs: f64,
    /// Velocity method: heel-strike threshold on the heel stand-in's horizontal speed, as a
    /// fraction of the segment's walking speed. Default 1.0. Ghoussayni et al. used 0.5 m/s on a
    /// heel marker (≈ 0.4 × walking speed), but the *ankle* keeps rolling forward over the heel
    /// after contact: on the CMU and OpenSim walks a 0.4 threshold fires 120–150 ms after the
    /// heel marker reaches the floor, 1.0 fires 50–65 ms after it, like the coordinate method.
    pub heel_strike_speed_fraction: f64,
    /// Velocity method: toe-off threshold on the toe stand-in's horizontal speed, as a fraction
    /// of the segment's walking speed. Default 0.4 (Ghoussayni's 0.5 m/s at 1.25 m/s).
    pub toe_off_speed_fraction: f64,
    /// Velocity method: a swing must reach this multiple of its threshold. Default 1.8 (a
    /// swinging foot moves at 2–3 × walking speed).
    pub swing_peak_factor: f64,
    /// Velocity method in running: heel-strike and toe-off threshold as a fraction of the
    /// running speed. Default 0.5: a running foot moves at 1.5–2 × running speed in swing and
    /// is still in stance, and the pelvis no longer rolls the ankle forward over the heel as
    /// it does in walking, so one low threshold fits both events.
    pub running_speed_fraction: f64,
}

impl Default for EventParams {
    fn default() -> Self {
        Self {
            method: EventMethod::Auto,
            min_prominence_m: 0.04,
            min_separation_secs: 0.4,
            heel_strike_speed_fraction: 1.0,
            toe_off_speed_fraction: 0.4,
            swing_peak_factor: 1.8,
            running_speed_fraction: 0.5,
        }
    }
}

impl EventParams {
    pub(crate) fn validate(&self) -> Result<()> {
        let check = |name, value: f64, ok: bool| {
            if value.is_finite() && ok {
                Ok(())
            } else {
                Err(Error::BadParameter {
                    name,
                    value,
                    expected: "a positive finite number",
                })
            }
        };
        check(
            "min_prominence_m",
            self.min_prominence_m,
            self.min_prominence_m >= 0.0,
        )?;
        check(
            "min_separation_secs",
            self.min_separation_secs,
            self.min_separation_secs > 0.0,
        )?;
        check(
            "heel_strike_speed_fraction",
            self.heel_strike_speed_fraction,
            self.heel_strike_speed_fraction > 0.0,
        )?;
        check(
            "toe_off_speed_fraction",
            self.toe_off_speed_fraction,
            self.toe_off_speed_fraction > 0.0,
        )?;
        check(
            "running_speed_fraction",
            self.running_speed_fraction,
            self.running_speed_fraction > 0.0,
        )?;
        check(
            "swing_peak_factor",
            self.swing_peak_factor,
            self.swing_peak_factor >= 1.0,
        )
    }
}

/// Heel strikes and toe offs of both feet inside the walking segments of `segmentation`,
/// sorted by time.
///
/// Only turning points seen *inside* a segment are events: an extremum on a segment's first or
/// last frame (coordinate method), or a speed crossing whose swing is cut by a segment end
/// (velocity method), is left out, because the true event may lie outside what was recorded.
/// So a clip that starts in mid-stance yields no heel strike for that stance, and partial strides
/// at the ends contribute the events that were observed and nothing invented.
///
/// # Errors
/// [`Error::MissingJoint`] without ankles or a pelvis, [`Error::BadParameter`] for invalid
/// tuning.
pub fn detect_events(
    clip: &MotionClip,
    segmentation: &Segmentation,
    params: &EventParams,
) -> Result<Vec<GaitEvent>> {
    params.validate()?;
    let tracks = Tracks::from_clip(clip)?;
    Ok(detect_in_tracks(&tracks, segmentation, params, false))
}

/// Events in every segment; `Auto` is the coordinate method unless `running`, and the velocity
/// method uses the running thresholds when `running`.
pub(crate) fn detect_in_tracks(
    tracks: &Tracks,
    segmentation: &Segmentation,
    params: &EventParams,
    running: bool,
) -> Vec<GaitEvent> {
    let method = params.method.for_clip(running);
    let mut params = *params;
    if running {
        params.heel_strike_speed_fraction = params.running_speed_fraction;
        params.toe_off_speed_fraction = params.running_speed_fraction;
    }
    let params = &params;
    let mut events = Vec::new();
    for (index, segment) in segmentation.segments.iter().enumerate() {
        for foot in Foot::BOTH {
            match method {
                EventMethod::Coordinate | EventMethod::Auto => {
                    coordinate_events(tracks, segment, index, foot, params, &mut events);
                }
                EventMethod::Velocity => {
                    velocity_events(tracks, segment, index, foot, params, &mut events);
                }
            }
        }
    }
    events.sort_by(|a, b| a.time_secs.total_cmp(&b.time_secs));
    events
}

fn push(
    events: &mut Vec<GaitEvent>,
    tracks: &Tracks,
    segment_index: usize,
    foot: Foot,
    kind: EventKind,
    frame: f64,
    prominence_m: Option<f64>,
) {
    events.push(GaitEvent {
        foot,
        kind,
        time_secs: tracks.time(frame),
        frame,
        segment: segment_index,
        prominence_m,
    });
}

/// Zeni et al. (2008): HS at maxima of (heel − pelvis)·d, TO at minima of (toe − pelvis)·d.
fn coordinate_events(
    tracks: &Tracks,
    segment: &WalkingSegment,
    segment_index: usize,
    foot: Foot,
    params: &EventParams,
    events: &mut Vec<GaitEvent>,
) {
    let relative = |track| relative_to_pelvis(tracks, segment, track);
    let separation = params.min_separation_secs * tracks.rate_hz;
    let first = segment.first_frame as f64;
    // Each gap-free run on its own: a peak next to a bridged gap is not known to be one.
    for (kind, maxima, track) in [
        (EventKind::HeelStrike, true, &tracks.heel[foot.index()]),
        (EventKind::ToeOff, false, &tracks.toe[foot.index()]),
    ] {
        for (offset, values) in runs_of(&relative(track)) {
            for e in extrema(&values, maxima, params.min_prominence_m, separation) {
                push(
                    events,
                    tracks,
                    segment_index,
                    foot,
                    kind,
                    first + offset as f64 + e.index,
                    Some(e.prominence),
                );
            }
        }
    }
}

/// `track` minus the pelvis, horizontal, along the segment's walking direction, for each frame
/// of the segment (`None` where either is missing).
fn relative_to_pelvis(
    tracks: &Tracks,
    segment: &WalkingSegment,
    track: &[Option<nalgebra::Point3<f64>>],
) -> Vec<Option<f64>> {
    let d = segment.direction();
    (segment.first_frame..=segment.last_frame)
        .map(|f| {
            let p = track.get(f).copied().flatten()?;
            let pelvis = tracks.pelvis.get(f).copied().flatten()?;
            Some(horizontal(&(p - pelvis)).dot(&d))
        })
        .collect()
}

/// Coordinate-method heel-strike candidates at the start of a gap-free run, which
/// [`detect_in_tracks`] leaves out: the heel's highest point ahead of the pelvis before the
/// signal first falls [`EventParams::min_prominence_m`] below it, when nothing before it in the
/// run lies that far below (the run's start cuts the peak's left side short, so it is no
/// prominent peak for [`extrema`]).
///
/// Such a peak is not known to be a turning point: the recording (or the gap) may begin in
/// terminal swing, a few frames before the landing (the treadmill recording in `shared/data`
/// starts 52 ms before a plate contact), or in mid-stance, when the heel falls back behind the
/// pelvis from the first frame on. So these are only candidates: the caller keeps one only if
/// the heel marker is seen to land after it (see `refine_heel_strikes` in `params.rs`), which a
/// heel already resting on the floor never does.
pub(crate) fn edge_heel_strikes(
    tracks: &Tracks,
    segmentation: &Segmentation,
    params: &EventParams,
) -> Vec<GaitEvent> {
    let mut events = Vec::new();
    for (index, segment) in segmentation.segments.iter().enumerate() {
        for foot in Foot::BOTH {
            let values = relative_to_pelvis(tracks, segment, &tracks.heel[foot.index()]);
            for (offset, run) in runs_of(&values) {
                let mut peak = 0;
                for (i, v) in run.iter().enumerate() {
                    if *v > run[peak] {
                        peak = i;
                    }
                    let floor = run[peak] - params.min_prominence_m;
                    if *v < floor {
                        if run[..peak].iter().all(|b| *b > floor) {
                            let frame = (segment.first_frame + offset + peak) as f64;
                            push(
                                &mut events,
                                tracks,
                                index,
                                foot,
                                EventKind::HeelStrike,
                                frame,
                                None,
                            );
                        }
                        break;
                    }
                }
            }
        }
    }
    events
}

/// Maximal runs of present values: (index of the first, the values).
fn runs_of<T: Copy>(values: &[Option<T>]) -> Vec<(usize, Vec<T>)> {
    let mut out: Vec<(usize, Vec<T>)> = Vec::new();
    let mut current: Option<(usize, Vec<T>)> = None;
    for (i, v) in values.iter().enumerate() {
        match (v, current.as_mut()) {
            (Some(v), Some((_, run))) => run.push(*v),
            (Some(v), None) => current = Some((i, vec![*v])),
            (None, _) => out.extend(current.take()),
        }
    }
    out.extend(current);
    out
}

/// Horizontal speed of `track` over the segment, one run per gap-free stretch: (index of the
/// run's first frame in the segment, speeds by central differences, one-sided at run ends).
fn horizontal_speed_runs(
    tracks: &Tracks,
    track: &[Option<nalgebra::Point3<f64>>],
    segment: &WalkingSegment,
) -> Vec<(usize, Vec<f64>)> {
    let positions: Vec<Option<Vector2<f64>>> = (segment.first_frame..=segment.last_frame)
        .map(|f| {
            track
                .get(f)
                .copied()
                .flatten()
                .map(|p| Vector2::new(p.x, p.y))
        })
        .collect();
    runs_of(&positions)
        .into_iter()
        .filter(|(_, run)| run.len() >= 2)
        .map(|(offset, run)| {
            let last = run.len() - 1;
            let speeds = (0..run.len())
                .map(|i| {
                    let (lo, hi) = (i.saturating_sub(1), (i + 1).min(last));
                    (run[hi] - run[lo]).norm() * tracks.rate_hz / (hi - lo) as f64
                })
                .collect();
            (offset, speeds)
        })
        .collect()
}

/// Swing phases of a speed signal: maximal runs at or above `threshold` that reach
/// `peak`, with dips shorter than `merge` samples bridged. Returns (start, end) sample indices.
fn swings(speed: &[f64], threshold: f64, peak: f64, merge: usize) -> Vec<(usize, usize)> {
    let mut runs: Vec<(usize, usize)> = Vec::new();
    for run in trigait_skeleton::frame_runs(speed.len(), |i| speed[i] >= threshold) {
        let (start, end) = (run.start, run.end - 1);
        match runs.last_mut() {
            Some(last) if start - last.1 <= merge => last.1 = end,
            _ => runs.push((start, end)),
        }
    }
    runs.retain(|(s, e)| speed[*s..=*e].iter().any(|v| *v >= peak));
    runs
}

/// Ghoussayni et al. (2004), horizontal speed against a speed-scaled threshold. A heel strike
/// needs at least 0.1 s of observed stance after it and a toe off 0.1 s before it; each
/// gap-free run of the segment is treated like a segment of its own.
fn velocity_events(
    tracks: &Tracks,
    segment: &WalkingSegment,
    segment_index: usize,
    foot: Foot,
    params: &EventParams,
    events: &mut Vec<GaitEvent>,
) {
    let merge = (0.1 * tracks.rate_hz).round() as usize;
    let min_stance = ((0.1 * tracks.rate_hz).round() as usize).max(2);
    let first = segment.first_frame as f64;
    let crossing = |speed: &[f64], threshold: f64, i: usize, j: usize| -> f64 {
        // Linear interpolation of the threshold crossing between samples i and j = i ± 1.
        let (si, sj) = (speed[i], speed[j]);
        let frac = if (sj - si).abs() > 1e-12 {
            ((threshold - si) / (sj - si)).clamp(0.0, 1.0)
        } else {
            0.0
        };
        i as f64 + frac * (j as f64 - i as f64)
    };
    let threshold = params.heel_strike_speed_fraction * segment.speed_mps;
    let peak = params.swing_peak_factor * threshold;
    let mut previous: Option<f64> = None;
    for (offset, heel) in horizontal_speed_runs(tracks, &tracks.heel[foot.index()], segment) {
        let first = first + offset as f64;
        let last = heel.len() - 1;
        let runs = swings(&heel, threshold, peak, merge);
        for (k, &(_, end)) in runs.iter().enumerate() {
            // The stance that follows must be seen for `min_stance` samples (or until the next
            // swing): a foot slowing in terminal swing as the recording ends is no heel strike.
            let stance_end = runs.get(k + 1).map_or(last + 1, |next| next.0);
            if end >= last || stance_end - (end + 1) < min_stance {
                continue;
            }
            let f = first + crossing(&heel, threshold, end, end + 1);
            if previous.is_none_or(|p| f - p >= params.min_separation_secs * tracks.rate_hz) {
                push(
                    events,
                    tracks,
                    segment_index,
                    foot,
                    EventKind::HeelStrike,
                    f,
                    None,
                );
                previous = Some(f);
            }
        }
    }
    let threshold = params.toe_off_speed_fraction * segment.speed_mps;
    let peak = params.swing_peak_factor * threshold;
    let mut previous: Option<f64> = None;
    for (offset, toe) in horizontal_speed_runs(tracks, &tracks.toe[foot.index()], segment) {
        let first = first + offset as f64;
        let runs = swings(&toe, threshold, peak, merge);
        for (k, &(start, _)) in runs.iter().enumerate() {
            // The stance before must have been seen for `min_stance` samples (or since the
            // previous swing); a swing under way at the segment start has no observed toe off.
            let stance_start = match k.checked_sub(1).and_then(|p| runs.get(p)) {
                Some(previous_swing) => previous_swing.1 + 1,
                None => 0,
            };
            if start == 0 || start - stance_start < min_stance {
                continue;
            }
            let f = first + crossing(&toe, threshold, start - 1, start);
            if previous.is_none_or(|p| f - p >= params.min_separation_secs * tracks.rate_hz) {
                push(
                    events,
                    tracks,
                    segment_index,
                    foot,
                    EventKind::ToeOff,
                    f,
                    None,
                );
                previous = Some(f);
            }
        }
    }
}

/// Position of the heel stand-in of `foot` at fractional `frame`.
pub(crate) fn heel_at(tracks: &Tracks, foot: Foot, frame: f64) -> Option<nalgebra::Point3<f64>> {
    sample(&tracks.heel[foot.index()], frame)
}

/// Forward travel (m) a foot covers, at least, in the [`SWING_WINDOW_SECS`] before its heel
/// strike or after its toe off. A heel strike ends a swing and a toe off starts one, and a
/// swinging foot crosses a stride length (0.6–1.8 m) in 0.35–0.5 s; even a slow walker's foot
/// moves 0.2–0.3 m in the last 0.3 s of its swing. A foot in stance moves only by its
/// tracker's noise: a Kinect ankle that wobbles 6–9 cm forward for a frame or two peaks like a
/// heel strike in the coordinate method's signal, but its position over the window is the same.
pub const MIN_SWING_TRAVEL_M: f64 = 0.10;

/// The window over which [`MIN_SWING_TRAVEL_M`] is measured (s).
pub const SWING_WINDOW_SECS: f64 = 0.3;

/// Whether the foot of `event` is seen swinging next to it: its heel stand-in, median of three
/// frames at each end, travels at least [`MIN_SWING_TRAVEL_M`] along its segment's walking
/// direction over the [`SWING_WINDOW_SECS`] before a heel strike or after a toe off. The far end
/// stays inside the event's segment (before it the walker was turning or standing, and the foot
/// moved along another direction or not at all) and may come up to half the window closer
/// where the track has a gap or the segment begins or ends; when the foot is not seen there at
/// all, or not at the event, nothing is known and the event stands.
pub(crate) fn swing_seen(tracks: &Tracks, segmentation: &Segmentation, event: &GaitEvent) -> bool {
    let Some(segment) = segmentation.segments.get(event.segment) else {
        return true;
    };
    let d = segment.direction();
    let track = &tracks.heel[event.foot.index()];
    let along = |f: usize| -> Option<f64> {
        let mut v: Vec<f64> = (f.saturating_sub(1)..=f + 1)
            .filter_map(|i| track.get(i).copied().flatten())
            .map(|p| horizontal(&p.coords).dot(&d))
            .collect();
        if v.is_empty() {
            return None;
        }
        v.sort_by(f64::total_cmp);
        Some(v[v.len() / 2])
    };
    let at = event.frame.round().max(0.0) as usize;
    let Some(here) = along(at) else {
        return true;
    };
    let window = (SWING_WINDOW_SECS * tracks.rate_hz).round().max(2.0) as usize;
    let heel_strike = event.kind == EventKind::HeelStrike;
    // The far end, from the whole window back towards half of it, within the segment.
    let far = (window.div_ceil(2)..=window).rev().find_map(|k| {
        let f = if heel_strike {
            at.checked_sub(k)?
        } else {
            at + k
        };
        (segment.first_frame..=segment.last_frame)
            .contains(&f)
            .then(|| along(f))
            .flatten()
    });
    let Some(far) = far else {
        return true;
    };
    let travel = if heel_strike { here - far } else { far - here };
    travel >= MIN_SWING_TRAVEL_M
}

#[cfg(test)]
mod tests {
    use nalgebra::Point3;

    use super::*;
    use crate::HeelSource;

    /// A left heel along +x at 30 Hz, the right one still, one segment over all frames.
    fn walk(left_x: &[f64]) -> (Tracks, Segmentation) {
        let n = left_x.len();
        let at = |x: f64| Some(Point3::new(x, 0.1, 0.08));
        let tracks = Tracks {
            rate_hz: 30.0,
            pelvis: (0..n).map(|i| at(i as f64 * 0.04)).collect(),
            heel: [left_x.iter().map(|x| at(*x)).collect(), vec![at(0.0); n]],
            toe: [vec![None; n], vec![None; n]],
            heel_source: HeelSource::AnkleCentre,
        };
        let segment = WalkingSegment {
            first_frame: 0,
            last_frame: n - 1,
            start_secs: 0.0,
            end_secs: (n - 1) as f64 / 30.0,
            direction: [1.0, 0.0],
            speed_mps: 1.2,
        };
        let segmentation = Segmentation {
            segments: vec![segment],
            excluded: Vec::new(),
        };
        (tracks, segmentation)
    }

    fn event(kind: EventKind, frame: f64) -> GaitEvent {
        GaitEvent {
            foot: Foot::Left,
            kind,
            time_secs: frame / 30.0,
            frame,
            segment: 0,
            prominence_m: Some(0.05),
        }
    }

    #[test]
    fn events_need_a_swing_next_to_them() {
        // Stance at 0, a wobble 9 cm forward for two frames at 12–13, stance again, then a
        // swing from frame 20 that lands at 0.9 m on frame 30 and stays.
        let mut x = vec![0.0; 40];
        x[12] = 0.09;
        x[13] = 0.06;
        for (i, v) in x.iter_mut().enumerate().skip(20) {
            *v = 0.9 * ((i - 20) as f64 / 10.0).min(1.0);
        }
        let (tracks, seg) = walk(&x);
        assert!(!swing_seen(
            &tracks,
            &seg,
            &event(EventKind::HeelStrike, 12.0)
        ));
        assert!(swing_seen(
            &tracks,
            &seg,
            &event(EventKind::HeelStrike, 30.0)
        ));
        // A toe off needs the swing after it.
        assert!(swing_seen(&tracks, &seg, &event(EventKind::ToeOff, 20.0)));
        assert!(!swing_seen(&tracks, &seg, &event(EventKind::ToeOff, 5.0)));
        // Nothing seen before a heel strike (a gap over the whole window): it stands.
        let mut unseen = tracks.clone();
        for p in &mut unseen.heel[0][15..29] {
            *p = None;
        }
        assert!(swing_seen(
            &unseen,
            &seg,
            &event(EventKind::HeelStrike, 30.0)
        ));
    }

    /// The window does not reach out of the event's segment. The last toe off before a turn,
    /// at frame 40: the foot swings 0.15 m forward until frame 43, where the walking segment
    /// ends, and is then planted 5 cm behind where it left (the walker turning on it). Measured
    /// over the whole 0.3 s, into the turn, the foot went backwards and the toe off would be
    /// taken for a wobble in stance; the segment holds less than half the window after it, so
    /// nothing is known and the event stands. Inside a segment the window still tells a foot
    /// that stands from one that swings.
    #[test]
    fn the_swing_window_stays_in_the_segment() {
        let mut x = vec![0.0; 50];
        for (i, v) in x.iter_mut().enumerate().skip(40) {
            *v = if i <= 43 {
                0.05 * (i - 40) as f64
            } else {
                -0.05
            };
        }
        let (tracks, mut seg) = walk(&x);
        let to = event(EventKind::ToeOff, 40.0);
        assert!(!swing_seen(&tracks, &seg, &to), "into the turn");
        seg.segments[0].last_frame = 43;
        assert!(swing_seen(&tracks, &seg, &to));
        assert!(!swing_seen(&tracks, &seg, &event(EventKind::ToeOff, 25.0)));
    }
}
