//! Whether the person found stands on their legs.
//!
//! The leg model ([`crate::legs`]) hangs two chains from the hips down to the floor. A seated
//! person's thighs run level from the seat forward to the knees, and the model, fitted to them
//! anyway, put hips and knees 0.2–0.6 m off and called them tracked: on a rendered person
//! seated before standing up, and on the ten Kinects of a real seated cellist (CMU Panoptic
//! `171026_cello3`), where six of the ten views came out as standing legs with confidence 1.
//!
//! Standing or walking, the legs stay under the trunk: at thigh height (30–45 % of the person's
//! height over the floor) hardly a point lies more than [`REACH_M`] across the floor from the
//! middle of the upper body (55–85 %). Over the walker, CMU 07_01 and the OpenSim walk rendered
//! on the thesis rig's three sensors the share of such points was at most 6 % in any frame, and
//! none at all standing. Seated, the thighs reach out to the knees: 26–64 % of those points in
//! the rendered frames, 37–85 % in the cellist's views. From a fifth up
//! ([`crate::TrackerConfig::not_standing_share`]) the person is taken as not standing (seated
//! or crouching), and no leg joints are reported.
//!
//! Anything else the person's component holds at thigh height and reaches out with counts the
//! same way: a table or a walking frame touching them. The rule was not tried with either.

use crate::legs::FloorFrame;
use crate::segment::Cloud;

/// A point at thigh height this far across the floor from the middle of the upper body reaches
/// out from under the trunk, metres: a walking knee swings about 0.25 m ahead of the hips, a
/// seated knee sits a thigh's length (0.4–0.5 m) ahead of them.
pub(crate) const REACH_M: f64 = 0.3;

/// Thigh height, as shares of the person's height over the floor: a seated person's thighs
/// (the seat is 0.35–0.5 m high, the seated head 1.2–1.4 m).
const THIGH_BAND: (f64, f64) = (0.30, 0.45);

/// The upper body, as shares of the person's height over the floor.
const TRUNK_BAND: (f64, f64) = (0.55, 0.85);

/// Fewest points in either band for a share to be told.
const MIN_BAND_POINTS: usize = 20;

/// The person's height over the floor, as a share of their points' heights: a little under
/// the very top, so that a raised bow, a hat's brim or a flying pixel over the head does not
/// lift the bands.
const TOP_QUANTILE: f64 = 0.98;

/// The share of the person's points (`piece` non-zero) at thigh height that lie more than
/// [`REACH_M`] across the floor from the middle of their upper body; `None` when either band
/// holds too few points to tell.
pub(crate) fn reaching_share(cloud: &Cloud, piece: &[u8], ff: &FloorFrame) -> Option<f64> {
    let mut person: Vec<(f32, usize)> = piece
        .iter()
        .enumerate()
        .filter(|(i, m)| **m != 0 && cloud.height[*i].is_finite())
        .map(|(i, _)| (cloud.height[i], i))
        .collect();
    if person.len() < MIN_BAND_POINTS {
        return None;
    }
    let k = ((person.len() - 1) as f64 * TOP_QUANTILE) as usize;
    let top = f64::from(
        person
            .select_nth_unstable_by(k, |a, b| a.0.total_cmp(&b.0))
            .1
            .0,
    );
    if top <= 0.0 {
        return None;
    }
    let within = |h: f32, (lo, hi): (f64, f64)| {
        let h = f64::from(h);
        h >= lo * top && h < hi * top
    };
    let across = |i: usize| {
        let p = cloud.points[i].coords.cast::<f64>();
        nalgebra::Vector2::new(ff.e1.dot(&p), ff.e2.dot(&p))
    };
    let (mut trunk, mut trunk_n) = (nalgebra::Vector2::zeros(), 0_usize);
    let mut thighs = Vec::new();
    for &(h, i) in &person {
        if within(h, TRUNK_BAND) {
            trunk += across(i);
            trunk_n += 1;
        } else if within(h, THIGH_BAND) {
            thighs.push(across(i));
        }
    }
    if trunk_n < MIN_BAND_POINTS || thighs.len() < MIN_BAND_POINTS {
        return None;
    }
    let middle = trunk / trunk_n as f64;
    let out = thighs
        .iter()
        .filter(|p| (*p - middle).norm() > REACH_M)
        .count();
    Some(out as f64 / thighs.len() as f64)
}
