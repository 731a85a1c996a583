//! Scenario tests for trigait-sync on synthetic ground truth: one test binary, modules by topic.
#![allow(clippy::unwrap_used)] // tests may unwrap (STYLE.md §6); helpers outside #[test] fns need saying so

mod clock;
mod interpolate;
mod props;
mod slots;

use nalgebra::{Point3, Vector3};
use trigait_skeleton::{Joint, JointSample, SkeletonFrame, TrackingState};
use trigait_sync::TimedFrame;

/// A frame of `sensor` with the given joints all `Tracked`.
pub fn frame(
    sensor: &str,
    seq: u64,
    local_stamp_nanos: i64,
    joints: &[(Joint, Point3<f64>)],
) -> SkeletonFrame {
    SkeletonFrame {
        sensor_id: sensor.to_owned(),
        seq,
        local_stamp_nanos,
        joints: joints
            .iter()
            .map(|&(joint, p)| JointSample {
                joint,
                position_in_kinect: p,
                state: TrackingState::Tracked,
            })
            .collect(),
    }
}

/// A frame already on the server clock (exact stamp, zero uncertainty).
pub fn timed(
    sensor: &str,
    seq: u64,
    stamp_nanos: i64,
    joints: &[(Joint, Point3<f64>)],
) -> TimedFrame {
    TimedFrame {
        frame: frame(sensor, seq, stamp_nanos, joints),
        server_stamp_nanos: stamp_nanos,
        time_uncertainty_nanos: 0,
    }
}

/// Seconds from nanoseconds.
pub fn secs(nanos: i64) -> f64 {
    nanos as f64 * 1e-9
}

/// A joint moving on a straight line: `p0 + v·t`.
pub fn linear(p0: Point3<f64>, v: Vector3<f64>) -> impl Fn(i64) -> Point3<f64> {
    move |t| p0 + v * secs(t)
}

/// An "ankle" in one sensor's frame: forward-back sinusoid of amplitude 0.3 m at 1 Hz plus a
/// lift, sensor-specific offset (peak speed ≈ 1.9 m/s, peak acceleration ≈ 12 m/s²).
pub fn ankle(offset: Vector3<f64>) -> impl Fn(i64) -> Point3<f64> {
    move |t| {
        let w = 2.0 * std::f64::consts::PI * secs(t);
        Point3::new(0.3 * w.sin(), 0.1 * (2.0 * w).cos(), 2.5) + offset
    }
}

/// The 99th percentile of |values|.
pub fn p99(values: &[f64]) -> f64 {
    let mut v: Vec<f64> = values.iter().map(|x| x.abs()).collect();
    v.sort_by(f64::total_cmp);
    v.get((v.len() as f64 * 0.99) as usize)
        .copied()
        .unwrap_or(f64::NAN)
}
