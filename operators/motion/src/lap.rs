//! A walk made endless: out along the walkway, turn on the spot, back, like the thesis subject
//! walking up and down the 3 m line (thesis §6.5) for as long as a dataflow runs.

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use trigait_skeleton::{Joint, MotionClip};

use crate::{Error, Result};

/// `clip` followed by itself turned 180° about the vertical through the middle of its pelvis
/// path, so the walker returns to where it started facing the way it began; play it modulo
/// [`MotionClip::duration_secs`] for an endless walk. Frames are joined without a duplicate
/// sample at the turn or at the wrap (the last frame of the lap is the turned last frame).
///
/// # Errors
/// [`Error::Clip`] when the clip has no pelvis (hips or `SpineBase`) to turn about.
pub fn there_and_back(clip: &MotionClip) -> Result<MotionClip> {
    let pelvis = |f: usize| match (
        clip.position(f, Joint::HipLeft),
        clip.position(f, Joint::HipRight),
    ) {
        (Some(l), Some(r)) => Some(nalgebra::center(&l, &r)),
        _ => clip.position(f, Joint::SpineBase),
    };
    let count = clip.frame_count();
    let (Some(first), Some(last)) = (
        (0..count).find_map(pelvis),
        (0..count).rev().find_map(pelvis),
    ) else {
        return Err(Error::Clip(trigait_skeleton::ClipError::Empty));
    };
    let centre = nalgebra::center(&first, &last);
    let turn: Isometry3<f64> = Translation3::new(centre.x, centre.y, 0.0)
        * UnitQuaternion::from_axis_angle(&Vector3::z_axis(), std::f64::consts::PI)
        * Translation3::new(-centre.x, -centre.y, 0.0);
    let joints = clip.joints().to_vec();
    let row = |f: usize, turned: bool| -> Vec<_> {
        joints
            .iter()
            .map(|j| {
                clip.position(f, *j)
                    .map(|p| if turned { turn * p } else { p })
            })
            .collect()
    };
    let mut frames: Vec<_> = (0..count).map(|f| row(f, false)).collect();
    frames.extend((0..count).map(|f| row(f, true)));
    Ok(MotionClip::new(
        format!("{} (there and back)", clip.name()),
        clip.rate_hz(),
        joints,
        frames,
    )?)
}

/// The longest walk [`walkway_laps`] makes, seconds: an hour.
pub const MAX_LAPS_SECS: f64 = 3600.0;

/// A walk up and down the walkway on two lanes, `laps` times: `clip` (placed on the walkway,
/// walking +X) shifted `lane_offset_m / 2` to the right, then a turn of `turn_secs`, then the
/// same clip turned 180° about the vertical through the walkway centre and shifted to the other
/// side, walking back along −X, then a turn, and so on. A person pacing a lab walkway turns at
/// each end and rarely comes back on exactly the same line; walking back a metre to the side is
/// what a rig calibration from the walk asks for (the stance feet then span the floor across the
/// walk, not only along it). The turns themselves are not modelled: the clip has no samples
/// while the walker turns (a gap, which no reader or sensor bridges), so nothing is reported
/// then. With `lane_offset_m = 0` the walk goes back on the same line.
///
/// # Errors
/// [`Error::Clip`] for a clip without frames or `laps = 0`; [`Error::BadParameter`] for a lane
/// offset or turn that is not a finite number of metres or seconds in range, or laps that would
/// make the walk longer than [`MAX_LAPS_SECS`].
pub fn walkway_laps(
    clip: &MotionClip,
    lane_offset_m: f64,
    turn_secs: f64,
    laps: usize,
) -> Result<MotionClip> {
    let count = clip.frame_count();
    if count == 0 || laps == 0 {
        return Err(Error::Clip(trigait_skeleton::ClipError::Empty));
    }
    let bad = |name, value, reason| {
        Err(Error::BadParameter {
            name,
            value,
            reason,
        })
    };
    if !(lane_offset_m.is_finite() && lane_offset_m.abs() <= 20.0) {
        return bad("lane_offset_m", lane_offset_m, "must be within ±20 m");
    }
    if !(0.0..=600.0).contains(&turn_secs) {
        return bad("turn_secs", turn_secs, "must be within 0..=600 s");
    }
    let total_secs = laps as f64 * 2.0 * (clip.duration_secs() + turn_secs);
    if total_secs > MAX_LAPS_SECS {
        return bad(
            "laps",
            laps as f64,
            "the laps would last longer than an hour",
        );
    }
    let out = Translation3::new(0.0, -lane_offset_m / 2.0, 0.0);
    let back: Isometry3<f64> = Translation3::new(0.0, lane_offset_m / 2.0, 0.0)
        * UnitQuaternion::from_axis_angle(&Vector3::z_axis(), std::f64::consts::PI);
    let turn_frames = (turn_secs.max(0.0) * clip.rate_hz()).round() as usize;
    let joints = clip.joints().to_vec();
    let mut frames = Vec::with_capacity(laps * 2 * (count + turn_frames));
    for pass in 0..2 * laps {
        if pass > 0 {
            frames.extend((0..turn_frames).map(|_| vec![None; joints.len()]));
        }
        let iso: Isometry3<f64> = if pass % 2 == 0 {
            Isometry3::from_parts(out, UnitQuaternion::identity())
        } else {
            back
        };
        frames.extend((0..count).map(|f| {
            joints
                .iter()
                .map(|j| clip.position(f, *j).map(|p| iso * p))
                .collect()
        }));
    }
    Ok(MotionClip::new(
        format!(
            "{} ({laps} laps, lanes {lane_offset_m} m apart)",
            clip.name()
        ),
        clip.rate_hz(),
        joints,
        frames,
    )?)
}

/// One lap of [`walkway_laps`] made endless: out on one lane, a turn of `turn_secs`, back on
/// the other lane, and a second turn before the lap starts over, so played modulo
/// [`MotionClip::duration_secs`] the walker paces the walkway on two lanes for as long as a
/// dataflow runs (the turns are gaps, as in [`walkway_laps`]).
///
/// # Errors
/// As [`walkway_laps`].
pub fn walkway_loop(clip: &MotionClip, lane_offset_m: f64, turn_secs: f64) -> Result<MotionClip> {
    let lap = walkway_laps(clip, lane_offset_m, turn_secs, 1)?;
    let joints = lap.joints().to_vec();
    let turn_frames = (turn_secs.max(0.0) * lap.rate_hz()).round() as usize;
    let frames = (0..lap.frame_count() + turn_frames)
        .map(|f| joints.iter().map(|j| lap.position(f, *j)).collect())
        .collect();
    Ok(MotionClip::new(
        format!("{} (endless)", lap.name()),
        lap.rate_hz(),
        joints,
        frames,
    )?)
}

#[cfg(test)]
mod tests {
    use approx::assert_relative_eq;

    use super::*;
    use crate::{WalkerParams, walker};

    /// Laps alternate direction on two lanes with a gap for each turn.
    #[test]
    fn laps_on_two_lanes() {
        let out = walker(&WalkerParams::default(), 2.5, 100.0)
            .unwrap()
            .placed_on_walkway();
        let laps = walkway_laps(&out, 1.0, 1.0, 2).unwrap();
        let n = out.frame_count();
        assert_eq!(laps.frame_count(), 4 * n + 3 * 100);
        let hip = |f: usize| laps.position(f, Joint::HipLeft);
        assert!(
            hip(n - 1).unwrap().x > hip(0).unwrap().x + 2.0,
            "outbound along +X"
        );
        assert!(hip(n + 50).is_none(), "no samples while turning");
        let back = n + 100;
        assert!(
            hip(back + n - 1).unwrap().x < hip(back).unwrap().x - 2.0,
            "back along −X"
        );
        let lane = |f: usize| laps.position(f, Joint::SpineBase).unwrap().y;
        assert!((lane(n / 2) + 0.5).abs() < 0.1 && (lane(back + n / 2) - 0.5).abs() < 0.1);
    }

    /// The endless two-lane lap ends with a turn, so its wrap is a gap, not a jump across lanes.
    #[test]
    fn endless_walkway_loop_turns_before_it_wraps() {
        let out = walker(&WalkerParams::default(), 2.5, 100.0)
            .unwrap()
            .placed_on_walkway();
        let n = out.frame_count();
        let lap = walkway_loop(&out, 1.0, 0.5).unwrap();
        assert_eq!(lap.frame_count(), 2 * n + 2 * 50);
        let hip = |f: usize| lap.position(f, Joint::HipLeft);
        assert!(
            hip(2 * n + 50 - 1).is_some(),
            "back lane ends before the last turn"
        );
        assert!(hip(2 * n + 50).is_none() && hip(lap.frame_count() - 1).is_none());
        assert_eq!(
            hip(0),
            walkway_laps(&out, 1.0, 0.5, 1)
                .unwrap()
                .position(0, Joint::HipLeft)
        );
    }

    /// A lane, turn or lap count out of range is an error naming it, before anything is
    /// allocated (an infinite turn or a billion laps once asked for terabytes).
    #[test]
    fn out_of_range_laps_are_errors() {
        let out = walker(&WalkerParams::default(), 2.5, 100.0)
            .unwrap()
            .placed_on_walkway();
        for (lane, turn, laps, name) in [
            (f64::NAN, 1.0, 1, "lane_offset_m"),
            (1.0, f64::INFINITY, 1, "turn_secs"),
            (1.0, 1e9, 1, "turn_secs"),
            (1.0, -1.0, 1, "turn_secs"),
            (1.0, f64::NAN, 1, "turn_secs"),
            (1.0, 1.0, 100_000, "laps"),
            (1.0, 1.0, usize::MAX, "laps"),
        ] {
            match walkway_laps(&out, lane, turn, laps) {
                Err(Error::BadParameter { name: got, .. }) => assert_eq!(got, name),
                other => panic!("{lane} {turn} {laps}: {other:?}"),
            }
        }
    }

    /// The lap is twice as long, walks +X then −X, and ends near where it began.
    #[test]
    fn walks_out_and_back() {
        let out = walker(&WalkerParams::default(), 2.5, 100.0)
            .unwrap()
            .placed_on_walkway();
        let lap = there_and_back(&out).unwrap();
        assert_eq!(lap.frame_count(), 2 * out.frame_count());
        let hip = |t: f64| lap.position_at(Joint::HipLeft, t).unwrap();
        assert!(hip(1.5).x > hip(0.5).x + 0.5, "outbound along +X");
        let half = out.duration_secs();
        assert!(hip(half + 1.5).x < hip(half + 0.5).x - 0.5, "back along −X");
        // Left stays left: on the way back the left hip is on the −Y side.
        assert!(hip(half + 1.0).y < lap.position_at(Joint::HipRight, half + 1.0).unwrap().y);
        let start = out.position(0, Joint::SpineBase).unwrap();
        let end = lap
            .position(lap.frame_count() - 1, Joint::SpineBase)
            .unwrap();
        assert!((start.x - end.x).abs() < 0.3, "{start} {end}");
        // The turn is about the vertical: heights are kept (the lap ends on the outbound
        // walk's last frame, turned).
        let last_out = out
            .position(out.frame_count() - 1, Joint::SpineBase)
            .unwrap();
        assert_relative_eq!(end.z, last_out.z, epsilon = 1e-9);
    }
}
