//! The Rust undistortion and back-projection (`trigait_depth::Undistorter`) against
//! libfreenect2's own `Registration::undistortDepth` + `getPointXYZ`, on hand-fed frames: a
//! tilted floor, a step edge, holes (0), NaN, negative and out-of-range values, for a typical and a
//! strongly distorted IR lens. Needs the real library (`--features freenect2`).
#![cfg(feature = "freenect2")]
#![allow(clippy::unwrap_used)]

use trigait_depth::Undistorter;
use trigait_freenect2::{IrParams, registration_xyz};

const W: usize = 512;
const H: usize = 424;

fn frame(seed: u32) -> Vec<f32> {
    let mut v = Vec::with_capacity(W * H);
    for r in 0..H {
        for c in 0..W {
            let base = 1500.0 + 3.1 * r as f32 + 0.7 * c as f32 + seed as f32;
            let d = match (r * W + c) % 97 {
                0 => 0.0,
                1 => f32::NAN,
                2 => -5.0,
                3 => 0.5, // below libfreenect2's 1 mm validity limit once in metres
                _ if c > 300 && r < 200 => base + 800.0, // a step edge
                _ => base,
            };
            v.push(d);
        }
    }
    v
}

fn lenses() -> [IrParams; 2] {
    [
        IrParams {
            fx: 365.456,
            fy: 365.456,
            cx: 254.878,
            cy: 205.395,
            k1: 0.090_547_4,
            k2: -0.268_19,
            k3: 0.095_086_2,
            p1: 0.0,
            p2: 0.0,
        },
        IrParams {
            fx: 361.2,
            fy: 362.9,
            cx: 259.3,
            cy: 210.7,
            k1: 0.12,
            k2: -0.35,
            k3: 0.2,
            p1: 0.0012,
            p2: -0.0009,
        },
    ]
}

/// Every pixel: the same undistorted depth, and points within 0.1 mm (NaN where libfreenect2
/// has no point, `None` in Rust).
#[test]
fn matches_libfreenect2_registration() {
    let mut worst = 0.0f32;
    let mut compared = 0usize;
    for (i, lens) in lenses().iter().enumerate() {
        let raw = frame(i as u32);
        let (lf2_und, lf2_xyz) = registration_xyz(lens, &raw).unwrap();
        let ours = Undistorter::new(&lens.intrinsics());
        let mut und = vec![0.0f32; W * H];
        ours.undistort_into(&raw, &mut und).unwrap();
        for (k, (a, b)) in und.iter().zip(&lf2_und).enumerate() {
            assert!(
                a == b || (a.is_nan() && b.is_nan()),
                "lens {i} pixel {k}: {a} vs {b}"
            );
        }
        for r in 0..H {
            for c in 0..W {
                let theirs = lf2_xyz[r * W + c];
                match ours.point_xyz(&und, r, c) {
                    None => assert!(theirs[2].is_nan(), "lens {i} ({r},{c}): {theirs:?}"),
                    Some(p) => {
                        for (a, b) in p.iter().zip(theirs) {
                            worst = worst.max((a - b).abs());
                        }
                        compared += 1;
                    }
                }
            }
        }
    }
    eprintln!(
        "{compared} points compared, worst difference {:.3e} m",
        worst
    );
    assert!(compared > 300_000);
    assert!(worst <= 1e-4, "worst difference {worst} m");
}
