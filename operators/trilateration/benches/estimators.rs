//! Solves per second of each estimator for one joint seen by 3, 6 and 16 sensors.
//!
//! Inputs are pre-generated noisy observations (Kinect-like anisotropic noise, 1 cm along the
//! ray, 2 cm across) so only the solve is timed. Run with
//! `cargo bench --release -p trigait-trilateration`; `trigait bench` prints the same solvers'
//! throughput as ratios against `linear` and against scipy.

// Test helpers outside `#[test]` functions panic on failure by design.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::hint::black_box;

use criterion::{BatchSize, Criterion, Throughput, criterion_group, criterion_main};
use nalgebra::{Isometry3, Matrix3, Point3, Vector3};
use trigait_trilateration::{Method, Observation, Params, estimate};

/// Observations of a joint at knee height by `n` sensors on a 3 m ring at two heights, with a
/// fixed pseudo-random perturbation per sensor and frame.
fn frames(n: usize, count: usize) -> Vec<Vec<Observation>> {
    let mut state = 0x9e37_79b9_7f4a_7c15_u64;
    let mut noise = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    (0..count)
        .map(|_| {
            let target = Point3::new(noise(), noise() * 0.4, 0.5 + noise() * 0.4);
            (0..n)
                .map(|i| {
                    let az = std::f64::consts::TAU * (i as f64 + 0.5) / n as f64;
                    let height = if i % 2 == 0 { 0.7 } else { 1.5 };
                    let eye = Point3::new(3.0 * az.cos(), 3.0 * az.sin(), height);
                    let pose =
                        Isometry3::face_towards(&eye, &Point3::new(0.0, 0.0, 0.5), &Vector3::z());
                    let truth = pose.inverse_transform_point(&target);
                    let u = truth.coords.normalize();
                    let along = u * u.transpose();
                    let cov = along * 1e-4 + (Matrix3::identity() - along) * 4e-4;
                    let p = truth + Vector3::new(noise(), noise(), noise()) * 0.02;
                    Observation::new(pose, p, cov)
                })
                .collect()
        })
        .collect()
}

fn estimators(c: &mut Criterion) {
    for n in [3, 6, 16] {
        let inputs = frames(n, 256);
        let mut group = c.benchmark_group(format!("{n} sensors"));
        group.throughput(Throughput::Elements(1));
        for method in Method::ALL {
            for robust in [false, true] {
                if robust && method != Method::Fusion {
                    continue;
                }
                let params = Params::new(method).with_robust(robust);
                let name = if robust {
                    format!("{method}+robust")
                } else {
                    method.to_string()
                };
                let mut next = 0;
                group.bench_function(name, |b| {
                    b.iter_batched(
                        || {
                            next = (next + 1) % inputs.len();
                            &inputs[next]
                        },
                        |obs| black_box(estimate(obs, &params)),
                        BatchSize::SmallInput,
                    );
                });
            }
        }
        group.finish();
    }
}

// `criterion_group!` defines an undocumented `pub fn benches`.
#[allow(missing_docs)]
mod group {
    use super::{criterion_group, estimators};
    criterion_group!(benches, estimators);
}
use group::benches;
criterion_main!(benches);
