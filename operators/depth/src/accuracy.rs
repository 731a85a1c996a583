//! Accuracy distribution (thesis §3.1, eq. 3.1; results §5.1.1, Fig. 5.1–5.2).
//!
//! Depth accuracy is the true distance minus the mean measured depth of a planar target. Per
//! pixel, the mean over a sequence is compared with the target's true depth along that pixel's
//! ray; the absolute difference puts the pixel in the thesis' green (< 2 mm), yellow (2–4 mm) or
//! red (> 4 mm) zone, and the zone shares are reported inside the sensor's elliptical 70°×60°
//! cone (Fig. 5.2). The target is either given (a fronto-parallel plane at a laser-measured
//! distance, as in the thesis) or fitted robustly to the mean frame.

use crate::frame::{DepthFrame, HEIGHT, PIXELS, Rays, WIDTH, in_elliptical_cone};
use crate::plane::{ImagePlane, fit_image_plane};
use crate::stats::{Summary, SummaryAcc};
use crate::{Error, Result};

/// Per-pixel running moments over a sequence of frames (valid samples only).
#[derive(Debug, Clone)]
pub struct PixelStats {
    count: Vec<u32>,
    sum: Vec<u64>,
    sumsq: Vec<u64>,
    min: Vec<u16>,
    max: Vec<u16>,
    frames: usize,
}

impl Default for PixelStats {
    fn default() -> Self {
        Self::new()
    }
}

impl PixelStats {
    /// Empty accumulator.
    #[must_use]
    pub fn new() -> Self {
        Self {
            count: vec![0; PIXELS],
            sum: vec![0; PIXELS],
            sumsq: vec![0; PIXELS],
            min: vec![u16::MAX; PIXELS],
            max: vec![0; PIXELS],
            frames: 0,
        }
    }

    /// Adds one frame (zeros are skipped).
    pub fn push(&mut self, frame: &DepthFrame) {
        let z = frame.as_mm();
        // Zipped slices (no indexing) so the loop vectorises.
        let lanes = self
            .count
            .iter_mut()
            .zip(self.sum.iter_mut())
            .zip(self.sumsq.iter_mut())
            .zip(self.min.iter_mut().zip(self.max.iter_mut()))
            .zip(z);
        for ((((count, sum), sumsq), (min, max)), &v) in lanes {
            let w = u32::from(v);
            *count += u32::from(v != 0);
            *sum += u64::from(w);
            *sumsq += u64::from(w * w);
            *min = (*min).min(if v == 0 { u16::MAX } else { v });
            *max = (*max).max(v);
        }
        self.frames += 1;
    }

    /// Adds a block of raw frames (frame-major, a multiple of 512×424 values). Faster than
    /// frame-by-frame [`push`](Self::push): each chunk of the per-pixel state stays in cache
    /// while every frame is added to it.
    pub fn push_block(&mut self, frames: &[u16]) {
        const CHUNK: usize = 2048;
        let n = frames.len() / PIXELS;
        for start in (0..PIXELS).step_by(CHUNK) {
            let end = (start + CHUNK).min(PIXELS);
            for f in 0..n {
                let z = &frames[f * PIXELS + start..f * PIXELS + end];
                let lanes = self.count[start..end]
                    .iter_mut()
                    .zip(self.sum[start..end].iter_mut())
                    .zip(self.sumsq[start..end].iter_mut())
                    .zip(
                        self.min[start..end]
                            .iter_mut()
                            .zip(self.max[start..end].iter_mut()),
                    )
                    .zip(z);
                for ((((count, sum), sumsq), (min, max)), &v) in lanes {
                    let w = u32::from(v);
                    *count += u32::from(v != 0);
                    *sum += u64::from(w);
                    *sumsq += u64::from(w * w);
                    *min = (*min).min(if v == 0 { u16::MAX } else { v });
                    *max = (*max).max(v);
                }
            }
        }
        self.frames += n;
    }

    /// Adds one pixel's moments over several frames (the frames are counted by
    /// [`add_frames`](Self::add_frames)).
    pub(crate) fn add_moments(
        &mut self,
        i: usize,
        count: u32,
        sum: u64,
        sumsq: u64,
        min: u16,
        max: u16,
    ) {
        self.count[i] += count;
        self.sum[i] += sum;
        self.sumsq[i] += sumsq;
        self.min[i] = self.min[i].min(min);
        self.max[i] = self.max[i].max(max);
    }

    /// Counts `n` frames added pixel by pixel with [`add_moments`](Self::add_moments).
    pub(crate) fn add_frames(&mut self, n: usize) {
        self.frames += n;
    }

    /// Forgets every frame (keeps the allocations).
    pub fn clear(&mut self) {
        self.count.fill(0);
        self.sum.fill(0);
        self.sumsq.fill(0);
        self.min.fill(u16::MAX);
        self.max.fill(0);
        self.frames = 0;
    }

    /// Frames pushed.
    #[must_use]
    pub fn frames(&self) -> usize {
        self.frames
    }

    /// Valid samples of pixel `i`.
    #[must_use]
    pub fn count(&self, i: usize) -> u32 {
        self.count[i]
    }

    /// Mean depth of pixel `i` in millimetres, `None` without valid samples.
    #[must_use]
    pub fn mean_mm(&self, i: usize) -> Option<f64> {
        (self.count[i] > 0).then(|| self.sum[i] as f64 / f64::from(self.count[i]))
    }

    /// Temporal standard deviation of pixel `i` in millimetres (needs two samples).
    #[must_use]
    pub fn sd_mm(&self, i: usize) -> Option<f64> {
        let n = f64::from(self.count[i]);
        (self.count[i] > 1).then(|| {
            let mean = self.sum[i] as f64 / n;
            (self.sumsq[i] as f64 / n - mean * mean).max(0.0).sqrt()
        })
    }

    /// Mean frame in millimetres, NaN where a pixel never had data.
    #[must_use]
    pub fn mean_frame_mm(&self) -> Vec<f32> {
        (0..PIXELS)
            .map(|i| self.mean_mm(i).map_or(f32::NAN, |m| m as f32))
            .collect()
    }

    /// Share of valid samples over all pixels and frames.
    #[must_use]
    pub fn valid_share(&self) -> f64 {
        if self.frames == 0 {
            return 0.0;
        }
        let total: u64 = self.count.iter().map(|&c| u64::from(c)).sum();
        total as f64 / (self.frames * PIXELS) as f64
    }

    /// Share of frames in which pixel `i` had no data.
    #[must_use]
    pub fn zero_share(&self, i: usize) -> f64 {
        if self.frames == 0 {
            return 0.0;
        }
        1.0 - f64::from(self.count[i]) / self.frames as f64
    }
}

/// Accuracy zone of a pixel (§5.1.1): by the absolute error of its mean depth.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Zone {
    /// Error below the green limit (2 mm).
    Green,
    /// Error between the green and yellow limits (2–4 mm).
    Yellow,
    /// Error above the yellow limit (4 mm).
    Red,
}

/// Settings of [`accuracy`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AccuracyParams {
    /// True distance of a fronto-parallel target, metres; `None` fits a plane to the mean frame.
    pub target_distance_m: Option<f64>,
    /// Pixels whose mean is farther than this from the target are not on the target, mm.
    pub on_target_tolerance_mm: f64,
    /// Upper limit of the green zone, mm (thesis: 2).
    pub green_below_mm: f64,
    /// Upper limit of the yellow zone, mm (thesis: 4).
    pub yellow_below_mm: f64,
    /// Full horizontal angle of the elliptical cone, degrees (thesis: 70).
    pub cone_horizontal_deg: f64,
    /// Full vertical angle of the elliptical cone, degrees (thesis: 60).
    pub cone_vertical_deg: f64,
    /// RANSAC draws when fitting the target plane.
    pub ransac_iterations: usize,
    /// RNG seed of the plane fit.
    pub seed: u64,
}

impl Default for AccuracyParams {
    fn default() -> Self {
        Self {
            target_distance_m: None,
            on_target_tolerance_mm: 30.0,
            green_below_mm: 2.0,
            yellow_below_mm: 4.0,
            cone_horizontal_deg: 70.0,
            cone_vertical_deg: 60.0,
            ransac_iterations: 200,
            seed: 31,
        }
    }
}

impl AccuracyParams {
    /// The zone of an absolute error in millimetres.
    #[must_use]
    pub fn zone(&self, abs_error_mm: f64) -> Zone {
        if abs_error_mm < self.green_below_mm {
            Zone::Green
        } else if abs_error_mm <= self.yellow_below_mm {
            Zone::Yellow
        } else {
            Zone::Red
        }
    }
}

/// Shares of the three zones among a set of pixels.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ZoneShares {
    /// Pixels counted.
    pub pixels: usize,
    /// Share in the green zone, 0..=1.
    pub green: f64,
    /// Share in the yellow zone, 0..=1.
    pub yellow: f64,
    /// Share in the red zone, 0..=1.
    pub red: f64,
}

impl ZoneShares {
    fn from_counts(counts: [usize; 3]) -> Self {
        let n = counts.iter().sum::<usize>();
        let share = |c: usize| if n == 0 { 0.0 } else { c as f64 / n as f64 };
        Self {
            pixels: n,
            green: share(counts[0]),
            yellow: share(counts[1]),
            red: share(counts[2]),
        }
    }
}

/// The accuracy distribution of a sequence (§3.1, §5.1.1).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct AccuracyReport {
    /// `"given_distance"` or `"fitted_plane"`.
    pub target: &'static str,
    /// True depth of the target on the optical axis, metres.
    pub target_distance_m: f64,
    /// Tilt of the target against the optical axis, degrees (0 for a given distance).
    pub target_tilt_deg: f64,
    /// Pixels whose mean lies on the target.
    pub pixels_on_target: usize,
    /// Raw depth values of the target over all frames, mm (the thesis' mean/sd/range, Fig. 5.1).
    pub depth_mm: Option<Summary>,
    /// Eq. 3.1: true distance minus mean measured depth, averaged over the target, mm.
    pub accuracy_mm: f64,
    /// Per-pixel (mean − true depth), mm.
    pub error_mm: Option<Summary>,
    /// Mean over target pixels of the temporal standard deviation, mm (`None` for one frame).
    pub temporal_sd_mm: Option<f64>,
    /// Zone shares of target pixels inside the 70°×60° cone.
    pub zones_in_cone: ZoneShares,
    /// Zone shares of all target pixels.
    pub zones_all: ZoneShares,
}

/// Per-pixel zone map: `None` off target or without data.
#[derive(Debug, Clone)]
pub struct AccuracyMap {
    /// Zone per pixel, row-major.
    pub zones: Vec<Option<Zone>>,
    /// Whether each pixel lies inside the elliptical cone.
    pub in_cone: Vec<bool>,
}

/// Depth samples (x, y, z metres) of a mean frame for plane fits, from every `stride`-th
/// pixel along rows and columns; NaN or 0 = no data.
#[must_use]
pub fn plane_samples(mean_mm: &[f32], rays: &Rays, stride: usize) -> Vec<(f64, f64, f64)> {
    let stride = stride.max(1);
    let mut out = Vec::with_capacity(PIXELS / (stride * stride) + 1);
    for v in (0..HEIGHT).step_by(stride) {
        for u in (0..WIDTH).step_by(stride) {
            let i = v * WIDTH + u;
            let m = mean_mm[i];
            if m.is_finite() && m > 0.0 {
                let (x, y) = rays.at(i);
                out.push((x, y, f64::from(m) / 1000.0));
            }
        }
    }
    out
}

/// Which pixels lie inside the elliptical cone of `params`.
#[must_use]
pub fn cone_mask(rays: &Rays, params: &AccuracyParams) -> Vec<bool> {
    rays.as_slice()
        .iter()
        .map(|&(x, y)| {
            in_elliptical_cone(x, y, params.cone_horizontal_deg, params.cone_vertical_deg)
        })
        .collect()
}

/// The target plane: fronto-parallel at the given distance, or fitted robustly to the mean
/// frame. Returns its kind (`"given_distance"` or `"fitted_plane"`) and the plane.
///
/// # Errors
/// A non-positive distance, or no plane could be fitted.
pub fn target_plane(
    mean_mm: &[f32],
    rays: &Rays,
    params: &AccuracyParams,
) -> Result<(&'static str, ImagePlane)> {
    match params.target_distance_m {
        Some(d) if d > 0.0 && d.is_finite() => Ok((
            "given_distance",
            ImagePlane {
                a: 0.0,
                b: 0.0,
                c: 1.0 / d,
            },
        )),
        Some(d) => Err(Error::BadParameter {
            name: "target_distance_m",
            value: d,
            expected: "a positive distance in metres",
        }),
        None => {
            let fit = fit_image_plane(
                &plane_samples(mean_mm, rays, 2),
                params.on_target_tolerance_mm / 1000.0,
                params.ransac_iterations,
                params.seed,
            )?;
            Ok(("fitted_plane", fit.plane))
        }
    }
}

/// Computes the accuracy distribution from the per-pixel moments of a sequence (finds the
/// target and the cone itself; see [`accuracy_against`] to reuse them).
///
/// # Errors
/// No frame was pushed, or no target plane could be fitted.
pub fn accuracy(
    stats: &PixelStats,
    rays: &Rays,
    params: &AccuracyParams,
) -> Result<(AccuracyReport, AccuracyMap)> {
    if stats.frames() == 0 {
        return Err(Error::NoFrames);
    }
    let target = target_plane(&stats.mean_frame_mm(), rays, params)?;
    accuracy_against(stats, rays, &cone_mask(rays, params), target, params)
}

/// The accuracy distribution against a known target plane with a precomputed cone mask.
///
/// # Errors
/// No frame was pushed, or the cone mask has the wrong size.
pub fn accuracy_against(
    stats: &PixelStats,
    rays: &Rays,
    in_cone: &[bool],
    (target, plane): (&'static str, ImagePlane),
    params: &AccuracyParams,
) -> Result<(AccuracyReport, AccuracyMap)> {
    if stats.frames() == 0 {
        return Err(Error::NoFrames);
    }
    if in_cone.len() != PIXELS {
        return Err(Error::WrongLength {
            got: in_cone.len(),
            expected: PIXELS,
        });
    }
    let mut zones = vec![None; PIXELS];
    let (mut depth, mut error) = (SummaryAcc::default(), SummaryAcc::default());
    let (mut bias_sum, mut bias_n) = (0.0, 0u64);
    let (mut sd_sum, mut sd_n) = (0.0, 0usize);
    let (mut cone_counts, mut all_counts) = ([0usize; 3], [0usize; 3]);
    let mut on_target = 0;
    for i in 0..PIXELS {
        let (x, y) = rays.at(i);
        let (Some(mean), Some(truth_m)) = (stats.mean_mm(i), plane.depth_m(x, y)) else {
            continue;
        };
        let truth = truth_m * 1000.0;
        let err = mean - truth;
        if err.abs() > params.on_target_tolerance_mm {
            continue;
        }
        on_target += 1;
        let n = u64::from(stats.count[i]);
        depth.push_moments(
            n,
            stats.sum[i] as f64,
            stats.sumsq[i] as f64,
            f64::from(stats.min[i]),
            f64::from(stats.max[i]),
        );
        bias_sum += (truth - mean) * n as f64;
        bias_n += n;
        error.push(err);
        if let Some(sd) = stats.sd_mm(i) {
            sd_sum += sd;
            sd_n += 1;
        }
        let zone = params.zone(err.abs());
        zones[i] = Some(zone);
        let k = zone as usize;
        all_counts[k] += 1;
        if in_cone[i] {
            cone_counts[k] += 1;
        }
    }
    let report = AccuracyReport {
        target,
        target_distance_m: 1.0 / plane.c,
        target_tilt_deg: plane.tilt_deg(),
        pixels_on_target: on_target,
        depth_mm: depth.summary(),
        accuracy_mm: if bias_n > 0 {
            bias_sum / bias_n as f64
        } else {
            f64::NAN
        },
        error_mm: error.summary(),
        temporal_sd_mm: (sd_n > 0).then(|| sd_sum / sd_n as f64),
        zones_in_cone: ZoneShares::from_counts(cone_counts),
        zones_all: ZoneShares::from_counts(all_counts),
    };
    Ok((
        report,
        AccuracyMap {
            zones,
            in_cone: in_cone.to_vec(),
        },
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::Intrinsics;

    /// A frame at exactly the given distance is all green with zero accuracy error; a +3 mm
    /// offset turns it yellow and eq. 3.1 reports −3 mm.
    #[test]
    fn constant_offset_moves_zone() {
        let rays = Intrinsics::default().rays();
        for (value, zone_yellow, acc) in [(2000u16, 0.0, 0.0), (2003, 1.0, -3.0)] {
            let mut stats = PixelStats::new();
            stats.push(&DepthFrame::from_mm(vec![value; PIXELS]).unwrap());
            let params = AccuracyParams {
                target_distance_m: Some(2.0),
                ..AccuracyParams::default()
            };
            let (r, _) = accuracy(&stats, &rays, &params).unwrap();
            assert_eq!(r.pixels_on_target, PIXELS);
            assert!((r.zones_in_cone.yellow - zone_yellow).abs() < 1e-12);
            assert!((r.accuracy_mm - acc).abs() < 1e-9);
            assert!(r.zones_in_cone.pixels < PIXELS && r.zones_in_cone.pixels > PIXELS / 2);
        }
    }
}
