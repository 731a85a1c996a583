//! Structural noise (thesis §3.5; results §5.1.5, Fig. 5.6).
//!
//! A flat wall seen by a Kinect v2 is not flat in its depth image: the depths form rings around
//! the image centre, and fall off towards the border. A plane is fitted robustly to the mean
//! frame (averaging over frames removes the temporal noise of §3.3, leaving the structure), the
//! residual (measured − plane) is profiled by radius from the principal point, and a radial
//! trend (quadratic in the radius) plus one sinusoidal ring term is fitted to the profile by
//! weighted least squares, scanning the ring period. The ring amplitude is the sinusoid's
//! amplitude, the period its wavelength in pixels.

use nalgebra::{DMatrix, DVector};

use crate::frame::{HEIGHT, Intrinsics, PIXELS, Rays, WIDTH};
use crate::plane::{ImagePlaneFit, fit_image_plane};
use crate::{Error, Result};

/// Settings of [`structural_noise`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StructuralParams {
    /// Pixels farther than this from the fitted plane are not on the wall, mm.
    pub plane_tolerance_mm: f64,
    /// Width of the radial profile bins, pixels.
    pub bin_px: f64,
    /// Shortest ring period tried, pixels.
    pub min_period_px: f64,
    /// Longest ring period tried, pixels.
    pub max_period_px: f64,
    /// RANSAC draws of the plane fit.
    pub ransac_iterations: usize,
    /// RNG seed of the plane fit.
    pub seed: u64,
}

impl Default for StructuralParams {
    fn default() -> Self {
        Self {
            plane_tolerance_mm: 30.0,
            bin_px: 1.0,
            min_period_px: 6.0,
            max_period_px: 120.0,
            ransac_iterations: 200,
            seed: 35,
        }
    }
}

/// One bin of the radial residual profile.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ProfileBin {
    /// Bin centre, pixels from the principal point.
    pub radius_px: f64,
    /// Mean residual, mm.
    pub residual_mm: f64,
    /// Pixels in the bin.
    pub pixels: u32,
}

/// Structural noise of a (mean) frame.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct StructuralNoise {
    /// The fitted plane: depth on the optical axis, metres.
    pub plane_distance_m: f64,
    /// The fitted plane's tilt against the optical axis, degrees.
    pub plane_tilt_deg: f64,
    /// Pixels on the plane.
    pub plane_pixels: usize,
    /// RMS residual of those pixels, mm.
    pub rms_residual_mm: f64,
    /// Fitted ring amplitude, mm.
    pub ring_amplitude_mm: f64,
    /// Fitted ring period, pixels.
    pub ring_period_px: f64,
    /// Radial trend: fitted residual at the centre minus at the largest radius with data, mm
    /// (positive when depths fall off towards the border).
    pub centre_minus_edge_mm: f64,
    /// RMS of the profile about the fitted trend + ring, mm.
    pub profile_fit_rms_mm: f64,
    /// The radial profile.
    pub profile: Vec<ProfileBin>,
}

struct RingFit {
    period: f64,
    coef: DVector<f64>,
    rss: f64,
}

fn fit_ring(r: &[f64], p: &[f64], w: &[f64], period: f64) -> Option<RingFit> {
    let n = r.len();
    let k = 2.0 * std::f64::consts::PI / period;
    let a = DMatrix::from_fn(n, 5, |i, j| {
        let s = w[i].sqrt();
        s * match j {
            0 => 1.0,
            1 => r[i],
            2 => r[i] * r[i],
            3 => (k * r[i]).cos(),
            _ => (k * r[i]).sin(),
        }
    });
    let b = DVector::from_fn(n, |i, _| w[i].sqrt() * p[i]);
    let ata = a.transpose() * &a;
    let atb = a.transpose() * &b;
    let coef = ata.cholesky()?.solve(&atb);
    let rss = (&a * &coef - b).norm_squared();
    Some(RingFit { period, coef, rss })
}

/// Structural noise of a mean frame (`mean_mm`, NaN = no data) seen through `rays`, profiled
/// around the principal point of `intrinsics`. Also returns the residual map (mm, NaN off the
/// plane) for the image.
///
/// # Errors
/// The frame has too few valid pixels for a plane, or the profile is too short for the fit.
pub fn structural_noise(
    mean_mm: &[f32],
    rays: &Rays,
    intrinsics: &Intrinsics,
    params: &StructuralParams,
) -> Result<(StructuralNoise, Vec<f32>)> {
    if mean_mm.len() != PIXELS {
        return Err(Error::WrongLength {
            got: mean_mm.len(),
            expected: PIXELS,
        });
    }
    let samples: Vec<_> = (0..PIXELS)
        .filter(|&i| mean_mm[i].is_finite() && mean_mm[i] > 0.0)
        .map(|i| {
            let (x, y) = rays.at(i);
            (x, y, f64::from(mean_mm[i]) / 1000.0)
        })
        .collect();
    let tol_m = params.plane_tolerance_mm / 1000.0;
    let ImagePlaneFit { plane, .. } =
        fit_image_plane(&samples, tol_m, params.ransac_iterations, params.seed)?;
    let bin = params.bin_px.max(0.25);
    let max_r = ((WIDTH * WIDTH + HEIGHT * HEIGHT) as f64).sqrt();
    let nbins = (max_r / bin).ceil() as usize + 1;
    let (mut sum, mut cnt) = (vec![0.0f64; nbins], vec![0u32; nbins]);
    let mut residual = vec![f32::NAN; PIXELS];
    let (mut ss, mut n) = (0.0, 0usize);
    for i in 0..PIXELS {
        let m = f64::from(mean_mm[i]);
        if !m.is_finite() || m <= 0.0 {
            continue;
        }
        let (x, y) = rays.at(i);
        let Some(p) = plane.depth_m(x, y) else {
            continue;
        };
        let e = m - p * 1000.0;
        if e.abs() > params.plane_tolerance_mm {
            continue;
        }
        residual[i] = e as f32;
        ss += e * e;
        n += 1;
        let (u, v) = ((i % WIDTH) as f64, (i / WIDTH) as f64);
        let rad = (u - intrinsics.cx).hypot(v - intrinsics.cy);
        let b = ((rad / bin) as usize).min(nbins - 1);
        sum[b] += e;
        cnt[b] += 1;
    }
    let profile: Vec<ProfileBin> = (0..nbins)
        .filter(|&b| cnt[b] > 0)
        .map(|b| ProfileBin {
            radius_px: (b as f64 + 0.5) * bin,
            residual_mm: sum[b] / f64::from(cnt[b]),
            pixels: cnt[b],
        })
        .collect();
    if profile.len() < 10 {
        return Err(Error::TooFewPoints {
            what: "radial profile of the structural residual".into(),
            got: profile.len(),
            need: 10,
        });
    }
    let r: Vec<f64> = profile.iter().map(|b| b.radius_px).collect();
    let p: Vec<f64> = profile.iter().map(|b| b.residual_mm).collect();
    let w: Vec<f64> = profile.iter().map(|b| f64::from(b.pixels)).collect();
    let span = r.last().copied().unwrap_or(0.0) - r.first().copied().unwrap_or(0.0);
    let max_period = params
        .max_period_px
        .min(span / 1.5)
        .max(params.min_period_px);
    let mut best: Option<RingFit> = None;
    let scan = |from: f64, to: f64, step: f64, best: &mut Option<RingFit>| {
        let mut period = from;
        while period <= to {
            if let Some(f) = fit_ring(&r, &p, &w, period)
                && best.as_ref().is_none_or(|b| f.rss < b.rss)
            {
                *best = Some(f);
            }
            period += step;
        }
    };
    scan(params.min_period_px, max_period, 0.25, &mut best);
    if let Some(centre) = best.as_ref().map(|b| b.period) {
        scan(centre - 0.25, centre + 0.25, 0.01, &mut best);
    }
    let Some(fit) = best else {
        return Err(Error::NoPlane {
            what: "ring fit of the structural residual".into(),
            detail: "the profile's normal equations are singular".into(),
        });
    };
    let c = &fit.coef;
    let r_max = r.last().copied().unwrap_or(0.0);
    let wsum: f64 = w.iter().sum();
    let report = StructuralNoise {
        plane_distance_m: 1.0 / plane.c,
        plane_tilt_deg: plane.tilt_deg(),
        plane_pixels: n,
        rms_residual_mm: if n > 0 {
            (ss / n as f64).sqrt()
        } else {
            f64::NAN
        },
        ring_amplitude_mm: c[3].hypot(c[4]),
        ring_period_px: fit.period,
        centre_minus_edge_mm: -(c[1] * r_max + c[2] * r_max * r_max),
        profile_fit_rms_mm: (fit.rss / wsum).sqrt(),
        profile,
    };
    Ok((report, residual))
}
