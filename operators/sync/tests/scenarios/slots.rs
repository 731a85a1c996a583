//! `slots` policy: thesis §6.4.2 (Fig. 6.5) for n = 3 and its generalisation (§6.4.4, Fig. 6.10).

use nalgebra::Point3;
use trigait_skeleton::Joint;
use trigait_sync::{AlignedSet, Policy, SyncBuffer, SyncParams};

use super::timed;

const SLOT: i64 = 15_000_000;

fn ids(n: usize) -> Vec<String> {
    (1..=n).map(|i| format!("k{i}")).collect()
}

/// Thesis-style clients that obtain and send one frame inside their own slot, `cycles` cycles.
fn triggered_run(n: usize, cycles: i64, params: SyncParams) -> Vec<AlignedSet> {
    let ids = ids(n);
    let mut buffer = SyncBuffer::new(ids.clone(), params).unwrap();
    let cycle = (n as i64 + 1) * SLOT;
    let mut out = Vec::new();
    for k in 0..cycles {
        for (i, id) in ids.iter().enumerate() {
            // Captured 5 ms into its slot.
            let t = k * cycle + i as i64 * SLOT + 5_000_000;
            let p = Point3::new(i as f64, k as f64, 2.0);
            out.extend(
                buffer
                    .push_timed(timed(id, k as u64, t, &[(Joint::KneeLeft, p)]))
                    .unwrap(),
            );
        }
    }
    out.extend(buffer.flush());
    assert_eq!(buffer.counters().sets_out, out.len() as u64);
    out
}

/// Checks the schedule: one complete set per cycle of (n+1)·15 ms, stamped at the start of the
/// fusion slot, with sensor i's frame from slot i of that cycle.
fn check_schedule(n: usize) {
    let params = SyncParams::default()
        .with_policy(Policy::Slots)
        .with_slot_max_frame_age_nanos(SLOT);
    let cycles = 20;
    let sets = triggered_run(n, cycles, params);
    let cycle = (n as i64 + 1) * SLOT;
    assert_eq!(sets.len(), cycles as usize, "n = {n}");
    for (k, set) in sets.iter().enumerate() {
        let k = k as i64;
        assert_eq!(set.seq, k as u64);
        assert_eq!(set.stamp_nanos, k * cycle + n as i64 * SLOT, "n = {n}");
        assert!(
            set.is_complete(),
            "n = {n}, cycle {k}: missing {:?}",
            set.missing
        );
        assert_eq!(set.sensors.len(), n);
        for (i, id) in ids(n).iter().enumerate() {
            let view = &set.sensors[id];
            assert_eq!(view.frame_seqs, vec![k as u64]);
            assert_eq!(
                view.joints[0].position_in_kinect,
                Point3::new(i as f64, k as f64, 2.0)
            );
            // Captured 5 ms into slot i, fused at the start of slot n.
            assert_eq!(
                view.skew_nanos,
                i as i64 * SLOT + 5_000_000 - n as i64 * SLOT
            );
        }
    }
    let diffs: Vec<i64> = sets
        .windows(2)
        .map(|w| w[1].stamp_nanos - w[0].stamp_nanos)
        .collect();
    assert!(diffs.iter().all(|&d| d == cycle));
}

/// Fig. 6.5: three sensors, 60 ms cycle = 4 × 15 ms, fusion in the fourth slot.
#[test]
fn thesis_schedule_n3() {
    check_schedule(3);
    let sets = triggered_run(
        3,
        2,
        SyncParams::default()
            .with_policy(Policy::Slots)
            .with_slot_max_frame_age_nanos(SLOT),
    );
    assert_eq!(sets[1].stamp_nanos - sets[0].stamp_nanos, 60_000_000);
    assert_eq!(sets[0].stamp_nanos, 45_000_000);
}

/// Fig. 6.10 generalised: n sensors, n+1 slots.
#[test]
fn schedule_generalises_to_5_and_16() {
    check_schedule(5);
    check_schedule(16);
}

/// Free-running 30 Hz sensors with the strict "captured in the slot" rule: a set names exactly the
/// sensors that had no frame in their slot, and those sets are counted as incomplete.
#[test]
fn strict_slots_report_missing_sensors() {
    let params = SyncParams::default()
        .with_policy(Policy::Slots)
        .with_slot_max_frame_age_nanos(SLOT);
    let ids = ids(3);
    let mut buffer = SyncBuffer::new(ids.clone(), params).unwrap();
    let phases = [0, 11_000_000, 22_000_000];
    let period = 33_333_333;
    let mut sets = Vec::new();
    let mut stamps: Vec<Vec<i64>> = vec![Vec::new(); 3];
    for j in 0..90 {
        for (i, id) in ids.iter().enumerate() {
            let t = phases[i] + j * period;
            stamps[i].push(t);
            sets.extend(
                buffer
                    .push_timed(timed(
                        id,
                        j as u64,
                        t,
                        &[(Joint::AnkleLeft, Point3::origin())],
                    ))
                    .unwrap(),
            );
        }
    }
    sets.extend(buffer.flush());
    // 3 s = 50 cycles; a cycle in which no sensor captured inside its slot yields no set.
    let c = buffer.counters();
    assert!(sets.len() >= 25, "{}", sets.len());
    assert!((49..=51).contains(&(c.sets_out + c.sets_empty)), "{c:?}");
    let mut incomplete = 0;
    for set in &sets {
        let start = set.stamp_nanos - 3 * SLOT;
        for (i, id) in ids.iter().enumerate() {
            let slot = (start + i as i64 * SLOT, start + (i as i64 + 1) * SLOT);
            let had_frame = stamps[i].iter().any(|&t| t >= slot.0 && t < slot.1);
            assert_eq!(
                set.sensors.contains_key(id),
                had_frame,
                "set at {} sensor {id}",
                set.stamp_nanos
            );
            assert_eq!(set.missing.contains(id), !had_frame);
        }
        incomplete += usize::from(!set.is_complete());
    }
    assert!(incomplete > 0);
    assert_eq!(buffer.counters().sets_incomplete, incomplete as u64);
}

/// The default frame age (one Kinect period) takes the newest frame each free-running sensor had
/// when its slot ended, so every cycle is complete; skews stay within one cycle.
#[test]
fn default_slots_take_newest_frame_before_slot_end() {
    let params = SyncParams::default().with_policy(Policy::Slots);
    let ids = ids(3);
    let mut buffer = SyncBuffer::new(ids.clone(), params).unwrap();
    let mut sets = Vec::new();
    for j in 0..90 {
        for (i, id) in ids.iter().enumerate() {
            let t = 5_000_000 * i as i64 + j * 33_333_333;
            sets.extend(
                buffer
                    .push_timed(timed(
                        id,
                        j as u64,
                        t,
                        &[(Joint::AnkleLeft, Point3::origin())],
                    ))
                    .unwrap(),
            );
        }
    }
    assert!(sets.len() >= 48);
    for set in &sets {
        assert!(set.is_complete(), "{:?}", set.missing);
        for (i, id) in ids.iter().enumerate() {
            let skew = set.sensors[id].skew_nanos;
            let slot_end_rel = (i as i64 + 1 - 3) * SLOT;
            assert!(
                skew < slot_end_rel && skew >= slot_end_rel - 33_400_000,
                "{id}: {skew}"
            );
        }
    }
}

/// A sensor that stops sending: sets keep coming after the latency deadline, without it.
#[test]
fn dead_sensor_does_not_stop_the_schedule() {
    let params = SyncParams::default().with_policy(Policy::Slots);
    let ids = ids(3);
    let mut buffer = SyncBuffer::new(ids.clone(), params).unwrap();
    let mut sets = Vec::new();
    for j in 0..60 {
        for (i, id) in ids.iter().enumerate() {
            if i == 2 && j >= 30 {
                continue; // k3 dies after 1 s
            }
            let t = 5_000_000 * i as i64 + j * 33_333_333;
            sets.extend(
                buffer
                    .push_timed(timed(
                        id,
                        j as u64,
                        t,
                        &[(Joint::HipLeft, Point3::origin())],
                    ))
                    .unwrap(),
            );
        }
    }
    let after: Vec<&AlignedSet> = sets
        .iter()
        .filter(|s| s.stamp_nanos > 1_100_000_000)
        .collect();
    assert!(after.len() >= 10, "{}", after.len());
    assert!(after.iter().all(|s| s.missing == vec!["k3".to_owned()]));
    assert!(buffer.counters().sets_incomplete >= after.len() as u64);
}
