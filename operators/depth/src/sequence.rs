//! All five metrics over a stream of frames, one frame at a time.
//!
//! [`SequenceAnalyzer`] is what a dataflow node or the CLI holds: `push` each frame as it
//! arrives (cheap per-pixel accumulation), `report` whenever a result is wanted. Accuracy (§3.1)
//! and entropy (§3.3) use every frame; resolution (§3.2) and edge noise (§3.4) are single-frame
//! measurements in the thesis and are evaluated on every `frame_metric_stride`-th frame with
//! depth (the first, then one per entropy window by default; a frame of all zeros, as a sensor
//! sends while it starts up, has nothing to measure) and merged; structural noise (§3.5) is
//! measured on the mean frame, where the temporal noise has averaged out.

use crate::accuracy::{
    AccuracyMap, AccuracyParams, AccuracyReport, PixelStats, accuracy_against, cone_mask,
    plane_samples, target_plane,
};
use crate::edge::{EdgeAccumulator, EdgeClass, EdgeNoise, EdgeParams, edge_noise};
use crate::entropy::{EntropyAccumulator, EntropyReport};
use crate::frame::{DepthFrame, Intrinsics, Mask, PIXELS, Rays};
use crate::plane::fit_image_plane;
use crate::resolution::{Resolution, ResolutionAccumulator, ResolutionParams};
use crate::structural::{StructuralNoise, StructuralParams, structural_noise_on_plane};
use crate::{Error, Result};

/// Settings of every metric.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MetricsParams {
    /// Camera model (rays for plane fits, cone and principal point).
    pub intrinsics: Intrinsics,
    /// §3.1 accuracy distribution.
    pub accuracy: AccuracyParams,
    /// §3.2 depth resolution.
    pub resolution: ResolutionParams,
    /// §3.3 frames per entropy window (thesis: 30).
    pub entropy_window: usize,
    /// §3.4 edge noise.
    pub edge: EdgeParams,
    /// §3.5 structural noise.
    pub structural: StructuralParams,
    /// Resolution and edge noise are evaluated on frames 0, k, 2k, … with this k.
    pub frame_metric_stride: usize,
}

impl Default for MetricsParams {
    fn default() -> Self {
        Self {
            intrinsics: Intrinsics::default(),
            accuracy: AccuracyParams::default(),
            resolution: ResolutionParams::default(),
            entropy_window: 30,
            edge: EdgeParams::default(),
            structural: StructuralParams::default(),
            frame_metric_stride: 30,
        }
    }
}

/// The five metrics of a sequence. A metric that cannot be computed from this input (entropy
/// of a single frame, a plane fit on a scene without one) is `None` with the reason in `notes`.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SequenceReport {
    /// Frames pushed.
    pub frames: usize,
    /// Share of pixels with data over all frames.
    pub valid_share: f64,
    /// §3.1 accuracy distribution.
    pub accuracy: Option<AccuracyReport>,
    /// §3.2 depth resolution.
    pub resolution: Resolution,
    /// §3.3 depth entropy.
    pub entropy: Option<EntropyReport>,
    /// §3.4 edge noise.
    pub edge_noise: EdgeNoise,
    /// §3.5 structural noise.
    pub structural_noise: Option<StructuralNoise>,
    /// Why a metric is missing.
    pub notes: Vec<String>,
}

/// Per-pixel maps for images.
#[derive(Debug, Clone)]
pub struct SequenceMaps {
    /// Accuracy zones and cone.
    pub accuracy: Option<AccuracyMap>,
    /// Entropy, bits.
    pub entropy: Vec<Option<f32>>,
    /// Edge classes of the last frame evaluated for edge noise.
    pub edge: Vec<EdgeClass>,
    /// Depth of that frame, mm (background of the edge image).
    pub edge_depth_mm: Vec<u16>,
    /// Structural residual, mm (NaN off the plane).
    pub structural_residual_mm: Option<Vec<f32>>,
    /// Mean depth, mm (NaN without data).
    pub mean_depth_mm: Vec<f32>,
}

/// Streaming computation of the five metrics.
///
/// Frames are buffered for one entropy window and folded into the per-pixel accumulators a
/// window at a time (cache-friendly); `report` includes a partly filled window.
#[derive(Debug, Clone)]
pub struct SequenceAnalyzer {
    params: MetricsParams,
    rays: Rays,
    in_cone: Vec<bool>,
    mask: Option<Mask>,
    stats: PixelStats,
    entropy: EntropyAccumulator,
    resolution: ResolutionAccumulator,
    edge: EdgeAccumulator,
    last_edge: Option<(Vec<EdgeClass>, Vec<u16>)>,
    window: Vec<u16>,
    buffered: usize,
    frames: usize,
    /// Frames with at least one valid pixel, which the single-frame metrics' stride counts.
    frames_with_depth: usize,
}

impl SequenceAnalyzer {
    /// A new analyzer; `mask` marks the object for edge noise (§3.4). Sets up the camera model
    /// (rays, cone) once; [`reset`](Self::reset) starts a new sequence without redoing it.
    #[must_use]
    pub fn new(params: MetricsParams, mask: Option<Mask>) -> Self {
        let rays = params.intrinsics.rays();
        let in_cone = cone_mask(&rays, &params.accuracy);
        let entropy = EntropyAccumulator::new(params.entropy_window);
        Self {
            window: vec![0; entropy.window() * PIXELS],
            rays,
            in_cone,
            mask,
            stats: PixelStats::new(),
            entropy,
            resolution: ResolutionAccumulator::new(params.resolution),
            edge: EdgeAccumulator::default(),
            last_edge: None,
            buffered: 0,
            frames: 0,
            frames_with_depth: 0,
            params,
        }
    }

    /// Forgets every frame, keeping the camera model and the allocations.
    pub fn reset(&mut self) {
        self.stats.clear();
        self.entropy.clear();
        self.resolution = ResolutionAccumulator::new(self.params.resolution);
        self.edge = EdgeAccumulator::default();
        self.last_edge = None;
        self.buffered = 0;
        self.frames = 0;
        self.frames_with_depth = 0;
    }

    /// Frames pushed so far.
    #[must_use]
    pub fn frames(&self) -> usize {
        self.frames
    }

    /// Frames pushed so far with at least one valid pixel (the rest are all zeros, as a sensor
    /// sends while it starts up).
    #[must_use]
    pub fn frames_with_depth(&self) -> usize {
        self.frames_with_depth
    }

    /// Adds one frame.
    pub fn push(&mut self, frame: &DepthFrame) {
        let has_depth = frame.valid_count() > 0;
        if has_depth
            && self
                .frames_with_depth
                .is_multiple_of(self.params.frame_metric_stride.max(1))
        {
            self.resolution.push(frame);
            let (e, widths, classes) = edge_noise(frame, self.mask.as_ref(), &self.params.edge);
            self.edge.push(&e, &widths);
            match &mut self.last_edge {
                Some((c, z)) => {
                    *c = classes;
                    z.copy_from_slice(frame.as_mm());
                }
                None => self.last_edge = Some((classes, frame.as_mm().to_vec())),
            }
        }
        self.window[self.buffered * PIXELS..(self.buffered + 1) * PIXELS]
            .copy_from_slice(frame.as_mm());
        self.buffered += 1;
        self.frames += 1;
        self.frames_with_depth += usize::from(has_depth);
        if self.buffered * PIXELS == self.window.len() {
            self.entropy
                .push_window_with_stats(&self.window, Some(&mut self.stats));
            self.buffered = 0;
        }
    }

    /// The metrics over the frames so far.
    ///
    /// # Errors
    /// [`Error::NoFrames`] before the first frame.
    pub fn report(&self) -> Result<SequenceReport> {
        Ok(self.report_and_maps()?.0)
    }

    /// The metrics and the per-pixel maps.
    ///
    /// # Errors
    /// [`Error::NoFrames`] before the first frame.
    pub fn report_and_maps(&self) -> Result<(SequenceReport, SequenceMaps)> {
        if self.frames == 0 {
            return Err(Error::NoFrames);
        }
        let partial = &self.window[..self.buffered * PIXELS];
        let with_partial;
        let stats = if self.buffered > 0 {
            let mut s = self.stats.clone();
            s.push_block(partial);
            with_partial = s;
            &with_partial
        } else {
            &self.stats
        };
        let mut notes = Vec::new();
        let mean = stats.mean_frame_mm();
        // One robust plane fit serves both the accuracy target (when no distance is given)
        // and the structural residual.
        let fitted = fit_image_plane(
            &plane_samples(&mean, &self.rays, 2),
            self.params.accuracy.on_target_tolerance_mm / 1000.0,
            self.params.accuracy.ransac_iterations,
            self.params.accuracy.seed,
        );
        let target = match (self.params.accuracy.target_distance_m, &fitted) {
            (None, Ok(fit)) => Ok(("fitted_plane", fit.plane)),
            (None, Err(e)) => Err(format!("{e}")),
            (Some(_), _) => {
                target_plane(&mean, &self.rays, &self.params.accuracy).map_err(|e| e.to_string())
            }
        };
        let accuracy = target.and_then(|t| {
            accuracy_against(stats, &self.rays, &self.in_cone, t, &self.params.accuracy)
                .map_err(|e| e.to_string())
        });
        let (acc, acc_map) = match accuracy {
            Ok((r, m)) => (Some(r), Some(m)),
            Err(e) => {
                notes.push(format!("accuracy: {e}"));
                (None, None)
            }
        };
        let (entropy, entropy_map) = self.entropy.finish_with(partial);
        let entropy = if entropy.windows == 0 {
            notes.push("entropy: needs at least 2 frames".to_owned());
            None
        } else {
            Some(entropy)
        };
        let structural = fitted.map_err(|e| e.to_string()).and_then(|fit| {
            structural_noise_on_plane(
                &mean,
                &self.rays,
                &self.params.intrinsics,
                &fit.plane,
                &self.params.structural,
            )
            .map_err(|e| e.to_string())
        });
        let (structural, residual) = match structural {
            Ok((s, r)) => (Some(s), Some(r)),
            Err(e) => {
                notes.push(format!("structural noise: {e}"));
                (None, None)
            }
        };
        let (edge_classes, edge_depth) = self.last_edge.clone().unwrap_or_default();
        let report = SequenceReport {
            frames: self.frames,
            valid_share: stats.valid_share(),
            accuracy: acc,
            resolution: self.resolution.finish(),
            entropy,
            edge_noise: self.edge.finish(),
            structural_noise: structural,
            notes,
        };
        let maps = SequenceMaps {
            accuracy: acc_map,
            entropy: entropy_map,
            edge: edge_classes,
            edge_depth_mm: edge_depth,
            structural_residual_mm: residual,
            mean_depth_mm: mean,
        };
        Ok((report, maps))
    }
}
