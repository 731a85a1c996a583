//! What the recorder writes of the fused joints: the thesis-style ring buffer (1000 positions
//! per joint, thesis §6.4.5) as a whitespace text file like the thesis's, and the whole run as a
//! motion (CSV, TRC, C3D) through `trigait-motion`, so that the CLI reads it back, and its gait
//! report (`report.html`, the page `trigait report` writes, made by `trigait-gait`).
//!
//! While the run goes, `trajectory.csv` is appended ([`LiveTrajectory`] on the event loop hands
//! the new frames to [`LiveCsv`] on the writer thread, [`crate::writer`]) and `summary.json`
//! rewritten, so a recorder killed mid-run leaves both behind, up to the last update; at the
//! end every file is written whole.

use std::collections::{BTreeMap, VecDeque};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use eyre::Context;
use nalgebra::Point3;
use tracing::warn;
use trigait_fusion::{FrameGrid, Trajectory};
use trigait_motion::CsvAppender;
use trigait_schema::FusedPose;
use trigait_skeleton::Joint;

/// One buffered position.
#[derive(Debug, Clone, PartialEq)]
pub struct Entry {
    /// Aligned-set sequence number.
    pub set_seq: u64,
    /// Fusion instant, server clock, ns.
    pub stamp_nanos: i64,
    /// World position, m.
    pub position: Point3<f64>,
    /// √trace of the covariance, m.
    pub sigma_m: f64,
    /// Sensors used.
    pub sensors_used: Vec<String>,
}

/// Positions per joint, the oldest dropped beyond `capacity`.
#[derive(Debug, Clone)]
pub struct Ring {
    capacity: usize,
    joints: BTreeMap<Joint, VecDeque<Entry>>,
}

impl Ring {
    /// An empty buffer keeping `capacity` positions per joint.
    #[must_use]
    pub fn new(capacity: usize) -> Self {
        Self {
            capacity: capacity.max(1),
            joints: BTreeMap::new(),
        }
    }

    /// Adds every fused joint of `pose`.
    pub fn push(&mut self, pose: &FusedPose) {
        for (joint, fused) in &pose.joints {
            let q = self.joints.entry(*joint).or_default();
            if q.len() == self.capacity {
                q.pop_front();
            }
            q.push_back(Entry {
                set_seq: pose.set_seq,
                stamp_nanos: pose.stamp_nanos,
                position: fused.position,
                sigma_m: fused.covariance.trace().max(0.0).sqrt(),
                sensors_used: fused.sensors_used.clone(),
            });
        }
    }

    /// Positions held for `joint`.
    #[cfg(test)]
    #[must_use]
    pub fn len(&self, joint: Joint) -> usize {
        self.joints.get(&joint).map_or(0, VecDeque::len)
    }

    /// The thesis text file: a header, then one line per instant — time in seconds from the
    /// first, then x y z (m, world frame) of each joint in column order (`nan` where a joint
    /// was not fused at that instant).
    #[must_use]
    pub fn thesis_text(&self) -> String {
        let joints: Vec<Joint> = self.joints.keys().copied().collect();
        let mut by_instant: BTreeMap<(i64, u64), BTreeMap<Joint, Point3<f64>>> = BTreeMap::new();
        for (joint, q) in &self.joints {
            for e in q {
                by_instant
                    .entry((e.stamp_nanos, e.set_seq))
                    .or_default()
                    .insert(*joint, e.position);
            }
        }
        let mut out = format!("{}\n", trigait_motion::THESIS_TEXT_HEADER);
        out.push_str("# world frame, metres; columns: t_secs");
        for j in &joints {
            write!(out, " {0}_x {0}_y {0}_z", j.name()).ok();
        }
        out.push('\n');
        let t0 = by_instant.keys().next().map_or(0, |(t, _)| *t);
        for ((t, _), row) in &by_instant {
            write!(out, "{:.6}", (t - t0) as f64 * 1e-9).ok();
            for j in &joints {
                match row.get(j) {
                    Some(p) => write!(out, " {:.6} {:.6} {:.6}", p.x, p.y, p.z).ok(),
                    None => write!(out, " nan nan nan").ok(),
                };
            }
            out.push('\n');
        }
        out
    }

    /// Writes `trajectory.txt` into `dir`.
    pub fn write(&self, dir: &Path) -> eyre::Result<()> {
        let txt = dir.join("trajectory.txt");
        std::fs::write(&txt, self.thesis_text())
            .with_context(|| format!("writing {}", txt.display()))?;
        Ok(())
    }
}

/// The files [`write_trajectory`] writes, in `OUTPUT_DIR`.
pub const TRAJECTORY_FILES: [&str; 4] = [
    "trajectory.csv",
    "trajectory.trc",
    "trajectory.c3d",
    REPORT_FILE,
];

/// The gait report of the run, in `OUTPUT_DIR`.
pub const REPORT_FILE: &str = "report.html";

/// Writes the whole run's fused joints through `trigait-motion` as `trajectory.csv` (the CSV
/// `trigait gait` and `trigait export` read), `trajectory.trc` and `trajectory.c3d`, and their
/// gait report as [`REPORT_FILE`] (what `trigait report out/trajectory.csv` gives). A run with
/// too few poses for a frame rate writes none of them (and removes those of an earlier run,
/// so no stale file is taken for this run's) and says why.
///
/// # Errors
/// When a file cannot be written or removed.
pub fn write_trajectory(dir: &Path, trajectory: &Trajectory) -> eyre::Result<()> {
    let clip = match trajectory.to_clip("trigait fused joints") {
        Ok(clip) => clip,
        Err(e) => {
            warn!("no trajectory files written: {e}");
            for name in TRAJECTORY_FILES {
                let path = dir.join(name);
                if path.exists() {
                    std::fs::remove_file(&path)
                        .with_context(|| format!("removing the stale {}", path.display()))?;
                }
            }
            return Ok(());
        }
    };
    let [csv, trc, c3d, report] = TRAJECTORY_FILES.map(|name| dir.join(name));
    trigait_motion::write_csv(&csv, &clip)?;
    trigait_motion::write_trc(&trc, &clip)?;
    trigait_motion::write_c3d(&c3d, &clip)?;
    std::fs::write(&report, gait_report(&clip))
        .with_context(|| format!("writing {}", report.display()))?;
    Ok(())
}

/// The gait report page of the run's fused joints, analysed as the live analysis does
/// ([`crate::gait::gait_params`]); a run without gait parameters gets a page that says why.
fn gait_report(clip: &trigait_skeleton::MotionClip) -> String {
    let title = "trigait graph run: fused joints (trajectory.csv)";
    let notes = [format!(
        "fused joints of the graph run: {} frames at {:.1} Hz",
        clip.frame_count(),
        clip.rate_hz()
    )];
    let recorder = crate::gait::gait_params();
    let params = trigait_gait::GaitParams {
        filter: recorder.filter.or_none_at(clip.rate_hz()),
        ..recorder
    };
    let page = trigait_gait::Landmarks::from_clip(clip)
        .and_then(|l| trigait_gait::analyse_landmarks(&l, &params))
        .and_then(|a| {
            let filter = params.filter.to_string();
            trigait_gait::report::html(title, &filter, &notes, clip, &a)
        });
    page.unwrap_or_else(|e| {
        warn!("the gait report has no parameters: {e}");
        trigait_gait::report::html_without_analysis(title, &e.to_string(), &notes)
    })
}

/// `summary.json` written whole or not at all (a temporary file renamed over it), so a
/// reader, or a kill in the middle of the write, never meets half a file.
///
/// # Errors
/// When the file cannot be written or renamed.
pub fn write_summary(dir: &Path, summary: &crate::stats::Summary) -> eyre::Result<PathBuf> {
    let path = dir.join("summary.json");
    let tmp = dir.join(".summary.json.partial");
    let json = serde_json::to_string_pretty(summary).context("serialising the summary")?;
    std::fs::write(&tmp, json).with_context(|| format!("writing {}", tmp.display()))?;
    std::fs::rename(&tmp, &path).with_context(|| format!("renaming to {}", path.display()))?;
    Ok(path)
}

/// Removes the summary and trajectory files of an earlier run from `dir`, so that none is
/// taken for this run's before this run's first update.
///
/// # Errors
/// When an old file cannot be removed.
pub fn clear_earlier_run(dir: &Path) -> eyre::Result<()> {
    for name in TRAJECTORY_FILES
        .iter()
        .chain(&["summary.json", "trajectory.txt"])
    {
        let path = dir.join(name);
        if path.exists() {
            std::fs::remove_file(&path)
                .with_context(|| format!("removing the earlier run's {}", path.display()))?;
        }
    }
    Ok(())
}

/// Frames of `trajectory.csv` to append: `rows` are frames `first_frame…` on the grid whose
/// columns and rate `start` gives in the first batch of the run (the file's header).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CsvRows {
    /// The columns and the frame rate, Hz, in the batch that starts the file.
    pub start: Option<(Vec<Joint>, f64)>,
    /// The frame number of `rows[0]`.
    pub first_frame: usize,
    /// One row of cells (one per column) per frame.
    pub rows: Vec<Vec<Option<Point3<f64>>>>,
}

impl CsvRows {
    /// Appends `newer`'s frames (the ones after these) after these.
    pub fn absorb(&mut self, newer: CsvRows) {
        if self.start.is_none() && self.rows.is_empty() {
            self.first_frame = newer.first_frame;
        }
        debug_assert!(
            newer.rows.is_empty() || newer.first_frame == self.first_frame + self.rows.len(),
            "trajectory rows are handed on in order"
        );
        self.start = self.start.take().or(newer.start);
        self.rows.extend(newer.rows);
    }
}

/// The event loop's side of the live `trajectory.csv`: which frames were handed to the writer
/// thread already.
#[derive(Debug, Default)]
pub struct LiveTrajectory {
    grid: Option<FrameGrid>,
    frames: usize,
    warned_new_joint: bool,
}

impl LiveTrajectory {
    /// The frames fused since the last call ([`Trajectory::rows_from`]: the new poses only).
    /// The file starts once two poses give the frame rate; its columns are the joints fused by
    /// then (one fused only later is in the files written at the end).
    pub fn take_rows(&mut self, trajectory: &Trajectory) -> CsvRows {
        let mut start = None;
        if self.grid.is_none() {
            let Ok(grid) = trajectory.grid() else {
                return CsvRows::default();
            };
            start = Some((grid.joints.clone(), grid.rate_hz()));
            self.grid = Some(grid);
        }
        let Some(grid) = &self.grid else {
            return CsvRows::default();
        };
        let rows = match trajectory.rows_from(grid, self.frames) {
            Ok(rows) => rows,
            Err(e) => {
                warn!("trajectory.csv is not extended while the run goes: {e}");
                Vec::new()
            }
        };
        if !self.warned_new_joint
            && let Some(new) = trajectory
                .joints()
                .iter()
                .find(|j| !grid.joints.contains(j))
        {
            self.warned_new_joint = true;
            warn!(
                joint = new.name(),
                "a joint first fused after trajectory.csv's columns were fixed: it is in the files written at the end"
            );
        }
        let first_frame = self.frames;
        self.frames += rows.len();
        CsvRows {
            start,
            first_frame,
            rows,
        }
    }
}

/// The writer thread's side of the live `trajectory.csv`.
#[derive(Debug)]
pub struct LiveCsv {
    path: PathBuf,
    csv: Option<CsvAppender>,
}

impl LiveCsv {
    /// `trajectory.csv` in `dir`, created by the first [`Self::append`] that starts it.
    #[must_use]
    pub fn new(dir: &Path) -> Self {
        Self {
            path: dir.join("trajectory.csv"),
            csv: None,
        }
    }

    /// Appends `rows` and hands them to the operating system (no `fsync`: see
    /// [`CsvAppender::flush`]). What was written is taken out of `rows`, so after a failure
    /// they hold what is still to write.
    ///
    /// # Errors
    /// When the file cannot be created or written.
    pub fn append(&mut self, rows: &mut CsvRows) -> eyre::Result<()> {
        if self.csv.is_none() {
            let Some((joints, rate_hz)) = &rows.start else {
                return Ok(());
            };
            self.csv = Some(CsvAppender::create(&self.path, joints, *rate_hz)?);
            rows.start = None;
        }
        let Some(csv) = &mut self.csv else {
            return Ok(());
        };
        if rows.rows.is_empty() {
            // Nothing new (the run's last update carries only the raw recording's lines).
            return Ok(());
        }
        if rows.first_frame != csv.frames() {
            warn!(
                "trajectory.csv has {} frames but the next rows start at frame {}: not extended while the run goes",
                csv.frames(),
                rows.first_frame
            );
            *rows = CsvRows::default();
            return Ok(());
        }
        csv.append(&rows.rows)?;
        csv.flush()?;
        rows.first_frame += rows.rows.len();
        rows.rows.clear();
        Ok(())
    }
}
