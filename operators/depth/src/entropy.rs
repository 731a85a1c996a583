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

use crate::accuracy::PixelStats;
use crate::frame::{DepthFrame, PIXELS};
use crate::stats::{Summary, SummaryAcc};

/// Streaming eq. 3.3 over windows of `window` frames.
#[derive(Debug, Clone)]
pub struct EntropyAccumulator {
    window: usize,
    /// Raw frames of the current window, frame-major.
    buffer: Vec<u16>,
    buffered: usize,
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

impl EntropyAccumulator {
    /// A new accumulator; `window` is clamped to at least 2 frames.
    #[must_use]
    pub fn new(window: usize) -> Self {
        let window = window.max(2);
        Self {
            window,
            buffer: Vec::new(),
            buffered: 0,
            sum_bits: vec![0.0; PIXELS],
            windows: vec![0; PIXELS],
            finished_windows: 0,
        }
    }

    /// Frames per window.
    #[must_use]
    pub fn window(&self) -> usize {
        self.window
    }

    /// Adds one frame; a full window is evaluated at once.
    pub fn push(&mut self, frame: &DepthFrame) {
        if self.buffer.len() < self.window * PIXELS {
            self.buffer.resize(self.window * PIXELS, 0);
        }
        self.buffer[self.buffered * PIXELS..(self.buffered + 1) * PIXELS]
            .copy_from_slice(frame.as_mm());
        self.buffered += 1;
        if self.buffered == self.window {
            let buffer = std::mem::take(&mut self.buffer);
            self.push_window(&buffer[..self.window * PIXELS]);
            self.buffer = buffer;
            self.buffered = 0;
        }
    }

    /// Adds one complete window of raw frames (frame-major, a multiple of 512×424 values).
    pub fn push_window(&mut self, frames: &[u16]) {
        self.push_window_with_stats(frames, None);
    }

    /// Like [`push_window`](Self::push_window), also folding the frames into `stats` in the
    /// same pass.
    pub fn push_window_with_stats(&mut self, frames: &[u16], stats: Option<&mut PixelStats>) {
        if frames.len() < 2 * PIXELS {
            if let Some(st) = stats {
                st.push_block(frames);
            }
            return;
        }
        let map = window_pass(frames, stats);
        for ((sum, count), h) in self.sum_bits.iter_mut().zip(&mut self.windows).zip(map) {
            if let Some(h) = h {
                *sum += h;
                *count = count.saturating_add(1);
            }
        }
        self.finished_windows += 1;
    }

    /// Forgets every frame (keeps the allocations).
    pub fn clear(&mut self) {
        self.buffered = 0;
        self.sum_bits.fill(0.0);
        self.windows.fill(0);
        self.finished_windows = 0;
    }

    /// Per-pixel entropy in bits (`None` where no valid pair was seen) and its summary.
    #[must_use]
    pub fn finish(&self) -> (EntropyReport, Vec<Option<f32>>) {
        self.finish_with(&self.buffer[..self.buffered * PIXELS])
    }

    /// Like [`finish`](Self::finish) with `partial` (frame-major raw frames) as the trailing
    /// partial window, used when no full window exists.
    #[must_use]
    pub fn finish_with(&self, partial: &[u16]) -> (EntropyReport, Vec<Option<f32>>) {
        let (map, windows) = if self.finished_windows > 0 {
            let map = self
                .sum_bits
                .iter()
                .zip(&self.windows)
                .map(|(&s, &n)| (n > 0).then(|| s / f32::from(n)))
                .collect();
            (map, self.finished_windows)
        } else if partial.len() >= 2 * PIXELS {
            (window_entropy(partial), 1)
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

/// Pixels per block: the block's rows of every frame are copied next to each other first, so
/// the per-pixel loop reads from L1 (frames are 434 176 bytes apart, a multiple of 4 KiB, and
/// would otherwise all fall into the same cache set).
const BLOCK: usize = 64;

/// Eq. 3.3 for every pixel over raw frames (frame-major, n = len / 512·424 frames).
fn window_entropy(frames: &[u16]) -> Vec<Option<f32>> {
    window_pass(frames, None)
}

/// One pass over a window of raw frames: eq. 3.3 per pixel and, when `stats` is given, the
/// per-pixel moments of §3.1 folded into it (both need every sample of the pixel, so one pass
/// reads the window once).
pub(crate) fn window_pass(frames: &[u16], stats: Option<&mut PixelStats>) -> Vec<Option<f32>> {
    window_pass_impl(frames, stats, true)
}

/// Largest spread of differences (max − min) within one pixel for the vector path.
const VECTOR_RANGE: i16 = 24;

/// Scratch buffers of [`block_entropy`].
#[derive(Default)]
struct BlockScratch {
    diffs: Vec<i16>,
    valid: Vec<i16>,
}

/// Eq. 3.3 for the 64 pixels of a block at once: differences as i16 lanes, and for each
/// difference value j in the block's (narrow) range the count c_j of every lane, so the work
/// is element-wise over lanes and vectorises. Returns false (nothing written) when a pixel's
/// differences span more than [`VECTOR_RANGE`] values; the caller then goes pixel by pixel.
fn block_entropy(
    block: &[u16],
    n: usize,
    scratch: &mut BlockScratch,
    out: &mut [Option<f32>],
) -> bool {
    let pairs = n - 1;
    scratch.diffs.resize(pairs * BLOCK, 0);
    scratch.valid.resize(pairs * BLOCK, 0);
    let (mut lo, mut hi) = ([i16::MAX; BLOCK], [i16::MIN; BLOCK]);
    let mut m = [0i16; BLOCK];
    for p in 0..pairs {
        let prev = &block[p * BLOCK..(p + 1) * BLOCK];
        let row = &block[(p + 1) * BLOCK..(p + 2) * BLOCK];
        let diffs = &mut scratch.diffs[p * BLOCK..(p + 1) * BLOCK];
        let valid = &mut scratch.valid[p * BLOCK..(p + 1) * BLOCK];
        for k in 0..BLOCK {
            let ok = row[k] != 0 && prev[k] != 0;
            // Wrapping i16 difference: exact for |difference| < 32 768 mm; larger ones make
            // the range test below fail and the block goes the exact scalar way.
            let diff = row[k].wrapping_sub(prev[k]) as i16;
            let far = (i32::from(row[k]) - i32::from(prev[k])).abs() >= 32_768;
            diffs[k] = diff;
            valid[k] = i16::from(ok);
            lo[k] = lo[k].min(if ok { diff } else { i16::MAX });
            hi[k] = hi[k].max(if ok && !far {
                diff
            } else if far {
                i16::MAX
            } else {
                i16::MIN
            });
            m[k] += i16::from(ok);
        }
    }
    // Shift every lane to start at 0 so the value loop runs over the widest lane's range,
    // not the whole block's.
    let mut widest = -1i32;
    for k in 0..BLOCK {
        if m[k] > 0 {
            widest = widest.max(i32::from(hi[k]) - i32::from(lo[k]));
        }
    }
    if widest < 0 {
        // No valid pair anywhere in the block.
        return true;
    }
    if widest >= i32::from(VECTOR_RANGE) {
        return false;
    }
    // Shifted values are 0..=widest; pairs without data become −1 and never match.
    for p in 0..pairs {
        let diffs = &mut scratch.diffs[p * BLOCK..(p + 1) * BLOCK];
        let valid = &scratch.valid[p * BLOCK..(p + 1) * BLOCK];
        for k in 0..BLOCK {
            diffs[k] = if valid[k] != 0 {
                diffs[k].wrapping_sub(lo[k])
            } else {
                -1
            };
        }
    }
    let log2: [f32; 257] = std::array::from_fn(|c| if c == 0 { 0.0 } else { (c as f32).log2() });
    let mut s = [0f32; BLOCK];
    for j in 0..=widest as i16 {
        let mut c = [0i16; BLOCK];
        for p in 0..pairs {
            let diffs = &scratch.diffs[p * BLOCK..(p + 1) * BLOCK];
            for k in 0..BLOCK {
                c[k] += i16::from(diffs[k] == j);
            }
        }
        for k in 0..BLOCK {
            let ck = usize::from(c[k].clamp(0, 256) as u16);
            s[k] += ck as f32 * log2[ck];
        }
    }
    for (k, slot) in out.iter_mut().enumerate() {
        let mk = usize::from(m[k].clamp(0, 256) as u16);
        if mk > 0 {
            *slot = Some((log2[mk] - s[k] / mk as f32).max(0.0));
        }
    }
    true
}

/// Folds the per-pixel moments of one block (n frames × 64 lanes) into `stats`, lane by lane
/// so the loops vectorise. Min/max live in the sign-flipped i16 domain (SSE2 has signed i16
/// min/max only; 0 maps to the neutral element). Sums are taken of deviations from each lane's
/// maximum, which fit i16 and whose squares fit u32 when the lane's range is small; a block
/// with a wider range is summed exactly in u64 instead.
fn block_moments(block: &[u16], n: usize, start: usize, len: usize, stats: &mut PixelStats) {
    let mut count = [0u32; BLOCK];
    let mut min = [i16::MAX; BLOCK];
    let mut max = [i16::MIN; BLOCK];
    for f in 0..n {
        let row = &block[f * BLOCK..(f + 1) * BLOCK];
        for k in 0..BLOCK {
            let v = row[k];
            count[k] += u32::from(v != 0);
            min[k] = min[k].min((v.wrapping_sub(1) ^ 0x8000) as i16);
            max[k] = max[k].max((v ^ 0x8000) as i16);
        }
    }
    let lo: [u16; BLOCK] = std::array::from_fn(|k| ((min[k] as u16) ^ 0x8000).wrapping_add(1));
    let hi: [u16; BLOCK] = std::array::from_fn(|k| (max[k] as u16) ^ 0x8000);
    // |deviation| ≤ limit keeps n·deviation² within u32 and the deviation within i16.
    let limit = ((f64::from(u32::MAX) / n.max(1) as f64).sqrt() as u32).min(32_767);
    let narrow = (0..BLOCK).all(|k| count[k] == 0 || u32::from(hi[k] - lo[k]) <= limit);
    let mut sum = [0u64; BLOCK];
    let mut sumsq = [0u64; BLOCK];
    if narrow {
        let mut dsum = [0i32; BLOCK];
        let mut dsq = [0u32; BLOCK];
        for f in 0..n {
            let row = &block[f * BLOCK..(f + 1) * BLOCK];
            for k in 0..BLOCK {
                let v = row[k];
                let mask = -i16::from(v != 0);
                let dev = (v.wrapping_sub(hi[k]) as i16) & mask;
                let d = i32::from(dev);
                dsum[k] += d;
                dsq[k] += (d * d) as u32;
            }
        }
        for k in 0..BLOCK {
            let (c, r) = (i64::from(count[k]), i64::from(hi[k]));
            let ds = i64::from(dsum[k]);
            sum[k] = (c * r + ds) as u64;
            sumsq[k] = (c * r * r + 2 * r * ds + i64::from(dsq[k])) as u64;
        }
    } else {
        for f in 0..n {
            let row = &block[f * BLOCK..(f + 1) * BLOCK];
            for k in 0..BLOCK {
                let w = u32::from(row[k]);
                sum[k] += u64::from(w);
                sumsq[k] += u64::from(w * w);
            }
        }
    }
    for k in 0..len {
        stats.add_moments(start + k, count[k], sum[k], sumsq[k], lo[k], hi[k]);
    }
}

fn window_pass_impl(
    frames: &[u16],
    mut stats: Option<&mut PixelStats>,
    vector: bool,
) -> Vec<Option<f32>> {
    let n = frames.len() / PIXELS;
    let mut scratch = BlockScratch::default();
    // H = log2 m − (1/m)·Σ_j c_j·log2 c_j over the m valid pairs with difference counts c_j.
    let log2: [f32; 256] = std::array::from_fn(|c| if c == 0 { 0.0 } else { (c as f32).log2() });
    let clog2c: [f32; 256] = std::array::from_fn(|c| c as f32 * log2[c]);
    let mut hist = [0u8; 256];
    let mut out = vec![None; PIXELS];
    let mut block = vec![0u16; n * BLOCK];
    let mut d = vec![0i32; n];
    let mut slow = Vec::with_capacity(n);
    for start in (0..PIXELS).step_by(BLOCK) {
        let len = BLOCK.min(PIXELS - start);
        if len < BLOCK {
            block.fill(0);
        }
        for f in 0..n {
            block[f * BLOCK..f * BLOCK + len]
                .copy_from_slice(&frames[f * PIXELS + start..f * PIXELS + start + len]);
        }
        if let Some(st) = stats.as_deref_mut() {
            block_moments(&block, n, start, len, st);
        }
        if vector
            && (2..=256).contains(&n)
            && block_entropy(&block, n, &mut scratch, &mut out[start..start + len])
        {
            continue;
        }
        for k in 0..len {
            let mut m = 0usize;
            let mut small = true;
            let mut prev = 0u16;
            for f in 0..n {
                let a = block[f * BLOCK + k];
                if a != 0 && prev != 0 {
                    let diff = i32::from(a) - i32::from(prev);
                    small &= diff.unsigned_abs() < 128;
                    d[m] = diff;
                    m += 1;
                }
                prev = a;
            }
            if m == 0 {
                continue;
            }
            let h = if small && m < 256 {
                for &x in &d[..m] {
                    hist[usize::from((x + 128) as u8)] += 1;
                }
                let mut s = 0.0f32;
                for &x in &d[..m] {
                    let idx = usize::from((x + 128) as u8);
                    let c = hist[idx];
                    if c != 0 {
                        s += clog2c[usize::from(c)];
                        hist[idx] = 0;
                    }
                }
                // Exactly 0 for a constant pixel (s = m·log2 m).
                (log2[m] - s / m as f32).max(0.0)
            } else {
                slow.clear();
                slow.extend_from_slice(&d[..m]);
                slow.sort_unstable();
                let mut h = 0.0f64;
                for run in slow.chunk_by(|a, b| a == b) {
                    let p = run.len() as f64 / m as f64;
                    h -= p * p.log2();
                }
                h as f32
            };
            out[start + k] = Some(h.max(0.0));
        }
    }
    if let Some(st) = stats {
        st.add_frames(n);
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

    /// The fused window pass folds the same per-pixel moments into the statistics as adding
    /// the frames one by one (zeros, min/max, narrow ranges summed as deviations and wide
    /// ranges up to 60 m summed exactly).
    #[test]
    fn window_pass_moments_match_frame_by_frame() {
        for (frames_n, span) in [(7u32, 9000u32), (30, 60_000)] {
            let frames: Vec<DepthFrame> = (0..frames_n)
                .map(|f| {
                    let z = (0..PIXELS as u32)
                        .map(|i| {
                            let v = (i.wrapping_mul(2_654_435_761) ^ f.wrapping_mul(40_503)) % span;
                            if v % 13 == 0 { 0 } else { (v + 500) as u16 }
                        })
                        .collect();
                    DepthFrame::from_mm(z).unwrap()
                })
                .collect();
            let mut by_frame = PixelStats::new();
            let mut buffer = Vec::new();
            for f in &frames {
                by_frame.push(f);
                buffer.extend_from_slice(f.as_mm());
            }
            let mut fused = PixelStats::new();
            let mut acc = EntropyAccumulator::new(frames_n as usize);
            acc.push_window_with_stats(&buffer, Some(&mut fused));
            assert_eq!(fused.frames(), frames_n as usize);
            assert_eq!(format!("{fused:?}"), format!("{by_frame:?}"), "span {span}");
        }
    }

    /// The vectorised block path gives the same entropies as the pixel-by-pixel path, on
    /// narrow-range noise and on blocks it must hand back (wide differences, zeros).
    #[test]
    fn vector_path_matches_scalar_path() {
        let mut frames = Vec::new();
        for f in 0..30u32 {
            frames.extend((0..PIXELS as u32).map(|i| {
                let h = (i.wrapping_mul(2_654_435_761) ^ f.wrapping_mul(97_531)).rotate_left(7);
                let noise = (h % 9) as u16;
                match i % 1000 {
                    0..=4 => 0,
                    5..=9 => (500 + h % 7000) as u16,
                    _ => 2000 + noise,
                }
            }));
        }
        let fast = window_pass_impl(&frames, None, true);
        let exact = window_pass_impl(&frames, None, false);
        let mut compared = 0;
        for (a, b) in fast.iter().zip(&exact) {
            match (a, b) {
                (Some(a), Some(b)) => {
                    assert!((a - b).abs() < 1e-4, "{a} vs {b}");
                    compared += 1;
                }
                (None, None) => {}
                _ => panic!("{a:?} vs {b:?}"),
            }
        }
        assert!(compared > PIXELS / 2);
    }
}
