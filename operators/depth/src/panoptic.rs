//! Multi-sensor consistency check on calibrated CMU Panoptic Kinect v2 frames.
//!
//! Each sensor's depth frame is back-projected to world points: pixel → distorted normalised
//! coordinates → lens distortion undone (`distCoeffs_depth`, OpenCV k1 k2 p1 p2 k3) → ray
//! (x, y, 1) scaled by the depth → depth-camera point → world, with world → depth camera being
//! `M_depth · M_world2sensor` (the calibration's own convention; world in metres, y up, the floor
//! near y = −1.03 m). The floor is fitted per sensor (RANSAC with a normal prior along the
//! world up direction, then least squares on the inliers), and every sensor's floor is evaluated
//! at one common world point, the dome centre. If depth and calibration are right, the floor
//! heights there agree; their spread is the headline number. Medians of each sensor's floor
//! points would not be comparable: the world floor is slightly tilted and each sensor sees a
//! different part of it.

use std::path::Path;

use nalgebra::{Matrix4, Point3, Vector3};
use serde_json::Value;

use crate::frame::{DepthFrame, Intrinsics, PIXELS, WIDTH};
use crate::plane::{RansacParams, fit_plane_ransac};
use crate::{Error, Result};

/// One calibrated Kinect of the Panoptic studio.
#[derive(Debug, Clone, PartialEq)]
pub struct PanopticSensor {
    /// Depth camera intrinsics and distortion.
    pub intrinsics: Intrinsics,
    /// World → depth camera (OpenCV frame), `M_depth · M_world2sensor`.
    pub depth_from_world: Matrix4<f64>,
    /// Depth camera → world.
    pub world_from_depth: Matrix4<f64>,
    /// World → sensor (`M_world2sensor`, Kinect camera space).
    pub sensor_from_world: Matrix4<f64>,
    /// The calibration's `domeCenter`, given in this sensor's frame, metres.
    pub dome_center_in_sensor: Point3<f64>,
}

impl PanopticSensor {
    /// The dome centre in world coordinates.
    #[must_use]
    pub fn dome_center_in_world(&self) -> Option<Point3<f64>> {
        self.sensor_from_world
            .try_inverse()
            .map(|m| m.transform_point(&self.dome_center_in_sensor))
    }

    /// The sensor's up direction (Kinect camera space +y) in world coordinates.
    #[must_use]
    pub fn up_in_world(&self) -> Vector3<f64> {
        let r = self.sensor_from_world.fixed_view::<3, 3>(0, 0);
        r.transpose() * Vector3::y()
    }
}

fn numbers(v: &Value) -> Option<Vec<f64>> {
    match v {
        Value::Number(n) => n.as_f64().map(|x| vec![x]),
        Value::Array(items) => {
            let mut out = Vec::new();
            for item in items {
                out.extend(numbers(item)?);
            }
            Some(out)
        }
        _ => None,
    }
}

/// Reads the sensors of a Panoptic `kcalibration_*.json`, in file order (frame i ↔ sensor i).
///
/// # Errors
/// Unreadable file, invalid JSON, or a missing/malformed key (named in the error).
pub fn read_panoptic_calibration(path: &Path) -> Result<Vec<PanopticSensor>> {
    // Ten sensors take 60 kB; serde_json limits the nesting (128) itself.
    let text = trigait_input_limits::read_bounded_text(path, 16 << 20, "calibration file")
        .map_err(|source| Error::Io {
            path: path.to_owned(),
            source,
        })?;
    let json: Value = serde_json::from_str(&text).map_err(|source| Error::Json {
        path: path.to_owned(),
        source,
    })?;
    let bad = |sensor, key, expected| Error::CalibrationKey {
        path: path.to_owned(),
        sensor,
        key,
        expected,
    };
    let sensors = json
        .get("sensors")
        .and_then(Value::as_array)
        .filter(|s| !s.is_empty())
        .ok_or_else(|| bad(0, "sensors", "a non-empty array of sensors"))?;
    let mut out = Vec::with_capacity(sensors.len());
    for (i, s) in sensors.iter().enumerate() {
        let get = |key: &'static str, len: usize, expected: &'static str| -> Result<Vec<f64>> {
            s.get(key)
                .and_then(numbers)
                .filter(|v| v.len() >= len && v.iter().all(|x| x.is_finite()))
                .ok_or_else(|| bad(i, key, expected))
        };
        let k = get("K_depth", 9, "a 3x3 matrix")?;
        let dist = get(
            "distCoeffs_depth",
            5,
            "at least 5 coefficients k1 k2 p1 p2 k3",
        )?;
        let m_depth = get("M_depth", 16, "a 4x4 matrix")?;
        let m_w2s = get("M_world2sensor", 16, "a 4x4 matrix")?;
        let dome = get("domeCenter", 3, "a 3-vector")?;
        let m_depth = Matrix4::from_row_slice(&m_depth[..16]);
        let m_w2s = Matrix4::from_row_slice(&m_w2s[..16]);
        let depth_from_world = m_depth * m_w2s;
        let world_from_depth = depth_from_world.try_inverse().ok_or_else(|| {
            bad(
                i,
                "M_depth",
                "an invertible transform (with M_world2sensor)",
            )
        })?;
        if k[0] <= 0.0 || k[4] <= 0.0 {
            return Err(bad(i, "K_depth", "positive focal lengths"));
        }
        out.push(PanopticSensor {
            intrinsics: Intrinsics {
                fx: k[0],
                fy: k[4],
                cx: k[2],
                cy: k[5],
                dist: [dist[0], dist[1], dist[2], dist[3], dist[4]],
            },
            depth_from_world,
            world_from_depth,
            sensor_from_world: m_w2s,
            dome_center_in_sensor: Point3::new(dome[0], dome[1], dome[2]),
        });
    }
    Ok(out)
}

/// World points of every `stride`-th pixel (in both directions) with data.
#[must_use]
pub fn back_project(
    frame: &DepthFrame,
    sensor: &PanopticSensor,
    stride: usize,
) -> Vec<Point3<f64>> {
    let stride = stride.max(1);
    let k = &sensor.intrinsics;
    let z = frame.as_mm();
    let mut out = Vec::new();
    for (i, &zi) in z.iter().enumerate().take(PIXELS) {
        let (u, v) = (i % WIDTH, i / WIDTH);
        if !u.is_multiple_of(stride) || !v.is_multiple_of(stride) || zi == 0 {
            continue;
        }
        let d = f64::from(zi) / 1000.0;
        out.push(
            sensor
                .world_from_depth
                .transform_point(&k.back_project_opencv(u as f64, v as f64, d)),
        );
    }
    out
}

/// Settings of [`floor_check`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FloorParams {
    /// Pixel stride of the back-projection (2 = every other row and column).
    pub stride: usize,
    /// RANSAC draws, inlier tolerance and seed.
    pub ransac: RansacParams,
    /// Largest angle between a floor normal and world up, degrees.
    pub max_tilt_deg: f64,
}

impl Default for FloorParams {
    fn default() -> Self {
        Self {
            stride: 2,
            ransac: RansacParams {
                iterations: 1000,
                tolerance_m: 0.02,
                ..RansacParams::default()
            },
            max_tilt_deg: 20.0,
        }
    }
}

/// One sensor's floor.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SensorFloor {
    /// Index into the calibration's `sensors`.
    pub sensor: usize,
    /// Share of pixels with data.
    pub valid_pixel_share: f64,
    /// Points back-projected (after the stride).
    pub points: usize,
    /// Unit floor normal in world coordinates (pointing up).
    pub normal: [f64; 3],
    /// Plane offset: the floor is `normal · p = offset_m`.
    pub offset_m: f64,
    /// RMS distance of the floor inliers from the plane, metres.
    pub rms_m: f64,
    /// Floor inliers.
    pub inliers: usize,
    /// World y of this sensor's floor plane at the dome centre's x, z, metres.
    pub floor_height_at_dome_m: f64,
    /// Angle between this floor normal and world +y, degrees.
    pub tilt_from_y_deg: f64,
}

/// The floors of all sensors and how well they agree.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct FloorCheck {
    /// The common evaluation point: mean of the sensors' `domeCenter`s mapped to world, metres.
    pub dome_center_world_m: [f64; 3],
    /// Largest distance of one sensor's mapped `domeCenter` from that mean, metres.
    pub dome_center_disagreement_m: f64,
    /// World up used as the floor-normal prior (mean of the sensors' up axes).
    pub up_prior: [f64; 3],
    /// Per sensor.
    pub sensors: Vec<SensorFloor>,
    /// Largest minus smallest floor height at the dome centre, metres.
    pub floor_height_spread_m: f64,
    /// Mean floor height at the dome centre, metres.
    pub floor_height_mean_m: f64,
    /// Largest angle between two sensors' floor normals, degrees.
    pub max_normal_angle_deg: f64,
}

/// Fits the floor in every sensor's back-projected frame and compares them at the dome centre.
///
/// # Errors
/// Frame and sensor counts differ, a transform is singular, or a sensor shows no floor.
pub fn floor_check(
    frames: &[DepthFrame],
    sensors: &[PanopticSensor],
    params: &FloorParams,
) -> Result<FloorCheck> {
    if frames.len() != sensors.len() || sensors.is_empty() {
        return Err(Error::SensorCountMismatch {
            frames: frames.len(),
            sensors: sensors.len(),
        });
    }
    let mut domes = Vec::with_capacity(sensors.len());
    let mut up = Vector3::zeros();
    for (i, s) in sensors.iter().enumerate() {
        domes.push(s.dome_center_in_world().ok_or_else(|| Error::NoPlane {
            what: format!("sensor {i}"),
            detail: "M_world2sensor is singular".into(),
        })?);
        up += s.up_in_world();
    }
    let dome =
        Point3::from(domes.iter().map(|p| p.coords).sum::<Vector3<f64>>() / domes.len() as f64);
    let dome_disagreement = domes.iter().map(|p| (p - dome).norm()).fold(0.0, f64::max);
    let up = up.try_normalize(1e-9).unwrap_or_else(Vector3::y);
    let mut floors = Vec::with_capacity(sensors.len());
    for (i, (frame, sensor)) in frames.iter().zip(sensors).enumerate() {
        let points = back_project(frame, sensor, params.stride);
        let ransac = RansacParams {
            normal_prior: Some((up, params.max_tilt_deg)),
            seed: params.ransac.seed.wrapping_add(i as u64),
            ..params.ransac
        };
        let fit = fit_plane_ransac(&points, &ransac).map_err(|e| Error::NoPlane {
            what: format!("floor of sensor {i}"),
            detail: e.to_string(),
        })?;
        let n = fit.plane.normal;
        if n.y.abs() < 1e-6 {
            return Err(Error::NoPlane {
                what: format!("floor of sensor {i}"),
                detail: "the fitted plane is vertical".into(),
            });
        }
        let height = (fit.plane.offset - n.x * dome.x - n.z * dome.z) / n.y;
        floors.push(SensorFloor {
            sensor: i,
            valid_pixel_share: frame.valid_share(),
            points: points.len(),
            normal: [n.x, n.y, n.z],
            offset_m: fit.plane.offset,
            rms_m: fit.rms_m,
            inliers: fit.inliers,
            floor_height_at_dome_m: height,
            tilt_from_y_deg: n.y.abs().min(1.0).acos().to_degrees(),
        });
    }
    let heights: Vec<f64> = floors.iter().map(|f| f.floor_height_at_dome_m).collect();
    let hmax = heights.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let hmin = heights.iter().copied().fold(f64::INFINITY, f64::min);
    let mut max_angle: f64 = 0.0;
    for a in &floors {
        for b in &floors {
            let na = Vector3::from(a.normal);
            let nb = Vector3::from(b.normal);
            max_angle = max_angle.max(na.dot(&nb).clamp(-1.0, 1.0).acos().to_degrees());
        }
    }
    Ok(FloorCheck {
        dome_center_world_m: [dome.x, dome.y, dome.z],
        dome_center_disagreement_m: dome_disagreement,
        up_prior: [up.x, up.y, up.z],
        floor_height_spread_m: hmax - hmin,
        floor_height_mean_m: heights.iter().sum::<f64>() / heights.len() as f64,
        max_normal_angle_deg: max_angle,
        sensors: floors,
    })
}
