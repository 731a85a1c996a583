//! The fused poses of a run as one [`MotionClip`], so that what the dataflow records is read
//! back by every tool that reads motions (`trigait gait`, `trigait export`) and written by the
//! same writers (`trigait-motion`: CSV, TRC, C3D).
//!
//! A clip has one rate; fused poses come at the fusion instants of `sync`, evenly spaced on the
//! server clock except where `sync` skipped an instant nobody saw. The frame period is the
//! median spacing of consecutive sets, each pose goes to the frame nearest its instant, and
//! instants without a pose (and joints a pose lacks) are gaps.

use std::collections::BTreeMap;

use nalgebra::Point3;
use trigait_schema::FusedPose;
use trigait_skeleton::{ClipError, Joint, MotionClip};

/// Why a trajectory cannot be a clip.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TrajectoryError {
    /// Fewer than two poses with increasing instants: no frame rate can be told.
    #[error("{poses} fused poses with increasing instants: at least 2 are needed for a frame rate")]
    TooFewPoses {
        /// Poses held.
        poses: usize,
    },
    /// The instants span far more frames than there are poses (a jump of the server clock).
    #[error("{poses} fused poses span {frames} frames of {period_nanos:.0} ns: the instants jump")]
    InstantsJump {
        /// Poses held.
        poses: usize,
        /// Frames between the first and the last instant.
        frames: f64,
        /// The frame period, ns.
        period_nanos: f64,
    },
    /// The clip refused the frames.
    #[error(transparent)]
    Clip(#[from] ClipError),
}

/// Fused joint positions by instant.
#[derive(Debug, Clone, Default)]
pub struct Trajectory {
    /// `set_seq → (stamp_nanos, joints)`.
    poses: BTreeMap<u64, (i64, BTreeMap<Joint, Point3<f64>>)>,
    /// Every joint any pose fused.
    joints: std::collections::BTreeSet<Joint>,
}

impl Trajectory {
    /// An empty trajectory.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds the fused joints of `pose` (a repeated set is replaced).
    pub fn push(&mut self, pose: &FusedPose) {
        let joints = pose.joints.iter().map(|(j, f)| (*j, f.position)).collect();
        self.joints.extend(pose.joints.keys().copied());
        self.poses.insert(pose.set_seq, (pose.stamp_nanos, joints));
    }

    /// Every joint any pose fused.
    #[must_use]
    pub fn joints(&self) -> &std::collections::BTreeSet<Joint> {
        &self.joints
    }

    /// Poses held.
    #[must_use]
    pub fn len(&self) -> usize {
        self.poses.len()
    }

    /// Whether no pose is held.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.poses.is_empty()
    }

    /// The frame period: the median of (Δstamp / Δseq) over consecutive poses held, ns.
    /// `None` with fewer than two poses or instants that do not increase.
    #[must_use]
    pub fn period_nanos(&self) -> Option<f64> {
        let mut spacing: Vec<f64> = self
            .poses
            .iter()
            .zip(self.poses.iter().skip(1))
            .map(|((s0, (t0, _)), (s1, (t1, _)))| (t1 - t0) as f64 / (s1 - s0) as f64)
            .filter(|d| d.is_finite() && *d > 0.0)
            .collect();
        spacing.sort_by(f64::total_cmp);
        spacing.get(spacing.len() / 2).copied()
    }

    /// Where the poses land in a clip: frame 0 at the first pose's instant, the period from
    /// [`Self::period_nanos`], the joints any pose fused, in Kinect joint order.
    ///
    /// # Errors
    /// [`TrajectoryError::TooFewPoses`] without two poses with increasing instants.
    pub fn grid(&self) -> Result<FrameGrid, TrajectoryError> {
        let (Some(period_nanos), Some((_, (t0_nanos, _)))) =
            (self.period_nanos(), self.poses.first_key_value())
        else {
            return Err(TrajectoryError::TooFewPoses {
                poses: self.poses.len(),
            });
        };
        let mut joints: Vec<Joint> = self.joints.iter().copied().collect();
        joints.sort_by_key(|j| j.index());
        Ok(FrameGrid {
            t0_nanos: *t0_nanos,
            period_nanos,
            joints,
        })
    }

    /// The frames from `from_frame` to the newest pose's on `grid`, one row of cells (one per
    /// grid joint; `None` where no pose fused it) each: what a clip on `grid` holds there.
    /// Poses before `from_frame` are not looked at, so writing a run as it goes costs the
    /// new poses only.
    ///
    /// # Errors
    /// [`TrajectoryError::InstantsJump`] when the newest pose lies more than ten times as many
    /// frames past `from_frame` as there are poses held (plus a minute).
    pub fn rows_from(
        &self,
        grid: &FrameGrid,
        from_frame: usize,
    ) -> Result<Vec<Vec<Option<Point3<f64>>>>, TrajectoryError> {
        let poses = self.poses.len();
        let Some((_, (newest, _))) = self.poses.last_key_value() else {
            return Ok(Vec::new());
        };
        let last = grid.frame_of(*newest);
        let bound = from_frame as f64 + 10.0 * poses as f64 + 60e9 / grid.period_nanos;
        if last > bound {
            return Err(TrajectoryError::InstantsJump {
                poses,
                frames: last,
                period_nanos: grid.period_nanos,
            });
        }
        if last < from_frame as f64 {
            return Ok(Vec::new());
        }
        let mut rows = vec![vec![None; grid.joints.len()]; last as usize + 1 - from_frame];
        // Newest first, until the poses fall before `from_frame` (instants grow with seq).
        for (t, fused) in self.poses.values().rev() {
            let f = grid.frame_of(*t);
            if f < from_frame as f64 {
                break;
            }
            let Some(row) = rows.get_mut(f as usize - from_frame) else {
                continue;
            };
            for (cell, joint) in row.iter_mut().zip(&grid.joints) {
                if cell.is_none()
                    && let Some(p) = fused.get(joint)
                {
                    *cell = Some(*p);
                }
            }
        }
        Ok(rows)
    }

    /// The trajectory as a clip named `name`, on [`Self::grid`].
    ///
    /// # Errors
    /// [`TrajectoryError`]: too few poses for a rate, or instants spanning more than ten
    /// times as many frames as there are poses (plus a minute).
    pub fn to_clip(&self, name: impl Into<String>) -> Result<MotionClip, TrajectoryError> {
        let grid = self.grid()?;
        let rows = self.rows_from(&grid, 0)?;
        Ok(MotionClip::new(name, grid.rate_hz(), grid.joints, rows)?)
    }
}

/// Where fused poses land in a clip: frame `k` is the instant `t0_nanos + k × period_nanos`,
/// and the columns are `joints`.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameGrid {
    /// The instant of frame 0 (the first pose's), server clock, ns.
    pub t0_nanos: i64,
    /// The frame period, ns.
    pub period_nanos: f64,
    /// The columns, in Kinect joint order.
    pub joints: Vec<Joint>,
}

impl FrameGrid {
    /// The frame nearest `stamp_nanos` (negative before frame 0).
    #[must_use]
    pub fn frame_of(&self, stamp_nanos: i64) -> f64 {
        ((stamp_nanos - self.t0_nanos) as f64 / self.period_nanos).round()
    }

    /// Frames per second.
    #[must_use]
    pub fn rate_hz(&self) -> f64 {
        1e9 / self.period_nanos
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Matrix3;
    use trigait_schema::FusedJoint;

    fn pose(seq: u64, t: i64, x: f64) -> FusedPose {
        let joint = FusedJoint {
            position: Point3::new(x, 0.1, 0.5),
            covariance: Matrix3::identity() * 1e-4,
            sensors_used: vec!["k1".into()],
            residual_m: 0.0,
            condition_number: 1.0,
            estimator: "fusion".into(),
        };
        FusedPose {
            set_seq: seq,
            stamp_nanos: t,
            joints: BTreeMap::from([(Joint::KneeLeft, joint)]),
            skipped: BTreeMap::new(),
            missing_sensors: Vec::new(),
        }
    }

    /// 30 Hz poses with a lost set and an instant `sync` skipped (seq does not advance over
    /// it): the clip runs at 30 Hz, each pose on the frame of its instant, gaps where none.
    #[test]
    fn poses_land_on_the_frame_of_their_instant() {
        let period = 33_333_333;
        let mut t = Trajectory::new();
        assert!(t.to_clip("run").is_err());
        for (seq, frame) in [(0, 0), (1, 1), (3, 3), (4, 5), (5, 6)] {
            t.push(&pose(seq, 1_000 + frame * period, frame as f64));
        }
        let clip = t.to_clip("run").unwrap();
        assert!((clip.rate_hz() - 30.0).abs() < 1e-6, "{}", clip.rate_hz());
        assert_eq!(clip.joints(), [Joint::KneeLeft]);
        assert_eq!(clip.frame_count(), 7);
        let xs: Vec<Option<f64>> = (0..7)
            .map(|f| clip.position(f, Joint::KneeLeft).map(|p| p.x))
            .collect();
        assert_eq!(
            xs,
            [
                Some(0.0),
                Some(1.0),
                None,
                Some(3.0),
                None,
                Some(5.0),
                Some(6.0)
            ]
        );
        // Read as a run goes (new frames only, after each batch of poses), the rows are the
        // clip's.
        let grid = t.grid().unwrap();
        assert_eq!(t.rows_from(&grid, 7).unwrap().len(), 0);
        let tail = t.rows_from(&grid, 4).unwrap();
        assert_eq!(tail.len(), 3);
        assert_eq!(tail[0], vec![None]);
        assert_eq!(tail[2].first().copied().flatten().map(|p| p.x), Some(6.0));
        // A server clock that jumps an hour is an error, not an hour of empty frames.
        t.push(&pose(6, 3_600_000_000_000, 7.0));
        assert!(matches!(
            t.to_clip("run"),
            Err(TrajectoryError::InstantsJump { .. })
        ));
    }
}
