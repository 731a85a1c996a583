//! `leg-tracker`: a lower-body skeleton from one sensor's depth frames, for sensors without the
//! Kinect SDK's body tracker (a Kinect v2 on Linux gives depth and no skeleton). Each
//! `depth_frame` on `depth` goes through [`trigait_leg_tracker::LegTracker`] — the tracker
//! `trigait legs` runs on PNG files — and comes out on `frame` as the `skeleton_frame` an
//! SDK-like source sends: same sensor, seq and sensor-clock stamp, hips, knees, ankles and
//! feet with an SDK-like state, and the depth frame's metadata (rig stamp, true stamp,
//! end of stream, send instant) passed on, so `sync`, `trilaterate` and the recorder are
//! unchanged. A frame in which nobody is tracked goes out without joints, as the SDK's would.
//! A malformed message, a frame of another sensor or of the wrong size is counted and skipped.
//! With `RERUN`, each frame's person mask and fitted legs are logged for debugging
//! ([`trigait_depth_rerun::log_legs`]).
//! Each frame is taken by the camera its source stamped (`trigait.depth_pinhole`, an
//! undistorted real frame), otherwise the configured (nominal) camera ([`frame_camera`]).
//! Configuration: [`config`].

mod config;
#[cfg(test)]
mod tests;

use std::collections::BTreeMap;

use dora_node_api::dora_core::config::DataId;
use dora_node_api::{DoraNode, Event, EventStream};
use eyre::Context;
use tracing::{info, warn};
use trigait_depth::{DepthFrame, HEIGHT, WIDTH};
use trigait_depth_rerun::RecordingStream;
use trigait_leg_tracker::{LegTracker, Status, TrackedFrame};
use trigait_schema::{DepthFrameMessage, Message, SkeletonFrameMessage, ports};
use trigait_skeleton::{Joint, SkeletonFrame, TrackingState};

use crate::config::Config;

fn main() -> eyre::Result<()> {
    let config = Config::from_env()?;
    trigait_node_log::init(&format!("leg-tracker {}", config.sensor_id));
    let (node, events) =
        DoraNode::init_from_env().context("leg-tracker: connecting to the dora daemon")?;
    run(config, node, events).map(|_| ())
}

/// Frames the tracker's floor matches the depth poorly, without a better one found, before
/// the node says so (5 s at 30 Hz).
const FLOOR_DOUBT_TOLD_FRAMES: usize = 150;

/// Totals the node reports at the end.
#[derive(Debug, Default, Clone, PartialEq, Eq)]
pub struct Counters {
    /// Skeleton frames sent.
    pub frames_sent: u64,
    /// Inputs that did not decode as `depth_frame` (skipped).
    pub malformed: u64,
    /// Frames of another sensor (skipped).
    pub wrong_sensor: u64,
    /// Frames that are not 512×424 (skipped).
    pub wrong_size: u64,
    /// Frames sent, by the tracker's outcome (`no_data`, `no_floor`, `nobody`, `too_close`,
    /// `tracking`, `no_stature`, `not_standing`).
    pub by_status: BTreeMap<&'static str, u64>,
    /// Floors fitted afresh because the one in use no longer matched the depth.
    pub floor_refits: u64,
    /// Bodies learned afresh because the person's stature changed.
    pub bodies_relearned: u64,
    /// Joints sent tracked.
    pub joints_tracked: u64,
    /// Joints sent inferred.
    pub joints_inferred: u64,
}

/// Why a depth message was not tracked.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Refused {
    /// It did not decode.
    Malformed(String),
    /// It is another sensor's.
    WrongSensor(String),
    /// Its size is not the Kinect v2's.
    WrongSize(u32, u32),
}

impl std::fmt::Display for Refused {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Refused::Malformed(e) => write!(f, "malformed depth_frame: {e}"),
            Refused::WrongSensor(s) => write!(f, "a depth frame of sensor {s:?}"),
            Refused::WrongSize(w, h) => write!(
                f,
                "a depth frame of {w}x{h} pixels, the tracker needs {WIDTH}x{HEIGHT}"
            ),
        }
    }
}

/// The name of a tracker outcome in the counts and logs.
#[must_use]
pub fn status_name(status: Status) -> &'static str {
    match status {
        Status::NoData => "no_data",
        Status::NoFloor => "no_floor",
        Status::Nobody => "nobody",
        Status::Tracking => "tracking",
        Status::NoStature => "no_stature",
        Status::TooClose => "too_close",
        Status::NotStanding => "not_standing",
    }
}

/// Logs `tracked` (frame `seq`) to the debugging sink: the person mask and the fitted legs.
fn log_debug(
    rec: &RecordingStream,
    sensor: &str,
    seq: u64,
    tracked: &TrackedFrame,
) -> Result<(), trigait_depth_rerun::RecordingStreamError> {
    let f32x3 = |p: &nalgebra::Point3<f64>| [p.x as f32, p.y as f32, p.z as f32];
    let joints: Vec<(String, [f32; 3])> = tracked
        .joints
        .iter()
        .map(|j| (format!("{:?}", j.joint), f32x3(&j.position_in_kinect)))
        .collect();
    let chains: Vec<Vec<[f32; 3]>> = [
        [
            Joint::HipLeft,
            Joint::KneeLeft,
            Joint::AnkleLeft,
            Joint::FootLeft,
        ],
        [
            Joint::HipRight,
            Joint::KneeRight,
            Joint::AnkleRight,
            Joint::FootRight,
        ],
    ]
    .iter()
    .map(|chain| {
        chain
            .iter()
            .filter_map(|j| tracked.joint(*j).map(|t| f32x3(&t.position_in_kinect)))
            .collect()
    })
    .collect();
    trigait_depth_rerun::log_legs(rec, sensor, seq, &tracked.person_mask, &joints, &chains)
}

/// What [`track_message`] made of one depth frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Tracked {
    /// The skeleton frame to send.
    pub frame: SkeletonFrame,
    /// The tracker's outcome.
    pub status: Status,
    /// Whether the tracker fitted its floor afresh (the sensor moved).
    pub floor_refitted: bool,
    /// Frames in a row the floor has matched the depth poorly without a better one found.
    pub floor_doubted_frames: usize,
    /// Whether the tracker began to learn the body afresh (someone else walked in, or someone
    /// stood up).
    pub body_relearned: bool,
}

/// Tracks one `depth_frame` of `sensor_id`: the skeleton frame to send and the outcome; with
/// `rec`, logs what the tracker made of it.
///
/// # Errors
/// [`Refused`] for a message that is not a 512×424 depth frame of `sensor_id`.
pub fn track_message(
    tracker: &mut LegTracker,
    sensor_id: &str,
    array: &dyn trigait_schema::Array,
    rec: Option<&RecordingStream>,
) -> Result<Tracked, Refused> {
    let message =
        DepthFrameMessage::decode(array).map_err(|e| Refused::Malformed(e.to_string()))?;
    if message.sensor_id != sensor_id {
        return Err(Refused::WrongSensor(message.sensor_id));
    }
    if (message.width, message.height) != (WIDTH as u32, HEIGHT as u32) {
        return Err(Refused::WrongSize(message.width, message.height));
    }
    let depth = DepthFrame::from_mm(message.depth_mm)
        .map_err(|_| Refused::WrongSize(message.width, message.height))?;
    let tracked = tracker.track(&depth);
    if let Some(rec) = rec
        && let Err(e) = log_debug(rec, sensor_id, message.seq, &tracked)
    {
        warn!("rerun: {e}");
    }
    let frame = SkeletonFrame {
        sensor_id: message.sensor_id,
        seq: message.seq,
        local_stamp_nanos: message.local_stamp_nanos,
        joints: tracked.joint_samples(),
    };
    Ok(Tracked {
        frame,
        status: tracked.status,
        floor_refitted: tracked.floor_refitted,
        floor_doubted_frames: tracked.floor_doubted_frames,
        body_relearned: tracked.body_relearned,
    })
}

/// The tracker's camera for a frame with metadata `params`: the pinhole its source stamped on
/// an undistorted real frame ([`trigait_node_config::stamped_pinhole`], in
/// `trigait_camera::Intrinsics`' convention where pixel index u looks along (u − cx)/fx; this
/// camera's column u spans u..u+1, so its principal point is half a pixel further), otherwise
/// `configured` (the nominal camera).
#[must_use]
pub fn frame_camera(
    configured: &trigait_kinect::Intrinsics,
    params: &dora_node_api::MetadataParameters,
) -> trigait_kinect::Intrinsics {
    trigait_node_config::stamped_pinhole(params).map_or(*configured, |[fx, fy, cx, cy]| {
        trigait_kinect::Intrinsics {
            fx,
            fy,
            cx: cx + 0.5,
            cy: cy + 0.5,
            ..*configured
        }
    })
}

/// Makes `tracker` see through `camera` ([`frame_camera`]): when it is not the tracker's
/// camera, the tracker is rebuilt with it (its rays are precomputed), which starts its
/// tracking afresh. Returns whether it was rebuilt.
///
/// # Errors
/// The tracker refuses the camera.
pub fn use_camera(
    tracker: &mut LegTracker,
    camera: trigait_kinect::Intrinsics,
) -> eyre::Result<bool> {
    if tracker.config().camera.intrinsics == camera {
        return Ok(false);
    }
    let mut config = tracker.config().clone();
    config.camera.intrinsics = camera;
    *tracker = LegTracker::new(config).context("leg-tracker: the depth camera changed")?;
    Ok(true)
}

/// The event loop.
pub fn run(config: Config, mut node: DoraNode, mut events: EventStream) -> eyre::Result<Counters> {
    let rec = config
        .rerun
        .as_ref()
        .map(|sink| trigait_depth_rerun::open("trigait-legs", sink))
        .transpose()
        .map_err(|e| eyre::eyre!("leg-tracker: {}: {e}", config::RERUN))?;
    let mut tracker =
        LegTracker::new(config.tracker).context("leg-tracker: building the tracker")?;
    let configured_camera = tracker.config().camera.intrinsics;
    let frame_out = DataId::from(ports::FRAME.to_owned());
    let mut counters = Counters::default();
    // Whether the floor's current spell of doubt has been logged.
    let mut doubt_told = false;
    while let Some(event) = events.recv() {
        trigait_node_log::warn_drops(&mut events);
        match event {
            Event::Input { id, metadata, data } => match id.as_str() {
                ports::DEPTH => {
                    let camera = frame_camera(&configured_camera, &metadata.parameters);
                    if use_camera(&mut tracker, camera)? {
                        info!("depth camera: {camera:?}");
                    }
                    let Tracked {
                        frame,
                        status,
                        floor_refitted,
                        floor_doubted_frames,
                        body_relearned,
                    } = match track_message(
                        &mut tracker,
                        &config.sensor_id,
                        data.as_array().as_ref(),
                        rec.as_ref(),
                    ) {
                        Ok(out) => out,
                        Err(why) => {
                            let count = match &why {
                                Refused::Malformed(_) => &mut counters.malformed,
                                Refused::WrongSensor(_) => &mut counters.wrong_sensor,
                                Refused::WrongSize(..) => &mut counters.wrong_size,
                            };
                            if *count == 0 {
                                warn!("skipping {why} (counted; further ones are not logged)");
                            }
                            *count += 1;
                            continue;
                        }
                    };
                    for j in &frame.joints {
                        match j.state {
                            TrackingState::Tracked => counters.joints_tracked += 1,
                            TrackingState::Inferred => counters.joints_inferred += 1,
                            TrackingState::NotTracked => {}
                        }
                    }
                    *counters.by_status.entry(status_name(status)).or_insert(0) += 1;
                    if floor_doubted_frames == 0 {
                        doubt_told = false;
                    } else if floor_doubted_frames >= FLOOR_DOUBT_TOLD_FRAMES && !doubt_told {
                        doubt_told = true;
                        warn!(
                            "{}: the floor has matched the depth poorly for {floor_doubted_frames} frames and no better one was found: something large hides it, or the sensor moved to where too little floor is in view",
                            config.sensor_id
                        );
                    }
                    if body_relearned {
                        counters.bodies_relearned += 1;
                        info!(
                            "{}: the person's stature changed (someone else found, someone who sat and stood up, or a hand held over the head): learning their stature and leg lengths afresh",
                            config.sensor_id
                        );
                    }
                    if floor_refitted {
                        counters.floor_refits += 1;
                        warn!(
                            "{}: the floor no longer matched the depth (the sensor moved?): fitted it afresh and finding the legs again; its pose in the rig may need calibrating again",
                            config.sensor_id
                        );
                    }
                    let array = SkeletonFrameMessage::from(frame)
                        .encode()
                        .context("leg-tracker: encoding a skeleton frame")?;
                    node.send_output(frame_out.clone(), metadata.parameters, array)
                        .context("leg-tracker: sending frame")?;
                    counters.frames_sent += 1;
                }
                other => warn!(input = other, "ignoring an unknown input"),
            },
            Event::Error(e) => warn!("event stream error: {e}"),
            _ => {}
        }
    }
    let statuses: Vec<String> = counters
        .by_status
        .iter()
        .map(|(s, n)| format!("{s} {n}"))
        .collect();
    info!(
        "{} frames sent ({}), {} joints tracked, {} inferred, floor fitted afresh {} times, {} bodies learned afresh; skipped: {} malformed, {} of another sensor, {} of the wrong size",
        counters.frames_sent,
        if statuses.is_empty() {
            "none".to_owned()
        } else {
            statuses.join(", ")
        },
        counters.joints_tracked,
        counters.joints_inferred,
        counters.floor_refits,
        counters.bodies_relearned,
        counters.malformed,
        counters.wrong_sensor,
        counters.wrong_size
    );
    Ok(counters)
}
