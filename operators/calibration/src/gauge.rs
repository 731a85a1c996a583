//! The world frame from the walk alone (DESIGN.md: Z up, floor at z = 0, walking along +X).
//!
//! The joint tracks fix every sensor relative to the others but say nothing about where the
//! world is: that gauge (six degrees of freedom) is fixed here, from the same tracks, the same
//! way for an estimate and for ground truth, so the two can be compared:
//!
//! - **Z (up) and the floor**: the stance ankles. Ankle samples that barely move (stance) are
//!   fitted by a plane, trimmed to the lowest consistent band; its normal, pointing from the
//!   ankles to the hips, is +Z. The floor lies the ankle joint's height below that plane:
//!   0.039 × body height (Winter 2009, Fig. 4.1), the height taken from the tracked leg length
//!   (thigh + shank = 0.491 × height, same source), unless given.
//! - **X**: the principal direction of the pelvis velocities (mid-point of the hips) on the
//!   floor, signed by where the walk goes during its first second.
//! - **Origin**: on the floor below the mean pelvis position.
//!
//! What the floor can and cannot tell: its tilt *along* the walk is fixed by the metres walked,
//! but its tilt *across* the walk only by how far apart across the walk the stance feet are. On a
//! straight line (or out and back on the same line) that is the step width, about 0.1 m, and any
//! left/right difference of the ankle centres' height (anatomy, tracker bias) tilts the
//! "floor" by degrees — so that rotation is reported as unobservable, with the advice to walk a
//! second line to the side, or to turn.

use nalgebra::{
    Isometry3, Matrix2, Matrix3, Point3, Rotation3, Translation3, UnitQuaternion, Vector3,
};
use serde::Serialize;
use trigait_skeleton::Joint;

use crate::{Error, Result};

/// Winter 2009: ankle joint centre above the floor, as a share of body height.
const ANKLE_HEIGHT_PER_HEIGHT: f64 = 0.039;
/// Winter 2009: thigh + shank (hip to knee to ankle joint centre), as a share of body height.
const LEG_PER_HEIGHT: f64 = 0.245 + 0.246;
/// Ankle speed below which an ankle sample is taken as stance, m/s (swing peaks near 4 m/s).
const STANCE_SPEED_MPS: f64 = 0.3;
/// Fewest stance samples a floor is fitted to.
const MIN_STANCE_SAMPLES: usize = 10;
/// Chord over which the pelvis velocity is measured for the walking direction, seconds.
const HEADING_WINDOW_SECS: f64 = 1.0;
/// Shortest pelvis path (extent along the walk) that can give a walking direction, metres.
pub const MIN_PATH_M: f64 = 1.0;

/// Joint positions of one body on an even time grid, in one frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Tracks {
    /// Grid period, seconds.
    pub dt_secs: f64,
    /// Columns of `positions`.
    pub joints: Vec<Joint>,
    /// `positions[instant][column]`; `None` where the joint is unknown.
    pub positions: Vec<Vec<Option<Point3<f64>>>>,
}

impl Tracks {
    /// Position of `joint` at instant `k`.
    #[must_use]
    pub fn get(&self, k: usize, joint: Joint) -> Option<Point3<f64>> {
        let c = self.joints.iter().position(|j| *j == joint)?;
        *self.positions.get(k)?.get(c)?
    }

    fn mid(&self, k: usize, a: Joint, b: Joint) -> Option<Point3<f64>> {
        Some(nalgebra::center(&self.get(k, a)?, &self.get(k, b)?))
    }

    /// The mid-point of the hips at instant `k`.
    #[must_use]
    pub fn pelvis(&self, k: usize) -> Option<Point3<f64>> {
        self.mid(k, Joint::HipLeft, Joint::HipRight)
    }

    /// Every position mapped through `new_from_old`.
    #[must_use]
    pub fn transformed(&self, new_from_old: &Isometry3<f64>) -> Tracks {
        Tracks {
            dt_secs: self.dt_secs,
            joints: self.joints.clone(),
            positions: self
                .positions
                .iter()
                .map(|row| row.iter().map(|p| p.map(|p| new_from_old * p)).collect())
                .collect(),
        }
    }
}

/// The world frame found in a walk, and how well the walk determines it.
#[derive(Debug, Clone, Serialize)]
pub struct Gauge {
    /// Maps the tracks' frame into the world frame.
    #[serde(skip)]
    pub world_from_frame: Isometry3<f64>,
    /// Ankle height above the floor used, metres.
    pub ankle_height_m: f64,
    /// Stance ankle samples the floor was fitted to.
    pub stance_samples: usize,
    /// Standard deviation of those samples along the walk (x) and across it (y), metres.
    pub stance_spread_m: [f64; 2],
    /// RMS distance of the stance samples from the fitted plane, metres.
    pub floor_rms_m: f64,
    /// Standard deviation of the world frame's rotation about x (the floor's tilt across the
    /// walk), y (its tilt along the walk) and z (the walking direction), radians, from the
    /// scatter of the samples that fixed them.
    pub rotation_sigma_rad: [f64; 3],
    /// Standard deviation of the origin along x, y and z, metres.
    pub origin_sigma_m: [f64; 3],
    /// Extent of the pelvis path along the walk and across it, metres.
    pub path_extent_m: [f64; 2],
}

fn unit(v: Vector3<f64>) -> Option<Vector3<f64>> {
    v.try_normalize(1e-12)
}

fn mean_cov(points: &[Point3<f64>]) -> (Point3<f64>, Matrix3<f64>) {
    let n = points.len().max(1) as f64;
    let c = points.iter().map(|p| p.coords).sum::<Vector3<f64>>() / n;
    let cov = points
        .iter()
        .map(|p| (p.coords - c) * (p.coords - c).transpose())
        .sum::<Matrix3<f64>>()
        / n;
    (Point3::from(c), cov)
}

fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// The world frame of `tracks` as the module documentation defines it; `ankle_height_m`
/// overrides the height taken from the leg length.
///
/// # Errors
/// [`Error::MissingJoints`] without hips and ankles, [`Error::TooLittleMotion`] for a pelvis
/// path shorter than [`MIN_PATH_M`], [`Error::NoFloor`] with too few stance samples.
pub fn gauge(tracks: &Tracks, ankle_height_m: Option<f64>) -> Result<Gauge> {
    let n = tracks.positions.len();
    let dt = tracks.dt_secs;
    let ankles = [Joint::AnkleLeft, Joint::AnkleRight];
    let sides = [
        (Joint::HipLeft, Joint::KneeLeft, Joint::AnkleLeft),
        (Joint::HipRight, Joint::KneeRight, Joint::AnkleRight),
    ];
    // Provisional up: from the ankles to the hips, averaged over the walk.
    let mut up = Vector3::zeros();
    let mut legs = Vec::new();
    for k in 0..n {
        for (hip, knee, ankle) in sides {
            if let (Some(h), Some(a)) = (tracks.get(k, hip), tracks.get(k, ankle)) {
                up += h - a;
                if let Some(kn) = tracks.get(k, knee) {
                    legs.push((h - kn).norm() + (kn - a).norm());
                }
            }
        }
    }
    let up = unit(up).ok_or(Error::MissingJoints {
        what: "hips and ankles at the same instants",
    })?;
    let ankle_height_m = match ankle_height_m {
        Some(h) => h,
        None if !legs.is_empty() => median(legs) * ANKLE_HEIGHT_PER_HEIGHT / LEG_PER_HEIGHT,
        None => {
            return Err(Error::MissingJoints {
                what: "hips, knees and ankles for the leg length",
            });
        }
    };

    // Pelvis path: walking direction and extent.
    let pelvis: Vec<(usize, Point3<f64>)> = (0..n)
        .filter_map(|k| Some((k, tracks.pelvis(k)?)))
        .collect();
    if pelvis.len() < 3 {
        return Err(Error::MissingJoints {
            what: "both hips (the pelvis path)",
        });
    }
    let flat = |v: Vector3<f64>, n: &Vector3<f64>| v - n * n.dot(&v);

    // Stance ankles.
    let mut stance = Vec::new();
    for ankle in ankles {
        for k in 2..n.saturating_sub(2) {
            let (Some(a), Some(b), Some(p)) = (
                tracks.get(k - 2, ankle),
                tracks.get(k + 2, ankle),
                tracks.get(k, ankle),
            ) else {
                continue;
            };
            if (b - a).norm() / (4.0 * dt) < STANCE_SPEED_MPS {
                stance.push(p);
            }
        }
    }
    if stance.len() < MIN_STANCE_SAMPLES {
        return Err(Error::NoFloor {
            stance_samples: stance.len(),
        });
    }
    // Plane fit, trimmed to the band the flat foot makes (heel and toe rockers lift the ankle).
    let mut kept = stance.clone();
    let mut normal = up;
    for _ in 0..3 {
        let (c, cov) = mean_cov(&kept);
        let eig = cov.symmetric_eigen();
        let (imin, _) = eig
            .eigenvalues
            .iter()
            .enumerate()
            .min_by(|a, b| a.1.total_cmp(b.1))
            .unwrap_or((0, &0.0));
        let mut candidate: Vector3<f64> = eig.eigenvectors.column(imin).into_owned();
        if candidate.dot(&up) < 0.0 {
            candidate = -candidate;
        }
        // Stance feet on one line leave the tilt across it to the noise: keep the body's up
        // there (reported as unobservable below) rather than a plane through the line at random.
        normal = if candidate.dot(&up) > 30f64.to_radians().cos() {
            candidate
        } else {
            let (_, along) = principal_direction(&kept, &up);
            unit(flat(up, &along)).unwrap_or(up)
        };
        let heights: Vec<f64> = stance.iter().map(|p| (p - c).dot(&normal)).collect();
        let mid = median(heights.clone());
        let mad = 1.4826 * median(heights.iter().map(|h| (h - mid).abs()).collect());
        let band = (2.5 * mad).max(0.005);
        let next: Vec<Point3<f64>> = stance
            .iter()
            .zip(&heights)
            .filter(|(_, h)| (**h - mid).abs() <= band)
            .map(|(p, _)| *p)
            .collect();
        if next.len() < MIN_STANCE_SAMPLES {
            break;
        }
        kept = next;
    }
    let (c_stance, _) = mean_cov(&kept);
    let floor_level = c_stance.coords.dot(&normal) - ankle_height_m;

    let pelvis_points: Vec<Point3<f64>> = pelvis.iter().map(|(_, p)| *p).collect();
    // Walking direction: the principal axis of the pelvis velocities on the floor (sign-free,
    // so out and back count alike, and unmoved by where the passes lie).
    // Over a second (two steps), so the sway and the noise average out; a chord whose middle is
    // off the line is a turn and is left out.
    let half = ((HEADING_WINDOW_SECS / 2.0) / dt).round().max(1.0) as usize;
    let mut velocities = Vec::new();
    for k in half..n.saturating_sub(half) {
        let (Some(a), Some(m), Some(b)) = (
            tracks.pelvis(k - half),
            tracks.pelvis(k),
            tracks.pelvis(k + half),
        ) else {
            continue;
        };
        let v = flat((b - a) / (2.0 * half as f64 * dt), &normal);
        let bend = flat(m - nalgebra::center(&a, &b), &normal).norm();
        if (0.3..3.0).contains(&v.norm()) && bend < 0.05 {
            velocities.push(v.normalize());
        }
    }
    if velocities.len() < 3 {
        return Err(Error::TooLittleMotion {
            path_m: 0.0,
            need_m: MIN_PATH_M,
        });
    }
    let directions: Vec<Point3<f64>> = velocities
        .iter()
        .flat_map(|v| [Point3::from(*v), Point3::from(-v)])
        .collect();
    let (_, mut x) = principal_direction(&directions, &normal);
    // Sign: where the walk goes in its first second (first unbroken run of pelvis samples).
    let (k0, p0) = pelvis[0];
    let mut heading = Vector3::zeros();
    for (k, p) in pelvis.iter().skip(1) {
        if (*k - k0) as f64 * dt > 1.0 {
            break;
        }
        heading = p - p0;
    }
    if heading.dot(&x) < 0.0 {
        x = -x;
    }
    let z = normal;
    let x =
        unit(flat(x, &z)).unwrap_or_else(|| unit(z.cross(&Vector3::y())).unwrap_or(Vector3::x()));
    let y = z.cross(&x);
    let rotation = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(
        Matrix3::from_rows(&[x.transpose(), y.transpose(), z.transpose()]),
    ));
    let (pelvis_mean, _) = mean_cov(&pelvis_points);
    let origin = pelvis_mean - z * (pelvis_mean.coords.dot(&z) - floor_level);
    let world_from_frame =
        Isometry3::from_parts(Translation3::from(-(rotation * origin.coords)), rotation);

    // How well the walk fixed it.
    let in_world = |p: &Point3<f64>| world_from_frame * p;
    let stance_w: Vec<Point3<f64>> = kept.iter().map(in_world).collect();
    let (sc, scov) = mean_cov(&stance_w);
    let spread = [scov[(0, 0)].sqrt(), scov[(1, 1)].sqrt()];
    let floor_rms =
        (stance_w.iter().map(|p| (p.z - sc.z).powi(2)).sum::<f64>() / stance_w.len() as f64).sqrt();
    let ns = (stance_w.len() as f64).sqrt();
    let pelvis_w: Vec<Point3<f64>> = pelvis_points.iter().map(in_world).collect();
    let np = (pelvis_w.len() as f64).sqrt();
    let (lo, hi) = pelvis_w.iter().fold(
        (
            Vector3::repeat(f64::INFINITY),
            Vector3::repeat(f64::NEG_INFINITY),
        ),
        |(lo, hi), p| (lo.inf(&p.coords), hi.sup(&p.coords)),
    );
    let path_extent_m = [hi.x - lo.x, hi.y - lo.y];
    if path_extent_m[0] < MIN_PATH_M {
        return Err(Error::TooLittleMotion {
            path_m: path_extent_m[0],
            need_m: MIN_PATH_M,
        });
    }
    let lateral: Vec<f64> = velocities
        .iter()
        .map(|v| (world_from_frame.rotation * v).y)
        .collect();
    let heading_sigma = (lateral.iter().map(|v| v * v).sum::<f64>() / lateral.len() as f64).sqrt()
        / (lateral.len() as f64).sqrt();
    let tilt = |s: f64| floor_rms / (s.max(1e-6) * ns);
    Ok(Gauge {
        world_from_frame,
        ankle_height_m,
        stance_samples: stance_w.len(),
        stance_spread_m: spread,
        floor_rms_m: floor_rms,
        rotation_sigma_rad: [tilt(spread[1]), tilt(spread[0]), heading_sigma],
        // The origin is a mean of the pelvis path, so only the noise of its points moves it; the
        // stance ankles' scatter about the floor stands for that noise.
        origin_sigma_m: [floor_rms / np, floor_rms / np, floor_rms / ns],
        path_extent_m,
    })
}

/// The mean and the dominant direction of `points` in the plane normal to `normal`.
fn principal_direction(
    points: &[Point3<f64>],
    normal: &Vector3<f64>,
) -> (Point3<f64>, Vector3<f64>) {
    let (c, cov) = mean_cov(points);
    let a = unit(normal.cross(&Vector3::x()))
        .or_else(|| unit(normal.cross(&Vector3::y())))
        .unwrap_or(Vector3::y());
    let b = normal.cross(&a);
    let m = Matrix2::new(
        (a.transpose() * cov * a)[(0, 0)],
        (a.transpose() * cov * b)[(0, 0)],
        (b.transpose() * cov * a)[(0, 0)],
        (b.transpose() * cov * b)[(0, 0)],
    );
    let eig = m.symmetric_eigen();
    let i = if eig.eigenvalues[0] >= eig.eigenvalues[1] {
        0
    } else {
        1
    };
    let v = eig.eigenvectors.column(i);
    (c, a * v[0] + b * v[1])
}
