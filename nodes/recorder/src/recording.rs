//! The raw recording of the trial, in `OUTPUT_DIR`: every frame `sync` received
//! ([`trigait_recording::FRAMES_FILE`]), every fused pose with its absolute instant
//! ([`trigait_recording::POSES_FILE`]) and the rig ([`trigait_recording::RIG_FILE`]), so the
//! directory replays on its own (`kinect-source` `BACKEND: recording`, `trigait calibrate
//! --recording`). The rows are turned into lines on the event loop as they come ([`Lines`]) and
//! appended by the writer thread with the other live files ([`crate::writer`]), whole frames
//! and poses only.

use std::io::Write as _;
use std::path::{Path, PathBuf};

use eyre::Context;
use trigait_rig::Rig;
use trigait_schema::{FrameTiming, FusedPose};

/// One CSV file being appended.
#[derive(Debug)]
struct Appended {
    path: PathBuf,
    file: std::io::BufWriter<std::fs::File>,
}

impl Appended {
    fn create(path: PathBuf, header: &str) -> eyre::Result<Self> {
        let file =
            std::fs::File::create(&path).with_context(|| format!("creating {}", path.display()))?;
        let mut appended = Self {
            path,
            file: std::io::BufWriter::new(file),
        };
        appended.append(&format!("{header}\n"))?;
        Ok(appended)
    }

    /// Appends `text` and hands it to the operating system (no `fsync`, as
    /// `trigait_motion::CsvAppender::flush`).
    fn append(&mut self, text: &str) -> eyre::Result<()> {
        self.file
            .write_all(text.as_bytes())
            .and_then(|()| self.file.flush())
            .with_context(|| format!("appending to {}", self.path.display()))
    }
}

/// The lines of the recording not written yet: built on the event loop as the rows come,
/// written by the writer thread ([`Recording::append`]).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Lines {
    frames: String,
    poses: String,
}

impl Lines {
    /// Adds frames.
    pub fn push_frames(&mut self, rows: &[FrameTiming]) {
        for row in rows {
            trigait_recording::push_frame_lines(&mut self.frames, row);
        }
    }

    /// Adds a fused pose.
    pub fn push_pose(&mut self, pose: &FusedPose) {
        trigait_recording::push_pose_lines(&mut self.poses, pose);
    }

    /// Appends `newer`'s lines after these.
    pub fn absorb(&mut self, newer: Lines) {
        self.frames.push_str(&newer.frames);
        self.poses.push_str(&newer.poses);
    }
}

/// The recording's files.
#[derive(Debug)]
pub struct Recording {
    frames: Appended,
    poses: Appended,
}

impl Recording {
    /// Starts the recording in `dir` (replacing an earlier run's): `rig` written whole, the
    /// two CSV files with their headers.
    ///
    /// # Errors
    /// When a file cannot be created or written.
    pub fn start(dir: &Path, rig: &Rig) -> eyre::Result<Self> {
        let rig_path = dir.join(trigait_recording::RIG_FILE);
        let yaml = serde_yaml::to_string(&rig.to_rig_file()).context("serialising the rig")?;
        std::fs::write(&rig_path, yaml)
            .with_context(|| format!("writing {}", rig_path.display()))?;
        Ok(Self {
            frames: Appended::create(
                dir.join(trigait_recording::FRAMES_FILE),
                trigait_recording::FRAMES_HEADER,
            )?,
            poses: Appended::create(
                dir.join(trigait_recording::POSES_FILE),
                trigait_recording::POSES_HEADER,
            )?,
        })
    }

    /// Appends `lines` (whole frames and poses) and hands them to the operating system; what
    /// was written is taken out of `lines`, so after a failure they hold what is still to
    /// write.
    ///
    /// # Errors
    /// When a file cannot be written.
    pub fn append(&mut self, lines: &mut Lines) -> eyre::Result<()> {
        if !lines.frames.is_empty() {
            self.frames.append(&lines.frames)?;
            lines.frames.clear();
        }
        if !lines.poses.is_empty() {
            self.poses.append(&lines.poses)?;
            lines.poses.clear();
        }
        Ok(())
    }
}
