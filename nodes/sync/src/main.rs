//! `sync`: the server clock of the dataflow. Runs the four-timestamp NTP exchange with every
//! source (a cycle in the graph: `ntp_request` out, `ntp_<id>` in), maps each `frame_<id>` onto
//! the server clock with [`trigait_sync::SyncBuffer`], and sends the [`AlignedSet`]s its policy
//! makes on `aligned_set`, plus every frame's placement on `frame_timing`. Configuration:
//! [`config`].

mod config;
mod order;
#[cfg(test)]
mod tests;

use dora_node_api::arrow_v59::array::Array;
use dora_node_api::dora_core::config::DataId;
use dora_node_api::{
    DoraNode, Event, EventStream, MetadataParameters, Parameter, get_integer_param,
};
use std::collections::HashMap;

use eyre::{Context, bail};
use tracing::{info, warn};
use trigait_node_config::RigStamp;
use trigait_schema::{FrameTiming, Message, NtpExchange, SkeletonFrameMessage, ports};
use trigait_skeleton::MAX_REPORT_RANGE_M;
use trigait_sync::{AlignedSet, Error as SyncError, NtpSchedule, SampleOutcome, SyncBuffer};

use crate::config::Config;

fn main() -> eyre::Result<()> {
    trigait_node_log::init("sync");
    let config = Config::from_env()?;
    let (node, events) =
        DoraNode::init_from_env().context("sync: connecting to the dora daemon")?;
    let wired = sensors_from_inputs(node.node_config().inputs.keys().map(|id| id.as_str()))?;
    let sensors = match &config.sensors {
        Some(ids) => {
            check_listed_sensors(ids, &wired)?;
            ids.clone()
        }
        None => wired,
    };
    let routes = ntp_routes(
        node.node_config().outputs.iter().map(|id| id.as_str()),
        &sensors,
    )?;
    let tick = node
        .node_config()
        .inputs
        .get(&DataId::from(ports::TICK.to_owned()))
        .map(|input| timer_interval(&input.mapping.to_string()));
    check_tick(tick)?;
    run(config, sensors, routes, node, events).map(|_| ())
}

/// The slowest `tick` timer: sets whose deadline passed go out, and NTP requests are sent, on
/// its ticks, so a slower one delays both (at one a second, no sensor ever synchronised).
pub const MAX_TICK: std::time::Duration = std::time::Duration::from_millis(20);

/// The interval of a dora timer as its input mapping reads (`dora/timer/millis/10`; dora
/// writes the coarsest exact unit), `None` for anything else.
#[must_use]
pub fn timer_interval(mapping: &str) -> Option<std::time::Duration> {
    use std::time::Duration;
    let (unit, value) = mapping.strip_prefix("dora/timer/")?.split_once('/')?;
    let value: u64 = value.parse().ok()?;
    match unit {
        "secs" => Some(Duration::from_secs(value)),
        "millis" => Some(Duration::from_millis(value)),
        "micros" => Some(Duration::from_micros(value)),
        "nanos" => Some(Duration::from_nanos(value)),
        _ => None,
    }
}

/// Checks the `tick` input: present (`None`: missing), a dora timer (`Some(None)`: something
/// else), at most [`MAX_TICK`] apart.
///
/// # Errors
/// Naming the input and what it must be.
pub fn check_tick(tick: Option<Option<std::time::Duration>>) -> eyre::Result<()> {
    let want = format!(
        "a timer of at most {} ms, e.g. `tick: dora/timer/millis/10`",
        MAX_TICK.as_millis()
    );
    match tick {
        None => bail!("sync: no `{}` input: it needs {want}", ports::TICK),
        Some(None) => bail!(
            "sync: input `{}` is not a dora timer: it needs {want}",
            ports::TICK
        ),
        Some(Some(interval)) if interval > MAX_TICK => bail!(
            "sync: input `{}` fires every {} ms: it needs {want} (sets go out and NTP requests \
             are sent on its ticks)",
            ports::TICK,
            interval.as_millis()
        ),
        Some(Some(_)) => Ok(()),
    }
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
                    "sync: output `{output}` names sensor {sensor:?}, which is not one of its \
                     sensors ({})",
                    sensors.join(", ")
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

/// Checks `SENSORS` (`listed`) against the sensors whose `frame_<id>` inputs are wired: each
/// listed sensor needs its input, and a wired one left out of the list would be read and never
/// synchronised.
///
/// # Errors
/// Naming the sensor and what it lacks.
pub fn check_listed_sensors(listed: &[String], wired: &[String]) -> eyre::Result<()> {
    if let Some(id) = listed.iter().find(|id| !wired.contains(id)) {
        bail!(
            "sync: SENSORS lists {id:?}, which has no `{}{id}` input (inputs for: {})",
            ports::FRAME_INPUT_PREFIX,
            wired.join(", ")
        );
    }
    if let Some(id) = wired.iter().find(|id| !listed.contains(id)) {
        bail!(
            "sync: input `{}{id}` is wired, but SENSORS ({}) leaves {id:?} out: list it, or \
             remove its inputs",
            ports::FRAME_INPUT_PREFIX,
            listed.join(", ")
        );
    }
    Ok(())
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

/// The error for a message of sensor `theirs` on input `<prefix><sensor>`: every message on an
/// input of a sensor is that sensor's, so the node feeding it was given another `SENSOR_ID`
/// or the inputs were swapped. Skipping such messages would fuse the graph's sensors short of
/// one, without a word on why.
fn miswired(prefix: &str, sensor: &str, theirs: &str) -> String {
    format!(
        "sync: input {prefix}{sensor} carries messages of sensor {theirs:?}: the node wired to it \
         runs with SENSOR_ID {theirs} (a copied source block whose SENSOR_ID was not changed?), \
         or the inputs of {sensor} and {theirs} are swapped"
    )
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
    /// Joint reports left out as no sensor could have measured them
    /// ([`trigait_skeleton::JointSample::is_possible`]).
    pub impossible_joints: u64,
    /// Sets still waiting for frames when the graph was stopped (not sent: nothing sent after
    /// a stop is delivered).
    pub sets_unfinished_at_stop: u64,
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

/// What an input id says the input is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Input<'a> {
    /// The timer ([`ports::TICK`]): NTP requests due, sets whose deadline passed, timings.
    Tick,
    /// `ntp_<sensor>`: an answered NTP request.
    NtpReply(&'a str),
    /// `frame_<sensor>`: a skeleton frame.
    Frame(&'a str),
    /// Anything else (logged, ignored).
    Unknown(&'a str),
}

impl<'a> Input<'a> {
    /// The input `id` names.
    #[must_use]
    pub fn parse(id: &'a str) -> Self {
        if id == ports::TICK {
            Input::Tick
        } else if let Some(sensor) = ports::sensor_of(id, ports::NTP_INPUT_PREFIX) {
            Input::NtpReply(sensor)
        } else if let Some(sensor) = ports::sensor_of(id, ports::FRAME_INPUT_PREFIX) {
            Input::Frame(sensor)
        } else {
            Input::Unknown(id)
        }
    }
}

/// The node's state between events.
struct State {
    sensors: Vec<String>,
    routes: NtpRoutes,
    buffer: SyncBuffer,
    out: Outputs,
    counters: Counters,
    timings: Vec<FrameTiming>,
    ntp_schedule: NtpSchedule,
    request_id: u64,
    /// The rig the first stamped frame was made with; every later source must share it.
    rig: Option<RigStamp>,
    /// Sources whose input has closed.
    closed: Vec<String>,
    /// Sources whose last frame said their stream ends as planned.
    ended: Vec<String>,
    /// Frames are placed on their recorded server stamps (`TIMESTAMPS: recorded`).
    recorded_time: bool,
    /// Under recorded time: each source's replayed frames not taken in yet, in arrival order.
    replayed: ReplayOrder,
    /// The sources have ended: the sets still held go out now.
    ending: bool,
}

/// The event loop.
pub fn run(
    config: Config,
    sensors: Vec<String>,
    routes: NtpRoutes,
    mut node: DoraNode,
    mut events: EventStream,
) -> eyre::Result<Counters> {
    info!(
        "{} sensors ({}), policy {}",
        sensors.len(),
        sensors.join(", "),
        config.params.policy
    );
    let mut state = State {
        buffer: SyncBuffer::new(sensors.clone(), config.params.clone())
            .context("sync: building the sync buffer")?,
        out: Outputs {
            aligned: DataId::from(ports::ALIGNED_SET.to_owned()),
            ntp: DataId::from(ports::NTP_REQUEST.to_owned()),
            timing: DataId::from(ports::FRAME_TIMING.to_owned()),
        },
        counters: Counters::default(),
        timings: Vec::new(),
        // Each sensor's exchange at its own phase of the interval, not all on one tick.
        ntp_schedule: NtpSchedule::new(sensors.len(), config.ntp_interval_nanos),
        request_id: 0,
        rig: None,
        closed: Vec::new(),
        ended: Vec::new(),
        recorded_time: config.recorded_time,
        replayed: ReplayOrder::default(),
        ending: false,
        sensors,
        routes,
    };
    let mut stopped = false;
    let mut in_order = order::InputsFirst::dora();
    while let Some(event) = in_order.next(&mut events) {
        trigait_node_log::warn_drops(&mut events);
        match event {
            Event::Input { id, metadata, data } => {
                let now = now_nanos();
                let array = data.as_array();
                match Input::parse(id.as_str()) {
                    Input::Tick => state.on_tick(&mut node, now)?,
                    Input::NtpReply(sensor) => state.on_ntp_reply(sensor, array.as_ref(), now)?,
                    Input::Frame(sensor) => state.on_frame(
                        &mut node,
                        sensor,
                        &metadata.parameters,
                        array.as_ref(),
                        now,
                    )?,
                    Input::Unknown(id) => warn!(input = id, "ignoring an unknown input"),
                }
            }
            Event::InputClosed { id } => {
                if let Input::Frame(sensor) = Input::parse(id.as_str())
                    && state.on_source_closed(&mut node, sensor)?
                {
                    break;
                }
            }
            Event::Stop(_) => stopped = true,
            Event::Error(e) => warn!("event stream error: {e}"),
            _ => {}
        }
    }
    state.finish(&mut node, stopped)?;
    let c = state.buffer.counters();
    info!(
        "frames in {}, unsynchronised {}, late {}, evicted {}, from future {}; impossible joints left out {}; NTP in {} rejected {} steps {}; sets sent {} ({} incomplete, {} empty; {} without waiting for an overdue frame, {} at the deadline), {} unfinished at the stop",
        c.frames_in,
        c.frames_unsynchronised,
        c.frames_late,
        c.frames_evicted,
        c.frames_from_future,
        state.counters.impossible_joints,
        c.ntp_in,
        c.ntp_rejected,
        c.clock_steps,
        state.counters.sets_sent,
        c.sets_incomplete,
        c.sets_empty,
        c.sets_overdue,
        c.sets_deadline,
        state.counters.sets_unfinished_at_stop
    );
    Ok(state.counters)
}

impl State {
    /// A source's input closed: whether every source has now ended (the run's end).
    fn on_source_closed(&mut self, node: &mut DoraNode, sensor: &str) -> eyre::Result<bool> {
        self.closed.push(sensor.to_owned());
        self.take_replayed(node)?;
        // A source that ended as planned was let go with its last frame.
        let ended = self.ended.iter().any(|e| e == sensor);
        if !self.recorded_time && !ended {
            self.end_stream(node, sensor, now_nanos())?;
        }
        if self.closed.len() >= self.sensors.len() {
            info!("every source has ended; sending the last sets");
            return Ok(true);
        }
        if ended {
            info!(%sensor, "source ended its stream");
        } else {
            warn!(%sensor, "source stopped; its sets go out incomplete from now on");
        }
        Ok(false)
    }

    /// The end of the run: the sets still held go out, with the last frame timings, when the
    /// sources ended; after a stop they are counted instead, because dora delivers nothing a
    /// node sends after the stop reached the graph.
    fn finish(&mut self, node: &mut DoraNode, stopped: bool) -> eyre::Result<()> {
        self.replayed.release_all();
        self.take_replayed(node)?;
        let sets: Vec<AlignedSet> = self.buffer.flush().collect();
        if stopped {
            self.counters.sets_unfinished_at_stop = sets.len() as u64;
            return Ok(());
        }
        self.ending = true;
        self.send_sets(node, sets, now_nanos())?;
        self.send_timings(node)
    }

    /// Sends the NTP requests due, the sets whose deadline passed and the frame timings
    /// gathered since the last tick.
    fn on_tick(&mut self, node: &mut DoraNode, now: i64) -> eyre::Result<()> {
        // Under recorded time the NTP requests only tell the replaying sources that sync
        // listens (their replies are not used).
        for i in self.ntp_schedule.due(now) {
            let Some(sensor) = self.sensors.get(i) else {
                continue;
            };
            self.request_id += 1;
            let request = NtpExchange::request(sensor.clone(), self.request_id, now_nanos());
            let array = request.encode().context("encoding an NTP request")?;
            let port = match &self.routes {
                NtpRoutes::PerSensor(ports) => ports.get(sensor).unwrap_or(&self.out.ntp),
                NtpRoutes::Broadcast => &self.out.ntp,
            };
            node.send_output(port.clone(), MetadataParameters::default(), array)
                .with_context(|| format!("sync: sending {port}"))?;
            self.counters.ntp_requests += 1;
        }
        if !self.recorded_time {
            let sets: Vec<AlignedSet> = self.buffer.advance_to(now).collect();
            self.send_sets(node, sets, now)?;
        }
        self.send_timings(node)
    }

    /// Sends `sets`, each stamped with the rig, `trigger_sent_nanos`, why it went out now and
    /// the wait budget.
    fn send_sets(
        &mut self,
        node: &mut DoraNode,
        sets: Vec<AlignedSet>,
        trigger_sent_nanos: i64,
    ) -> eyre::Result<()> {
        let params = self.buffer.params();
        let budget = vec![
            params.frame_wait_margin_nanos,
            params.latency_deadline_nanos,
        ];
        for set in sets {
            let release = if self.ending {
                "end"
            } else {
                self.buffer
                    .release_of(set.seq)
                    .map_or("end", trigait_sync::Release::name)
            };
            let mut metadata = MetadataParameters::default();
            if let Some(rig) = &self.rig {
                rig.insert_into(&mut metadata);
            }
            metadata.insert(
                ports::TRIGGER_SENT_NANOS.to_owned(),
                Parameter::Integer(trigger_sent_nanos),
            );
            metadata.insert(
                ports::SYNC_RELEASE.to_owned(),
                Parameter::String(release.to_owned()),
            );
            if !self.ended.is_empty() {
                metadata.insert(ports::WIND_DOWN.to_owned(), Parameter::Bool(true));
            }
            metadata.insert(
                ports::SYNC_WAIT_BUDGET_NANOS.to_owned(),
                Parameter::ListInt(budget.clone()),
            );
            let array = set.encode().context("encoding an aligned set")?;
            node.send_output(self.out.aligned.clone(), metadata, array)
                .context("sync: sending aligned_set")?;
            self.counters.sets_sent += 1;
        }
        Ok(())
    }

    /// Sends the frame timings gathered since the last send, if any.
    fn send_timings(&mut self, node: &mut DoraNode) -> eyre::Result<()> {
        if self.timings.is_empty() {
            return Ok(());
        }
        let array = FrameTiming::encode_many(&self.timings).context("encoding frame timings")?;
        let mut params = MetadataParameters::default();
        if let Some(rig) = &self.rig {
            rig.insert_into(&mut params);
        }
        node.send_output(self.out.timing.clone(), params, array)
            .context("sync: sending frame_timing")?;
        self.timings.clear();
        Ok(())
    }

    /// Feeds an answered NTP request of `sensor` to its clock filter; a malformed reply is
    /// counted and skipped.
    ///
    /// # Errors
    /// The reply is another sensor's: the graph is wired wrong.
    fn on_ntp_reply(&mut self, sensor: &str, array: &dyn Array, now: i64) -> eyre::Result<()> {
        let exchange = match NtpExchange::decode(array) {
            Ok(e) if e.sensor_id == sensor => e.completed(now),
            Ok(e) => bail!(miswired(ports::NTP_INPUT_PREFIX, sensor, &e.sensor_id)),
            Err(e) => {
                self.counters.malformed += 1;
                warn!(%sensor, "skipping a malformed NTP reply: {e}");
                return Ok(());
            }
        };
        let Some(sample) = exchange.sample() else {
            self.counters.malformed += 1;
            warn!(%sensor, "skipping an NTP reply without t2/t3");
            return Ok(());
        };
        match self.buffer.push_ntp(sensor, sample) {
            Ok(SampleOutcome::Step {
                step_nanos,
                exchanges,
                at_server_nanos,
                agreed_server_nanos,
            }) => {
                self.counters.ntp_replies += 1;
                warn!(
                    %sensor,
                    step_ms = step_nanos as f64 * 1e-6,
                    exchanges,
                    stale_ms = at_server_nanos.saturating_sub(agreed_server_nanos) as f64 * 1e-6,
                    "sensor clock stepped; frames map with the new offset from this exchange on"
                );
            }
            Ok(_) => self.counters.ntp_replies += 1,
            Err(e) => {
                self.counters.malformed += 1;
                warn!(%sensor, "NTP reply refused: {e}");
            }
        }
        Ok(())
    }

    /// Sends the sets due before a frame of `sensor`, notes its timing, buffers it and sends
    /// the sets it completes; a malformed or misrouted frame is counted and skipped.
    fn on_frame(
        &mut self,
        node: &mut DoraNode,
        sensor: &str,
        params: &MetadataParameters,
        array: &dyn Array,
        now: i64,
    ) -> eyre::Result<()> {
        let last_frame = matches!(
            params.get(ports::END_OF_STREAM),
            Some(Parameter::Bool(true))
        );
        if last_frame {
            self.ended.push(sensor.to_owned());
        }
        let frame = match SkeletonFrameMessage::decode(array) {
            Ok(m) if m.frame.sensor_id == sensor => m.frame,
            Ok(m) => bail!(miswired(
                ports::FRAME_INPUT_PREFIX,
                sensor,
                &m.frame.sensor_id
            )),
            Err(e) => {
                self.counters.malformed += 1;
                warn!(%sensor, "skipping a malformed frame: {e}");
                return Ok(());
            }
        };
        if let Some(theirs) = RigStamp::from_params(params) {
            match &self.rig {
                Some(first) => first
                    .check(&theirs)
                    .map_err(|e| eyre::eyre!("sync: the sources disagree on the rig: {e}"))?,
                None => self.rig = Some(theirs),
            }
        }
        if self.recorded_time {
            return self.on_recorded_frame(node, frame, params, last_frame, now);
        }
        let sets: Vec<AlignedSet> = self.buffer.advance_to(now).collect();
        self.send_sets(node, sets, now)?;
        self.timings.push(timing_of(
            &self.buffer,
            &frame,
            get_integer_param(params, ports::TRUE_STAMP_NANOS),
            now,
        ));
        let sent = get_integer_param(params, ports::SENT_NANOS).unwrap_or(now);
        let mut frame = frame;
        self.drop_impossible(&mut frame);
        match self.buffer.push(frame) {
            Ok(sets) => {
                let sets: Vec<AlignedSet> = sets.collect();
                self.send_sets(node, sets, sent)?;
            }
            Err(SyncError::NotSynchronised { .. }) => self.counters.frames_dropped += 1,
            Err(e) => {
                self.counters.frames_dropped += 1;
                warn!("frame dropped: {e}");
            }
        }
        if last_frame {
            self.end_stream(node, sensor, sent)?;
        }
        Ok(())
    }

    /// `sensor` has sent its last frame: the sets no longer wait for it, and those that
    /// waited only for it go out now (a replay on recorded stamps ends the stream when it
    /// takes in the last frame, in the recorded order).
    fn end_stream(
        &mut self,
        node: &mut DoraNode,
        sensor: &str,
        trigger_sent_nanos: i64,
    ) -> eyre::Result<()> {
        match self.buffer.end_of_stream(sensor) {
            Ok(sets) => {
                let sets: Vec<AlignedSet> = sets.collect();
                self.send_sets(node, sets, trigger_sent_nanos)
            }
            Err(e) => {
                warn!(%sensor, "end of stream: {e}");
                Ok(())
            }
        }
    }
}

impl State {
    /// A replayed frame placed on the server stamp its recording gave it (none: it was not
    /// synchronised in the recorded run, and is dropped as it was then). A frame that carries
    /// the instant the recording's `sync` received it waits until every source still playing
    /// has sent a frame at least as late, so the frames are taken in the recorded order
    /// whatever the sources' pace ([`ReplayOrder`]).
    fn on_recorded_frame(
        &mut self,
        node: &mut DoraNode,
        mut frame: trigait_skeleton::SkeletonFrame,
        params: &MetadataParameters,
        last_frame: bool,
        now: i64,
    ) -> eyre::Result<()> {
        let server = get_integer_param(params, ports::RECORDED_SERVER_STAMP_NANOS);
        let uncertainty = get_integer_param(params, ports::RECORDED_UNCERTAINTY_NANOS);
        let received = get_integer_param(params, ports::RECORDED_RECEIVED_NANOS);
        let sensor = frame.sensor_id.clone();
        let timing = FrameTiming {
            sensor_id: frame.sensor_id.clone(),
            seq: frame.seq,
            local_stamp_nanos: frame.local_stamp_nanos,
            server_stamp_nanos: server,
            uncertainty_nanos: server.map(|_| uncertainty.unwrap_or(0)),
            offset_nanos: None,
            drift_ppm: None,
            true_stamp_nanos: get_integer_param(params, ports::TRUE_STAMP_NANOS),
            received_nanos: received,
            joints: frame.joints.clone(),
        };
        self.drop_impossible(&mut frame);
        let replayed = Replayed {
            timing,
            frame,
            sent_nanos: get_integer_param(params, ports::SENT_NANOS).unwrap_or(now),
            last_frame,
        };
        match received {
            Some(received) => self.replayed.push(&sensor, received, replayed),
            // A recording without arrival instants: taken in as it comes.
            None => self.take_in(node, replayed)?,
        }
        if self.ended.contains(&sensor) {
            self.replayed.finished(&sensor);
        }
        self.take_replayed(node)
    }

    /// Leaves out of `frame` the joints no sensor could have measured, before they are fused
    /// or interpolated into their neighbours, and counts them; the recording (`frame_timing`)
    /// keeps the frame as it came. The first such joint is logged.
    fn drop_impossible(&mut self, frame: &mut trigait_skeleton::SkeletonFrame) {
        let impossible = frame.drop_impossible() as u64;
        if impossible == 0 {
            return;
        }
        if self.counters.impossible_joints == 0 {
            warn!(
                sensor = %frame.sensor_id,
                "left out a joint no sensor could have measured (not finite, behind the sensor \
                 or farther than {MAX_REPORT_RANGE_M} m): a corrupted recording or a unit slip? \
                 (all such are counted at the end)"
            );
        }
        self.counters.impossible_joints += impossible;
    }

    /// Takes in the replayed frames whose turn has come.
    fn take_replayed(&mut self, node: &mut DoraNode) -> eyre::Result<()> {
        for sensor in &self.closed {
            self.replayed.finished(sensor);
        }
        while let Some(next) = self.replayed.pop(&self.sensors) {
            self.take_in(node, next)?;
        }
        Ok(())
    }

    /// What the recorded run's `sync` did with the frame: its clock moved to the instant it
    /// received the frame (sets whose deadline passed go out), then the frame is buffered.
    fn take_in(&mut self, node: &mut DoraNode, replayed: Replayed) -> eyre::Result<()> {
        let Replayed {
            frame,
            timing,
            sent_nanos,
            last_frame,
        } = replayed;
        // The stream this frame ends, if it is its source's last.
        let ended = last_frame.then(|| frame.sensor_id.clone());
        let server = timing.server_stamp_nanos;
        let uncertainty = timing.uncertainty_nanos;
        if let Some(received) = timing.received_nanos {
            let sets: Vec<AlignedSet> = self.buffer.advance_to(received).collect();
            self.send_sets(node, sets, received)?;
        }
        self.timings.push(timing);
        let Some(server_stamp_nanos) = server else {
            self.counters.frames_dropped += 1;
            return self.end_replayed_stream(node, ended, sent_nanos);
        };
        let timed = trigait_sync::TimedFrame {
            frame,
            server_stamp_nanos,
            time_uncertainty_nanos: uncertainty.unwrap_or(0),
        };
        match self.buffer.push_timed(timed) {
            Ok(sets) => {
                let sets: Vec<AlignedSet> = sets.collect();
                self.send_sets(node, sets, sent_nanos)?;
            }
            Err(e) => {
                self.counters.frames_dropped += 1;
                warn!("frame dropped: {e}");
            }
        }
        self.end_replayed_stream(node, ended, sent_nanos)
    }

    /// After a replayed source's last frame is taken in, its stream ends there, in the
    /// recorded order, as the recording's `sync` ended it after the same frame.
    fn end_replayed_stream(
        &mut self,
        node: &mut DoraNode,
        ended: Option<String>,
        sent_nanos: i64,
    ) -> eyre::Result<()> {
        match ended {
            Some(sensor) => self.end_stream(node, &sensor, sent_nanos),
            None => Ok(()),
        }
    }
}

/// A replayed frame waiting for its turn.
struct Replayed {
    frame: trigait_skeleton::SkeletonFrame,
    timing: FrameTiming,
    sent_nanos: i64,
    /// The source marked it its stream's last.
    last_frame: bool,
}

/// The replayed frames in the order the recording's `sync` received them. Each source plays
/// its own sensor in recorded order, but the sources run at their own pace, so frames reach
/// this node interleaved otherwise than in the recorded run; and the recorded `sync` sent a
/// set when a deadline passed on its clock, before a late frame arrived. Taking the frames
/// in order of their recorded arrival instants, each after moving the clock to that instant,
/// repeats every one of those decisions. A frame is taken once every source still playing has
/// one waiting (the earliest goes first; a tie goes to the sensor listed first).
#[derive(Default)]
struct ReplayOrder {
    waiting: HashMap<String, std::collections::VecDeque<(i64, Replayed)>>,
    /// Sources that will send nothing more.
    finished: Vec<String>,
    /// Take everything (the end of the run).
    all: bool,
}

impl ReplayOrder {
    fn push(&mut self, sensor: &str, received_nanos: i64, frame: Replayed) {
        self.waiting
            .entry(sensor.to_owned())
            .or_default()
            .push_back((received_nanos, frame));
    }

    fn finished(&mut self, sensor: &str) {
        if !self.finished.iter().any(|s| s == sensor) {
            self.finished.push(sensor.to_owned());
        }
    }

    fn release_all(&mut self) {
        self.all = true;
    }

    /// The next frame to take in, if its turn has come.
    fn pop(&mut self, sensors: &[String]) -> Option<Replayed> {
        let mut best: Option<(i64, &String)> = None;
        for sensor in sensors {
            match self.waiting.get(sensor).and_then(|q| q.front()) {
                Some((at, _)) => {
                    if best.is_none_or(|(b, _)| *at < b) {
                        best = Some((*at, sensor));
                    }
                }
                None if self.all || self.finished.contains(sensor) => {}
                // This source may still send an earlier frame.
                None => return None,
            }
        }
        let (_, sensor) = best?;
        let sensor = sensor.clone();
        self.waiting
            .get_mut(&sensor)
            .and_then(|q| q.pop_front())
            .map(|(_, f)| f)
    }
}

fn timing_of(
    buffer: &SyncBuffer,
    frame: &trigait_skeleton::SkeletonFrame,
    true_stamp_nanos: Option<i64>,
    now: i64,
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
        true_stamp_nanos,
        received_nanos: Some(now),
        joints: frame.joints.clone(),
    }
}
