//! Pairwise initial alignment: the rigid motion between two sensors from the joints both saw
//! at the same instants, by weighted Kabsch/Umeyama inside a RANSAC over instants (a whole
//! instant is one sample, so a mis-tracked skeleton, a left/right mix-up the handedness check
//! missed, or a bad interpolation costs that instant and nothing else).

use nalgebra::{Isometry3, Matrix3, Point3, Rotation3, Translation3, UnitQuaternion, Vector3};

/// Weighted correspondences `a ≈ a_from_b · b`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Pair {
    pub a: Point3<f64>,
    pub b: Point3<f64>,
    pub weight: f64,
}

/// Weighted Kabsch (Umeyama without scale): the rigid `a_from_b` minimising
/// `Σ w |a − (R b + t)|²`; `None` for fewer than three pairs or a degenerate (collinear) set.
pub(crate) fn kabsch(pairs: &[Pair]) -> Option<Isometry3<f64>> {
    let total: f64 = pairs.iter().map(|p| p.weight).sum();
    if pairs.len() < 3 || total <= 0.0 {
        return None;
    }
    let ca = pairs
        .iter()
        .map(|p| p.a.coords * p.weight)
        .sum::<Vector3<f64>>()
        / total;
    let cb = pairs
        .iter()
        .map(|p| p.b.coords * p.weight)
        .sum::<Vector3<f64>>()
        / total;
    let mut h = Matrix3::zeros();
    for p in pairs {
        h += (p.b.coords - cb) * (p.a.coords - ca).transpose() * p.weight;
    }
    let svd = h.try_svd(
        true,
        true,
        f64::EPSILON,
        crate::MAX_DECOMPOSITION_ITERATIONS,
    )?;
    let (u, v_t) = (svd.u?, svd.v_t?);
    let s = &svd.singular_values;
    // Collinear points leave the rotation about their line free.
    if s[1] <= 1e-9 * s[0].max(1e-300) {
        return None;
    }
    let v = v_t.transpose();
    let d = (v * u.transpose()).determinant().signum();
    let r = v * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * u.transpose();
    let rotation = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r));
    let t = ca - rotation * cb;
    Some(Isometry3::from_parts(Translation3::from(t), rotation))
}

/// The correspondences of one common instant.
pub(crate) type Instant = Vec<Pair>;

/// Result of [`ransac`].
#[derive(Debug, Clone)]
pub(crate) struct Alignment {
    pub a_from_b: Isometry3<f64>,
    /// Instants consistent with it.
    pub inliers: usize,
}

/// Median distance of an instant's correspondences under `a_from_b`.
fn instant_error(instant: &Instant, a_from_b: &Isometry3<f64>) -> f64 {
    let mut d: Vec<f64> = instant
        .iter()
        .map(|p| (p.a - a_from_b * p.b).norm())
        .collect();
    d.sort_by(f64::total_cmp);
    d[d.len() / 2]
}

/// RANSAC over instants: hypotheses from three instants spread over the walk (deterministic,
/// strided), scored by how many instants agree within `threshold_m` (median joint distance),
/// the best refined by Kabsch on all its inliers until the inlier set stops changing.
pub(crate) fn ransac(
    instants: &[Instant],
    threshold_m: f64,
    hypotheses: usize,
) -> Option<Alignment> {
    let n = instants.len();
    if n < 3 {
        return None;
    }
    let score = |iso: &Isometry3<f64>| {
        instants
            .iter()
            .filter(|i| instant_error(i, iso) < threshold_m)
            .count()
    };
    let mut best: Option<(usize, Isometry3<f64>)> = None;
    for h in 0..hypotheses {
        // Golden-ratio sequence: deterministic, low-discrepancy picks that cover the walk.
        let pick = |i: usize| (((3 * h + i) as f64 * 0.618_033_988_75).fract() * n as f64) as usize;
        let picks = [pick(0), pick(1), pick(2)];
        let pairs: Vec<Pair> = picks
            .iter()
            .flat_map(|i| instants[*i].iter().copied())
            .collect();
        let Some(iso) = kabsch(&pairs) else { continue };
        let s = score(&iso);
        if best.as_ref().is_none_or(|(b, _)| s > *b) {
            best = Some((s, iso));
        }
    }
    let (_, mut iso) = best?;
    let mut inliers: Vec<usize> = Vec::new();
    for _ in 0..5 {
        let now: Vec<usize> = (0..n)
            .filter(|i| instant_error(&instants[*i], &iso) < threshold_m)
            .collect();
        if now.len() < 3 {
            return None;
        }
        let pairs: Vec<Pair> = now
            .iter()
            .flat_map(|i| instants[*i].iter().copied())
            .collect();
        iso = kabsch(&pairs)?;
        if now == inliers {
            break;
        }
        inliers = now;
    }
    Some(Alignment {
        a_from_b: iso,
        inliers: inliers.len(),
    })
}

#[cfg(test)]
mod tests {
    use approx::assert_relative_eq;

    use super::*;

    /// Pairs holding a NaN or an overflowing coordinate give no motion, and promptly: an
    /// unbounded SVD never converges on them.
    #[test]
    fn non_finite_pairs_give_no_motion() {
        for bad in [f64::NAN, f64::INFINITY, 1e300] {
            let pairs: Vec<Pair> = (0..6)
                .map(|j| {
                    let j = f64::from(j);
                    let b = Point3::new(0.1 * j, j.sin(), 0.3 * j.cos());
                    Pair {
                        a: if j == 2.0 {
                            Point3::new(bad, 0.0, 0.0)
                        } else {
                            b
                        },
                        b,
                        weight: 1.0,
                    }
                })
                .collect();
            let found = kabsch(&pairs);
            assert!(
                found.is_none_or(|m| m.translation.vector.iter().all(|v| !v.is_finite())),
                "{bad}: {found:?}"
            );
        }
    }

    /// Kabsch recovers a known motion exactly; RANSAC keeps it when a third of the instants are
    /// garbage.
    #[test]
    fn recovers_motion_despite_outlier_instants() {
        let truth = Isometry3::new(Vector3::new(1.0, -2.0, 0.5), Vector3::new(0.1, 0.7, -0.2));
        let points = |k: usize| -> Vec<Point3<f64>> {
            (0..6)
                .map(|j| {
                    let (k, j) = (k as f64, j as f64);
                    Point3::new(0.05 * k, 0.1 * j.sin(), 0.15 * j + 0.01 * k.cos())
                })
                .collect()
        };
        let instants: Vec<Instant> = (0..60)
            .map(|k| {
                points(k)
                    .into_iter()
                    .map(|b| Pair {
                        a: if k % 3 == 1 {
                            Point3::new(5.0, 5.0, 5.0) - b.coords
                        } else {
                            truth * b
                        },
                        b,
                        weight: 1.0,
                    })
                    .collect()
            })
            .collect();
        let clean: Vec<Pair> = instants[0].clone();
        assert_relative_eq!(kabsch(&clean).unwrap(), truth, epsilon = 1e-9);
        let a = ransac(&instants, 0.05, 30).unwrap();
        assert_eq!(a.inliers, 40);
        assert_relative_eq!(a.a_from_b, truth, epsilon = 1e-9);
    }
}
