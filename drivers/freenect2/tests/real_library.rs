//! The safe driver over the real libfreenect2 on a machine with no Kinect (CI machines, a
//! developer's laptop): contexts come and go without hanging, the enumeration is empty, and
//! opening a serial or an index fails at once with an error that names what is connected,
//! before libfreenect2 builds a pipeline; the capture state machine reports the sensor absent
//! and shuts down promptly. Needs the real library (`--features freenect2`). With a Kinect
//! plugged in, the no-device checks are skipped (and say so).
#![cfg(feature = "freenect2")]
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::time::{Duration, Instant};

use trigait_freenect2::capture::{Capture, CaptureConfig, Degraded, Event, Selector, State};
use trigait_freenect2::{Driver, Error, Freenect2, Pipeline, Streams};

/// Generous for a loaded 2-core machine; a libfreenect2 deadlock would last forever.
const BOUND: Duration = Duration::from_secs(3);

fn no_kinect(driver: &mut Freenect2) -> bool {
    let e = driver.enumerate().unwrap();
    if e.serials.is_empty() {
        assert!(!e.usb_access_denied, "{e:?}");
        true
    } else {
        eprintln!("skipping: Kinect v2 connected ({:?})", e.serials);
        false
    }
}

/// Creating, enumerating and destroying contexts quickly neither hangs nor crashes.
#[test]
fn contexts_come_and_go() {
    for _ in 0..10 {
        let t = Instant::now();
        let mut driver = Freenect2::new().unwrap();
        let e = driver.enumerate().unwrap();
        drop(driver);
        assert!(t.elapsed() < BOUND, "{:?} for {e:?}", t.elapsed());
    }
}

/// Opening a serial that is not on the bus is a typed error naming what is (nothing), at once;
/// a pipeline not compiled in is refused as such.
#[test]
fn opening_an_absent_serial_fails_clearly() {
    let mut driver = Freenect2::new().unwrap();
    assert!(driver.pipelines().contains(&Pipeline::Cpu));
    if !no_kinect(&mut driver) {
        return;
    }
    let t = Instant::now();
    let err = driver
        .open("000000000000", Pipeline::Cpu, Streams::default())
        .unwrap_err();
    assert!(t.elapsed() < BOUND, "{:?}", t.elapsed());
    assert_eq!(
        err,
        Error::NoSuchSerial {
            serial: "000000000000".into(),
            available: "none".into()
        }
    );
    assert!(err.to_string().contains("connected: none"), "{err}");
    // A pipeline this build of libfreenect2 lacks is refused before anything is opened.
    for pipeline in Pipeline::ALL {
        if !driver.pipelines().contains(&pipeline) {
            let err = driver
                .open("000000000000", pipeline, Streams::default())
                .unwrap_err();
            assert_eq!(err, Error::PipelineUnavailable(pipeline.name().into()));
        }
    }
}

/// The capture state machine over the real driver: absent at once (by serial and by index),
/// re-enumerating while it waits, and a prompt shutdown.
#[test]
fn capture_reports_the_sensor_absent_and_stops() {
    let mut probe = Freenect2::new().unwrap();
    if !no_kinect(&mut probe) {
        return;
    }
    drop(probe);
    for sensor in [Selector::Serial("000000000000".into()), Selector::Index(0)] {
        let mut config = CaptureConfig::new(sensor.clone());
        config.rescan_every = Duration::from_millis(100);
        let mut capture = Capture::new(config, Box::new(Freenect2::new().unwrap()));
        let t = Instant::now();
        let mut states = Vec::new();
        while t.elapsed() < Duration::from_millis(500) {
            match capture.poll(Duration::from_millis(50)) {
                Some(Event::State(s)) => states.push(s),
                Some(Event::Frame(_)) => panic!("a frame without a Kinect"),
                None => {}
            }
        }
        match &states[..] {
            [State::Degraded(Degraded::Absent(why))] => {
                assert!(why.contains("none"), "{sensor:?}: {why}");
            }
            other => panic!("{sensor:?}: {other:?}"),
        }
        let t = Instant::now();
        capture.shutdown();
        assert!(t.elapsed() < BOUND, "{:?}", t.elapsed());
        assert_eq!(capture.counters().frames, 0);
    }
}
