//! C3D files through c3dio 0.8.
//!
//! Two quirks of c3dio shape this module:
//! * it reads the residual byte of float-format files as signed, so almost every residual comes out
//!   negative and cannot mark gaps: a gap is a NaN coordinate or exactly (0, 0, 0), the value
//!   Vicon and c3dio write for an invalid point;
//! * it indexes and unwraps freely inside, so a garbage file could panic in it. We check the C3D
//!   signature first and contain any panic left as [`Error::C3d`], so bad input never takes the
//!   caller down.

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};

use c3dio::{C3d, MarkerPoint, Parameter};
use nalgebra::{Matrix3, Point3, Vector3};
use trigait_skeleton::MotionClip;

use crate::trc::metres_per_unit;
use crate::{Error, MarkerSet, Result};

fn c3d_error(path: &Path, reason: impl Into<String>) -> Error {
    Error::C3d {
        path: path.to_path_buf(),
        reason: reason.into(),
    }
}

/// The proper rotation taking a file whose vertical is `up` (its `POINT:Y_SCREEN`, e.g. `+Y`)
/// to our Z-up world, keeping the file's X axis where it can; `None` for an unknown axis.
fn world_from_up_axis(up: [char; 2]) -> Option<Matrix3<f64>> {
    let m = |rows: [[f64; 3]; 3]| {
        Matrix3::new(
            rows[0][0], rows[0][1], rows[0][2], rows[1][0], rows[1][1], rows[1][2], rows[2][0],
            rows[2][1], rows[2][2],
        )
    };
    let sign = match up[0] {
        '+' | ' ' => 1.0,
        '-' => -1.0,
        _ => return None,
    };
    Some(match (up[1].to_ascii_uppercase(), sign > 0.0) {
        ('Z', true) => Matrix3::identity(),
        ('Z', false) => m([[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]]),
        // Y up (TRC, Motion Analysis): (x, y, z) ↦ (x, −z, y).
        ('Y', true) => m([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]]),
        ('Y', false) => m([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]]),
        ('X', true) => m([[0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]]),
        ('X', false) => m([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]]),
        _ => return None,
    })
}

/// Reads the 3-D points of a C3D file into a [`MarkerSet`] in metres, Z up.
///
/// `POINT:Y_SCREEN` names the file's vertical axis: a `+Z` file (CMU, Vicon, or none given) keeps
/// its axes, a `+Y` file is turned by (x, y, z) ↦ (x, −z, y) as TRC is. `POINT:UNITS` gives
/// the length unit. Frames are indexed from 0 whatever the file's `first_frame`. A point that is
/// NaN or exactly (0, 0, 0) is a gap.
///
/// # Errors
/// [`Error::Io`] if the file cannot be read, [`Error::C3d`] if it is not a C3D file, c3dio
/// rejects it or its `Y_SCREEN` is not an axis, [`Error::UnknownUnits`] for a `POINT:UNITS` other than mm, cm or m.
pub fn read_c3d(path: impl AsRef<Path>) -> Result<MarkerSet> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })?;
    // Header word 1: parameter block number (≥ 2) and the key byte 0x50.
    if bytes.len() < 1024 || bytes[1] != 0x50 || bytes[0] < 2 {
        return Err(c3d_error(
            path,
            "missing the C3D signature (0x50 in byte 2)",
        ));
    }
    let c3d = catch_unwind(AssertUnwindSafe(|| {
        C3d::from_bytes(&bytes).map_err(|e| format!("{e:?}"))
    }))
    .map_err(|_| c3d_error(path, "c3dio panicked on malformed content"))?
    .map_err(|reason| c3d_error(path, reason))?;
    let points = &c3d.points;
    let units: String = points.units.iter().collect::<String>().trim().to_string();
    let scale = metres_per_unit(&units).ok_or_else(|| Error::UnknownUnits {
        path: path.to_path_buf(),
        units: units.clone(),
    })?;
    let world_from_file = match points.y_screen {
        None => Matrix3::identity(),
        Some(axis) => world_from_up_axis(axis).ok_or_else(|| {
            c3d_error(
                path,
                format!(
                    "unsupported POINT:Y_SCREEN {:?} (expected ±X, ±Y or ±Z)",
                    axis.iter().collect::<String>()
                ),
            )
        })?,
    };
    let rate_hz = f64::from(points.frame_rate);
    let (rows, cols) = (points.rows(), points.cols());
    // More than 255 points: POINT:LABELS continues in LABELS2, LABELS3, … (C3D spec).
    let mut all_labels = points.labels.clone();
    for k in 2.. {
        if all_labels.len() >= cols {
            break;
        }
        let Some(more) = c3d.parameters.get("POINT", &format!("LABELS{k}")) else {
            break;
        };
        let more: Vec<String> = more.try_into().unwrap_or_default();
        if more.is_empty() {
            break;
        }
        all_labels.extend(more);
    }
    if all_labels.len() < cols {
        return Err(c3d_error(
            path,
            format!("{cols} points but only {} labels", all_labels.len()),
        ));
    }
    let labels: Vec<String> = all_labels[..cols]
        .iter()
        .map(|l| l.trim().to_string())
        .collect();
    let frames = (0..rows)
        .map(|f| {
            (0..cols)
                .map(|m| {
                    let p = points[f][m].point;
                    let gap = p.iter().any(|c| !c.is_finite()) || p == [0.0; 3];
                    (!gap).then(|| {
                        let file = Vector3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]));
                        Point3::from(world_from_file * file * scale)
                    })
                })
                .collect()
        })
        .collect();
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_string())
        .unwrap_or_default();
    MarkerSet::new(name, rate_hz, labels, frames)
}

/// Writes `clip` as a float-format C3D file with c3dio: one point per joint (labelled by its
/// snake_case name), millimetres, Z up as our world (`X_SCREEN` +X, `Y_SCREEN` +Z),
/// `POINT:RATE`, `POINT:SCALE` and `POINT:DATA_START` set for readers that need them. A gap is written as (0, 0, 0)
/// flagged invalid (fourth word −1.0), as the C3D spec asks.
///
/// # Errors
/// [`Error::C3dWrite`] if c3dio refuses (e.g. the extension is not `.c3d`) or fails to write,
/// [`Error::Io`] if the file cannot be re-read to flag its gaps.
pub fn write_c3d(path: impl AsRef<Path>, clip: &MotionClip) -> Result<()> {
    let path = path.as_ref();
    let write_error = |reason: String| Error::C3dWrite {
        path: path.to_path_buf(),
        reason,
    };
    // c3dio unwraps the extension; check it here so a bare name is an error, not a panic.
    if !path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("c3d"))
    {
        return Err(write_error("the file name must end in .c3d".to_string()));
    }
    let frames = clip.frame_count();
    if clip.joints().is_empty() {
        return Err(write_error("the clip has no joints".to_string()));
    }
    if frames > usize::from(u16::MAX) {
        return Err(write_error(format!(
            "{frames} frames do not fit the 16-bit frame numbers of a C3D header"
        )));
    }
    let mut c3d = C3d::new();
    // The groups c3dio's writer indexes (it panics on a missing one).
    for group in [
        "POINT",
        "ANALOG",
        "FORCE_PLATFORM",
        "EVENT",
        "EVENT_CONTEXT",
    ] {
        // c3dio writes a group's description without the length byte the C3D spec puts before
        // it; a one-byte description "\0" *is* that byte (length 0), which keeps the parameter
        // section readable by other C3D readers (checked with the Python `c3d` package).
        c3d.parameters.insert_group(group, "\0".to_string());
    }
    let rate = clip.rate_hz() as f32;
    let residual_scale = 0.1_f32;
    c3d.parameters
        .insert("POINT", "RATE", Parameter::float(rate));
    c3d.parameters
        .insert("POINT", "SCALE", Parameter::float(-residual_scale));
    let rows: Vec<Vec<MarkerPoint>> = (0..frames)
        .map(|f| {
            clip.joints()
                .iter()
                .map(|j| match clip.position(f, *j) {
                    Some(p) => {
                        let mm = p.coords * 1e3;
                        MarkerPoint::new(mm.x as f32, mm.y as f32, mm.z as f32)
                    }
                    None => {
                        let mut gap = MarkerPoint::new(0.0, 0.0, 0.0);
                        gap.residual = -residual_scale;
                        gap
                    }
                })
                .collect()
        })
        .collect();
    let points = &mut c3d.points;
    points.clear();
    for row in rows {
        points.push_row(row);
    }
    points.labels = clip.joints().iter().map(|j| j.name().to_string()).collect();
    points.descriptions = clip
        .joints()
        .iter()
        .map(|j| format!("{j} joint centre"))
        .collect();
    points.units = ['m', 'm', ' ', ' '];
    points.x_screen = Some(['+', 'X']);
    points.y_screen = Some(['+', 'Z']);
    points.frame_rate = rate;
    points.scale_factor = residual_scale;
    points.format = c3dio::DataFormat::Float;
    points.first_frame = 1;
    points.last_frame = frames as u16;
    // POINT:DATA_START must name the block the data starts in, which c3dio only decides while
    // writing: write, read the header's pointer back, store it and write again until they agree
    // (the parameter can push the section over a block boundary at most once).
    let mut data_start = None;
    for _ in 0..3 {
        if let Some(block) = data_start {
            c3d.parameters
                .insert("POINT", "DATA_START", Parameter::integer(block));
        }
        let target = PathBuf::from(path);
        catch_unwind(AssertUnwindSafe(|| c3d.write_path(target).map(|_| ())))
            .map_err(|_| write_error("c3dio panicked while writing".to_string()))?
            .map_err(|e| write_error(format!("{e:?}")))?;
        let written = header_data_block(path)?;
        if data_start == Some(written) {
            return mark_gaps_invalid(path, clip);
        }
        data_start = Some(written);
    }
    Err(write_error(
        "the data start block does not settle; c3dio's layout changed".to_string(),
    ))
}

/// Header word 9 of a C3D file c3dio wrote: the 1-based block where the data starts.
fn header_data_block(path: &Path) -> Result<i16> {
    let mut header = [0u8; 18];
    std::fs::File::open(path)
        .and_then(|mut f| std::io::Read::read_exact(&mut f, &mut header))
        .map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })?;
    Ok(i16::from_le_bytes([header[16], header[17]]))
}

/// Rewrites the fourth word of every gap to −1.0, the C3D float-format flag for an invalid point.
///
/// c3dio packs that word from a camera mask of 7 flags and a residual byte, so it cannot write a
/// negative value, and other readers would take (0, 0, 0) with residual 25.5 for a real
/// sample. The data section of c3dio's file is plain: Intel byte order, no analog, 16 bytes per
/// point, starting at the block named in header word 9.
fn mark_gaps_invalid(path: &Path, clip: &MotionClip) -> Result<()> {
    let joints = clip.joints();
    let gaps: Vec<usize> = (0..clip.frame_count())
        .flat_map(|f| (0..joints.len()).map(move |c| (f, c)))
        .filter(|(f, c)| clip.position(*f, joints[*c]).is_none())
        .map(|(f, c)| f * joints.len() + c)
        .collect();
    if gaps.is_empty() {
        return Ok(());
    }
    let io_error = |source| Error::Io {
        path: path.to_path_buf(),
        source,
    };
    let mut bytes = std::fs::read(path).map_err(io_error)?;
    let layout_error = || Error::C3dWrite {
        path: path.to_path_buf(),
        reason: "c3dio wrote an unexpected layout; cannot flag gaps as invalid".to_string(),
    };
    let parameter_block = usize::from(*bytes.first().ok_or_else(layout_error)?);
    let processor = parameter_block
        .checked_sub(1)
        .and_then(|b| bytes.get(b * 512 + 3))
        .ok_or_else(layout_error)?;
    let data_block = usize::from(u16::from_le_bytes([
        *bytes.get(16).ok_or_else(layout_error)?,
        *bytes.get(17).ok_or_else(layout_error)?,
    ]));
    if *processor != 0x54 || data_block < 2 {
        return Err(layout_error());
    }
    let data_start = (data_block - 1) * 512;
    for point in gaps {
        let at = data_start + point * 16 + 12;
        bytes
            .get_mut(at..at + 4)
            .ok_or_else(layout_error)?
            .copy_from_slice(&(-1.0_f32).to_le_bytes());
    }
    std::fs::write(path, bytes).map_err(io_error)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each supported vertical axis is turned onto +Z by a proper rotation.
    #[test]
    fn up_axes_map_to_z() {
        for (axis, up) in [
            ('Z', Vector3::z()),
            ('Y', Vector3::y()),
            ('X', Vector3::x()),
        ] {
            for (sign, s) in [('+', 1.0), ('-', -1.0)] {
                let r = world_from_up_axis([sign, axis]).unwrap();
                assert!((r * (up * s) - Vector3::z()).norm() < 1e-12, "{sign}{axis}");
                assert!((r.determinant() - 1.0).abs() < 1e-12);
                assert!((r * r.transpose() - Matrix3::identity()).norm() < 1e-12);
            }
        }
        // Y up is the TRC convention: (x, y, z) ↦ (x, −z, y).
        let r = world_from_up_axis(['+', 'Y']).unwrap();
        assert_eq!(
            r * Vector3::new(1.0, 2.0, 3.0),
            Vector3::new(1.0, -3.0, 2.0)
        );
        assert!(world_from_up_axis(['+', 'Q']).is_none());
        assert!(world_from_up_axis(['*', 'Z']).is_none());
    }
}
