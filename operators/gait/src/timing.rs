//! Whether the events keep a human rhythm at the clip's sample rate.
//!
//! A file's time base can be wrong while every position in it is right: Kinect SDK text without
//! time stamps is read at the Kinect's 30 frames/s, but a logger that wrote only some frames, or
//! wrote them at its own pace, leaves fewer lines per second. Nothing in the positions shows it,
//! and every duration (cadence, speed, stance) is then off by the same factor. The legs do show
//! it: a swinging leg is a pendulum driven by the hip, and it needs time. Walking swing lasts
//! about 0.4 s (38–40 % of a 1.0–1.2 s stride); even at top sprinting speed it stays near
//! 0.35 s, because faster runners press harder on the ground rather than swing their legs
//! faster (Weyand et al. 2000). Step frequency tops out near 5 steps/s in elite sprinting. A
//! median swing shorter than [`MIN_HUMAN_SWING_SECS`], or a median step shorter than
//! [`MIN_HUMAN_STEP_SECS`], therefore says the clock is wrong, not the walker. So does a walk
//! (no flight phase) faster than [`MAX_HUMAN_WALKING_SPEED_MPS`]: a clock running ten times
//! fast turns a stroll into a sprint's rhythm, which a swing and a step still allow, but at
//! 6 m/s with a foot always on the floor.
//!
//! The check only flags; it does not guess the true rate. Estimating a rate from gait norms
//! would make every figure then read from the file a restatement of those norms. It does say
//! how slow the true rate must at least be: the medians span a number of frames whatever the
//! rate, so the highest rate at which those frames are still a human swing and step bounds the
//! rate the file was logged at from above ([`Timing::highest_human_rate_hz`]). The bound is
//! approximate: the filter and the event windows depend on the rate, so the events found at
//! another rate span slightly different frames.
//!
//! Reference: Weyand, Sternlight, Bellizzi, Wright (2000). Faster top running speeds are
//! achieved with greater ground forces not more rapid leg movements. *J. Appl. Physiol.* 89(5),
//! 1991–1999 (swing time 0.37 ± 0.02 s at top speed, independent of the runner's speed).

use serde::{Deserialize, Serialize};

use crate::{EventKind, Foot, GaitEvent, Step};

/// Shortest median swing (s) a human leg makes: well under the ≈0.35 s of top-speed sprinting.
pub const MIN_HUMAN_SWING_SECS: f64 = 0.25;

/// Shortest median step (s): well under the ≈0.2 s of elite sprinting (5 steps/s).
pub const MIN_HUMAN_STEP_SECS: f64 = 0.15;

/// Fastest median speed (m/s) of a walk, a foot always on the floor: elite race walkers hold
/// about 4.35 m/s over 20 km (the world record, 1 h 16 min 36 s), and faster than that a
/// person runs, with flight phases.
pub const MAX_HUMAN_WALKING_SPEED_MPS: f64 = 4.5;

/// Fewest swings (or steps) a median needs before it is judged.
const MIN_SAMPLES: usize = 2;

/// The rhythm of the detected events at the clip's rate.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Timing {
    /// Swings measured: a toe off and the same foot's next heel strike in one segment, with no
    /// other event of that foot between.
    pub swings: usize,
    /// Their median duration (s).
    pub median_swing_secs: Option<f64>,
    /// Steps measured.
    pub steps: usize,
    /// Their median duration (s).
    pub median_step_secs: Option<f64>,
    /// Strides of a walk (no flight phase in the clip) whose speed was measured.
    #[serde(default)]
    pub walking_strides: usize,
    /// Their median speed (m/s).
    #[serde(default)]
    pub median_walking_speed_mps: Option<f64>,
    /// Whether the swings or steps are shorter than a human leg can make them
    /// ([`MIN_HUMAN_SWING_SECS`], [`MIN_HUMAN_STEP_SECS`]), or the walk faster than a person
    /// walks ([`MAX_HUMAN_WALKING_SPEED_MPS`]): the clip's time base is then probably wrong.
    pub implausible: bool,
    /// The highest frame rate (Hz) at which the median swing and step, counted in frames,
    /// would still last [`MIN_HUMAN_SWING_SECS`] and [`MIN_HUMAN_STEP_SECS`] (and the walk be
    /// no faster than [`MAX_HUMAN_WALKING_SPEED_MPS`]): at or above the
    /// clip's rate when its rhythm is human, and an upper bound on the true rate when it is
    /// not. `None` when neither median was measured.
    #[serde(default)]
    pub highest_human_rate_hz: Option<f64>,
}

/// Swing durations (s) of `events`, in no particular order.
fn swings(events: &[GaitEvent]) -> Vec<f64> {
    let mut out = Vec::new();
    for foot in Foot::BOTH {
        let mut own: Vec<&GaitEvent> = events.iter().filter(|e| e.foot == foot).collect();
        own.sort_by(|a, b| a.time_secs.total_cmp(&b.time_secs));
        for pair in own.windows(2) {
            let [off, strike] = [pair[0], pair[1]];
            if off.kind == EventKind::ToeOff
                && strike.kind == EventKind::HeelStrike
                && off.segment == strike.segment
            {
                out.push(strike.time_secs - off.time_secs);
            }
        }
    }
    out
}

/// Judges the rhythm of `events` and `steps`, and the speed of a walk's strides
/// (`walking_speeds`, m/s: empty when the clip is running), timed at `rate_hz` frames per
/// second.
#[must_use]
pub fn check(events: &[GaitEvent], steps: &[Step], walking_speeds: &[f64], rate_hz: f64) -> Timing {
    let mut swing = swings(events);
    let mut step: Vec<f64> = steps.iter().map(|s| s.step_time_secs).collect();
    let mut speed: Vec<f64> = walking_speeds
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .collect();
    let (swings, steps, walking_strides) = (swing.len(), step.len(), speed.len());
    let median_swing_secs = (swings >= MIN_SAMPLES).then(|| crate::clean::median(&mut swing));
    let median_step_secs = (steps >= MIN_SAMPLES).then(|| crate::clean::median(&mut step));
    let median_walking_speed_mps =
        (walking_strides >= MIN_SAMPLES).then(|| crate::clean::median(&mut speed));
    let implausible = median_swing_secs.is_some_and(|s| s < MIN_HUMAN_SWING_SECS)
        || median_step_secs.is_some_and(|s| s < MIN_HUMAN_STEP_SECS)
        || median_walking_speed_mps.is_some_and(|v| v > MAX_HUMAN_WALKING_SPEED_MPS);
    let highest_human_rate_hz = [
        median_swing_secs.map(|s| rate_hz * s / MIN_HUMAN_SWING_SECS),
        median_step_secs.map(|s| rate_hz * s / MIN_HUMAN_STEP_SECS),
        median_walking_speed_mps
            .filter(|v| *v > 0.0)
            .map(|v| rate_hz * MAX_HUMAN_WALKING_SPEED_MPS / v),
    ]
    .into_iter()
    .flatten()
    .reduce(f64::min);
    Timing {
        swings,
        median_swing_secs,
        steps,
        median_step_secs,
        walking_strides,
        median_walking_speed_mps,
        implausible,
        highest_human_rate_hz,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn event(foot: Foot, kind: EventKind, t: f64) -> GaitEvent {
        GaitEvent {
            foot,
            kind,
            time_secs: t,
            frame: t * 100.0,
            segment: 0,
            prominence_m: None,
        }
    }

    /// A 1.1 s stride with 40 % swing passes; the same events on a clock running 3× fast
    /// (every time divided by 3) are flagged, with the bound on the true rate a third of the
    /// bound at the right clock.
    #[test]
    fn a_fast_clock_is_flagged() {
        let walk = |scale: f64| -> Vec<GaitEvent> {
            let mut v = Vec::new();
            for k in 0..4 {
                let t = k as f64 * 1.1;
                v.push(event(Foot::Left, EventKind::HeelStrike, t / scale));
                v.push(event(Foot::Left, EventKind::ToeOff, (t + 0.66) / scale));
                v.push(event(
                    Foot::Right,
                    EventKind::HeelStrike,
                    (t + 0.55) / scale,
                ));
                v.push(event(Foot::Right, EventKind::ToeOff, (t + 0.11) / scale));
            }
            v
        };
        let real = check(&walk(1.0), &[], &[], 100.0);
        assert_eq!(real.swings, 7, "{real:?}");
        assert!((real.median_swing_secs.unwrap() - 0.44).abs() < 1e-9);
        assert!(!real.implausible);
        let bound = real.highest_human_rate_hz.unwrap();
        assert!(
            (bound - 100.0 * 0.44 / MIN_HUMAN_SWING_SECS).abs() < 1e-9,
            "{bound}"
        );
        let fast = check(&walk(3.0), &[], &[], 100.0);
        assert!(fast.implausible, "{fast:?}");
        let fast_bound = fast.highest_human_rate_hz.unwrap();
        assert!(fast_bound < 100.0, "{fast:?}");
        assert!((fast_bound - bound / 3.0).abs() < 1e-9, "{fast:?}");
    }

    /// With both medians, the bound is the tighter one: swings of 0.44 s allow 176 Hz at 100
    /// Hz, steps of 0.12 s only 80 Hz, and the steps alone make the clip implausible.
    #[test]
    fn the_tighter_median_bounds_the_rate() {
        let mut events = Vec::new();
        for k in 0..3 {
            let t = f64::from(k) * 1.1;
            events.push(event(Foot::Left, EventKind::ToeOff, t));
            events.push(event(Foot::Left, EventKind::HeelStrike, t + 0.44));
        }
        let step = |start_secs: f64| crate::Step {
            foot: Foot::Left,
            segment: 0,
            start_secs,
            end_secs: start_secs + 0.12,
            step_time_secs: 0.12,
            cadence_steps_per_min: 500.0,
            step_length_m: None,
            step_width_m: None,
            pelvis_travel_m: None,
        };
        let t = check(&events, &[step(0.0), step(0.5), step(1.0)], &[], 100.0);
        assert!(t.implausible, "{t:?}");
        let bound = t.highest_human_rate_hz.unwrap();
        assert!(
            (bound - 100.0 * 0.12 / MIN_HUMAN_STEP_SECS).abs() < 1e-9,
            "{t:?}"
        );
    }

    /// One swing is too little to judge; swings across segments are not swings.
    #[test]
    fn too_few_swings_are_not_judged() {
        let mut events = vec![
            event(Foot::Left, EventKind::ToeOff, 0.0),
            event(Foot::Left, EventKind::HeelStrike, 0.1),
            event(Foot::Right, EventKind::ToeOff, 0.2),
        ];
        let mut strike = event(Foot::Right, EventKind::HeelStrike, 0.3);
        strike.segment = 1;
        events.push(strike);
        let t = check(&events, &[], &[], 100.0);
        assert_eq!(t.swings, 1);
        assert_eq!(t.median_swing_secs, None);
        assert!(!t.implausible);
        assert_eq!(t.highest_human_rate_hz, None);
    }

    /// A walk at 1.3 m/s passes; the same strides on a clock running five times fast walk at
    /// 6.5 m/s with a foot always on the floor, which nobody does, and the bound on the true
    /// rate is a fifth of the one at the right clock. A run (no walking speeds given) is not
    /// judged by speed.
    #[test]
    fn a_walk_faster_than_anyone_walks_is_flagged() {
        let real = check(&[], &[], &[1.3, 1.25, 1.35], 30.0);
        assert_eq!(real.walking_strides, 3);
        assert!(!real.implausible, "{real:?}");
        let bound = real.highest_human_rate_hz.unwrap();
        assert!((bound - 30.0 * MAX_HUMAN_WALKING_SPEED_MPS / 1.3).abs() < 1e-9);
        let fast = check(&[], &[], &[6.5, 6.25, 6.75], 150.0);
        assert!(fast.implausible, "{fast:?}");
        let fast_bound = fast.highest_human_rate_hz.unwrap();
        assert!(
            fast_bound < 150.0 && (fast_bound - bound).abs() < 1e-9,
            "{fast:?}"
        );
        assert!(!check(&[], &[], &[], 150.0).implausible);
    }
}
