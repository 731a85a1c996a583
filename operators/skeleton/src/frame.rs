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

impl JointSample {
    /// Whether the sample is a measurement (`Tracked` or `Inferred`): a `NotTracked` joint sits
    /// wherever the body tracker's model left it.
    #[must_use]
    pub fn is_measured(&self) -> bool {
        self.state != TrackingState::NotTracked
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
}
