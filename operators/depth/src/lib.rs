//! Kinect v2 depth accuracy toolkit: the five depth metrics of the thesis (ch. 3, results §5.1),
//! a depth frame simulator to test them against, and a multi-sensor floor check.
//!
//! Why: before trusting a multi-Kinect rig, a gait lab wants to know how good each sensor's depth
//! is where the walker will be, and whether the calibration puts every sensor's view of the same
//! floor in the same place. The thesis measured five attributes in MATLAB on a screen and a wall;
//! this crate computes them on recorded or streamed frames:
//!
//! | thesis | module | what |
//! |---|---|---|
//! | §3.1, eq. 3.1, §5.1.1 | [`accuracy`] | per-pixel mean vs. true distance, green/yellow/red zones in the 70°×60° cone |
//! | §3.2, eq. 3.2, §5.1.2 | [`resolution`] | smallest/mean/max step between neighbours, per distance |
//! | §3.3, eq. 3.3, §5.1.3 | [`entropy`] | per-pixel entropy of frame-to-frame differences over 30 frames |
//! | §3.4, §5.1.4 | [`edge`] | width and share of the no-data band around object contours |
//! | §3.5, §5.1.5 | [`structural`] | residual of a flat wall from its plane, radial rings |
//!
//! Frames are [`DepthFrame`]s: 512×424 millimetres, 0 = no data. Metrics are plain functions
//! and streaming accumulators ([`SequenceAnalyzer`]) with no I/O, so a dataflow node can push
//! frames as they arrive; [`io`] reads PNG files and directories for the CLI, [`render`] turns
//! maps into colour PNGs with a legend, [`sim`] renders synthetic frames with known noise (placed
//! in a lab by a sensor's pose with [`lab`]), and
//! [`panoptic`] back-projects calibrated CMU Panoptic Kinect frames to world points and fits the
//! floor per sensor. Inside, lengths are metres; values the thesis states in millimetres carry
//! `_mm`.

pub mod accuracy;
pub mod edge;
pub mod entropy;
mod error;
pub mod frame;
pub mod io;
pub mod lab;
pub mod panoptic;
pub mod plane;
pub mod render;
pub mod resolution;
pub mod sequence;
pub mod sim;
pub mod stats;
pub mod structural;

pub use error::{Error, Result};
pub use frame::{DepthFrame, HEIGHT, Intrinsics, Mask, PIXELS, WIDTH};
pub use sequence::{MetricsParams, SequenceAnalyzer, SequenceMaps, SequenceReport};
pub use trigait_camera::Undistorter;
