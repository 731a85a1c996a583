//! Simulated sensor clocks and network links, so the sync code meets offsets, drift, jitter and
//! queueing delays as on a LAN (DESIGN.md, Time) — in tests and in the simulator's sensors.
//!
//! "True" time is the simulation's time line; the server (`sync` node) clock is taken as true
//! time, since only the difference between clocks matters. Everything is deterministic given the
//! seed of the [`ChaCha8Rng`] the caller passes or [`SimSensorLink`] owns.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Exp, Gamma, Normal};

use trigait_sync::NtpSample;

/// A sensor clock: `local = true + offset + drift·true + jitter`, plus a step scheduled with
/// [`SimClock::with_step_at`] (someone, or an NTP daemon, setting the clock while it runs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SimClock {
    /// Sensor clock minus true time at true time 0, nanoseconds.
    pub offset_nanos: i64,
    /// Rate error, ppm (positive: the sensor clock runs fast).
    pub drift_ppm: f64,
    /// Standard deviation of the noise on every reading of the clock (timer resolution,
    /// scheduling), nanoseconds.
    pub jitter_nanos: f64,
    /// True time from which [`Self::step_nanos`] is added (`i64::MAX`: never).
    pub step_at_true_nanos: i64,
    /// The scheduled step, nanoseconds (positive: the clock is set forward).
    pub step_nanos: i64,
}

impl SimClock {
    /// A clock with `offset_nanos` and `drift_ppm` and no jitter.
    #[must_use]
    pub fn new(offset_nanos: i64, drift_ppm: f64) -> Self {
        SimClock {
            offset_nanos,
            drift_ppm,
            jitter_nanos: 0.0,
            step_at_true_nanos: i64::MAX,
            step_nanos: 0,
        }
    }

    /// The same clock, set `step_nanos` forward (negative: back) at true time `at_true_nanos`.
    #[must_use]
    pub fn with_step_at(mut self, at_true_nanos: i64, step_nanos: i64) -> Self {
        self.step_at_true_nanos = at_true_nanos;
        self.step_nanos = step_nanos;
        self
    }

    /// The scheduled step in effect at `true_nanos`.
    fn step_by(&self, true_nanos: i64) -> i64 {
        if true_nanos >= self.step_at_true_nanos {
            self.step_nanos
        } else {
            0
        }
    }

    /// The same clock with reading noise of standard deviation `jitter_nanos`.
    #[must_use]
    pub fn with_jitter_nanos(mut self, jitter_nanos: f64) -> Self {
        self.jitter_nanos = jitter_nanos;
        self
    }

    /// The same clock after someone set it `step_nanos` forward (negative: back).
    #[must_use]
    pub fn stepped(mut self, step_nanos: i64) -> Self {
        self.offset_nanos = self.offset_nanos.saturating_add(step_nanos);
        self
    }

    /// What the clock reads at `true_nanos`, without jitter.
    #[must_use]
    pub fn ideal_local_from_true(&self, true_nanos: i64) -> i64 {
        let drift = (true_nanos as f64 * self.drift_ppm * 1e-6).round() as i64;
        true_nanos
            .saturating_add(self.offset_nanos)
            .saturating_add(drift)
            .saturating_add(self.step_by(true_nanos))
    }

    /// True time at which the clock (without jitter) reads `local_nanos`; after a step that
    /// set the clock back, a reading the clock showed twice maps to its later instant.
    #[must_use]
    pub fn true_from_local(&self, local_nanos: i64) -> i64 {
        let unstepped = |local: i64| {
            let rel = local.saturating_sub(self.offset_nanos) as f64;
            (rel / (1.0 + self.drift_ppm * 1e-6)).round() as i64
        };
        let after = unstepped(local_nanos.saturating_sub(self.step_nanos));
        if after >= self.step_at_true_nanos {
            after
        } else {
            unstepped(local_nanos)
        }
    }

    /// What the clock reads at `true_nanos`, with jitter drawn from `rng`.
    pub fn local_from_true<R: Rng + ?Sized>(&self, true_nanos: i64, rng: &mut R) -> i64 {
        let noise = Normal::new(0.0, self.jitter_nanos)
            .map(|n| n.sample(rng))
            .unwrap_or(0.0);
        self.ideal_local_from_true(true_nanos)
            .saturating_add(noise.round() as i64)
    }
}

/// One-way network delay: a fixed base per direction (the two may differ, which no NTP exchange
/// can see), a gamma-distributed queueing tail, and occasional exponential congestion spikes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinkDelay {
    /// Minimum delay server → sensor, nanoseconds.
    pub base_up_nanos: i64,
    /// Minimum delay sensor → server, nanoseconds.
    pub base_down_nanos: i64,
    /// Mean of the gamma queueing tail added to every message, nanoseconds.
    pub tail_mean_nanos: f64,
    /// Shape of the gamma tail (1 = exponential; larger = less skewed).
    pub tail_shape: f64,
    /// Probability that a message meets a congestion spike.
    pub spike_probability: f64,
    /// Mean extra delay of a spike (exponential), nanoseconds.
    pub spike_mean_nanos: f64,
}

impl LinkDelay {
    /// A switched LAN as in the thesis (§6.4.1: round trip under 1 ms): 100 µs up, 150 µs down,
    /// a gamma(2) tail of mean 80 µs, and 2 % of messages delayed by an extra 3 ms on average.
    #[must_use]
    pub fn lan() -> Self {
        LinkDelay {
            base_up_nanos: 100_000,
            base_down_nanos: 150_000,
            tail_mean_nanos: 80_000.0,
            tail_shape: 2.0,
            spike_probability: 0.02,
            spike_mean_nanos: 3_000_000.0,
        }
    }

    /// Both directions in one process: 5 µs base, 5 µs tail, no spikes.
    #[must_use]
    pub fn loopback() -> Self {
        LinkDelay {
            base_up_nanos: 5_000,
            base_down_nanos: 5_000,
            tail_mean_nanos: 5_000.0,
            tail_shape: 1.0,
            spike_probability: 0.0,
            spike_mean_nanos: 0.0,
        }
    }

    /// A delay server → sensor.
    pub fn sample_up<R: Rng + ?Sized>(&self, rng: &mut R) -> i64 {
        self.base_up_nanos.max(0).saturating_add(self.extra(rng))
    }

    /// A delay sensor → server.
    pub fn sample_down<R: Rng + ?Sized>(&self, rng: &mut R) -> i64 {
        self.base_down_nanos.max(0).saturating_add(self.extra(rng))
    }

    /// Tail plus spike; degenerate parameters give 0 rather than a panic.
    fn extra<R: Rng + ?Sized>(&self, rng: &mut R) -> i64 {
        let tail = Gamma::new(self.tail_shape, self.tail_mean_nanos / self.tail_shape)
            .map(|g| g.sample(rng))
            .unwrap_or(0.0);
        let spike = if self.spike_probability > 0.0 && rng.random::<f64>() < self.spike_probability
        {
            Exp::new(1.0 / self.spike_mean_nanos)
                .map(|e| e.sample(rng))
                .unwrap_or(0.0)
        } else {
            0.0
        };
        (tail.max(0.0) + spike.max(0.0)).round() as i64
    }
}

/// A sensor behind a link, with its own random stream: answers NTP requests and stamps frames.
#[derive(Debug, Clone)]
pub struct SimSensorLink {
    /// The sensor's clock (change it to simulate a step).
    pub clock: SimClock,
    /// The link between the server and the sensor.
    pub link: LinkDelay,
    /// Time the sensor takes between receiving a request and replying, nanoseconds.
    pub processing_nanos: i64,
    rng: ChaCha8Rng,
}

/// One simulated exchange: the sample the server ends up with, and when it has it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SimExchange {
    /// The four stamps.
    pub sample: NtpSample,
    /// True (= server) time the reply arrived.
    pub reply_true_nanos: i64,
}

impl SimSensorLink {
    /// A sensor with `clock` behind `link`, 50 µs processing time, random stream from `seed`.
    #[must_use]
    pub fn new(clock: SimClock, link: LinkDelay, seed: u64) -> Self {
        SimSensorLink {
            clock,
            link,
            processing_nanos: 50_000,
            rng: ChaCha8Rng::seed_from_u64(seed),
        }
    }

    /// The server sends a request at true time `t1_true_nanos` (its own clock is true time).
    pub fn exchange(&mut self, t1_true_nanos: i64) -> SimExchange {
        let arrive = t1_true_nanos.saturating_add(self.link.sample_up(&mut self.rng));
        let t2 = self.clock.local_from_true(arrive, &mut self.rng);
        let leave = arrive.saturating_add(self.processing_nanos.max(0));
        let t3 = self.clock.local_from_true(leave, &mut self.rng);
        let t4 = leave.saturating_add(self.link.sample_down(&mut self.rng));
        SimExchange {
            sample: NtpSample {
                t1: t1_true_nanos,
                t2,
                t3,
                t4,
            },
            reply_true_nanos: t4,
        }
    }

    /// The sensor-local stamp of a frame captured at true time `true_nanos` (with jitter).
    pub fn capture_stamp(&mut self, true_nanos: i64) -> i64 {
        self.clock.local_from_true(true_nanos, &mut self.rng)
    }

    /// How long a frame sent at `true_nanos` takes to reach the server.
    pub fn frame_delay(&mut self) -> i64 {
        self.link.sample_down(&mut self.rng)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The ideal clock and its inverse agree; drift accumulates at the stated rate.
    #[test]
    fn clock_model() {
        let c = SimClock::new(-50_000_000, 100.0);
        assert_eq!(c.ideal_local_from_true(0), -50_000_000);
        // 100 ppm over 10 s = 1 ms.
        assert_eq!(
            c.ideal_local_from_true(10_000_000_000) - 10_000_000_000,
            -49_000_000
        );
        for t in [0, 1_234_567_890, 60_000_000_000] {
            assert!((c.true_from_local(c.ideal_local_from_true(t)) - t).abs() <= 1);
        }
    }

    /// A scheduled step moves the readings from its instant on, and the inverse follows it.
    #[test]
    fn scheduled_step() {
        let c = SimClock::new(5_000, 0.0).with_step_at(1_000_000_000, 1_000_000_000);
        assert_eq!(c.ideal_local_from_true(999_999_999), 1_000_004_999);
        assert_eq!(c.ideal_local_from_true(1_000_000_000), 2_000_005_000);
        for t in [0, 999_999_999, 1_000_000_000, 5_000_000_000] {
            assert_eq!(c.true_from_local(c.ideal_local_from_true(t)), t);
        }
        let back = SimClock::new(0, 0.0).with_step_at(2_000_000_000, -1_000_000_000);
        // Set back, the clock shows 1.5 s at true 1.5 s and again at 2.5 s: the later is taken.
        for (t, later) in [
            (1_500_000_000, 2_500_000_000),
            (2_000_000_000, 2_000_000_000),
            (2_500_000_000, 2_500_000_000),
        ] {
            assert_eq!(back.true_from_local(back.ideal_local_from_true(t)), later);
        }
    }

    /// Delays respect the base, the mean is near base + tail + p·spike, and a seed reproduces.
    #[test]
    fn link_model() {
        let link = LinkDelay::lan();
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let n = 20_000;
        let ups: Vec<i64> = (0..n).map(|_| link.sample_up(&mut rng)).collect();
        assert!(ups.iter().all(|&d| d >= link.base_up_nanos));
        let mean = ups.iter().sum::<i64>() as f64 / n as f64;
        let expected = 100_000.0 + 80_000.0 + 0.02 * 3_000_000.0;
        assert!((mean - expected).abs() < 0.1 * expected, "{mean}");
        let mut a = SimSensorLink::new(SimClock::new(1, 2.0), link, 3);
        let mut b = SimSensorLink::new(SimClock::new(1, 2.0), link, 3);
        assert_eq!(a.exchange(1_000), b.exchange(1_000));
    }

    /// Degenerate link parameters do not panic.
    #[test]
    fn degenerate_link_is_base_only() {
        let link = LinkDelay {
            base_up_nanos: 10,
            base_down_nanos: -5,
            tail_mean_nanos: -1.0,
            tail_shape: 0.0,
            spike_probability: 1.0,
            spike_mean_nanos: 0.0,
        };
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        assert_eq!(link.sample_up(&mut rng), 10);
        assert_eq!(link.sample_down(&mut rng), 0);
    }
}
