//! Depth entropy (thesis §3.3, eq. 3.3; results §5.1.3, Fig. 5.4).
//!
//! For each pixel, the differences between its depth in consecutive frames are collected over a
//! window of frames (30 in the thesis: 29 differences), and their Shannon entropy in bits is
//!
//! ```text
//!   H(i) = − Σ_j p(i)_j · log2 p(i)_j        (eq. 3.3)
//! ```
//!
//! with p(i)_j the relative frequency of difference j. A static pixel has H = 0; the more the
//! depth flickers, the larger H. Pairs where either frame has no data are skipped. Long
//! sequences are cut into consecutive windows; the per-pixel entropy is averaged over windows,
//! which keeps memory bounded for a live stream.

use crate::frame::{DepthFrame, PIXELS};
use crate::stats::{Summary, SummaryAcc};

/// Streaming eq. 3.3 over windows of `window` frames.
#[derive(Debug, Clone)]
pub struct EntropyAccumulator {
    window: usize,
    prev: Option<Vec<u16>>,
    /// Differences of the current window, frame-major; `i16::MIN` marks a pair without data.
    diffs: Vec<i16>,
    diff_frames: usize,
    /// Σ entropy over finished windows and the number of windows per pixel.
    sum_bits: Vec<f32>,
    windows: Vec<u16>,
    finished_windows: usize,
}

/// Summary of the entropy map.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct EntropyReport {
    /// Frames per window (the thesis uses 30).
    pub window_frames: usize,
    /// Windows evaluated (a trailing partial window counts only when no full window exists).
    pub windows: usize,
    /// Entropy over pixels with at least one valid frame pair, bits.
    pub bits: Option<Summary>,
}

const NO_PAIR: i16 = i16::MIN;

impl EntropyAccumulator {
    /// A new accumulator; `window` is clamped to at least 2 frames.
    #[must_use]
    pub fn new(window: usize) -> Self {
        let window = window.max(2);
        Self {
            window,
            prev: None,
            diffs: Vec::with_capacity((window - 1) * PIXELS),
            diff_frames: 0,
            sum_bits: vec![0.0; PIXELS],
            windows: vec![0; PIXELS],
            finished_windows: 0,
        }
    }

    /// Adds one frame.
    pub fn push(&mut self, frame: &DepthFrame) {
        let z = frame.as_mm();
        if let Some(prev) = &self.prev {
            self.diffs.extend(z.iter().zip(prev).map(|(&a, &b)| {
                if a == 0 || b == 0 {
                    NO_PAIR
                } else {
                    // Depths are ≤ 65535 mm; clamp the (absurd) larger jumps into i16.
                    (i32::from(a) - i32::from(b)).clamp(-32767, 32767) as i16
                }
            }));
            self.diff_frames += 1;
        }
        if self.diff_frames + 1 == self.window {
            let map = window_entropy(&self.diffs, self.diff_frames);
            for (i, h) in map.into_iter().enumerate() {
                if let Some(h) = h {
                    self.sum_bits[i] += h;
                    self.windows[i] = self.windows[i].saturating_add(1);
                }
            }
            self.finished_windows += 1;
            self.diffs.clear();
            self.diff_frames = 0;
            self.prev = None;
        } else {
            match &mut self.prev {
                Some(p) => p.copy_from_slice(z),
                None => self.prev = Some(z.to_vec()),
            }
        }
    }

    /// Per-pixel entropy in bits (`None` where no valid pair was seen) and its summary.
    #[must_use]
    pub fn finish(&self) -> (EntropyReport, Vec<Option<f32>>) {
        let (map, windows) = if self.finished_windows > 0 {
            let map = self
                .sum_bits
                .iter()
                .zip(&self.windows)
                .map(|(&s, &n)| (n > 0).then(|| s / f32::from(n)))
                .collect();
            (map, self.finished_windows)
        } else if self.diff_frames > 0 {
            (window_entropy(&self.diffs, self.diff_frames), 1)
        } else {
            (vec![None; PIXELS], 0)
        };
        let mut acc = SummaryAcc::default();
        for h in map.iter().flatten() {
            acc.push(f64::from(*h));
        }
        let report = EntropyReport {
            window_frames: self.window,
            windows,
            bits: acc.summary(),
        };
        (report, map)
    }
}

/// Eq. 3.3 for every pixel of one window of `frames` difference frames (frame-major).
fn window_entropy(diffs: &[i16], frames: usize) -> Vec<Option<f32>> {
    // log2 of counts up to 255 by table; H = (1/n)·Σ_occurrences (log2 n − log2 c(j)).
    let log2: Vec<f32> = (0..256)
        .map(|c| if c == 0 { 0.0 } else { (c as f32).log2() })
        .collect();
    let mut hist = [0u8; 256];
    let mut out = vec![None; PIXELS];
    let mut slow = Vec::new();
    let mut column = Vec::with_capacity(frames);
    for (i, slot) in out.iter_mut().enumerate() {
        column.clear();
        column.extend(
            (0..frames)
                .map(|f| diffs[f * PIXELS + i])
                .filter(|&d| d != NO_PAIR),
        );
        let n = column.len();
        if n == 0 {
            continue;
        }
        let small = n < 256 && column.iter().all(|&d| (-128..=127).contains(&d));
        let h = if small {
            for &d in &column {
                hist[(d + 128) as usize] += 1;
            }
            // Σ (log2 n − log2 c) is exactly 0 for a constant pixel.
            let log2_n = (n as f32).log2();
            let mut s = 0.0f32;
            for &d in &column {
                s += log2_n - log2[usize::from(hist[(d + 128) as usize])];
            }
            for &d in &column {
                hist[(d + 128) as usize] = 0;
            }
            s / n as f32
        } else {
            slow.clear();
            slow.extend_from_slice(&column);
            slow.sort_unstable();
            let mut h = 0.0f64;
            for run in slow.chunk_by(|a, b| a == b) {
                let p = run.len() as f64 / n as f64;
                h -= p * p.log2();
            }
            h as f32
        };
        *slot = Some(h.max(0.0));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(v: u16) -> DepthFrame {
        DepthFrame::from_mm(vec![v; PIXELS]).unwrap()
    }

    /// A static pixel has zero entropy; alternating +1/−1 differences give exactly 1 bit; four
    /// equally frequent differences give 2 bits (eq. 3.3 by hand).
    #[test]
    fn entropy_of_known_difference_patterns() {
        let mut acc = EntropyAccumulator::new(30);
        for _ in 0..30 {
            acc.push(&frame(1500));
        }
        let (r, _) = acc.finish();
        assert_eq!(r.windows, 1);
        assert_eq!(r.bits.unwrap().max, 0.0);

        // 9 frames → 8 differences: +1, −1 alternating → p = ½, ½.
        let mut acc = EntropyAccumulator::new(9);
        for k in 0..9 {
            acc.push(&frame(1500 + (k % 2)));
        }
        let (r, map) = acc.finish();
        assert!((r.bits.unwrap().mean - 1.0).abs() < 1e-6);
        assert!(map.iter().all(|h| h.is_some()));

        // differences +1, +2, −3, +300 (slow path) repeated twice → four values, 2 bits.
        let values = [1000u16, 1001, 1003, 1000, 1300, 1301, 1303, 1300, 1600];
        let mut acc = EntropyAccumulator::new(values.len());
        for v in values {
            acc.push(&frame(v));
        }
        let (r, _) = acc.finish();
        assert!((r.bits.unwrap().mean - 2.0).abs() < 1e-6, "{:?}", r.bits);
    }

    /// Pairs touching a zero are skipped; a pixel that is always zero has no entropy.
    #[test]
    fn zero_pairs_are_skipped() {
        let mut acc = EntropyAccumulator::new(4);
        let mut f = frame(1000);
        f.as_mm_mut()[7] = 0;
        acc.push(&f);
        acc.push(&f);
        acc.push(&f);
        acc.push(&f);
        let (r, map) = acc.finish();
        assert!(map[7].is_none());
        assert_eq!(r.bits.unwrap().count, (PIXELS - 1) as u64);
    }
}
