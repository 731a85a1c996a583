//! Kinect v2 SDK skeleton recordings as plain text, one line per frame, 25 joints in SDK
//! `JointType` order, camera space in metres (`../shared/data/kinect-v2-skeleton-replay/`).
//! Two layouts exist and are told apart by the column count:
//!
//! - 76 columns: `frame x y z × 25` (every joint taken as tracked);
//! - 201 columns: `frame (state x y z qx qy qz qw) × 25`, state 0 = not tracked, 1 = inferred,
//!   2 = tracked; orientations are ignored;
//! - timed logs, `frame time_ms` first: 202 columns with `(state x y z qx qy qz qw) × 25`, 177
//!   with 175 zeros when no body was tracked, and (a logger glitch) several `frame time_ms`
//!   pairs before the 175 zeros, each an empty frame. Such loggers may run faster than the
//!   Kinect and repeat its last skeleton; [`sdk_clip`] drops the repeats and places frames by
//!   their time.
//!
//! The SDK's body tracker assumes the person faces the sensor. Walking away, it fits that
//! front-facing skeleton to the person's back, so its "left" joints are the person's right
//! (measured on the CHU log in `../shared/data/kinect-v2-vicon-chu-walk`: the hip axis stays
//! within 12° of facing the sensor in every run, the walking-away ones included). People walk
//! forwards, so [`sdk_clip`] swaps the sides back wherever the labelled skeleton faces against
//! its own walking direction.

use std::path::Path;

use nalgebra::Point3;
use trigait_skeleton::{Joint, JointSample, MotionClip, TrackingState};

use crate::{Error, Result};

/// One recorded frame.
#[derive(Debug, Clone, PartialEq)]
pub struct SdkFrame {
    /// The recorder's frame number (first column).
    pub frame_number: u64,
    /// The logger's time stamp (ms since its start), in timed logs.
    pub time_ms: Option<f64>,
    /// Joints reported (not-tracked joints and all-zero positions are left out).
    pub joints: Vec<JointSample>,
}

/// Reads a Kinect v2 SDK skeleton text file (either layout).
///
/// # Errors
/// [`Error::Io`], or [`Error::SdkSkeleton`] naming the line for a wrong column count or a value
/// that is not a number; an empty file is an error too.
pub fn read_sdk_skeletons(path: impl AsRef<Path>) -> Result<Vec<SdkFrame>> {
    read_sdk_text(path.as_ref(), parse_sdk_skeletons)
}

/// A Kinect v2 SDK skeleton log as read by [`read_sdk_log`]: its frames, and the last line if a
/// logger stopped writing midway through it.
#[derive(Debug, Clone, PartialEq)]
pub struct SdkLog {
    /// The frames of the complete lines.
    pub frames: Vec<SdkFrame>,
    /// The unfinished last line, left out.
    pub cut_last_line: Option<CutLine>,
}

/// A last line a logger stopped writing midway: no line end, and fewer columns than a whole
/// line of the file's layout, or a last value cut to no number (a value cut to a shorter
/// number, `-0.5` of `-0.523`, cannot be told from a whole one).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CutLine {
    /// 1-based line number.
    pub line: usize,
    /// Its columns.
    pub columns: usize,
    /// The columns of a whole line of the file's layout.
    pub expected: usize,
}

impl std::fmt::Display for CutLine {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "the last line ({}) stops midway (", self.line)?;
        if self.columns < self.expected {
            write!(f, "{} of {} columns", self.columns, self.expected)?;
        } else {
            write!(f, "its last value cut short")?;
        }
        write!(
            f,
            ", no line end), as a logger stopped while writing it leaves it: left out"
        )
    }
}

/// Reads a Kinect v2 SDK skeleton text file as [`read_sdk_skeletons`] does, but takes a file
/// whose last line was cut off (a logger stopped, or the copy was, while writing it): that
/// line is left out and said ([`SdkLog::cut_last_line`]), and the complete lines are read.
/// Any other malformed line is still an error.
///
/// # Errors
/// As [`read_sdk_skeletons`].
pub fn read_sdk_log(path: impl AsRef<Path>) -> Result<SdkLog> {
    read_sdk_text(path.as_ref(), parse_sdk_log)
}

/// The first line of the recorder's thesis-format text export (`trajectory.txt`, thesis
/// §6.4.5): the last positions each joint's ring buffer held, not a walk to analyse.
pub const THESIS_TEXT_HEADER: &str =
    "# trigait fused joint trajectories (thesis §6.4.5 text format)";

/// `path`'s text through `parse`, its errors naming the file (the thesis-format export is named
/// as such).
fn read_sdk_text<T>(
    path: &Path,
    parse: impl FnOnce(&str) -> std::result::Result<T, (usize, String)>,
) -> Result<T> {
    let text =
        trigait_input_limits::read_bounded_text(path, crate::MAX_MOTION_FILE_BYTES, "motion file")
            .map_err(|source| Error::Io {
                path: path.to_owned(),
                source,
            })?;
    if text.starts_with(THESIS_TEXT_HEADER) {
        return Err(Error::SdkSkeleton {
            path: path.to_owned(),
            line: 1,
            reason: "this is trigait's thesis-format export (the last positions of each joint's \
                     ring buffer), not Kinect SDK text: analyse the trajectory.csv, .trc or .c3d \
                     the same run wrote beside it"
                .to_owned(),
        });
    }
    parse(&text).map_err(|(line, reason)| Error::SdkSkeleton {
        path: path.to_owned(),
        line,
        reason,
    })
}

/// Parses the text of a Kinect v2 SDK skeleton file as [`read_sdk_log`] reads it; errors are
/// `(1-based line, reason)`.
pub fn parse_sdk_log(text: &str) -> std::result::Result<SdkLog, (usize, String)> {
    let whole = match parse_sdk_skeletons(text) {
        Ok(frames) => {
            return Ok(SdkLog {
                frames,
                cut_last_line: None,
            });
        }
        Err(e) => e,
    };
    // The last line, if the text does not end it.
    let start = text.rfind('\n').map_or(0, |i| i + 1);
    let last: Vec<&str> = text[start..].split_whitespace().collect();
    let before = &text[..start];
    let Some(previous) = before.lines().rev().find(|l| !l.trim().is_empty()) else {
        return Err(whole);
    };
    let line = before.lines().count() + 1;
    // A whole line of the layout the line before shows (a timed log's lines without a body
    // are shorter than those with one).
    let expected = match previous.split_whitespace().count() {
        n @ (76 | 201) => n,
        _ => 202,
    };
    let cut_value = last.last().is_some_and(|v| v.parse::<f64>().is_err());
    if last.is_empty() || whole.0 != line || !(last.len() < expected || cut_value) {
        return Err(whole);
    }
    let frames = parse_sdk_skeletons(before)?;
    Ok(SdkLog {
        frames,
        cut_last_line: Some(CutLine {
            line,
            columns: last.len(),
            expected,
        }),
    })
}

/// Zeros a timed log writes instead of 25 joints × 7 values when no body is tracked.
const NO_BODY_ZEROS: usize = 175;

/// Parses the text of a Kinect v2 SDK skeleton file; errors are `(1-based line, reason)`.
pub fn parse_sdk_skeletons(text: &str) -> std::result::Result<Vec<SdkFrame>, (usize, String)> {
    let mut frames = Vec::new();
    // The line of each frame, and the layout of the first: one file holds one layout.
    let mut lines = Vec::new();
    let mut layout: Option<(Layout, usize)> = None;
    for (i, line) in text.lines().enumerate() {
        let line_no = i + 1;
        let cols: Vec<&str> = line.split_whitespace().collect();
        if cols.is_empty() {
            continue;
        }
        let n = cols.len();
        let columns_error = || {
            (
                line_no,
                format!(
                    "{n} columns, expected 76 (frame + 25×xyz), 201 (frame + 25×state xyz \
                     quaternion), 202 (frame, time + 25×state xyz quaternion) or 177 (frame, \
                     time + 175 zeros)"
                ),
            )
        };
        let this = match n {
            76 => Layout::Positions,
            201 => Layout::States,
            n if n >= 177 => Layout::Timed,
            _ => return Err(columns_error()),
        };
        match layout {
            Some((first, at)) if first != this => {
                return Err((
                    line_no,
                    format!(
                        "{} columns, a {} line, but line {at} was a {} line: one file holds one \
                         layout (two recordings joined?)",
                        cols.len(),
                        this.name(),
                        first.name()
                    ),
                ));
            }
            None => layout = Some((this, line_no)),
            Some(_) => {}
        }
        let number = |c: &str| -> std::result::Result<f64, (usize, String)> {
            c.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| (line_no, format!("{c:?} is not a finite number")))
        };
        let frame_number_of = |c: &str| {
            c.parse::<u64>().map_err(|_| {
                let what = if c.parse::<i64>().is_ok() {
                    "is negative"
                } else {
                    "is not an integer"
                };
                (line_no, format!("frame number {c:?} {what}"))
            })
        };
        // Timed logs: `frame time_ms` pairs, then either 25 joints or 175 zeros (no body).
        if this == Layout::Timed && n != 202 {
            let (pairs, zeros) = cols.split_at(n - NO_BODY_ZEROS);
            let all_zero = zeros
                .iter()
                .all(|c| c.parse::<f64>().is_ok_and(|v| v == 0.0));
            if pairs.len() % 2 == 0 && all_zero {
                for pair in pairs.chunks(2) {
                    frames.push(SdkFrame {
                        frame_number: frame_number_of(pair[0])?,
                        time_ms: Some(number(pair[1])?),
                        joints: Vec::new(),
                    });
                    lines.push(line_no);
                }
                continue;
            }
            return Err(columns_error());
        }
        let (stride, first_joint, time_ms) = match this {
            Layout::Positions => (3, 1, None),
            Layout::States => (8, 1, None),
            Layout::Timed => (8, 2, Some(number(cols[1])?)),
        };
        let frame_number = frame_number_of(cols[0])?;
        let mut joints = Vec::with_capacity(25);
        for (j, joint) in Joint::ALL.into_iter().enumerate() {
            let at = first_joint + j * stride;
            let (state, xyz) = if stride == 3 {
                (TrackingState::Tracked, &cols[at..at + 3])
            } else {
                let code = number(cols[at])?;
                let state = match code as i64 {
                    0 => TrackingState::NotTracked,
                    1 => TrackingState::Inferred,
                    2 => TrackingState::Tracked,
                    _ => {
                        return Err((
                            line_no,
                            format!("tracking state {code} of {joint} is not 0, 1 or 2"),
                        ));
                    }
                };
                (state, &cols[at + 1..at + 4])
            };
            let p = Point3::new(number(xyz[0])?, number(xyz[1])?, number(xyz[2])?);
            if state == TrackingState::NotTracked || p.coords.norm() == 0.0 {
                continue;
            }
            joints.push(JointSample {
                joint,
                position_in_kinect: p,
                state,
            });
        }
        frames.push(SdkFrame {
            frame_number,
            time_ms,
            joints,
        });
        lines.push(line_no);
    }
    if frames.is_empty() {
        return Err((1, "no frames".into()));
    }
    check_order(&frames, &lines)?;
    Ok(frames)
}

/// The three line layouts of SDK text.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Layout {
    /// 76 columns: frame, 25 × xyz.
    Positions,
    /// 201 columns: frame, 25 × state xyz quaternion.
    States,
    /// Frame and time first (202 columns, or 177 and more without a body).
    Timed,
}

impl Layout {
    fn name(self) -> &'static str {
        match self {
            Layout::Positions => "positions-only (76-column)",
            Layout::States => "untimed (201-column)",
            Layout::Timed => "timed",
        }
    }
}

/// The longest recording read: an hour. A frame number or time stamp further from the first is
/// a corrupt value or a recording to split, and either way an error rather than an allocation
/// of its size.
const MAX_SPAN_SECS: f64 = 3600.0;

/// [`MAX_SPAN_SECS`] in frame numbers, which the SDK counts at 30 Hz.
const MAX_SPAN_FRAMES: u64 = 3600 * 30;

/// Frames must come in recording order (a repeated frame number or time stamp is a repeat, and
/// is counted later) and within [`MAX_SPAN_FRAMES`] of the first: a file whose numbers or
/// times go back, or jump by hours, is two recordings joined or a corrupt one, and placing its
/// frames would interleave or drop them without a word.
fn check_order(frames: &[SdkFrame], lines: &[usize]) -> std::result::Result<(), (usize, String)> {
    let (first, first_line) = (&frames[0], lines[0]);
    for (pair, at) in frames.windows(2).zip(&lines[1..]) {
        let [before, frame] = [&pair[0], &pair[1]];
        if frame.frame_number < before.frame_number {
            return Err((
                *at,
                format!(
                    "frame number {} after {}: frame numbers go back (two recordings joined?)",
                    frame.frame_number, before.frame_number
                ),
            ));
        }
        if let (Some(t0), Some(t1)) = (before.time_ms, frame.time_ms)
            && t1 < t0
        {
            return Err((
                *at,
                format!("time stamp {t1} ms after {t0} ms: the logger's clock went back"),
            ));
        }
        let frames_on = frame.frame_number - first.frame_number;
        let secs_on = match (first.time_ms, frame.time_ms) {
            (Some(t0), Some(t1)) => (t1 - t0) / 1000.0,
            _ => frames_on as f64 / 30.0,
        };
        if frames_on > MAX_SPAN_FRAMES || secs_on > MAX_SPAN_SECS {
            return Err((
                *at,
                format!(
                    "frame {} ({secs_on:.0} s) is more than an hour after the first, frame {} on \
                     line {first_line}: split a longer recording, or mend the corrupt number",
                    frame.frame_number, first.frame_number
                ),
            ));
        }
    }
    Ok(())
}

/// Kinect v2 SDK skeleton frames as a world-frame [`MotionClip`] at `rate_hz` (30 for a Kinect
/// v2), with what was left out.
///
/// Camera space (x to the sensor's left, y up, z out of the lens) is turned into the Z-up world
/// by (x, y, z) ↦ (z, x, y), a proper rotation: world X points away from the sensor, Z up. The
/// floor is wherever the sensor saw it (not z = 0); gait analysis measures heights relative to
/// each foot's own stance level, so that does not matter. Frames are placed by their frame
/// number relative to the first, so a skipped number is a gap; a repeated number keeps its first
/// line. Joints the tracker only *inferred* are dropped when `drop_inferred` is set (the
/// occluded leg is then often far from the real one).
#[derive(Debug, Clone, PartialEq)]
pub struct SdkClip {
    /// The trajectories.
    pub clip: MotionClip,
    /// Lines whose frame number repeated an earlier one (skipped).
    pub repeated_frames: usize,
    /// Frame numbers missing between the first and the last (gaps).
    pub missing_frames: usize,
    /// Joint samples dropped as inferred.
    pub inferred_dropped: usize,
    /// Joint samples kept as inferred (when `drop_inferred` is off).
    pub inferred_kept: usize,
    /// Frames (with a skeleton) whose left and right joints were swapped back because the
    /// skeleton walked backwards as labelled (walking away from the sensor).
    pub swapped_frames: usize,
    /// The runs of frames (indices into the clip) that were swapped back.
    pub swapped_runs: Vec<std::ops::Range<usize>>,
}

/// Whether `frames` come from a timed log, whose time stamps (not a rate) place them.
#[must_use]
pub fn is_timed(frames: &[SdkFrame]) -> bool {
    !frames.is_empty() && frames.iter().all(|f| f.time_ms.is_some())
}

/// Builds an [`SdkClip`] from parsed SDK frames.
///
/// # Errors
/// [`Error::Clip`] for a bad rate or no frames.
pub fn sdk_clip(
    name: &str,
    frames: &[SdkFrame],
    rate_hz: f64,
    drop_inferred: bool,
) -> Result<SdkClip> {
    let placement = place(frames, rate_hz);
    let (mut dropped, mut kept) = (0, 0);
    let rows = placement.rows(frames, drop_inferred, &mut dropped, &mut kept);
    finish_clip(
        name,
        rate_hz,
        Joint::ALL.to_vec(),
        rows,
        placement.repeated,
        (dropped, kept),
    )
}

/// Swaps the left and right labels back in every frame recorded while the person walked away
/// from the sensor, as [`sdk_clip`] does for its clip, for a consumer that takes the frames
/// one by one (a replay into a dataflow). `rate_hz` places untimed frames, as for
/// [`sdk_clip`]; inferred joints count. Returns how many frames were swapped.
pub fn swap_sides_walking_away(frames: &mut [SdkFrame], rate_hz: f64) -> usize {
    let placement = place(frames, rate_hz);
    let (mut dropped, mut kept) = (0, 0);
    let mut rows = placement.rows(frames, false, &mut dropped, &mut kept);
    let runs = swap_sides_walking_backwards(&mut rows, rate_hz);
    let mut swapped = 0;
    for (frame, slot) in frames.iter_mut().zip(&placement.slots) {
        if slot.is_some_and(|(s, _)| runs.iter().any(|r| r.contains(&s))) {
            for sample in &mut frame.joints {
                sample.joint = sample.joint.mirrored();
            }
            swapped += 1;
        }
    }
    swapped
}

/// Where the frames of a log go in its clip.
struct Placement {
    /// Per frame: its row, and whether it was placed there (`false`: it repeats the frame that
    /// was); `None` for a frame without a skeleton or outside the clip.
    slots: Vec<Option<(usize, bool)>>,
    /// Rows of the clip.
    span: usize,
    /// Frames not placed because they repeat another.
    repeated: usize,
}

impl Placement {
    /// The placed frames' world rows (an empty row: a frame with every joint missing).
    fn rows(
        &self,
        frames: &[SdkFrame],
        drop_inferred: bool,
        dropped: &mut usize,
        kept: &mut usize,
    ) -> Vec<Option<Vec<Option<Point3<f64>>>>> {
        let mut rows = vec![None; self.span];
        for (frame, slot) in frames.iter().zip(&self.slots) {
            if let Some((row, true)) = slot {
                rows[*row] = Some(world_row(frame, drop_inferred, dropped, kept));
            }
        }
        rows
    }
}

/// Places `frames`: by frame number (a repeated number keeps its first line), or for a timed
/// log by [`place_timed`].
fn place(frames: &[SdkFrame], rate_hz: f64) -> Placement {
    if is_timed(frames) {
        return place_timed(frames, rate_hz);
    }
    let first = frames.iter().map(|f| f.frame_number).min().unwrap_or(0);
    let last = frames.iter().map(|f| f.frame_number).max().unwrap_or(0);
    // A corrupt frame number must not allocate the world: cap the span at an hour of frames.
    let span = usize::try_from(last - first)
        .unwrap_or(usize::MAX)
        .min(MAX_SPAN_FRAMES as usize)
        + 1;
    let mut taken = vec![false; span];
    let mut repeated = 0;
    let slots = frames
        .iter()
        .map(|frame| {
            let row = usize::try_from(frame.frame_number - first)
                .ok()
                .filter(|&r| r < span)?;
            if std::mem::replace(&mut taken[row], true) {
                repeated += 1;
                return Some((row, false));
            }
            Some((row, true))
        })
        .collect();
    Placement {
        slots,
        span,
        repeated,
    }
}

/// The clip of the placed rows (an empty slot is a frame with every joint missing) and the
/// counts of what placing them found.
fn finish_clip(
    name: &str,
    rate_hz: f64,
    joints: Vec<Joint>,
    rows: Vec<Option<Vec<Option<Point3<f64>>>>>,
    repeated: usize,
    (dropped, kept): (usize, usize),
) -> Result<SdkClip> {
    let missing = rows.iter().filter(|r| r.is_none()).count();
    let mut rows = rows;
    let swapped_runs = swap_sides_walking_backwards(&mut rows, rate_hz);
    let swapped_frames = swapped_runs
        .iter()
        .flat_map(|r| &rows[r.clone()])
        .filter(|r| r.is_some())
        .count();
    let rows = rows
        .into_iter()
        .map(|r| r.unwrap_or_else(|| vec![None; joints.len()]))
        .collect();
    Ok(SdkClip {
        clip: MotionClip::new(name, rate_hz, joints, rows)?,
        repeated_frames: repeated,
        missing_frames: missing,
        inferred_dropped: dropped,
        inferred_kept: kept,
        swapped_frames,
        swapped_runs,
    })
}

/// Pelvis speed (m/s, horizontal) above which a frame counts as walking for the side check.
const WALKING_SPEED_M_S: f64 = 0.3;

/// Half-width (s) of the window the pelvis velocity is taken over: a quarter stride, so the
/// sway within a step does not turn the direction.
const VELOCITY_HALF_WINDOW_SECS: f64 = 0.25;

/// Cosine of the angle between the labelled facing and the walking direction below which the
/// skeleton walks backwards as labelled: 120°. Walking across the view the SDK's hips still turn
/// towards the sensor by 26–33° (median, CHU), far from this.
const BACKWARDS_COS: f64 = -0.5;

/// Swaps left and right joints back in every walking run (frames whose pelvis moves faster than
/// [`WALKING_SPEED_M_S`]) whose labelled skeleton faces mostly against its walking direction;
/// returns the runs swapped. Rows are world rows (Z up) in [`Joint::ALL`] order.
/// The facing is (hip left − hip right) × up; a run is swapped when most of its frames with
/// both hips say so, so a frame with a dropped hip goes with its run.
fn swap_sides_walking_backwards(
    rows: &mut [Option<Vec<Option<Point3<f64>>>>],
    rate_hz: f64,
) -> Vec<std::ops::Range<usize>> {
    let n = rows.len();
    let joint = |f: usize, j: Joint| rows[f].as_ref().and_then(|r| r[j.index()]);
    let half = ((VELOCITY_HALF_WINDOW_SECS * rate_hz).round() as usize).max(1);
    // Per frame: None when not walking, else whether the labels face backwards (None inside when
    // a hip is missing).
    let verdicts: Vec<Option<Option<bool>>> = (0..n)
        .map(|f| {
            joint(f, Joint::SpineBase)?;
            let lo =
                (f.saturating_sub(half)..=f).find(|&g| joint(g, Joint::SpineBase).is_some())?;
            let hi = (f..=(f + half).min(n - 1))
                .rev()
                .find(|&g| joint(g, Joint::SpineBase).is_some())?;
            if hi - lo < half {
                return None;
            }
            let d = joint(hi, Joint::SpineBase)? - joint(lo, Joint::SpineBase)?;
            let v = nalgebra::Vector2::new(d.x, d.y) * rate_hz / (hi - lo) as f64;
            if v.norm() <= WALKING_SPEED_M_S || !v.norm().is_finite() {
                return None;
            }
            let backwards = match (joint(f, Joint::HipLeft), joint(f, Joint::HipRight)) {
                (Some(l), Some(r)) => {
                    let axis = l - r;
                    let facing = nalgebra::Vector2::new(axis.y, -axis.x);
                    let norm = facing.norm();
                    (norm > 0.0).then(|| facing.dot(&v) / (norm * v.norm()) < BACKWARDS_COS)
                }
                _ => None,
            };
            Some(backwards)
        })
        .collect();
    let mut backwards_runs: Vec<std::ops::Range<usize>> = Vec::new();
    for run in trigait_skeleton::frame_runs(n, |f| verdicts[f].is_some()) {
        let (start, f) = (run.start, run.end);
        let said: Vec<bool> = verdicts[start..f]
            .iter()
            .flatten()
            .flatten()
            .copied()
            .collect();
        let backwards = said.iter().filter(|b| **b).count();
        if 2 * backwards <= said.len() {
            continue;
        }
        // Nobody turns round within a quarter stride: frames between two backward runs that
        // close (a pelvis missing nearby leaves their speed unknown) go with them.
        match backwards_runs.last_mut() {
            Some(last) if start - last.end <= half => last.end = f,
            _ => backwards_runs.push(start..f),
        }
    }
    for run in &backwards_runs {
        for row in rows[run.clone()].iter_mut().flatten() {
            let original = row.clone();
            for j in Joint::ALL {
                row[j.index()] = original[j.mirrored().index()];
            }
        }
    }
    backwards_runs
}

/// One frame's joints turned into the world frame, with the inferred samples dropped or kept
/// (counted in `dropped`/`kept`).
fn world_row(
    frame: &SdkFrame,
    drop_inferred: bool,
    dropped: &mut usize,
    kept: &mut usize,
) -> Vec<Option<Point3<f64>>> {
    let mut row = vec![None; Joint::ALL.len()];
    for sample in &frame.joints {
        if sample.state == TrackingState::Inferred {
            if drop_inferred {
                *dropped += 1;
                continue;
            }
            *kept += 1;
        }
        let c = sample.position_in_kinect;
        row[sample.joint as usize] = Some(Point3::new(c.z, c.x, c.y));
    }
    row
}

/// [`place`] for timed logs: a line repeating the previous line's skeleton exactly is the
/// logger polling faster than the Kinect (counted as repeated, not placed), a line without a
/// body is a gap, and each remaining skeleton goes to the `rate_hz` slot nearest its time stamp,
/// or the next when that is taken (with neither free it is counted as repeated).
fn place_timed(frames: &[SdkFrame], rate_hz: f64) -> Placement {
    let times: Vec<f64> = frames.iter().filter_map(|f| f.time_ms).collect();
    let t0 = times.iter().copied().fold(f64::INFINITY, f64::min);
    let t1 = times.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let slot_of = |t: f64| ((t - t0) / 1000.0 * rate_hz).round();
    // A corrupt time stamp must not allocate the world: cap the span at an hour of frames.
    let span = (slot_of(t1).max(0.0).min(MAX_SPAN_SECS * rate_hz.max(1.0)) as usize) + 1;
    let mut taken = vec![false; span];
    let mut repeated = 0;
    let mut previous: Option<(&Vec<JointSample>, usize)> = None;
    let mut slots = Vec::with_capacity(frames.len());
    for frame in frames {
        if frame.joints.is_empty() {
            previous = None;
            slots.push(None);
            continue;
        }
        if let Some((joints, row)) = previous
            && *joints == frame.joints
        {
            repeated += 1;
            slots.push(Some((row, false)));
            continue;
        }
        let slot = slot_of(frame.time_ms.unwrap_or(t0));
        if slot < 0.0 {
            previous = None;
            slots.push(None);
            continue;
        }
        // The polling jitters by up to a Kinect period: a skeleton whose slot the previous one
        // took belongs to the next.
        let slot = slot as usize;
        match (slot..=slot + 1).find(|&k| taken.get(k).is_some_and(|t| !t)) {
            Some(free) => {
                taken[free] = true;
                previous = Some((&frame.joints, free));
                slots.push(Some((free, true)));
            }
            None => {
                repeated += 1;
                let row = slot.min(span - 1);
                previous = Some((&frame.joints, row));
                slots.push(Some((row, false)));
            }
        }
    }
    Placement {
        slots,
        span,
        repeated,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Both real recordings parse with the frame counts SOURCE.txt states, and the walking one
    /// starts where SOURCE.txt says the pelvis is.
    #[test]
    fn real_recordings() {
        let data = trigait_test_data::shared_data_dir().join("kinect-v2-skeleton-replay");
        let straight = read_sdk_skeletons(data.join("JointsInfo_Straight.txt")).unwrap();
        assert_eq!(straight.len(), 85);
        assert_eq!(straight[0].frame_number, 2198);
        let base = straight[0]
            .joints
            .iter()
            .find(|s| s.joint == Joint::SpineBase)
            .unwrap();
        assert!((base.position_in_kinect - Point3::new(-0.99, -0.11, 2.65)).norm() < 0.01);
        let cyrille = read_sdk_skeletons(data.join("JointsInfo_Cyrille_v2_2.txt")).unwrap();
        assert_eq!(cyrille.len(), 970);
        let inferred = cyrille
            .iter()
            .flat_map(|f| &f.joints)
            .filter(|s| s.state == TrackingState::Inferred)
            .count();
        assert!(inferred > 1000, "{inferred}");
    }

    /// The timed CHU log: 1253 lines, the two malformed ones split into empty frames, the
    /// logger's repeats dropped, and the tracked skeletons on a 30 Hz grid by their time.
    #[test]
    fn timed_log() {
        let path = trigait_test_data::shared_data_dir()
            .join("kinect-v2-vicon-chu-walk/JointsInfo_before_CHU_test.txt");
        let frames = read_sdk_skeletons(&path).unwrap();
        // 1251 well-formed lines, plus 3 and 9 frames from the two glued lines.
        assert_eq!(frames.len(), 1251 + 3 + 9);
        let bodies = frames.iter().filter(|f| !f.joints.is_empty()).count();
        assert_eq!(bodies, 817);
        let clip = sdk_clip("chu", &frames, 30.0, false).unwrap();
        // SOURCE.txt: 436 of the 817 tracked lines repeat the previous one exactly.
        assert!(clip.repeated_frames >= 436, "{}", clip.repeated_frames);
        // About 19.8 s at 30 Hz.
        assert!((590..=600).contains(&clip.clip.frame_count()));
        let tracked = (0..clip.clip.frame_count())
            .filter(|&f| clip.clip.position(f, Joint::SpineBase).is_some())
            .count();
        // 381 distinct skeletons; nearly all find a slot.
        assert!((370..=381).contains(&tracked), "{tracked}");
    }

    /// `clip` (world, Z up) as the SDK would log it, with left and right exchanged when
    /// `mirror` (its front-facing skeleton fitted to a back).
    fn as_sdk(clip: &MotionClip, mirror: bool) -> Vec<SdkFrame> {
        (0..clip.frame_count())
            .map(|f| SdkFrame {
                frame_number: f as u64,
                time_ms: None,
                joints: clip
                    .joints()
                    .iter()
                    .filter_map(|&j| {
                        let p = clip.position(f, j)?;
                        Some(JointSample {
                            joint: if mirror { j.mirrored() } else { j },
                            position_in_kinect: Point3::new(p.y, p.z, p.x),
                            state: TrackingState::Tracked,
                        })
                    })
                    .collect(),
            })
            .collect()
    }

    fn same(a: &MotionClip, b: &MotionClip) -> bool {
        (0..a.frame_count()).all(|f| {
            Joint::LEGS
                .iter()
                .all(|&j| match (a.position(f, j), b.position(f, j)) {
                    (Some(p), Some(q)) => (p - q).norm() < 1e-9,
                    (None, None) => true,
                    _ => false,
                })
        })
    }

    /// Walking away with the SDK's mirrored labels, the sides are put back in every frame;
    /// walking towards the sensor, and standing, nothing is touched.
    #[test]
    fn walking_away_sides_are_swapped_back() {
        let walk = crate::walker(&crate::WalkerParams::default(), 3.0, 30.0).unwrap();
        let pelvis = |c: &MotionClip, f: usize| c.position(f, Joint::SpineBase).unwrap();
        let last = walk.frame_count() - 1;
        assert!(
            pelvis(&walk, last).x - pelvis(&walk, 0).x > 2.0,
            "the walker walks +X"
        );
        let start = pelvis(&walk, 0);
        // Away: from 1 m in front of the sensor along +X (world X points away from it).
        let away = walk.transformed(&nalgebra::Isometry3::translation(
            1.0 - start.x,
            -start.y,
            0.0,
        ));
        let read = sdk_clip("away", &as_sdk(&away, true), 30.0, false).unwrap();
        assert_eq!(read.swapped_frames, away.frame_count());
        assert!(same(&read.clip, &away));
        // Frame by frame (a replay's path): the SDK's own frames with the labels put back.
        let mut frames = as_sdk(&away, true);
        assert_eq!(
            swap_sides_walking_away(&mut frames, 30.0),
            away.frame_count()
        );
        assert_eq!(frames, as_sdk(&away, false));
        // Towards: turned round, from 6 m.
        let turned = nalgebra::Isometry3::from_parts(
            nalgebra::Translation3::new(6.0 + start.x, start.y, 0.0),
            nalgebra::UnitQuaternion::from_axis_angle(
                &nalgebra::Vector3::z_axis(),
                std::f64::consts::PI,
            ),
        );
        let towards = walk.transformed(&turned);
        let read = sdk_clip("towards", &as_sdk(&towards, false), 30.0, false).unwrap();
        assert_eq!(read.swapped_frames, 0);
        assert!(same(&read.clip, &towards));
        assert_eq!(
            swap_sides_walking_away(&mut as_sdk(&towards, false), 30.0),
            0
        );
        // Standing still, mirrored or not: no walking direction, nothing swapped.
        let still: Vec<SdkFrame> = (0..30)
            .map(|f| SdkFrame {
                frame_number: f,
                ..as_sdk(&away, true)[0].clone()
            })
            .collect();
        assert_eq!(
            sdk_clip("still", &still, 30.0, false)
                .unwrap()
                .swapped_frames,
            0
        );
    }

    /// The CHU log: every frame swapped back is one where the pelvis moves away from the
    /// sensor (its distance grows over ±0.25 s, which the rule does not look at), and most of
    /// the frames that walk away are swapped.
    #[test]
    fn chu_walking_away_is_swapped_back() {
        let path = trigait_test_data::shared_data_dir()
            .join("kinect-v2-vicon-chu-walk/JointsInfo_before_CHU_test.txt");
        let frames = read_sdk_skeletons(&path).unwrap();
        let read = sdk_clip("chu", &frames, 30.0, true).unwrap();
        let clip = &read.clip;
        let distance = |f: usize| {
            clip.position(f, Joint::SpineBase)
                .map(|p| nalgebra::Vector2::new(p.x, p.y).norm())
        };
        let swapped = |f: usize| read.swapped_runs.iter().any(|r| r.contains(&f));
        let (mut away, mut away_swapped, mut towards_swapped) = (0, 0, 0);
        for f in 8..clip.frame_count().saturating_sub(8) {
            let (Some(a), Some(b)) = (distance(f - 8), distance(f + 8)) else {
                continue;
            };
            let radial = (b - a) * 30.0 / 16.0;
            if radial > 0.3 {
                away += 1;
                away_swapped += usize::from(swapped(f));
            } else if radial < -0.3 {
                towards_swapped += usize::from(swapped(f));
            }
        }
        eprintln!(
            "swapped {} frames in {:?}; walking away {away}, of them swapped {away_swapped}; towards and swapped {towards_swapped}",
            read.swapped_frames, read.swapped_runs
        );
        assert!(away > 100, "{away}");
        assert!(away_swapped * 10 >= away * 9, "{away_swapped} of {away}");
        assert!(towards_swapped <= 3, "{towards_swapped}");
        // SOURCE.txt: the third run (15.5–19.5 s) walks towards the sensor throughout.
        let third = (15.5 * 30.0) as usize..(19.5 * 30.0) as usize;
        assert!(
            read.swapped_runs
                .iter()
                .all(|r| r.end <= third.start || r.start >= third.end),
            "{:?}",
            read.swapped_runs
        );
        // Frame by frame (a replay's path), the same frames are swapped, repeated lines with
        // the line they repeat: the clip of the swapped frames needs no more swapping and is
        // the clip above.
        let mut frames = frames;
        let swapped = swap_sides_walking_away(&mut frames, 30.0);
        assert!(swapped >= read.swapped_frames, "{swapped}");
        let again = sdk_clip("chu", &frames, 30.0, true).unwrap();
        assert_eq!(again.swapped_frames, 0, "{:?}", again.swapped_runs);
        assert!(same(&again.clip, clip));
    }

    /// A last line cut off mid-write (no line end; fewer columns, or its last value cut to
    /// no number) is left out and said; cut anywhere else, or ended, it is still an error,
    /// and a complete last line that breaks the order is not taken for a cut one.
    #[test]
    fn a_last_line_cut_off_is_left_out_and_said() {
        let mut line = String::from("7");
        for _ in 0..75 {
            line.push_str(" 0.5");
        }
        let numbered = |n: u32| line.replacen('7', &n.to_string(), 1);
        let complete = format!("{}\n{}\n", numbered(7), numbered(8));
        let log = parse_sdk_log(&complete).unwrap();
        assert_eq!((log.frames.len(), log.cut_last_line), (2, None));

        let cut = format!("{complete}{}", &numbered(9)[..40]);
        let log = parse_sdk_log(&cut).unwrap();
        assert_eq!(log.frames.len(), 2);
        assert_eq!(
            log.cut_last_line,
            Some(CutLine {
                line: 3,
                columns: 11,
                expected: 76
            })
        );
        // Cut inside its last value, to a sign.
        let sign = format!("{complete}{} -", &numbered(9)[..numbered(9).len() - 4]);
        assert_eq!(
            parse_sdk_log(&sign).unwrap().cut_last_line.unwrap().columns,
            76
        );
        // The strict reader refuses it, naming the line.
        assert_eq!(parse_sdk_skeletons(&cut).unwrap_err().0, 3);
        // Ended by a line end, it was written short: an error.
        assert_eq!(parse_sdk_log(&format!("{cut}\n")).unwrap_err().0, 3);
        // A short line in the middle: an error.
        let middle = format!("{}\n{}\n{}", numbered(7), &numbered(8)[..40], numbered(9));
        assert_eq!(parse_sdk_log(&middle).unwrap_err().0, 2);
        // Complete but going back: the order error, not a cut.
        let back = format!("{complete}{}", numbered(3));
        assert!(parse_sdk_log(&back).unwrap_err().1.contains("go back"));
        // Nothing before the cut line: the cut line's own error.
        assert_eq!(parse_sdk_log(&numbered(9)[..40]).unwrap_err().0, 1);
        // Windows line ends, and trailing spaces after the cut.
        let crlf = format!(
            "{}\r\n{}\r\n{}  ",
            numbered(7),
            numbered(8),
            &numbered(9)[..40]
        );
        let log = parse_sdk_log(&crlf).unwrap();
        assert_eq!((log.frames.len(), log.cut_last_line.unwrap().line), (2, 3));
        // A timed log whose line before the cut one had no body (177 columns): a body line
        // cut at 190 columns is still short of the layout's 202.
        let mut states = String::from("9");
        for _ in 0..25 {
            states.push_str(" 2 0.5 0.5 0.5 0 0 0 1");
        }
        let body = |frame: u32, ms: f64| format!("{frame} {ms} {}", &states[2..]);
        let no_body = |frame: u32, ms: f64| format!("{frame} {ms}{}", " 0".repeat(175));
        let whole = body(12, 66.0);
        let cut_at = whole.match_indices(' ').nth(189).unwrap().0;
        let timed = format!(
            "{}\n{}\n{}",
            body(10, 0.0),
            no_body(11, 33.0),
            &whole[..cut_at]
        );
        let log = parse_sdk_log(&timed).unwrap();
        assert_eq!(log.frames.len(), 2);
        let cut = log.cut_last_line.unwrap();
        assert_eq!((cut.line, cut.columns, cut.expected), (3, 190, 202));
        assert!(
            cut.to_string()
                .starts_with("the last line (3) stops midway (190 of 202 columns"),
            "{cut}"
        );
        let sign = parse_sdk_log(&format!(
            "{complete}{} -",
            &numbered(9)[..numbered(9).len() - 4]
        ));
        assert!(
            sign.unwrap()
                .cut_last_line
                .unwrap()
                .to_string()
                .contains("its last value cut short")
        );
    }

    /// A short line and a non-number are errors naming the line, never panics.
    #[test]
    fn malformed_lines() {
        assert_eq!(parse_sdk_skeletons("1 2 3").unwrap_err().0, 1);
        let mut line = String::from("7");
        for _ in 0..75 {
            line.push_str(" 0.5");
        }
        assert_eq!(parse_sdk_skeletons(&line).unwrap()[0].joints.len(), 25);
        let bad = line.replacen("0.5", "abc", 1);
        let err = parse_sdk_skeletons(&format!("{line}\n{bad}")).unwrap_err();
        assert_eq!(err.0, 2);
        assert!(err.1.contains("abc"));
        // Out of order, joined, an hour apart, negative: errors naming the line.
        let numbered = |n: i64| line.replacen('7', &n.to_string(), 1);
        let two =
            |a: i64, b: i64| parse_sdk_skeletons(&format!("{}\n{}", numbered(a), numbered(b)));
        assert!(two(7, 7).is_ok(), "a repeated number is a repeat");
        let err = two(8, 7).unwrap_err();
        assert_eq!(err.0, 2);
        assert!(err.1.contains("go back"), "{}", err.1);
        let err = two(7, 7 + MAX_SPAN_FRAMES as i64 + 1).unwrap_err();
        assert!(err.1.contains("more than an hour"), "{}", err.1);
        assert!(two(7, 7 + MAX_SPAN_FRAMES as i64).is_ok());
        assert!(two(7, -2).unwrap_err().1.contains("is negative"));
        let mut states = String::from("9");
        for _ in 0..25 {
            states.push_str(" 2 0.5 0.5 0.5 0 0 0 1");
        }
        let err = parse_sdk_skeletons(&format!("{line}\n{states}")).unwrap_err();
        assert_eq!(err.0, 2);
        assert!(err.1.contains("one file holds one layout"), "{}", err.1);
        let timed = |frame: u32, ms: f64| format!("{frame} {ms} {}", &states[2..]);
        assert!(parse_sdk_skeletons(&format!("{}\n{}", timed(1, 0.0), timed(2, 33.0))).is_ok());
        let err =
            parse_sdk_skeletons(&format!("{}\n{}", timed(1, 40.0), timed(2, 5.0))).unwrap_err();
        assert!(err.1.contains("clock went back"), "{}", err.1);
        let err =
            parse_sdk_skeletons(&format!("{}\n{}", timed(1, 0.0), timed(2, 3.7e6))).unwrap_err();
        assert!(err.1.contains("more than an hour"), "{}", err.1);
        assert!(parse_sdk_skeletons("\n\n").is_err());
    }
}
