//! Depth resolution (thesis §3.2, eq. 3.2; results §5.1.2, Fig. 5.3).
//!
//! On a tilted plane neighbouring pixels see slightly different depths. The depth resolution of
//! eq. 3.2 is the smallest non-zero step |M_d[i+1] − M_d[i]| between adjacent depth values; §5.1.2
//! adds the mean, standard deviation and maximum of all adjacent steps. Steps are taken between
//! horizontal and vertical neighbours that both have data and differ by at most `max_step_mm`
//! (larger steps are object edges, not resolution), and are binned by the pair's mean distance
//! so one tilted plane spanning 1–4 m yields the whole curve of Fig. 5.3.

use crate::frame::{DepthFrame, HEIGHT, WIDTH};

/// Settings of [`ResolutionAccumulator`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ResolutionParams {
    /// Steps above this are depth edges and ignored, mm.
    pub max_step_mm: u16,
    /// Width of the distance bins, metres.
    pub bin_width_m: f64,
    /// Distance bins cover 0 to this, metres (Kinect v2 range ≤ 4.5 m, Table 3.1).
    pub max_distance_m: f64,
}

impl Default for ResolutionParams {
    fn default() -> Self {
        Self {
            max_step_mm: 100,
            bin_width_m: 0.5,
            max_distance_m: 8.0,
        }
    }
}

/// Step statistics of one distance bin (or of everything).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ResolutionBin {
    /// Lower edge of the distance bin, metres.
    pub from_m: f64,
    /// Upper edge of the distance bin, metres (the last bin also holds farther pairs).
    pub to_m: f64,
    /// Neighbour pairs counted.
    pub pairs: u64,
    /// Eq. 3.2: smallest non-zero step, mm.
    pub min_nonzero_step_mm: Option<u16>,
    /// Smallest non-zero step seen in at least 0.1 % of the pairs (robust to single outliers), mm.
    pub typical_min_step_mm: Option<u16>,
    /// Mean step ("mean resolution", §5.1.2), mm.
    pub mean_step_mm: f64,
    /// Standard deviation of the steps, mm.
    pub sd_step_mm: f64,
    /// Largest step ("max resolution"), mm.
    pub max_step_mm: u16,
}

/// Depth resolution overall and per distance bin.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Resolution {
    /// Frames evaluated.
    pub frames: usize,
    /// All pairs together.
    pub overall: Option<ResolutionBin>,
    /// Non-empty distance bins, nearest first.
    pub by_distance: Vec<ResolutionBin>,
}

/// Histograms of neighbour steps per distance bin, over any number of frames.
#[derive(Debug, Clone)]
pub struct ResolutionAccumulator {
    params: ResolutionParams,
    bins: usize,
    /// counts[bin · (max_step + 1) + step]
    counts: Vec<u64>,
    frames: usize,
}

impl ResolutionAccumulator {
    /// An empty accumulator.
    #[must_use]
    pub fn new(params: ResolutionParams) -> Self {
        let bins = ((params.max_distance_m / params.bin_width_m).ceil() as usize).max(1);
        Self {
            params,
            bins,
            counts: vec![0; bins * (usize::from(params.max_step_mm) + 1)],
            frames: 0,
        }
    }

    /// Adds the neighbour steps of one frame.
    pub fn push(&mut self, frame: &DepthFrame) {
        let z = frame.as_mm();
        let max_step = u32::from(self.params.max_step_mm);
        let stride = max_step as usize + 1;
        // Bin by the sum of the two depths (mm): bin = (a + b) / (2 · bin width in mm).
        let bin_mm2 = (2.0 * self.params.bin_width_m * 1000.0).max(1.0) as u32;
        let last = self.bins - 1;
        let mut add = |a: u16, b: u16| {
            if a == 0 || b == 0 {
                return;
            }
            let step = u32::from(a.abs_diff(b));
            if step > max_step {
                return;
            }
            let bin = ((u32::from(a) + u32::from(b)) / bin_mm2).min(last as u32) as usize;
            self.counts[bin * stride + step as usize] += 1;
        };
        for y in 0..HEIGHT {
            let row = &z[y * WIDTH..(y + 1) * WIDTH];
            for x in 0..WIDTH - 1 {
                add(row[x], row[x + 1]);
            }
            if y + 1 < HEIGHT {
                let next = &z[(y + 1) * WIDTH..(y + 2) * WIDTH];
                for x in 0..WIDTH {
                    add(row[x], next[x]);
                }
            }
        }
        self.frames += 1;
    }

    fn bin_stats(&self, hist: &[u64], from_m: f64, to_m: f64) -> Option<ResolutionBin> {
        let pairs: u64 = hist.iter().sum();
        if pairs == 0 {
            return None;
        }
        let (mut sum, mut sumsq) = (0.0, 0.0);
        for (step, &c) in hist.iter().enumerate() {
            sum += step as f64 * c as f64;
            sumsq += (step * step) as f64 * c as f64;
        }
        let mean = sum / pairs as f64;
        let floor = (pairs / 1000).max(1);
        let to_u16 = |s: usize| u16::try_from(s).ok();
        Some(ResolutionBin {
            from_m,
            to_m,
            pairs,
            min_nonzero_step_mm: hist
                .iter()
                .skip(1)
                .position(|&c| c > 0)
                .and_then(|s| to_u16(s + 1)),
            typical_min_step_mm: hist
                .iter()
                .skip(1)
                .position(|&c| c >= floor)
                .and_then(|s| to_u16(s + 1)),
            mean_step_mm: mean,
            sd_step_mm: (sumsq / pairs as f64 - mean * mean).max(0.0).sqrt(),
            max_step_mm: hist
                .iter()
                .rposition(|&c| c > 0)
                .and_then(to_u16)
                .unwrap_or(0),
        })
    }

    /// The statistics so far.
    #[must_use]
    pub fn finish(&self) -> Resolution {
        let stride = usize::from(self.params.max_step_mm) + 1;
        let mut all = vec![0u64; stride];
        let mut by_distance = Vec::new();
        for b in 0..self.bins {
            let hist = &self.counts[b * stride..(b + 1) * stride];
            for (a, h) in all.iter_mut().zip(hist) {
                *a += h;
            }
            let from = b as f64 * self.params.bin_width_m;
            let to = from + self.params.bin_width_m;
            if let Some(s) = self.bin_stats(hist, from, to) {
                by_distance.push(s);
            }
        }
        Resolution {
            frames: self.frames,
            overall: self.bin_stats(&all, 0.0, self.bins as f64 * self.params.bin_width_m),
            by_distance,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::PIXELS;

    /// A ramp rising 3 mm per column has horizontal steps of 3 mm and vertical steps of 0:
    /// eq. 3.2 gives 3 mm, the mean is 1.5 mm, the maximum 3 mm; a 500 mm edge is ignored.
    #[test]
    fn ramp_steps() {
        let mut z: Vec<u16> = (0..PIXELS).map(|i| 1000 + 3 * (i % WIDTH) as u16).collect();
        z[0] = 3000;
        let mut acc = ResolutionAccumulator::new(ResolutionParams::default());
        acc.push(&DepthFrame::from_mm(z).unwrap());
        let r = acc.finish();
        let all = r.overall.unwrap();
        assert_eq!(all.min_nonzero_step_mm, Some(3));
        assert_eq!(all.max_step_mm, 3);
        let h = (HEIGHT * (WIDTH - 1) - 1) as f64;
        let v = ((HEIGHT - 1) * WIDTH - 1) as f64;
        assert!((all.mean_step_mm - 3.0 * h / (h + v)).abs() < 1e-9);
        // 1000..2533 mm spans bins [1, 1.5), [1.5, 2), [2, 2.5), [2.5, 3).
        assert_eq!(r.by_distance.len(), 4);
        assert_eq!(r.by_distance[0].from_m, 1.0);
    }
}
