//! Plain CSV of a [`MotionClip`], for spreadsheets and quick plots, and read back so that
//! trigait's own exports load like any motion file.

use std::fmt::Write as _;
use std::path::Path;

use nalgebra::Point3;
use trigait_skeleton::{Joint, MotionClip};

use crate::{Error, Result};

/// The header line: `frame,time_s,<joint>_x_m,<joint>_y_m,<joint>_z_m,…`.
fn push_header(out: &mut String, joints: &[Joint]) {
    out.push_str("frame,time_s");
    for j in joints {
        // Writing into a String cannot fail.
        let _ = write!(out, ",{j}_x_m,{j}_y_m,{j}_z_m");
    }
    out.push('\n');
}

/// One frame's line: its number, its time, then x,y,z per joint (a gap: three empty cells).
fn push_row(
    out: &mut String,
    frame: usize,
    rate_hz: f64,
    cells: impl IntoIterator<Item = Option<Point3<f64>>>,
) {
    let _ = write!(out, "{frame},{:.6}", frame as f64 / rate_hz);
    for cell in cells {
        match cell {
            Some(p) => {
                let _ = write!(out, ",{:.6},{:.6},{:.6}", p.x, p.y, p.z);
            }
            None => out.push_str(",,,"),
        }
    }
    out.push('\n');
}

/// The CSV text of `clip`: a header `frame,time_s,<joint>_x_m,<joint>_y_m,<joint>_z_m,…`, then
/// one row per frame in metres in the world frame; a gap is three empty cells.
#[must_use]
pub(crate) fn csv_text(clip: &MotionClip) -> String {
    let mut out = String::new();
    push_header(&mut out, clip.joints());
    for f in 0..clip.frame_count() {
        push_row(
            &mut out,
            f,
            clip.rate_hz(),
            clip.joints().iter().map(|j| clip.position(f, *j)),
        );
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

/// A joint CSV written a few frames at a time, in exactly the format of [`write_csv`], for a
/// recording that must be on disk as it goes (a process killed mid-run leaves a file
/// [`read_csv`] reads, up to the last [`CsvAppender::flush`]).
#[derive(Debug)]
pub struct CsvAppender {
    path: std::path::PathBuf,
    file: std::fs::File,
    joints: Vec<Joint>,
    rate_hz: f64,
    frames: usize,
}

impl CsvAppender {
    /// Creates (or truncates) `path` and writes the header for `joints` at `rate_hz`.
    ///
    /// # Errors
    /// [`Error::Io`] if the file cannot be created or written.
    pub fn create(path: impl AsRef<Path>, joints: &[Joint], rate_hz: f64) -> Result<Self> {
        let path = path.as_ref().to_path_buf();
        let io = |source| Error::Io {
            path: path.clone(),
            source,
        };
        let file = std::fs::File::create(&path).map_err(io)?;
        let mut appender = Self {
            file,
            joints: joints.to_vec(),
            rate_hz,
            frames: 0,
            path: path.clone(),
        };
        let mut header = String::new();
        push_header(&mut header, joints);
        appender.write(&header)?;
        Ok(appender)
    }

    /// The columns, in order.
    #[must_use]
    pub fn joints(&self) -> &[Joint] {
        &self.joints
    }

    /// Frames written so far (the next frame's number).
    #[must_use]
    pub fn frames(&self) -> usize {
        self.frames
    }

    /// Appends the next frames, one row of cells (one per joint of [`Self::joints`]) each;
    /// missing trailing cells are gaps, extra cells are ignored.
    ///
    /// # Errors
    /// [`Error::Io`] if the file cannot be written.
    pub fn append(&mut self, rows: &[Vec<Option<Point3<f64>>>]) -> Result<()> {
        let mut text = String::new();
        for (i, row) in rows.iter().enumerate() {
            let cells = (0..self.joints.len()).map(|j| row.get(j).copied().flatten());
            push_row(&mut text, self.frames + i, self.rate_hz, cells);
        }
        self.write(&text)?;
        self.frames += rows.len();
        Ok(())
    }

    /// Hands what was appended to the operating system, so that it survives the process
    /// (a kill); it does not wait for the disk (no `fsync`: that can stall a live recorder for
    /// a tenth of a second, and a power cut is not what this guards against).
    ///
    /// # Errors
    /// [`Error::Io`] if the system refuses.
    pub fn flush(&mut self) -> Result<()> {
        use std::io::Write as _;
        self.file.flush().map_err(|source| Error::Io {
            path: self.path.clone(),
            source,
        })
    }

    fn write(&mut self, text: &str) -> Result<()> {
        use std::io::Write as _;
        self.file
            .write_all(text.as_bytes())
            .map_err(|source| Error::Io {
                path: self.path.clone(),
                source,
            })
    }
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
    // A spreadsheet's byte-order mark is not part of the first column's name.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty());
    let (_, header) = lines
        .next()
        .ok_or_else(|| csv_error(path, 1, "the file is empty"))?;
    let fields: Vec<&str> = header.split(',').map(str::trim).collect();
    if let Some(k) = fields.iter().position(|f| f.is_empty()) {
        return Err(csv_error(
            path,
            1,
            format!(
                "column {} of the header is empty{}",
                k + 1,
                if k + 1 == fields.len() {
                    " (a trailing comma?)"
                } else {
                    ""
                }
            ),
        ));
    }
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
        // A NaN coordinate is a gap, which the gait analysis counts and bridges; a time must be
        // a time.
        let number = |cell: &str| {
            cell.parse::<f64>()
                .map_err(|_| csv_error(path, line, format!("{cell:?} is not a number")))
        };
        let time = number(cells[1])?;
        if !time.is_finite() {
            return Err(csv_error(
                path,
                line,
                format!("time_s {:?} is not a finite number", cells[1]),
            ));
        }
        if let Some(&(before, _)) = times.last()
            && time <= before
        {
            return Err(csv_error(
                path,
                line,
                format!("time_s {time} after {before}: times must increase (a repeated row?)"),
            ));
        }
        times.push((time, line));
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
    let (Some(&(first, _)), Some(&(last, _))) = (times.first(), times.last()) else {
        return Err(csv_error(path, 2, "no data rows"));
    };
    if times.len() < 2 {
        return Err(csv_error(
            path,
            2,
            "need at least two rows with increasing time_s to know the rate",
        ));
    }
    // Rows are evenly spaced (a gap is a row of empty cells): a row off the grid would put
    // every later frame at the wrong time. The spacing is the median step, so that the row
    // named is the one off the grid (a clock that jumped) and not one the jump skews a mean
    // away from.
    let mut steps: Vec<f64> = times.windows(2).map(|p| p[1].0 - p[0].0).collect();
    steps.sort_by(f64::total_cmp);
    let step = steps[steps.len() / 2];
    for pair in times.windows(2) {
        let [(t0, _), (t1, line)] = [pair[0], pair[1]];
        if ((t1 - t0) - step).abs() > 0.01 * step + 2e-6 {
            return Err(csv_error(
                path,
                line,
                format!(
                    "time_s {t1} is {:.6} s after the row before, the file's rows are {step:.6} s \
                     apart (median): rows must be evenly spaced (a gap is a row of empty cells; \
                     a clock that jumped splits the file in two)",
                    t1 - t0
                ),
            ));
        }
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

    /// Appended a few frames at a time, the file is byte for byte what `write_csv` writes of
    /// the same clip, and `read_csv` reads it after every flush.
    #[test]
    fn appended_file_is_the_written_one() {
        let clip = MotionClip::new(
            "c",
            30.0,
            vec![Joint::KneeLeft, Joint::AnkleLeft],
            (0..7)
                .map(|f| {
                    let p = Point3::new(f as f64 * 0.05, 0.1, 0.4);
                    vec![Some(p), (f % 3 != 1).then_some(p)]
                })
                .collect(),
        )
        .unwrap();
        let dir = std::env::temp_dir().join(format!("trigait-csv-append-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("live.csv");
        let mut live = CsvAppender::create(&path, clip.joints(), clip.rate_hz()).unwrap();
        let rows: Vec<Vec<Option<Point3<f64>>>> = (0..7)
            .map(|f| clip.joints().iter().map(|j| clip.position(f, *j)).collect())
            .collect();
        for chunk in rows.chunks(3) {
            live.append(chunk).unwrap();
            live.flush().unwrap();
            if live.frames() >= 2 {
                assert_eq!(read_csv(&path).unwrap().frame_count(), live.frames());
            }
        }
        assert_eq!(std::fs::read_to_string(&path).unwrap(), csv_text(&clip));
        std::fs::remove_dir_all(&dir).ok();
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
        // A spreadsheet's byte-order mark is read past; a trailing comma is named.
        assert!(parse_csv(p, &format!("\u{feff}{header}\n0,0,1,2,3\n1,0.1,1,2,3")).is_ok());
        match parse_csv(p, &format!("{header},\n0,0,1,2,3,\n1,0.1,1,2,3,")) {
            Err(Error::Csv {
                line: 1, reason, ..
            }) => {
                assert!(reason.contains("trailing comma"), "{reason}");
            }
            other => panic!("{other:?}"),
        }
    }
}
