//! Contract tests of the estimators on synthetic ground truth: exact recovery on noise-free
//! data for random rigs, typed errors on degenerate input, outlier rejection, and efficiency
//! against the Cramér–Rao bound.

// Test helpers outside `#[test]` functions panic on failure by design.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use approx::assert_relative_eq;
use nalgebra::{Isometry3, Matrix3, Point3, Vector3};
use proptest::prelude::*;
use trigait_trilateration::{Error, Method, Observation, Params, crb, estimate};

/// Kinect-like anisotropic covariance in camera space: `range_sigma` along the ray to the joint,
/// `lateral_sigma` across it.
fn covariance(p_in_kinect: &Point3<f64>, range_sigma: f64, lateral_sigma: f64) -> Matrix3<f64> {
    let u = p_in_kinect.coords.normalize();
    let along = u * u.transpose();
    along * range_sigma.powi(2) + (Matrix3::identity() - along) * lateral_sigma.powi(2)
}

/// A sensor at `eye` looking at `look_at` (Kinect axes: x left, y up, z forward), reporting the
/// joint at `target` exactly.
fn observe(eye: Point3<f64>, look_at: Point3<f64>, target: Point3<f64>) -> Observation {
    let world_from_kinect = Isometry3::face_towards(&eye, &look_at, &Vector3::z());
    let p = world_from_kinect.inverse_transform_point(&target);
    Observation::new(world_from_kinect, p, covariance(&p, 0.01, 0.02))
}

fn rig(eyes: &[Point3<f64>], target: Point3<f64>) -> Vec<Observation> {
    eyes.iter().map(|e| observe(*e, target, target)).collect()
}

/// Distance of `target` from the plane through three points.
fn distance_from_plane(a: Point3<f64>, b: Point3<f64>, c: Point3<f64>, target: Point3<f64>) -> f64 {
    let n = (b - a).cross(&(c - a)).normalize();
    (target - a).dot(&n).abs()
}

/// Sensors around a target: azimuths spread over the circle with jitter, 1.5–4 m away
/// horizontally, 1–2 m high; the target 0–0.6 m high.
fn surrounding_rig() -> impl Strategy<Value = (Vec<Point3<f64>>, Point3<f64>)> {
    (3usize..=8).prop_flat_map(|n| {
        (
            proptest::collection::vec((-0.3f64..0.3, 1.5f64..4.0, 1.0f64..2.0), n),
            (-1.0f64..1.0, -1.0f64..1.0, 0.0f64..0.6),
        )
            .prop_map(move |(sensors, (tx, ty, tz))| {
                let target = Point3::new(tx, ty, tz);
                let eyes = sensors
                    .iter()
                    .enumerate()
                    .map(|(i, (jitter, dist, height))| {
                        let az = std::f64::consts::TAU * i as f64 / n as f64 + jitter;
                        Point3::new(tx + dist * az.cos(), ty + dist * az.sin(), *height)
                    })
                    .collect();
                (eyes, target)
            })
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, failure_persistence: None, ..ProptestConfig::default() })]

    /// Every estimator returns the exact joint (≤ 1e-9 m) on noise-free data from a random
    /// non-degenerate rig, whatever the sensor count.
    #[test]
    fn noise_free_is_exact((eyes, target) in surrounding_rig()) {
        let obs = rig(&eyes, target);
        // Geometric uses the widest triangle; a joint in that triangle's plane is the
        // degenerate case where the two mirror solutions merge.
        let triple = widest(&eyes);
        prop_assume!(distance_from_plane(eyes[triple[0]], eyes[triple[1]], eyes[triple[2]], target) > 0.2);
        for method in Method::ALL {
            let e = estimate(&obs, &Params::new(method)).unwrap();
            let error = (e.position - target).norm();
            prop_assert!(error <= 1e-9, "{method}: error {error:e} m with {} sensors", eyes.len());
        }
    }

    /// The answer does not depend on the order the sensors are listed in.
    #[test]
    fn order_independent((eyes, target) in surrounding_rig()) {
        let mut obs = rig(&eyes, target);
        // Add deterministic noise so the estimators have something to disagree about.
        for (i, o) in obs.iter_mut().enumerate() {
            o.position_in_kinect.x += 0.003 * ((i * 7 % 5) as f64 - 2.0);
            o.position_in_kinect.z += 0.002 * ((i * 3 % 4) as f64 - 1.5);
        }
        let mut reversed = obs.clone();
        reversed.reverse();
        for method in [Method::Nls, Method::Fusion] {
            let a = estimate(&obs, &Params::new(method)).unwrap();
            let b = estimate(&reversed, &Params::new(method)).unwrap();
            prop_assert!((a.position - b.position).norm() < 1e-8, "{method}");
        }
    }
}

fn widest(eyes: &[Point3<f64>]) -> [usize; 3] {
    let mut best = ([0, 1, 2], -1.0);
    for i in 0..eyes.len() {
        for j in i + 1..eyes.len() {
            for k in j + 1..eyes.len() {
                let area = (eyes[j] - eyes[i]).cross(&(eyes[k] - eyes[i])).norm();
                if area > best.1 {
                    best = ([i, j, k], area);
                }
            }
        }
    }
    best.0
}

fn thesis_like() -> (Vec<Point3<f64>>, Point3<f64>) {
    let eyes = vec![
        Point3::new(-2.3, 2.135, 1.5),
        Point3::new(-2.3, -2.135, 1.5),
        Point3::new(2.3, 0.0, 1.5),
    ];
    (eyes, Point3::new(0.4, 0.1, 0.5))
}

/// With all sensors at one height the linear system has rank 2; the mirror rule still puts
/// the joint below the sensors, where they look, for any sensor count.
#[test]
fn coplanar_rig_resolves_to_viewing_side() {
    let (mut eyes, target) = thesis_like();
    eyes.push(Point3::new(0.0, 3.0, 1.5));
    eyes.push(Point3::new(0.0, -3.0, 1.5));
    for n in 3..=5 {
        let obs = rig(&eyes[..n], target);
        for method in [Method::Geometric, Method::Linear, Method::Nls] {
            let e = estimate(&obs, &Params::new(method)).unwrap();
            assert!((e.position - target).norm() < 1e-9, "{method} n={n}");
            assert!(e.diagnostics.mirror_resolved, "{method} n={n}");
        }
    }
}

/// Sensors at hip height looking level cannot tell the side from their axes; the reported
/// bearings pick it, for joints above and below the sensors' plane.
#[test]
fn level_rig_uses_bearing_vote() {
    for z in [0.2, 1.4] {
        let target = Point3::new(0.2, 0.0, z);
        let eyes = [
            Point3::new(-2.3, 2.135, 0.8),
            Point3::new(-2.3, -2.135, 0.8),
            Point3::new(2.3, 0.0, 0.8),
        ];
        let obs: Vec<Observation> = eyes
            .iter()
            .map(|e| observe(*e, Point3::new(0.0, 0.0, 0.8), target))
            .collect();
        let e = estimate(&obs, &Params::new(Method::Linear)).unwrap();
        assert_relative_eq!(e.position.z, z, epsilon = 1e-9);
    }
}

/// Too few sensors, collinear sensors, NaN, a sensor at the target, and a broken covariance are
/// typed errors, never panics.
#[test]
fn degenerate_inputs_are_typed_errors() {
    let (eyes, target) = thesis_like();
    let obs = rig(&eyes, target);
    for method in [Method::Geometric, Method::Linear, Method::Nls] {
        let err = estimate(&obs[..2], &Params::new(method)).unwrap_err();
        assert_eq!(
            err,
            Error::TooFewSensors {
                method,
                got: 2,
                need: 3
            }
        );
    }
    assert!(matches!(
        estimate(&[], &Params::new(Method::Fusion)),
        Err(Error::TooFewSensors {
            got: 0,
            need: 1,
            ..
        })
    ));

    let collinear = rig(
        &[
            Point3::new(-2.0, 2.0, 1.5),
            Point3::new(0.0, 2.0, 1.5),
            Point3::new(2.0, 2.0, 1.5),
            Point3::new(4.0, 2.0, 1.5),
        ],
        target,
    );
    for method in [Method::Geometric, Method::Linear, Method::Nls] {
        let err = estimate(&collinear, &Params::new(method)).unwrap_err();
        assert!(matches!(err, Error::Degenerate { .. }), "{method}: {err:?}");
    }

    let mut nan = obs.clone();
    nan[1].position_in_kinect.y = f64::NAN;
    for method in Method::ALL {
        assert_eq!(
            estimate(&nan, &Params::new(method)).unwrap_err(),
            Error::NonFinite { index: 1 },
            "{method}"
        );
    }

    let mut at_target = obs.clone();
    at_target[2].position_in_kinect = Point3::origin();
    for method in Method::ALL {
        assert!(
            matches!(
                estimate(&at_target, &Params::new(method)),
                Err(Error::SensorAtTarget { index: 2, .. })
            ),
            "{method}"
        );
    }

    let mut singular = obs;
    singular[0].covariance_in_kinect = Matrix3::zeros();
    assert_eq!(
        estimate(&singular, &Params::new(Method::Fusion)).unwrap_err(),
        Error::BadCovariance { index: 0 }
    );
}

/// A sensor whose joint is 25 cm off along its ray (a leg mistaken for the other one behind it)
/// is rejected by the robust wrapper and the rest recover the joint; without the wrapper it drags
/// the answer away. A 25 cm error *across* the ray barely changes the range, so only Fusion,
/// which sees bearings, can catch that one.
#[test]
fn robust_rejects_the_inconsistent_sensor() {
    let target = Point3::new(0.3, -0.2, 0.5);
    let eyes: Vec<Point3<f64>> = (0..6)
        .map(|i| {
            let az = std::f64::consts::TAU * (i as f64 + 0.5) / 6.0;
            Point3::new(
                3.0 * az.cos(),
                3.0 * az.sin(),
                if i % 2 == 0 { 0.7 } else { 1.5 },
            )
        })
        .collect();
    let clean = rig(&eyes, target);
    let mut obs = clean.clone();
    let ray = obs[4].position_in_kinect.coords.normalize();
    obs[4].position_in_kinect += ray * 0.25;
    for method in [Method::Fusion, Method::Nls] {
        let plain = estimate(&obs, &Params::new(method)).unwrap();
        let robust = estimate(&obs, &Params::new(method).with_robust(true)).unwrap();
        assert_eq!(robust.diagnostics.rejected, vec![4], "{method}");
        assert_eq!(robust.diagnostics.used, vec![0, 1, 2, 3, 5], "{method}");
        assert!((robust.position - target).norm() < 1e-6, "{method}");
        assert!((plain.position - target).norm() > 0.01, "{method}");
    }
    let mut across = clean;
    across[4].position_in_kinect.x += 0.25;
    let fused = estimate(&across, &Params::new(Method::Fusion).with_robust(true)).unwrap();
    assert_eq!(fused.diagnostics.rejected, vec![4]);
    let ranged = estimate(&across, &Params::new(Method::Nls).with_robust(true)).unwrap();
    assert!(ranged.diagnostics.rejected.is_empty());
}

/// On consistent data the robust wrapper keeps every sensor.
#[test]
fn robust_keeps_consistent_sensors() {
    let (eyes, target) = thesis_like();
    let mut eyes = eyes;
    eyes.push(Point3::new(0.0, 3.0, 0.9));
    let obs = rig(&eyes, target);
    let e = estimate(&obs, &Params::new(Method::Fusion).with_robust(true)).unwrap();
    assert!(e.diagnostics.rejected.is_empty());
    assert_eq!(e.diagnostics.used.len(), 4);
}

/// Fusion's covariance is the full-observation Cramér–Rao bound, and the range-only bound is
/// never smaller than it (ranges are part of the full observation).
#[test]
fn fusion_covariance_is_the_bound() {
    let (eyes, target) = thesis_like();
    let obs = rig(&eyes, target);
    let e = estimate(&obs, &Params::new(Method::Fusion)).unwrap();
    let full = crb::full(&obs).unwrap();
    assert!((e.covariance - full).amax() < 1e-15);
    let range = crb::range_only(&obs).unwrap();
    assert!(crb::rmse_bound_m(&range) >= crb::rmse_bound_m(&full));
    // NLS's reported covariance at the truth is the range-only bound.
    let nls = estimate(&obs, &Params::new(Method::Nls)).unwrap();
    assert!((nls.covariance - range).amax() < 1e-12);
}

/// A deterministic Gaussian sampler (Box–Muller on a 64-bit LCG), so this crate needs no RNG.
struct Gauss(u64);
impl Gauss {
    fn uniform(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((self.0 >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }
    fn normal(&mut self) -> f64 {
        let (u, v) = (self.uniform(), self.uniform());
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }
}

/// Monte Carlo: with Gaussian noise drawn from the stated covariances, Fusion's RMSE equals the
/// full CRB and NLS's the range-only CRB (within 5 %), and Fusion beats Linear.
#[test]
fn monte_carlo_matches_the_bounds() {
    let target = Point3::new(0.2, 0.1, 0.5);
    let eyes: Vec<Point3<f64>> = (0..5)
        .map(|i| {
            let az = std::f64::consts::TAU * (i as f64 + 0.5) / 5.0;
            Point3::new(
                3.0 * az.cos(),
                3.0 * az.sin(),
                if i % 2 == 0 { 0.6 } else { 1.6 },
            )
        })
        .collect();
    let clean = rig(&eyes, target);
    let mut rng = Gauss(7);
    let trials = 4000;
    let mut sq = std::collections::BTreeMap::new();
    for _ in 0..trials {
        let noisy: Vec<Observation> = clean
            .iter()
            .map(|o| {
                let chol = o.covariance_in_kinect.cholesky().unwrap();
                let n = Vector3::new(rng.normal(), rng.normal(), rng.normal());
                let mut o = o.clone();
                o.position_in_kinect += chol.l() * n;
                o
            })
            .collect();
        for method in [Method::Linear, Method::Nls, Method::Fusion] {
            let e = estimate(&noisy, &Params::new(method)).unwrap();
            *sq.entry(method).or_insert(0.0) += (e.position - target).norm_squared();
        }
    }
    let rmse = |m| (sq[&m] / trials as f64).sqrt();
    let full = crb::rmse_bound_m(&crb::full(&clean).unwrap());
    let range = crb::rmse_bound_m(&crb::range_only(&clean).unwrap());
    assert!(
        (rmse(Method::Fusion) / full - 1.0).abs() < 0.05,
        "{} vs {full}",
        rmse(Method::Fusion)
    );
    assert!(
        (rmse(Method::Nls) / range - 1.0).abs() < 0.05,
        "{} vs {range}",
        rmse(Method::Nls)
    );
    assert!(rmse(Method::Fusion) < rmse(Method::Linear));
}
