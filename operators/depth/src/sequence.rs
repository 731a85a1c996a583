//! All five metrics over a stream of frames, one frame at a time.
//!
//! [`SequenceAnalyzer`] is what a dataflow node or the CLI holds: `push` each frame as it
//! arrives (cheap per-pixel accumulation), `report` whenever a result is wanted. Accuracy (§3.1)
//! and entropy (§3.3) use every frame; resolution (§3.2) and edge noise (§3.4) are single-frame
//! measurements in the thesis and are evaluated on every `frame_metric_stride`-th frame (frame
//! 0, then one per entropy window by default) and merged; structural noise (§3.5) is measured on
//! the mean frame, where the temporal noise has averaged out.

use crate::accuracy::{AccuracyMap, AccuracyParams, AccuracyReport, PixelStats, accuracy};
use crate::edge::{EdgeAccumulator, EdgeClass, EdgeNoise, EdgeParams, edge_noise};
use crate::entropy::{EntropyAccumulator, EntropyReport};
use crate::frame::{DepthFrame, Intrinsics, Mask, Rays};
use crate::resolution::{Resolution, ResolutionAccumulator, ResolutionParams};
use crate::structural::{StructuralNoise, StructuralParams, structural_noise};
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
#[derive(Debug, Clone)]
pub struct SequenceAnalyzer {
    params: MetricsParams,
    rays: Rays,
    mask: Option<Mask>,
    stats: PixelStats,
    entropy: EntropyAccumulator,
    resolution: ResolutionAccumulator,
    edge: EdgeAccumulator,
    last_edge: Option<(Vec<EdgeClass>, Vec<u16>)>,
}

impl SequenceAnalyzer {
    /// A new analyzer; `mask` marks the object for edge noise (§3.4).
    #[must_use]
    pub fn new(params: MetricsParams, mask: Option<Mask>) -> Self {
        Self {
            rays: params.intrinsics.rays(),
            mask,
            stats: PixelStats::new(),
            entropy: EntropyAccumulator::new(params.entropy_window),
            resolution: ResolutionAccumulator::new(params.resolution),
            edge: EdgeAccumulator::default(),
            last_edge: None,
            params,
        }
    }

    /// Frames pushed so far.
    #[must_use]
    pub fn frames(&self) -> usize {
        self.stats.frames()
    }

    /// Adds one frame.
    pub fn push(&mut self, frame: &DepthFrame) {
        let index = self.stats.frames();
        if index.is_multiple_of(self.params.frame_metric_stride.max(1)) {
            self.resolution.push(frame);
            let (e, widths, classes) = edge_noise(frame, self.mask.as_ref(), &self.params.edge);
            self.edge.push(&e, &widths);
            self.last_edge = Some((classes, frame.as_mm().to_vec()));
        }
        self.stats.push(frame);
        self.entropy.push(frame);
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
        if self.stats.frames() == 0 {
            return Err(Error::NoFrames);
        }
        let mut notes = Vec::new();
        let (acc, acc_map) = match accuracy(&self.stats, &self.rays, &self.params.accuracy) {
            Ok((r, m)) => (Some(r), Some(m)),
            Err(e) => {
                notes.push(format!("accuracy: {e}"));
                (None, None)
            }
        };
        let (entropy, entropy_map) = self.entropy.finish();
        let entropy = if entropy.windows == 0 {
            notes.push("entropy: needs at least 2 frames".to_owned());
            None
        } else {
            Some(entropy)
        };
        let mean = self.stats.mean_frame_mm();
        let (structural, residual) = match structural_noise(
            &mean,
            &self.rays,
            &self.params.intrinsics,
            &self.params.structural,
        ) {
            Ok((s, r)) => (Some(s), Some(r)),
            Err(e) => {
                notes.push(format!("structural noise: {e}"));
                (None, None)
            }
        };
        let (edge_classes, edge_depth) = self.last_edge.clone().unwrap_or_default();
        let report = SequenceReport {
            frames: self.stats.frames(),
            valid_share: self.stats.valid_share(),
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
