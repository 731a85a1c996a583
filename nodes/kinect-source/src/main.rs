//! `kinect-source`: one Kinect v2 sensor in the dataflow. Sends a `skeleton_frame` per capture
//! on `frame` (sensor clock; with `BACKEND: body-depth` a `depth_frame` on `depth` instead,
//! [`body_depth`]), answers `ntp_request`s addressed to it with its own clock on
//! `ntp_reply`, and — when simulated, from the one source of the graph that sends it (by default
//! the rig's first sensor) — the world-frame ground truth on `ground_truth`.
//! Configuration: [`config`].

mod backend;
mod body_depth;
mod config;
mod depth;
mod freenect2;
mod ntp;
#[cfg(test)]
mod tests;

use std::time::Duration;

use dora_node_api::dora_core::config::DataId;
use dora_node_api::{DoraNode, Event, EventStream, MetadataParameters, Parameter};
use eyre::Context;
use tracing::{info, warn};
use trigait_schema::{GroundTruth, Message, SkeletonFrameMessage, ports};

use trigait_node_config::RigStamp;

use crate::backend::{Captured, Source, now_nanos, sensor_clock};
use crate::config::Config;

fn main() -> eyre::Result<()> {
    let config = Config::from_env()?;
    trigait_node_log::init(&format!("kinect-source {}", config.sensor_id));
    if config.backend == config::Backend::Freenect2 {
        // A real Kinect runs its own loop: frames come when the device sends them.
        return freenect2::main(config).map(|_| ());
    }
    let mut source = Source::new(&config, now_nanos())?;
    let (node, events) =
        DoraNode::init_from_env().context("kinect-source: connecting to the dora daemon")?;
    match made_at_nanos(node.dataflow_id()) {
        Some(epoch) => source.start_lap_at(epoch),
        None => warn!(
            "the dataflow id {} carries no time: a simulated walk's phase follows the host clock",
            node.dataflow_id()
        ),
    }
    run(config, source, node, events).map(|_| ())
}

/// When the dataflow was made (host time, ns): dora's dataflow ids are time-ordered UUIDs
/// (version 7), whose first 48 bits are the Unix time in milliseconds. `None` for another
/// version.
fn made_at_nanos(id: &dora_node_api::uuid::Uuid) -> Option<i64> {
    if id.get_version_num() != 7 {
        return None;
    }
    let b = id.as_bytes();
    let millis = b[..6]
        .iter()
        .fold(0_i64, |ms, byte| (ms << 8) | i64::from(*byte));
    Some(millis * 1_000_000)
}

/// Counters the node reports when it ends.
#[derive(Debug, Default, Clone, PartialEq, Eq)]
pub struct Counters {
    /// Frames sent.
    pub frames_sent: u64,
    /// NTP requests answered.
    pub ntp_answered: u64,
    /// Inputs that could not be decoded (skipped).
    pub malformed: u64,
}

/// The event loop: capture when due, answer NTP requests in between.
pub fn run(
    config: Config,
    mut source: Source,
    mut node: DoraNode,
    mut events: EventStream,
) -> eyre::Result<Counters> {
    let frame_out = DataId::from(ports::FRAME.to_owned());
    let truth_out = DataId::from(ports::GROUND_TRUTH.to_owned());
    let ntp = ntp::Responder::new(&config.sensor_id);
    let depth_out = DataId::from(ports::DEPTH.to_owned());
    let mut depth = config
        .depth
        .as_ref()
        .map(|d| depth::DepthStream::new(d, &config, now_nanos()))
        .transpose()?;
    let mut clock = sensor_clock(&config, now_nanos());
    let mut counters = Counters::default();
    let stamp = RigStamp::new(&config.sensor_id, &config.rig);
    let mut first_frame_nanos = None;
    source.begin_at(now_nanos());
    loop {
        while let Some(due) = source.next_due().filter(|due| *due <= now_nanos()) {
            let Some(captured) = source.capture(due.max(now_nanos()), &mut clock) else {
                break;
            };
            let first = *first_frame_nanos.get_or_insert(due);
            // The run's planned end, or the end of a replayed file: this frame is the last,
            // and says so (sync then stops waiting for this sensor, as it did when recording).
            let planned = config
                .stop_after_nanos
                .is_some_and(|run| due - first >= run);
            let last = planned || source.played_out();
            let out = match source.take_depth() {
                Some(depth) => Out::Depth(&depth_out, depth),
                None => Out::Frame(&frame_out),
            };
            send_capture(&mut node, out, &truth_out, &stamp, last, captured)?;
            counters.frames_sent += 1;
            if planned {
                info!(
                    "stopping after {} frames ({}){}",
                    counters.frames_sent,
                    config::STOP_AFTER_SECS,
                    source
                        .losses()
                        .map(|l| format!("; {l}"))
                        .unwrap_or_default()
                );
                return Ok(counters);
            }
            if config.frame_limit_reached(counters.frames_sent) {
                return Ok(counters);
            }
        }
        depth::send_due(depth.as_mut(), &mut node, &depth_out, &mut clock)?;
        let Some(due) = source.next_due() else {
            info!("replay finished after {} frames", counters.frames_sent);
            return Ok(counters);
        };
        let due = depth::earliest(due, depth.as_ref());
        let wait_nanos = u64::try_from(due - now_nanos()).unwrap_or(0);
        let Some(event) = events.recv_timeout(Duration::from_nanos(wait_nanos)) else {
            break;
        };
        trigait_node_log::warn_drops(&mut events);
        match event {
            Event::Input { id, metadata, data } => match id.as_str() {
                ports::NTP_REQUEST => {
                    let t2 = clock.local(now_nanos());
                    ntp.answer(
                        &mut node,
                        metadata.parameters,
                        data.as_array().as_ref(),
                        t2,
                        || {
                            source.receiver_ready(now_nanos());
                            clock.local(now_nanos())
                        },
                        ntp::NtpCounts {
                            answered: &mut counters.ntp_answered,
                            malformed: &mut counters.malformed,
                        },
                    )?;
                }
                other => warn!(input = other, "ignoring an unknown input"),
            },
            Event::Stop(_) | Event::InputClosed { .. } => {}
            Event::Error(e) if e.contains("Timeout") || e.contains("timed out") => {}
            Event::Error(e) => warn!("event stream error: {e}"),
            _ => {}
        }
    }
    info!(
        "{} frames sent, {} NTP requests answered, {} malformed inputs{}",
        counters.frames_sent,
        counters.ntp_answered,
        counters.malformed,
        source
            .losses()
            .map(|l| format!("; {l}"))
            .unwrap_or_default()
    );
    Ok(counters)
}

/// Where a capture goes: its skeleton frame on `frame`, or (body depth) a depth frame on
/// `depth` in its place, with the same metadata.
enum Out<'a> {
    Frame(&'a DataId),
    Depth(&'a DataId, trigait_schema::DepthFrameMessage),
}

fn send_capture(
    node: &mut DoraNode,
    out: Out<'_>,
    truth_out: &DataId,
    stamp: &RigStamp,
    last: bool,
    captured: Captured,
) -> eyre::Result<()> {
    let mut params = MetadataParameters::default();
    stamp.insert_into(&mut params);
    if last {
        params.insert(ports::END_OF_STREAM.to_owned(), Parameter::Bool(true));
    }
    params.insert(
        ports::SENT_NANOS.to_owned(),
        Parameter::Integer(now_nanos()),
    );
    if let Some(t) = captured.true_stamp_nanos {
        params.insert(ports::TRUE_STAMP_NANOS.to_owned(), Parameter::Integer(t));
    }
    if let Some(r) = captured.recorded {
        if let Some(server) = r.server_stamp_nanos {
            params.insert(
                ports::RECORDED_SERVER_STAMP_NANOS.to_owned(),
                Parameter::Integer(server),
            );
            params.insert(
                ports::RECORDED_UNCERTAINTY_NANOS.to_owned(),
                Parameter::Integer(r.uncertainty_nanos),
            );
        }
        if let Some(received) = r.received_nanos {
            params.insert(
                ports::RECORDED_RECEIVED_NANOS.to_owned(),
                Parameter::Integer(received),
            );
        }
    }
    match out {
        Out::Frame(frame_out) => {
            let array = SkeletonFrameMessage::from(captured.frame)
                .encode()
                .context("encoding a skeleton frame")?;
            node.send_output(frame_out.clone(), params, array)
                .context("kinect-source: sending frame")?;
        }
        Out::Depth(depth_out, depth) => {
            let array = depth.encode().context("encoding a depth frame")?;
            node.send_output(depth_out.clone(), params, array)
                .context("kinect-source: sending depth")?;
        }
    }
    if !captured.truth.is_empty() {
        let array = GroundTruth::encode_many(&captured.truth).context("encoding ground truth")?;
        node.send_output(truth_out.clone(), MetadataParameters::default(), array)
            .context("kinect-source: sending ground_truth")?;
    }
    Ok(())
}
