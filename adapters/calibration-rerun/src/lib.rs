//! A rig calibration as a rerun recording: where the sensors were believed to be and what
//! their joint tracks looked like in the world then, and the same after the calibration, so a
//! viewer sees the tracks of the sensors fall onto each other. Kept out of
//! `trigait-calibration` (an operator crate stays free of rerun; the same reason as
//! `trigait-depth-rerun`).
//!
//! Logged (static, no timeline), each stage `before` (the rough rig the calibration started
//! from, in that rig's world frame) and `after` (the calibrated rig, in the world frame the
//! walk defines: floor at z = 0, x along the walk):
//! - `<stage>/sensors/<id>`: the sensor's optical centre, labelled, and its viewing direction
//!   (camera +z) as a 0.5 m arrow;
//! - `<stage>/tracks/<id>`: every joint that sensor reported, mapped into the world with the
//!   stage's pose of the sensor, one colour per sensor;
//! - `after/joints`: the adjustment's own joint estimates.
//!
//! The two stages are in different world frames (the rough rig's lab frame against the
//! walk's), so they are logged side by side under their own roots, not on top of each other.

use nalgebra::{Isometry3, Point3};
pub use rerun::{RecordingStream, RecordingStreamError};
use trigait_calibration::{Calibration, SensorTrack};

/// One colour per sensor index (cycled).
fn colour(i: usize) -> rerun::Color {
    const PALETTE: [(u8, u8, u8); 8] = [
        (230, 25, 75),
        (60, 180, 75),
        (0, 130, 200),
        (245, 130, 48),
        (145, 30, 180),
        (70, 240, 240),
        (240, 50, 230),
        (128, 128, 0),
    ];
    let (r, g, b) = PALETTE[i % PALETTE.len()];
    rerun::Color::from_rgb(r, g, b)
}

fn f32x3(p: &Point3<f64>) -> [f32; 3] {
    [p.x as f32, p.y as f32, p.z as f32]
}

/// Logs the sensors and tracks of one stage under `root`, each sensor at `poses[i]` (none:
/// not placed at this stage, left out).
fn log_stage(
    rec: &RecordingStream,
    root: &str,
    tracks: &[SensorTrack],
    poses: &[Option<Isometry3<f64>>],
) -> Result<(), RecordingStreamError> {
    for (i, (track, pose)) in tracks.iter().zip(poses).enumerate() {
        let Some(pose) = pose else { continue };
        let centre = Point3::from(pose.translation.vector);
        let look = pose.rotation * nalgebra::Vector3::z() * 0.5;
        rec.log_static(
            format!("{root}/sensors/{}", track.id),
            &rerun::Points3D::new([f32x3(&centre)])
                .with_radii([0.06_f32])
                .with_colors([colour(i)])
                .with_labels([track.id.as_str()]),
        )?;
        rec.log_static(
            format!("{root}/sensors/{}/view", track.id),
            &rerun::Arrows3D::from_vectors([[look.x as f32, look.y as f32, look.z as f32]])
                .with_origins([f32x3(&centre)])
                .with_colors([colour(i)]),
        )?;
        let points: Vec<[f32; 3]> = track
            .frames
            .iter()
            .flat_map(|f| f.joints.iter())
            .map(|j| f32x3(&(pose * j.position_in_kinect)))
            .collect();
        rec.log_static(
            format!("{root}/tracks/{}", track.id),
            &rerun::Points3D::new(points)
                .with_radii([0.008_f32])
                .with_colors([colour(i)]),
        )?;
    }
    Ok(())
}

/// Logs `calibration` of `tracks`: `before` with `start` (the rough rig, when the calibration
/// started from one), `after` with the calibrated poses and the joint estimates.
///
/// # Errors
/// The recording stream refused a message.
pub fn log_calibration(
    rec: &RecordingStream,
    tracks: &[SensorTrack],
    start: Option<&trigait_rig::Rig>,
    calibration: &Calibration,
) -> Result<(), RecordingStreamError> {
    if let Some(rig) = start {
        let poses: Vec<Option<Isometry3<f64>>> = tracks
            .iter()
            .map(|t| {
                rig.sensors
                    .iter()
                    .find(|s| s.id == t.id)
                    .map(|s| s.world_from_kinect)
            })
            .collect();
        log_stage(rec, "before", tracks, &poses)?;
    }
    let poses: Vec<Option<Isometry3<f64>>> = tracks
        .iter()
        .map(|t| {
            calibration
                .sensors
                .iter()
                .find(|s| s.id == t.id)
                .and_then(|s| s.world_from_kinect)
        })
        .collect();
    log_stage(rec, "after", tracks, &poses)?;
    let joints: Vec<[f32; 3]> = calibration
        .joints_in_world
        .positions
        .iter()
        .flatten()
        .flatten()
        .map(f32x3)
        .collect();
    rec.log_static(
        "after/joints",
        &rerun::Points3D::new(joints)
            .with_radii([0.01_f32])
            .with_colors([rerun::Color::from_rgb(200, 200, 200)]),
    )?;
    Ok(())
}

/// A recording saved to `path` (its folder created).
///
/// # Errors
/// The folder or the file cannot be made, said with the path.
pub fn save(app_id: &'static str, path: &std::path::Path) -> Result<RecordingStream, String> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| format!("creating {}: {e}", dir.display()))?;
    }
    rerun::RecordingStreamBuilder::new(app_id)
        .save(path)
        .map_err(|e| format!("opening {}: {e}", path.display()))
}
