//! Plain CSV of a [`MotionClip`], for spreadsheets and quick plots, and read back so that
//! trigait's own exports load like any motion file.

use std::fmt::Write as _;
use std::path::Path;

use nalgebra::Point3;
use trigait_skeleton::{Joint, MotionClip};

use crate::{Error, Result};

/// The CSV text of `clip`: a header `frame,time_s,<joint>_x_m,<joint>_y_m,<joint>_z_m,…`, then
/// one row per frame in metres in the world frame; a gap is three empty cells.
#[must_use]
pub(crate) fn csv_text(clip: &MotionClip) -> String {
    let mut out = String::from("frame,time_s");
    for j in clip.joints() {
        // Writing into a String cannot fail.
        let _ = write!(out, ",{j}_x_m,{j}_y_m,{j}_z_m");
    }
    out.push('\n');
    for f in 0..clip.frame_count() {
        let _ = write!(out, "{f},{:.6}", f as f64 / clip.rate_hz());
        for j in clip.joints() {
            match clip.position(f, *j) {
                Some(p) => {
                    let _ = write!(out, ",{:.6},{:.6},{:.6}", p.x, p.y, p.z);
                }
                None => out.push_str(",,,"),
            }
        }
        out.push('\n');
    }
    out
}

/// Writes `clip` as CSV: a header `frame,time_s,<joint>_x_m,<joint>_y_m,<joint>_z_m,…` (joints by
/// snake_case name), then one row per frame in metres in the world frame (Z up), micrometre
/// resolution, a gap as three empty cells.
///
/// # Errors
/// [`Error::Io`] if the file cannot be written.
pub fn write_csv(path: impl AsRef<Path>, clip: &MotionClip) -> Result<()> {
    let path = path.as_ref();
    std::fs::write(path, csv_text(clip)).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })
}

fn csv_error(path: &Path, line: usize, reason: impl Into<String>) -> Error {
    Error::Csv {
        path: path.to_path_buf(),
        line,
        reason: reason.into(),
    }
}

/// Reads a joint CSV as [`write_csv`] writes it: header
/// `frame,time_s,<joint>_x_m,<joint>_y_m,<joint>_z_m,…`, metres, Z up, a gap as empty cells.
///
/// The rate comes from the time column (first to last row), rounded to 1 mHz so that the
/// microsecond rounding of the times does not show; at least two rows are needed for it.
///
/// # Errors
/// [`Error::Io`] if the file cannot be read; [`Error::Csv`] with the line number for a header
/// that is not joint columns, a row of the wrong length, a non-number, a partial gap, or times
/// that do not increase.
pub fn read_csv(path: impl AsRef<Path>) -> Result<MotionClip> {
    let path = path.as_ref();
    let bytes =
        trigait_input_limits::read_bounded(path, crate::MAX_MOTION_FILE_BYTES, "motion file")
            .map_err(|source| Error::Io {
                path: path.to_path_buf(),
                source,
            })?;
    parse_csv(path, &String::from_utf8_lossy(&bytes))
}

fn parse_csv(path: &Path, text: &str) -> Result<MotionClip> {
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty());
    let (_, header) = lines
        .next()
        .ok_or_else(|| csv_error(path, 1, "the file is empty"))?;
    let fields: Vec<&str> = header.split(',').map(str::trim).collect();
    if fields.len() < 5
        || fields[0] != "frame"
        || fields[1] != "time_s"
        || !(fields.len() - 2).is_multiple_of(3)
    {
        return Err(csv_error(
            path,
            1,
            "expected `frame,time_s,<joint>_x_m,<joint>_y_m,<joint>_z_m,…`",
        ));
    }
    let mut joints = Vec::new();
    for triple in fields[2..].chunks(3) {
        let joint = triple[0]
            .strip_suffix("_x_m")
            .and_then(Joint::from_name)
            .filter(|j| triple[1] == format!("{j}_y_m") && triple[2] == format!("{j}_z_m"))
            .ok_or_else(|| {
                csv_error(
                    path,
                    1,
                    format!("columns {triple:?} are not one joint's x, y, z"),
                )
            })?;
        joints.push(joint);
    }
    let mut times = Vec::new();
    let mut frames = Vec::new();
    for (line, row) in lines {
        let cells: Vec<&str> = row.split(',').map(str::trim).collect();
        if cells.len() != fields.len() {
            return Err(csv_error(
                path,
                line,
                format!("{} cells, the header has {}", cells.len(), fields.len()),
            ));
        }
        let number = |cell: &str| {
            cell.parse::<f64>()
                .map_err(|_| csv_error(path, line, format!("{cell:?} is not a number")))
        };
        times.push(number(cells[1])?);
        let mut frame = Vec::with_capacity(joints.len());
        for (joint, xyz) in joints.iter().zip(cells[2..].chunks(3)) {
            frame.push(match xyz.iter().filter(|c| c.is_empty()).count() {
                3 => None,
                0 => Some(Point3::new(
                    number(xyz[0])?,
                    number(xyz[1])?,
                    number(xyz[2])?,
                )),
                _ => {
                    return Err(csv_error(path, line, format!("{joint} is partly empty")));
                }
            });
        }
        frames.push(frame);
    }
    let (Some(first), Some(last)) = (times.first(), times.last()) else {
        return Err(csv_error(path, 2, "no data rows"));
    };
    if times.len() < 2 || last <= first || times.windows(2).any(|w| w[1] <= w[0]) {
        return Err(csv_error(
            path,
            2,
            "need at least two rows with increasing time_s to know the rate",
        ));
    }
    let rate_hz = ((times.len() - 1) as f64 / (last - first) * 1e3).round() / 1e3;
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_string())
        .unwrap_or_default();
    Ok(MotionClip::new(name, rate_hz, joints, frames)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Header names every coordinate; gaps are empty cells; values are in metres.
    #[test]
    fn layout() {
        let clip = MotionClip::new(
            "c",
            10.0,
            vec![Joint::KneeLeft, Joint::Head],
            vec![
                vec![Some(Point3::new(1.0, 2.0, 3.0)), None],
                vec![None, Some(Point3::new(-0.5, 0.0, 1.25))],
            ],
        )
        .unwrap();
        let text = csv_text(&clip);
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(
            lines[0],
            "frame,time_s,knee_left_x_m,knee_left_y_m,knee_left_z_m,head_x_m,head_y_m,head_z_m"
        );
        assert_eq!(lines[1], "0,0.000000,1.000000,2.000000,3.000000,,,");
        assert_eq!(lines[2], "1,0.100000,,,,-0.500000,0.000000,1.250000");
        assert_eq!(lines.len(), 3);
    }
}

#[cfg(test)]
mod read_tests {
    use super::*;

    /// What `csv_text` writes, `parse_csv` reads back, gaps and rate included.
    #[test]
    fn round_trip() {
        let clip = MotionClip::new(
            "c",
            30.0,
            vec![Joint::AnkleRight, Joint::SpineBase],
            (0..10)
                .map(|f| {
                    let p = Point3::new(f as f64 * 0.1, -0.25, 0.9);
                    vec![(f != 3).then_some(p), Some(p)]
                })
                .collect(),
        )
        .unwrap();
        let back = parse_csv(Path::new("c.csv"), &csv_text(&clip)).unwrap();
        assert_eq!(back.rate_hz(), 30.0);
        assert_eq!(back.joints(), clip.joints());
        assert_eq!(back.missing_frames(Joint::AnkleRight), 1);
        for f in 0..10 {
            for j in clip.joints() {
                let (a, b) = (clip.position(f, *j), back.position(f, *j));
                assert_eq!(a.is_some(), b.is_some());
                if let (Some(a), Some(b)) = (a, b) {
                    assert!((a - b).norm() < 1e-6);
                }
            }
        }
    }

    /// Malformed CSV is a typed error naming the line.
    #[test]
    fn malformed() {
        let p = Path::new("x.csv");
        let header = "frame,time_s,knee_left_x_m,knee_left_y_m,knee_left_z_m";
        let parse = |body: &str| parse_csv(p, &format!("{header}\n{body}"));
        assert!(matches!(
            parse("0,0,1,2,3\n1,0.1,1,2"),
            Err(Error::Csv { line: 3, .. })
        ));
        assert!(matches!(
            parse("0,0,1,x,3\n1,0.1,1,2,3"),
            Err(Error::Csv { line: 2, .. })
        ));
        assert!(matches!(
            parse("0,0,1,,3\n1,0.1,1,2,3"),
            Err(Error::Csv { line: 2, .. })
        ));
        assert!(matches!(parse("0,0,1,2,3"), Err(Error::Csv { .. })));
        assert!(matches!(
            parse_csv(p, "frame,time_s,elbow_x_m,elbow_y_m,elbow_z_m\n"),
            Err(Error::Csv { line: 1, .. })
        ));
        assert!(matches!(parse_csv(p, ""), Err(Error::Csv { line: 1, .. })));
    }
}
