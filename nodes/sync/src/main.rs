//! `sync`: the server clock of the dataflow. Runs the four-timestamp NTP exchange with every
//! source (a cycle in the graph: `ntp_request` out, `ntp_<id>` in), maps each `frame_<id>` onto
//! the server clock with [`trigait_sync::SyncBuffer`], and sends the [`AlignedSet`]s its policy
//! makes on `aligned_set`, plus every frame's placement on `frame_timing`. Configuration:
//! [`config`].

mod config;
#[cfg(test)]
mod tests;

use dora_node_api::dora_core::config::DataId;
use dora_node_api::{
    DoraNode, Event, EventStream, MetadataParameters, Parameter, get_integer_param,
};
use std::collections::HashMap;

use eyre::{Context, bail};
use tracing::{info, warn};
use trigait_schema::{FrameTiming, Message, NtpExchange, SkeletonFrameMessage, ports};
use trigait_sync::{AlignedSet, Error as SyncError, NtpSchedule, SyncBuffer};

use crate::config::Config;

fn main() -> eyre::Result<()> {
    trigait_node_log::init("sync");
    let config = Config::from_env()?;
    let (node, events) =
        DoraNode::init_from_env().context("sync: connecting to the dora daemon")?;
    let sensors = match &config.sensors {
        Some(ids) => ids.clone(),
        None => sensors_from_inputs(node.node_config().inputs.keys().map(|id| id.as_str()))?,
    };
    let routes = ntp_routes(
        node.node_config().outputs.iter().map(|id| id.as_str()),
        &sensors,
    )?;
    run(config, sensors, routes, node, events).map(|_| ())
}

/// Where the NTP requests of each sensor go.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum NtpRoutes {
    /// One `ntp_request` output that every source reads (each ignores requests addressed to
    /// another sensor): simple to wire, but n² deliveries per NTP round.
    Broadcast,
    /// One `ntp_request_<id>` output per sensor, read only by that source.
    PerSensor(HashMap<String, DataId>),
}

/// The NTP routing the graph declares: `ntp_request_<id>` outputs for every sensor, or (none
/// declared) the broadcast `ntp_request`. A partial set is a wiring mistake and an error.
pub fn ntp_routes<'a>(
    outputs: impl Iterator<Item = &'a str>,
    sensors: &[String],
) -> eyre::Result<NtpRoutes> {
    let mut routes = HashMap::new();
    for output in outputs {
        if let Some(sensor) = ports::sensor_of(output, ports::NTP_REQUEST_OUTPUT_PREFIX) {
            if !sensors.iter().any(|s| s == sensor) {
                bail!(
                    "sync: output `{output}` names sensor {sensor:?}, which has no `frame_{sensor}` input"
                );
            }
            routes.insert(sensor.to_owned(), DataId::from(output.to_owned()));
        }
    }
    if routes.is_empty() {
        return Ok(NtpRoutes::Broadcast);
    }
    if let Some(missing) = sensors.iter().find(|s| !routes.contains_key(*s)) {
        bail!(
            "sync: sensor {missing} has no `{}{missing}` output, while other sensors have one (declare one per sensor, or only `{}`)",
            ports::NTP_REQUEST_OUTPUT_PREFIX,
            ports::NTP_REQUEST
        );
    }
    Ok(NtpRoutes::PerSensor(routes))
}

/// Sensor ids from the `frame_<id>` input ids, in natural order (`k2` before `k10`); every
/// sensor must also have an `ntp_<id>` input.
pub fn sensors_from_inputs<'a>(inputs: impl Iterator<Item = &'a str>) -> eyre::Result<Vec<String>> {
    let inputs: Vec<&str> = inputs.collect();
    let mut ids: Vec<String> = inputs
        .iter()
        .filter_map(|i| ports::sensor_of(i, ports::FRAME_INPUT_PREFIX))
        .map(str::to_owned)
        .collect();
    if ids.is_empty() {
        bail!("sync: no `frame_<sensor>` inputs in the graph, so no sensors to synchronise");
    }
    for id in &ids {
        let ntp = format!("{}{id}", ports::NTP_INPUT_PREFIX);
        if !inputs.contains(&ntp.as_str()) {
            bail!(
                "sync: input `frame_{id}` has no matching `{ntp}` input (the NTP replies of {id})"
            );
        }
    }
    ports::sort_sensor_ids(&mut ids);
    Ok(ids)
}

/// Totals the node reports at the end.
#[derive(Debug, Default, Clone, PartialEq, Eq)]
pub struct Counters {
    /// Sets sent.
    pub sets_sent: u64,
    /// NTP requests sent.
    pub ntp_requests: u64,
    /// NTP replies fed to the clock filters.
    pub ntp_replies: u64,
    /// Inputs that could not be decoded or did not fit (skipped).
    pub malformed: u64,
    /// Frames dropped by the buffer (not synchronised yet, late, from the future, …).
    pub frames_dropped: u64,
}

struct Outputs {
    aligned: DataId,
    ntp: DataId,
    timing: DataId,
}

fn now_nanos() -> i64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| i64::try_from(d.as_nanos()).unwrap_or(i64::MAX))
}

/// The event loop.
pub fn run(
    config: Config,
    sensors: Vec<String>,
    routes: NtpRoutes,
    mut node: DoraNode,
    mut events: EventStream,
) -> eyre::Result<Counters> {
    let mut buffer = SyncBuffer::new(sensors.clone(), config.params.clone())
        .context("sync: building the sync buffer")?;
    let out = Outputs {
        aligned: DataId::from(ports::ALIGNED_SET.to_owned()),
        ntp: DataId::from(ports::NTP_REQUEST.to_owned()),
        timing: DataId::from(ports::FRAME_TIMING.to_owned()),
    };
    info!(
        "{} sensors ({}), policy {}",
        sensors.len(),
        sensors.join(", "),
        config.params.policy
    );
    let mut counters = Counters::default();
    let mut timings: Vec<FrameTiming> = Vec::new();
    // Each sensor's exchange at its own phase of the interval, not all on one tick.
    let mut ntp_schedule = NtpSchedule::new(sensors.len(), config.ntp_interval_nanos);
    let mut request_id = 0_u64;
    while let Some(event) = events.recv() {
        trigait_node_log::warn_drops(&mut events);
        match event {
            Event::Input { id, metadata, data } => {
                let id = id.as_str();
                let now = now_nanos();
                if id == "tick" {
                    for sensor in ntp_schedule.due(now).into_iter().map(|i| &sensors[i]) {
                        request_id += 1;
                        let request = NtpExchange::request(sensor.clone(), request_id, now_nanos());
                        let array = request.encode().context("encoding an NTP request")?;
                        let port = match &routes {
                            NtpRoutes::PerSensor(ports) => ports.get(sensor).unwrap_or(&out.ntp),
                            NtpRoutes::Broadcast => &out.ntp,
                        };
                        node.send_output(port.clone(), MetadataParameters::default(), array)
                            .with_context(|| format!("sync: sending {port}"))?;
                        counters.ntp_requests += 1;
                    }
                    let sets: Vec<AlignedSet> = buffer.advance_to(now).collect();
                    emit(&mut node, &out, sets, now, &mut counters)?;
                    if !timings.is_empty() {
                        let array =
                            FrameTiming::encode_many(&timings).context("encoding frame timings")?;
                        node.send_output(out.timing.clone(), MetadataParameters::default(), array)
                            .context("sync: sending frame_timing")?;
                        timings.clear();
                    }
                } else if let Some(sensor) = ports::sensor_of(id, ports::NTP_INPUT_PREFIX) {
                    let exchange = match NtpExchange::decode(data.as_array().as_ref()) {
                        Ok(e) if e.sensor_id == sensor => e.completed(now),
                        Ok(e) => {
                            counters.malformed += 1;
                            warn!(
                                input = id,
                                "skipping an NTP reply of sensor {:?}", e.sensor_id
                            );
                            continue;
                        }
                        Err(e) => {
                            counters.malformed += 1;
                            warn!(input = id, "skipping a malformed NTP reply: {e}");
                            continue;
                        }
                    };
                    let Some(sample) = exchange.sample() else {
                        counters.malformed += 1;
                        warn!(input = id, "skipping an NTP reply without t2/t3");
                        continue;
                    };
                    match buffer.push_ntp(sensor, sample) {
                        Ok(_) => counters.ntp_replies += 1,
                        Err(e) => {
                            counters.malformed += 1;
                            warn!(input = id, "NTP reply refused: {e}");
                        }
                    }
                } else if let Some(sensor) = ports::sensor_of(id, ports::FRAME_INPUT_PREFIX) {
                    let frame = match SkeletonFrameMessage::decode(data.as_array().as_ref()) {
                        Ok(m) if m.frame.sensor_id == sensor => m.frame,
                        Ok(m) => {
                            counters.malformed += 1;
                            warn!(
                                input = id,
                                "skipping a frame of sensor {:?}", m.frame.sensor_id
                            );
                            continue;
                        }
                        Err(e) => {
                            counters.malformed += 1;
                            warn!(input = id, "skipping a malformed frame: {e}");
                            continue;
                        }
                    };
                    let sets: Vec<AlignedSet> = buffer.advance_to(now).collect();
                    emit(&mut node, &out, sets, now, &mut counters)?;
                    timings.push(timing_of(
                        &buffer,
                        &frame,
                        get_integer_param(&metadata.parameters, ports::TRUE_CAPTURE_NANOS),
                    ));
                    let sent =
                        get_integer_param(&metadata.parameters, ports::SENT_NANOS).unwrap_or(now);
                    match buffer.push(frame) {
                        Ok(sets) => {
                            let sets: Vec<AlignedSet> = sets.collect();
                            emit(&mut node, &out, sets, sent, &mut counters)?;
                        }
                        Err(SyncError::NotSynchronised { .. }) => counters.frames_dropped += 1,
                        Err(e) => {
                            counters.frames_dropped += 1;
                            warn!("frame dropped: {e}");
                        }
                    }
                } else {
                    warn!(input = id, "ignoring an unknown input");
                }
            }
            Event::InputClosed { id } => {
                if let Some(sensor) = ports::sensor_of(id.as_str(), ports::FRAME_INPUT_PREFIX) {
                    warn!(%sensor, "source stopped; its sets go out incomplete from now on");
                }
            }
            Event::Stop(_) => {}
            Event::Error(e) => warn!("event stream error: {e}"),
            _ => {}
        }
    }
    let sets: Vec<AlignedSet> = buffer.flush().collect();
    emit(&mut node, &out, sets, now_nanos(), &mut counters)?;
    let c = buffer.counters();
    info!(
        "frames in {}, unsynchronised {}, late {}, evicted {}, from future {}; NTP in {} rejected {} steps {}; sets {} ({} incomplete, {} empty)",
        c.frames_in,
        c.frames_unsynchronised,
        c.frames_late,
        c.frames_evicted,
        c.frames_from_future,
        c.ntp_in,
        c.ntp_rejected,
        c.clock_steps,
        c.sets_out,
        c.sets_incomplete,
        c.sets_empty
    );
    Ok(counters)
}

fn timing_of(
    buffer: &SyncBuffer,
    frame: &trigait_skeleton::SkeletonFrame,
    true_nanos: Option<i64>,
) -> FrameTiming {
    let mapped = buffer.server_from_local(&frame.sensor_id, frame.local_stamp_nanos);
    let estimate = buffer.clock(&frame.sensor_id).and_then(|c| c.estimate());
    FrameTiming {
        sensor_id: frame.sensor_id.clone(),
        seq: frame.seq,
        local_stamp_nanos: frame.local_stamp_nanos,
        server_stamp_nanos: mapped.map(|m| m.server_nanos),
        uncertainty_nanos: mapped.map(|m| m.uncertainty_nanos),
        offset_nanos: estimate.map(|e| e.offset_nanos),
        drift_ppm: estimate.map(|e| e.drift_ppm),
        true_stamp_nanos: true_nanos,
    }
}

fn emit(
    node: &mut DoraNode,
    out: &Outputs,
    sets: Vec<AlignedSet>,
    trigger_sent_nanos: i64,
    counters: &mut Counters,
) -> eyre::Result<()> {
    for set in sets {
        let mut params = MetadataParameters::default();
        params.insert(
            ports::TRIGGER_SENT_NANOS.to_owned(),
            Parameter::Integer(trigger_sent_nanos),
        );
        params.insert(
            ports::MISSING_SENSORS.to_owned(),
            Parameter::Integer(i64::try_from(set.missing.len()).unwrap_or(i64::MAX)),
        );
        let array = set.encode().context("encoding an aligned set")?;
        node.send_output(out.aligned.clone(), params, array)
            .context("sync: sending aligned_set")?;
        counters.sets_sent += 1;
    }
    Ok(())
}
