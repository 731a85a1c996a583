//! The raw recording of the trial, in `OUTPUT_DIR`: every frame `sync` received
//! ([`trigait_recording::FRAMES_FILE`]), every fused pose with its absolute instant
//! ([`trigait_recording::POSES_FILE`]) and the rig ([`trigait_recording::RIG_FILE`]), so the
//! directory replays on its own (`kinect-source` `BACKEND: recording`, `trigait calibrate
//! --recording`). The CSV files are appended as the rows come and flushed with the other live
//! files, whole frames and poses only.

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
    pending: String,
}

impl Appended {
    fn create(path: PathBuf, header: &str) -> eyre::Result<Self> {
        let file =
            std::fs::File::create(&path).with_context(|| format!("creating {}", path.display()))?;
        Ok(Self {
            path,
            file: std::io::BufWriter::new(file),
            pending: format!("{header}\n"),
        })
    }

    fn flush(&mut self) -> eyre::Result<()> {
        self.file
            .write_all(self.pending.as_bytes())
            .and_then(|()| self.file.flush())
            .with_context(|| format!("appending to {}", self.path.display()))?;
        self.pending.clear();
        Ok(())
    }
}

/// The recording being written.
#[derive(Debug)]
pub struct Recording {
    frames: Appended,
    poses: Appended,
}

impl Recording {
    /// Starts the recording in `dir` (replacing an earlier run's) with `rig` written whole.
    ///
    /// # Errors
    /// When a file cannot be created or written.
    pub fn start(dir: &Path, rig: &Rig) -> eyre::Result<Self> {
        let rig_path = dir.join(trigait_recording::RIG_FILE);
        let yaml = serde_yaml::to_string(&rig.to_rig_file()).context("serialising the rig")?;
        std::fs::write(&rig_path, yaml)
            .with_context(|| format!("writing {}", rig_path.display()))?;
        let mut recording = Self {
            frames: Appended::create(
                dir.join(trigait_recording::FRAMES_FILE),
                trigait_recording::FRAMES_HEADER,
            )?,
            poses: Appended::create(
                dir.join(trigait_recording::POSES_FILE),
                trigait_recording::POSES_HEADER,
            )?,
        };
        recording.flush()?;
        Ok(recording)
    }

    /// Adds frames (written at the next [`Self::flush`]).
    pub fn push_frames(&mut self, rows: &[FrameTiming]) {
        for row in rows {
            trigait_recording::push_frame_lines(&mut self.frames.pending, row);
        }
    }

    /// Adds a fused pose (written at the next [`Self::flush`]).
    pub fn push_pose(&mut self, pose: &FusedPose) {
        trigait_recording::push_pose_lines(&mut self.poses.pending, pose);
    }

    /// Appends what was added since the last flush and makes it durable.
    ///
    /// # Errors
    /// When a file cannot be written.
    pub fn flush(&mut self) -> eyre::Result<()> {
        self.frames.flush()?;
        self.poses.flush()
    }
}
