use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};

use crate::Joint;

/// Why a [`MotionClip`] could not be built.
#[derive(Debug, thiserror::Error, PartialEq)]
#[non_exhaustive]
pub enum ClipError {
    /// The sample rate is zero, negative or not finite.
    #[error("sample rate must be a positive number of hertz, got {rate_hz}")]
    BadRate {
        /// The rejected rate.
        rate_hz: f64,
    },
    /// A frame holds a different number of positions than there are joints.
    #[error("frame {frame} has {got} positions but the clip has {expected} joints")]
    RaggedFrame {
        /// Index of the offending frame.
        frame: usize,
        /// Positions in that frame.
        got: usize,
        /// Joints in the clip.
        expected: usize,
    },
    /// The same joint is listed twice.
    #[error("joint {joint} is listed twice")]
    DuplicateJoint {
        /// The repeated joint.
        joint: Joint,
    },
    /// No frames at all.
    #[error("the clip has no frames")]
    Empty,
}

/// Joint positions sampled at a fixed rate: ground truth for the simulator, or a fused result.
///
/// A missing sample (a marker gap, a joint the tracker lost) is `None` and stays `None`:
/// interpolation never bridges a gap, so a gap is reported, never invented.
#[derive(Debug, Clone, PartialEq)]
pub struct MotionClip {
    name: String,
    rate_hz: f64,
    joints: Vec<Joint>,
    /// Row-major: `positions[frame * joints.len() + column]`.
    positions: Vec<Option<Point3<f64>>>,
}

impl MotionClip {
    /// Builds a clip from per-frame positions, one entry per joint in `joints` order.
    ///
    /// Non-finite coordinates (NaN, ±inf) are stored as gaps.
    ///
    /// # Errors
    /// [`ClipError`] for a non-positive rate, ragged frames, repeated joints or no frames.
    pub fn new(
        name: impl Into<String>,
        rate_hz: f64,
        joints: Vec<Joint>,
        frames: Vec<Vec<Option<Point3<f64>>>>,
    ) -> Result<Self, ClipError> {
        if !(rate_hz.is_finite() && rate_hz > 0.0) {
            return Err(ClipError::BadRate { rate_hz });
        }
        if frames.is_empty() {
            return Err(ClipError::Empty);
        }
        for (i, j) in joints.iter().enumerate() {
            if joints[..i].contains(j) {
                return Err(ClipError::DuplicateJoint { joint: *j });
            }
        }
        let mut positions = Vec::with_capacity(frames.len() * joints.len());
        for (frame, row) in frames.into_iter().enumerate() {
            if row.len() != joints.len() {
                return Err(ClipError::RaggedFrame {
                    frame,
                    got: row.len(),
                    expected: joints.len(),
                });
            }
            positions.extend(
                row.into_iter()
                    .map(|p| p.filter(|p| p.coords.iter().all(|c| c.is_finite()))),
            );
        }
        Ok(Self {
            name: name.into(),
            rate_hz,
            joints,
            positions,
        })
    }

    /// Samples `position(joint, t_secs)` at `rate_hz` over `[0, duration_secs]`.
    ///
    /// # Errors
    /// As [`MotionClip::new`].
    pub fn from_fn(
        name: impl Into<String>,
        rate_hz: f64,
        duration_secs: f64,
        joints: Vec<Joint>,
        mut position: impl FnMut(Joint, f64) -> Option<Point3<f64>>,
    ) -> Result<Self, ClipError> {
        if !(rate_hz.is_finite() && rate_hz > 0.0) {
            return Err(ClipError::BadRate { rate_hz });
        }
        let count = (duration_secs.max(0.0) * rate_hz).floor() as usize + 1;
        let frames = (0..count)
            .map(|i| {
                let t = i as f64 / rate_hz;
                joints.iter().map(|j| position(*j, t)).collect()
            })
            .collect();
        Self::new(name, rate_hz, joints, frames)
    }

    /// Where the clip came from (file name or generator).
    #[must_use]
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Samples per second.
    #[must_use]
    pub fn rate_hz(&self) -> f64 {
        self.rate_hz
    }

    /// The joints every frame holds, in column order.
    #[must_use]
    pub fn joints(&self) -> &[Joint] {
        &self.joints
    }

    /// Whether the clip holds `joint`.
    #[must_use]
    pub fn has(&self, joint: Joint) -> bool {
        self.joints.contains(&joint)
    }

    /// Number of frames.
    #[must_use]
    pub fn frame_count(&self) -> usize {
        self.positions.len() / self.joints.len().max(1)
    }

    /// Time of the last frame; frame 0 is at t = 0.
    #[must_use]
    pub fn duration_secs(&self) -> f64 {
        (self.frame_count().saturating_sub(1)) as f64 / self.rate_hz
    }

    /// Position of `joint` in frame `frame`, `None` for a gap or an unknown joint/frame.
    #[must_use]
    pub fn position(&self, frame: usize, joint: Joint) -> Option<Point3<f64>> {
        let column = self.joints.iter().position(|j| *j == joint)?;
        if frame >= self.frame_count() {
            return None;
        }
        self.positions
            .get(frame * self.joints.len() + column)
            .copied()
            .flatten()
    }

    /// Position of `joint` at `t_secs`, linearly interpolated between the two nearest frames.
    ///
    /// `None` outside the clip or when either neighbouring frame is a gap. Linear interpolation of
    /// a ≥ 100 Hz mocap clip is within about 0.5 mm of the true path for a 4 m/s ankle.
    #[must_use]
    pub fn position_at(&self, joint: Joint, t_secs: f64) -> Option<Point3<f64>> {
        if !t_secs.is_finite() || t_secs < 0.0 {
            return None;
        }
        let f = t_secs * self.rate_hz;
        let i = f.floor() as usize;
        let a = self.position(i, joint)?;
        let frac = f - i as f64;
        if frac <= 1e-12 {
            return Some(a);
        }
        let b = self.position(i + 1, joint)?;
        Some(a + (b - a) * frac)
    }

    /// Number of frames in which `joint` is missing.
    #[must_use]
    pub fn missing_frames(&self, joint: Joint) -> usize {
        (0..self.frame_count())
            .filter(|f| self.position(*f, joint).is_none())
            .count()
    }

    /// The clip with every position mapped through `new_from_old`.
    #[must_use]
    pub fn transformed(&self, new_from_old: &Isometry3<f64>) -> MotionClip {
        MotionClip {
            name: self.name.clone(),
            rate_hz: self.rate_hz,
            joints: self.joints.clone(),
            positions: self
                .positions
                .iter()
                .map(|p| p.map(|p| new_from_old * p))
                .collect(),
        }
    }

    /// A clip holding only `joints` (those this clip has), in that order.
    #[must_use]
    pub fn select(&self, joints: &[Joint]) -> MotionClip {
        let kept: Vec<Joint> = joints.iter().copied().filter(|j| self.has(*j)).collect();
        let positions = (0..self.frame_count())
            .flat_map(|f| kept.iter().map(move |j| (f, *j)))
            .map(|(f, j)| self.position(f, j))
            .collect();
        MotionClip {
            name: self.name.clone(),
            rate_hz: self.rate_hz,
            joints: kept,
            positions,
        }
    }

    /// The rigid motion that puts the walk on the rig's walkway: the pelvis path (mid-point of the
    /// hips, else `SpineBase`) centred on the origin in x and y, and its start-to-end direction
    /// turned onto +X. Heights are kept, so the floor stays at z = 0.
    ///
    /// `None` when the clip has no pelvis samples.
    #[must_use]
    pub fn walkway_from_clip(&self) -> Option<Isometry3<f64>> {
        let pelvis: Vec<Point3<f64>> = (0..self.frame_count())
            .filter_map(|f| {
                match (
                    self.position(f, Joint::HipLeft),
                    self.position(f, Joint::HipRight),
                ) {
                    (Some(l), Some(r)) => Some(nalgebra::center(&l, &r)),
                    _ => self.position(f, Joint::SpineBase),
                }
            })
            .collect();
        let (first, last) = (pelvis.first()?, pelvis.last()?);
        let mut heading = last - first;
        heading.z = 0.0;
        let yaw = if heading.norm() > 1e-6 {
            -heading.y.atan2(heading.x)
        } else {
            0.0
        };
        let rotation = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw);
        let (min, max) = pelvis.iter().fold(
            (
                Vector3::repeat(f64::INFINITY),
                Vector3::repeat(f64::NEG_INFINITY),
            ),
            |(lo, hi), p| {
                let q = rotation * p.coords;
                (lo.inf(&q), hi.sup(&q))
            },
        );
        let centre = (min + max) / 2.0;
        let translation = Translation3::new(-centre.x, -centre.y, 0.0);
        Some(translation * rotation)
    }

    /// This clip [placed on the walkway](MotionClip::walkway_from_clip); unchanged when it has no
    /// pelvis samples.
    #[must_use]
    pub fn placed_on_walkway(&self) -> MotionClip {
        match self.walkway_from_clip() {
            Some(iso) => self.transformed(&iso),
            None => self.clone(),
        }
    }
}

#[cfg(test)]
mod tests {
    use approx::assert_relative_eq;

    use super::*;

    fn walk_along_y() -> MotionClip {
        MotionClip::from_fn(
            "test",
            100.0,
            2.0,
            vec![Joint::HipLeft, Joint::HipRight, Joint::AnkleLeft],
            |j, t| {
                let side = match j {
                    Joint::HipLeft => 0.1,
                    _ => -0.1,
                };
                let z = if j == Joint::AnkleLeft { 0.1 } else { 0.9 };
                Some(Point3::new(5.0 + side, 1.0 + 1.5 * t, z))
            },
        )
        .unwrap()
    }

    /// Interpolation is exact on a linear path and refuses to leave the clip.
    #[test]
    fn position_at_interpolates_inside_only() {
        let clip = walk_along_y();
        assert_eq!(clip.frame_count(), 201);
        assert_relative_eq!(clip.duration_secs(), 2.0);
        let p = clip.position_at(Joint::AnkleLeft, 0.123_4).unwrap();
        assert_relative_eq!(p.y, 1.0 + 1.5 * 0.123_4, epsilon = 1e-12);
        assert!(clip.position_at(Joint::AnkleLeft, 2.001).is_none());
        assert!(clip.position_at(Joint::AnkleLeft, -0.1).is_none());
        assert!(clip.position_at(Joint::Head, 1.0).is_none());
    }

    /// A NaN sample becomes a gap that interpolation does not bridge.
    #[test]
    fn nan_is_a_gap() {
        let p = Some(Point3::new(0.0, 0.0, 0.0));
        let clip = MotionClip::new(
            "gap",
            10.0,
            vec![Joint::KneeLeft],
            vec![
                vec![p],
                vec![Some(Point3::new(f64::NAN, 0.0, 0.0))],
                vec![p],
            ],
        )
        .unwrap();
        assert_eq!(clip.missing_frames(Joint::KneeLeft), 1);
        assert!(clip.position_at(Joint::KneeLeft, 0.05).is_none());
        assert!(clip.position_at(Joint::KneeLeft, 0.0).is_some());
    }

    /// Malformed clips are typed errors.
    #[test]
    fn rejects_malformed() {
        let p = Some(Point3::origin());
        assert_eq!(
            MotionClip::new("x", 0.0, vec![Joint::Head], vec![vec![p]]),
            Err(ClipError::BadRate { rate_hz: 0.0 })
        );
        assert!(matches!(
            MotionClip::new("x", 1.0, vec![Joint::Head], vec![vec![p, p]]),
            Err(ClipError::RaggedFrame {
                frame: 0,
                got: 2,
                expected: 1
            })
        ));
        assert!(matches!(
            MotionClip::new("x", 1.0, vec![Joint::Head, Joint::Head], vec![vec![p, p]]),
            Err(ClipError::DuplicateJoint { .. })
        ));
        assert_eq!(
            MotionClip::new("x", 1.0, vec![Joint::Head], vec![]),
            Err(ClipError::Empty)
        );
    }

    /// Placing on the walkway turns the walk onto +X, centres it and keeps heights.
    #[test]
    fn walkway_placement() {
        let placed = walk_along_y().placed_on_walkway();
        let start = placed.position(0, Joint::AnkleLeft).unwrap();
        let end = placed.position(200, Joint::AnkleLeft).unwrap();
        assert_relative_eq!(end.x - start.x, 3.0, epsilon = 1e-9);
        assert_relative_eq!(end.y - start.y, 0.0, epsilon = 1e-9);
        assert_relative_eq!(start.z, 0.1, epsilon = 1e-12);
        let hl = placed.position(100, Joint::HipLeft).unwrap();
        let hr = placed.position(100, Joint::HipRight).unwrap();
        assert_relative_eq!((hl.x + hr.x) / 2.0, 0.0, epsilon = 1e-9);
        assert_relative_eq!((hl.y + hr.y) / 2.0, 0.0, epsilon = 1e-9);
        // walking along +Y, the left hip (+x side) ends up on the walker's right (-y)
        assert!(hl.y < hr.y);
    }
}

/// The maximal runs of consecutive frames of `0..n` where `holds` is true, in order: the
/// stretches a clip is cut into (gaps, flights, swings, a leg merged into the other).
pub fn frame_runs(n: usize, mut holds: impl FnMut(usize) -> bool) -> Vec<std::ops::Range<usize>> {
    let mut runs = Vec::new();
    let mut start = None;
    for f in 0..n {
        match (holds(f), start) {
            (true, None) => start = Some(f),
            (false, Some(s)) => {
                runs.push(s..f);
                start = None;
            }
            _ => {}
        }
    }
    if let Some(s) = start {
        runs.push(s..n);
    }
    runs
}

#[cfg(test)]
mod runs_tests {
    use super::frame_runs;

    #[test]
    fn runs_of_a_predicate() {
        let v = [0, 1, 1, 0, 0, 1, 0, 1, 1, 1];
        assert_eq!(frame_runs(v.len(), |f| v[f] == 1), vec![1..3, 5..6, 7..10]);
        assert_eq!(frame_runs(v.len(), |f| v[f] == 2), Vec::new());
        assert_eq!(frame_runs(3, |_| true), vec![0..3]);
        assert_eq!(frame_runs(0, |_| true), Vec::new());
    }
}
