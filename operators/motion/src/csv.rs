//! Plain CSV export of a [`MotionClip`], for spreadsheets and quick plots.

use std::fmt::Write as _;
use std::path::Path;

use trigait_skeleton::MotionClip;

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

#[cfg(test)]
mod tests {
    use nalgebra::Point3;
    use trigait_skeleton::Joint;

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
