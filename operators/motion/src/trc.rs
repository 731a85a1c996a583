//! TRC (track row column) files, the marker format OpenSim reads.
//!
//! c3dio writes TRC but does not read it, so the reader is ours. Layout (the OpenSim / Motion
//! Analysis convention):
//!
//! ```text
//! 1  PathFileType  4  (X/Y/Z)  <file>
//! 2  DataRate  CameraRate  NumFrames  NumMarkers  Units  OrigDataRate ...   (keys)
//! 3  100.0     100.0       238        41          mm     100.0 ...          (values)
//! 4  Frame#  Time  R.Shoulder  <empty> <empty>  L.Shoulder ...
//! 5          X1 Y1 Z1 X2 Y2 Z2 ...
//! 6  (often blank)
//! 7  1  0.00000  -652.630  1529.542  -94.520 ...
//! ```
//!
//! Fields are tab-separated and may be padded with spaces; key and value lines need not line up
//! column by column (the shared file pads values with empty columns), so keys and values are paired
//! in order after dropping empty fields. An empty coordinate is a gap. TRC is Y up; our world is Z
//! up, so (X, Y, Z)_trc ↦ (X, −Z, Y) and back.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use nalgebra::Point3;
use trigait_skeleton::MotionClip;

use crate::{Error, MarkerSet, Result};

/// Metres per unit of a length unit as written in TRC or C3D headers.
pub(crate) fn metres_per_unit(units: &str) -> Option<f64> {
    match units.trim().to_ascii_lowercase().as_str() {
        "mm" | "millimeters" | "millimetres" => Some(1e-3),
        "cm" | "centimeters" | "centimetres" => Some(1e-2),
        "m" | "meters" | "metres" => Some(1.0),
        _ => None,
    }
}

fn trc_error(path: &Path, line: usize, reason: impl Into<String>) -> Error {
    Error::Trc {
        path: path.to_path_buf(),
        line,
        reason: reason.into(),
    }
}

fn non_empty_fields(line: &str) -> Vec<&str> {
    line.split('\t')
        .map(str::trim)
        .filter(|f| !f.is_empty())
        .collect()
}

/// Reads a TRC file into a [`MarkerSet`] in metres, Z up.
///
/// Honours the `Units` (mm, cm or m) and `DataRate` headers, both required. Empty cells and
/// `NaN` are gaps.
///
/// # Errors
/// [`Error::Io`] if the file cannot be read; [`Error::Trc`] with the line number for a malformed
/// header or data line; [`Error::UnknownUnits`]; [`Error::Truncated`] when fewer rows than
/// `NumFrames` are present or the last row is cut off.
pub fn read_trc(path: impl AsRef<Path>) -> Result<MarkerSet> {
    let path = path.as_ref();
    let bytes =
        trigait_input_limits::read_bounded(path, crate::MAX_MOTION_FILE_BYTES, "motion file")
            .map_err(|source| Error::Io {
                path: path.to_path_buf(),
                source,
            })?;
    let text = String::from_utf8_lossy(&bytes);
    parse_trc(path, &text)
}

fn parse_trc(path: &Path, text: &str) -> Result<MarkerSet> {
    let lines: Vec<&str> = text.lines().collect();
    let line = |i: usize| lines.get(i).copied();

    // Line 1: file type.
    match line(0) {
        Some(l) if l.trim_start().starts_with("PathFileType") => {}
        _ => return Err(trc_error(path, 1, "expected a `PathFileType` header line")),
    }

    // Lines 2–3: header keys and values.
    let keys = non_empty_fields(line(1).ok_or_else(|| trc_error(path, 2, "missing header keys"))?);
    let values =
        non_empty_fields(line(2).ok_or_else(|| trc_error(path, 3, "missing header values"))?);
    if keys.len() != values.len() {
        return Err(trc_error(
            path,
            3,
            format!("{} header values for {} keys", values.len(), keys.len()),
        ));
    }
    let header = |key: &str| {
        keys.iter()
            .position(|k| k.eq_ignore_ascii_case(key))
            .map(|i| values[i])
    };
    let rate_hz: f64 = header("DataRate")
        .ok_or_else(|| trc_error(path, 2, "no DataRate in the header"))?
        .parse()
        .map_err(|_| trc_error(path, 3, "DataRate is not a number"))?;
    if !(rate_hz.is_finite() && rate_hz > 0.0) {
        return Err(trc_error(
            path,
            3,
            format!("DataRate must be positive, got {rate_hz}"),
        ));
    }
    let units = header("Units").ok_or_else(|| trc_error(path, 2, "no Units in the header"))?;
    let scale = metres_per_unit(units).ok_or_else(|| Error::UnknownUnits {
        path: path.to_path_buf(),
        units: units.to_string(),
    })?;
    let num_frames: Option<usize> = match header("NumFrames") {
        Some(v) => Some(
            v.parse()
                .map_err(|_| trc_error(path, 3, format!("NumFrames {v:?} is not a count")))?,
        ),
        None => None,
    };
    let num_markers: Option<usize> = match header("NumMarkers") {
        Some(v) => Some(
            v.parse()
                .map_err(|_| trc_error(path, 3, format!("NumMarkers {v:?} is not a count")))?,
        ),
        None => None,
    };

    // Line 4: labels, each followed by empty columns.
    let label_fields =
        non_empty_fields(line(3).ok_or_else(|| trc_error(path, 4, "missing marker labels"))?);
    if label_fields.len() < 2 || !label_fields[0].eq_ignore_ascii_case("Frame#") {
        return Err(trc_error(path, 4, "expected `Frame#  Time  <labels>`"));
    }
    let labels: Vec<String> = label_fields[2..].iter().map(|s| s.to_string()).collect();
    if let Some(n) = num_markers
        && n != labels.len()
    {
        return Err(trc_error(
            path,
            4,
            format!(
                "header announces {n} markers but {} labels follow",
                labels.len()
            ),
        ));
    }
    // Line 5: X1 Y1 Z1 … (not needed beyond its presence).
    if line(4).is_none() {
        return Err(Error::Truncated {
            path: path.to_path_buf(),
            expected: num_frames.unwrap_or(1),
            got: 0,
        });
    }

    let ends_with_newline = text.ends_with('\n');
    let data_lines: Vec<(usize, &str)> = lines
        .iter()
        .enumerate()
        .skip(5)
        .filter(|(_, l)| !l.trim().is_empty())
        .map(|(i, l)| (i + 1, *l))
        .collect();
    let columns = 2 + 3 * labels.len();
    // A row may stop early (its missing cells are gaps), so the cells are bounded by the file's
    // size rather than by its rows: at most one cell per byte of the file.
    let cells = data_lines.len().saturating_mul(labels.len());
    if cells > text.len() {
        return Err(trc_error(
            path,
            6,
            format!(
                "{} rows of {} markers ({cells} cells) are more than a file of {} bytes can \
                 hold; rows this short are not marker data",
                data_lines.len(),
                labels.len(),
                text.len()
            ),
        ));
    }
    let mut frames = Vec::with_capacity(data_lines.len());
    let mut last_time: Option<f64> = None;
    // (row index, line, time) of the first timed row, to check the Time column's rate.
    let mut first_time: Option<(usize, usize, f64)> = None;
    for (k, (line_no, l)) in data_lines.iter().enumerate() {
        let fields: Vec<&str> = l.split('\t').map(str::trim).collect();
        let is_last = k + 1 == data_lines.len();
        if is_last && !ends_with_newline && fields.len() < columns {
            if num_frames.is_some_and(|n| k >= n) {
                // Past the announced frames: not a cut-off frame but something appended.
                return Err(trc_error(
                    path,
                    *line_no,
                    format!(
                        "a partial row of {} fields after the {k} frames the header announces",
                        fields.len()
                    ),
                ));
            }
            // The file stops in the middle of a row.
            return Err(Error::Truncated {
                path: path.to_path_buf(),
                expected: num_frames.unwrap_or(data_lines.len()),
                got: k,
            });
        }
        if let Some(n) = num_frames
            && k == n
        {
            return Err(trc_error(
                path,
                *line_no,
                format!(
                    "{} rows, more than the {n} frames the header announces (a repeated row, or \
                     a wrong NumFrames)",
                    data_lines.len()
                ),
            ));
        }
        if fields.len() > columns && fields[columns..].iter().any(|f| !f.is_empty()) {
            return Err(trc_error(
                path,
                *line_no,
                format!(
                    "{} fields, more than the {columns} the labels allow",
                    fields.len()
                ),
            ));
        }
        if fields.first().is_none_or(|f| f.parse::<f64>().is_err()) {
            return Err(trc_error(
                path,
                *line_no,
                "row does not start with a frame number",
            ));
        }
        if let Some(time) = fields.get(1).and_then(|f| f.parse::<f64>().ok()) {
            if let Some(before) = last_time
                && time <= before
            {
                return Err(trc_error(
                    path,
                    *line_no,
                    format!("time {time} after {before}: times must increase (a repeated row?)"),
                ));
            }
            // The last digit written may round a step by up to one unit of it.
            let resolution = fields[1]
                .split_once('.')
                .map_or(1.0, |(_, d)| 10_f64.powi(-(d.len().min(12) as i32)));
            if let Some(before) = last_time
                && time - before > MAX_TIME_STEP_FRAMES / rate_hz + resolution
            {
                return Err(trc_error(
                    path,
                    *line_no,
                    format!(
                        "time {time} s after {before} s: a jump of {:.0} frames at the {rate_hz} Hz \
                         of DataRate (rows missing?); rows must follow each other evenly",
                        (time - before) * rate_hz
                    ),
                ));
            }
            first_time.get_or_insert((k, *line_no, time));
            if let Some((k0, line0, t0)) = first_time
                && k > k0
            {
                check_time_rate(path, (k0, line0, t0), (k, *line_no, time), rate_hz)?;
            }
            last_time = Some(time);
        }
        let mut row = Vec::with_capacity(labels.len());
        for (m, label) in labels.iter().enumerate() {
            let mut xyz = [0.0; 3];
            let mut gap = false;
            for (a, value) in xyz.iter_mut().enumerate() {
                let field = fields.get(2 + 3 * m + a).copied().unwrap_or("");
                if field.is_empty() {
                    gap = true;
                    continue;
                }
                *value = field.parse::<f64>().map_err(|_| {
                    trc_error(
                        path,
                        *line_no,
                        format!(
                            "{} of {} is not a number: {field:?}",
                            ["X", "Y", "Z"][a],
                            label
                        ),
                    )
                })?;
            }
            row.push((!gap).then(|| Point3::new(xyz[0] * scale, -xyz[2] * scale, xyz[1] * scale)));
        }
        frames.push(row);
    }
    if let Some(expected) = num_frames
        && frames.len() < expected
    {
        return Err(Error::Truncated {
            path: path.to_path_buf(),
            expected,
            got: frames.len(),
        });
    }
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_string())
        .unwrap_or_default();
    MarkerSet::new(name, rate_hz, labels, frames)
}

/// Most frames of `DataRate` between two rows' times before rows count as missing, beyond the
/// rounding of the time's last digit (at 90 Hz to two decimals, steps of 0.01 and 0.02 s
/// alternate).
const MAX_TIME_STEP_FRAMES: f64 = 1.5;

/// Most relative difference between `DataRate` and the rate the Time column advances at over
/// the rows read so far; only checked over at least a second (a step's rounding then counts
/// for little).
const MAX_TIME_RATE_MISMATCH: f64 = 0.02;

/// Whether the Time column from `first` to `now` (row index, line, time) advances at the
/// `rate_hz` the header declares; a header that says 50 Hz over times 10 ms apart would halve
/// every duration read from the file.
fn check_time_rate(
    path: &Path,
    (k0, _, t0): (usize, usize, f64),
    (k, line_no, t): (usize, usize, f64),
    rate_hz: f64,
) -> Result<()> {
    let span = t - t0;
    if span < 1.0 {
        return Ok(());
    }
    let column_hz = (k - k0) as f64 / span;
    if (column_hz / rate_hz - 1.0).abs() > MAX_TIME_RATE_MISMATCH {
        return Err(trc_error(
            path,
            line_no,
            format!(
                "DataRate says {rate_hz} Hz but the Time column advances at {column_hz:.2} Hz \
                 ({} rows in {span:.3} s): which is the file's rate?",
                k - k0 + 1
            ),
        ));
    }
    Ok(())
}

/// Formats a rate to at most six decimals, whole numbers with one (`100.0`), as OpenSim writes
/// them: a rate measured on a clock (30.000000300000004 Hz) reads as the 30.0 it is.
fn rate_text(rate_hz: f64) -> String {
    let text = format!("{rate_hz:.6}");
    let text = text.trim_end_matches('0');
    if text.ends_with('.') {
        format!("{text}0")
    } else {
        text.to_owned()
    }
}

/// The TRC text of `clip`: millimetres, Y up, one marker per joint named by [`Joint::name`].
///
/// [`Joint::name`]: trigait_skeleton::Joint::name
#[must_use]
pub(crate) fn trc_text(file_name: &str, clip: &MotionClip) -> String {
    let joints = clip.joints();
    let n = clip.frame_count();
    let rate = rate_text(clip.rate_hz());
    let mut out = String::new();
    // Writing into a String cannot fail.
    let _ = writeln!(out, "PathFileType\t4\t(X/Y/Z)\t{file_name}");
    let _ = writeln!(
        out,
        "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tOrigDataRate\tOrigDataStartFrame\tOrigNumFrames"
    );
    let _ = writeln!(
        out,
        "{rate}\t{rate}\t{n}\t{}\tmm\t{rate}\t1\t{n}",
        joints.len()
    );
    out.push_str("Frame#\tTime");
    for j in joints {
        let _ = write!(out, "\t{}\t\t", j.name());
    }
    out.push('\n');
    out.push('\t');
    for i in 1..=joints.len() {
        let _ = write!(out, "\tX{i}\tY{i}\tZ{i}");
    }
    out.push_str("\n\n");
    for f in 0..n {
        let _ = write!(out, "{}\t{:.5}", f + 1, f as f64 / clip.rate_hz());
        for j in joints {
            match clip.position(f, *j) {
                Some(p) => {
                    let _ = write!(
                        out,
                        "\t{:.5}\t{:.5}\t{:.5}",
                        p.x * 1e3,
                        p.z * 1e3,
                        -p.y * 1e3
                    );
                }
                None => out.push_str("\t\t\t"),
            }
        }
        out.push('\n');
    }
    out
}

/// Writes `clip` as an OpenSim-readable TRC file: millimetres, Y up (the inverse of [`read_trc`]'s
/// frame change), one marker per joint named by its snake_case name, gaps as empty cells.
///
/// # Errors
/// [`Error::Io`] if the file cannot be written.
pub fn write_trc(path: impl AsRef<Path>, clip: &MotionClip) -> Result<()> {
    let path = path.as_ref();
    let file_name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_string())
        .unwrap_or_default();
    std::fs::write(path, trc_text(&file_name, clip)).map_err(|source| Error::Io {
        path: PathBuf::from(path),
        source,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = "PathFileType\t4\t(X/Y/Z)\tx.trc\n\
DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\n\
 50.0\t\t 50.0\t\t 2\t\t 2\t\t m\n\
Frame#\tTime\tA\t\t\tB\t\t\n\
\t\tX1\tY1\tZ1\tX2\tY2\tZ2\n\
\n\
1\t0.0\t1.0\t2.0\t3.0\t\t\t\n\
2\t0.02\t1.5\t2.5\t3.5\t4\t5\t6\n";

    /// Header values are paired with keys across padding columns; units and the Y-up frame are
    /// converted; empty cells are gaps.
    #[test]
    fn parses_padded_header_and_gaps() {
        let set = parse_trc(Path::new("x.trc"), GOOD).unwrap();
        assert_eq!(set.rate_hz(), 50.0);
        assert_eq!(set.labels(), ["A", "B"]);
        assert_eq!(set.frame_count(), 2);
        assert_eq!(set.position(0, "A"), Some(Point3::new(1.0, -3.0, 2.0)));
        assert_eq!(set.position(0, "B"), None);
        assert_eq!(set.position(1, "B"), Some(Point3::new(4.0, -6.0, 5.0)));
        assert_eq!(set.gaps().len(), 1);
    }

    /// Missing rows, cut-off rows and non-numbers are typed errors with line numbers.
    #[test]
    fn malformed_is_typed() {
        let short = GOOD.replace("2\t0.02\t1.5\t2.5\t3.5\t4\t5\t6\n", "");
        assert!(matches!(
            parse_trc(Path::new("x.trc"), &short),
            Err(Error::Truncated {
                expected: 2,
                got: 1,
                ..
            })
        ));
        let cut = GOOD.trim_end_matches("\t5\t6\n");
        assert!(matches!(
            parse_trc(Path::new("x.trc"), cut),
            Err(Error::Truncated { got: 1, .. })
        ));
        let bad = GOOD.replace("2.5", "two");
        assert!(matches!(
            parse_trc(Path::new("x.trc"), &bad),
            Err(Error::Trc { line: 8, .. })
        ));
        let no_units = GOOD
            .replace("\tNumMarkers\tUnits\n", "\tNumMarkers\n")
            .replace("\t\t m\n", "\n");
        assert!(matches!(
            parse_trc(Path::new("x.trc"), &no_units),
            Err(Error::Trc { line: 2, .. })
        ));
        let furlongs = GOOD.replace(" m\n", " furlong\n");
        assert!(matches!(
            parse_trc(Path::new("x.trc"), &furlongs),
            Err(Error::UnknownUnits { .. })
        ));
        assert!(matches!(
            parse_trc(Path::new("x.trc"), "hello\nworld\n"),
            Err(Error::Trc { line: 1, .. })
        ));
    }

    /// A TRC of `frames` rows, `step_secs` apart in the Time column written to `decimals`,
    /// under a `DataRate` of `rate_hz`; rows whose index `skip` holds are left out.
    fn timed(
        rate_hz: f64,
        frames: usize,
        step_secs: f64,
        skip: &[usize],
        decimals: usize,
    ) -> String {
        let kept: Vec<usize> = (0..frames).filter(|k| !skip.contains(k)).collect();
        let mut text = format!(
            "PathFileType\t4\t(X/Y/Z)\tx.trc\nDataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\n\
             {rate_hz}\t{rate_hz}\t{}\t1\tmm\nFrame#\tTime\tA\t\t\n\t\tX1\tY1\tZ1\n\n",
            kept.len()
        );
        for k in kept {
            text += &format!("{}\t{:.decimals$}\t1\t2\t3\n", k + 1, k as f64 * step_secs);
        }
        text
    }

    #[test]
    fn rates_are_written_as_people_write_them() {
        assert_eq!(rate_text(100.0), "100.0");
        assert_eq!(rate_text(30.000000300000004), "30.0");
        assert_eq!(rate_text(29.97), "29.97");
        assert_eq!(rate_text(1.0 / 3.0), "0.333333");
    }

    /// The Time column is the file's clock too: a header rate it does not keep, or rows missing
    /// from it, are errors that say so, instead of durations read wrong.
    #[test]
    fn the_time_column_keeps_the_data_rate() {
        let read = |text: &str| parse_trc(Path::new("x.trc"), text);
        // 120 Hz written to five decimals, and to three (steps of 8 and 9 ms alternate).
        for (rate, decimals) in [(120.0, 5), (120.0, 3), (90.0, 2), (1000.0, 3)] {
            let set = read(&timed(rate, 600, 1.0 / rate, &[], decimals)).unwrap();
            assert_eq!(set.frame_count(), 600, "{rate} Hz to {decimals} decimals");
        }
        let halved = read(&timed(50.0, 300, 0.01, &[], 5))
            .unwrap_err()
            .to_string();
        assert!(
            halved.contains("DataRate says 50 Hz") && halved.contains("100.00 Hz"),
            "{halved}"
        );
        let holed = read(&timed(100.0, 300, 0.01, &(100..131).collect::<Vec<_>>(), 5))
            .unwrap_err()
            .to_string();
        assert!(holed.contains("a jump of 32 frames"), "{holed}");
    }
}
