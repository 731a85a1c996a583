//! What the feet can physically be doing: on the floor or in the air.
//!
//! The event detectors look at horizontal motion (the coordinate method does not even need a
//! vertical axis), so by themselves they will place a "heel strike" wherever a foot stops
//! moving forward relative to the pelvis — also at the top of a hop. These checks add the
//! vertical: each foot's *stance level* is the low quantile of its own height over a sliding
//! window (so a floor that slopes, a treadmill deck, a skeleton whose floor is not at z = 0, or
//! an ankle centre 8 cm above the sole all give the right level), and a foot is *airborne* when
//! it is clearly above that level.
//!
//! * An event is kept only if its landmark is within [`PhysicsParams::event_gate_m`] of its stance
//!   level, and, in a clip judged running, not inside a flight phase. A heel strike may instead
//!   reach that height within [`CONTACT_WINDOW_SECS`] after its instant: the coordinate method
//!   fires where the foot stops moving *forward*, and a skeleton tracker's ankle (a Kinect's,
//!   walking towards it) can come down a few frames after it has stopped. A toe off may likewise
//!   have been at that height within the window before it: without a foot joint the ankle stands
//!   in for the toe, and the ankle rises with the heel before the toes leave the floor. A hop's
//!   foot, 0.2–0.4 m up at the apex, falls only g·t²/2 ≈ 8 cm in that time and stays rejected.
//! * A **flight phase** is a stretch where *both* feet (lowest of heel and toe) are more than
//!   [`PhysicsParams::flight_gate_m`] above their levels for at least
//!   [`PhysicsParams::min_flight_secs`]: running, hopping, jumping. Walking never has one, but
//!   a tracker's noise can make one (see [`Heights::allows`]).

use serde::{Deserialize, Serialize};

use crate::signal::Landmarks;
use crate::{Error, Foot, Result};

/// Tuning of the airborne checks.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PhysicsParams {
    /// A heel strike or toe off is rejected when its landmark is higher than this above its
    /// stance level (m). Default 0.10 m: at a real contact the heel or toe is within a few
    /// centimetres of it (the coordinate method fires up to ~2 frames early or late), a hop's
    /// feet are 0.2–0.4 m up.
    pub event_gate_m: f64,
    /// Both feet above their levels by more than this (m) is flight. Default 0.05 m, above the
    /// 1–2 cm of marker or Kinect noise and the few cm a stance heel rises before toe off (the
    /// lower of heel and toe counts, and the toe stays down).
    pub flight_gate_m: f64,
    /// Shortest flight (s). Default 0.04 s.
    pub min_flight_secs: f64,
    /// Half-width of the window the stance level is taken over (s). Default 1.0 s: at least a
    /// stride, so it always holds a stance, and short enough to follow a slope.
    pub level_window_secs: f64,
}

impl Default for PhysicsParams {
    fn default() -> Self {
        Self {
            event_gate_m: 0.10,
            flight_gate_m: 0.05,
            min_flight_secs: 0.04,
            level_window_secs: 1.0,
        }
    }
}

impl PhysicsParams {
    pub(crate) fn validate(&self) -> Result<()> {
        for (name, value) in [
            ("event_gate_m", self.event_gate_m),
            ("flight_gate_m", self.flight_gate_m),
            ("min_flight_secs", self.min_flight_secs),
            ("level_window_secs", self.level_window_secs),
        ] {
            if !(value.is_finite() && value > 0.0) {
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

/// A stretch with both feet off the floor.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FlightPhase {
    /// First airborne frame's time (s).
    pub start_secs: f64,
    /// Last airborne frame's time (s).
    pub end_secs: f64,
    /// First airborne frame.
    pub first_frame: usize,
    /// Last airborne frame.
    pub last_frame: usize,
}

/// Heights of every landmark above its own stance level.
#[derive(Debug, Clone)]
pub(crate) struct Heights {
    /// Frames per second of the tracks.
    pub rate_hz: f64,
    /// Heel heights above the heel's level, left then right.
    pub heel: [Vec<Option<f64>>; 2],
    /// Toe heights above the toe's level.
    pub toe: [Vec<Option<f64>>; 2],
    /// Flight phases.
    pub flights: Vec<FlightPhase>,
}

/// How long after a heel strike's instant its landmark may still come down to the gate, and
/// before a toe off's instant it may already have left it (s): four Kinect frames. A Kinect ankle
/// walking towards the sensor has been seen 11 cm up for the three frames after the instant and
/// down to 6 cm on the fourth (the CHU log's right foot at 16.19 s); a hop's foot falls from
/// its apex by only g·t²/2 ≈ 8 cm in this time.
pub const CONTACT_WINDOW_SECS: f64 = 0.13;

/// Fraction of the window below the stance level: stance is ≥ 35 % of a running stride and
/// ≈ 60 % of a walking one, so the 10th percentile lies inside stance.
const LEVEL_QUANTILE: f64 = 0.10;

fn relative_heights(track: &[Option<nalgebra::Point3<f64>>], half: usize) -> Vec<Option<f64>> {
    let z: Vec<Option<f64>> = track.iter().map(|p| p.map(|p| p.z)).collect();
    let n = z.len();
    let mut window = Vec::with_capacity(2 * half + 1);
    (0..n)
        .map(|i| {
            let zi = z[i]?;
            window.clear();
            window.extend(
                z[i.saturating_sub(half)..=(i + half).min(n - 1)]
                    .iter()
                    .flatten(),
            );
            if window.len() < half.max(3) {
                return None;
            }
            window.sort_by(f64::total_cmp);
            let k = ((window.len() - 1) as f64 * LEVEL_QUANTILE).round() as usize;
            Some(zi - window[k])
        })
        .collect()
}

pub(crate) fn heights(landmarks: &Landmarks, params: &PhysicsParams) -> Heights {
    let half = ((params.level_window_secs * landmarks.rate_hz).round() as usize).max(3);
    let heel = [0, 1].map(|s| relative_heights(&landmarks.heel[s], half));
    let toe = [0, 1].map(|s| relative_heights(&landmarks.toe[s], half));
    let n = landmarks.len();
    let foot_up = |s: usize, f: usize| -> Option<bool> {
        let low = match (heel[s][f], toe[s][f]) {
            (Some(h), Some(t)) => h.min(t),
            (Some(h), None) => h,
            (None, Some(t)) => t,
            (None, None) => return None,
        };
        Some(low > params.flight_gate_m)
    };
    let airborne: Vec<bool> = (0..n)
        .map(|f| foot_up(0, f) == Some(true) && foot_up(1, f) == Some(true))
        .collect();
    let min_frames = ((params.min_flight_secs * landmarks.rate_hz).ceil() as usize).max(2);
    let flights = trigait_skeleton::frame_runs(n, |f| airborne[f])
        .into_iter()
        .filter(|run| run.len() >= min_frames)
        .map(|run| FlightPhase {
            start_secs: run.start as f64 / landmarks.rate_hz,
            end_secs: (run.end - 1) as f64 / landmarks.rate_hz,
            first_frame: run.start,
            last_frame: run.end - 1,
        })
        .collect();
    Heights {
        rate_hz: landmarks.rate_hz,
        heel,
        toe,
        flights,
    }
}

impl Heights {
    /// Whether an event of `foot` at fractional `frame` on the heel (`heel` true) or toe track
    /// is physically possible: its landmark near its stance level (a heel strike's by
    /// [`CONTACT_WINDOW_SECS`] after it, a toe off's that long before it) and, when
    /// `flights_are_real`, not inside a flight (an event within one frame of a flight's end is
    /// its take-off or landing).
    ///
    /// Flights are real in a clip judged running (or hopping); in one judged walking they are
    /// tracking noise — that is how it was judged — and veto nothing. A Kinect stream shows why:
    /// without a foot joint the ankle stands in for the toe, and in double support the trailing
    /// ankle rises 5–10 cm with its heel while the leading one has just come down onto a heel
    /// a few centimetres below it, so both "feet" are up just where the heel strike is.
    pub(crate) fn allows(
        &self,
        foot: Foot,
        heel: bool,
        frame: f64,
        gate: f64,
        flights_are_real: bool,
    ) -> bool {
        let track = if heel {
            &self.heel[foot.index()]
        } else {
            &self.toe[foot.index()]
        };
        let nearest = frame.round().max(0.0) as usize;
        let high = |f: usize| track.get(f).copied().flatten().is_some_and(|h| h > gate);
        // Seen high at the instant and at every frame of the contact window it was seen in (after
        // a heel strike, before a toe off); a frame without data neither touches nor stays up.
        let window = (CONTACT_WINDOW_SECS * self.rate_hz).round() as usize;
        let contact = if heel {
            nearest + 1..nearest + 1 + window
        } else {
            nearest.saturating_sub(window)..nearest
        };
        let high = high(nearest)
            && contact
                .into_iter()
                .all(|f| high(f) || track.get(f).copied().flatten().is_none());
        let in_flight = flights_are_real
            && self
                .flights
                .iter()
                .any(|p| frame > p.first_frame as f64 + 1.0 && frame < p.last_frame as f64 - 1.0);
        !high && !in_flight
    }

    /// Flight frames inside `first..=last`.
    pub(crate) fn flight_frames(&self, first: usize, last: usize) -> usize {
        self.flights
            .iter()
            .map(|p| {
                let a = p.first_frame.max(first);
                let b = p.last_frame.min(last);
                if b >= a { b - a + 1 } else { 0 }
            })
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Heights at 30 Hz: a left heel that stops moving forward 8 cm up and comes down over the
    /// next frames, as a Kinect ankle does, and one still 0.25 m up at a hop's apex.
    fn heights(left_heel: Vec<Option<f64>>) -> Heights {
        let n = left_heel.len();
        Heights {
            rate_hz: 30.0,
            heel: [left_heel, vec![Some(0.0); n]],
            toe: [vec![Some(0.0); n], vec![Some(0.0); n]],
            flights: Vec::new(),
        }
    }

    #[test]
    fn events_may_touch_within_the_contact_window() {
        let landing = heights([0.3, 0.12, 0.11, 0.08, 0.02, 0.0].map(Some).to_vec());
        // At frame 1 it is 12 cm up, and down to 8 cm two frames (67 ms) later.
        assert!(landing.allows(Foot::Left, true, 1.0, 0.10, true));
        // A toe off looks back, not ahead: 0.3 m up the frame before, it is rejected.
        let toe_high = Heights {
            toe: landing.heel.clone(),
            ..landing.clone()
        };
        assert!(!toe_high.allows(Foot::Left, false, 1.0, 0.10, true));
        // An ankle standing in for the toe, 12 cm up at toe off and on the floor 0.13 s before.
        let lifting = heights(vec![Some(0.0); 6]);
        let lifting = Heights {
            toe: [
                [0.0, 0.02, 0.05, 0.09, 0.12, 0.2].map(Some).to_vec(),
                vec![Some(0.0); 6],
            ],
            ..lifting
        };
        assert!(lifting.allows(Foot::Left, false, 4.0, 0.10, true));
        // One that left the floor more than the window (four frames) before is airborne.
        let early = Heights {
            toe: [
                [0.0, 0.15, 0.2, 0.25, 0.3, 0.35].map(Some).to_vec(),
                vec![Some(0.0); 6],
            ],
            ..lifting.clone()
        };
        assert!(!early.allows(Foot::Left, false, 5.0, 0.10, true));
        // The apex of a hop: 0.3 m falling to 0.25 m over the window is rejected.
        let hop = heights([0.28, 0.30, 0.29, 0.28, 0.26, 0.25, 0.2].map(Some).to_vec());
        assert!(!hop.allows(Foot::Left, true, 1.0, 0.10, true));
        // Missing frames in the window do not count as landed.
        let unseen = heights(vec![
            Some(0.3),
            Some(0.12),
            None,
            None,
            None,
            None,
            Some(0.0),
        ]);
        assert!(!unseen.allows(Foot::Left, true, 1.0, 0.10, true));
        // A Kinect ankle walking towards the sensor: 11 cm up at the instant and for the three
        // frames after it, down to 6 cm on the fourth (0.13 s) — a landing.
        let kinect = heights([0.13, 0.114, 0.115, 0.113, 0.102, 0.062].map(Some).to_vec());
        assert!(kinect.allows(Foot::Left, true, 1.0, 0.10, true));
    }

    /// A flight vetoes an event inside it only where flights are real (a clip judged running or
    /// hopping); the height gate holds either way.
    #[test]
    fn flights_veto_only_where_they_are_real() {
        let mut h = heights(vec![Some(0.06); 10]);
        h.flights.push(FlightPhase {
            start_secs: 0.0,
            end_secs: 0.3,
            first_frame: 0,
            last_frame: 9,
        });
        assert!(!h.allows(Foot::Left, true, 5.0, 0.10, true));
        assert!(h.allows(Foot::Left, true, 5.0, 0.10, false));
        let high = heights(vec![Some(0.3); 10]);
        assert!(!high.allows(Foot::Left, true, 5.0, 0.10, false));
    }
}
