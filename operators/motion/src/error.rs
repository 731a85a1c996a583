use std::path::PathBuf;

use trigait_skeleton::{ClipError, Joint};

/// Why motion could not be read, derived or written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The file could not be opened, read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// What the OS said.
        source: std::io::Error,
    },
    /// The extension is not `.c3d`, `.trc` or `.csv`.
    #[error("{path}: unknown motion file extension {extension:?} (expected .c3d, .trc or .csv)")]
    UnknownExtension {
        /// The file.
        path: PathBuf,
        /// Its extension as written (empty when it has none).
        extension: String,
    },
    /// c3dio refused the C3D file, or it is not a C3D file at all.
    #[error("{path}: not a readable C3D file: {reason}")]
    C3d {
        /// The file.
        path: PathBuf,
        /// What was wrong.
        reason: String,
    },
    /// A TRC line could not be parsed.
    #[error("{path}:{line}: {reason}")]
    Trc {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What was wrong.
        reason: String,
    },
    /// A joint CSV line could not be parsed.
    #[error("{path}:{line}: {reason}")]
    Csv {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What was wrong.
        reason: String,
    },
    /// A Kinect v2 SDK skeleton text line could not be parsed.
    #[error("{path}:{line}: {reason}")]
    SdkSkeleton {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What was wrong.
        reason: String,
    },
    /// The file holds fewer frames than its header announces.
    #[error("{path}: truncated, header announces {expected} frames but the data holds {got}")]
    Truncated {
        /// The file.
        path: PathBuf,
        /// Frames the header announced.
        expected: usize,
        /// Complete frames found.
        got: usize,
    },
    /// The length unit of the points is not one we know.
    #[error("{path}: unknown length unit {units:?} (expected mm, cm or m)")]
    UnknownUnits {
        /// The file.
        path: PathBuf,
        /// The unit as written.
        units: String,
    },
    /// A marker set whose shape is inconsistent (ragged frames, bad rate, no frames).
    #[error("marker set {name:?}: {reason}")]
    BadMarkerSet {
        /// Name of the set.
        name: String,
        /// What was wrong.
        reason: String,
    },
    /// A joint centre needs a marker the file does not have.
    #[error(
        "cannot place {joint}: no {role} marker (looked for {candidates}; the file has {found}); \
         accepted names are listed in trigait_motion::MARKER_NAMES"
    )]
    MissingMarker {
        /// The joint that could not be placed.
        joint: Joint,
        /// Which anatomical landmark was missing, e.g. `"left ASIS"`.
        role: &'static str,
        /// The labels that were tried.
        candidates: String,
        /// The skin-marker labels the file holds.
        found: String,
    },
    /// A walker or joint-centre parameter is out of range.
    #[error("parameter {name} = {value}: {reason}")]
    BadParameter {
        /// The parameter's field name.
        name: &'static str,
        /// The rejected value.
        value: f64,
        /// The valid range or the constraint that failed.
        reason: &'static str,
    },
    /// The legs come out at a length no person's are: the coordinates are in other units than
    /// the file says.
    #[error(
        "{path}: the legs measure {leg_m:.3} m {what} (median of {samples} legs over the \
         frames), which no person's do (0.2-1.5 m){hint}"
    )]
    ImplausibleScale {
        /// The file.
        path: PathBuf,
        /// Median leg length, in the file's stated units as metres.
        leg_m: f64,
        /// How the leg was measured.
        what: &'static str,
        /// Legs measured (two a frame at most).
        samples: usize,
        /// What the units probably are.
        hint: &'static str,
    },
    /// c3dio could not write the file.
    #[error("{path}: cannot write C3D: {reason}")]
    C3dWrite {
        /// The file.
        path: PathBuf,
        /// What c3dio said.
        reason: String,
    },
    /// The joint positions did not form a valid clip.
    #[error(transparent)]
    Clip(#[from] ClipError),
}

/// Result with the crate's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;
