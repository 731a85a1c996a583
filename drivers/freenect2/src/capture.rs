//! The capture state machine of a Kinect source: the part of a source node that decides, with
//! no dora and no threads of its own, what to do next. It opens a sensor by serial or by index,
//! pairs each depth frame with the IR frame of the same sequence, counts frames lost to
//! sequence gaps (and frames missed while the sensor was away), unwraps the device's 32-bit
//! tick clock, maps device time to the host clock, and reports a sensor that stops delivering
//! as degraded: stalled first, unplugged once it leaves the enumeration. It re-enumerates
//! periodically and rejoins the sensor when it is back, without restarting anything.
//!
//! Device time → host clock: each frame's host arrival time is its capture time plus a USB and
//! processing latency that is never negative and only sometimes near its minimum, so the offset
//! host − device is estimated as the minimum over a sliding window (3 s): the stamp follows the
//! device's regular clock instead of the arrival jitter, and drift between the two clocks is
//! tracked window by window. The stamps are on the host clock, the clock the node answers NTP
//! requests with.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use trigait_schema::{DepthFrameMessage, IrFrameMessage};

use crate::{Device, DeviceInfo, Driver, Error, Frame, FrameKind, Pipeline, Streams, TICK_NANOS};

/// Which sensor to capture.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Selector {
    /// By serial number (what a lab with several sensors wants).
    Serial(String),
    /// By position in libfreenect2's enumeration.
    Index(usize),
}

impl std::fmt::Display for Selector {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Selector::Serial(s) => write!(f, "serial {s}"),
            Selector::Index(i) => write!(f, "index {i}"),
        }
    }
}

/// The state machine's settings.
#[derive(Debug, Clone, PartialEq)]
pub struct CaptureConfig {
    /// The sensor.
    pub sensor: Selector,
    /// Depth pipeline.
    pub pipeline: Pipeline,
    /// Streams.
    pub streams: Streams,
    /// No frame for this long → degraded (stalled).
    pub stall_after: Duration,
    /// How often to re-enumerate while degraded.
    pub rescan_every: Duration,
    /// A device still enumerated but stalled this long is closed and reopened.
    pub reopen_after: Duration,
    /// Nominal frame period (frames missed while degraded are counted with it).
    pub frame_period: Duration,
}

impl CaptureConfig {
    /// Defaults for a sensor: CPU pipeline, depth + IR, degraded after 1 s without frames,
    /// re-enumeration every 2 s, reopen after 5 s of stall.
    #[must_use]
    pub fn new(sensor: Selector) -> Self {
        Self {
            sensor,
            pipeline: Pipeline::Cpu,
            streams: Streams::default(),
            stall_after: Duration::from_secs(1),
            rescan_every: Duration::from_secs(2),
            reopen_after: Duration::from_secs(5),
            frame_period: Duration::from_micros(33_250),
        }
    }
}

/// Why a sensor is degraded.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Degraded {
    /// Not on the bus (never seen, or unplugged).
    Absent(String),
    /// Open but no frames for longer than the stall limit.
    Stalled,
    /// On the bus but it could not be opened or started.
    Failed(String),
}

/// The sensor's state.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum State {
    /// Not opened yet.
    Starting,
    /// Frames are arriving.
    Streaming,
    /// No frames; why.
    Degraded(Degraded),
}

impl std::fmt::Display for State {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            State::Starting => f.write_str("starting"),
            State::Streaming => f.write_str("streaming"),
            State::Degraded(Degraded::Absent(why)) => write!(f, "degraded: {why}"),
            State::Degraded(Degraded::Stalled) => f.write_str("degraded: no frames (stalled)"),
            State::Degraded(Degraded::Failed(why)) => write!(f, "degraded: {why}"),
        }
    }
}

/// One captured depth frame (with its IR frame when asked for).
#[derive(Debug)]
pub struct Captured {
    /// Depth, mm.
    pub depth: Frame,
    /// IR of the same sequence number.
    pub ir: Option<Frame>,
    /// Device time, unwrapped, ns since the device's clock started (this session).
    pub device_nanos: i64,
    /// The capture instant on the host clock (device time + estimated offset), ns.
    pub stamp_nanos: i64,
    /// When it reached the host, ns.
    pub host_nanos: i64,
    /// Frames lost just before this one (sequence gap and driver drops).
    pub lost_before: u64,
    /// Device session (1 for the first open, +1 per rejoin).
    pub session: u32,
}

impl Captured {
    /// Resamples the depth (and IR) image through `lens`' forward map (libfreenect2's
    /// undistortion, [`trigait_depth::Undistorter`]) so it becomes the ideal distortion-free
    /// pinhole with the lens' fx, fy, cx, cy (returned, `[fx, fy, cx, cy]`); pixels that map
    /// outside the raw image get no data (0). One table lookup per pixel. On an error both
    /// frames stay as they were.
    ///
    /// # Errors
    /// [`crate::Error::BadFrame`] when a frame is not 512×424.
    pub fn undistort(&mut self, lens: &trigait_depth::Undistorter) -> crate::Result<[f64; 4]> {
        let resample = |frame: &Frame| -> crate::Result<Vec<f32>> {
            let mut out = vec![0.0; trigait_depth::PIXELS];
            lens.undistort_into(frame.as_f32(), &mut out)
                .map_err(|e| crate::Error::BadFrame(e.to_string()))?;
            Ok(out)
        };
        // Both resampled before either is replaced: on an error the capture stays raw.
        let depth = resample(&self.depth)?;
        let ir = self.ir.as_ref().map(resample).transpose()?;
        self.depth.pixels = crate::frame::Pixels::Owned(depth);
        if let (Some(frame), Some(pixels)) = (self.ir.as_mut(), ir) {
            frame.pixels = crate::frame::Pixels::Owned(pixels);
        }
        let k = lens.intrinsics();
        Ok([k.fx, k.fy, k.cx, k.cy])
    }

    /// The messages of this capture: the `depth_frame` in whole mm and, when captured, the
    /// `ir_frame` of the IR amplitude; both stamped on the host clock, numbered `seq`.
    #[must_use]
    pub fn messages(
        &self,
        sensor_id: &str,
        seq: u64,
    ) -> (DepthFrameMessage, Option<IrFrameMessage>) {
        let size = |frame: &Frame| {
            (
                u32::try_from(frame.width).unwrap_or(0),
                u32::try_from(frame.height).unwrap_or(0),
            )
        };
        let (width, height) = size(&self.depth);
        let depth = DepthFrameMessage {
            sensor_id: sensor_id.to_owned(),
            seq,
            local_stamp_nanos: self.stamp_nanos,
            width,
            height,
            depth_mm: self.depth.to_u16(),
        };
        let ir = self.ir.as_ref().map(|frame| {
            let (width, height) = size(frame);
            IrFrameMessage {
                sensor_id: sensor_id.to_owned(),
                seq,
                local_stamp_nanos: self.stamp_nanos,
                width,
                height,
                amplitude: frame.to_u16(),
            }
        });
        (depth, ir)
    }
}

/// Running totals.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Counters {
    /// Depth frames delivered.
    pub frames: u64,
    /// Frames lost to sequence gaps while streaming.
    pub lost_in_sequence: u64,
    /// Frames dropped by the driver's queue.
    pub dropped_by_driver: u64,
    /// Frames missed while the sensor was away (estimated from the outage's length).
    pub missed_while_away: u64,
    /// Times the sensor went degraded.
    pub degraded: u64,
    /// Times it came back after being degraded.
    pub rejoins: u64,
    /// Device timestamp wraps seen.
    pub timestamp_wraps: u64,
    /// IR frames without a depth frame of the same sequence (discarded).
    pub unpaired_ir: u64,
}

impl Counters {
    /// All frames lost.
    #[must_use]
    pub fn lost(&self) -> u64 {
        self.lost_in_sequence + self.dropped_by_driver + self.missed_while_away
    }
}

/// What a poll produced.
#[derive(Debug)]
pub enum Event {
    /// A frame.
    Frame(Box<Captured>),
    /// The state changed.
    State(State),
}

/// Unwraps libfreenect2's 32-bit tick counter.
#[derive(Debug, Clone, Default)]
pub struct TickUnwrapper {
    last: Option<u32>,
    high: i64,
}

impl TickUnwrapper {
    /// Device time of `ticks`, ns; `true` when the counter wrapped just now.
    pub fn unwrap(&mut self, ticks: u32) -> (i64, bool) {
        let mut wrapped = false;
        if let Some(last) = self.last
            && ticks < last
            && last - ticks > u32::MAX / 2
        {
            self.high += 1;
            wrapped = true;
        }
        self.last = Some(ticks);
        (((self.high << 32) + i64::from(ticks)) * TICK_NANOS, wrapped)
    }
}

/// Sliding-window minimum of host − device, the offset mapping device time to the host clock.
#[derive(Debug, Clone)]
pub struct HostMapping {
    window: VecDeque<i64>,
    len: usize,
}

impl HostMapping {
    /// A window of `len` frames.
    #[must_use]
    pub fn new(len: usize) -> Self {
        Self {
            window: VecDeque::with_capacity(len.max(1)),
            len: len.max(1),
        }
    }

    /// Adds a frame, returns its host-clock stamp.
    pub fn stamp(&mut self, device_nanos: i64, host_nanos: i64) -> i64 {
        if self.window.len() == self.len {
            self.window.pop_front();
        }
        self.window.push_back(host_nanos - device_nanos);
        let offset = self.window.iter().copied().min().unwrap_or(0);
        device_nanos + offset
    }
}

struct Session {
    device: Box<dyn Device>,
    number: u32,
    last_frame: Instant,
    last_sequence: Option<u32>,
    pending_ir: Option<Frame>,
    ticks: TickUnwrapper,
    mapping: HostMapping,
    dropped_seen: u64,
}

/// The capture state machine over any [`Driver`].
pub struct Capture {
    config: CaptureConfig,
    driver: Box<dyn Driver>,
    session: Option<Session>,
    sessions: u32,
    state: State,
    next_scan: Instant,
    last_frame: Option<(i64, u32)>,
    counters: Counters,
    events: VecDeque<Event>,
}

impl std::fmt::Debug for Capture {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Capture")
            .field("sensor", &self.config.sensor)
            .field("state", &self.state)
            .field("counters", &self.counters)
            .finish_non_exhaustive()
    }
}

impl Capture {
    /// A state machine that opens its sensor on the first poll.
    #[must_use]
    pub fn new(config: CaptureConfig, driver: Box<dyn Driver>) -> Self {
        Self {
            config,
            driver,
            session: None,
            sessions: 0,
            state: State::Starting,
            next_scan: Instant::now(),
            last_frame: None,
            counters: Counters::default(),
            events: VecDeque::new(),
        }
    }

    /// The state.
    #[must_use]
    pub fn state(&self) -> &State {
        &self.state
    }

    /// The totals.
    #[must_use]
    pub fn counters(&self) -> &Counters {
        &self.counters
    }

    /// The open device, if any.
    #[must_use]
    pub fn device(&self) -> Option<&DeviceInfo> {
        self.session.as_ref().map(|s| s.device.info())
    }

    /// The open device's IR camera parameters.
    #[must_use]
    pub fn ir_params(&self) -> Option<crate::IrParams> {
        self.session.as_ref().map(|s| s.device.ir_params())
    }

    /// Works for at most about `max_wait` (plus a bounded open or close) and returns what
    /// happened, if anything. Call it in a loop; between calls the caller can check for a stop.
    pub fn poll(&mut self, max_wait: Duration) -> Option<Event> {
        if let Some(e) = self.events.pop_front() {
            return Some(e);
        }
        let now = Instant::now();
        match self.session.as_mut() {
            None => {
                if now >= self.next_scan {
                    self.try_open();
                } else {
                    std::thread::sleep(max_wait.min(self.next_scan - now));
                }
            }
            Some(session) => match session.device.wait(max_wait) {
                Ok(Some(frame)) => self.on_frame(frame),
                Ok(None) => self.on_silence(),
                Err(e) => {
                    self.close_session();
                    self.set_state(State::Degraded(Degraded::Failed(e.to_string())));
                }
            },
        }
        self.events.pop_front()
    }

    /// Closes the device (bounded by the driver's watchdog).
    pub fn shutdown(&mut self) {
        self.close_session();
    }

    fn set_state(&mut self, state: State) {
        if state == self.state {
            return;
        }
        match (&self.state, &state) {
            (State::Streaming, State::Degraded(_)) => self.counters.degraded += 1,
            (State::Degraded(_), State::Streaming) => self.counters.rejoins += 1,
            _ => {}
        }
        self.state = state.clone();
        self.events.push_back(Event::State(state));
    }

    fn close_session(&mut self) {
        if let Some(s) = self.session.take()
            && let Err(e) = s.device.close()
        {
            tracing::warn!("closing the Kinect: {e}");
        }
    }

    fn try_open(&mut self) {
        self.next_scan = Instant::now() + self.config.rescan_every;
        let serial = match self.driver.enumerate() {
            Err(e) => {
                self.set_state(State::Degraded(Degraded::Failed(e.to_string())));
                return;
            }
            Ok(e) => match &self.config.sensor {
                Selector::Serial(s) if e.serials.contains(s) => s.clone(),
                Selector::Index(i) if *i < e.serials.len() => e.serials[*i].clone(),
                sensor => {
                    let why = if e.usb_access_denied {
                        Error::UsbAccessDenied.to_string()
                    } else {
                        format!(
                            "no Kinect v2 with {sensor} on the bus (connected: {})",
                            if e.serials.is_empty() {
                                "none".to_owned()
                            } else {
                                e.serials.join(", ")
                            }
                        )
                    };
                    self.set_state(State::Degraded(Degraded::Absent(why)));
                    return;
                }
            },
        };
        match self
            .driver
            .open(&serial, self.config.pipeline, self.config.streams)
        {
            Ok(device) => {
                self.sessions += 1;
                tracing::info!(
                    "Kinect v2 {} open (firmware {}, {} pipeline, session {})",
                    device.info().serial,
                    device.info().firmware,
                    device.info().pipeline,
                    self.sessions
                );
                self.session = Some(Session {
                    device,
                    number: self.sessions,
                    last_frame: Instant::now(),
                    last_sequence: None,
                    pending_ir: None,
                    ticks: TickUnwrapper::default(),
                    mapping: HostMapping::new(90),
                    dropped_seen: 0,
                });
            }
            Err(e) => self.set_state(State::Degraded(Degraded::Failed(e.to_string()))),
        }
    }

    fn on_frame(&mut self, frame: Frame) {
        let Some(s) = self.session.as_mut() else {
            return;
        };
        s.last_frame = Instant::now();
        match frame.kind {
            FrameKind::Ir => {
                if s.pending_ir.replace(frame).is_some() {
                    self.counters.unpaired_ir += 1;
                }
                return;
            }
            FrameKind::Color => return,
            FrameKind::Depth => {}
        }
        let ir = match s.pending_ir.take() {
            Some(ir) if ir.sequence == frame.sequence => Some(ir),
            Some(_) => {
                self.counters.unpaired_ir += 1;
                None
            }
            None => None,
        };
        let mut lost = 0;
        if let Some(last) = s.last_sequence {
            let gap = frame.sequence.wrapping_sub(last);
            if gap == 0 || gap > u32::MAX / 2 {
                // A repeated or older frame: nothing to count, never a huge number.
            } else {
                lost += u64::from(gap - 1);
            }
        }
        s.last_sequence = Some(frame.sequence);
        self.counters.lost_in_sequence += lost;
        let dropped = s.device.dropped();
        let new_drops = dropped.saturating_sub(s.dropped_seen);
        s.dropped_seen = dropped;
        self.counters.dropped_by_driver += new_drops;
        let (device_nanos, wrapped) = s.ticks.unwrap(frame.timestamp);
        if wrapped {
            self.counters.timestamp_wraps += 1;
        }
        let stamp_nanos = s.mapping.stamp(device_nanos, frame.host_nanos);
        let session = s.number;
        // Frames missed while the sensor was away, from the outage's length: a new session's
        // sequence restarts, so its gap says nothing (within a session, the gap counted them).
        if matches!(self.state, State::Degraded(_))
            && let Some((prev_host, prev_session)) = self.last_frame
            && prev_session != session
        {
            let period = self.config.frame_period.as_nanos().max(1) as f64;
            let gap = ((frame.host_nanos - prev_host) as f64 / period).round() as i64 - 1;
            self.counters.missed_while_away += u64::try_from(gap).unwrap_or(0);
        }
        self.set_state(State::Streaming);
        self.last_frame = Some((frame.host_nanos, session));
        self.counters.frames += 1;
        self.events.push_back(Event::Frame(Box::new(Captured {
            host_nanos: frame.host_nanos,
            depth: frame,
            ir,
            device_nanos,
            stamp_nanos,
            lost_before: lost + new_drops,
            session,
        })));
    }

    fn on_silence(&mut self) {
        let Some(s) = self.session.as_ref() else {
            return;
        };
        let silent = s.last_frame.elapsed();
        if silent < self.config.stall_after {
            return;
        }
        let serial = s.device.info().serial.clone();
        if self.state == State::Streaming || self.state == State::Starting {
            tracing::warn!("Kinect v2 {serial}: no frames for {silent:.1?}");
            self.set_state(State::Degraded(Degraded::Stalled));
        }
        if Instant::now() < self.next_scan {
            return;
        }
        self.next_scan = Instant::now() + self.config.rescan_every;
        let present = match self.driver.enumerate() {
            Ok(e) => e.serials.contains(&serial),
            Err(_) => true,
        };
        if !present {
            self.close_session();
            self.set_state(State::Degraded(Degraded::Absent(format!(
                "Kinect v2 {serial} unplugged (gone from the USB enumeration)"
            ))));
            // Rejoin as soon as it is back: the next scan opens it.
        } else if silent >= self.config.reopen_after {
            tracing::warn!("Kinect v2 {serial}: stalled for {silent:.1?}, reopening");
            self.close_session();
            self.next_scan = Instant::now();
        }
    }
}
