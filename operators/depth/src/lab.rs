//! Scenes a gait lab images to check a sensor before a session, placed by the sensor's pose in
//! the rig, for the simulated depth stream of `kinect-source`.
//!
//! Two targets, both from the thesis's protocol:
//! - [`LabTarget::Wall`]: a flat wall or board facing the sensor at a known distance — the
//!   set-up of the accuracy distribution and structural noise measurements (§3.1, §3.5, §5.1.1:
//!   "target at 2 m", Fig. 5.1). It does not depend on the pose.
//! - [`LabTarget::Floor`]: the floor of the walkway (world z = 0) as this sensor sees it from
//!   its tripod: the one surface every sensor of a rig shares, which is what the multi-sensor
//!   check fits on real frames ([`crate::panoptic`]). Its depth grows towards the horizon and
//!   ends at the Kinect v2's 4.5 m range (Table 3.1), so the frame is physically what a tilted
//!   Kinect v2 on a 1.5 m tripod reports, upper rows empty.
//!
//! The sensor effects (noise, quantisation, rings, edge band) come from [`SimParams`]; this
//! module only places the geometry.

use nalgebra::{Isometry3, Vector3};

use crate::sim::{Scene, ScenePlane};
use crate::{Error, Result};

/// What the simulated sensor looks at.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LabTarget {
    /// A fronto-parallel wall at this depth, metres.
    Wall {
        /// Depth on the optical axis, metres.
        distance_m: f64,
    },
    /// The world floor (z = 0) seen from the sensor's pose.
    Floor,
}

impl LabTarget {
    /// Parses `floor`, `wall` (2 m, the thesis's example distance) or `wall:<metres>`.
    ///
    /// # Errors
    /// [`Error::BadParameter`] for a non-positive or non-finite distance, [`Error::BadSpec`]
    /// for anything else.
    pub fn from_spec(spec: &str) -> Result<Self> {
        let spec = spec.trim();
        let distance = match spec.split_once(':') {
            None if spec == "floor" => return Ok(Self::Floor),
            None if spec == "wall" => 2.0,
            Some(("wall", d)) => d.trim().parse::<f64>().map_err(|_| Error::BadSpec {
                spec: spec.to_owned(),
                expected: "`floor`, `wall` or `wall:<metres>`",
            })?,
            _ => {
                return Err(Error::BadSpec {
                    spec: spec.to_owned(),
                    expected: "`floor`, `wall` or `wall:<metres>`",
                });
            }
        };
        if !(distance > 0.0 && distance.is_finite()) {
            return Err(Error::BadParameter {
                name: "wall distance",
                value: distance,
                expected: "a positive distance in metres",
            });
        }
        Ok(Self::Wall {
            distance_m: distance,
        })
    }
}

/// The floor (world z = 0, world Z up) in the OpenCV camera frame of a sensor with pose
/// `world_from_kinect` (Kinect camera space: x left, y up, z out of the lens; metres).
///
/// A point p of Kinect space lies on the floor when `ẑ · (R p + t) = 0`, i.e.
/// `(Rᵀ ẑ) · p = −t_z`; OpenCV flips x and y, and the sign is chosen so the offset is the
/// sensor's height above the floor.
///
/// # Errors
/// [`Error::BadParameter`] when the sensor is not above the floor.
pub fn floor_in_camera(world_from_kinect: &Isometry3<f64>) -> Result<ScenePlane> {
    let height = world_from_kinect.translation.vector.z;
    if !(height > 0.0 && height.is_finite()) {
        return Err(Error::BadParameter {
            name: "sensor height above the floor",
            value: height,
            expected: "a sensor above the floor (world z > 0)",
        });
    }
    let n_kinect = world_from_kinect.rotation.inverse() * Vector3::z();
    // Kinect (x left, y up) → OpenCV (x right, y down); negate so that n · p = +height.
    let normal = [n_kinect.x, n_kinect.y, -n_kinect.z];
    Ok(ScenePlane {
        normal,
        offset_m: height,
    })
}

/// The scene of `target` for a sensor at `world_from_kinect`.
///
/// # Errors
/// As [`floor_in_camera`] for [`LabTarget::Floor`].
pub fn lab_scene(target: LabTarget, world_from_kinect: &Isometry3<f64>) -> Result<Scene> {
    Ok(match target {
        LabTarget::Wall { distance_m } => Scene::wall(distance_m),
        LabTarget::Floor => Scene {
            background_m: None,
            tilt_x_deg: 0.0,
            tilt_y_deg: 0.0,
            shapes: Vec::new(),
            planes: vec![floor_in_camera(world_from_kinect)?],
        },
    })
}

#[cfg(test)]
mod tests {
    use nalgebra::{Point3, Translation3, UnitQuaternion};

    use super::*;
    use crate::sim::{SimParams, Simulator};
    use crate::{HEIGHT, WIDTH};

    /// A thesis-rig pose: 1.5 m up, looking at (0, 0, 0.5) from (−2.3, 2.135, 1.5).
    fn thesis_k1() -> Isometry3<f64> {
        let eye = Point3::new(-2.3, 2.135, 1.5);
        let target = Point3::new(0.0, 0.0, 0.5);
        // Kinect space: z forward, y up, x left (right-handed: x = y × z).
        let z = (target - eye).normalize();
        let x = Vector3::z().cross(&z).normalize();
        let y = z.cross(&x);
        let rot = nalgebra::Rotation3::from_basis_unchecked(&[x, y, z]);
        Isometry3::from_parts(
            Translation3::from(eye.coords),
            UnitQuaternion::from_rotation_matrix(&rot),
        )
    }

    /// Every pixel of a noise-free floor frame back-projects to world z ≈ 0 (within the 1 mm
    /// quantisation at these depths), the upper rows (above the horizon or beyond 4.5 m) are
    /// empty and the lower rows see the floor.
    #[test]
    fn floor_frame_lies_on_the_world_floor() {
        let pose = thesis_k1();
        let scene = lab_scene(LabTarget::Floor, &pose).unwrap();
        let params = SimParams {
            noise_sd_mm: 0.0,
            ..SimParams::default()
        };
        let mut sim = Simulator::new(&scene, params).unwrap();
        let frame = sim.next_frame();
        let rays = sim.rays().clone();
        let mut checked = 0;
        for (i, &z_mm) in frame.as_mm().iter().enumerate() {
            if z_mm == 0 {
                continue;
            }
            let z = f64::from(z_mm) / 1000.0;
            let (x, y) = rays.at(i);
            // OpenCV → Kinect space, then world.
            let p = pose * Point3::new(-x * z, -y * z, z);
            assert!(
                p.coords.z.abs() < 0.002,
                "pixel {i}: world z {}",
                p.coords.z
            );
            checked += 1;
        }
        assert!(checked > 30_000, "{checked}");
        assert_eq!(frame.at_mm(WIDTH / 2, 0), 0);
        assert!(frame.at_mm(WIDTH / 2, HEIGHT - 1) > 1000);
        // The plane's offset is the sensor height.
        let plane = floor_in_camera(&pose).unwrap();
        assert!((plane.offset_m - 1.5).abs() < 1e-12);
    }

    /// Specs parse; a sensor below the floor and bad specs are errors.
    #[test]
    fn specs_and_bad_poses() {
        assert_eq!(LabTarget::from_spec("floor").unwrap(), LabTarget::Floor);
        assert_eq!(
            LabTarget::from_spec(" wall:3.5 ").unwrap(),
            LabTarget::Wall { distance_m: 3.5 }
        );
        assert_eq!(
            LabTarget::from_spec("wall").unwrap(),
            LabTarget::Wall { distance_m: 2.0 }
        );
        for bad in ["wall:-1", "wall:x", "ceiling", "", "wall:inf"] {
            assert!(LabTarget::from_spec(bad).is_err(), "{bad}");
        }
        let under = Isometry3::translation(0.0, 0.0, -0.1);
        assert!(floor_in_camera(&under).is_err());
    }
}
