//! Invariants under random inputs (proptest): monotonic output, independence from the order of
//! sensor ids and of arrival among sensors, no panics on garbage.

use nalgebra::Point3;
use proptest::prelude::*;
use trigait_skeleton::Joint;
use trigait_sync::{
    AlignedSet, ClockFilter, ClockFilterParams, Interpolation, NtpSample, Policy, SampleOutcome,
    SyncBuffer, SyncParams, TimedFrame,
};

use super::timed;

/// Frames of `n` sensors, 30 Hz with the given phases, `frames` each, joints on a known track.
fn frames(phases: &[i64], frames: i64) -> Vec<TimedFrame> {
    let mut out = Vec::new();
    for (i, &phase) in phases.iter().enumerate() {
        for j in 0..frames {
            let t = phase + j * 33_333_333;
            let p = Point3::new(i as f64, (t as f64 * 1e-9).sin(), 2.0);
            out.push(timed(
                &format!("s{i}"),
                j as u64,
                t,
                &[(Joint::AnkleRight, p), (Joint::HipRight, p)],
            ));
        }
    }
    out
}

fn policy() -> impl Strategy<Value = (Policy, Interpolation)> {
    prop_oneof![
        Just((Policy::Slots, Interpolation::Linear)),
        Just((Policy::Interpolate, Interpolation::Linear)),
        Just((Policy::Interpolate, Interpolation::CubicHermite)),
    ]
}

fn run(ids: &[String], params: SyncParams, pushes: Vec<TimedFrame>) -> Vec<AlignedSet> {
    let mut buffer = SyncBuffer::new(ids.iter().cloned(), params).unwrap();
    let mut out = Vec::new();
    for f in pushes {
        out.extend(buffer.push_timed(f).unwrap());
    }
    out.extend(buffer.flush());
    let c = buffer.counters();
    assert_eq!(c.sets_out, out.len() as u64);
    out
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Whatever the arrival order (frames delayed by up to 80 ms, so some arrive late), set stamps
    /// strictly increase, seq counts up from 0, and every set accounts for every sensor once.
    #[test]
    fn output_is_monotonic(
        phases in prop::collection::vec(0_i64..33_333_333, 1..6),
        delays in prop::collection::vec(0_i64..80_000_000, 200),
        (policy, method) in policy(),
    ) {
        let ids: Vec<String> = (0..phases.len()).map(|i| format!("s{i}")).collect();
        let mut pushes: Vec<(i64, TimedFrame)> = frames(&phases, 40)
            .into_iter()
            .enumerate()
            .map(|(k, f)| (f.server_stamp_nanos + delays[k % delays.len()], f))
            .collect();
        pushes.sort_by_key(|(arrival, f)| (*arrival, f.frame.sensor_id.clone()));
        let params = SyncParams::default().with_policy(policy).with_interpolation(method);
        let sets = run(&ids, params, pushes.into_iter().map(|(_, f)| f).collect());
        prop_assert!(!sets.is_empty());
        for (k, set) in sets.iter().enumerate() {
            prop_assert_eq!(set.seq, k as u64);
            let mut all: Vec<String> = set.sensors.keys().cloned().chain(set.missing.iter().cloned()).collect();
            all.sort();
            prop_assert_eq!(&all, &ids);
            prop_assert!(!set.sensors.is_empty());
        }
        for w in sets.windows(2) {
            prop_assert!(w[1].stamp_nanos > w[0].stamp_nanos);
        }
    }

    /// `interpolate`: the sets do not depend on the order the sensor ids were given in, nor on the
    /// order among frames captured at the same instant.
    #[test]
    fn interpolate_is_independent_of_sensor_order(
        phases in prop::collection::vec(prop_oneof![Just(0_i64), Just(10_000_000), Just(20_000_000)], 2..6),
        rotate in 0_usize..6,
        method in prop_oneof![Just(Interpolation::Linear), Just(Interpolation::CubicHermite)],
    ) {
        let ids: Vec<String> = (0..phases.len()).map(|i| format!("s{i}")).collect();
        let params = SyncParams::default().with_interpolation(method);
        let mut pushes = frames(&phases, 30);
        pushes.sort_by_key(|f| (f.server_stamp_nanos, f.frame.sensor_id.clone()));
        let reference = run(&ids, params.clone(), pushes.clone());

        let mut shuffled_ids = ids.clone();
        shuffled_ids.rotate_left(rotate % ids.len());
        shuffled_ids.reverse();
        pushes.sort_by_key(|f| (f.server_stamp_nanos, std::cmp::Reverse(f.frame.sensor_id.clone())));
        let other = run(&shuffled_ids, params, pushes);
        prop_assert_eq!(reference, other);
    }

    /// The clock filter takes any stamps without panicking and rejects impossible ones; the map
    /// never panics for any local stamp.
    #[test]
    fn clock_filter_never_panics(
        samples in prop::collection::vec(any::<(i64, i64, i64, i64)>(), 1..40),
        locals in prop::collection::vec(any::<i64>(), 1..10),
    ) {
        let mut f = ClockFilter::new(ClockFilterParams::default()).unwrap();
        for (t1, t2, t3, t4) in samples {
            let s = NtpSample { t1, t2, t3, t4 };
            if let SampleOutcome::Accepted(m) = f.push(s) {
                prop_assert!(m.delay_nanos >= 0 && t4 >= t1 && t3 >= t2);
            }
        }
        for l in locals {
            let _ = f.server_from_local(l);
            let _ = f.local_from_server(l);
        }
    }

    /// Eq. 6.3: for any offset and any split of the delay, the measured offset is within ±d/2.
    #[test]
    fn offset_error_within_half_delay(
        offset in -100_000_000_i64..100_000_000,
        d1 in 0_i64..5_000_000,
        d2 in 0_i64..5_000_000,
        processing in 0_i64..1_000_000,
        t1 in -1_000_000_000_000_i64..1_000_000_000_000,
    ) {
        let t2 = t1 + d1 + offset;
        let t3 = t2 + processing;
        let t4 = t3 - offset + d2;
        let m = NtpSample { t1, t2, t3, t4 }.measure().unwrap();
        prop_assert_eq!(m.delay_nanos, d1 + d2);
        prop_assert!((m.offset_nanos - offset).abs() <= m.error_bound_nanos());
    }
}
