//! The calibrated rig as a rig file (`operators/rig`'s YAML), with the full orientation.

use nalgebra::{Point3, UnitQuaternion, Vector3};
use trigait_rig::{RigFile, SensorEntry, looking_at};

use crate::Calibration;

/// Yaw, pitch and roll in degrees as rig files define them (yaw about world Z from +X, pitch of
/// the optical axis up positive, roll about the optical axis): the inverse of what
/// `trigait_rig` builds from `yaw_pitch_roll_deg`.
#[must_use]
pub fn yaw_pitch_roll_deg(rotation: &UnitQuaternion<f64>) -> [f64; 3] {
    let forward = rotation * Vector3::z();
    let yaw = forward.y.atan2(forward.x);
    let pitch = forward.z.clamp(-1.0, 1.0).asin();
    let level = looking_at(&Point3::origin(), &Point3::from(forward)).rotation;
    let roll = (level.inverse() * rotation).to_rotation_matrix();
    let m = roll.matrix();
    [
        yaw.to_degrees(),
        pitch.to_degrees(),
        m[(1, 0)].atan2(m[(0, 0)]).to_degrees(),
    ]
}

/// The calibrated sensors as a rig file named `name` (uncalibrated sensors are left out).
#[must_use]
pub fn rig_file(name: &str, calibration: &Calibration) -> RigFile {
    RigFile {
        name: Some(name.to_owned()),
        sensors: calibration
            .sensors
            .iter()
            .filter_map(|s| {
                let pose = s.world_from_kinect?;
                let p = pose.translation.vector;
                Some(SensorEntry {
                    id: s.id.clone(),
                    position: [p.x, p.y, p.z],
                    look_at: None,
                    yaw_pitch_roll_deg: Some(yaw_pitch_roll_deg(&pose.rotation)),
                })
            })
            .collect(),
    }
}
