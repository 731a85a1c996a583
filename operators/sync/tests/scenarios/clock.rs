//! Clock sync accuracy on simulated LAN links: the target figure (offset error < 1 ms for ≥ 99 % of
//! frames with offsets up to ±50 ms and drift up to 100 ppm), step recovery.

use trigait_sim::clock::{LinkDelay, SimClock, SimSensorLink};
use trigait_sync::{SampleOutcome, SyncBuffer, SyncParams};

const FRAME_PERIOD: i64 = 33_333_333;
const EXCHANGE_PERIOD: i64 = 500_000_000;

#[derive(Debug)]
enum Event {
    Ntp { sample: trigait_sync::NtpSample },
    Frame { true_capture: i64, local: i64 },
}

struct Sensor {
    id: String,
    link: SimSensorLink,
    /// (true time of the step, step) applied to the clock from then on.
    step: Option<(i64, i64)>,
}

#[derive(Debug, Default)]
struct Stats {
    /// Mapped server stamp minus true capture time, per frame after warm-up, nanoseconds.
    errors: Vec<f64>,
    /// The uncertainty reported with each of those frames.
    uncertainties: Vec<f64>,
    /// (sensor, true arrival time of the confirming sample, step) for each step reported.
    steps: Vec<(String, i64, i64)>,
    /// Frames dropped because their sensor was not synchronised yet.
    unsynchronised: u64,
}

impl Stats {
    fn fraction_below(&self, limit_nanos: f64) -> f64 {
        self.errors.iter().filter(|e| e.abs() < limit_nanos).count() as f64
            / self.errors.len() as f64
    }

    fn median_uncertainty(&self) -> f64 {
        let mut u = self.uncertainties.clone();
        u.sort_by(f64::total_cmp);
        u.get(u.len() / 2).copied().unwrap_or(f64::NAN)
    }

    fn covered(&self) -> f64 {
        self.errors
            .iter()
            .zip(&self.uncertainties)
            .filter(|(e, u)| e.abs() <= **u)
            .count() as f64
            / self.errors.len() as f64
    }
}

/// Runs `duration` of frames (30 Hz, own phase per sensor) and exchanges (every 0.5 s, staggered)
/// in arrival order through a `SyncBuffer`; frames captured after `warmup` are scored.
fn run(
    mut sensors: Vec<Sensor>,
    duration: i64,
    warmup: i64,
    score: impl Fn(&str, i64) -> bool,
) -> Stats {
    let ids: Vec<String> = sensors.iter().map(|s| s.id.clone()).collect();
    let mut buffer = SyncBuffer::new(ids, SyncParams::default()).unwrap();
    let mut events: Vec<(i64, usize, Event)> = Vec::new();
    for (i, s) in sensors.iter_mut().enumerate() {
        let base_clock = s.link.clock;
        let phase = 7_000_000 * i as i64 + 1_000_000;
        let stagger = 100_000_000 * i as i64;
        let (mut next_frame, mut next_ntp) = (phase, stagger);
        while next_frame < duration || next_ntp < duration {
            let t = next_frame.min(next_ntp);
            s.link.clock = match s.step {
                Some((at, step)) if t >= at => base_clock.stepped(step),
                _ => base_clock,
            };
            if next_ntp <= next_frame {
                let ex = s.link.exchange(next_ntp);
                events.push((ex.reply_true_nanos, i, Event::Ntp { sample: ex.sample }));
                next_ntp += EXCHANGE_PERIOD;
            } else {
                let local = s.link.capture_stamp(next_frame);
                let arrival = next_frame + s.link.frame_delay();
                events.push((
                    arrival,
                    i,
                    Event::Frame {
                        true_capture: next_frame,
                        local,
                    },
                ));
                next_frame += FRAME_PERIOD;
            }
        }
    }
    events.sort_by_key(|(t, i, _)| (*t, *i));

    let mut stats = Stats::default();
    for (arrival, i, event) in events {
        let id = &sensors[i].id;
        match event {
            Event::Ntp { sample } => {
                if let SampleOutcome::Step { step_nanos, .. } = buffer.push_ntp(id, sample).unwrap()
                {
                    stats.steps.push((id.clone(), arrival, step_nanos));
                }
            }
            Event::Frame {
                true_capture,
                local,
            } => match buffer.server_from_local(id, local) {
                Some(mapped) if true_capture >= warmup && score(id, true_capture) => {
                    stats
                        .errors
                        .push((mapped.server_nanos - true_capture) as f64);
                    stats.uncertainties.push(mapped.uncertainty_nanos as f64);
                }
                Some(_) => {}
                None => stats.unsynchronised += 1,
            },
        }
    }
    stats
}

fn sensors(clocks: &[(i64, f64)], link: LinkDelay, seed: u64) -> Vec<Sensor> {
    clocks
        .iter()
        .enumerate()
        .map(|(i, &(offset, drift))| Sensor {
            id: format!("kinect-{i}"),
            link: SimSensorLink::new(
                SimClock::new(offset, drift).with_jitter_nanos(20_000.0),
                link,
                seed * 100 + i as u64,
            ),
            step: None,
        })
        .collect()
}

/// Acceptance, measured: five sensors at ±50 ms offsets and up to ±100 ppm drift on the
/// thesis LAN model (asymmetric base delay, gamma tail, 2 % congestion spikes of ~3 ms); over 60 s
/// at 30 Hz with an exchange every 0.5 s and 2 s warm-up, ≥ 99 % of frames are mapped within
/// 1 ms (measured: 100 %, p99 ≈ 0.1 ms, max 0.25 ms), and the reported uncertainty (median
/// ±0.18 ms) covers the error for
/// ≥ 99 % of frames.
#[test]
fn lan_offsets_and_drift_are_tracked_within_1_ms() {
    let clocks = [
        (-50_000_000, -100.0),
        (-20_000_000, 40.0),
        (0, 0.0),
        (35_000_000, -60.0),
        (50_000_000, 100.0),
    ];
    for seed in 1..=3 {
        let stats = run(
            sensors(&clocks, LinkDelay::lan(), seed),
            60_000_000_000,
            2_000_000_000,
            |_, _| true,
        );
        let below = stats.fraction_below(1e6);
        let max = stats.errors.iter().fold(0.0_f64, |m, e| m.max(e.abs()));
        eprintln!(
            "seed {seed}: {} frames, {:.3} % < 1 ms, p99 {:.1} µs, max {:.1} µs, uncertainty covers {:.2} % (median ±{:.1} µs)",
            stats.errors.len(),
            100.0 * below,
            super::p99(&stats.errors) / 1e3,
            max / 1e3,
            100.0 * stats.covered(),
            stats.median_uncertainty() / 1e3
        );
        // Honest but not uselessly wide.
        assert!(stats.median_uncertainty() < 500_000.0);
        assert!(
            (5 * 1735..=5 * 1745).contains(&stats.errors.len()),
            "{}",
            stats.errors.len()
        );
        assert!(below >= 0.99, "{below}");
        assert!(super::p99(&stats.errors) < 200_000.0);
        assert!(stats.covered() >= 0.99, "{}", stats.covered());
        assert!(stats.steps.is_empty(), "{:?}", stats.steps);
    }
}

/// The same on a congested link: 600 µs asymmetry between directions and 10 % of messages
/// delayed by ~5 ms. The asymmetry is invisible to any NTP exchange (it biases every offset by
/// (d_up − d_down)/2 = −250 µs), so this checks the filter does not add to it.
#[test]
fn congested_link_stays_within_1_ms() {
    let link = LinkDelay {
        base_up_nanos: 100_000,
        base_down_nanos: 600_000,
        tail_mean_nanos: 200_000.0,
        tail_shape: 1.5,
        spike_probability: 0.1,
        spike_mean_nanos: 5_000_000.0,
    };
    let clocks = [
        (-50_000_000, 100.0),
        (50_000_000, -100.0),
        (1_000_000, 30.0),
    ];
    let stats = run(
        sensors(&clocks, link, 9),
        60_000_000_000,
        2_000_000_000,
        |_, _| true,
    );
    let below = stats.fraction_below(1e6);
    eprintln!(
        "congested: {:.3} % < 1 ms, p99 {:.1} µs, uncertainty covers {:.2} % (median ±{:.1} µs)",
        100.0 * below,
        super::p99(&stats.errors) / 1e3,
        100.0 * stats.covered(),
        stats.median_uncertainty() / 1e3
    );
    assert!(below >= 0.99, "{below}");
    assert!(stats.covered() >= 0.99, "{}", stats.covered());
}

/// A sensor cannot be placed on the server clock until its filter holds `min_used` (4)
/// exchanges; from then on it can.
#[test]
fn frames_before_the_fourth_exchange_are_unsynchronised() {
    let stats = run(
        sensors(&[(10_000_000, 0.0)], LinkDelay::lan(), 4),
        3_000_000_000,
        0,
        |_, _| true,
    );
    // Exchanges go out at 0, 0.5, 1 and 1.5 s and return within ~1 ms; frames come at 1 ms +
    // k·33.3 ms, so the 45 before 1.5 s are unsynchronised, one more if the link was slow.
    let before = (3 * EXCHANGE_PERIOD / FRAME_PERIOD) as u64;
    assert!(
        (before..=before + 1).contains(&stats.unsynchronised),
        "{}",
        stats.unsynchronised
    );
    assert!(!stats.errors.is_empty());
}

/// A sensor clock set 20 ms forward (then another set 15 ms back) mid-run: the step is reported
/// within three exchanges with the right size, and frames are back within 1 ms right after.
#[test]
fn clock_steps_are_detected_and_recovered() {
    let mut s = sensors(
        &[(5_000_000, 50.0), (-30_000_000, -80.0)],
        LinkDelay::lan(),
        5,
    );
    let step_at = 30_000_000_000;
    s[0].step = Some((step_at, 20_000_000));
    s[1].step = Some((step_at + 250_000_000, -15_000_000));
    let recovered_by = step_at + 2_000_000_000;
    let stats = run(s, 60_000_000_000, 2_000_000_000, |_, t| {
        t < step_at || t >= recovered_by
    });
    assert_eq!(stats.steps.len(), 2, "{:?}", stats.steps);
    for (id, at, step) in &stats.steps {
        let (expected, since) = if id == "kinect-0" {
            (20e6, step_at)
        } else {
            (-15e6, step_at + 250_000_000)
        };
        assert!((*step as f64 - expected).abs() < 0.5e6, "{id}: {step}");
        assert!(
            *at - since < 3 * EXCHANGE_PERIOD,
            "{id}: detected {} ms late",
            (*at - since) / 1_000_000
        );
    }
    let below = stats.fraction_below(1e6);
    eprintln!(
        "steps {:?}; after recovery {:.3} % < 1 ms",
        stats.steps,
        100.0 * below
    );
    assert!(below >= 0.99, "{below}");
}
