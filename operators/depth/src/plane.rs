//! Robust plane fits: RANSAC for the inliers, least squares (SVD) on the inliers for the answer.
//!
//! Two models. [`ImagePlane`] is a plane seen by one camera, written as inverse depth linear in
//! the undistorted normalised image coordinates (1/z = a·x + b·y + c, exact for any plane not
//! through the optical centre); it needs no extrinsics and serves the single-sensor metrics
//! (§3.1 target plane, §3.5 flat wall). [`Plane3`] is a plane in 3-D (n·p = d), used for the
//! world floor in the multi-sensor check. Both use a seeded RNG, so results are reproducible.

use nalgebra::{Matrix3, Point3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::{Error, Result};

/// A plane in one camera's view: inverse depth 1/z = a·x + b·y + c (z in metres, x and y
/// undistorted normalised image coordinates).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ImagePlane {
    /// Coefficient of x, 1/m.
    pub a: f64,
    /// Coefficient of y, 1/m.
    pub b: f64,
    /// Inverse depth on the optical axis, 1/m.
    pub c: f64,
}

impl ImagePlane {
    /// Depth of the plane along the ray (x, y, 1) in metres, if the ray hits it in front.
    #[must_use]
    pub fn depth_m(&self, x: f64, y: f64) -> Option<f64> {
        let w = self.a * x + self.b * y + self.c;
        (w > 1e-9).then(|| 1.0 / w)
    }

    /// Angle between the plane's normal and the optical axis, degrees (0 = fronto-parallel).
    #[must_use]
    pub fn tilt_deg(&self) -> f64 {
        // Plane n·p = 1 with n = (a, b, c) in the camera frame.
        let n = Vector3::new(self.a, self.b, self.c);
        (self.c.abs() / n.norm())
            .clamp(-1.0, 1.0)
            .acos()
            .to_degrees()
    }
}

/// Result of [`fit_image_plane`].
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ImagePlaneFit {
    /// The fitted plane.
    pub plane: ImagePlane,
    /// Samples within the tolerance of the final plane.
    pub inliers: usize,
    /// RMS depth residual of the inliers, metres.
    pub rms_m: f64,
}

fn solve3(m: &Matrix3<f64>, r: &Vector3<f64>) -> Option<Vector3<f64>> {
    m.lu().solve(r)
}

fn image_residual(plane: &ImagePlane, (x, y, z): (f64, f64, f64)) -> f64 {
    plane.depth_m(x, y).map_or(f64::INFINITY, |p| z - p)
}

fn lsq_image_plane<'a>(samples: impl Iterator<Item = &'a (f64, f64, f64)>) -> Option<ImagePlane> {
    // Weighted least squares in inverse depth: a depth error dz is an inverse-depth error
    // dz / z², so weight each equation by z⁴ to minimise depth residuals.
    let mut m = Matrix3::zeros();
    let mut r = Vector3::zeros();
    for &(x, y, z) in samples {
        let v = Vector3::new(x, y, 1.0);
        let w = z.powi(4);
        m += w * v * v.transpose();
        r += w * v / z;
    }
    solve3(&m, &r).map(|s| ImagePlane {
        a: s.x,
        b: s.y,
        c: s.z,
    })
}

/// Fits an [`ImagePlane`] to samples (x, y, z metres) robustly: `iterations` RANSAC draws of
/// three samples, inliers within `tolerance_m` in depth, then two rounds of least squares on
/// the inliers. Deterministic for a given `seed`.
///
/// # Errors
/// Fewer than 3 samples, or no draw produced a usable plane.
pub fn fit_image_plane(
    samples: &[(f64, f64, f64)],
    tolerance_m: f64,
    iterations: usize,
    seed: u64,
) -> Result<ImagePlaneFit> {
    if samples.len() < 3 {
        return Err(Error::TooFewPoints {
            what: "image plane".into(),
            got: samples.len(),
            need: 3,
        });
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    // Score hypotheses on an evenly strided subset; refit on everything.
    let stride = (samples.len() / 2000).max(1);
    let scoring: Vec<_> = samples.iter().step_by(stride).copied().collect();
    let mut best: Option<(usize, ImagePlane)> = None;
    for _ in 0..iterations {
        let pick: [usize; 3] = std::array::from_fn(|_| rng.random_range(0..samples.len()));
        if pick[0] == pick[1] || pick[1] == pick[2] || pick[0] == pick[2] {
            continue;
        }
        let mut m = Matrix3::zeros();
        let mut r = Vector3::zeros();
        for (row, &i) in pick.iter().enumerate() {
            let (x, y, z) = samples[i];
            m.set_row(row, &Vector3::new(x, y, 1.0).transpose());
            r[row] = 1.0 / z;
        }
        let Some(s) = solve3(&m, &r) else { continue };
        let plane = ImagePlane {
            a: s.x,
            b: s.y,
            c: s.z,
        };
        let count = scoring
            .iter()
            .filter(|&&p| image_residual(&plane, p).abs() < tolerance_m)
            .count();
        if best.is_none_or(|(c, _)| count > c) {
            best = Some((count, plane));
        }
    }
    let Some((_, mut plane)) = best else {
        return Err(Error::NoPlane {
            what: "image plane".into(),
            detail: "every RANSAC draw was degenerate".into(),
        });
    };
    for _ in 0..2 {
        let inliers = samples
            .iter()
            .filter(|&&p| image_residual(&plane, p).abs() < tolerance_m);
        if let Some(p) = lsq_image_plane(inliers) {
            plane = p;
        }
    }
    let (mut n, mut ss) = (0usize, 0.0);
    for &p in samples {
        let e = image_residual(&plane, p);
        if e.abs() < tolerance_m {
            n += 1;
            ss += e * e;
        }
    }
    if n < 3 {
        return Err(Error::NoPlane {
            what: "image plane".into(),
            detail: format!("only {n} inliers within {tolerance_m} m"),
        });
    }
    Ok(ImagePlaneFit {
        plane,
        inliers: n,
        rms_m: (ss / n as f64).sqrt(),
    })
}

/// A plane in 3-D: points p with `normal · p = offset`, `normal` a unit vector.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Plane3 {
    /// Unit normal.
    pub normal: Vector3<f64>,
    /// Signed distance of the plane from the origin along `normal`, metres.
    pub offset: f64,
}

impl Plane3 {
    /// Signed distance of `p` from the plane, metres.
    #[must_use]
    pub fn distance(&self, p: &Point3<f64>) -> f64 {
        self.normal.dot(&p.coords) - self.offset
    }

    /// The plane with its normal flipped if needed so that `normal · towards ≥ 0`.
    #[must_use]
    pub fn oriented(self, towards: &Vector3<f64>) -> Self {
        if self.normal.dot(towards) < 0.0 {
            Self {
                normal: -self.normal,
                offset: -self.offset,
            }
        } else {
            self
        }
    }

    /// Least-squares plane through points: centroid plus the singular vector of the scatter
    /// matrix with the smallest singular value. `None` for fewer than 3 points.
    #[must_use]
    pub fn fit_lsq<'a>(points: impl Iterator<Item = &'a Point3<f64>> + Clone) -> Option<Self> {
        let (mut n, mut sum) = (0usize, Vector3::zeros());
        for p in points.clone() {
            n += 1;
            sum += p.coords;
        }
        if n < 3 {
            return None;
        }
        let centroid = sum / n as f64;
        let mut scatter = Matrix3::zeros();
        for p in points {
            let d = p.coords - centroid;
            scatter += d * d.transpose();
        }
        let svd = scatter.svd(true, false);
        let u = svd.u?;
        let (i_min, _) = svd
            .singular_values
            .iter()
            .enumerate()
            .min_by(|a, b| a.1.total_cmp(b.1))?;
        let normal = u.column(i_min).into_owned().normalize();
        Some(Self {
            normal,
            offset: normal.dot(&centroid),
        })
    }
}

/// RANSAC settings for [`fit_plane_ransac`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RansacParams {
    /// Number of three-point draws.
    pub iterations: usize,
    /// Inlier distance, metres.
    pub tolerance_m: f64,
    /// RNG seed (results are reproducible).
    pub seed: u64,
    /// Only accept planes whose normal is within `max_angle_deg` of this direction (e.g. world
    /// up for a floor); `None` accepts any plane.
    pub normal_prior: Option<(Vector3<f64>, f64)>,
}

impl Default for RansacParams {
    fn default() -> Self {
        Self {
            iterations: 500,
            tolerance_m: 0.02,
            seed: 0x7269_6761_6974,
            normal_prior: None,
        }
    }
}

/// Result of [`fit_plane_ransac`].
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct PlaneFit3 {
    /// The plane (normal oriented along the prior direction when one was given).
    pub plane: Plane3,
    /// Points within the tolerance.
    pub inliers: usize,
    /// RMS distance of the inliers from the plane, metres.
    pub rms_m: f64,
}

/// Fits a [`Plane3`]: RANSAC (three-point draws, optional normal prior) for the inlier set,
/// then least squares on the inliers, repeated twice with the refitted plane.
///
/// # Errors
/// Fewer than 3 points or no plane satisfying the prior.
pub fn fit_plane_ransac(points: &[Point3<f64>], params: &RansacParams) -> Result<PlaneFit3> {
    if points.len() < 3 {
        return Err(Error::TooFewPoints {
            what: "3-D plane".into(),
            got: points.len(),
            need: 3,
        });
    }
    let mut rng = ChaCha8Rng::seed_from_u64(params.seed);
    let stride = (points.len() / 5000).max(1);
    let scoring: Vec<_> = points.iter().step_by(stride).collect();
    let accept = |n: &Vector3<f64>| {
        params.normal_prior.is_none_or(|(dir, max_deg)| {
            n.dot(&dir).abs() / dir.norm() >= max_deg.to_radians().cos()
        })
    };
    let mut best: Option<(usize, Plane3)> = None;
    for _ in 0..params.iterations {
        let [a, b, c]: [&Point3<f64>; 3] =
            std::array::from_fn(|_| &points[rng.random_range(0..points.len())]);
        let cross = (b - a).cross(&(c - a));
        let norm = cross.norm();
        if norm < 1e-9 {
            continue;
        }
        let normal = cross / norm;
        if !accept(&normal) {
            continue;
        }
        let plane = Plane3 {
            normal,
            offset: normal.dot(&a.coords),
        };
        let count = scoring
            .iter()
            .filter(|p| plane.distance(p).abs() < params.tolerance_m)
            .count();
        if best.is_none_or(|(n, _)| count > n) {
            best = Some((count, plane));
        }
    }
    let Some((_, mut plane)) = best else {
        return Err(Error::NoPlane {
            what: "3-D plane".into(),
            detail: "no RANSAC draw satisfied the normal prior".into(),
        });
    };
    for _ in 0..2 {
        let inliers = points
            .iter()
            .filter(|p| plane.distance(p).abs() < params.tolerance_m);
        if let Some(p) = Plane3::fit_lsq(inliers) {
            plane = p;
        }
    }
    if let Some((dir, _)) = params.normal_prior {
        plane = plane.oriented(&dir);
    }
    let (mut n, mut ss) = (0usize, 0.0);
    for p in points {
        let e = plane.distance(p);
        if e.abs() < params.tolerance_m {
            n += 1;
            ss += e * e;
        }
    }
    Ok(PlaneFit3 {
        plane,
        inliers: n,
        rms_m: if n > 0 {
            (ss / n as f64).sqrt()
        } else {
            f64::NAN
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A tilted 3-D plane with 30 % outliers is recovered to sub-millimetre precision.
    #[test]
    fn ransac_recovers_plane_with_outliers() {
        let n = Vector3::new(0.1, 1.0, -0.05).normalize();
        let d = -1.03;
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut pts = Vec::new();
        for i in 0..3000 {
            let x = rng.random_range(-2.0..2.0);
            let z = rng.random_range(0.0..4.0);
            let y = (d - n.x * x - n.z * z) / n.y;
            let off = if i % 10 < 3 {
                rng.random_range(0.1..1.5)
            } else {
                0.0
            };
            pts.push(Point3::new(x, y + off, z));
        }
        let params = RansacParams {
            normal_prior: Some((Vector3::y(), 30.0)),
            ..RansacParams::default()
        };
        let fit = fit_plane_ransac(&pts, &params).unwrap();
        assert!((fit.plane.normal - n).norm() < 1e-6, "{:?}", fit.plane);
        assert!((fit.plane.offset - d).abs() < 1e-6);
        assert_eq!(fit.inliers, 2100);
    }

    /// The inverse-depth model reproduces a tilted plane exactly and reports its tilt.
    #[test]
    fn image_plane_fits_tilted_plane() {
        // Plane through (0,0,2) tilted 45° about the x axis: n = (0, sin, cos)·p = 2·cos.
        let t = 45f64.to_radians();
        let mut samples = Vec::new();
        for i in 0..50 {
            for j in 0..50 {
                let (x, y) = (-0.5 + i as f64 / 50.0, -0.4 + j as f64 / 60.0);
                let z = 2.0 * t.cos() / (y * t.sin() + t.cos());
                samples.push((x, y, z));
            }
        }
        samples.push((0.0, 0.0, 0.7)); // an outlier
        let fit = fit_image_plane(&samples, 0.01, 100, 1).unwrap();
        assert_eq!(fit.inliers, 2500);
        assert!((fit.plane.tilt_deg() - 45.0).abs() < 1e-6);
        assert!((fit.plane.depth_m(0.0, 0.0).unwrap() - 2.0).abs() < 1e-9);
    }
}
