//! A sensor clock stepped by ±1 s while frames flow (someone set the sensor PC's clock, or an
//! NTP daemon stepped it): how many NTP exchanges the filter needs to map correctly again, and
//! how many frames it maps more than 1 ms wrong meanwhile.
//!
//! The sensor is simulated end to end as the graph runs it: offset, 50 ppm drift and 20 µs
//! reading jitter on its clock, a switched LAN with congestion spikes between it and the server
//! (`LinkDelay::lan`), one exchange every 100 ms (the `sync` node's default) and frames at 30 Hz
//! stamped by the sensor clock. Acceptance: resynchronised within 5 exchanges, at most 1 s
//! (30 frames) mapped more than 1 ms wrong.

#![allow(clippy::unwrap_used)]

use trigait_sim::clock::{LinkDelay, SimClock, SimSensorLink};
use trigait_sync::{ClockFilter, ClockFilterParams, SampleOutcome};

const NTP_INTERVAL_NANOS: i64 = 100_000_000;
const FRAME_NANOS: i64 = 33_333_333;
const STEP_AT_NANOS: i64 = 20_000_000_000;
const RUN_NANOS: i64 = 30_000_000_000;

/// What one run measured.
#[derive(Debug)]
struct Resync {
    /// Exchanges after the step up to and including the one after which every frame maps
    /// within 1 ms again.
    exchanges: usize,
    /// Frames after the step mapped more than 1 ms wrong (unmapped frames are not counted here).
    wrong_frames: usize,
    /// Frames after the step the filter did not map at all.
    unmapped_frames: usize,
    /// Frames before the step (after the first second) mapped more than 1 ms wrong.
    wrong_before: usize,
    steps: u64,
    /// The exchanges the filter itself reported for the step.
    reported_exchanges: Option<u64>,
}

fn run(step_nanos: i64, seed: u64) -> Resync {
    let clock = SimClock::new(-20_000_000, 50.0)
        .with_jitter_nanos(20_000.0)
        .with_step_at(STEP_AT_NANOS, step_nanos);
    let mut sensor = SimSensorLink::new(clock, LinkDelay::lan(), seed);
    let mut filter = ClockFilter::new(ClockFilterParams::default()).unwrap();
    let (mut next_ntp, mut next_frame) = (0, 5_000_000);
    let mut exchanges_after_step = 0;
    let mut last_wrong_exchange = 0;
    let (mut wrong_frames, mut unmapped_frames, mut wrong_before) = (0, 0, 0);
    let mut reported_exchanges = None;
    while next_ntp < RUN_NANOS || next_frame < RUN_NANOS {
        if next_ntp <= next_frame {
            let exchange = sensor.exchange(next_ntp);
            if let SampleOutcome::Step { exchanges, .. } = filter.push(exchange.sample) {
                reported_exchanges = Some(exchanges);
            }
            if next_ntp >= STEP_AT_NANOS {
                exchanges_after_step += 1;
            }
            next_ntp += NTP_INTERVAL_NANOS;
        } else {
            let stamp = sensor.capture_stamp(next_frame);
            match filter.server_from_local(stamp) {
                Some(mapped) if (mapped.server_nanos - next_frame).abs() > 1_000_000 => {
                    if next_frame >= STEP_AT_NANOS {
                        wrong_frames += 1;
                        last_wrong_exchange = exchanges_after_step;
                    } else if next_frame > 1_000_000_000 {
                        wrong_before += 1;
                    }
                }
                Some(_) => {}
                None if next_frame >= STEP_AT_NANOS => {
                    unmapped_frames += 1;
                    last_wrong_exchange = exchanges_after_step;
                }
                None => {}
            }
            next_frame += FRAME_NANOS;
        }
    }
    Resync {
        // The exchange after the last wrong frame is the one that resynchronised the filter.
        exchanges: last_wrong_exchange + 1,
        wrong_frames,
        unmapped_frames,
        wrong_before,
        steps: filter.steps(),
        reported_exchanges,
    }
}

/// +1 s and −1 s steps, five seeds each: resynchronised within 5 exchanges, ≤ 30 frames (1 s)
/// mapped more than 1 ms wrong, and exactly one step detected. The filter's own count of the
/// step's exchanges (from the first that disagreed) is at most the count from the true step.
#[test]
fn one_second_step_resyncs_within_five_exchanges() {
    for step in [1_000_000_000, -1_000_000_000] {
        for seed in 1..=5 {
            let r = run(step, seed);
            eprintln!("step {:+} ms, seed {seed}: {r:?}", step / 1_000_000);
            assert_eq!(r.wrong_before, 0, "{r:?}");
            assert_eq!(r.steps, 1, "{r:?}");
            assert!(r.exchanges <= 5, "{r:?}");
            assert!(r.wrong_frames <= 30, "{r:?}");
            assert!(r.unmapped_frames <= 30, "{r:?}");
            let reported = r.reported_exchanges.unwrap() as usize;
            assert!((3..=r.exchanges).contains(&reported), "{r:?}");
        }
    }
}
