//! The body surface: ellipsoids placed and sized by the joint centres.
//!
//! Each segment is a chain of overlapping ellipsoids along its bone whose cross-sections shrink
//! from the proximal to the distal end and are wider front-to-back than side-to-side (a thigh
//! is not a cylinder), so the union is a tapered, non-circular limb. Sizes are fractions of the
//! segment's own length as measured from the joints of that frame, with ratios taken from
//! anthropometric girths (Winter 2009, Biomechanics and Motor Control of Human Movement, Table
//! 4.1 segment lengths; mid-thigh girth ≈ 0.30 × height, calf ≈ 0.21 × height, ankle
//! ≈ 0.13 × height for a typical adult, i.e. radii of ≈ 0.19, 0.13 and 0.08 thigh lengths).
//! Rounded to what matters for a depth image, they give a thigh 15 cm across at the top and 10 cm
//! above the knee, a calf 11 cm across, an ankle 6 cm.

use nalgebra::{Matrix3, Point3, Unit, Vector3};
use trigait_skeleton::Joint;

use crate::{Error, Result};

/// Body parts, for the rendered label image.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Part {
    /// Pelvis and torso, head.
    Trunk,
    /// Left thigh and knee.
    ThighLeft,
    /// Right thigh and knee.
    ThighRight,
    /// Left shank.
    ShankLeft,
    /// Right shank.
    ShankRight,
    /// Left foot.
    FootLeft,
    /// Right foot.
    FootRight,
}

impl Part {
    /// Label value in [`crate::Rendered::labels`] (0 is the background).
    #[must_use]
    pub fn label(self) -> u8 {
        match self {
            Self::Trunk => 1,
            Self::ThighLeft => 2,
            Self::ThighRight => 3,
            Self::ShankLeft => 4,
            Self::ShankRight => 5,
            Self::FootLeft => 6,
            Self::FootRight => 7,
        }
    }
}

/// One ellipsoid of the surface, in the world frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ellipsoid {
    /// Centre, metres.
    pub centre: Point3<f64>,
    /// Columns: the three orthonormal axes.
    pub axes: Matrix3<f64>,
    /// Semi-axis lengths along `axes`, metres.
    pub semi_m: Vector3<f64>,
    /// The part it belongs to.
    pub part: Part,
}

impl Ellipsoid {
    /// The largest semi-axis: the radius of a bounding sphere.
    #[must_use]
    pub fn bounding_radius_m(&self) -> f64 {
        self.semi_m.max()
    }
}

/// A body as a set of ellipsoids.
#[derive(Debug, Clone, PartialEq)]
pub struct Body {
    /// The surface primitives.
    pub ellipsoids: Vec<Ellipsoid>,
}

/// Proportions of the surface, as fractions of segment lengths (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct BodyShape {
    /// Thigh cross-section (front-back, side-to-side) semi-axes at 20 %, 50 % and 80 % of the
    /// bone, in thigh lengths.
    pub thigh: [(f64, f64); 3],
    /// Knee radius, thigh lengths.
    pub knee: f64,
    /// Shank cross-sections at 25 %, 55 % and 85 % of the bone, in shank lengths.
    pub shank: [(f64, f64); 3],
    /// Foot half-width and half-height, metres.
    pub foot_half_width_m: f64,
    /// See [`BodyShape::foot_half_width_m`].
    pub foot_half_height_m: f64,
    /// Pelvis semi-axes (front-back, side, vertical) in hip widths.
    pub pelvis: (f64, f64, f64),
    /// Torso length from the pelvis centre when the clip has no `SpineShoulder`, thigh lengths.
    pub torso_length: f64,
}

impl Default for BodyShape {
    fn default() -> Self {
        Self {
            thigh: [(0.19, 0.17), (0.155, 0.135), (0.12, 0.105)],
            knee: 0.11,
            shank: [(0.13, 0.115), (0.10, 0.09), (0.07, 0.062)],
            foot_half_width_m: 0.045,
            foot_half_height_m: 0.042,
            pelvis: (0.65, 0.95, 0.7),
            torso_length: 1.2,
        }
    }
}

/// Orthonormal frame with `along` as the third axis and `front` (projected off `along`) first.
fn frame(along: &Unit<Vector3<f64>>, front: &Vector3<f64>) -> Matrix3<f64> {
    let f = (front - along.as_ref() * along.dot(front))
        .try_normalize(1e-9)
        .unwrap_or_else(|| {
            let any = if along.x.abs() < 0.9 {
                Vector3::x()
            } else {
                Vector3::y()
            };
            along.cross(&any).normalize()
        });
    let side = along.cross(&f);
    Matrix3::from_columns(&[f, side, along.into_inner()])
}

impl Body {
    /// The body of one pose. `joint` gives world positions (Z up); hips, knees and ankles are
    /// required, feet and `SpineShoulder` used when present.
    ///
    /// # Errors
    /// [`Error::MissingJoint`] when a required joint is absent or not finite.
    pub fn from_joints(
        shape: &BodyShape,
        joint: impl Fn(Joint) -> Option<Point3<f64>>,
    ) -> Result<Self> {
        let need = |j: Joint| {
            joint(j)
                .filter(|p| p.coords.iter().all(|v| v.is_finite()))
                .ok_or(Error::MissingJoint(j))
        };
        let hip_l = need(Joint::HipLeft)?;
        let hip_r = need(Joint::HipRight)?;
        let pelvis = nalgebra::center(&hip_l, &hip_r);
        let lateral = hip_l - hip_r;
        let hip_width = lateral.norm().max(0.05);
        let up = Vector3::z();
        // Walking forward: left × up points backwards for a body whose left is +Y and walks +X.
        let forward = lateral
            .cross(&up)
            .try_normalize(1e-9)
            .map_or_else(Vector3::x, |v| -v);
        let mut ellipsoids = Vec::with_capacity(32);
        // Pelvis: a wide ellipsoid centred a little above the hip joint centres.
        let (pf, ps, pv) = shape.pelvis;
        let pelvis_axes = frame(&Unit::new_normalize(up), &forward);
        ellipsoids.push(Ellipsoid {
            centre: pelvis + up * (0.25 * hip_width),
            axes: pelvis_axes,
            semi_m: Vector3::new(pf * hip_width, ps * hip_width, pv * hip_width),
            part: Part::Trunk,
        });
        let legs = [
            (
                Joint::HipLeft,
                Joint::KneeLeft,
                Joint::AnkleLeft,
                Joint::FootLeft,
                Part::ThighLeft,
                Part::ShankLeft,
                Part::FootLeft,
            ),
            (
                Joint::HipRight,
                Joint::KneeRight,
                Joint::AnkleRight,
                Joint::FootRight,
                Part::ThighRight,
                Part::ShankRight,
                Part::FootRight,
            ),
        ];
        let mut thigh_len = 0.0_f64;
        for (hip_j, knee_j, ankle_j, foot_j, thigh_p, shank_p, foot_p) in legs {
            let hip = need(hip_j)?;
            let knee = need(knee_j)?;
            let ankle = need(ankle_j)?;
            let thigh = knee - hip;
            let shank = ankle - knee;
            let (lt, ls) = (thigh.norm(), shank.norm());
            if lt < 0.05 || ls < 0.05 {
                return Err(Error::MissingJoint(knee_j));
            }
            thigh_len = thigh_len.max(lt);
            let thigh_axes = frame(&Unit::new_normalize(thigh), &forward);
            for (k, (fb, side)) in shape.thigh.iter().enumerate() {
                let at = [0.2, 0.5, 0.8][k];
                ellipsoids.push(Ellipsoid {
                    centre: hip + thigh * at,
                    axes: thigh_axes,
                    semi_m: Vector3::new(fb * lt, side * lt, 0.3 * lt),
                    part: thigh_p,
                });
            }
            let kr = shape.knee * lt;
            ellipsoids.push(Ellipsoid {
                centre: knee,
                axes: thigh_axes,
                semi_m: Vector3::new(kr, kr * 0.95, kr * 1.1),
                part: thigh_p,
            });
            let shank_axes = frame(&Unit::new_normalize(shank), &forward);
            for (k, (fb, side)) in shape.shank.iter().enumerate() {
                let at = [0.25, 0.55, 0.85][k];
                // The calf bulges behind the tibia.
                let back = if k == 0 { -0.03 * ls } else { 0.0 };
                ellipsoids.push(Ellipsoid {
                    centre: knee + shank * at + shank_axes.column(0) * back,
                    axes: shank_axes,
                    semi_m: Vector3::new(fb * ls, side * ls, 0.28 * ls),
                    part: shank_p,
                });
            }
            // Foot: heel under the ankle to the toe, along the foot joint when known.
            let toe_dir = joint(foot_j)
                .filter(|p| p.coords.iter().all(|v| v.is_finite()))
                .and_then(|f| (f - ankle).try_normalize(1e-6))
                .unwrap_or(forward);
            let flat = (toe_dir - up * toe_dir.dot(&up) * 0.5).normalize();
            let foot_len = 0.6 * lt;
            let heel = ankle - up * (0.75 * shape.foot_half_height_m) - flat * 0.05;
            let foot_axes = frame(&Unit::new_normalize(flat), &up);
            ellipsoids.push(Ellipsoid {
                centre: heel + flat * (0.5 * foot_len),
                axes: foot_axes,
                semi_m: Vector3::new(
                    shape.foot_half_height_m,
                    shape.foot_half_width_m,
                    0.5 * foot_len,
                ),
                part: foot_p,
            });
        }
        // Torso and head.
        let top = joint(Joint::SpineShoulder)
            .filter(|p| p.coords.iter().all(|v| v.is_finite()))
            .unwrap_or_else(|| pelvis + up * (shape.torso_length * thigh_len));
        let torso = top - pelvis;
        let tl = torso.norm().max(0.1);
        let torso_axes = frame(&Unit::new_normalize(torso), &forward);
        for (at, fb, side) in [(0.35, 0.24, 0.75), (0.7, 0.27, 0.85)] {
            ellipsoids.push(Ellipsoid {
                centre: pelvis + torso * at,
                axes: torso_axes,
                semi_m: Vector3::new(fb * hip_width * 2.0 * 0.5, side * hip_width, 0.3 * tl),
                part: Part::Trunk,
            });
        }
        let head_r = 0.18 * tl;
        let dir = torso / tl;
        // Neck, then the head on it.
        ellipsoids.push(Ellipsoid {
            centre: top + dir * (0.06 * tl),
            axes: torso_axes,
            semi_m: Vector3::new(0.1 * tl, 0.11 * tl, 0.14 * tl),
            part: Part::Trunk,
        });
        ellipsoids.push(Ellipsoid {
            centre: top + dir * (0.14 * tl + head_r),
            axes: torso_axes,
            semi_m: Vector3::new(head_r * 1.1, head_r * 0.9, head_r * 1.25),
            part: Part::Trunk,
        });
        Ok(Self { ellipsoids })
    }
}
