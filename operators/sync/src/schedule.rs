//! When to start each sensor's NTP exchange.
//!
//! Polling every sensor at the same instant makes n replies arrive together: they queue behind
//! each other in the sync node (and in front of the frames), so each later reply carries the
//! wait of the ones before it as round-trip delay — and, at 16 sensors, that wait is what the
//! clock filter then has to reject. [`NtpSchedule`] spreads the n exchanges evenly over the
//! polling interval (sensor i at phase i/n), so at most one or two start per sync tick.

/// Staggered polling of `n` sensors, each once per interval. Pure: the caller passes the time.
#[derive(Debug, Clone)]
pub struct NtpSchedule {
    interval_nanos: i64,
    next_due: Vec<Option<i64>>,
}

impl NtpSchedule {
    /// `sensors` sensors, each polled every `interval_nanos` (clamped to at least 1 ns).
    #[must_use]
    pub fn new(sensors: usize, interval_nanos: i64) -> Self {
        NtpSchedule {
            interval_nanos: interval_nanos.max(1),
            next_due: vec![None; sensors],
        }
    }

    /// Indices of the sensors whose exchange is due at `now_nanos`, in index order. The first
    /// call sets the phases (sensor 0 is due at once). A sensor whose turns were missed (a
    /// stalled tick) is polled once and keeps its phase: the missed turns are skipped, not made
    /// up in a burst, and the sensors do not end up polled together afterwards.
    pub fn due(&mut self, now_nanos: i64) -> Vec<usize> {
        let n = self.next_due.len() as i64;
        let interval = self.interval_nanos;
        let mut due = Vec::new();
        for (i, next) in self.next_due.iter_mut().enumerate() {
            let next_due = *next.get_or_insert_with(|| {
                now_nanos.saturating_add(interval.saturating_mul(i as i64) / n.max(1))
            });
            if now_nanos >= next_due {
                due.push(i);
                let missed = now_nanos.saturating_sub(next_due) / interval;
                *next = Some(
                    next_due.saturating_add(interval.saturating_mul(missed.saturating_add(1))),
                );
            }
        }
        due
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Over one interval every sensor is polled exactly once, spread out, never all together.
    #[test]
    fn spreads_sensors_over_the_interval() {
        let mut s = NtpSchedule::new(16, 100_000_000);
        let mut per_sensor = [0_u32; 16];
        let mut most_per_tick = 0;
        for tick in 0..110 {
            let due = s.due(tick * 10_000_000);
            most_per_tick = most_per_tick.max(due.len());
            if tick >= 10 {
                for i in due {
                    per_sensor[i] += 1;
                }
            }
        }
        // Any 1 s of 10 ms ticks at a 100 ms interval: ten polls each.
        assert!(per_sensor.iter().all(|&c| c == 10), "{per_sensor:?}");
        assert!(most_per_tick <= 2, "{most_per_tick} polls in one tick");
    }

    /// A stalled tick polls each late sensor once, then every sensor is back on its own phase
    /// (0, 33 and 67 ms of each 100 ms), not polled together from then on.
    #[test]
    fn a_stall_polls_each_sensor_once_and_keeps_the_phases() {
        let mut s = NtpSchedule::new(3, 100_000_000);
        assert_eq!(s.due(0), vec![0]);
        assert_eq!(s.due(1_000_000_000), vec![0, 1, 2]);
        assert!(s.due(1_010_000_000).is_empty());
        assert_eq!(s.due(1_040_000_000), vec![1]);
        assert_eq!(s.due(1_070_000_000), vec![2]);
        assert_eq!(s.due(1_100_000_000), vec![0]);
        assert!(s.due(1_120_000_000).is_empty());
    }

    /// No sensors, or a zero interval: no panic, sensible output.
    #[test]
    fn degenerate_inputs() {
        assert!(NtpSchedule::new(0, 100).due(0).is_empty());
        let mut s = NtpSchedule::new(2, 0);
        assert_eq!(s.due(0), vec![0, 1]);
        assert_eq!(s.due(1), vec![0, 1]);
    }
}
