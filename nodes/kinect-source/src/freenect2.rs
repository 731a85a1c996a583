//! The `freenect2` backend: a real Kinect v2 through libfreenect2 (`freenect2` feature). The
//! decisions (open by serial or index, pairing, lost frames, device → host time, degraded and
//! rejoin) are `trigait_freenect2::capture`'s; this module only runs that state machine on a
//! worker thread, turns its frames into `depth_frame` messages, and keeps the dora event loop
//! answering NTP requests and stops while the device blocks.
//!
//! | env var | type | default | meaning |
//! |---|---|---|---|
//! | `FREENECT2_SERIAL` | string | none | the sensor's serial (`trigait devices` lists them) |
//! | `FREENECT2_INDEX` | integer | `0` | position in the enumeration, when no serial is given |
//! | `FREENECT2_PIPELINE` | `cpu`, `opengl`, `opencl`, `cuda` | `cpu` | libfreenect2's depth pipeline |
//! | `FREENECT2_IR` | bool | `false` | also send IR amplitude on `ir` (see below) |
//! | `FREENECT2_STALL_MILLIS` | ms | `1000` | no frame for this long → degraded |
//! | `FREENECT2_RESCAN_MILLIS` | ms | `2000` | re-enumeration period while degraded |
//! | `FREENECT2_STATUS_MILLIS` | ms | `500` | period of the `status` report |
//!
//! Output `depth`: `depth_frame` with whole millimetres (libfreenect2's float mm rounded; no data
//! = 0), undistorted once the device's IR intrinsics are known: resampled through
//! [`trigait_depth::Undistorter`] (libfreenect2's own forward map, built once per device) to the
//! ideal pinhole with the device's fx, fy, cx, cy, which go on the frame as
//! `trigait.depth_pinhole` so downstream back-projects with them (without it, the nominal
//! camera); `local_stamp_nanos` the capture instant on the host clock (device time mapped by the
//! capture state machine), `seq` counting lost frames too (a gap downstream is a loss here).
//! Metadata: `trigait.device_nanos` (unwrapped device time), `trigait.device_sequence`,
//! `trigait.host_arrival_nanos`, `trigait.lost_before`. NTP requests are answered on the host
//! clock, the same clock as the stamps, so `sync` measures the host's offset to the server.
//! Output `ir` (when `FREENECT2_IR` is on): an `ir_frame`, the IR amplitude (0–65535,
//! unitless) of the same capture, with the depth frame's `seq` and stamp, resampled the same way.
//! Output `status` (when declared): a `sensor_status` on every state change and every
//! `FREENECT2_STATUS_MILLIS` in between — streaming, or degraded (stalled, absent, failed) with
//! the reason and frames lost so far — so a consumer sees a stalled or unplugged sensor while
//! its frames have stopped.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use dora_node_api::dora_core::config::DataId;
use dora_node_api::{DoraNode, Event, EventStream, MetadataParameters, Parameter};
use eyre::{Context, bail, eyre};
use tracing::{info, warn};
use trigait_depth::Undistorter;
use trigait_freenect2::capture::Degraded;
use trigait_freenect2::capture::{Capture, CaptureConfig, Captured, Counters, Selector, State};
use trigait_freenect2::{Driver, IrParams, Pipeline, Streams};
use trigait_node_config::{env_flag, env_number_where, env_value};
use trigait_schema::{Message, SensorStatus, ports};

use crate::backend::now_nanos;
use crate::config::{self, Config};

/// Env var: serial.
pub const FREENECT2_SERIAL: &str = "FREENECT2_SERIAL";
/// Env var: index.
pub const FREENECT2_INDEX: &str = "FREENECT2_INDEX";
/// Env var: pipeline.
pub const FREENECT2_PIPELINE: &str = "FREENECT2_PIPELINE";
/// Env var: IR output.
pub const FREENECT2_IR: &str = "FREENECT2_IR";
/// Env var: stall limit.
pub const FREENECT2_STALL_MILLIS: &str = "FREENECT2_STALL_MILLIS";
/// Env var: rescan period.
pub const FREENECT2_RESCAN_MILLIS: &str = "FREENECT2_RESCAN_MILLIS";
/// Env var: status report period.
pub const FREENECT2_STATUS_MILLIS: &str = "FREENECT2_STATUS_MILLIS";

/// Output port of the IR frames.
pub const IR: &str = ports::IR;
/// Metadata: unwrapped device time, ns.
pub const DEVICE_NANOS: &str = "trigait.device_nanos";
/// Metadata: the device's sequence number.
pub const DEVICE_SEQUENCE: &str = "trigait.device_sequence";
/// Metadata: host arrival time, ns.
pub const HOST_ARRIVAL_NANOS: &str = "trigait.host_arrival_nanos";
/// Metadata: frames lost just before this one.
pub const LOST_BEFORE: &str = "trigait.lost_before";

/// How long a stop may wait for the device to close before the node exits anyway (the
/// driver's own watchdog then leaks the device).
const STOP_GRACE: Duration = Duration::from_millis(700);
/// The longest the worker blocks in one wait, so a stop is seen promptly.
const POLL: Duration = Duration::from_millis(100);
/// The longest the event thread blocks in one wait, so a stop is seen promptly.
const EVENT_WAIT: Duration = Duration::from_millis(50);
/// Frames waiting to be sent at most (about 100 ms at 30 Hz); more means sending is slower
/// than the sensor, and a frame that old is better dropped and counted than sent late.
const MAX_QUEUED_FRAMES: usize = 3;

const NODE: &str = "kinect-source";

/// The backend's configuration.
#[derive(Debug, Clone, PartialEq)]
pub struct Freenect2Config {
    /// What the capture state machine runs with.
    pub capture: CaptureConfig,
    /// Send IR frames on `ir`.
    pub send_ir: bool,
    /// Period of the `status` report.
    pub status_every: Duration,
}

impl Freenect2Config {
    /// From the node's `env:` block.
    ///
    /// # Errors
    /// A value that does not parse, naming the variable.
    pub fn from_lookup(lookup: &impl Fn(&str) -> Option<String>) -> eyre::Result<Self> {
        let sensor = match lookup(FREENECT2_SERIAL).map(|s| s.trim().to_owned()) {
            Some(s) if !s.is_empty() => {
                if lookup(FREENECT2_INDEX).is_some() {
                    bail!("{NODE}: give {FREENECT2_SERIAL} or {FREENECT2_INDEX}, not both");
                }
                Selector::Serial(s)
            }
            _ => Selector::Index(
                env_value(
                    NODE,
                    lookup,
                    FREENECT2_INDEX,
                    |_: &usize| true,
                    "an index from 0",
                )?
                .unwrap_or(0),
            ),
        };
        let pipeline = match lookup(FREENECT2_PIPELINE) {
            None => Pipeline::Cpu,
            Some(p) => Pipeline::from_name(&p).ok_or_else(|| {
                eyre!(
                    "{NODE}: {FREENECT2_PIPELINE}={p:?} is invalid: expected cpu, opengl, opencl or cuda"
                )
            })?,
        };
        let send_ir = env_flag(NODE, lookup, FREENECT2_IR, false)?;
        let millis = |key: &str, default: f64| {
            env_number_where(
                NODE,
                lookup,
                key,
                default,
                |v| (50.0..=600_000.0).contains(&v),
                "milliseconds within 50–600000",
            )
            .map(|ms| Duration::from_secs_f64(ms / 1000.0))
        };
        let mut capture = CaptureConfig::new(sensor);
        capture.pipeline = pipeline;
        capture.streams = Streams {
            depth: true,
            ir: send_ir,
            color: false,
        };
        capture.stall_after = millis(FREENECT2_STALL_MILLIS, 1000.0)?;
        capture.rescan_every = millis(FREENECT2_RESCAN_MILLIS, 2000.0)?;
        capture.reopen_after = capture.stall_after * 5;
        let status_every = millis(FREENECT2_STATUS_MILLIS, 500.0)?;
        Ok(Self {
            capture,
            send_ir,
            status_every,
        })
    }
}

/// What the node did.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Summary {
    /// Depth frames sent.
    pub frames_sent: u64,
    /// NTP requests answered.
    pub ntp_answered: u64,
    /// Inputs that could not be decoded.
    pub malformed: u64,
    /// The capture state machine's totals (lost frames, degraded, rejoins).
    pub capture: Counters,
    /// State changes, in order.
    pub states: Vec<State>,
    /// Frames captured while [`MAX_QUEUED_FRAMES`] were already waiting to be sent, dropped
    /// (their sequence numbers are skipped, so downstream counts them lost).
    pub dropped_busy: u64,
    /// Frames captured but not yet sent when the node stopped.
    pub unsent_at_stop: u64,
    /// The worker had not closed the device when the node exited.
    pub abandoned_device: bool,
}

enum Msg {
    /// A captured frame, its stream sequence number and, when it was undistorted, the
    /// pinhole it now is (`[fx, fy, cx, cy]`).
    Frame(Box<Captured>, u64, Option<[f64; 4]>),
    /// The capture state changed.
    State(State),
    /// The capture thread closed the device; its totals.
    Done(Counters),
    /// A dora event and its arrival time on the host clock, ns.
    Event(Event, i64),
    /// dora's event stream ended.
    EventsClosed,
}

/// One captured frame as the messages the node sends (also what the benchmark measures).
///
/// # Errors
/// Encoding failed.
pub fn encode(
    sensor_id: &str,
    seq: u64,
    captured: &Captured,
    send_ir: bool,
) -> eyre::Result<(
    dora_node_api::arrow_v59::array::ArrayRef,
    Option<dora_node_api::arrow_v59::array::ArrayRef>,
)> {
    let (depth, ir) = captured.messages(sensor_id, seq);
    let depth = depth.encode().context("encoding a depth frame")?;
    let ir = match ir {
        Some(ir) if send_ir => Some(ir.encode().context("encoding an IR frame")?),
        _ => None,
    };
    Ok((depth, ir))
}

/// Builds the real driver and runs the backend.
///
/// # Errors
/// The build has no libfreenect2, the configuration is invalid, or sending failed.
pub fn main(config: Config) -> eyre::Result<Summary> {
    let f2 = Freenect2Config::from_lookup(&|k| std::env::var(k).ok())?;
    let driver = real_driver()?;
    let (node, events) =
        DoraNode::init_from_env().context("kinect-source: connecting to the dora daemon")?;
    run(&config, &f2, driver, node, events)
}

#[cfg(feature = "freenect2")]
fn real_driver() -> eyre::Result<Box<dyn Driver>> {
    Ok(Box::new(trigait_freenect2::Freenect2::new().map_err(
        |e| eyre!("{NODE}: {}=freenect2: {e}", config::BACKEND),
    )?))
}

#[cfg(not(feature = "freenect2"))]
fn real_driver() -> eyre::Result<Box<dyn Driver>> {
    bail!(
        "{NODE}: {}=freenect2, but this binary was not built with freenect2 \
         (rebuild with `cargo build --release --workspace --features trigait-kinect-source-node/freenect2`; see the README)",
        config::BACKEND
    )
}

/// The event loop over any driver (the fake one in tests): frames out as they come, NTP
/// replies on the host clock in between, and a stop that never waits on the device for more
/// than a moment.
///
/// Two threads feed one channel, so the loop blocks on both at once without polling: the
/// capture thread (frames, state changes) and an event thread (dora events, each stamped on
/// arrival, so an NTP request's receive time does not include the frames queued before it).
/// At most [`MAX_QUEUED_FRAMES`] frames wait to be sent; a frame captured while the queue is
/// full is dropped and counted (its sequence number is skipped, so downstream sees the gap),
/// which keeps a slow send from delaying a stop or growing the queue without bound.
///
/// # Errors
/// Encoding or sending failed.
pub fn run(
    config: &Config,
    f2: &Freenect2Config,
    driver: Box<dyn Driver>,
    mut node: DoraNode,
    events: EventStream,
) -> eyre::Result<Summary> {
    let depth_out = DataId::from(ports::DEPTH.to_owned());
    let ir_out = DataId::from(IR.to_owned());
    let ntp = crate::ntp::Responder::new(&config.sensor_id);
    let status_out = DataId::from(ports::STATUS.to_owned());
    let mut status = StatusReport::new(&config.sensor_id, f2.status_every);
    let stop = Arc::new(AtomicBool::new(false));
    let queue = Arc::new(FrameQueue::default());
    let (tx, rx) = mpsc::channel();
    let worker = {
        let stop = Arc::clone(&stop);
        let queue = Arc::clone(&queue);
        let tx = tx.clone();
        let capture_config = f2.capture.clone();
        std::thread::Builder::new()
            .name("freenect2-capture".into())
            .spawn(move || capture_loop(capture_config, driver, &stop, &queue, &tx))
            .context("kinect-source: starting the capture thread")?
    };
    let forwarder = {
        let stop = Arc::clone(&stop);
        std::thread::Builder::new()
            .name("freenect2-events".into())
            .spawn(move || forward_events(events, &stop, &tx))
            .context("kinect-source: starting the event thread")?
    };
    let mut summary = Summary::default();
    let mut done = false;
    let result = (|| -> eyre::Result<()> {
        loop {
            if status.due() {
                let array = status.message().encode().context("encoding the status")?;
                node.send_output(status_out.clone(), MetadataParameters::default(), array)
                    .context("kinect-source: sending status")?;
                status.sent();
            }
            let msg = match rx.recv_timeout(status.wait()) {
                Ok(msg) => msg,
                Err(mpsc::RecvTimeoutError::Timeout) => continue,
                Err(mpsc::RecvTimeoutError::Disconnected) => return Ok(()),
            };
            match msg {
                // A stop is on its way behind this frame: it is not sent.
                Msg::Frame(..) if stop.load(Ordering::SeqCst) => {
                    queue.taken();
                    summary.unsent_at_stop += 1;
                }
                Msg::Frame(captured, seq, pinhole) => {
                    status.lost_frames += captured.lost_before;
                    let sent = (|| {
                        let (depth, ir) = encode(&config.sensor_id, seq, &captured, f2.send_ir)?;
                        let params = metadata(&captured, pinhole);
                        if let Some(ir) = ir {
                            node.send_output(ir_out.clone(), params.clone(), ir)
                                .context("kinect-source: sending ir")?;
                        }
                        node.send_output(depth_out.clone(), params, depth)
                            .context("kinect-source: sending depth")
                    })();
                    queue.taken();
                    sent?;
                    summary.frames_sent += 1;
                    if config.frame_limit_reached(summary.frames_sent) {
                        return Ok(());
                    }
                }
                Msg::State(state) => {
                    match &state {
                        State::Streaming => info!("Kinect v2: {state}"),
                        _ => warn!("Kinect v2: {state}"),
                    }
                    status.change(&state);
                    summary.states.push(state);
                }
                Msg::Done(counters) => {
                    summary.capture = counters;
                    done = true;
                    return Ok(());
                }
                Msg::EventsClosed | Msg::Event(Event::Stop(_), _) => return Ok(()),
                Msg::Event(Event::Input { id, metadata, data }, t2)
                    if id.as_str() == ports::NTP_REQUEST =>
                {
                    ntp.answer(
                        &mut node,
                        metadata.parameters,
                        data.as_array().as_ref(),
                        t2,
                        now_nanos,
                        crate::ntp::NtpCounts {
                            answered: &mut summary.ntp_answered,
                            malformed: &mut summary.malformed,
                        },
                    )?;
                }
                Msg::Event(Event::Input { id, .. }, _) => {
                    warn!(input = id.as_str(), "ignoring an unknown input");
                }
                Msg::Event(Event::Error(e), _) => warn!("event stream error: {e}"),
                Msg::Event(..) => {}
            }
        }
    })();
    stop.store(true, Ordering::SeqCst);
    let deadline = Instant::now() + STOP_GRACE;
    while !done {
        match rx.recv_timeout(deadline.saturating_duration_since(Instant::now())) {
            Ok(Msg::Done(counters)) => {
                summary.capture = counters;
                done = true;
            }
            Ok(Msg::Frame(..)) => summary.unsent_at_stop += 1,
            Ok(_) => {}
            Err(mpsc::RecvTimeoutError::Timeout) => {
                warn!("the Kinect did not close within {STOP_GRACE:?}; exiting without it");
                summary.abandoned_device = true;
                break;
            }
            // Both threads are gone; the capture thread ended without its totals.
            Err(mpsc::RecvTimeoutError::Disconnected) => break,
        }
    }
    summary.dropped_busy = queue.dropped();
    // The event thread sees the stop within one of its waits; joined only if it has, so a
    // stream that does not close cannot hold the exit.
    let forwarder_deadline = Instant::now() + EVENT_WAIT * 2;
    while !forwarder.is_finished() && Instant::now() < forwarder_deadline {
        std::thread::sleep(Duration::from_millis(5));
    }
    if forwarder.is_finished() {
        let _ = forwarder.join();
    }
    drop(worker);
    info!(
        "{} depth frames sent, {} lost ({} in sequence gaps, {} while away), {} dropped while sending was busy, {} degraded, {} rejoins, {} NTP requests answered",
        summary.frames_sent,
        summary.capture.lost(),
        summary.capture.lost_in_sequence,
        summary.capture.missed_while_away,
        summary.dropped_busy,
        summary.capture.degraded,
        summary.capture.rejoins,
        summary.ntp_answered
    );
    result.map(|()| summary)
}

/// The `status` report: the current state, since when, frames lost so far, and when the next
/// report is due (at once after a change, then every period).
#[derive(Debug)]
struct StatusReport {
    sensor_id: String,
    every: Duration,
    state: State,
    since_nanos: i64,
    lost_frames: u64,
    next: Instant,
}

impl StatusReport {
    fn new(sensor_id: &str, every: Duration) -> Self {
        Self {
            sensor_id: sensor_id.to_owned(),
            every,
            state: State::Starting,
            since_nanos: now_nanos(),
            lost_frames: 0,
            next: Instant::now(),
        }
    }

    fn change(&mut self, state: &State) {
        if *state != self.state {
            self.state = state.clone();
            self.since_nanos = now_nanos();
            self.next = Instant::now();
        }
    }

    fn due(&self) -> bool {
        Instant::now() >= self.next
    }

    fn wait(&self) -> Duration {
        self.next.saturating_duration_since(Instant::now())
    }

    fn sent(&mut self) {
        self.next = Instant::now() + self.every;
    }

    fn message(&self) -> SensorStatus {
        let state = match &self.state {
            State::Starting => SensorStatus::STARTING,
            State::Streaming => SensorStatus::STREAMING,
            State::Degraded(Degraded::Stalled) => SensorStatus::STALLED,
            State::Degraded(Degraded::Absent(_)) => SensorStatus::ABSENT,
            State::Degraded(Degraded::Failed(_)) => SensorStatus::FAILED,
        };
        SensorStatus {
            sensor_id: self.sensor_id.clone(),
            stamp_nanos: now_nanos(),
            state: state.to_owned(),
            detail: self.state.to_string(),
            since_nanos: self.since_nanos,
            lost_frames: self.lost_frames,
        }
    }
}

/// Frames handed to the event loop and not yet sent, and those dropped because too many were.
#[derive(Debug, Default)]
struct FrameQueue {
    queued: AtomicUsize,
    dropped: AtomicU64,
}

impl FrameQueue {
    /// Takes a place for one more frame, or counts it dropped when the queue is full.
    fn offer(&self) -> bool {
        let placed = self
            .queued
            .fetch_update(Ordering::SeqCst, Ordering::SeqCst, |n| {
                (n < MAX_QUEUED_FRAMES).then_some(n + 1)
            })
            .is_ok();
        if !placed {
            self.dropped.fetch_add(1, Ordering::SeqCst);
        }
        placed
    }

    /// One queued frame was sent (or failed to be).
    fn taken(&self) {
        let _ = self
            .queued
            .fetch_update(Ordering::SeqCst, Ordering::SeqCst, |n| n.checked_sub(1));
    }

    fn dropped(&self) -> u64 {
        self.dropped.load(Ordering::SeqCst)
    }
}

/// Moves dora's events onto the loop's channel, each with its arrival time on the host clock,
/// until the stream ends, the loop is gone, or `stop` is set.
fn forward_events(mut events: EventStream, stop: &AtomicBool, tx: &mpsc::Sender<Msg>) {
    while !stop.load(Ordering::SeqCst) {
        let Some(event) = events.recv_timeout(EVENT_WAIT) else {
            let _ = tx.send(Msg::EventsClosed);
            return;
        };
        let arrived = now_nanos();
        trigait_node_log::warn_drops(&mut events);
        if matches!(event, Event::Stop(_)) {
            // Seen at once by the capture thread (it starts closing the device) and by the
            // loop (frames queued before the stop are not sent).
            stop.store(true, Ordering::SeqCst);
        }
        if let Event::Error(e) = &event
            && (e.contains("Timeout") || e.contains("timed out"))
        {
            continue;
        }
        if tx.send(Msg::Event(event, arrived)).is_err() {
            return;
        }
    }
}

fn metadata(c: &Captured, pinhole: Option<[f64; 4]>) -> MetadataParameters {
    let mut params = MetadataParameters::default();
    if let Some(k) = pinhole {
        params.insert(
            ports::DEPTH_PINHOLE.to_owned(),
            trigait_node_config::pinhole_parameter(k),
        );
    }
    params.insert(
        ports::SENT_NANOS.to_owned(),
        Parameter::Integer(now_nanos()),
    );
    params.insert(DEVICE_NANOS.to_owned(), Parameter::Integer(c.device_nanos));
    params.insert(
        DEVICE_SEQUENCE.to_owned(),
        Parameter::Integer(i64::from(c.depth.sequence)),
    );
    params.insert(
        HOST_ARRIVAL_NANOS.to_owned(),
        Parameter::Integer(c.host_nanos),
    );
    params.insert(
        LOST_BEFORE.to_owned(),
        Parameter::Integer(i64::try_from(c.lost_before).unwrap_or(i64::MAX)),
    );
    params
}

/// The open device's lens as an [`Undistorter`] map, rebuilt only when the device's
/// intrinsics change (a rejoin may bring another device), so a frame costs one table lookup
/// per pixel.
#[derive(Default)]
struct Lens {
    map: Option<(IrParams, Undistorter)>,
}

impl Lens {
    /// Undistorts `frame` to the ideal pinhole of the device's intrinsics and returns that
    /// pinhole; `None` (the frame stays raw) when the intrinsics are unknown or unusable.
    fn undistort(&mut self, params: Option<IrParams>, frame: &mut Captured) -> Option<[f64; 4]> {
        let params =
            params.filter(|p| p.fx.is_finite() && p.fy.is_finite() && p.fx > 0.0 && p.fy > 0.0)?;
        if self.map.as_ref().is_none_or(|(p, _)| *p != params) {
            self.map = Some((params, Undistorter::new(&params.intrinsics())));
        }
        let (_, map) = self.map.as_ref()?;
        match frame.undistort(map) {
            Ok(k) => Some(k),
            Err(e) => {
                warn!("{NODE}: sending a raw frame: {e}");
                None
            }
        }
    }
}

fn capture_loop(
    config: CaptureConfig,
    driver: Box<dyn Driver>,
    stop: &AtomicBool,
    queue: &FrameQueue,
    tx: &mpsc::Sender<Msg>,
) {
    let mut capture = Capture::new(config, driver);
    let mut lens = Lens::default();
    while !stop.load(Ordering::SeqCst) {
        let msg = match capture.poll(POLL) {
            Some(trigait_freenect2::capture::Event::Frame(mut f)) => {
                if !queue.offer() {
                    continue;
                }
                let pinhole = lens.undistort(capture.ir_params(), &mut f);
                let c = capture.counters();
                // The stream's frame number counts the lost frames too.
                Msg::Frame(f, (c.frames - 1) + c.lost(), pinhole)
            }
            Some(trigait_freenect2::capture::Event::State(s)) => Msg::State(s),
            None => continue,
        };
        if tx.send(msg).is_err() {
            break;
        }
    }
    capture.shutdown();
    let _ = tx.send(Msg::Done(capture.counters().clone()));
}

#[cfg(test)]
mod tests {
    use dora_node_api::integration_testing::{TestingOptions, drain_outputs};
    use dora_node_api::serde_json;
    use trigait_freenect2::capture::Degraded;
    use trigait_freenect2::fake::{FakeDriver, FakeKinect, Fault};
    use trigait_node_testing::{chain, init_node, lookup};
    use trigait_schema::{DepthFrameMessage, NtpExchange};

    use super::*;

    const PIXELS: usize = 512 * 424;
    /// A pixel at the fake lens' principal point, which undistortion leaves in place.
    const CENTRE: usize = 205 * 512 + 255;

    /// The first frame of a fake device's capture.
    fn first_frame(frames: Vec<Vec<f32>>) -> (Capture, Box<Captured>) {
        let mut capture = Capture::new(
            CaptureConfig::new(Selector::Index(0)),
            Box::new(FakeDriver::new(vec![FakeKinect::new("S1", frames)])),
        );
        loop {
            if let Some(trigait_freenect2::capture::Event::Frame(f)) =
                capture.poll(Duration::from_millis(100))
            {
                return (capture, f);
            }
        }
    }

    /// The tilted plane n·p = d (Kinect-agnostic OpenCV frame, m) used below.
    const PLANE_N: [f64; 3] = [0.3, -0.2, 1.0];
    const PLANE_D: f64 = 2.2;

    /// The plane's distance from the plane, m, of the point at depth `z_m` along `ray`.
    fn off_plane((x, y): (f64, f64), z_m: f64) -> f64 {
        let norm = PLANE_N.iter().map(|c| c * c).sum::<f64>().sqrt();
        (PLANE_N[0] * x * z_m + PLANE_N[1] * y * z_m + PLANE_N[2] * z_m - PLANE_D) / norm
    }

    /// What the device's distorted lens sees of the plane: raw pixel (u, v) looks along the
    /// undistorted ray of its distorted coordinates.
    fn raw_plane(lens: &trigait_depth::Intrinsics) -> Vec<f32> {
        (0..PIXELS)
            .map(|i| {
                let (u, v) = ((i % 512) as f64, (i / 512) as f64);
                let (x, y) = lens.undistort((u - lens.cx) / lens.fx, (v - lens.cy) / lens.fy);
                let z = PLANE_D / (PLANE_N[0] * x + PLANE_N[1] * y + PLANE_N[2]);
                (z * 1000.0) as f32
            })
            .collect()
    }

    /// The backend's path on the fake device (whose lens has barrel distortion): the frame is
    /// resampled to the device's pinhole, stamped on the metadata, and a tilted plane seen
    /// through the lens back-projects onto the plane with the stamped pinhole to the resampling
    /// (nearest raw pixel) and mm rounding, where the raw frame with the same pinhole is off by
    /// centimetres at the edges.
    #[test]
    fn undistorted_plane_back_projects_to_the_plane() {
        let (capture, _) = first_frame(wall());
        let device = capture.ir_params().unwrap().intrinsics();
        assert_ne!(device.dist, [0.0; 5], "the fake lens must be distorted");
        let raw = raw_plane(&device);
        drop(capture);
        let (capture, mut captured) = first_frame(vec![raw.clone()]);
        let mut lens = Lens::default();
        let pinhole = lens
            .undistort(capture.ir_params(), &mut captured)
            .expect("undistorted with the device's intrinsics");
        assert_eq!(pinhole, [device.fx, device.fy, device.cx, device.cy]);
        let params = metadata(&captured, Some(pinhole));
        let stamped = trigait_node_config::stamped_pinhole(&params).unwrap();
        assert_eq!(stamped, pinhole);
        let [fx, fy, cx, cy] = stamped;
        let rays = trigait_depth::Intrinsics::pinhole(fx, fy, cx, cy).rays();
        let sent = DepthFrameMessage::decode(encode("k1", 0, &captured, false).unwrap().0.as_ref())
            .unwrap()
            .depth_mm;
        let (mut worst, mut with_data) = (0.0_f64, 0);
        for (i, &mm) in sent.iter().enumerate() {
            if mm > 0 {
                with_data += 1;
                worst = worst.max(off_plane(rays.at(i), f64::from(mm) / 1000.0).abs());
            }
        }
        assert!(with_data > PIXELS * 9 / 10, "{with_data} pixels with data");
        assert!(worst < 0.003, "undistorted: {worst} m off the plane");
        let raw_worst = raw
            .iter()
            .enumerate()
            .map(|(i, &mm)| off_plane(rays.at(i), f64::from(mm) / 1000.0).abs())
            .fold(0.0, f64::max);
        assert!(raw_worst > 0.02, "raw: {raw_worst} m off the plane");
        // A second frame reuses the map; no intrinsics → the frame stays raw and unstamped.
        let (_, mut again) = first_frame(vec![raw.clone()]);
        assert_eq!(
            lens.undistort(capture.ir_params(), &mut again),
            Some(pinhole)
        );
        let (_, mut unknown) = first_frame(vec![raw.clone()]);
        assert_eq!(lens.undistort(None, &mut unknown), None);
        assert_eq!(unknown.depth.as_f32(), raw.as_slice());
        assert_eq!(metadata(&unknown, None).get(ports::DEPTH_PINHOLE), None);
        // The IR image of the same capture (the fake's is depth / 10) is resampled the same way.
        let mut with_ir = CaptureConfig::new(Selector::Index(0));
        with_ir.streams.ir = true;
        let mut capture = Capture::new(
            with_ir,
            Box::new(FakeDriver::new(vec![FakeKinect::new("S1", vec![raw])])),
        );
        let mut captured = loop {
            if let Some(trigait_freenect2::capture::Event::Frame(f)) =
                capture.poll(Duration::from_millis(100))
            {
                break f;
            }
        };
        assert!(captured.ir.is_some());
        assert_eq!(
            lens.undistort(capture.ir_params(), &mut captured),
            Some(pinhole)
        );
        let ir = captured.ir.as_ref().unwrap().as_f32();
        for (d, i) in captured.depth.as_f32().iter().zip(ir) {
            assert!((d / 10.0 - i).abs() <= d.abs() * 1e-6, "depth {d}, ir {i}");
        }
    }

    fn config() -> Config {
        Config::from_lookup(lookup(&[("SENSOR_ID", "k1"), ("BACKEND", "freenect2")])).unwrap()
    }

    fn f2(pairs: &[(&str, &str)]) -> eyre::Result<Freenect2Config> {
        Freenect2Config::from_lookup(&lookup(pairs))
    }

    fn wall() -> Vec<Vec<f32>> {
        vec![(0..PIXELS).map(|i| 2000.4 + (i % 7) as f32).collect()]
    }

    /// Serial or index, pipeline, IR and timings come from the env block; errors name the key.
    #[test]
    fn config_from_env() {
        let c = f2(&[
            ("FREENECT2_SERIAL", " 012345 "),
            ("FREENECT2_PIPELINE", "opencl"),
        ])
        .unwrap();
        assert_eq!(c.capture.sensor, Selector::Serial("012345".into()));
        assert_eq!(c.capture.pipeline, Pipeline::OpenCl);
        assert!(!c.send_ir && !c.capture.streams.ir);
        let c = f2(&[("FREENECT2_INDEX", "2"), ("FREENECT2_IR", "true")]).unwrap();
        assert_eq!(c.capture.sensor, Selector::Index(2));
        assert!(c.send_ir && c.capture.streams.ir);
        assert_eq!(f2(&[]).unwrap().capture.sensor, Selector::Index(0));
        for (key, value) in [
            ("FREENECT2_PIPELINE", "vulkan"),
            ("FREENECT2_INDEX", "-1"),
            ("FREENECT2_STALL_MILLIS", "0"),
            ("FREENECT2_IR", "maybe"),
        ] {
            let text = chain(&f2(&[(key, value)]).unwrap_err());
            assert!(
                text.contains(key) && text.contains("kinect-source"),
                "{text}"
            );
        }
        assert!(f2(&[("FREENECT2_SERIAL", "a"), ("FREENECT2_INDEX", "0")]).is_err());
    }

    /// The node's input: NTP requests for this sensor at `mine`, requests for another
    /// sensor (which it skips) every 10 ms, and a stop at `stop_at` s.
    ///
    /// The requests for another sensor are what a sync node serving several sensors sends;
    /// here they also keep dora's testing daemon serving the node's sends, which it does
    /// only between scheduled events (it sleeps until the next one on the thread that takes
    /// the outputs), so a sparse input would hold every frame until the stop.
    fn events(stop_at: f64, dir: &std::path::Path, mine: &[f64]) -> serde_json::Value {
        let own = ntp_file(dir, "k1");
        let other = ntp_file(dir, "k9");
        let mut list = Vec::new();
        for &t in mine {
            list.push(serde_json::json!({"time_offset_secs": t, "type": "Input", "id": "ntp_request", "path": own, "column": "msg"}));
        }
        for i in 1.. {
            let t = f64::from(i) * 0.01;
            if t >= stop_at {
                break;
            }
            list.push(serde_json::json!({"time_offset_secs": t, "type": "Input", "id": "ntp_request", "path": other, "column": "msg"}));
        }
        list.push(serde_json::json!({"time_offset_secs": stop_at, "type": "Stop"}));
        serde_json::json!({"id": "k1", "events": list})
    }

    fn scratch(name: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!(
            "trigait-freenect2-node-{name}-{}",
            std::process::id()
        ));
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    fn ntp_file(dir: &std::path::Path, sensor: &str) -> std::path::PathBuf {
        trigait_node_testing::arrow_file(
            dir,
            sensor,
            NtpExchange::request(sensor, 3, 1_000).encode().unwrap(),
        )
    }

    /// Depth frames go out as `depth_frame`s in whole mm with host-clock stamps and stream
    /// sequence numbers that skip only counted losses, NTP requests are answered on the same
    /// host clock (only those addressed to this sensor), and the node stops on Stop.
    #[test]
    fn frames_and_ntp_replies() {
        let dir = scratch("frames");
        let (node, events, mut rx) = init_node(
            events(1.0, &dir, &[0.3, 0.7]),
            TestingOptions {
                skip_output_time_offsets: true,
            },
        );
        let driver = FakeDriver::new(vec![FakeKinect::new("S1", wall())]);
        let c = f2(&[("FREENECT2_SERIAL", "S1")]).unwrap();
        let start = now_nanos();
        let summary = run(&config(), &c, Box::new(driver), node, events).unwrap();
        let end = now_nanos();
        assert_eq!(summary.ntp_answered, 2, "{summary:?}");
        assert!(summary.frames_sent >= 5, "{summary:?}");
        assert_eq!(summary.states.first(), Some(&State::Streaming));
        assert!(!summary.abandoned_device);
        assert_eq!(summary.malformed, 0);
        let outputs = drain_outputs(&mut rx);
        let depth: Vec<_> = outputs
            .iter()
            .filter(|o| o.get("id").and_then(|v| v.as_str()) == Some("depth"))
            .map(|o| {
                let row = &o["data"][0];
                (
                    row["seq"].as_u64().unwrap(),
                    row["local_stamp_nanos"].as_i64().unwrap(),
                    [0, CENTRE, CENTRE + 1]
                        .map(|i| row["depth_mm"].as_array().unwrap()[i].as_u64().unwrap()),
                )
            })
            .collect();
        assert_eq!(depth.len() as u64, summary.frames_sent);
        let mut skipped = 0;
        for pair in depth.windows(2) {
            assert!(pair[1].0 > pair[0].0, "sequence not increasing: {pair:?}");
            assert!(pair[1].1 > pair[0].1, "stamps not increasing: {pair:?}");
            skipped += pair[1].0 - pair[0].0 - 1;
        }
        assert!(
            skipped <= summary.dropped_busy + summary.capture.lost(),
            "{skipped} sequence numbers skipped, {summary:?}"
        );
        // Undistorted: the corner takes another raw pixel (raw it would be 2000), the centre
        // stays put.
        for (_, stamp, mm) in &depth {
            assert!((start..=end).contains(stamp));
            assert_ne!(mm[0], 2000, "{mm:?}");
            assert_eq!(
                mm[1..],
                [2000 + CENTRE as u64 % 7, 2000 + (CENTRE as u64 + 1) % 7]
            );
        }
        let replies = trigait_node_testing::output_arrays(&outputs, "ntp_reply");
        assert_eq!(replies.len(), 2);
        for reply in replies {
            let r = NtpExchange::decode(reply.as_ref()).unwrap();
            assert_eq!((r.sensor_id.as_str(), r.request_id), ("k1", 3));
            let (t2, t3) = (r.t2_nanos.unwrap(), r.t3_nanos.unwrap());
            assert!(start <= t2 && t2 <= t3 && t3 <= end, "{r:?}");
        }
        // The metadata (not in dora's testing output) of one captured frame.
        let mut capture = Capture::new(
            CaptureConfig::new(Selector::Index(0)),
            Box::new(FakeDriver::new(vec![FakeKinect::new("S1", wall())])),
        );
        let captured = loop {
            if let Some(trigait_freenect2::capture::Event::Frame(f)) =
                capture.poll(Duration::from_millis(100))
            {
                break f;
            }
        };
        let params = metadata(&captured, None);
        assert_eq!(params.get(ports::DEPTH_PINHOLE), None);
        assert_eq!(
            params.get(HOST_ARRIVAL_NANOS),
            Some(&Parameter::Integer(captured.host_nanos))
        );
        assert_eq!(
            params.get(DEVICE_NANOS),
            Some(&Parameter::Integer(captured.device_nanos))
        );
        assert_eq!(
            params.get(DEVICE_SEQUENCE),
            Some(&Parameter::Integer(i64::from(captured.depth.sequence)))
        );
        assert_eq!(params.get(LOST_BEFORE), Some(&Parameter::Integer(0)));
        // The encoded message itself: rounding, stamps on the host clock.
        let mut capture = Capture::new(
            CaptureConfig::new(Selector::Index(0)),
            Box::new(FakeDriver::new(vec![FakeKinect::new("S1", wall())])),
        );
        let captured = loop {
            if let Some(trigait_freenect2::capture::Event::Frame(f)) =
                capture.poll(Duration::from_millis(100))
            {
                break f;
            }
        };
        // Raw (the capture state machine's frame, not undistorted by the backend here).
        let (array, ir) = encode("k1", 4, &captured, false).unwrap();
        assert!(ir.is_none());
        let m = DepthFrameMessage::decode(array.as_ref()).unwrap();
        assert_eq!((m.seq, m.width, m.height), (4, 512, 424));
        assert_eq!(&m.depth_mm[..3], &[2000, 2001, 2002]);
        assert!(m.local_stamp_nanos >= start && m.local_stamp_nanos <= now_nanos());
        assert!(m.local_stamp_nanos <= captured.host_nanos);
        std::fs::remove_dir_all(&dir).ok();
    }

    /// A stop while the device blocks (stalled, and its close hangs): the node still returns
    /// within 1 s of the stop.
    #[test]
    fn stop_during_a_blocked_wait_exits_within_a_second() {
        let dir = scratch("stop");
        let (node, events, _rx) = init_node(
            events(0.8, &dir, &[]),
            TestingOptions {
                skip_output_time_offsets: true,
            },
        );
        let mut kinect = FakeKinect::new("S2", wall()).with(Fault::Stall {
            at: Duration::from_millis(200),
            length: Duration::from_secs(600),
        });
        kinect.close_hangs = Duration::from_secs(30);
        let c = f2(&[("FREENECT2_SERIAL", "S2")]).unwrap();
        let t = Instant::now();
        let summary = run(
            &config(),
            &c,
            Box::new(FakeDriver::new(vec![kinect])),
            node,
            events,
        )
        .unwrap();
        let took = t.elapsed();
        eprintln!("returned {took:?} after the start (the stop is due at most 0.8 s in)");
        assert!(
            took < Duration::from_millis(1800),
            "stop at 0.8 s, returned after {took:?}"
        );
        assert!(summary.abandoned_device, "{summary:?}");
        assert!(summary.frames_sent >= 3, "{summary:?}");
        std::fs::remove_dir_all(&dir).ok();
    }

    /// Unplugged mid-run, the node reports degraded and then streaming again, without a
    /// restart; frames keep flowing after the rejoin and the outage is counted as lost.
    #[test]
    fn unplug_degrades_then_rejoins() {
        let dir = scratch("unplug");
        let (node, events, mut rx) = init_node(
            events(2.4, &dir, &[]),
            TestingOptions {
                skip_output_time_offsets: true,
            },
        );
        let kinect = FakeKinect::new("S3", wall()).with(Fault::Unplug {
            at: Duration::from_millis(400),
            after: Some(Duration::from_millis(800)),
        });
        let c = f2(&[
            ("FREENECT2_SERIAL", "S3"),
            ("FREENECT2_STALL_MILLIS", "200"),
            ("FREENECT2_RESCAN_MILLIS", "150"),
        ])
        .unwrap();
        let summary = run(
            &config(),
            &c,
            Box::new(FakeDriver::new(vec![kinect])),
            node,
            events,
        )
        .unwrap();
        assert!(
            summary
                .states
                .iter()
                .any(|s| matches!(s, State::Degraded(Degraded::Absent(_)))),
            "{:?}",
            summary.states
        );
        assert_eq!(summary.states.last(), Some(&State::Streaming));
        assert_eq!(summary.capture.rejoins, 1);
        let outputs = drain_outputs(&mut rx);
        let states: Vec<String> = trigait_node_testing::output_arrays(&outputs, ports::STATUS)
            .iter()
            .map(|a| SensorStatus::decode(a.as_ref()).unwrap().state)
            .collect();
        let absent = states.iter().position(|s| s == SensorStatus::ABSENT);
        assert!(
            absent.is_some_and(|i| states[i..].contains(&SensorStatus::STREAMING.to_owned())),
            "{states:?}"
        );
        assert!(
            summary.capture.missed_while_away >= 20,
            "{:?}",
            summary.capture
        );
        // Frames flow after the rejoin: the outage is one jump of the stream's sequence
        // (counting the missed frames), with frames sent after it.
        let seqs: Vec<u64> = outputs
            .iter()
            .filter(|o| o.get("id").and_then(|v| v.as_str()) == Some("depth"))
            .map(|o| o["data"][0]["seq"].as_u64().unwrap())
            .collect();
        assert_eq!(seqs.len() as u64, summary.frames_sent);
        let (at, jump) = seqs
            .windows(2)
            .enumerate()
            .map(|(i, w)| (i + 1, w[1] - w[0]))
            .max_by_key(|&(_, jump)| jump)
            .unwrap();
        assert!(
            jump > summary.capture.missed_while_away,
            "largest jump {jump} at {at} of {seqs:?}, {summary:?}"
        );
        assert!(seqs.len() - at >= 5, "{seqs:?}, {summary:?}");
        std::fs::remove_dir_all(&dir).ok();
    }

    /// A 2 s stall: NTP requests during it are still answered at once (on the host clock,
    /// which the device does not hold up), the sensor is reported stalled and then streaming,
    /// the frames it captured meanwhile are counted lost and skipped in the sequence, and the
    /// stamps after the stall are still on the host clock: the stamp gap across the stall is
    /// the sequence gap times the frame period.
    #[test]
    fn two_second_stall_counts_lost_frames_and_ntp_goes_on() {
        let dir = scratch("stall");
        let requests = [0.2, 0.9, 1.6, 2.3, 2.8];
        let (node, events, mut rx) = init_node(
            events(3.1, &dir, &requests),
            TestingOptions {
                skip_output_time_offsets: true,
            },
        );
        let kinect = FakeKinect::new("S4", wall()).with(Fault::Stall {
            at: Duration::from_millis(400),
            length: Duration::from_secs(2),
        });
        let c = f2(&[
            ("FREENECT2_SERIAL", "S4"),
            ("FREENECT2_STATUS_MILLIS", "200"),
        ])
        .unwrap();
        let summary = run(
            &config(),
            &c,
            Box::new(FakeDriver::new(vec![kinect])),
            node,
            events,
        )
        .unwrap();
        assert_eq!(summary.ntp_answered, requests.len() as u64, "{summary:?}");
        assert_eq!(
            summary.states,
            [
                State::Streaming,
                State::Degraded(Degraded::Stalled),
                State::Streaming
            ]
        );
        // 2 s / 33.25 ms = 60.2 frames captured but not delivered.
        assert!(
            (59..=62).contains(&summary.capture.lost_in_sequence),
            "{summary:?}"
        );
        let outputs = drain_outputs(&mut rx);
        // The status reports the stall while no frame arrives: at once when it is detected
        // (1 s after the last frame), then every 200 ms, with its start time; then streaming
        // again, about 1 s later (the 2 s stall less the 1 s stall limit), with the frames
        // lost.
        let status: Vec<SensorStatus> =
            trigait_node_testing::output_arrays(&outputs, ports::STATUS)
                .iter()
                .map(|a| SensorStatus::decode(a.as_ref()).unwrap())
                .collect();
        let stalled: Vec<&SensorStatus> = status
            .iter()
            .filter(|s| s.state == SensorStatus::STALLED)
            .collect();
        assert!((3..=7).contains(&stalled.len()), "{status:#?}");
        assert!(stalled.iter().all(|s| s.is_degraded()
            && s.sensor_id == "k1"
            && s.since_nanos == stalled[0].since_nanos
            && s.stamp_nanos >= s.since_nanos));
        let last = status.last().unwrap();
        assert_eq!(last.state, SensorStatus::STREAMING, "{status:#?}");
        let stall_seen = last.since_nanos - stalled[0].since_nanos;
        assert!(
            (700_000_000..1_600_000_000).contains(&stall_seen),
            "{stall_seen} ns"
        );
        assert!((59..=62).contains(&last.lost_frames), "{last:?}");
        for reply in trigait_node_testing::output_arrays(&outputs, "ntp_reply") {
            let r = NtpExchange::decode(reply.as_ref()).unwrap();
            let (t2, t3) = (r.t2_nanos.unwrap(), r.t3_nanos.unwrap());
            // Never held up by the device; at most by the few frames queued before it
            // (each of which dora's testing daemon turns into JSON).
            assert!((0..500_000_000).contains(&(t3 - t2)), "{r:?}");
        }
        let depth: Vec<(u64, i64)> = outputs
            .iter()
            .filter(|o| o.get("id").and_then(|v| v.as_str()) == Some("depth"))
            .map(|o| {
                let row = &o["data"][0];
                (
                    row["seq"].as_u64().unwrap(),
                    row["local_stamp_nanos"].as_i64().unwrap(),
                )
            })
            .collect();
        let (before, after) = depth
            .windows(2)
            .map(|w| (w[0], w[1]))
            .max_by_key(|(a, b)| b.0 - a.0)
            .unwrap();
        let frames = after.0 - before.0;
        assert!(frames > summary.capture.lost_in_sequence, "{depth:?}");
        let period = 33_250_000_i64;
        let expected = i64::try_from(frames).unwrap() * period;
        assert!(
            (after.1 - before.1 - expected).abs() < period / 2,
            "{frames} frames apart, stamps {} ms apart",
            (after.1 - before.1) / 1_000_000
        );
        assert!(
            depth.iter().filter(|d| d.0 >= after.0).count() >= 3,
            "{depth:?}"
        );
        std::fs::remove_dir_all(&dir).ok();
    }

    /// The node over the real libfreenect2 on a machine with no Kinect: degraded (absent) at
    /// once, no frames, and it still stops within 1 s of the stop.
    #[cfg(feature = "freenect2")]
    #[test]
    fn real_library_without_a_kinect_is_degraded_and_stops() {
        let mut driver = real_driver().unwrap();
        if !driver.enumerate().unwrap().serials.is_empty() {
            eprintln!("skipping: a Kinect v2 is connected");
            return;
        }
        let dir = scratch("real");
        let (node, events, _rx) = init_node(
            events(0.6, &dir, &[0.3]),
            TestingOptions {
                skip_output_time_offsets: true,
            },
        );
        let c = f2(&[("FREENECT2_SERIAL", "000000000000")]).unwrap();
        let t = Instant::now();
        let summary = run(&config(), &c, driver, node, events).unwrap();
        let took = t.elapsed();
        eprintln!("returned {took:?} after the start (the stop is due at most 0.6 s in)");
        assert!(took < Duration::from_millis(1600), "{took:?}");
        assert_eq!((summary.frames_sent, summary.ntp_answered), (0, 1));
        assert!(
            matches!(
                summary.states.first(),
                Some(State::Degraded(Degraded::Absent(_)))
            ),
            "{summary:?}"
        );
        assert!(!summary.abandoned_device);
        std::fs::remove_dir_all(&dir).ok();
    }
}
