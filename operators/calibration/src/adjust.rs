//! The joint adjustment: Levenberg–Marquardt over every sensor's pose (and optionally a residual
//! clock offset per sensor) and every unknown joint position at once, each report weighted by
//! the Kinect noise model's anisotropic covariance (range σ along the ray, lateral σ across it).
//!
//! A report of joint position `X` (frame coordinates) by sensor `s` with pose
//! `frame_from_kinect = (R, c)` is predicted as `q = Rᵀ (X − c)`; the residual is
//! `r = q − p_s(t + δ_s)`, the sensor's track at the instant shifted by its clock offset. The
//! rotation is updated on the right, `R ← R exp([δθ]×)`, so `∂r/∂δθ = [q]×`, `∂r/∂c = −Rᵀ`,
//! `∂r/∂X = Rᵀ`, `∂r/∂δ = −ṗ_s`. The points are eliminated by the Schur complement (each
//! point's block is 3×3), leaving a system of 6 or 7 unknowns per sensor. One sensor (the
//! reference) is held fixed: the tracks cannot say where the world is, and the world frame is
//! fixed afterwards from the floor ([`crate::gauge`]).

use nalgebra::{
    DMatrix, DVector, Isometry3, Matrix3, Point3, SMatrix, Translation3, UnitQuaternion, Vector3,
};

use crate::interp::{JointTrack, Limits};

/// One report in the adjustment.
#[derive(Debug, Clone)]
pub(crate) struct Obs {
    pub sensor: usize,
    pub point: usize,
    /// The track instant (grid time) before the sensor's clock offset.
    pub t_secs: f64,
    /// Index of the sensor's joint track.
    pub track: usize,
    /// Inverse covariance in the sensor's frame.
    pub information: Matrix3<f64>,
    pub measured: Point3<f64>,
    pub velocity: Vector3<f64>,
    pub active: bool,
}

/// The problem: sensors (poses, offsets), points and reports.
pub(crate) struct Problem<'a> {
    pub poses: Vec<Isometry3<f64>>,
    pub offsets: Vec<f64>,
    /// Which sensors' poses are estimated (the reference and uncalibrated ones are not).
    pub free: Vec<bool>,
    pub points: Vec<Point3<f64>>,
    pub obs: Vec<Obs>,
    /// Reports grouped by point: `obs[by_point[p]..by_point[p + 1]]` (obs sorted by point).
    pub by_point: Vec<usize>,
    pub tracks: &'a [Vec<JointTrack>],
    pub limits: Limits,
    pub time_offsets: bool,
    pub max_offset_secs: f64,
}

type Block = SMatrix<f64, 7, 3>;

/// Outcome of one solve.
#[derive(Debug, Clone, Default)]
pub(crate) struct Solve {
    pub iterations: usize,
    /// Covariance of each free sensor's parameters (δθ in its frame, δc in the frame, δt), from
    /// the inverse of the reduced normal matrix; zero for fixed sensors.
    pub covariance: Vec<SMatrix<f64, 7, 7>>,
}

fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

impl Problem<'_> {
    fn dims(&self) -> usize {
        if self.time_offsets { 7 } else { 6 }
    }

    /// Index of each free sensor's block in the reduced system.
    fn blocks(&self) -> Vec<Option<usize>> {
        let mut next = 0;
        self.free
            .iter()
            .map(|f| {
                f.then(|| {
                    next += 1;
                    next - 1
                })
            })
            .collect()
    }

    /// Re-reads every report at its sensor's shifted instant.
    fn remeasure(&mut self, offsets: &[f64]) {
        if !self.time_offsets {
            return;
        }
        for o in &mut self.obs {
            let track = &self.tracks[o.sensor][o.track];
            if let Some(s) = track.at(o.t_secs + offsets[o.sensor], &self.limits) {
                o.measured = s.position;
                o.velocity = s.velocity;
            }
        }
    }

    fn residual(&self, o: &Obs, poses: &[Isometry3<f64>], points: &[Point3<f64>]) -> Vector3<f64> {
        poses[o.sensor].inverse_transform_point(&points[o.point]) - o.measured
    }

    /// Squared Mahalanobis distance of every report under the current estimate.
    pub fn chi2(&self) -> Vec<f64> {
        self.obs
            .iter()
            .map(|o| {
                let r = self.residual(o, &self.poses, &self.points);
                (r.transpose() * o.information * r)[(0, 0)]
            })
            .collect()
    }

    fn cost(&self, poses: &[Isometry3<f64>], points: &[Point3<f64>]) -> f64 {
        self.obs
            .iter()
            .filter(|o| o.active)
            .map(|o| {
                let r = self.residual(o, poses, points);
                (r.transpose() * o.information * r)[(0, 0)]
            })
            .sum()
    }

    /// Levenberg–Marquardt until the cost stops falling.
    pub fn solve(&mut self, max_iterations: usize) -> Solve {
        let m = self.dims();
        let blocks = self.blocks();
        let mut lambda = 1e-3;
        let mut cost = self.cost(&self.poses, &self.points);
        let mut iterations = 0;
        for _ in 0..max_iterations {
            iterations += 1;
            let (s, rhs, point_terms) = self.normal_equations(&blocks, m, lambda);
            let Some(delta_c) = solve_spd(&s, &rhs) else {
                lambda *= 10.0;
                continue;
            };
            // Back-substitute the points.
            let mut points = self.points.clone();
            for (p, (hpp_inv, bp, hcp)) in point_terms.iter().enumerate() {
                let mut b = *bp;
                for (sensor, h) in hcp {
                    if let Some(i) = blocks[*sensor] {
                        let dc = delta_c.rows(i * m, m);
                        for r in 0..m {
                            b -= h.row(r).transpose() * dc[r];
                        }
                    }
                }
                points[p] += hpp_inv * b;
            }
            let mut poses = self.poses.clone();
            let mut offsets = self.offsets.clone();
            for (sensor, block) in blocks.iter().enumerate() {
                let Some(i) = block else { continue };
                let d = delta_c.rows(i * m, m);
                let dtheta = Vector3::new(d[0], d[1], d[2]);
                let dc = Vector3::new(d[3], d[4], d[5]);
                let pose = &self.poses[sensor];
                poses[sensor] = Isometry3::from_parts(
                    Translation3::from(pose.translation.vector + dc),
                    pose.rotation * UnitQuaternion::from_scaled_axis(dtheta),
                );
                if m == 7 {
                    offsets[sensor] =
                        (offsets[sensor] + d[6]).clamp(-self.max_offset_secs, self.max_offset_secs);
                }
            }
            let saved: Vec<(Point3<f64>, Vector3<f64>)> =
                self.obs.iter().map(|o| (o.measured, o.velocity)).collect();
            self.remeasure(&offsets);
            let new_cost = self.cost(&poses, &points);
            if new_cost.is_finite() && new_cost <= cost {
                let done = cost - new_cost <= 1e-10 * cost.max(1e-300);
                self.poses = poses;
                self.points = points;
                self.offsets = offsets;
                cost = new_cost;
                lambda = (lambda / 3.0).max(1e-12);
                if done {
                    break;
                }
            } else {
                for (o, (p, v)) in self.obs.iter_mut().zip(saved) {
                    o.measured = p;
                    o.velocity = v;
                }
                lambda *= 5.0;
                if lambda > 1e12 {
                    break;
                }
            }
        }
        // Covariance from the undamped reduced normal matrix at the solution.
        let (reduced, _, _) = self.normal_equations(&blocks, m, 0.0);
        let inverse = pseudo_inverse(&reduced);
        let covariance = blocks
            .iter()
            .map(|b| {
                let mut c = SMatrix::<f64, 7, 7>::zeros();
                if let Some(i) = b {
                    let sub = inverse.view((i * m, i * m), (m, m));
                    for r in 0..m {
                        for k in 0..m {
                            c[(r, k)] = sub[(r, k)];
                        }
                    }
                }
                c
            })
            .collect();
        Solve {
            iterations,
            covariance,
        }
    }

    /// The reduced (Schur complement) system and, per point, what back-substitution needs.
    #[allow(clippy::type_complexity)]
    fn normal_equations(
        &self,
        blocks: &[Option<usize>],
        m: usize,
        lambda: f64,
    ) -> (
        DMatrix<f64>,
        DVector<f64>,
        Vec<(Matrix3<f64>, Vector3<f64>, Vec<(usize, Block)>)>,
    ) {
        let nb = blocks.iter().flatten().count();
        let mut s = DMatrix::<f64>::zeros(nb * m, nb * m);
        let mut rhs = DVector::<f64>::zeros(nb * m);
        let mut terms = Vec::with_capacity(self.points.len());
        for p in 0..self.points.len() {
            let mut hpp = Matrix3::zeros();
            let mut bp = Vector3::zeros();
            // Per report of this point with a free sensor: J_cᵀ W (m × 3) = Hcp, and J_cᵀ W r.
            let mut hcp: Vec<(usize, Block)> = Vec::new();
            for o in &self.obs[self.by_point[p]..self.by_point[p + 1]] {
                if !o.active {
                    continue;
                }
                let pose = &self.poses[o.sensor];
                let rt = pose.rotation.to_rotation_matrix().matrix().transpose();
                let q = pose.inverse_transform_point(&self.points[o.point]);
                let r = q.coords - o.measured.coords;
                let w = &o.information;
                let jx = rt;
                hpp += jx.transpose() * w * jx;
                bp -= jx.transpose() * (w * r);
                let Some(i) = blocks[o.sensor] else { continue };
                let mut jc = SMatrix::<f64, 3, 7>::zeros();
                jc.fixed_view_mut::<3, 3>(0, 0).copy_from(&skew(&q.coords));
                jc.fixed_view_mut::<3, 3>(0, 3).copy_from(&(-rt));
                if m == 7 {
                    jc.fixed_view_mut::<3, 1>(0, 6).copy_from(&(-o.velocity));
                }
                let jtw = jc.transpose() * w;
                let hcc = jtw * jc;
                let g = jtw * r;
                for a in 0..m {
                    rhs[i * m + a] -= g[a];
                    for b in 0..m {
                        s[(i * m + a, i * m + b)] += hcc[(a, b)];
                    }
                }
                hcp.push((o.sensor, jtw * jx));
            }
            for d in 0..3 {
                hpp[(d, d)] *= 1.0 + lambda;
            }
            let hpp_inv = hpp.try_inverse().unwrap_or_else(Matrix3::zeros);
            for (s1, h1) in &hcp {
                let Some(i1) = blocks[*s1] else { continue };
                let h1_inv = h1 * hpp_inv;
                let g = h1_inv * bp;
                for a in 0..m {
                    rhs[i1 * m + a] -= g[a];
                }
                for (s2, h2) in &hcp {
                    let Some(i2) = blocks[*s2] else { continue };
                    let c = h1_inv * h2.transpose();
                    for a in 0..m {
                        for b in 0..m {
                            s[(i1 * m + a, i2 * m + b)] -= c[(a, b)];
                        }
                    }
                }
            }
            terms.push((hpp_inv, bp, hcp));
        }
        for d in 0..nb * m {
            s[(d, d)] += lambda * s[(d, d)] + 1e-12;
        }
        (s, rhs, terms)
    }
}

fn solve_spd(s: &DMatrix<f64>, rhs: &DVector<f64>) -> Option<DVector<f64>> {
    if s.nrows() == 0 {
        return Some(DVector::zeros(0));
    }
    let x = s.clone().cholesky()?.solve(rhs);
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// Inverse through the SVD with singular values floored at 1e-15 of the largest: an
/// unobservable direction gets an enormous variance (which the diagnostics report) instead of
/// a NaN.
pub(crate) fn pseudo_inverse(s: &DMatrix<f64>) -> DMatrix<f64> {
    if s.nrows() == 0 {
        return s.clone();
    }
    let Some(svd) = s.clone().try_svd(
        true,
        true,
        f64::EPSILON,
        crate::MAX_DECOMPOSITION_ITERATIONS,
    ) else {
        return DMatrix::from_diagonal_element(s.nrows(), s.ncols(), f64::INFINITY);
    };
    let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else {
        return DMatrix::from_diagonal_element(s.nrows(), s.ncols(), f64::INFINITY);
    };
    let floor = svd.singular_values.max().max(f64::MIN_POSITIVE) * 1e-15;
    let inv = DVector::from_iterator(
        svd.singular_values.len(),
        svd.singular_values.iter().map(|v| 1.0 / v.max(floor)),
    );
    v_t.transpose() * DMatrix::from_diagonal(&inv) * u.transpose()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A normal matrix holding a NaN or an overflow gives back a matrix, promptly: an unbounded
    /// SVD never converges on it. A well-posed one is inverted.
    #[test]
    fn pseudo_inverse_of_a_non_finite_matrix_ends() {
        for bad in [f64::NAN, f64::INFINITY, 1e300 * 1e300] {
            let mut s = DMatrix::<f64>::identity(12, 12);
            s[(3, 5)] = bad;
            s[(5, 3)] = bad;
            let inv = pseudo_inverse(&s);
            assert_eq!(inv.shape(), (12, 12));
        }
        let s = DMatrix::from_diagonal(&DVector::from_iterator(4, [1.0, 2.0, 4.0, 8.0]));
        let inv = pseudo_inverse(&s);
        assert!((inv[(3, 3)] - 0.125).abs() < 1e-12 && (inv[(0, 0)] - 1.0).abs() < 1e-12);
    }
}
