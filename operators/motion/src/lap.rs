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

#[cfg(test)]
mod tests {
    use approx::assert_relative_eq;

    use super::*;
    use crate::{WalkerParams, walker};

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
