//! Structural noise (thesis §3.5; results §5.1.5, Fig. 5.6).
//!
//! A flat wall seen by a Kinect v2 is not flat in its depth image: the depths form rings around
//! the image centre, and fall off towards the border. A plane is fitted robustly to the mean
//! frame (averaging over frames removes the temporal noise of §3.3, leaving the structure), the
//! residual (measured − plane) is profiled by radius from the principal point, and a radial
//! trend (quadratic in the radius) plus one sinusoidal ring term is fitted to the profile by
//! weighted least squares, scanning the ring period. The ring amplitude is the sinusoid's
//! amplitude, the period its wavelength in pixels.

use nalgebra::{Matrix3, Matrix5, Vector3, Vector5};

use crate::accuracy::plane_samples;
use crate::frame::{HEIGHT, Intrinsics, PIXELS, Rays, WIDTH};
use crate::plane::{ImagePlane, ImagePlaneFit, fit_image_plane};
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

/// Weighted least-squares fit of `c0 + c1·r + c2·r² + A·cos(2πf·r) + B·sin(2πf·r)` to a
/// profile on a uniform radius grid, for one frequency f (cycles per pixel). The polynomial
/// block of the normal equations is the same for every f and computed once.
struct RingFitter<'a> {
    r: &'a [f64],
    p: &'a [f64],
    w: &'a [f64],
    poly: Matrix3<f64>,
    poly_rhs: Vector3<f64>,
    wpp: f64,
}

#[derive(Debug, Clone, Copy)]
struct RingFit {
    frequency: f64,
    coef: Vector5<f64>,
    rss: f64,
}

impl<'a> RingFitter<'a> {
    fn new(r: &'a [f64], p: &'a [f64], w: &'a [f64]) -> Self {
        let (mut poly, mut poly_rhs, mut wpp) = (Matrix3::zeros(), Vector3::zeros(), 0.0);
        for i in 0..r.len() {
            let v = Vector3::new(1.0, r[i], r[i] * r[i]);
            poly += w[i] * v * v.transpose();
            poly_rhs += w[i] * p[i] * v;
            wpp += w[i] * p[i] * p[i];
        }
        Self {
            r,
            p,
            w,
            poly,
            poly_rhs,
            wpp,
        }
    }

    fn fit(&self, frequency: f64) -> Option<RingFit> {
        let k = 2.0 * std::f64::consts::PI * frequency;
        // cos/sin along the uniform grid by rotation (no trig per bin).
        let step =
            k * (self.r.get(1).copied().unwrap_or(0.0) - self.r.first().copied().unwrap_or(0.0));
        let (rs, rc) = step.sin_cos();
        let (mut s, mut c) = (k * self.r.first().copied().unwrap_or(0.0)).sin_cos();
        // Sums: [w c, w r c, w r² c, w s, w r s, w r² s, w c², w c s, w s², w p c, w p s]
        let mut a = [0.0f64; 11];
        for i in 0..self.r.len() {
            let (w, r, p) = (self.w[i], self.r[i], self.p[i]);
            if w > 0.0 {
                let (wc, ws) = (w * c, w * s);
                a[0] += wc;
                a[1] += wc * r;
                a[2] += wc * r * r;
                a[3] += ws;
                a[4] += ws * r;
                a[5] += ws * r * r;
                a[6] += wc * c;
                a[7] += wc * s;
                a[8] += ws * s;
                a[9] += wc * p;
                a[10] += ws * p;
            }
            let (nc, ns) = (c * rc - s * rs, s * rc + c * rs);
            c = nc;
            s = ns;
        }
        let mut m = Matrix5::zeros();
        m.fixed_view_mut::<3, 3>(0, 0).copy_from(&self.poly);
        for j in 0..3 {
            m[(j, 3)] = a[j];
            m[(3, j)] = a[j];
            m[(j, 4)] = a[3 + j];
            m[(4, j)] = a[3 + j];
        }
        m[(3, 3)] = a[6];
        m[(3, 4)] = a[7];
        m[(4, 3)] = a[7];
        m[(4, 4)] = a[8];
        let rhs = Vector5::new(
            self.poly_rhs[0],
            self.poly_rhs[1],
            self.poly_rhs[2],
            a[9],
            a[10],
        );
        let coef = m.cholesky()?.solve(&rhs);
        Some(RingFit {
            frequency,
            coef,
            rss: (self.wpp - coef.dot(&rhs)).max(0.0),
        })
    }
}

/// Structural noise of a mean frame (`mean_mm`, NaN = no data) seen through `rays`, profiled
/// around the principal point of `intrinsics`: fits the plane robustly, then
/// [`structural_noise_on_plane`]. Also returns the residual map (mm, NaN off the plane).
///
/// # Errors
/// The frame has too few valid pixels for a plane, or the profile is too short for the fit.
pub fn structural_noise(
    mean_mm: &[f32],
    rays: &Rays,
    intrinsics: &Intrinsics,
    params: &StructuralParams,
) -> Result<(StructuralNoise, Vec<f32>)> {
    let tol_m = params.plane_tolerance_mm / 1000.0;
    let ImagePlaneFit { plane, .. } = fit_image_plane(
        &plane_samples(mean_mm, rays, 2),
        tol_m,
        params.ransac_iterations,
        params.seed,
    )?;
    structural_noise_on_plane(mean_mm, rays, intrinsics, &plane, params)
}

/// Structural noise of a mean frame against an already fitted plane.
///
/// # Errors
/// The frame has the wrong size, or the profile is too short for the fit.
pub fn structural_noise_on_plane(
    mean_mm: &[f32],
    rays: &Rays,
    intrinsics: &Intrinsics,
    plane: &ImagePlane,
    params: &StructuralParams,
) -> Result<(StructuralNoise, Vec<f32>)> {
    if mean_mm.len() != PIXELS {
        return Err(Error::WrongLength {
            got: mean_mm.len(),
            expected: PIXELS,
        });
    }
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
        let (du, dv) = (u - intrinsics.cx, v - intrinsics.cy);
        let rad = (du * du + dv * dv).sqrt();
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
    // The fit runs on the full uniform grid (empty bins weigh 0), from the first bin with data.
    let first = cnt.iter().position(|&c| c > 0).unwrap_or(0);
    let last = cnt.iter().rposition(|&c| c > 0).unwrap_or(0);
    let r: Vec<f64> = (first..=last).map(|b| (b as f64 + 0.5) * bin).collect();
    let w: Vec<f64> = (first..=last).map(|b| f64::from(cnt[b])).collect();
    let p: Vec<f64> = (first..=last)
        .map(|b| {
            if cnt[b] > 0 {
                sum[b] / f64::from(cnt[b])
            } else {
                0.0
            }
        })
        .collect();
    let span = r.last().copied().unwrap_or(0.0) - r.first().copied().unwrap_or(0.0);
    let max_period = params
        .max_period_px
        .min(span / 1.5)
        .max(params.min_period_px);
    let fitter = RingFitter::new(&r, &p, &w);
    // Frequency grid fine enough that the phase drifts < 0.1 cycle across the profile, then a
    // golden-section refinement around the best grid point.
    let (f_lo, f_hi) = (1.0 / max_period, 1.0 / params.min_period_px);
    let df = 0.1 / span.max(1.0);
    let mut best: Option<RingFit> = None;
    let mut f = f_lo;
    while f <= f_hi {
        if let Some(fit) = fitter.fit(f)
            && best.is_none_or(|b| fit.rss < b.rss)
        {
            best = Some(fit);
        }
        f += df;
    }
    if let Some(b) = best {
        let (mut a, mut c) = ((b.frequency - df).max(f_lo), (b.frequency + df).min(f_hi));
        let g = (5f64.sqrt() - 1.0) / 2.0;
        let rss = |f: f64| fitter.fit(f).map_or(f64::INFINITY, |x| x.rss);
        for _ in 0..40 {
            let (x1, x2) = (c - g * (c - a), a + g * (c - a));
            if rss(x1) < rss(x2) {
                c = x2;
            } else {
                a = x1;
            }
        }
        if let Some(fit) = fitter.fit((a + c) / 2.0)
            && fit.rss < b.rss
        {
            best = Some(fit);
        }
    }
    let Some(fit) = best else {
        return Err(Error::NoPlane {
            what: "ring fit of the structural residual".into(),
            detail: "the profile's normal equations are singular".into(),
        });
    };
    let c = &fit.coef;
    let r_max = r.last().copied().unwrap_or(0.0);
    let wsum: f64 = w.iter().sum::<f64>().max(1.0);
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
        ring_period_px: 1.0 / fit.frequency,
        centre_minus_edge_mm: -(c[1] * r_max + c[2] * r_max * r_max),
        profile_fit_rms_mm: (fit.rss / wsum).sqrt(),
        profile,
    };
    Ok((report, residual))
}
