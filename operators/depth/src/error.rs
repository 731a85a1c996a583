//! The crate's one error type: every variant names the input it is about.

use std::path::PathBuf;

/// What can go wrong when reading, checking or measuring depth frames.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A file could not be opened, read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// What the operating system said.
        source: std::io::Error,
    },
    /// The file is not a PNG the decoder can read.
    #[error("{}: not a readable PNG: {source}", path.display())]
    PngDecode {
        /// The file.
        path: PathBuf,
        /// What the PNG decoder said.
        source: png::DecodingError,
    },
    /// A PNG could not be encoded.
    #[error("{}: cannot write PNG: {source}", path.display())]
    PngEncode {
        /// The file.
        path: PathBuf,
        /// What the PNG encoder said.
        source: png::EncodingError,
    },
    /// A depth PNG is not 16-bit single-channel (e.g. an 8-bit preview image).
    #[error(
        "{}: {bit_depth}-bit {color} PNG, but a depth frame must be 16-bit grayscale millimetres",
        path.display()
    )]
    NotDepthPng {
        /// The file.
        path: PathBuf,
        /// Bits per sample found.
        bit_depth: u8,
        /// Colour type found (`Grayscale`, `Rgba`, ...).
        color: String,
    },
    /// An image does not have the Kinect v2 depth size.
    #[error("{what}: {width}x{height} pixels, but Kinect v2 depth frames are 512x424")]
    WrongSize {
        /// The file or frame.
        what: String,
        /// Width found.
        width: usize,
        /// Height found.
        height: usize,
    },
    /// A buffer handed to a frame constructor has the wrong number of pixels.
    #[error("depth buffer has {got} pixels, expected {expected} (512x424)")]
    WrongLength {
        /// Pixels given.
        got: usize,
        /// Pixels expected.
        expected: usize,
    },
    /// A frame has no valid (non-zero) pixel at all.
    #[error("{what}: every pixel is 0 (no depth data)")]
    NoValidPixels {
        /// The file or frame.
        what: String,
    },
    /// A mask has no pixel set.
    #[error("{what}: the mask is empty (no non-zero pixel)")]
    EmptyMask {
        /// The file.
        what: String,
    },
    /// An image given as a mask holds many values, as a depth image does.
    #[error(
        "{what}: not a mask: its pixels hold more than {limit} different non-zero values, \
         where a mask holds a few labels (is it a depth image?)"
    )]
    NotAMask {
        /// The file.
        what: String,
        /// The most distinct non-zero values a mask may hold.
        limit: usize,
    },
    /// A directory holds no PNG file.
    #[error("{}: no .png files in this directory", path.display())]
    EmptyDirectory {
        /// The directory.
        path: PathBuf,
    },
    /// A metric was asked for before any frame arrived.
    #[error("no frame has been pushed yet")]
    NoFrames,
    /// Not enough points for a fit.
    #[error("{what}: {got} points, need at least {need}")]
    TooFewPoints {
        /// What was being fitted.
        what: String,
        /// Points available.
        got: usize,
        /// Points needed.
        need: usize,
    },
    /// RANSAC found no plane satisfying the constraints.
    #[error("{what}: no plane found ({detail})")]
    NoPlane {
        /// What was being fitted.
        what: String,
        /// Why.
        detail: String,
    },
    /// A calibration file is not JSON.
    #[error("{}: not valid JSON: {source}", path.display())]
    Json {
        /// The file.
        path: PathBuf,
        /// What the parser said.
        source: serde_json::Error,
    },
    /// A calibration value is missing or malformed.
    #[error("{}: sensors[{sensor}].{key}: expected {expected}", path.display())]
    CalibrationKey {
        /// The file.
        path: PathBuf,
        /// Index into `sensors`.
        sensor: usize,
        /// The key.
        key: &'static str,
        /// What was expected there.
        expected: &'static str,
    },
    /// The number of depth frames does not match the number of calibrated sensors.
    #[error(
        "{frames} depth frames for {sensors} calibrated sensors; frame i belongs to sensors[i]"
    )]
    SensorCountMismatch {
        /// Frames given.
        frames: usize,
        /// Sensors in the calibration.
        sensors: usize,
    },
    /// A parameter is out of its meaningful range.
    #[error("parameter {name} = {value}: {expected}")]
    BadParameter {
        /// Parameter name.
        name: &'static str,
        /// Value given.
        value: f64,
        /// What is allowed.
        expected: &'static str,
    },
    /// A scene spec that is not one of the known forms.
    #[error("scene {spec:?}: expected {expected}")]
    BadSpec {
        /// The spec given.
        spec: String,
        /// The forms allowed.
        expected: &'static str,
    },
}

/// Result with this crate's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;
