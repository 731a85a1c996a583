//! Edge noise (thesis §3.4; results §5.1.4, Fig. 5.5).
//!
//! Around the contour of an object in front of a farther background, a Kinect v2 returns a band
//! of zero-valued ("no data") pixels, 1–2 px wide in the thesis, and sometimes "flying" pixels
//! with depths between object and background. This module finds the object's rim and measures
//! the band between rim and background:
//!
//! * foreground F and background G: with a mask, F is the valid masked pixels and G the valid
//!   unmasked ones; without a mask, F is valid pixels with a surface farther by more than
//!   `jump_mm` within `search_radius_px`, G those with a nearer one;
//! * flying pixels: valid pixels with one 8-neighbour nearer and another farther, each by more
//!   than `jump_mm`; they belong to the band, not to F or G (pixels with both a nearer and a
//!   farther surface only further away lie on a steep slope and are neither F nor G);
//! * rim: F pixels with a 4-neighbour that is not F (no data, flying, or outside the object);
//! * band width at a rim pixel: Euclidean distance to the nearest G pixel, minus one pixel (0
//!   when the background touches the rim); a rim pixel is *affected* when a 4-neighbour has no
//!   data or is flying.
//!
//! Rim pixels with no G pixel within the search radius (background out of range) count as
//! rim but have no width.

use crate::frame::{DepthFrame, HEIGHT, Mask, PIXELS, WIDTH};
use crate::stats::{Summary, SummaryAcc};

/// Settings of [`edge_noise`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EdgeParams {
    /// Depth difference that separates an object from its background, mm.
    pub jump_mm: u16,
    /// Search radius for the background and for depth discontinuities, pixels.
    pub search_radius_px: usize,
}

impl Default for EdgeParams {
    fn default() -> Self {
        Self {
            jump_mm: 100,
            search_radius_px: 6,
        }
    }
}

/// Edge-noise figures of one frame or a merged set of frames.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct EdgeNoise {
    /// Whether an object mask defined the foreground.
    pub used_mask: bool,
    /// Frames evaluated.
    pub frames: usize,
    /// Rim (object boundary) pixels found.
    pub rim_pixels: u64,
    /// Rim pixels with a visible background within the search radius.
    pub rim_pixels_with_background: u64,
    /// Share of rim pixels touching a no-data or flying pixel (the share of boundary affected).
    pub affected_share: f64,
    /// Band width in pixels over rim pixels with background (mean, sd, min, max).
    pub band_width_px: Option<Summary>,
    /// No-data pixels on the band between rim and background.
    pub band_zero_pixels: u64,
    /// Flying pixels found.
    pub flying_pixels: u64,
}

/// Accumulates [`EdgeNoise`] over several frames.
#[derive(Debug, Clone, Default)]
pub struct EdgeAccumulator {
    used_mask: bool,
    frames: usize,
    rim: u64,
    rim_bg: u64,
    affected: u64,
    width: SummaryAcc,
    band_zero: u64,
    flying: u64,
}

impl EdgeAccumulator {
    /// Adds one frame's figures.
    pub fn push(&mut self, part: &EdgeNoise, widths: &SummaryAcc) {
        self.used_mask |= part.used_mask;
        self.frames += part.frames;
        self.rim += part.rim_pixels;
        self.rim_bg += part.rim_pixels_with_background;
        self.affected += (part.affected_share * part.rim_pixels as f64).round() as u64;
        self.band_zero += part.band_zero_pixels;
        self.flying += part.flying_pixels;
        if let Some(s) = widths.summary() {
            let n = s.count as f64;
            self.width.push_moments(
                s.count,
                s.mean * n,
                (s.sd * s.sd + s.mean * s.mean) * n,
                s.min,
                s.max,
            );
        }
    }

    /// The merged figures.
    #[must_use]
    pub fn finish(&self) -> EdgeNoise {
        EdgeNoise {
            used_mask: self.used_mask,
            frames: self.frames,
            rim_pixels: self.rim,
            rim_pixels_with_background: self.rim_bg,
            affected_share: if self.rim == 0 {
                0.0
            } else {
                self.affected as f64 / self.rim as f64
            },
            band_width_px: self.width.summary(),
            band_zero_pixels: self.band_zero,
            flying_pixels: self.flying,
        }
    }
}

/// What each pixel is, for the edge-band image.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EdgeClass {
    /// Nothing special.
    Other,
    /// Object rim pixel.
    Rim,
    /// No-data pixel on the band.
    BandZero,
    /// Flying pixel.
    Flying,
    /// Background pixel nearest to a rim pixel.
    Background,
}

/// Separable window maximum (zeros count as the smallest value) and minimum over valid pixels
/// (zeros count as `u16::MAX`) with radius `r`. Works in the sign-flipped i16 domain, where
/// SSE2's signed min/max vectorise the shifted element-wise passes.
fn window_min_max(z: &[u16], r: usize) -> (Vec<u16>, Vec<u16>) {
    let max_in: Vec<i16> = z.iter().map(|&v| (v ^ 0x8000) as i16).collect();
    let min_in: Vec<i16> = z
        .iter()
        .map(|&v| (v.wrapping_sub(1) ^ 0x8000) as i16)
        .collect();
    let hmax = window_extreme(&max_in, r, i16::max);
    let hmin = window_extreme(&min_in, r, i16::min);
    let wmax = hmax.iter().map(|&x| (x as u16) ^ 0x8000).collect();
    let wmin = hmin
        .iter()
        .map(|&x| {
            if x == i16::MAX {
                u16::MAX
            } else {
                ((x as u16) ^ 0x8000) + 1
            }
        })
        .collect();
    (wmin, wmax)
}

/// Separable (2r+1)² window extreme by shifted element-wise passes over rows, then rows.
fn window_extreme(input: &[i16], r: usize, op: impl Fn(i16, i16) -> i16 + Copy) -> Vec<i16> {
    let mut h = input.to_vec();
    for (dst, src) in h.chunks_exact_mut(WIDTH).zip(input.chunks_exact(WIDTH)) {
        for o in 1..=r.min(WIDTH - 1) {
            for (d, s) in dst[..WIDTH - o].iter_mut().zip(&src[o..]) {
                *d = op(*d, *s);
            }
            for (d, s) in dst[o..].iter_mut().zip(&src[..WIDTH - o]) {
                *d = op(*d, *s);
            }
        }
    }
    let mut v = h.clone();
    for y in 0..HEIGHT {
        let dst = &mut v[y * WIDTH..(y + 1) * WIDTH];
        for yy in y.saturating_sub(r)..=(y + r).min(HEIGHT - 1) {
            if yy != y {
                for (d, s) in dst.iter_mut().zip(&h[yy * WIDTH..(yy + 1) * WIDTH]) {
                    *d = op(*d, *s);
                }
            }
        }
    }
    v
}

const F: u8 = 1;
const G: u8 = 2;
const FLY: u8 = 3;
const ZERO: u8 = 4;
const OTHER: u8 = 0;

/// Edge noise of one frame, with the per-pixel classes for the edge-band image and the
/// band-width accumulator (for merging frames with [`EdgeAccumulator`]).
#[must_use]
pub fn edge_noise(
    frame: &DepthFrame,
    mask: Option<&Mask>,
    params: &EdgeParams,
) -> (EdgeNoise, SummaryAcc, Vec<EdgeClass>) {
    let z = frame.as_mm();
    let r = params.search_radius_px.max(1);
    let jump = u32::from(params.jump_mm);
    let (wmin, wmax) = window_min_max(z, r);
    let (nmin, nmax) = window_min_max(z, 1);
    let mut kind = vec![OTHER; PIXELS];
    let mut flying = 0u64;
    for i in 0..PIXELS {
        let v = u32::from(z[i]);
        if v == 0 {
            kind[i] = ZERO;
            continue;
        }
        // Flying: an immediate neighbour nearer and another farther, both by more than the
        // jump. A steep but smooth surface has both within the search radius, not next door.
        if u32::from(nmax[i]) > v + jump && v > u32::from(nmin[i]) + jump {
            flying += 1;
            kind[i] = FLY;
            continue;
        }
        let near = u32::from(wmax[i]) > v + jump;
        let far = v > u32::from(wmin[i]) + jump;
        kind[i] = if let Some(m) = mask {
            if m.as_slice()[i] { F } else { G }
        } else if near && !far {
            F
        } else if far && !near {
            G
        } else {
            OTHER
        };
    }
    let mut classes = vec![EdgeClass::Other; PIXELS];
    for i in 0..PIXELS {
        classes[i] = match kind[i] {
            FLY => EdgeClass::Flying,
            _ => EdgeClass::Other,
        };
    }
    let (mut rim, mut rim_bg, mut affected) = (0u64, 0u64, 0u64);
    let mut widths = SummaryAcc::default();
    let mut band_zero = 0u64;
    let ri = r as isize;
    for y in 1..HEIGHT - 1 {
        for x in 1..WIDTH - 1 {
            let i = y * WIDTH + x;
            if kind[i] != F {
                continue;
            }
            let nbrs = [i - 1, i + 1, i - WIDTH, i + WIDTH];
            let is_rim = if mask.is_some() {
                nbrs.iter().any(|&j| kind[j] != F)
            } else {
                nbrs.iter().any(|&j| matches!(kind[j], G | FLY | ZERO))
            };
            if !is_rim {
                continue;
            }
            rim += 1;
            classes[i] = EdgeClass::Rim;
            if nbrs.iter().any(|&j| matches!(kind[j], FLY | ZERO)) {
                affected += 1;
            }
            // Nearest background pixel within the search radius.
            let mut best: Option<(isize, isize, isize)> = None;
            for dy in -ri..=ri {
                let yy = y as isize + dy;
                if yy < 0 || yy >= HEIGHT as isize {
                    continue;
                }
                for dx in -ri..=ri {
                    let xx = x as isize + dx;
                    if xx < 0 || xx >= WIDTH as isize {
                        continue;
                    }
                    let d2 = dx * dx + dy * dy;
                    if d2 > ri * ri || best.is_some_and(|b| b.0 <= d2) {
                        continue;
                    }
                    if kind[yy as usize * WIDTH + xx as usize] == G {
                        best = Some((d2, dx, dy));
                    }
                }
            }
            let Some((d2, dx, dy)) = best else { continue };
            rim_bg += 1;
            widths.push(((d2 as f64).sqrt() - 1.0).max(0.0));
            let gx = (x as isize + dx) as usize;
            let gy = (y as isize + dy) as usize;
            classes[gy * WIDTH + gx] = EdgeClass::Background;
            // Mark the band pixels on the segment from the rim to the background.
            let steps = dx.abs().max(dy.abs());
            for s in 1..steps {
                let px = x as f64 + dx as f64 * s as f64 / steps as f64;
                let py = y as f64 + dy as f64 * s as f64 / steps as f64;
                let j = py.round() as usize * WIDTH + px.round() as usize;
                if kind[j] == ZERO && classes[j] != EdgeClass::BandZero {
                    classes[j] = EdgeClass::BandZero;
                    band_zero += 1;
                }
            }
        }
    }
    let report = EdgeNoise {
        used_mask: mask.is_some(),
        frames: 1,
        rim_pixels: rim,
        rim_pixels_with_background: rim_bg,
        affected_share: if rim == 0 {
            0.0
        } else {
            affected as f64 / rim as f64
        },
        band_width_px: widths.summary(),
        band_zero_pixels: band_zero,
        flying_pixels: flying,
    };
    (report, widths, classes)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A square at 1 m on a wall at 2 m with a 2-px zero band on its left and right sides
    /// only: width 2 px there, 0 on top and bottom, half the rim affected.
    #[test]
    fn square_with_band_on_two_sides() {
        let mut z = vec![2000u16; PIXELS];
        for y in 100..200 {
            for x in 100..200 {
                z[y * WIDTH + x] = 1000;
            }
            for x in [100, 101, 198, 199] {
                z[y * WIDTH + x] = 0;
            }
        }
        let frame = DepthFrame::from_mm(z).unwrap();
        for mask in [None, Some(())] {
            let m = mask.map(|()| {
                let inside = (0..PIXELS)
                    .map(|i| (100..200).contains(&(i % WIDTH)) && (100..200).contains(&(i / WIDTH)))
                    .collect();
                Mask::from_bools(inside).unwrap()
            });
            let (r, _, classes) = edge_noise(&frame, m.as_ref(), &EdgeParams::default());
            // Rim: columns 102 and 197 (rows 100..200) plus rows 100 and 199 (columns 103..197).
            assert_eq!(r.rim_pixels, 2 * 100 + 2 * 94, "mask {:?}", m.is_some());
            assert!((r.affected_share - 200.0 / 388.0).abs() < 1e-9);
            let w = r.band_width_px.unwrap();
            assert_eq!(w.max, 2.0);
            assert_eq!(w.min, 0.0);
            // 400 zeros; the few in the corner rows lie beside rims whose nearest background
            // is straight above or below, so they are not on any rim-to-background segment.
            assert!(
                (370..=400).contains(&r.band_zero_pixels),
                "{}",
                r.band_zero_pixels
            );
            assert_eq!(r.flying_pixels, 0);
            assert_eq!(classes[150 * WIDTH + 100], EdgeClass::BandZero);
        }
    }

    /// The separable window extremes equal a brute-force search (zeros ignored, no valid
    /// neighbour → u16::MAX for the minimum), including depths above 32 767 mm.
    #[test]
    fn window_min_max_matches_brute_force() {
        let z: Vec<u16> = (0..PIXELS as u32)
            .map(|i| {
                let h = i.wrapping_mul(2_654_435_761).rotate_left(11);
                if h % 5 == 0 { 0 } else { (h % 65_535) as u16 }
            })
            .collect();
        let mut z = z;
        for x in 0..12 {
            for y in 0..12 {
                z[y * WIDTH + x] = 0; // a corner without data
            }
        }
        let r = 2;
        let (wmin, wmax) = window_min_max(&z, r);
        for &(x, y) in &[
            (0usize, 0usize),
            (0, 0),
            (1, 1),
            (40, 7),
            (511, 423),
            (300, 200),
            (13, 0),
            (255, 2),
        ] {
            let (mut lo, mut hi) = (u16::MAX, 0);
            for yy in y.saturating_sub(r)..=(y + r).min(HEIGHT - 1) {
                for xx in x.saturating_sub(r)..=(x + r).min(WIDTH - 1) {
                    let v = z[yy * WIDTH + xx];
                    hi = hi.max(v);
                    if v != 0 {
                        lo = lo.min(v);
                    }
                }
            }
            assert_eq!(
                (wmin[y * WIDTH + x], wmax[y * WIDTH + x]),
                (lo, hi),
                "({x}, {y})"
            );
        }
    }
}
