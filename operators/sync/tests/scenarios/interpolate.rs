//! `interpolate` policy: exactness, error budget, gaps, extrapolation limits, and the end-to-end
//! comparison with `slots` on a moving ankle behind simulated clocks.

use nalgebra::{Point3, Vector3};
use trigait_sim::clock::{LinkDelay, SimClock, SimSensorLink};
use trigait_skeleton::{Joint, TrackingState};
use trigait_sync::{AlignedSet, Interpolation, Policy, SyncBuffer, SyncParams, TimedFrame};

use super::{ankle, linear, timed};

const PERIOD: i64 = 33_333_333;

/// Pushes 30 Hz frames of `n` sensors (phases 0, 11, 23, … ms) in capture order, each joint from
/// `motion(sensor, joint, t)`; `None` leaves the joint out of that frame.
fn run<F>(n: usize, frames: i64, params: SyncParams, motion: F) -> (Vec<AlignedSet>, SyncBuffer)
where
    F: Fn(usize, Joint, i64) -> Option<Point3<f64>>,
{
    let ids: Vec<String> = (0..n).map(|i| format!("s{i}")).collect();
    let mut buffer = SyncBuffer::new(ids.clone(), params).unwrap();
    let mut pushes: Vec<TimedFrame> = Vec::new();
    for (i, id) in ids.iter().enumerate() {
        let phase = (11_000_000 * i as i64) % PERIOD;
        for j in 0..frames {
            let t = phase + j * PERIOD;
            let joints: Vec<(Joint, Point3<f64>)> =
                [Joint::HipLeft, Joint::KneeLeft, Joint::AnkleLeft]
                    .into_iter()
                    .filter_map(|joint| motion(i, joint, t).map(|p| (joint, p)))
                    .collect();
            pushes.push(timed(id, j as u64, t, &joints));
        }
    }
    pushes.sort_by_key(|f| f.server_stamp_nanos);
    let mut sets = Vec::new();
    for f in pushes {
        sets.extend(buffer.push_timed(f).unwrap());
    }
    sets.extend(buffer.flush());
    (sets, buffer)
}

fn velocity(i: usize, joint: Joint) -> Vector3<f64> {
    Vector3::new(1.5 + i as f64, -0.3 * joint.index() as f64 / 10.0, 4.0)
}

/// Linear motion is reproduced exactly at every fusion instant, by both methods, with a zero error
/// budget; instants are 1/30 s apart, strictly increasing, sets complete.
#[test]
fn exact_on_linear_motion() {
    for method in [Interpolation::Linear, Interpolation::CubicHermite] {
        let truth = |i: usize, joint: Joint, t: i64| {
            linear(
                Point3::new(i as f64, joint.index() as f64 * 0.1, 2.0),
                velocity(i, joint),
            )(t)
        };
        let params = SyncParams::default().with_interpolation(method);
        let (sets, buffer) = run(3, 60, params, |i, j, t| Some(truth(i, j, t)));
        assert!(sets.len() >= 55, "{method}: {}", sets.len());
        for w in sets.windows(2) {
            let d = w[1].stamp_nanos - w[0].stamp_nanos;
            assert!((33_333_333..=33_333_334).contains(&d), "{d}");
        }
        for set in &sets {
            for (i, id) in ["s0", "s1", "s2"].iter().enumerate() {
                let Some(view) = set.sensors.get(*id) else {
                    continue;
                };
                assert_eq!(view.joints.len(), 3);
                for (s, e) in view.joints.iter().zip(&view.interpolation_error_m) {
                    let expected = truth(i, s.joint, set.stamp_nanos);
                    assert!(
                        (s.position_in_kinect - expected).norm() < 1e-9,
                        "{method} {id} {:?}",
                        s.joint
                    );
                    assert!(e.is_none_or(|e| e < 1e-9), "{e:?}");
                }
            }
        }
        // Only the flush tail may be incomplete (beyond the extrapolation limit of some sensor).
        let incomplete: Vec<i64> = sets
            .iter()
            .filter(|s| !s.is_complete())
            .map(|s| s.stamp_nanos)
            .collect();
        assert!(
            incomplete.iter().all(|&t| t > 58 * PERIOD),
            "{incomplete:?}"
        );
        assert_eq!(buffer.counters().frames_late, 0);
    }
}

/// On constant acceleration the chord's error is exactly |a|·(t − t₀)(t₁ − t)/2: the reported
/// budget equals the true error; cubic Hermite (exact tangents on uniform samples) is exact.
#[test]
fn error_budget_on_constant_acceleration() {
    let acc = Vector3::new(9.0, 0.0, -4.0);
    let truth = move |t: i64| {
        let s = t as f64 * 1e-9;
        Point3::new(0.0, 0.0, 2.0) + Vector3::new(1.0, 0.5, 0.0) * s + acc * (0.5 * s * s)
    };
    let (sets, _) = run(2, 40, SyncParams::default(), |_, _, t| Some(truth(t)));
    let mut checked = 0;
    for set in &sets {
        for view in set.sensors.values() {
            for (s, e) in view.joints.iter().zip(&view.interpolation_error_m) {
                let actual = (s.position_in_kinect - truth(set.stamp_nanos)).norm();
                let Some(budget) = e else { continue };
                assert!(
                    (budget - actual).abs() <= 1e-9 + 1e-6 * actual,
                    "budget {budget} actual {actual}"
                );
                checked += 1;
            }
        }
    }
    assert!(checked > 100);
    let params = SyncParams::default().with_interpolation(Interpolation::CubicHermite);
    let (sets, _) = run(2, 40, params, |_, _, t| Some(truth(t)));
    for set in sets
        .iter()
        .filter(|s| s.stamp_nanos > 3 * PERIOD && s.stamp_nanos < 36 * PERIOD)
    {
        for view in set.sensors.values() {
            for s in &view.joints {
                assert!((s.position_in_kinect - truth(set.stamp_nanos)).norm() < 1e-9);
            }
        }
    }
}

/// With `bridge_gaps`, a joint missing for two frames (gap 100 ms ≤ limit) is bridged; missing
/// for four (167 ms) it is left out of the sets inside the gap while the other joints continue.
/// Without it (the default) the sets inside any gap go out without waiting for the joint, and
/// lack it except within the extrapolation limit of its last sample.
#[test]
fn gaps_are_bridged_only_up_to_the_limit() {
    let p = |t: i64| linear(Point3::new(0.0, 0.0, 2.0), Vector3::new(1.0, 0.0, 0.0))(t);
    let lost = |j: i64, n: i64| (20..20 + n).contains(&j);
    let bridging = SyncParams::default().with_bridge_gaps(true);
    for (params, n_lost, bridged) in [
        (bridging.clone(), 2, true),
        (bridging, 4, false),
        (SyncParams::default(), 2, false),
    ] {
        let (sets, _) = run(1, 40, params.clone(), |_, joint, t| {
            (joint != Joint::AnkleLeft || !lost(t / PERIOD, n_lost)).then(|| p(t))
        });
        // Past the extrapolation limit (10 ms) of the last sample before the gap.
        let inside: Vec<&AlignedSet> = sets
            .iter()
            .filter(|s| {
                s.stamp_nanos > 19 * PERIOD + 10_000_000 && s.stamp_nanos < (19 + n_lost) * PERIOD
            })
            .collect();
        assert!(!inside.is_empty());
        for set in inside {
            let view = &set.sensors["s0"];
            let has_ankle = view.joints.iter().any(|s| s.joint == Joint::AnkleLeft);
            assert_eq!(
                has_ankle, bridged,
                "lost {n_lost}, set at {}, {params:?}",
                set.stamp_nanos
            );
            assert!(view.joints.iter().any(|s| s.joint == Joint::HipLeft));
        }
    }
}

/// A joint reported `Inferred` in one of the two frames comes out `Inferred`; `NotTracked` samples
/// are never used.
#[test]
fn tracking_state_is_the_weaker_of_the_two() {
    let ids = ["a"];
    let mut buffer = SyncBuffer::new(ids, SyncParams::default()).unwrap();
    let mut sets = Vec::new();
    for j in 0..10_i64 {
        let mut f = timed(
            "a",
            j as u64,
            j * PERIOD + 5_000_000,
            &[(Joint::KneeRight, Point3::new(j as f64, 0.0, 2.0))],
        );
        if j == 4 {
            f.frame.joints[0].state = TrackingState::Inferred;
        }
        if j == 6 {
            f.frame.joints[0].state = TrackingState::NotTracked;
            f.frame.joints[0].position_in_kinect = Point3::new(1e6, 1e6, 1e6);
        }
        sets.extend(buffer.push_timed(f).unwrap());
    }
    sets.extend(buffer.flush());
    for set in &sets {
        let Some(view) = set.sensors.get("a") else {
            continue;
        };
        let s = view.joints[0];
        assert!(s.position_in_kinect.x < 100.0, "NotTracked sample used");
        let j = (set.stamp_nanos - 5_000_000) as f64 / PERIOD as f64;
        let touches_4 = j > 3.0 && j < 5.0;
        assert_eq!(
            s.state == TrackingState::Inferred,
            touches_4,
            "set at {}",
            set.stamp_nanos
        );
    }
}

/// Three sensors whose frames reach the buffer 2 ms after capture, the clock read on every
/// arrival and on a 5 ms timer: a set goes out once every sensor's frame after its instant is
/// in, so its age (clock when it went out − instant) stays under a frame period plus the
/// transport delay and the timer. When one sensor's frame is lost, the sets that needed it
/// wait only until that frame is overdue by the margin (10 ms), not the 100 ms deadline, and
/// go out with that sensor's joints where its earlier samples reach (extrapolated ≤ 10 ms) or
/// without it.
#[test]
fn a_lost_frame_delays_a_set_by_its_margin_not_the_deadline() {
    let lag = 2_000_000;
    let tick = 5_000_000;
    let ids = ["s0", "s1", "s2"];
    let p = |t: i64| linear(Point3::new(0.0, 0.0, 2.0), Vector3::new(1.0, 0.0, 0.0))(t);
    let lost = |i: usize, j: i64| i == 1 && (30..32).contains(&j);
    for params in [
        SyncParams::default(),
        SyncParams::default().with_interpolation(Interpolation::CubicHermite),
    ] {
        let mut arrivals: Vec<(i64, Option<TimedFrame>)> = Vec::new();
        for (i, id) in ids.iter().enumerate() {
            let phase = 3_000_000 + 11_000_000 * i as i64;
            for j in (0..60).filter(|&j| !lost(i, j)) {
                let t = phase + j * PERIOD;
                let f = timed(id, j as u64, t, &[(Joint::KneeLeft, p(t))]);
                arrivals.push((t + lag, Some(f)));
            }
        }
        arrivals.extend((0..60 * PERIOD / tick).map(|k| (k * tick, None)));
        arrivals.sort_by_key(|(at, f)| (*at, f.is_some()));
        let mut buffer = SyncBuffer::new(ids, params.clone()).unwrap();
        let mut ages: Vec<(i64, i64, bool)> = Vec::new();
        for (at, frame) in arrivals {
            let mut out: Vec<AlignedSet> = buffer.advance_to(at).collect();
            if let Some(f) = frame {
                out.extend(buffer.push_timed(f).unwrap());
            }
            ages.extend(
                out.iter()
                    .map(|s| (s.stamp_nanos, at - s.stamp_nanos, s.is_complete())),
            );
        }
        let need = if params.interpolation == Interpolation::Linear {
            1
        } else {
            2
        };
        let s1_lost_from = 3_000_000 + 11_000_000 + 29 * PERIOD;
        let affected = |stamp: i64| {
            stamp > s1_lost_from - (need - 1) * PERIOD && stamp <= s1_lost_from + 3 * PERIOD
        };
        let steady: Vec<&(i64, i64, bool)> = ages
            .iter()
            .filter(|(stamp, ..)| *stamp > 10 * PERIOD && *stamp < 50 * PERIOD)
            .collect();
        assert!(steady.len() >= 35, "{}", steady.len());
        let mut without_s1 = 0;
        for &&(stamp, age, complete) in &steady {
            if affected(stamp) {
                // The newest s1 frame is at most a period before the instant (need − 1 more
                // after it); the set waits for the next one until period + lag + margin after
                // that frame, then for the timer.
                let bound = need * PERIOD + lag + params.frame_wait_margin_nanos + tick;
                assert!(age <= bound, "set at {stamp}: age {age} > {bound}");
                without_s1 += usize::from(!complete);
            } else {
                let bound = need * PERIOD + lag + tick;
                assert!(age <= bound, "set at {stamp}: age {age} > {bound}");
                assert!(complete, "set at {stamp}");
            }
        }
        // Those that s1's earlier frames could not reach went out without it.
        assert!(without_s1 >= 1, "no set went out without s1");
        assert_eq!(buffer.counters().sets_deadline, 0);
        assert!(buffer.counters().sets_overdue >= 1);
    }
}

/// A sensor that never sends a frame the buffer can use (never synchronised): the first set
/// waits the deadline for it, the later ones go out on the other sensors' frames.
#[test]
fn a_silent_sensor_holds_back_only_the_first_set() {
    let p = |t: i64| linear(Point3::new(0.0, 0.0, 2.0), Vector3::new(1.0, 0.0, 0.0))(t);
    let mut buffer = SyncBuffer::new(["s0", "s1", "silent"], SyncParams::default()).unwrap();
    let mut released: Vec<(i64, i64)> = Vec::new();
    for j in 0..30_i64 {
        for (i, id) in ["s0", "s1"].iter().enumerate() {
            let t = 5_000_000 + 11_000_000 * i as i64 + j * PERIOD;
            let arrival = t + 2_000_000;
            let out: Vec<AlignedSet> = buffer
                .advance_to(arrival)
                .chain(
                    buffer
                        .push_timed(timed(id, j as u64, t, &[(Joint::KneeLeft, p(t))]))
                        .unwrap(),
                )
                .collect();
            released.extend(out.iter().map(|s| (s.stamp_nanos, arrival - s.stamp_nanos)));
        }
    }
    assert!(released.len() >= 25, "{}", released.len());
    let first = released[0].0;
    for &(stamp, age) in &released {
        let bound = if stamp == first {
            110_000_000
        } else {
            PERIOD + 2_000_000 + 11_000_000
        };
        assert!(age <= bound, "set at {stamp}: age {age}");
    }
    let c = buffer.counters();
    assert_eq!(c.sets_incomplete, c.sets_out);
}

/// A sensor whose source ends its stream (the last frame says so, or its input closes): the
/// sets after its last frame do not wait for a next frame that will not come; each goes out as
/// soon as the other sensors' frames after its instant are in, as young as while all three
/// streamed, and holds the ended sensor's joints only where its last frames reach. Without the
/// notice the same sets wait until that sensor is overdue.
#[test]
fn an_ended_stream_is_not_waited_for() {
    let p = |t: i64| linear(Point3::new(0.0, 0.0, 2.0), Vector3::new(1.0, 0.0, 0.0))(t);
    let lag = 2_000_000;
    let last = 29_i64;
    let ages = |notice: bool| {
        let mut buffer = SyncBuffer::new(["s0", "s1", "s2"], SyncParams::default()).unwrap();
        let mut arrivals: Vec<(i64, &str, i64)> = Vec::new();
        for (i, id) in ["s0", "s1", "s2"].into_iter().enumerate() {
            let phase = 3_000_000 + 11_000_000 * i as i64;
            for j in (0..60).filter(|&j| id != "s2" || j <= last) {
                arrivals.push((phase + j * PERIOD + lag, id, j));
            }
        }
        arrivals.sort_unstable();
        let mut released: Vec<(i64, i64, bool)> = Vec::new();
        for (at, id, j) in arrivals {
            let t = at - lag;
            let mut out: Vec<AlignedSet> = buffer.advance_to(at).collect();
            out.extend(
                buffer
                    .push_timed(timed(id, j as u64, t, &[(Joint::KneeLeft, p(t))]))
                    .unwrap(),
            );
            if notice && id == "s2" && j == last {
                out.extend(buffer.end_of_stream("s2").unwrap());
            }
            released.extend(out.iter().map(|s| {
                (
                    s.stamp_nanos,
                    at - s.stamp_nanos,
                    s.sensors.contains_key("s2"),
                )
            }));
        }
        assert!(buffer.end_of_stream("s9").is_err(), "an unknown sensor");
        released
    };
    let last_s2 = 3_000_000 + 22_000_000 + last * PERIOD;
    let worst_after = |released: &[(i64, i64, bool)]| {
        released
            .iter()
            .filter(|(stamp, ..)| *stamp > last_s2 && *stamp < 55 * PERIOD)
            .map(|&(_, age, _)| age)
            .max()
            .unwrap()
    };
    let with_notice = ages(true);
    let steady_before = with_notice
        .iter()
        .filter(|(stamp, ..)| *stamp > 5 * PERIOD && *stamp < last_s2 - PERIOD)
        .map(|&(_, age, _)| age)
        .max()
        .unwrap();
    let after = worst_after(&with_notice);
    assert!(
        after <= steady_before,
        "after the end {after} ns, before {steady_before} ns"
    );
    for &(stamp, _, has_s2) in &with_notice {
        if stamp > last_s2 + 10_000_000 {
            assert!(!has_s2, "set at {stamp} holds s2 past its reach");
        }
        if stamp <= last_s2 {
            assert!(has_s2, "set at {stamp} lacks s2");
        }
    }
    let without_notice = worst_after(&ages(false));
    assert!(
        without_notice >= after + SyncParams::default().frame_wait_margin_nanos,
        "without the notice {without_notice} ns, with it {after} ns"
    );
}

/// A sensor that stops: it is extrapolated at most `max_extrapolation_nanos` past its last frame,
/// then reported missing; sets keep coming (after the latency deadline) with the others.
#[test]
fn stopped_sensor_is_extrapolated_briefly_then_missing() {
    let p = |t: i64| linear(Point3::new(0.0, 0.0, 2.0), Vector3::new(1.0, 0.0, 0.0))(t);
    let (sets, buffer) = run(2, 60, SyncParams::default(), |i, _, t| {
        (i == 0 || t < 30 * PERIOD).then(|| p(t))
    });
    let last_s1 = 11_000_000 + 29 * PERIOD;
    for set in &sets {
        let has = set.sensors.contains_key("s1");
        if set.stamp_nanos > last_s1 + 10_000_000 {
            assert!(!has && set.missing == vec!["s1".to_owned()]);
        }
        if set.stamp_nanos <= last_s1 {
            assert!(has, "{}", set.stamp_nanos);
        }
    }
    assert!(
        sets.iter()
            .filter(|s| s.stamp_nanos > last_s1 + 10_000_000)
            .count()
            >= 25
    );
    assert!(buffer.counters().sets_incomplete >= 25);
}

/// End to end: three sensors with clocks 40 ms apart and 100 ppm drift behind LAN links, NTP every
/// 0.5 s, 30 Hz frames of a moving ankle (peak 1.9 m/s). `interpolate` puts every sensor's ankle
/// within 3 mm of the truth at the fusion instant (measured RMS 1.3 mm); `slots` leaves the
/// inter-sensor skew in (measured RMS 55 mm), which is why `interpolate` is the default. Cubic
/// Hermite does better still (measured RMS 0.09 mm), and the reported error budget plus the clock
/// uncertainty at peak speed covers the true error for ≥ 95 % of joints (measured 98 % linear,
/// 100 % Hermite).
#[test]
fn interpolate_beats_slots_behind_real_clocks() {
    let clocks = [(-40_000_000, 100.0), (0, -50.0), (40_000_000, 20.0)];
    let offsets = [
        Vector3::new(0.1, 0.0, 0.0),
        Vector3::new(-0.2, 0.1, 0.3),
        Vector3::zeros(),
    ];
    let rms = |policy: Policy, method: Interpolation| {
        let ids: Vec<String> = (0..3).map(|i| format!("k{i}")).collect();
        let mut buffer = SyncBuffer::new(
            ids.clone(),
            SyncParams::default()
                .with_policy(policy)
                .with_interpolation(method),
        )
        .unwrap();
        let mut links: Vec<SimSensorLink> = clocks
            .iter()
            .enumerate()
            .map(|(i, &(o, d))| {
                SimSensorLink::new(
                    SimClock::new(o, d).with_jitter_nanos(20_000.0),
                    LinkDelay::lan(),
                    40 + i as u64,
                )
            })
            .collect();
        // (arrival, sensor, Some(frame) | None for an NTP sample)
        let mut events = Vec::new();
        for (i, link) in links.iter_mut().enumerate() {
            for m in 0..40 {
                let ex = link.exchange(m * 500_000_000 + i as i64 * 100_000_000);
                events.push((ex.reply_true_nanos, i, Err(ex.sample)));
            }
            for j in 0..600_i64 {
                let t = 2_000_000_000 + (7_000_000 * i as i64) + j * PERIOD;
                let local = link.capture_stamp(t);
                let f = super::frame(
                    &ids[i],
                    j as u64,
                    local,
                    &[(Joint::AnkleLeft, ankle(offsets[i])(t))],
                );
                events.push((t + link.frame_delay(), i, Ok(f)));
            }
        }
        events.sort_by_key(|e| (e.0, e.1));
        let mut sets = Vec::new();
        for (_, i, e) in events {
            match e {
                Err(sample) => {
                    buffer.push_ntp(&ids[i], sample).unwrap();
                }
                Ok(f) => sets.extend(buffer.push(f).unwrap()),
            }
        }
        sets.extend(buffer.flush());
        let mut errors = Vec::new();
        // Error budget check: the true error is within the reported interpolation budget plus
        // what the clock uncertainty allows at the ankle's peak speed (1.9 m/s).
        let (mut budgeted, mut within) = (0, 0);
        for set in sets.iter().filter(|s| s.is_complete()) {
            for (i, id) in ids.iter().enumerate() {
                let view = &set.sensors[id];
                let s = view.joints[0];
                let error = (s.position_in_kinect - ankle(offsets[i])(set.stamp_nanos)).norm();
                errors.push(error);
                if let Some(budget) = view.interpolation_error_m[0] {
                    budgeted += 1;
                    let allowed = budget + 1.9 * view.time_uncertainty_nanos as f64 * 1e-9 + 1e-5;
                    within += usize::from(error <= allowed);
                }
            }
        }
        if policy == Policy::Interpolate {
            let covered = within as f64 / budgeted as f64;
            eprintln!(
                "{method}: error budget covers {:.1} % of {budgeted} joints",
                100.0 * covered
            );
            assert!(budgeted > 3 * 250 && covered >= 0.95, "{covered}");
        }
        let n = errors.len();
        assert!(n > 3 * 250, "{policy}: {n}");
        let rms = (errors.iter().map(|e| e * e).sum::<f64>() / n as f64).sqrt();
        let max = errors.iter().fold(0.0_f64, |m, e| m.max(*e));
        eprintln!(
            "{policy} ({method}): {} sets, ankle RMS {:.2} mm, max {:.2} mm",
            sets.len(),
            rms * 1e3,
            max * 1e3
        );
        (rms, max)
    };
    let (interp_rms, interp_max) = rms(Policy::Interpolate, Interpolation::Linear);
    let (hermite_rms, hermite_max) = rms(Policy::Interpolate, Interpolation::CubicHermite);
    let (slots_rms, _) = rms(Policy::Slots, Interpolation::Linear);
    assert!(
        hermite_max < interp_max && hermite_rms < interp_rms,
        "{hermite_rms} {interp_rms}"
    );
    assert!(interp_max < 3e-3, "{interp_max}");
    assert!(interp_rms < 1.5e-3, "{interp_rms}");
    assert!(
        slots_rms > 5.0 * interp_rms,
        "slots {slots_rms} interpolate {interp_rms}"
    );
}

/// With the server clock given (`advance_to`), one frame stamped an hour ahead is rejected and
/// counted; without that guard it would drag the schedule an hour ahead and make every later
/// frame late. The stream goes on undisturbed.
#[test]
fn garbage_future_stamp_is_rejected() {
    let p = |t: i64| linear(Point3::new(0.0, 0.0, 2.0), Vector3::new(1.0, 0.0, 0.0))(t);
    let mut buffer = SyncBuffer::new(["a", "b"], SyncParams::default()).unwrap();
    let mut sets = Vec::new();
    for j in 0..60_i64 {
        let t = j * PERIOD;
        sets.extend(buffer.advance_to(t + 2_000_000));
        for id in ["a", "b"] {
            sets.extend(
                buffer
                    .push_timed(timed(id, j as u64, t, &[(Joint::HipLeft, p(t))]))
                    .unwrap(),
            );
        }
        if j == 30 {
            let garbage = timed("b", 1_000, t + 3_600_000_000_000, &[(Joint::HipLeft, p(t))]);
            let err = buffer.push_timed(garbage).err().unwrap();
            assert!(
                matches!(err, trigait_sync::Error::FrameFromFuture { seq: 1_000, .. }),
                "{err}"
            );
        }
    }
    let c = *buffer.counters();
    assert_eq!(c.frames_from_future, 1);
    assert_eq!(c.frames_late, 0);
    assert!(
        sets.len() >= 55 && sets.iter().all(AlignedSet::is_complete),
        "{}",
        sets.len()
    );
    assert!(sets.last().unwrap().stamp_nanos < 60 * PERIOD);
}
