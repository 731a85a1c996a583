//! The shim over the fake libfreenect2, through the safe driver: enumeration, the serial check
//! before a pipeline is built, the refused second open, frames with device time, sequence and
//! host arrival time, a timed wait that really times out, the close watchdog, the USB
//! permission diagnosis, log routing, and the capture state machine on top.
// Tests: a failed set-up is a failed test.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::io::Write;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use trigait_freenect2::capture::{Capture, CaptureConfig, Degraded, Event, Selector, State};
use trigait_freenect2::{
    Driver, Error, FrameKind, Freenect2, Pipeline, Streams, TICK_NANOS, fake_bus,
};

const PIXELS: usize = 512 * 424;

/// The fake bus is process-wide: one test at a time.
fn bus() -> Option<MutexGuard<'static, ()>> {
    static LOCK: Mutex<()> = Mutex::new(());
    if !fake_bus::available() {
        eprintln!("skipping: the real libfreenect2 is linked, not the fake");
        return None;
    }
    let guard = LOCK
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    fake_bus::reset();
    Some(guard)
}

fn now_nanos() -> i64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_nanos() as i64
}

fn ramp() -> Vec<f32> {
    (0..PIXELS).map(|i| 1000.0 + (i % 1000) as f32).collect()
}

/// Enumeration, firmware, pipelines; an unknown serial is refused before any pipeline is built;
/// a second open of one serial is refused (libfreenect2 would hand out the same pointer).
#[test]
fn open_checks_serial_and_refuses_a_second_open() {
    let Some(_bus) = bus() else { return };
    fake_bus::plug("A1", "fw-1", 33_250, 0, 0, &ramp());
    fake_bus::plug("A2", "fw-2", 33_250, 0, 0, &ramp());
    let mut f2 = Freenect2::new().unwrap();
    assert_eq!(f2.pipelines(), vec![Pipeline::Cpu]);
    assert_eq!(f2.enumerate().unwrap().serials, vec!["A1", "A2"]);
    let err = f2
        .open("B9", Pipeline::Cpu, Streams::default())
        .unwrap_err();
    match &err {
        Error::NoSuchSerial { serial, available } => {
            assert_eq!((serial.as_str(), available.as_str()), ("B9", "A1, A2"));
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(
        fake_bus::pipelines_built(),
        0,
        "no pipeline for an unknown serial"
    );
    assert!(matches!(
        f2.open("A1", Pipeline::OpenCl, Streams::default()),
        Err(Error::PipelineUnavailable(_))
    ));
    let dev = f2.open("A2", Pipeline::Cpu, Streams::default()).unwrap();
    assert_eq!(dev.info().firmware, "fw-2");
    assert!(dev.ir_params().fx > 300.0, "IR parameters read after start");
    assert!(matches!(
        f2.open("A2", Pipeline::Cpu, Streams::default()),
        Err(Error::AlreadyOpen(_))
    ));
    assert_eq!(fake_bus::pipelines_built(), 1);
    dev.close().unwrap();
    // Closed: it can be opened again.
    let dev = f2.open("A2", Pipeline::Cpu, Streams::default()).unwrap();
    dev.close().unwrap();
}

/// Frames arrive IR then depth with the same sequence, device time +266 ticks per frame, the
/// played pixels, and a host arrival time taken when the frame reached the listener.
#[test]
fn frames_carry_device_time_sequence_and_host_time() {
    let Some(_bus) = bus() else { return };
    let depth = ramp();
    fake_bus::plug("C1", "fw", 20_000, 1_000, 7, &depth);
    let mut f2 = Freenect2::new().unwrap();
    let mut dev = f2.open("C1", Pipeline::Cpu, Streams::default()).unwrap();
    let mut got = Vec::new();
    let before = now_nanos();
    while got.len() < 6 {
        let f = dev
            .wait(Duration::from_secs(1))
            .unwrap()
            .expect("a frame within 1 s");
        assert!(f.host_nanos >= before && f.host_nanos <= now_nanos());
        got.push(f);
    }
    for pair in got.chunks(2) {
        assert_eq!(
            (pair[0].kind, pair[1].kind),
            (FrameKind::Ir, FrameKind::Depth)
        );
        assert_eq!(pair[0].sequence, pair[1].sequence);
        assert_eq!(pair[1].as_f32(), &depth[..]);
        assert!((pair[0].as_f32()[3] - depth[3] / 10.0).abs() < 1e-3);
    }
    assert_eq!(got[0].timestamp, 1_000);
    assert_eq!(got[0].sequence, 7);
    assert_eq!(got[2].timestamp - got[0].timestamp, 266);
    assert_eq!(got[2].sequence - got[0].sequence, 1);
    assert_eq!(got[3].to_u16()[0], 1000);
    assert_eq!(got[2].to_u16()[0], 100);
    // Frames outlive their device: they own their pixels.
    dev.close().unwrap();
    assert_eq!(got[5].as_f32().len(), PIXELS);
}

/// The wait's timeout is real (libfreenect2's own ignores it without C++11): a stalled or
/// unplugged device returns "no frame" after the timeout, not never.
#[test]
fn wait_times_out_on_a_stall_and_an_unplug() {
    let Some(_bus) = bus() else { return };
    fake_bus::plug("D1", "fw", 33_250, 0, 0, &ramp());
    let mut f2 = Freenect2::new().unwrap();
    let mut dev = f2.open("D1", Pipeline::Cpu, Streams::default()).unwrap();
    assert!(dev.wait(Duration::from_secs(1)).unwrap().is_some());
    fake_bus::stall("D1", 600);
    std::thread::sleep(Duration::from_millis(50));
    while dev.wait(Duration::ZERO).unwrap().is_some() {}
    let t = Instant::now();
    assert!(dev.wait(Duration::from_millis(200)).unwrap().is_none());
    let waited = t.elapsed();
    assert!(
        waited >= Duration::from_millis(190) && waited < Duration::from_millis(400),
        "{waited:?}"
    );
    // After the stall the sequence has jumped by the frames captured meanwhile.
    let a = loop {
        if let Some(f) = dev.wait(Duration::from_secs(2)).unwrap() {
            break f;
        }
    };
    assert!(
        a.sequence >= 15,
        "sequence {} after a 600 ms stall",
        a.sequence
    );
    fake_bus::unplug("D1");
    std::thread::sleep(Duration::from_millis(50));
    while dev.wait(Duration::ZERO).unwrap().is_some() {}
    let t = Instant::now();
    assert!(dev.wait(Duration::from_millis(150)).unwrap().is_none());
    assert!(t.elapsed() < Duration::from_millis(400));
    assert!(f2.enumerate().unwrap().serials.is_empty());
    dev.close().unwrap();
}

/// A close that deadlocks returns a watchdog error after the timeout instead of hanging; the
/// poisoned context is replaced, so the driver keeps working.
#[test]
fn close_watchdog() {
    let Some(_bus) = bus() else { return };
    fake_bus::plug("E1", "fw", 33_250, 0, 0, &ramp());
    fake_bus::hang_close("E1", 60_000);
    let mut f2 = Freenect2::new().unwrap();
    let dev = f2.open("E1", Pipeline::Cpu, Streams::default()).unwrap();
    let t = Instant::now();
    let err = dev.close().unwrap_err();
    assert!(matches!(err, Error::Watchdog { .. }), "{err:?}");
    assert!(t.elapsed() < Duration::from_secs(3), "{:?}", t.elapsed());
    fake_bus::plug("E2", "fw", 33_250, 0, 0, &ramp());
    // The first call on the poisoned context reports it and renews the context.
    assert!(matches!(f2.enumerate(), Err(Error::Watchdog { .. })));
    assert!(f2.enumerate().unwrap().serials.contains(&"E2".to_owned()));
    let dev = f2.open("E2", Pipeline::Cpu, Streams::default()).unwrap();
    dev.close().unwrap();
}

/// A Kinect without USB permission is diagnosed (the udev rule), not reported as absent.
#[test]
fn usb_permission_is_diagnosed() {
    let Some(_bus) = bus() else { return };
    fake_bus::plug("F1", "fw", 33_250, 0, 0, &ramp());
    fake_bus::deny_access("F1", true);
    let mut f2 = Freenect2::new().unwrap();
    let e = f2.enumerate().unwrap();
    assert!(e.serials.is_empty() && e.usb_access_denied);
    let err = f2
        .open("F1", Pipeline::Cpu, Streams::default())
        .unwrap_err();
    assert_eq!(err, Error::UsbAccessDenied);
    assert!(err.to_string().contains("udev"));
}

#[derive(Clone, Default)]
struct Sink(Arc<Mutex<Vec<u8>>>);

impl Write for Sink {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0.lock().unwrap().extend_from_slice(buf);
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// libfreenect2's log lines arrive in `tracing` (target `libfreenect2`) at their level.
#[test]
fn log_is_routed_to_tracing() {
    let Some(_bus) = bus() else { return };
    let sink = Sink::default();
    let writer = sink.clone();
    let subscriber = tracing_subscriber::fmt()
        .with_max_level(tracing::Level::DEBUG)
        .with_ansi(false)
        .with_writer(move || writer.clone())
        .finish();
    tracing::subscriber::with_default(subscriber, || {
        let _f2 = Freenect2::new().unwrap();
        fake_bus::log(2, "packets lost: 3");
    });
    let text = String::from_utf8(sink.0.lock().unwrap().clone()).unwrap();
    assert!(
        text.contains("WARN") && text.contains("libfreenect2") && text.contains("packets lost: 3"),
        "{text}"
    );
}

/// The capture state machine over the shim: unplugged → degraded, plugged back → rejoined in a
/// new session; device time is unwrapped across the u32 wrap.
#[test]
fn capture_over_the_shim_rejoins_after_an_unplug() {
    let Some(_bus) = bus() else { return };
    fake_bus::plug("G1", "fw", 33_250, u32::MAX - 266 * 3, 0, &ramp());
    let config = CaptureConfig {
        stall_after: Duration::from_millis(200),
        rescan_every: Duration::from_millis(150),
        ..CaptureConfig::new(Selector::Serial("G1".into()))
    };
    let mut capture = Capture::new(config, Box::new(Freenect2::new().unwrap()));
    let start = Instant::now();
    let (mut frames, mut states) = (Vec::new(), Vec::new());
    let mut unplugged = false;
    let mut replugged = false;
    while start.elapsed() < Duration::from_millis(2500) {
        if !unplugged && start.elapsed() > Duration::from_millis(500) {
            fake_bus::unplug("G1");
            unplugged = true;
        }
        if !replugged && start.elapsed() > Duration::from_millis(1300) {
            fake_bus::plug("G1", "fw", 33_250, 0, 0, &ramp());
            replugged = true;
        }
        let t = Instant::now();
        match capture.poll(Duration::from_millis(100)) {
            Some(Event::Frame(f)) => frames.push(*f),
            Some(Event::State(s)) => states.push(s),
            None => {}
        }
        assert!(
            t.elapsed() < Duration::from_millis(600),
            "poll blocked {:?}",
            t.elapsed()
        );
    }
    capture.shutdown();
    assert!(
        states
            .iter()
            .any(|s| matches!(s, State::Degraded(Degraded::Absent(_)))),
        "{states:?}"
    );
    assert_eq!(states.last(), Some(&State::Streaming), "{states:?}");
    let first: Vec<_> = frames.iter().filter(|f| f.session == 1).collect();
    assert!(first.len() > 8);
    for pair in first.windows(2) {
        assert_eq!(
            pair[1].device_nanos - pair[0].device_nanos,
            266 * TICK_NANOS
        );
    }
    assert_eq!(capture.counters().timestamp_wraps, 1);
    assert!(frames.iter().any(|f| f.session == 2));
    assert!(frames.iter().all(|f| f.ir.is_some()));
}
