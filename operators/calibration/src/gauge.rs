//! The world frame from the walk alone (DESIGN.md: Z up, floor at z = 0, walking along +X).
//!
//! The joint tracks fix every sensor relative to the others but say nothing about where the
//! world is: that gauge (six degrees of freedom) is fixed here, from the same tracks, the same
//! way for an estimate and for ground truth, so the two can be compared:
//!
//! - **Z (up)**: the normal of the plane the pelvis (mid-point of the hips) moves in, pointing
//!   from the ankles to the hips. On a level floor the pelvis keeps its height to within its
//!   bob, the same on either lane and either way along it; it is the least noisy of the joints
//!   (two hips, none of the ankles' extra scatter) and is seen at every instant, where the
//!   stance ankles give a few samples per step — a plane through those moves by tenths of a
//!   degree with the trackers' noise over a walk of 30 s, the pelvis plane by hundredths.
//! - **The floor's level**: the stance ankles, one ankle height below them. A stance is the run
//!   between two swings (ankle faster than 1 m/s, which it passes within hundredths of a second,
//!   so where a stance starts and ends hardly depends on the noise); its middle half is used
//!   (the foot is still rolling on at the start, the heel lifting at the end), Huber-weighted
//!   with a fixed threshold. The ankle height is 0.039 × body height (Winter 2009, Fig. 4.1),
//!   the height taken from the tracked leg length (thigh + shank = 0.491 × height, same
//!   source), unless given.
//! - **X**: the principal direction of the pelvis velocities on the floor, signed by where the
//!   walk goes during its first second.
//! - **Origin**: on the floor below the mean pelvis position.
//!
//! What the walk can and cannot tell: the floor's tilt *along* the walk is fixed by the metres
//! walked, but its tilt *across* the walk only by how far apart across the walk the path runs.
//! On a straight line (or out and back on the same line) that is the pelvis's sway and the
//! step width, a few centimetres, and the tilt across is left to the noise — so that rotation
//! is reported as unobservable, with the advice to walk a second line to the side, or to turn.

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
/// Ankle speed above which the foot swings, m/s. A swinging ankle peaks near 4 m/s and passes
/// 1 m/s within a few hundredths of a second, so where a swing starts and ends hardly moves
/// with the trackers' noise; a threshold near stance speeds would let the noise pick which
/// samples count as stance, and those it adds (the heel rising) stand higher.
const SWING_SPEED_MPS: f64 = 1.0;
/// Half the chord the ankle speed is measured over, seconds.
const SPEED_HALF_CHORD_SECS: f64 = 0.1;
/// Shortest swing, seconds: a faster-than-swing blip shorter than this is noise.
const MIN_SWING_SECS: f64 = 0.1;
/// Share of each stance (from one swing to the next) left out at either end: after heel strike
/// the foot is still rolling onto the floor, before toe-off the heel is already lifting.
const STANCE_EDGE_SHARE: f64 = 0.25;
/// Fewest samples in the middle of a stance for it to count.
const MIN_STANCE_CORE: usize = 3;
/// Huber threshold of the floor fit, metres: above the scatter of a fused stance ankle, below a
/// mislabelled or lifted one.
const FLOOR_HUBER_M: f64 = 0.03;
/// Reweighting rounds of the floor fit.
const FLOOR_ITERATIONS: usize = 6;
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
    /// RMS distance of the stance samples from the floor's level (plus the ankle height), metres.
    pub floor_rms_m: f64,
    /// Pelvis positions (mid-point of the hips) the floor's normal was fitted to.
    pub pelvis_samples: usize,
    /// RMS distance of the pelvis positions from their plane, metres: the pelvis's bob (a few
    /// centimetres) and the noise.
    pub pelvis_rms_m: f64,
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

    // Stance ankles: the middle of each stance between two swings.
    let stance: Vec<Point3<f64>> = ankles
        .iter()
        .flat_map(|a| stance_cores(tracks, *a))
        .flatten()
        .collect();
    if stance.len() < MIN_STANCE_SAMPLES {
        return Err(Error::NoFloor {
            stance_samples: stance.len(),
        });
    }
    // The floor's normal: the normal of the plane the pelvis moves in. The pelvis keeps its
    // height above a level floor to within its own bob, which is the same on either lane and
    // either way along it; of all the joints it is the least noisy (two hips, no ankle gain)
    // and it is seen at every instant, where the stance ankles give a few samples per step:
    // fitted to the stance ankles, the tilt is at the mercy of their scatter (tenths of a
    // degree over a walk of 30 s), fitted to the pelvis path a few hundredths.
    let pelvis_points: Vec<Point3<f64>> = pelvis.iter().map(|(_, p)| *p).collect();
    let (_, pelvis_cov) = mean_cov(&pelvis_points);
    let eig = pelvis_cov
        .try_symmetric_eigen(f64::EPSILON, crate::MAX_DECOMPOSITION_ITERATIONS)
        .ok_or(Error::NonFinite {
            what: "plane of the pelvis path",
        })?;
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
    // A path on one line leaves the tilt across it to the sway and the noise: keep the body's
    // up there (reported as unobservable below) rather than a plane through the line at random.
    let normal = if candidate.dot(&up) > 30f64.to_radians().cos() {
        candidate
    } else {
        let (_, along) = principal_direction(&pelvis_points, &up)?;
        unit(flat(up, &along)).unwrap_or(up)
    };
    // The floor's level: the stance ankles, Huber-weighted with a fixed threshold (so the
    // weights do not depend on how noisy the tracks are: symmetric noise moves nothing, a
    // mislabelled ankle little).
    let heights: Vec<f64> = stance.iter().map(|p| p.coords.dot(&normal)).collect();
    let mut level = median(heights.clone());
    for _ in 0..FLOOR_ITERATIONS {
        let (sum, wsum) = heights.iter().fold((0.0, 0.0), |(s, ws), h| {
            let r = (h - level).abs();
            let w = if r <= FLOOR_HUBER_M {
                1.0
            } else {
                FLOOR_HUBER_M / r
            };
            (s + w * h, ws + w)
        });
        level = sum / wsum;
    }
    let kept = stance;
    let floor_level = level - ankle_height_m;

    let velocities = pelvis_directions(tracks, &normal);
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
    let (_, mut x) = principal_direction(&directions, &normal)?;
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
    let (pc, pcov) = mean_cov(&pelvis_w);
    let pelvis_spread = [pcov[(0, 0)].sqrt(), pcov[(1, 1)].sqrt()];
    let pelvis_rms =
        (pelvis_w.iter().map(|p| (p.z - pc.z).powi(2)).sum::<f64>() / pelvis_w.len() as f64).sqrt();
    // The pelvis's bob counts as noise here, so this errs on the safe side.
    let tilt = |s: f64| pelvis_rms / (s.max(1e-6) * np);
    Ok(Gauge {
        world_from_frame,
        ankle_height_m,
        stance_samples: stance_w.len(),
        stance_spread_m: spread,
        floor_rms_m: floor_rms,
        pelvis_samples: pelvis_w.len(),
        pelvis_rms_m: pelvis_rms,
        rotation_sigma_rad: [
            tilt(pelvis_spread[1]),
            tilt(pelvis_spread[0]),
            heading_sigma,
        ],
        // Along and across the floor the origin is a mean of the pelvis path, its height that of
        // the stance ankles.
        origin_sigma_m: [pelvis_rms / np, pelvis_rms / np, floor_rms / ns],
        path_extent_m,
    })
}

/// Walking directions from the pelvis: over a second (two steps), so the sway and the noise
/// average out; a chord whose middle is off the line is a turn and is left out.
fn pelvis_directions(tracks: &Tracks, normal: &Vector3<f64>) -> Vec<Vector3<f64>> {
    let n = tracks.positions.len();
    let dt = tracks.dt_secs;
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
        let v = flat((b - a) / (2.0 * half as f64 * dt), normal);
        let bend = flat(m - nalgebra::center(&a, &b), normal).norm();
        if (0.3..3.0).contains(&v.norm()) && bend < 0.05 {
            velocities.push(v.normalize());
        }
    }
    velocities
}

fn flat(v: Vector3<f64>, n: &Vector3<f64>) -> Vector3<f64> {
    v - n * n.dot(&v)
}

/// The middle of every stance of `ankle`: a stance is a run of instants at which the ankle
/// moves slower than a swing, with a swing right before and right after (a run cut short by a
/// gap, or at the start or end of the tracks, is not known to be a whole stance and is left
/// out); its middle leaves [`STANCE_EDGE_SHARE`] out at either end.
fn stance_cores(tracks: &Tracks, ankle: Joint) -> Vec<Vec<Point3<f64>>> {
    let n = tracks.positions.len();
    let dt = tracks.dt_secs;
    let h = (SPEED_HALF_CHORD_SECS / dt).round().max(1.0) as usize;
    let min_swing = (MIN_SWING_SECS / dt).round().max(1.0) as usize;
    let p: Vec<Option<Point3<f64>>> = (0..n).map(|k| tracks.get(k, ankle)).collect();
    // Some(true): swinging, Some(false): not, None: unknown.
    let mut swing: Vec<Option<bool>> = vec![None; n];
    for k in h..n.saturating_sub(h) {
        if (k - h..=k + h).all(|i| p[i].is_some())
            && let (Some(a), Some(b)) = (p[k - h], p[k + h])
        {
            swing[k] = Some((b - a).norm() / (2.0 * h as f64 * dt) > SWING_SPEED_MPS);
        }
    }
    let runs = |swing: &[Option<bool>], what: Option<bool>| {
        let mut out = Vec::new();
        let mut k = 0;
        while k < n {
            if swing[k] == what {
                let s = k;
                while k < n && swing[k] == what {
                    k += 1;
                }
                out.push(s..k);
            } else {
                k += 1;
            }
        }
        out
    };
    for r in runs(&swing, Some(true)) {
        if r.len() < min_swing {
            for v in &mut swing[r] {
                *v = Some(false);
            }
        }
    }
    runs(&swing, Some(false))
        .into_iter()
        .filter(|r| r.start > 0 && swing[r.start - 1] == Some(true))
        .filter(|r| r.end < n && swing[r.end] == Some(true))
        .filter_map(|r| {
            let cut = (r.len() as f64 * STANCE_EDGE_SHARE).floor() as usize;
            let core: Vec<Point3<f64>> =
                (r.start + cut..r.end - cut).filter_map(|k| p[k]).collect();
            (core.len() >= MIN_STANCE_CORE).then_some(core)
        })
        .collect()
}

/// The mean and the dominant direction of `points` in the plane normal to `normal`.
fn principal_direction(
    points: &[Point3<f64>],
    normal: &Vector3<f64>,
) -> Result<(Point3<f64>, Vector3<f64>)> {
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
    let eig = m
        .try_symmetric_eigen(f64::EPSILON, crate::MAX_DECOMPOSITION_ITERATIONS)
        .ok_or(Error::NonFinite {
            what: "direction of the walk",
        })?;
    let i = if eig.eigenvalues[0] >= eig.eigenvalues[1] {
        0
    } else {
        1
    };
    let v = eig.eigenvectors.column(i);
    Ok((c, a * v[0] + b * v[1]))
}
