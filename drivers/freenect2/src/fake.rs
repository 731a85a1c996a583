//! A fake Kinect bus in plain Rust, behind the same [`Driver`]/[`Device`] traits as the real
//! one: it plays given depth frames (simulated or recorded, mm) at the device's frame rate in
//! real time, with device timestamps (+266 ticks per frame) and sequence numbers, and injects
//! what real Kinects do: stalls (frames captured but not delivered, so the sequence jumps),
//! dropped frames, unplugs (frames just stop and the device leaves the enumeration, as
//! libfreenect2 has no unplug event) with a later replug (a rebooted device: sequence and
//! timestamps restart), timestamps close to the `u32` wrap, and a close that hangs.

use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant};

use crate::{
    Device, DeviceInfo, Driver, Enumeration, Error, Frame, FrameKind, IrParams, Pipeline, Result,
    Streams, TICKS_PER_FRAME,
};

/// Something that happens to a fake device, at a time after the bus was created.
#[derive(Debug, Clone, PartialEq)]
pub enum Fault {
    /// Frames captured in `[at, at + length)` are not delivered.
    Stall {
        /// Start.
        at: Duration,
        /// Length.
        length: Duration,
    },
    /// The device is unplugged at `at` and plugged back `after` later (`None`: never).
    Unplug {
        /// When.
        at: Duration,
        /// Replug delay.
        after: Option<Duration>,
    },
}

/// One fake Kinect.
#[derive(Debug, Clone)]
pub struct FakeKinect {
    /// Serial.
    pub serial: String,
    /// Firmware string.
    pub firmware: String,
    /// Frame period (Kinect v2: 33.25 ms, 266 ticks).
    pub period: Duration,
    /// Device timestamp of the first frame (set near `u32::MAX` to test the wrap).
    pub timestamp0: u32,
    /// Sequence number of the first frame.
    pub sequence0: u32,
    /// Depth frames, 512×424 mm, played in a loop.
    pub depth_mm: Vec<Vec<f32>>,
    /// What happens to it.
    pub faults: Vec<Fault>,
    /// How long `close` blocks (a libfreenect2 shutdown deadlock).
    pub close_hangs: Duration,
    /// Refuse opening (no USB permission): seen, but not enumerable.
    pub access_denied: bool,
}

impl FakeKinect {
    /// A device playing `depth_mm` at 30 Hz from timestamp 0, with no faults.
    #[must_use]
    pub fn new(serial: &str, depth_mm: Vec<Vec<f32>>) -> Self {
        Self {
            serial: serial.into(),
            firmware: "2.3.3913.0.7 (fake)".into(),
            period: Duration::from_micros(33_250),
            timestamp0: 0,
            sequence0: 0,
            depth_mm,
            faults: Vec::new(),
            close_hangs: Duration::ZERO,
            access_denied: false,
        }
    }

    /// With a fault.
    #[must_use]
    pub fn with(mut self, fault: Fault) -> Self {
        self.faults.push(fault);
        self
    }

    /// The plug-in intervals `[start, end)` after the bus's start.
    fn sessions(&self) -> Vec<(Duration, Option<Duration>)> {
        let mut unplugs: Vec<(Duration, Option<Duration>)> = self
            .faults
            .iter()
            .filter_map(|f| match f {
                Fault::Unplug { at, after } => Some((*at, *after)),
                Fault::Stall { .. } => None,
            })
            .collect();
        unplugs.sort_by_key(|u| u.0);
        let mut sessions = Vec::new();
        let mut start = Some(Duration::ZERO);
        for (at, after) in unplugs {
            let Some(s) = start else { break };
            if at >= s {
                sessions.push((s, Some(at)));
                start = after.map(|a| at + a);
            }
        }
        if let Some(s) = start {
            sessions.push((s, None));
        }
        sessions
    }

    fn session_at(&self, t: Duration) -> Option<usize> {
        self.sessions()
            .iter()
            .position(|(s, e)| t >= *s && e.is_none_or(|e| t < e))
    }

    fn stalled(&self, t: Duration) -> bool {
        self.faults.iter().any(|f| match f {
            Fault::Stall { at, length } => t >= *at && t < *at + *length,
            Fault::Unplug { .. } => false,
        })
    }
}

#[derive(Debug)]
struct Bus {
    start: Instant,
    devices: Vec<FakeKinect>,
    open: Vec<String>,
    opens: u64,
}

/// The fake bus: a [`Driver`] over [`FakeKinect`]s.
#[derive(Debug, Clone)]
pub struct FakeDriver {
    bus: Arc<Mutex<Bus>>,
}

impl FakeDriver {
    /// A bus whose clock starts now.
    #[must_use]
    pub fn new(devices: Vec<FakeKinect>) -> Self {
        Self {
            bus: Arc::new(Mutex::new(Bus {
                start: Instant::now(),
                devices,
                open: Vec::new(),
                opens: 0,
            })),
        }
    }

    /// Successful opens so far.
    #[must_use]
    pub fn opens(&self) -> u64 {
        self.bus
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .opens
    }

    /// Time since the bus started.
    #[must_use]
    pub fn elapsed(&self) -> Duration {
        self.bus
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .start
            .elapsed()
    }
}

impl Driver for FakeDriver {
    fn enumerate(&mut self) -> Result<Enumeration> {
        let bus = self.bus.lock().unwrap_or_else(PoisonError::into_inner);
        let t = bus.start.elapsed();
        let mut e = Enumeration::default();
        for d in &bus.devices {
            if d.session_at(t).is_some() {
                if d.access_denied {
                    e.usb_access_denied = true;
                } else {
                    e.serials.push(d.serial.clone());
                }
            }
        }
        Ok(e)
    }

    fn open(
        &mut self,
        serial: &str,
        pipeline: Pipeline,
        streams: Streams,
    ) -> Result<Box<dyn Device>> {
        if pipeline != Pipeline::Cpu {
            return Err(Error::PipelineUnavailable(pipeline.name().into()));
        }
        let mut bus = self.bus.lock().unwrap_or_else(PoisonError::into_inner);
        let t = bus.start.elapsed();
        let start = bus.start;
        let available = |bus: &Bus| {
            let s: Vec<&str> = bus
                .devices
                .iter()
                .filter(|d| d.session_at(t).is_some() && !d.access_denied)
                .map(|d| d.serial.as_str())
                .collect();
            if s.is_empty() {
                "none".to_owned()
            } else {
                s.join(", ")
            }
        };
        let Some(kinect) = bus
            .devices
            .iter()
            .find(|d| d.serial == serial && d.session_at(t).is_some())
            .cloned()
        else {
            return Err(Error::NoSuchSerial {
                serial: serial.into(),
                available: available(&bus),
            });
        };
        if kinect.access_denied {
            return Err(Error::UsbAccessDenied);
        }
        if bus.open.iter().any(|s| s == serial) {
            return Err(Error::AlreadyOpen(serial.into()));
        }
        bus.open.push(serial.into());
        bus.opens += 1;
        let session = kinect.session_at(t).unwrap_or(0);
        let (session_start, session_end) = kinect.sessions()[session];
        // The first frame after opening: the device has been counting since it was plugged.
        let period = kinect.period.max(Duration::from_micros(100));
        let k0 = ((t.saturating_sub(session_start)).as_nanos() / period.as_nanos()) as u64 + 1;
        Ok(Box::new(FakeDevice {
            bus: Arc::clone(&self.bus),
            info: DeviceInfo {
                serial: serial.into(),
                firmware: kinect.firmware.clone(),
                pipeline,
            },
            start,
            session_start,
            session_end,
            // A replugged device rebooted: its clock and sequence restart.
            timestamp0: if session == 0 { kinect.timestamp0 } else { 0 },
            sequence0: if session == 0 { kinect.sequence0 } else { 0 },
            period,
            next: k0,
            pending_depth: None,
            streams,
            kinect,
        }))
    }

    fn pipelines(&self) -> Vec<Pipeline> {
        vec![Pipeline::Cpu]
    }
}

struct FakeDevice {
    bus: Arc<Mutex<Bus>>,
    info: DeviceInfo,
    kinect: FakeKinect,
    start: Instant,
    session_start: Duration,
    session_end: Option<Duration>,
    timestamp0: u32,
    sequence0: u32,
    period: Duration,
    next: u64,
    pending_depth: Option<Frame>,
    streams: Streams,
}

fn host_now() -> i64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| i64::try_from(d.as_nanos()).unwrap_or(i64::MAX))
}

impl FakeDevice {
    fn frame_time(&self, k: u64) -> Duration {
        self.session_start + self.period * u32::try_from(k).unwrap_or(u32::MAX)
    }

    fn frames(&self, k: u64) -> Result<(Frame, Option<Frame>)> {
        let n = self.kinect.depth_mm.len().max(1);
        let depth = self
            .kinect
            .depth_mm
            .get((k as usize) % n)
            .cloned()
            .unwrap_or_else(|| vec![0.0; 512 * 424]);
        let ts = self
            .timestamp0
            .wrapping_add((k as u32).wrapping_mul(TICKS_PER_FRAME));
        let seq = self.sequence0.wrapping_add(k as u32);
        let host = host_now();
        let ir = self
            .streams
            .ir
            .then(|| {
                let ir: Vec<f32> = depth.iter().map(|d| d / 10.0).collect();
                Frame::owned(FrameKind::Ir, 512, 424, ts, seq, host, ir)
            })
            .transpose()?;
        Ok((
            Frame::owned(FrameKind::Depth, 512, 424, ts, seq, host, depth)?,
            ir,
        ))
    }
}

impl Device for FakeDevice {
    fn info(&self) -> &DeviceInfo {
        &self.info
    }

    fn ir_params(&self) -> IrParams {
        IrParams {
            fx: 365.456,
            fy: 365.456,
            cx: 254.878,
            cy: 205.395,
            k1: 0.090_547_4,
            k2: -0.268_19,
            k3: 0.095_086_2,
            p1: 0.0,
            p2: 0.0,
        }
    }

    fn wait(&mut self, timeout: Duration) -> Result<Option<Frame>> {
        if let Some(d) = self.pending_depth.take() {
            return Ok(Some(d));
        }
        let deadline = self.start.elapsed() + timeout;
        loop {
            let t = self.frame_time(self.next);
            let gone = self.session_end.is_some_and(|end| t >= end);
            if gone || t > deadline {
                std::thread::sleep(deadline.saturating_sub(self.start.elapsed()));
                return Ok(None);
            }
            if self.kinect.stalled(t) {
                self.next += 1;
                continue;
            }
            std::thread::sleep(t.saturating_sub(self.start.elapsed()));
            let (depth, ir) = self.frames(self.next)?;
            self.next += 1;
            return Ok(Some(match ir {
                Some(ir) => {
                    // libfreenect2 delivers IR first, then depth of the same packet.
                    self.pending_depth = Some(depth);
                    ir
                }
                None => depth,
            }));
        }
    }

    fn dropped(&self) -> u64 {
        0
    }

    fn close(self: Box<Self>) -> Result<()> {
        let hang = self.kinect.close_hangs;
        let mut bus = self.bus.lock().unwrap_or_else(PoisonError::into_inner);
        bus.open.retain(|s| *s != self.info.serial);
        drop(bus);
        if hang > Duration::ZERO {
            std::thread::sleep(hang);
        }
        Ok(())
    }
}

impl Drop for FakeDevice {
    fn drop(&mut self) {
        let mut bus = self.bus.lock().unwrap_or_else(PoisonError::into_inner);
        bus.open.retain(|s| *s != self.info.serial);
    }
}
