use nalgebra::Point3;
use serde::{Deserialize, Serialize};

use crate::{Joint, TrackingState};

/// One joint as one sensor reported it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct JointSample {
    /// Which joint.
    pub joint: Joint,
    /// Position in the sensor's camera space (Kinect v2: x left, y up, z out of the lens; metres).
    pub position_in_kinect: Point3<f64>,
    /// How sure the body tracker was.
    pub state: TrackingState,
}

/// A joint reported farther from its sensor than this cannot have been measured, metres: a
/// Kinect v2 reads depth to 8 m and tracks skeletons to about 4.5 m. Such reports (a corrupted
/// file, a unit slip) are left out and counted wherever reports are taken in, as are
/// non-finite ones and ones behind the sensor.
pub const MAX_REPORT_RANGE_M: f64 = 20.0;

impl JointSample {
    /// Whether the sample is a measurement (`Tracked` or `Inferred`): a `NotTracked` joint sits
    /// wherever the body tracker's model left it.
    #[must_use]
    pub fn is_measured(&self) -> bool {
        self.state != TrackingState::NotTracked
    }

    /// Whether a sensor could have seen the joint where it is reported: in front of the lens
    /// and within [`MAX_REPORT_RANGE_M`] (which no NaN or infinity is).
    #[must_use]
    pub fn is_possible(&self) -> bool {
        let p = self.position_in_kinect;
        // The norm of an overflowing coordinate is infinite, and NaN fails both comparisons.
        p.z > 0.0 && p.coords.norm() <= MAX_REPORT_RANGE_M
    }
}

/// Everything one sensor reports about one body in one depth frame: what crosses the
/// `kinect-source → sync` edge of the dataflow.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SkeletonFrame {
    /// The sensor's id as in the rig file.
    pub sensor_id: String,
    /// Frame counter of that sensor, +1 per depth frame (a jump means frames were lost).
    pub seq: u64,
    /// Capture time on the sensor's own clock, nanoseconds.
    pub local_stamp_nanos: i64,
    /// The joints reported; joints the tracker did not report are absent or `NotTracked`.
    pub joints: Vec<JointSample>,
}

impl SkeletonFrame {
    /// The sample for `joint`, if reported with a usable state (`Tracked` or `Inferred`).
    #[must_use]
    pub fn joint(&self, joint: Joint) -> Option<&JointSample> {
        self.joints
            .iter()
            .find(|s| s.joint == joint && s.is_measured())
    }

    /// Removes the samples no sensor could have measured ([`JointSample::is_possible`]) and
    /// returns how many went. One absurd number in a recording would otherwise be fused, and
    /// interpolated into its neighbours, as a joint light-years away.
    pub fn drop_impossible(&mut self) -> usize {
        let before = self.joints.len();
        self.joints.retain(JointSample::is_possible);
        before - self.joints.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn impossible_reports_are_dropped_and_counted() {
        let sample = |x: f64, y: f64, z: f64| JointSample {
            joint: Joint::KneeLeft,
            position_in_kinect: Point3::new(x, y, z),
            state: TrackingState::Tracked,
        };
        let mut frame = SkeletonFrame {
            sensor_id: "k1".to_owned(),
            seq: 1,
            local_stamp_nanos: 0,
            joints: vec![
                sample(0.1, -0.4, 2.5),
                sample(1e300, 0.0, 2.0),
                sample(0.0, 0.0, -1.0),
                sample(f64::NAN, 0.0, 2.0),
                sample(0.0, 0.0, 25.0),
                sample(3.0, 1.0, 7.5),
            ],
        };
        assert_eq!(frame.drop_impossible(), 4);
        assert_eq!(frame.joints.len(), 2);
        assert_eq!(frame.drop_impossible(), 0);
    }
}
