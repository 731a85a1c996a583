//! Motion input for the trigait simulator: where the ground-truth joint trajectories come from.
//!
//! The simulator renders what each Kinect would report for a person whose joints follow a known
//! path. That path comes from one of two places:
//!
//! * **Real motion capture.** [`read_c3d`] and [`read_trc`] load marker trajectories into a
//!   [`MarkerSet`]; [`joint_centres`] turns skin markers into the joint centres a Kinect body
//!   tracker reports (hips by a published regression, knees and ankles from their epicondyle and
//!   malleolus markers). [`load_motion`] does both, picking the reader by file extension.
//! * **The embedded parametric [`walker`]**, so the default dataflow runs on a fresh machine with
//!   no files: a kinematic gait with normal-gait hip/knee/ankle curves, a stance foot that stays on
//!   the floor and exactly constant segment lengths.
//!
//! The writers ([`write_trc`], [`write_c3d`], [`write_csv`]) export a [`MotionClip`] (ground truth
//! or fused result) for OpenSim, Vicon-style tools and spreadsheets.
//!
//! # Frames and units
//! Everything inside is SI and in the world frame of DESIGN.md: metres, right-handed, Z up, floor at
//! z = 0. Files are converted at the edge: C3D points by their `POINT:UNITS`, TRC by its `Units`
//! header and from its Y-up frame by (X, Y, Z)_trc → (X, −Z, Y). Positions keep the laboratory's
//! origin; call [`MotionClip::placed_on_walkway`] to centre a walk on the rig.
//!
//! # Gaps
//! A marker the cameras lost is a gap (`None`) and stays one: no reader interpolates, and a joint
//! whose markers are missing in a frame is missing in that frame. [`MarkerSet::gaps`] reports them.

#![warn(missing_docs)]

mod c3d;
mod centres;
mod csv;
mod error;
mod markers;
mod trc;
mod walker;

use std::path::Path;

pub use c3d::{read_c3d, write_c3d};
pub use centres::{JointCentreParams, joint_centres, joint_centres_with};
pub use csv::write_csv;
pub use error::{Error, Result};
pub use markers::{MarkerGaps, MarkerSet};
pub use trc::{read_trc, write_trc};
pub use trigait_skeleton::{Joint, MotionClip};
pub use walker::{WalkerParams, walker};

/// The motion-file formats [`load_motion`] and [`read_markers`] understand.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MotionFormat {
    /// C3D binary (`.c3d`), read with c3dio.
    C3d,
    /// OpenSim / Motion Analysis track-row-column text (`.trc`).
    Trc,
}

impl MotionFormat {
    /// The format of `path` by its extension, case-insensitive.
    ///
    /// # Errors
    /// [`Error::UnknownExtension`] naming the extension (empty when there is none).
    pub fn from_path(path: &Path) -> Result<Self> {
        let extension = path
            .extension()
            .map(|e| e.to_string_lossy().to_string())
            .unwrap_or_default();
        match extension.to_ascii_lowercase().as_str() {
            "c3d" => Ok(MotionFormat::C3d),
            "trc" => Ok(MotionFormat::Trc),
            _ => Err(Error::UnknownExtension {
                path: path.to_path_buf(),
                extension,
            }),
        }
    }
}

/// Reads the marker trajectories of a `.c3d` or `.trc` file (extension case-insensitive).
///
/// # Errors
/// [`Error::UnknownExtension`] for other files, else as [`read_c3d`] / [`read_trc`].
pub fn read_markers(path: impl AsRef<Path>) -> Result<MarkerSet> {
    let path = path.as_ref();
    match MotionFormat::from_path(path)? {
        MotionFormat::C3d => read_c3d(path),
        MotionFormat::Trc => read_trc(path),
    }
}

/// Loads a marker file and returns its joint centres: the ground truth the simulator plays.
///
/// Dispatches on the extension (`.c3d` / `.trc`, case-insensitive), then calls
/// [`joint_centres`]. The clip keeps the laboratory's origin (floor at z = 0).
///
/// # Errors
/// [`Error::UnknownExtension`], any reader error, or [`Error::MissingMarker`] when the file lacks
/// the pelvis or leg markers the joint centres need.
pub fn load_motion(path: impl AsRef<Path>) -> Result<MotionClip> {
    joint_centres(&read_markers(path)?)
}
