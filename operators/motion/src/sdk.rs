//! Kinect v2 SDK skeleton recordings as plain text, one line per frame, 25 joints in SDK
//! `JointType` order, camera space in metres (`../shared/data/kinect-v2-skeleton-replay/`).
//! Two layouts exist and are told apart by the column count:
//!
//! - 76 columns: `frame x y z × 25` (every joint taken as tracked);
//! - 201 columns: `frame (state x y z qx qy qz qw) × 25`, state 0 = not tracked, 1 = inferred,
//!   2 = tracked; orientations are ignored.

use std::path::Path;

use nalgebra::Point3;
use trigait_skeleton::{Joint, JointSample, MotionClip, TrackingState};

use crate::{Error, Result};

/// One recorded frame.
#[derive(Debug, Clone, PartialEq)]
pub struct SdkFrame {
    /// The recorder's frame number (first column).
    pub frame_number: u64,
    /// Joints reported (not-tracked joints and all-zero positions are left out).
    pub joints: Vec<JointSample>,
}

/// Reads a Kinect v2 SDK skeleton text file (either layout).
///
/// # Errors
/// [`Error::Io`], or [`Error::SdkSkeleton`] naming the line for a wrong column count or a value
/// that is not a number; an empty file is an error too.
pub fn read_sdk_skeletons(path: impl AsRef<Path>) -> Result<Vec<SdkFrame>> {
    let path = path.as_ref();
    let text =
        trigait_input_limits::read_bounded_text(path, crate::MAX_MOTION_FILE_BYTES, "motion file")
            .map_err(|source| Error::Io {
                path: path.to_owned(),
                source,
            })?;
    parse_sdk_skeletons(&text).map_err(|(line, reason)| Error::SdkSkeleton {
        path: path.to_owned(),
        line,
        reason,
    })
}

/// Parses the text of a Kinect v2 SDK skeleton file; errors are `(1-based line, reason)`.
pub fn parse_sdk_skeletons(text: &str) -> std::result::Result<Vec<SdkFrame>, (usize, String)> {
    let mut frames = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line_no = i + 1;
        let cols: Vec<&str> = line.split_whitespace().collect();
        if cols.is_empty() {
            continue;
        }
        let stride = match cols.len() {
            76 => 3,
            201 => 8,
            n => {
                return Err((
                    line_no,
                    format!(
                        "{n} columns, expected 76 (frame + 25×xyz) or 201 (frame + 25×state xyz quaternion)"
                    ),
                ));
            }
        };
        let number = |c: &str| -> std::result::Result<f64, (usize, String)> {
            c.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| (line_no, format!("{c:?} is not a finite number")))
        };
        let frame_number = cols[0].parse::<u64>().map_err(|_| {
            (
                line_no,
                format!("frame number {:?} is not an integer", cols[0]),
            )
        })?;
        let mut joints = Vec::with_capacity(25);
        for (j, joint) in Joint::ALL.into_iter().enumerate() {
            let at = 1 + j * stride;
            let (state, xyz) = if stride == 3 {
                (TrackingState::Tracked, &cols[at..at + 3])
            } else {
                let code = number(cols[at])?;
                let state = match code as i64 {
                    0 => TrackingState::NotTracked,
                    1 => TrackingState::Inferred,
                    2 => TrackingState::Tracked,
                    _ => {
                        return Err((
                            line_no,
                            format!("tracking state {code} of {joint} is not 0, 1 or 2"),
                        ));
                    }
                };
                (state, &cols[at + 1..at + 4])
            };
            let p = Point3::new(number(xyz[0])?, number(xyz[1])?, number(xyz[2])?);
            if state == TrackingState::NotTracked || p.coords.norm() == 0.0 {
                continue;
            }
            joints.push(JointSample {
                joint,
                position_in_kinect: p,
                state,
            });
        }
        frames.push(SdkFrame {
            frame_number,
            joints,
        });
    }
    if frames.is_empty() {
        return Err((1, "no frames".into()));
    }
    Ok(frames)
}

/// Kinect v2 SDK skeleton frames as a world-frame [`MotionClip`] at `rate_hz` (30 for a Kinect
/// v2), with what was left out.
///
/// Camera space (x to the sensor's left, y up, z out of the lens) is turned into the Z-up world
/// by (x, y, z) ↦ (z, x, y), a proper rotation: world X points away from the sensor, Z up. The
/// floor is wherever the sensor saw it (not z = 0); gait analysis measures heights relative to
/// each foot's own stance level, so that does not matter. Frames are placed by their frame
/// number relative to the first, so a skipped number is a gap; a repeated number keeps its first
/// line. Joints the tracker only *inferred* are dropped when `drop_inferred` is set (the
/// occluded leg is then often far from the real one).
#[derive(Debug, Clone, PartialEq)]
pub struct SdkClip {
    /// The trajectories.
    pub clip: MotionClip,
    /// Lines whose frame number repeated an earlier one (skipped).
    pub repeated_frames: usize,
    /// Frame numbers missing between the first and the last (gaps).
    pub missing_frames: usize,
    /// Joint samples dropped as inferred.
    pub inferred_dropped: usize,
    /// Joint samples kept as inferred (when `drop_inferred` is off).
    pub inferred_kept: usize,
}

/// Builds an [`SdkClip`] from parsed SDK frames.
///
/// # Errors
/// [`Error::Clip`] for a bad rate or no frames.
pub fn sdk_clip(
    name: &str,
    frames: &[SdkFrame],
    rate_hz: f64,
    drop_inferred: bool,
) -> Result<SdkClip> {
    let first = frames.iter().map(|f| f.frame_number).min().unwrap_or(0);
    let last = frames.iter().map(|f| f.frame_number).max().unwrap_or(0);
    // A corrupt frame number must not allocate the world: cap the span at an hour of frames.
    let span = usize::try_from(last - first)
        .unwrap_or(usize::MAX)
        .min(3600 * 30)
        + 1;
    let joints = Joint::ALL.to_vec();
    let mut rows: Vec<Option<Vec<Option<Point3<f64>>>>> = vec![None; span];
    let (mut repeated, mut dropped, mut kept) = (0, 0, 0);
    for frame in frames {
        let Ok(index) = usize::try_from(frame.frame_number - first) else {
            continue;
        };
        let Some(slot) = rows.get_mut(index) else {
            continue;
        };
        if slot.is_some() {
            repeated += 1;
            continue;
        }
        let mut row = vec![None; joints.len()];
        for sample in &frame.joints {
            if sample.state == TrackingState::Inferred {
                if drop_inferred {
                    dropped += 1;
                    continue;
                }
                kept += 1;
            }
            let c = sample.position_in_kinect;
            row[sample.joint as usize] = Some(Point3::new(c.z, c.x, c.y));
        }
        *slot = Some(row);
    }
    let missing = rows.iter().filter(|r| r.is_none()).count();
    let rows = rows
        .into_iter()
        .map(|r| r.unwrap_or_else(|| vec![None; joints.len()]))
        .collect();
    Ok(SdkClip {
        clip: MotionClip::new(name, rate_hz, joints, rows)?,
        repeated_frames: repeated,
        missing_frames: missing,
        inferred_dropped: dropped,
        inferred_kept: kept,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Both real recordings parse with the frame counts SOURCE.txt states, and the walking one
    /// starts where SOURCE.txt says the pelvis is.
    #[test]
    fn real_recordings() {
        let data = trigait_test_data::shared_data_dir().join("kinect-v2-skeleton-replay");
        let straight = read_sdk_skeletons(data.join("JointsInfo_Straight.txt")).unwrap();
        assert_eq!(straight.len(), 85);
        assert_eq!(straight[0].frame_number, 2198);
        let base = straight[0]
            .joints
            .iter()
            .find(|s| s.joint == Joint::SpineBase)
            .unwrap();
        assert!((base.position_in_kinect - Point3::new(-0.99, -0.11, 2.65)).norm() < 0.01);
        let cyrille = read_sdk_skeletons(data.join("JointsInfo_Cyrille_v2_2.txt")).unwrap();
        assert_eq!(cyrille.len(), 970);
        let inferred = cyrille
            .iter()
            .flat_map(|f| &f.joints)
            .filter(|s| s.state == TrackingState::Inferred)
            .count();
        assert!(inferred > 1000, "{inferred}");
    }

    /// A short line and a non-number are errors naming the line, never panics.
    #[test]
    fn malformed_lines() {
        assert_eq!(parse_sdk_skeletons("1 2 3").unwrap_err().0, 1);
        let mut line = String::from("7");
        for _ in 0..75 {
            line.push_str(" 0.5");
        }
        assert_eq!(parse_sdk_skeletons(&line).unwrap()[0].joints.len(), 25);
        let bad = line.replacen("0.5", "abc", 1);
        let err = parse_sdk_skeletons(&format!("{line}\n{bad}")).unwrap_err();
        assert_eq!(err.0, 2);
        assert!(err.1.contains("abc"));
        assert!(parse_sdk_skeletons("\n\n").is_err());
    }
}
