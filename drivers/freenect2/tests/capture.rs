//! The capture state machine against the fake device: unplug and rejoin, a long stall, a wait
//! that must not block a stop, the device clock's wrap, and a sensor that is not there.

use std::time::{Duration, Instant};

use trigait_freenect2::capture::{
    Capture, CaptureConfig, Captured, Degraded, Event, Selector, State,
};
use trigait_freenect2::fake::{FakeDriver, FakeKinect, Fault};
use trigait_freenect2::{Driver, Pipeline, Streams, TICK_NANOS};

const PIXELS: usize = 512 * 424;

/// A wall 2 m away, with a ramp so frames differ pixel to pixel.
fn frames() -> Vec<Vec<f32>> {
    (0..3)
        .map(|k| {
            (0..PIXELS)
                .map(|i| 2000.0 + (i % 512) as f32 + k as f32)
                .collect()
        })
        .collect()
}

fn quick(serial: &str) -> CaptureConfig {
    CaptureConfig {
        stall_after: Duration::from_millis(200),
        rescan_every: Duration::from_millis(150),
        ..CaptureConfig::new(Selector::Serial(serial.into()))
    }
}

/// Polls for `secs`, returning frames and state changes in order.
fn run(capture: &mut Capture, secs: f64) -> (Vec<Captured>, Vec<State>, Duration) {
    let end = Instant::now() + Duration::from_secs_f64(secs);
    let (mut frames, mut states) = (Vec::new(), Vec::new());
    let mut longest = Duration::ZERO;
    while Instant::now() < end {
        let t = Instant::now();
        let e = capture.poll(Duration::from_millis(100));
        longest = longest.max(t.elapsed());
        match e {
            Some(Event::Frame(f)) => frames.push(*f),
            Some(Event::State(s)) => states.push(s),
            None => {}
        }
    }
    (frames, states, longest)
}

/// Unplugged mid-run, the sensor is reported degraded (absent from the enumeration), then
/// rejoins when it is plugged back, in a new session whose sequence restarts; the frames missed
/// meanwhile are counted from the outage's length.
#[test]
fn unplug_then_rejoin() {
    let kinect = FakeKinect::new("K1", frames()).with(Fault::Unplug {
        at: Duration::from_millis(500),
        after: Some(Duration::from_millis(1000)),
    });
    let mut capture = Capture::new(quick("K1"), Box::new(FakeDriver::new(vec![kinect])));
    let (frames, states, longest) = run(&mut capture, 2.6);
    assert!(
        longest < Duration::from_millis(400),
        "a poll blocked {longest:?}"
    );
    let absent = states
        .iter()
        .position(
            |s| matches!(s, State::Degraded(Degraded::Absent(why)) if why.contains("unplugged")),
        )
        .unwrap_or_else(|| panic!("no unplugged state in {states:?}"));
    assert!(states[..absent].contains(&State::Streaming), "{states:?}");
    assert_eq!(states.last(), Some(&State::Streaming), "{states:?}");
    let sessions: Vec<u32> = frames.iter().map(|f| f.session).collect();
    assert_eq!(sessions.first(), Some(&1));
    assert_eq!(sessions.last(), Some(&2), "rejoined in a second session");
    let second = frames.iter().find(|f| f.session == 2).unwrap();
    assert!(
        second.depth.sequence < 10,
        "a replugged device restarts its sequence"
    );
    let c = capture.counters();
    assert_eq!((c.degraded, c.rejoins), (1, 1), "{c:?}");
    // Out for ≥ 1 s (plus detection and rescan): about 30–60 frames missed.
    assert!((25..=75).contains(&c.missed_while_away), "{c:?}");
    assert_eq!(c.lost_in_sequence, 0, "{c:?}");
    // The frames carry the played depth and its IR.
    let f = &frames[0];
    assert_eq!(f.depth.as_f32().len(), PIXELS);
    assert!((f.depth.as_f32()[5] - f.ir.as_ref().unwrap().as_f32()[5] * 10.0).abs() < 1e-3);
}

/// A 2 s stall never blocks a poll for long; the sensor goes degraded (stalled), comes back in
/// the same session, and the frames captured meanwhile are counted lost from the sequence gap.
#[test]
fn two_second_stall_counts_lost_frames() {
    let kinect = FakeKinect::new("K2", frames()).with(Fault::Stall {
        at: Duration::from_millis(400),
        length: Duration::from_secs(2),
    });
    let mut config = quick("K2");
    config.reopen_after = Duration::from_secs(10);
    let mut capture = Capture::new(config, Box::new(FakeDriver::new(vec![kinect])));
    let (frames, states, longest) = run(&mut capture, 3.2);
    assert!(
        longest < Duration::from_millis(400),
        "a poll blocked {longest:?}"
    );
    assert!(
        states.contains(&State::Degraded(Degraded::Stalled)),
        "{states:?}"
    );
    assert_eq!(states.last(), Some(&State::Streaming));
    let c = capture.counters();
    // 2 s / 33.25 ms = 60.2 frames captured but not delivered.
    assert!((59..=62).contains(&c.lost_in_sequence), "{c:?}");
    assert_eq!(c.rejoins, 1);
    assert!(frames.iter().all(|f| f.session == 1));
    let jump = frames.iter().find(|f| f.lost_before > 0).unwrap();
    assert_eq!(jump.lost_before, c.lost_in_sequence);
}

/// A device that stops delivering does not hold a poll past its wait: a stop request checked
/// between polls is seen within the poll's bound.
#[test]
fn blocked_wait_returns_for_a_stop() {
    let kinect = FakeKinect::new("K3", frames()).with(Fault::Stall {
        at: Duration::from_millis(100),
        length: Duration::from_secs(60),
    });
    let mut capture = Capture::new(quick("K3"), Box::new(FakeDriver::new(vec![kinect])));
    let _ = run(&mut capture, 0.5);
    let t = Instant::now();
    let _ = capture.poll(Duration::from_millis(100));
    assert!(
        t.elapsed() < Duration::from_millis(300),
        "{:?}",
        t.elapsed()
    );
    let t = Instant::now();
    capture.shutdown();
    assert!(t.elapsed() < Duration::from_millis(100));
    assert!(capture.device().is_none());
}

/// Device time wraps at 2³² ticks (149 h): the unwrapped device time and the host-clock stamps
/// keep increasing by one frame period across the wrap.
#[test]
fn timestamp_wrap() {
    let mut kinect = FakeKinect::new("K4", frames());
    kinect.timestamp0 = u32::MAX - 266 * 8;
    kinect.sequence0 = u32::MAX - 8;
    let mut capture = Capture::new(quick("K4"), Box::new(FakeDriver::new(vec![kinect])));
    let (frames, _, _) = run(&mut capture, 1.0);
    assert!(frames.len() > 20, "{}", frames.len());
    assert!(
        frames.iter().any(|f| f.depth.timestamp < 266 * 4),
        "crossed the wrap"
    );
    for pair in frames.windows(2) {
        assert_eq!(
            pair[1].device_nanos - pair[0].device_nanos,
            266 * TICK_NANOS
        );
        let step = pair[1].stamp_nanos - pair[0].stamp_nanos;
        assert!((step - 33_250_000).abs() < 10_000_000, "stamp step {step}");
    }
    let c = capture.counters();
    assert_eq!((c.timestamp_wraps, c.lost_in_sequence), (1, 0), "{c:?}");
}

/// A serial that is not on the bus is reported with what is; an index picks from the
/// enumeration; a pipeline the library lacks is a typed error; a second open is refused.
#[test]
fn absent_sensor_index_and_refusals() {
    let mut capture = Capture::new(
        quick("NOPE"),
        Box::new(FakeDriver::new(vec![FakeKinect::new("K5", frames())])),
    );
    let (frames, states, _) = run(&mut capture, 0.3);
    assert!(frames.is_empty());
    match &states[..] {
        [State::Degraded(Degraded::Absent(why))] => {
            assert!(why.contains("NOPE") && why.contains("K5"), "{why}");
        }
        other => panic!("{other:?}"),
    }
    let driver = FakeDriver::new(vec![FakeKinect::new("K6", frames_small())]);
    let mut capture = Capture::new(
        CaptureConfig::new(Selector::Index(0)),
        Box::new(driver.clone()),
    );
    let (frames, _, _) = run(&mut capture, 0.3);
    assert!(!frames.is_empty());
    assert_eq!(capture.device().unwrap().serial, "K6");
    let mut d = driver.clone();
    assert!(matches!(
        d.open("K6", Pipeline::Cpu, Streams::default()),
        Err(trigait_freenect2::Error::AlreadyOpen(_))
    ));
    assert!(matches!(
        d.open("K6", Pipeline::Cuda, Streams::default()),
        Err(trigait_freenect2::Error::PipelineUnavailable(_))
    ));
}

fn frames_small() -> Vec<Vec<f32>> {
    vec![vec![1500.0; PIXELS]]
}
