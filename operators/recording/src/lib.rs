//! The recording of a trial: every raw skeleton frame each sensor sent, with its sensor-local
//! stamp and where `sync` placed it on the server clock, so the trial can be replayed through
//! any graph (re-synchronised, or on the recorded server times for a bit-identical re-run),
//! recalibrated or re-analysed; and the fused poses with their absolute instants, so two runs
//! can be compared instant by instant.
//!
//! A recording is a directory (the recorder's `OUTPUT_DIR`):
//!
//! - [`FRAMES_FILE`] (`frames.csv`): one line per joint sample of every frame, in the order
//!   `sync` received the frames, columns [`FRAMES_HEADER`]. A frame is the run of consecutive
//!   lines with the same `sensor_id`, `seq` and `local_stamp_nanos`; a frame without joints is
//!   one line with the joint columns empty. Empty optional cells: not known (a frame that
//!   arrived before its sensor's clock was synchronised has no server stamp; `true_stamp_nanos`
//!   is known in simulation only). Numbers are written so they read back bit for bit.
//! - [`POSES_FILE`] (`poses.csv`): one line per fused joint, columns [`POSES_HEADER`].
//! - [`RIG_FILE`] (`rig.yml`): the rig the trial ran with (a rig file the graphs read).
//!
//! Both CSV files are appended while the run goes (whole frames and poses only), so a recorder
//! killed mid-run leaves a readable prefix; a line cut off mid-write (no end of line) or any
//! malformed cell is an error naming the file and the line.

use std::io::BufRead as _;
use std::path::Path;

use nalgebra::Point3;
use trigait_schema::{FrameTiming, FusedPose};
use trigait_skeleton::{Joint, JointSample, TrackingState};

/// The raw frames of a recording.
pub const FRAMES_FILE: &str = "frames.csv";
/// The fused poses of a recording.
pub const POSES_FILE: &str = "poses.csv";
/// The rig of a recording.
pub const RIG_FILE: &str = "rig.yml";

/// Columns of [`FRAMES_FILE`]: sensor id; frame counter; capture stamp on the sensor clock (ns);
/// the same mapped to the server clock by `sync` (ns) and its uncertainty (ns); the clock
/// filter's offset (sensor − server, ns) and drift (ppm) then; the true capture instant on the
/// server clock (ns, simulation only); the joint (snake_case name); its position in Kinect
/// camera space (m); its tracking state (SDK number: 0 not tracked, 1 inferred, 2 tracked).
pub const FRAMES_HEADER: &str = "sensor_id,seq,local_stamp_nanos,server_stamp_nanos,uncertainty_nanos,offset_nanos,drift_ppm,true_stamp_nanos,received_nanos,joint,x_m,y_m,z_m,state";
/// Columns of [`POSES_FILE`]: the aligned set's sequence number; the fusion instant (server
/// clock, ns); the joint; its world position (m); √trace of its covariance (m); the sensors
/// used, `;`-separated.
pub const POSES_HEADER: &str = "set_seq,stamp_nanos,joint,x_m,y_m,z_m,sigma_m,sensors_used";

/// Why a recording cannot be read.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The file cannot be opened or read.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// What went wrong.
        source: std::io::Error,
    },
    /// A line that is not what the format says.
    #[error("{path}:{line}: {message}")]
    Line {
        /// The file.
        path: String,
        /// 1-based line number.
        line: usize,
        /// What is wrong with it.
        message: String,
    },
}

/// Result of this crate.
pub type Result<T> = std::result::Result<T, Error>;

fn opt<T: std::fmt::Display>(v: Option<T>) -> String {
    v.map_or_else(String::new, |v| v.to_string())
}

/// Appends the lines of `frame` to `out` (no header).
pub fn push_frame_lines(out: &mut String, frame: &FrameTiming) {
    let head = format!(
        "{},{},{},{},{},{},{},{},{}",
        frame.sensor_id,
        frame.seq,
        frame.local_stamp_nanos,
        opt(frame.server_stamp_nanos),
        opt(frame.uncertainty_nanos),
        opt(frame.offset_nanos),
        opt(frame.drift_ppm),
        opt(frame.true_stamp_nanos),
        opt(frame.received_nanos),
    );
    if frame.joints.is_empty() {
        out.push_str(&head);
        out.push_str(",,,,,\n");
    }
    for s in &frame.joints {
        let p = s.position_in_kinect;
        out.push_str(&format!(
            "{head},{},{},{},{},{}\n",
            s.joint.name(),
            p.x,
            p.y,
            p.z,
            s.state as u8
        ));
    }
}

/// Appends the lines of `pose` to `out` (no header).
pub fn push_pose_lines(out: &mut String, pose: &FusedPose) {
    for (joint, fused) in &pose.joints {
        let p = fused.position;
        out.push_str(&format!(
            "{},{},{},{},{},{},{},{}\n",
            pose.set_seq,
            pose.stamp_nanos,
            joint.name(),
            p.x,
            p.y,
            p.z,
            fused.covariance.trace().max(0.0).sqrt(),
            fused.sensors_used.join(";")
        ));
    }
}

/// Reads `path` line by line: checks the header, hands every other line (1-based number,
/// text) to `each`. A last line without an end of line is a cut-off write and an error.
fn read_lines(
    path: &Path,
    header: &str,
    mut each: impl FnMut(usize, &str) -> std::result::Result<(), String>,
) -> Result<()> {
    let name = path.display().to_string();
    let io = |source| Error::Io {
        path: name.clone(),
        source,
    };
    let file = std::fs::File::open(path).map_err(io)?;
    let mut reader = std::io::BufReader::new(file);
    let mut line = String::new();
    let mut number = 0;
    loop {
        line.clear();
        if reader.read_line(&mut line).map_err(io)? == 0 {
            break;
        }
        number += 1;
        let bad = |message: String| Error::Line {
            path: name.clone(),
            line: number,
            message,
        };
        let Some(text) = line.strip_suffix('\n') else {
            return Err(bad(
                "the line ends without an end of line: the file was cut off mid-write".into(),
            ));
        };
        let text = text.strip_suffix('\r').unwrap_or(text);
        if number == 1 {
            if text != header {
                return Err(bad(format!("expected the header {header:?}, got {text:?}")));
            }
            continue;
        }
        each(number, text).map_err(bad)?;
    }
    if number == 0 {
        return Err(Error::Line {
            path: name,
            line: 1,
            message: format!("the file is empty (expected the header {header:?})"),
        });
    }
    Ok(())
}

fn cells<const N: usize>(text: &str) -> std::result::Result<[&str; N], String> {
    let cells: Vec<&str> = text.split(',').collect();
    let n = cells.len();
    cells
        .try_into()
        .map_err(|_| format!("expected {N} comma-separated cells, got {n}"))
}

fn number<T: std::str::FromStr>(cell: &str, column: &str) -> std::result::Result<T, String>
where
    T::Err: std::fmt::Display,
{
    cell.parse()
        .map_err(|e| format!("column {column}: {cell:?} is not a number ({e})"))
}

fn optional<T: std::str::FromStr>(
    cell: &str,
    column: &str,
) -> std::result::Result<Option<T>, String>
where
    T::Err: std::fmt::Display,
{
    if cell.is_empty() {
        Ok(None)
    } else {
        number(cell, column).map(Some)
    }
}

fn joint(cell: &str) -> std::result::Result<Joint, String> {
    Joint::from_name(cell).ok_or_else(|| format!("column joint: {cell:?} is not a joint name"))
}

/// Reads a [`FRAMES_FILE`]: the frames in the order they were recorded.
///
/// # Errors
/// [`Error`]: the file cannot be read, a wrong header, a malformed or cut-off line (naming it).
pub fn read_frames(path: &Path) -> Result<Vec<FrameTiming>> {
    let mut frames: Vec<FrameTiming> = Vec::new();
    // The frame-level cells of the frame being read, to spot a line that contradicts them.
    let mut head = String::new();
    // Each sensor's last frame number: they only grow within a run.
    let mut last_seq: std::collections::HashMap<String, u64> = std::collections::HashMap::new();
    read_lines(path, FRAMES_HEADER, |_, text| {
        let c: [&str; 14] = cells(text)?;
        let this_head = c[..9].join(",");
        let seq: u64 = number(c[1], "seq")?;
        let local: i64 = number(c[2], "local_stamp_nanos")?;
        let same_frame = frames.last().is_some_and(|f| {
            f.sensor_id == c[0] && f.seq == seq && f.local_stamp_nanos == local && !c[9].is_empty()
        });
        if same_frame {
            if this_head != head {
                return Err(format!(
                    "frame {} {seq}: its stamps differ from its first line's",
                    c[0]
                ));
            }
        } else {
            if c[0].is_empty() {
                return Err("column sensor_id is empty".into());
            }
            if let Some(&before) = last_seq.get(c[0])
                && seq <= before
            {
                return Err(format!(
                    "frame {} {seq} after its frame {before}: a sensor's frame numbers only grow \
                     within a run (two recordings joined into one file, or lines out of order?)",
                    c[0]
                ));
            }
            last_seq.insert(c[0].to_owned(), seq);
            head = this_head;
            frames.push(FrameTiming {
                sensor_id: c[0].to_owned(),
                seq,
                local_stamp_nanos: local,
                server_stamp_nanos: optional(c[3], "server_stamp_nanos")?,
                uncertainty_nanos: optional(c[4], "uncertainty_nanos")?,
                offset_nanos: optional(c[5], "offset_nanos")?,
                drift_ppm: optional(c[6], "drift_ppm")?,
                true_stamp_nanos: optional(c[7], "true_stamp_nanos")?,
                received_nanos: optional(c[8], "received_nanos")?,
                joints: Vec::new(),
            });
        }
        if c[9..].iter().all(|s| s.is_empty()) {
            return Ok(());
        }
        let state: u8 = number(c[13], "state")?;
        let sample = JointSample {
            joint: joint(c[9])?,
            position_in_kinect: Point3::new(
                number(c[10], "x_m")?,
                number(c[11], "y_m")?,
                number(c[12], "z_m")?,
            ),
            state: TrackingState::from_index(state)
                .ok_or_else(|| format!("column state: {state} is not 0, 1 or 2"))?,
        };
        if let Some(f) = frames.last_mut() {
            f.joints.push(sample);
        }
        Ok(())
    })?;
    Ok(frames)
}

/// One fused joint of a [`POSES_FILE`].
#[derive(Debug, Clone, PartialEq)]
pub struct PoseLine {
    /// The aligned set's sequence number.
    pub set_seq: u64,
    /// The fusion instant, server clock, ns.
    pub stamp_nanos: i64,
    /// The joint.
    pub joint: Joint,
    /// World position, m.
    pub position: Point3<f64>,
    /// √trace of the covariance, m.
    pub sigma_m: f64,
    /// The sensors used.
    pub sensors_used: Vec<String>,
}

/// Reads a [`POSES_FILE`].
///
/// # Errors
/// [`Error`]: the file cannot be read, a wrong header, a malformed or cut-off line (naming it).
pub fn read_poses(path: &Path) -> Result<Vec<PoseLine>> {
    let mut poses = Vec::new();
    read_lines(path, POSES_HEADER, |_, text| {
        let c: [&str; 8] = cells(text)?;
        poses.push(PoseLine {
            set_seq: number(c[0], "set_seq")?,
            stamp_nanos: number(c[1], "stamp_nanos")?,
            joint: joint(c[2])?,
            position: Point3::new(
                number(c[3], "x_m")?,
                number(c[4], "y_m")?,
                number(c[5], "z_m")?,
            ),
            sigma_m: number(c[6], "sigma_m")?,
            sensors_used: c[7]
                .split(';')
                .filter(|s| !s.is_empty())
                .map(str::to_owned)
                .collect(),
        });
        Ok(())
    })?;
    Ok(poses)
}

/// Per-sensor joint tracks of recorded frames for the calibration: every synchronised frame
/// at its server stamp, seconds after the earliest; frames recorded before their sensor was
/// synchronised are left out (they have no common time).
#[must_use]
pub fn calibration_tracks(frames: &[FrameTiming]) -> Vec<trigait_calibration::SensorTrack> {
    let origin = frames
        .iter()
        .filter_map(|f| f.server_stamp_nanos)
        .min()
        .unwrap_or(0);
    sensor_ids(frames)
        .into_iter()
        .map(|id| trigait_calibration::SensorTrack {
            frames: frames
                .iter()
                .filter(|f| f.sensor_id == id)
                .filter_map(|f| {
                    Some(trigait_calibration::TrackFrame {
                        t_secs: (f.server_stamp_nanos? - origin) as f64 * 1e-9,
                        joints: f.joints.clone(),
                    })
                })
                .collect(),
            id,
        })
        .collect()
}

/// Writes the calibrated sensors of `calibration` to `path` as a rig file named `name` (the
/// graphs' `RIG` reads it), creating its directory.
///
/// # Errors
/// [`Error::Io`]: the directory or the file cannot be written.
pub fn write_calibrated_rig(
    path: &Path,
    name: &str,
    calibration: &trigait_calibration::Calibration,
) -> Result<()> {
    let io = |source| Error::Io {
        path: path.display().to_string(),
        source,
    };
    let file = trigait_calibration::rig_file(name, calibration);
    let text = serde_yaml::to_string(&file)
        .map_err(|e| io(std::io::Error::new(std::io::ErrorKind::InvalidData, e)))?;
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(io)?;
    }
    std::fs::write(path, text).map_err(io)
}

/// The sensor ids of `frames`, in the order they first appear.
#[must_use]
pub fn sensor_ids(frames: &[FrameTiming]) -> Vec<String> {
    let mut ids: Vec<String> = Vec::new();
    for f in frames {
        if !ids.contains(&f.sensor_id) {
            ids.push(f.sensor_id.clone());
        }
    }
    ids
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(sensor: &str, seq: u64, joints: usize) -> FrameTiming {
        FrameTiming {
            sensor_id: sensor.into(),
            seq,
            local_stamp_nanos: 1_700_000_000_123_456_789 + seq as i64,
            server_stamp_nanos: (seq > 0).then_some(1_700_000_000_000_000_001),
            uncertainty_nanos: (seq > 0).then_some(40_123),
            offset_nanos: (seq > 0).then_some(-35_000_017),
            drift_ppm: (seq > 0).then_some(0.1 + 0.2),
            true_stamp_nanos: None,
            received_nanos: (seq > 0).then_some(1_700_000_000_040_000_003),
            joints: Joint::LEGS
                .iter()
                .take(joints)
                .enumerate()
                .map(|(i, j)| JointSample {
                    joint: *j,
                    position_in_kinect: Point3::new(0.1 + 0.2, -1.0 / 3.0, 2.0 + i as f64 * 1e-17),
                    state: TrackingState::from_index((i % 3) as u8).unwrap(),
                })
                .collect(),
        }
    }

    fn write(dir: &Path, name: &str, text: &str) -> std::path::PathBuf {
        let path = dir.join(name);
        std::fs::write(&path, text).unwrap();
        path
    }

    fn temp_dir(name: &str) -> std::path::PathBuf {
        let dir =
            std::env::temp_dir().join(format!("trigait-recording-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    /// Frames (with and without joints, synchronised or not) read back bit for bit, in order.
    #[test]
    fn frames_round_trip() {
        let frames = vec![
            frame("k1", 0, 3),
            frame("k2", 1, 0),
            frame("k1", 1, 6),
            frame("k10", 2, 1),
        ];
        let mut text = format!("{FRAMES_HEADER}\n");
        frames.iter().for_each(|f| push_frame_lines(&mut text, f));
        let dir = temp_dir("round");
        let back = read_frames(&write(&dir, FRAMES_FILE, &text)).unwrap();
        assert_eq!(back, frames);
        assert_eq!(sensor_ids(&back), ["k1", "k2", "k10"]);
    }

    /// A cut-off last line, a bad cell, a wrong header and an empty file are errors naming the
    /// file and the line.
    #[test]
    fn bad_files_name_file_and_line() {
        let dir = temp_dir("bad");
        let mut text = format!("{FRAMES_HEADER}\n");
        push_frame_lines(&mut text, &frame("k1", 1, 6));
        let cut = &text[..text.len() - 5];
        let err = read_frames(&write(&dir, "cut.csv", cut))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("cut.csv:7:") && err.contains("cut off"),
            "{err}"
        );
        let bad = text.replacen("knee_left", "knee_middle", 1);
        let err = read_frames(&write(&dir, "bad.csv", &bad))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("bad.csv:") && err.contains("knee_middle"),
            "{err}"
        );
        let short = format!("{FRAMES_HEADER}\nk1,1,2\n");
        let err = read_frames(&write(&dir, "short.csv", &short))
            .unwrap_err()
            .to_string();
        assert!(err.contains("short.csv:2:") && err.contains("14"), "{err}");
        let err = read_frames(&write(&dir, "head.csv", "a,b\n"))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("head.csv:1:") && err.contains("header"),
            "{err}"
        );
        let err = read_frames(&write(&dir, "empty.csv", ""))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("empty.csv:1:") && err.contains("empty"),
            "{err}"
        );
        let err = read_frames(&dir.join("missing.csv"))
            .unwrap_err()
            .to_string();
        assert!(err.contains("missing.csv"), "{err}");
    }

    /// Two recordings joined into one file: the second's frame numbers start again, which no
    /// run does, and the reader says so instead of replaying both runs as one.
    #[test]
    fn joined_recordings_are_refused() {
        let dir = temp_dir("joined");
        let mut text = format!("{FRAMES_HEADER}\n");
        for run in 0..2 {
            for seq in 0..3 {
                push_frame_lines(&mut text, &frame("k1", seq, 2));
                push_frame_lines(&mut text, &frame("k2", seq + run, 2));
            }
        }
        let err = read_frames(&write(&dir, "joined.csv", &text))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("joined.csv:") && err.contains("frame k1 0 after its frame 2"),
            "{err}"
        );
    }
}
