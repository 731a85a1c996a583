//! Motion input for the trigait simulator: where the ground-truth joint trajectories come from.
//!
//! The simulator renders what each Kinect would report for a person whose joints follow a known
//! path. That path comes from one of two places:
//!
//! * **Real motion capture.** [`read_c3d`] and [`read_trc`] load marker trajectories into a
//!   [`MarkerSet`]; [`joint_centres`] turns skin markers into the joint centres a Kinect body
//!   tracker reports (hips by a published regression, knees and ankles from their epicondyle and
//!   malleolus markers). [`load_motion`] does both, picking the reader by file extension, and
//!   also loads trigait's own exports (joint-named TRC/C3D, [`read_csv`]).
//! * **The embedded parametric [`walker`]**, so the default dataflow runs on a fresh machine with
//!   no files: a kinematic gait with normal-gait hip/knee/ankle curves, a stance foot that stays on
//!   the floor and exactly constant segment lengths.
//!
//! The writers ([`write_trc`], [`write_c3d`], [`write_csv`]) export a [`MotionClip`] (ground truth
//! or fused result) for OpenSim, Vicon-style tools and spreadsheets; [`load_motion`] reads each
//! of them back.
//!
//! ```
//! use trigait_motion::{Joint, WalkerParams, walker};
//!
//! // Two seconds of the default walker at the Kinect's 30 Hz.
//! let clip = walker(&WalkerParams::default(), 2.0, 30.0)?;
//! assert_eq!(clip.frame_count(), 61);
//! let ankle = clip.position(0, Joint::AnkleRight).unwrap();
//! assert!(ankle.z > 0.0 && ankle.z < 0.15);
//! # Ok::<(), trigait_motion::Error>(())
//! ```
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
mod lap;
mod markers;
mod sdk;
mod trc;
mod walker;

use std::path::Path;

pub use c3d::{read_c3d, write_c3d};
pub use centres::{
    FootMarkers, JointCentreParams, foot_markers, joint_centres, joint_centres_with,
};

/// Largest motion file (C3D, TRC, CSV, SDK skeleton text) the readers accept: 512 MiB, an hour
/// of 300-marker capture at 100 Hz. What a reader builds from a file is bounded by a small
/// multiple of its size, so this bounds its memory too.
pub const MAX_MOTION_FILE_BYTES: u64 = 512 << 20;
pub use csv::{CsvAppender, read_csv, write_csv};
pub use error::{Error, Result};
pub use lap::{there_and_back, walkway_laps, walkway_loop};
pub use markers::{Landmark, MARKER_NAMES, MarkerGaps, MarkerSet};
pub use sdk::{
    CutLine, SdkClip, SdkFrame, SdkLog, THESIS_TEXT_HEADER, is_timed, parse_sdk_log,
    parse_sdk_skeletons, read_sdk_log, read_sdk_skeletons, sdk_clip, swap_sides_walking_away,
};
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
    /// trigait's joint CSV (`.csv`) as [`write_csv`] writes it.
    Csv,
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
            "csv" => Ok(MotionFormat::Csv),
            _ => Err(Error::UnknownExtension {
                path: path.to_path_buf(),
                extension,
            }),
        }
    }
}

/// Reads the trajectories of a `.c3d`, `.trc` or `.csv` file (extension case-insensitive) as
/// markers. A joint CSV gives one marker per joint, labelled by the joint's name.
///
/// # Errors
/// [`Error::UnknownExtension`] for other files, else as [`read_c3d`] / [`read_trc`] /
/// [`read_csv`].
pub fn read_markers(path: impl AsRef<Path>) -> Result<MarkerSet> {
    let path = path.as_ref();
    match MotionFormat::from_path(path)? {
        MotionFormat::C3d => read_c3d(path),
        MotionFormat::Trc => read_trc(path),
        MotionFormat::Csv => {
            let clip = read_csv(path)?;
            let labels = clip.joints().iter().map(|j| j.name().to_string()).collect();
            let frames = (0..clip.frame_count())
                .map(|f| clip.joints().iter().map(|j| clip.position(f, *j)).collect())
                .collect();
            MarkerSet::new(clip.name(), clip.rate_hz(), labels, frames)
        }
    }
}

/// The clip of a marker set whose every label is a joint name (`knee_left`, `KneeLeft`, with or
/// without a `subject:` prefix), as in files trigait exported; `None` for skin markers, an empty
/// set, or a joint named twice.
#[must_use]
pub fn joints_from_labels(markers: &MarkerSet) -> Option<MotionClip> {
    let joints: Vec<Joint> = markers
        .labels()
        .iter()
        .map(|l| Joint::from_name(l.rsplit(':').next().unwrap_or(l).trim()))
        .collect::<Option<_>>()?;
    if joints.is_empty() {
        return None;
    }
    let frames = (0..markers.frame_count())
        .map(|f| {
            (0..joints.len())
                .map(|c| markers.position_at_column(f, c))
                .collect()
        })
        .collect();
    MotionClip::new(markers.name(), markers.rate_hz(), joints, frames).ok()
}

/// Loads a motion file as joint trajectories: the ground truth the simulator plays.
///
/// Dispatches on the extension (case-insensitive): `.csv` is read as joints; a `.c3d` / `.trc`
/// whose markers are all joint names (a trigait export) is taken as is
/// ([`joints_from_labels`]); any other `.c3d` / `.trc` holds skin markers, turned into joint
/// centres by [`joint_centres`]. The clip keeps the file's origin (floor at z = 0).
///
/// # Errors
/// [`Error::UnknownExtension`], any reader error, [`Error::MissingMarker`] when skin markers
/// lack the pelvis or leg markers the joint centres need, or [`Error::ImplausibleScale`] when
/// the legs come out at no person's length (a file in millimetres that says metres).
pub fn load_motion(path: impl AsRef<Path>) -> Result<MotionClip> {
    let path = path.as_ref();
    let clip = if MotionFormat::from_path(path)? == MotionFormat::Csv {
        read_csv(path)?
    } else {
        let markers = read_markers(path)?;
        match joints_from_labels(&markers) {
            Some(clip) => clip,
            None => joint_centres(&markers)?,
        }
    };
    check_clip_scale(path, &clip)?;
    Ok(clip)
}

/// Shortest and longest leg (hip to ankle, metres) of anyone walking: a toddler's is about
/// 0.25 m, the tallest adults' about 1.3 m.
const LEG_RANGE_M: (f64, f64) = (0.2, 1.5);

/// Refuses a clip (read from `path`) whose legs, hip over knee to ankle, measure no person's
/// length, naming the likely unit (median leg outside 0.2–1.5 m).
///
/// # Errors
/// [`Error::ImplausibleScale`].
pub fn check_clip_scale(path: &Path, clip: &MotionClip) -> Result<()> {
    let mut legs: Vec<f64> = Vec::new();
    for f in 0..clip.frame_count() {
        for [hip, knee, ankle] in [
            [Joint::HipLeft, Joint::KneeLeft, Joint::AnkleLeft],
            [Joint::HipRight, Joint::KneeRight, Joint::AnkleRight],
        ] {
            if let (Some(h), Some(k), Some(a)) = (
                clip.position(f, hip),
                clip.position(f, knee),
                clip.position(f, ankle),
            ) {
                legs.push((h - k).norm() + (k - a).norm());
            }
        }
    }
    check_leg_scale(path, legs, "from hip over knee to ankle")
}

/// Refuses skin markers (read from `path`) whose legs, the pelvis markers' point to each heel
/// marker, measure no person's length, naming the likely unit (median leg outside 0.2–1.5 m).
///
/// # Errors
/// [`Error::ImplausibleScale`].
pub fn check_foot_marker_scale(path: &Path, feet: &FootMarkers) -> Result<()> {
    let legs: Vec<f64> = feet
        .heel
        .iter()
        .flat_map(|heel| {
            heel.iter()
                .zip(&feet.pelvis)
                .filter_map(|(h, p)| Some((h.as_ref()? - p.as_ref()?).norm()))
        })
        .collect();
    check_leg_scale(path, legs, "from the pelvis markers to the heel marker")
}

/// Refuses a file whose legs (`legs`, measured as `what` says, metres by the file's stated
/// units) measure no person's length, naming the likely unit: a unit slip (millimetres
/// written as metres) otherwise reads as a walk a thousand times too long, which the gait
/// analysis reports as no walking at all or as impossible speeds. No legs: nothing to judge.
fn check_leg_scale(path: &Path, mut legs: Vec<f64>, what: &'static str) -> Result<()> {
    legs.retain(|l| l.is_finite());
    if legs.is_empty() {
        return Ok(());
    }
    legs.sort_by(f64::total_cmp);
    let leg_m = legs[legs.len() / 2];
    if (LEG_RANGE_M.0..=LEG_RANGE_M.1).contains(&leg_m) {
        return Ok(());
    }
    let hint = match leg_m {
        l if (200.0..=1500.0).contains(&l) => ": are the coordinates in millimetres?",
        l if (20.0..=150.0).contains(&l) => ": are the coordinates in centimetres?",
        _ => "",
    };
    Err(Error::ImplausibleScale {
        path: path.to_path_buf(),
        leg_m,
        what,
        samples: legs.len(),
        hint,
    })
}
