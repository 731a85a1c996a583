//! What the recorder draws in rerun (STYLE.md §2): a Z-up world with the walkway, each sensor as
//! labelled axes and a frustum in its own colour, its raw joints in its own camera frame, the
//! fused leg skeleton (left blue, right red, a pelvis segment between the hips), ground truth in
//! white, per-axis time series of every joint (thesis Fig. 6.12) and each sensor's clock offset
//! and sync error. The gait panel is [`crate::gait`]; the layout is [`crate::blueprint`].
//!
//! Entity paths:
//! - `world/walkway` (floor outline), `world/sensors/<id>` (transform), `…/<id>/frustum`
//!   (pinhole), `…/<id>/label`, `…/<id>/joints` (raw, camera frame);
//! - `world/fused` (points with keypoint ids; its annotation context names only the joints
//!   logged), `world/fused_bones` (line strips), `world/truth`;
//! - `trajectories/<x|y|z>/<joint>`, `sync/offset_ms/<id>`, `sync/error_ms/<id>`;
//! - `timing/latency_ms` (end to end, per pose: newest contributing frame sent → recorded);
//! - `key` (the colour key), and the gait panel's `gait/…` and `flexion/…` ([`crate::gait`]).
//!
//! Timelines: `time` (seconds since the first instant the recorder saw, the one the viewer
//! opens with), `server_time` (ns since the epoch, server clock) and `set` (aligned-set seq).

use std::collections::BTreeSet;
use std::sync::atomic::{AtomicI64, Ordering};
use std::sync::{Arc, Mutex, PoisonError};

use rerun::{Color, RecordingStream};
use trigait_kinect::Intrinsics;
use trigait_rig::Rig;
use trigait_schema::{FrameTiming, FusedPose};
use trigait_skeleton::Joint;

use crate::config::Config;

/// Timeline of seconds since the run's first instant (the default timeline).
pub const TIME: &str = "time";
/// Timeline of server-clock instants.
pub const SERVER_TIME: &str = "server_time";
/// Timeline of aligned-set numbers.
pub const SET: &str = "set";
/// Entity of the fused skeleton's joints.
pub const FUSED: &str = "world/fused";
/// Entity of the fused skeleton's bones.
pub const BONES: &str = "world/fused_bones";
/// Entity of the ground truth.
pub const TRUTH: &str = "world/truth";
/// Entity of the colour key.
pub const KEY: &str = "key";
/// Root of the per-axis joint trajectories.
pub const TRAJECTORIES: &str = "trajectories";
/// Root of the clock offsets.
pub const SYNC_OFFSET: &str = "sync/offset_ms";
/// Root of the sync error bounds.
pub const SYNC_ERROR: &str = "sync/error_ms";
/// Root of the timing series.
pub const LATENCY_ROOT: &str = "timing";
/// Entity of the end-to-end latency series.
pub const LATENCY: &str = "timing/latency_ms";
/// Root of the stance/swing states per foot.
pub const PHASE: &str = "gait/phase";
/// Root of the heel-strike and toe-off markers.
pub const EVENTS: &str = "gait/events";
/// Entity of the gait parameter table.
pub const PARAMETERS: &str = "gait/parameters";
/// Entity of the gait event log.
pub const LOG: &str = "gait/log";
/// Root of the knee flexion chart.
pub const KNEE: &str = "flexion/knee";
/// Root of the hip flexion chart.
pub const HIP: &str = "flexion/hip";
/// Degrees the knee chart spans.
pub const KNEE_RANGE_DEG: (f64, f64) = (-10.0, 80.0);
/// Degrees the hip chart spans.
pub const HIP_RANGE_DEG: (f64, f64) = (-30.0, 50.0);
/// Chart units per degree on a flexion chart's y axis (x: 1 unit per % of the cycle), so a
/// chart is about twice as wide as high.
pub const CHART_UNITS_PER_DEG: f64 = 0.5;

/// A flexion chart's y coordinate for `deg` (2-D views point y down: up is more flexion).
#[must_use]
pub fn chart_y(deg: f64) -> f32 {
    (-deg * CHART_UNITS_PER_DEG) as f32
}

/// The axes of the trajectory panels and what they mean in the world frame.
pub const AXES: [(&str, &str); 3] = [
    ("x", "along the walkway"),
    ("y", "across it, + to the left"),
    ("z", "height above the floor"),
];
/// Length of the walkway outline along X (m): the thesis's 3 m walking line (§6.4.4), centred
/// on the origin like the simulated walk.
pub const WALKWAY_LENGTH_M: f64 = 3.0;
/// Width of the walkway outline (m).
pub const WALKWAY_WIDTH_M: f64 = 1.0;

/// Left side of the body.
pub const LEFT: Color = rgb(66, 133, 244);
/// Right side of the body.
pub const RIGHT: Color = rgb(234, 67, 53);
/// Midline (pelvis) and ground truth.
const MIDLINE: Color = rgb(200, 200, 200);
const TRUTH_COLOUR: Color = rgb(245, 245, 245);
const WALKWAY: Color = rgb(120, 200, 120);
/// One colour per sensor, in rig order (repeating after eight).
const SENSOR_COLOURS: [Color; 8] = [
    rgb(251, 188, 4),
    rgb(52, 211, 153),
    rgb(192, 120, 255),
    rgb(0, 188, 212),
    rgb(255, 112, 180),
    rgb(180, 140, 90),
    rgb(160, 220, 60),
    rgb(255, 150, 60),
];

/// The colour of `side`'s joints (`None`: a midline joint).
fn side_colour(joint: Joint) -> Color {
    let name = joint.name();
    if name.ends_with("_left") {
        LEFT
    } else if name.ends_with("_right") {
        RIGHT
    } else {
        MIDLINE
    }
}

/// `hip_left` → `left hip`; `spine_base` → `spine base`.
#[must_use]
pub fn display_name(joint: Joint) -> String {
    let name = joint.name();
    for side in ["left", "right"] {
        if let Some(base) = name.strip_suffix(&format!("_{side}")) {
            return format!("{side} {}", base.replace('_', " "));
        }
    }
    name.replace('_', " ")
}

/// A distinct colour per leg joint for the trajectory plots (left cool, right warm), others
/// from the sensor palette.
fn joint_colour(joint: Joint) -> Color {
    match joint {
        Joint::HipLeft => Color::from_rgb(31, 119, 180),
        Joint::KneeLeft => Color::from_rgb(23, 190, 207),
        Joint::AnkleLeft => Color::from_rgb(44, 160, 44),
        Joint::HipRight => Color::from_rgb(214, 39, 40),
        Joint::KneeRight => Color::from_rgb(255, 127, 14),
        Joint::AnkleRight => Color::from_rgb(188, 120, 220),
        other => SENSOR_COLOURS[other.index() % SENSOR_COLOURS.len()],
    }
}

/// An opaque colour, in a constant.
const fn rgb(r: u8, g: u8, b: u8) -> Color {
    Color(rerun::datatypes::Rgba32(u32::from_be_bytes([r, g, b, 255])))
}

fn f32x3(p: &nalgebra::Point3<f64>) -> [f32; 3] {
    [p.x as f32, p.y as f32, p.z as f32]
}

/// The recording stream and what the drawing remembers: the run's first instant (the zero of
/// the `time` timeline) and the joints the skeleton's annotation context declares. Clones share
/// both, so a thread drawing the gait panel ([`crate::gait`]) keeps the same clock.
#[derive(Debug, Clone)]
pub struct Viz {
    rec: RecordingStream,
    /// `i64::MIN` until the first instant is seen.
    start_nanos: Arc<AtomicI64>,
    declared: Arc<Mutex<BTreeSet<Joint>>>,
    sensors: Arc<Vec<String>>,
}

impl std::ops::Deref for Viz {
    type Target = RecordingStream;

    fn deref(&self) -> &RecordingStream {
        &self.rec
    }
}

impl Viz {
    /// Sets the timelines to the server-clock instant `stamp_nanos`.
    pub fn set_time(&self, stamp_nanos: i64) {
        let start = match self.start_nanos.compare_exchange(
            i64::MIN,
            stamp_nanos,
            Ordering::Relaxed,
            Ordering::Relaxed,
        ) {
            Ok(_) => stamp_nanos,
            Err(first) => first,
        };
        self.rec.reset_time();
        self.rec
            .set_timestamp_nanos_since_epoch(SERVER_TIME, stamp_nanos);
        // The `time` timeline counts from the first instant drawn and cannot go below it; an
        // earlier instant is drawn on `server_time` only.
        if stamp_nanos >= start {
            self.rec
                .set_duration_secs(TIME, (stamp_nanos - start) as f64 * 1e-9);
        }
    }

    fn sensor_colour(&self, id: &str) -> Color {
        let i = self.sensors.iter().position(|s| s == id).unwrap_or(0);
        SENSOR_COLOURS[i % SENSOR_COLOURS.len()]
    }

    /// Declares the joints of `pose` in the skeleton's annotation context when one is new: the
    /// context names exactly the joints logged. It lists no keypoint connections: the bones
    /// are their own line strips, so a joint missing from one pose leaves no connection the
    /// viewer cannot resolve.
    fn declare(&self, pose: &FusedPose) -> eyre::Result<()> {
        let mut declared = self.declared.lock().unwrap_or_else(PoisonError::into_inner);
        if pose.joints.keys().all(|j| declared.contains(j)) {
            return Ok(());
        }
        declared.extend(pose.joints.keys().copied());
        self.rec.log_static(
            FUSED,
            &rerun::AnnotationContext::new([rerun::datatypes::ClassDescription {
                info: (0, "fused skeleton").into(),
                keypoint_annotations: declared
                    .iter()
                    .map(|j| rerun::datatypes::AnnotationInfo {
                        id: j.index() as u16,
                        label: Some(display_name(*j).into()),
                        color: Some(side_colour(*j).0),
                    })
                    .collect(),
                keypoint_connections: Vec::new(),
            }]),
        )?;
        for joint in declared.iter() {
            for (axis, _) in AXES {
                self.rec.log_static(
                    format!("{TRAJECTORIES}/{axis}/{}", joint.name()),
                    &rerun::SeriesLines::new()
                        .with_names([display_name(*joint)])
                        .with_colors([joint_colour(*joint)])
                        .with_widths([1.5_f32]),
                )?;
            }
        }
        Ok(())
    }
}

/// Opens the recording: the `.rrd` file, a live viewer, both, or (neither configured) an
/// in-memory sink that is dropped.
pub fn open(config: &Config) -> eyre::Result<Viz> {
    use eyre::Context;
    let builder = rerun::RecordingStreamBuilder::new("trigait");
    let rec = match (&config.rrd, &config.connect) {
        (Some(path), None) => {
            if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir)
                    .with_context(|| format!("recorder: creating {}", dir.display()))?;
            }
            builder
                .save(path)
                .with_context(|| format!("recorder: RRD={}", path.display()))?
        }
        (None, Some(url)) => builder
            .set_sinks(vec![viewer_sink(url)?])
            .with_context(|| format!("recorder: RERUN_CONNECT={url:?}"))?,
        (Some(path), Some(url)) => {
            if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir)
                    .with_context(|| format!("recorder: creating {}", dir.display()))?;
            }
            let file = rerun::sink::FileSink::new(path)
                .with_context(|| format!("recorder: RRD={}", path.display()))?;
            builder
                .set_sinks(vec![
                    Box::new(file) as Box<dyn rerun::sink::LogSink>,
                    viewer_sink(url)?,
                ])
                .context("recorder: opening the rerun sinks")?
        }
        (None, None) => builder.buffered().context("recorder: opening rerun")?,
    };
    Ok(Viz {
        rec,
        start_nanos: Arc::new(AtomicI64::new(i64::MIN)),
        declared: Arc::new(Mutex::new(BTreeSet::new())),
        sensors: Arc::new(config.rig.sensors.iter().map(|s| s.id.clone()).collect()),
    })
}

/// The live viewer at `url`, which never makes the recorder wait ([`ViewerSink`]).
///
/// [`ViewerSink`]: trigait_rerun_viewer::ViewerSink
fn viewer_sink(url: &str) -> eyre::Result<Box<dyn rerun::sink::LogSink>> {
    let sink = trigait_rerun_viewer::ViewerSink::new(url)
        .map_err(|e| eyre::eyre!("recorder: RERUN_CONNECT={e}"))?;
    Ok(Box::new(sink))
}

/// Sends the default layout ([`crate::blueprint`]) before any data, so a file and a live viewer
/// open with it alike.
pub fn send_blueprint(viz: &Viz, rig: &Rig) -> eyre::Result<()> {
    crate::blueprint::send(&viz.rec, rig).map(|_| ())
}

/// The colour key under the 3-D view.
const KEY_TEXT: &str = "**Key** — big dots and bones: the fused skeleton (blue left, red \
right, grey pelvis) · small dots: each sensor's own joints, in its colour · white: ground truth \
· green: the 3 m walkway · hover a dot for its joint.  \n**Flexion charts**: x is % of the \
gait cycle, from a heel strike to the same foot's next; thin lines the last 10 cycles, thick \
the mean of all; blue left, red right.";

/// Static content: axes convention, walkway, sensors, the colour key, the series styles.
pub fn log_static(viz: &Viz, rig: &Rig) -> eyre::Result<()> {
    let rec = &viz.rec;
    rec.log_static("world", &rerun::ViewCoordinates::RIGHT_HAND_Z_UP())?;
    let (l, w) = (WALKWAY_LENGTH_M as f32 / 2.0, WALKWAY_WIDTH_M as f32 / 2.0);
    rec.log_static(
        "world/walkway",
        &rerun::LineStrips3D::new([[
            [-l, -w, 0.0],
            [l, -w, 0.0],
            [l, w, 0.0],
            [-l, w, 0.0],
            [-l, -w, 0.0],
        ]])
        .with_colors([WALKWAY])
        .with_radii([0.01_f32])
        .with_labels(["walkway"])
        .with_show_labels(false),
    )?;
    let k = Intrinsics::default();
    for sensor in &rig.sensors {
        let colour = viz.sensor_colour(&sensor.id);
        let t = sensor.world_from_kinect.translation.vector;
        let q = sensor.world_from_kinect.rotation.into_inner();
        let path = format!("world/sensors/{}", sensor.id);
        rec.log_static(
            path.as_str(),
            &rerun::Transform3D::from_translation_rotation(
                [t.x as f32, t.y as f32, t.z as f32],
                rerun::Quaternion::from_xyzw([q.i as f32, q.j as f32, q.k as f32, q.w as f32]),
            ),
        )?;
        rec.log_static(format!("{path}/axes"), &rerun::TransformAxes3D::new(0.2))?;
        rec.log_static(
            format!("{path}/frustum"),
            &rerun::Pinhole::from_focal_length_and_resolution(
                [k.fx as f32, k.fy as f32],
                [k.width as f32, k.height as f32],
            )
            .with_camera_xyz(rerun::components::ViewCoordinates::LUF)
            .with_image_plane_distance(0.25)
            .with_color(colour),
        )?;
        rec.log_static(
            format!("{path}/label"),
            &rerun::Points3D::new([[0.0_f32, 0.0, 0.0]])
                .with_radii([0.04_f32])
                .with_colors([colour])
                .with_labels([format!("sensor {}", sensor.id)])
                .with_show_labels(true),
        )?;
        rec.log_static(
            format!("{SYNC_OFFSET}/{}", sensor.id),
            &rerun::SeriesLines::new()
                .with_names([format!("{} offset", sensor.id)])
                .with_colors([colour]),
        )?;
        rec.log_static(
            format!("{SYNC_ERROR}/{}", sensor.id),
            &rerun::SeriesLines::new()
                .with_names([format!("{} error bound", sensor.id)])
                .with_colors([colour]),
        )?;
    }
    rec.log_static(KEY, &rerun::TextDocument::from_markdown(KEY_TEXT))?;
    rec.log_static(
        LATENCY,
        &rerun::SeriesLines::new()
            .with_names(["latency per pose (ms)"])
            .with_colors([Color::from_rgb(200, 200, 200)]),
    )?;
    Ok(())
}

/// One fused pose, with the ground truth at its instant when known.
pub fn log_pose(
    viz: &Viz,
    pose: &FusedPose,
    truth: &[nalgebra::Point3<f64>],
    latency_nanos: Option<i64>,
) -> eyre::Result<()> {
    viz.declare(pose)?;
    let rec = &viz.rec;
    viz.set_time(pose.stamp_nanos);
    rec.set_time_sequence(SET, i64::try_from(pose.set_seq).unwrap_or(i64::MAX));
    let points: Vec<[f32; 3]> = pose.joints.values().map(|j| f32x3(&j.position)).collect();
    let ids: Vec<u16> = pose.joints.keys().map(|j| j.index() as u16).collect();
    rec.log(
        FUSED,
        &rerun::Points3D::new(points)
            .with_class_ids([0_u16])
            .with_keypoint_ids(ids)
            .with_radii([0.035_f32])
            .with_colors(pose.joints.keys().map(|j| side_colour(*j)))
            .with_labels(pose.joints.keys().map(|j| display_name(*j)))
            .with_show_labels(false),
    )?;
    let (bones, colours): (Vec<[[f32; 3]; 2]>, Vec<Color>) = Joint::BONES
        .iter()
        .chain(std::iter::once(&(Joint::HipLeft, Joint::HipRight)))
        .filter_map(|(a, b)| {
            let colour = if side_colour(*a) == side_colour(*b) {
                side_colour(*a)
            } else {
                MIDLINE
            };
            Some((
                [
                    f32x3(&pose.joints.get(a)?.position),
                    f32x3(&pose.joints.get(b)?.position),
                ],
                colour,
            ))
        })
        .unzip();
    rec.log(
        BONES,
        &rerun::LineStrips3D::new(bones)
            .with_colors(colours)
            .with_radii([0.018_f32]),
    )?;
    if !truth.is_empty() {
        rec.log(
            TRUTH,
            &rerun::Points3D::new(truth.iter().map(f32x3))
                .with_radii([0.012_f32])
                .with_colors([TRUTH_COLOUR]),
        )?;
    }
    for (joint, fused) in &pose.joints {
        for ((axis, _), v) in AXES.iter().zip(fused.position.iter()) {
            rec.log(
                format!("{TRAJECTORIES}/{axis}/{}", joint.name()),
                &rerun::Scalars::single(*v),
            )?;
        }
    }
    if let Some(latency) = latency_nanos {
        rec.log(LATENCY, &rerun::Scalars::single(latency as f64 * 1e-6))?;
    }
    Ok(())
}

/// One raw frame, drawn in its sensor's camera frame at its server stamp, else when `sync`
/// received it (a replay's recorded instant, not this run's clock), else at `now_nanos`.
pub fn log_raw(viz: &Viz, frame: &FrameTiming, now_nanos: i64) -> eyre::Result<()> {
    viz.set_time(
        frame
            .server_stamp_nanos
            .or(frame.received_nanos)
            .unwrap_or(now_nanos),
    );
    viz.rec.log(
        format!("world/sensors/{}/joints", frame.sensor_id),
        &rerun::Points3D::new(frame.joints.iter().map(|s| f32x3(&s.position_in_kinect)))
            .with_radii([0.015_f32])
            .with_colors([viz.sensor_colour(&frame.sensor_id)]),
    )?;
    Ok(())
}

/// Clock offsets and mapping error bounds.
pub fn log_timing(viz: &Viz, rows: &[FrameTiming]) -> eyre::Result<()> {
    for row in rows {
        let Some(server) = row.server_stamp_nanos else {
            continue;
        };
        viz.set_time(server);
        if let Some(offset) = row.offset_nanos {
            viz.rec.log(
                format!("{SYNC_OFFSET}/{}", row.sensor_id),
                &rerun::Scalars::single(offset as f64 * 1e-6),
            )?;
        }
        if let Some(err) = row.error_nanos() {
            viz.rec.log(
                format!("{SYNC_ERROR}/{}", row.sensor_id),
                &rerun::Scalars::single(err as f64 * 1e-6),
            )?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn joint_names_read_as_words() {
        assert_eq!(display_name(Joint::HipLeft), "left hip");
        assert_eq!(display_name(Joint::AnkleRight), "right ankle");
        assert_eq!(display_name(Joint::SpineBase), "spine base");
        assert_eq!(side_colour(Joint::KneeLeft), LEFT);
        assert_eq!(side_colour(Joint::SpineBase), MIDLINE);
    }
}
