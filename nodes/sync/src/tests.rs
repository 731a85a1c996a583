//! `sync` contracts: the policy and its knobs come from YAML with errors naming node, key and
//! value; the sensor set comes from the graph's inputs; bad input is counted, never fatal.

use dora_node_api::integration_testing::{TestingOptions, drain_outputs};
use dora_node_api::serde_json;
use trigait_node_testing::{
    chain, init_node, input_event, lookup, output_arrays, output_count, scratch_dir,
};
use trigait_sync::{AlignedSet, Policy, SyncParams};

use crate::config::Config;

/// Defaults: interpolate at 30 Hz, a 10 ms wait margin and a 100 ms deadline, gaps not waited
/// for, NTP every 100 ms, sensors from inputs.
#[test]
fn config_defaults_and_policy() {
    let c = Config::from_lookup(lookup(&[])).unwrap();
    assert_eq!(c.params.policy, Policy::Interpolate);
    assert_eq!(c.params.latency_deadline_nanos, 100_000_000);
    assert_eq!(c.params.frame_wait_margin_nanos, 10_000_000);
    assert!(!c.params.bridge_gaps);
    let c = Config::from_lookup(lookup(&[
        ("FRAME_WAIT_MARGIN_MILLIS", "0"),
        ("BRIDGE_GAPS", "yes"),
    ]))
    .unwrap();
    assert_eq!(c.params.frame_wait_margin_nanos, 0);
    assert!(c.params.bridge_gaps);
    assert_eq!(c.ntp_interval_nanos, 100_000_000);
    assert!(c.sensors.is_none());
    let c = Config::from_lookup(lookup(&[
        ("POLICY", "slots"),
        ("SLOT_MILLIS", "20"),
        ("SENSORS", "a, b"),
    ]))
    .unwrap();
    assert_eq!(c.params.policy, Policy::Slots);
    assert_eq!(c.params.slot_nanos, 20_000_000);
    assert_eq!(c.sensors.unwrap(), ["a", "b"]);
    assert!(!c.recorded_time);
    // Recorded time: the recorded run's deadline and buffer, its clock the recorded arrivals.
    let c = Config::from_lookup(lookup(&[("TIMESTAMPS", "recorded")])).unwrap();
    assert!(c.recorded_time);
    assert_eq!(c.params.latency_deadline_nanos, 100_000_000);
    assert_eq!(
        c.params.max_frames_per_sensor,
        SyncParams::default().max_frames_per_sensor
    );
}

/// An unknown policy (or interpolation, or a bad number) stops the node with its key named.
#[test]
fn config_errors_name_node_key_and_value() {
    for (key, raw) in [
        ("POLICY", "round-robin"),
        ("INTERPOLATION", "spline"),
        ("FUSION_RATE_HZ", "fast"),
        // A typo for 30: its sets would outrun every queue of the graph.
        ("FUSION_RATE_HZ", "100000"),
        ("SLOT_MILLIS", "-3"),
        ("NTP_INTERVAL_MILLIS", "x"),
        ("SENSORS", " , "),
        ("TIMESTAMPS", "gps"),
        ("FRAME_WAIT_MARGIN_MILLIS", "-5"),
        ("BRIDGE_GAPS", "maybe"),
    ] {
        let text = chain(&Config::from_lookup(lookup(&[(key, raw)])).unwrap_err());
        assert!(text.starts_with("sync: ") && text.contains(key), "{text}");
        if key != "SLOT_MILLIS" {
            assert!(text.contains(raw.trim()), "{text}");
        }
    }
    let text = chain(&Config::from_lookup(lookup(&[("POLICY", "round-robin")])).unwrap_err());
    assert!(
        text.contains("slots") && text.contains("interpolate"),
        "lists the valid names: {text}"
    );
}

/// `SENSORS` and the wired `frame_<id>` inputs must name the same sensors; each mismatch is
/// named as what it is.
#[test]
fn listed_sensors_match_the_wiring() {
    let ids = |v: &[&str]| v.iter().map(|s| (*s).to_owned()).collect::<Vec<_>>();
    let wired = ids(&["k1", "k2", "k3"]);
    assert!(crate::check_listed_sensors(&wired, &wired).is_ok());
    let short = crate::check_listed_sensors(&ids(&["k1", "k2"]), &wired)
        .unwrap_err()
        .to_string();
    assert!(
        short.contains("`frame_k3` is wired, but SENSORS"),
        "{short}"
    );
    let long = crate::check_listed_sensors(&ids(&["k1", "k2", "k3", "k4"]), &wired)
        .unwrap_err()
        .to_string();
    assert!(
        long.contains("SENSORS lists \"k4\", which has no `frame_k4` input"),
        "{long}"
    );
}

/// The tick must be a timer of at most 20 ms: at one a second no sensor synchronised, and the
/// run ended with two sets and no error.
#[test]
fn the_tick_is_a_fast_timer() {
    use std::time::Duration;
    assert_eq!(
        crate::timer_interval("dora/timer/millis/10"),
        Some(Duration::from_millis(10))
    );
    assert_eq!(
        crate::timer_interval("dora/timer/secs/1"),
        Some(Duration::from_secs(1))
    );
    assert_eq!(crate::timer_interval("k1/frame"), None);
    assert!(crate::check_tick(Some(Some(Duration::from_millis(10)))).is_ok());
    for (tick, needle) in [
        (Some(Some(Duration::from_secs(1))), "fires every 1000 ms"),
        (Some(None), "is not a dora timer"),
        (None, "no `tick` input"),
    ] {
        let text = crate::check_tick(tick).unwrap_err().to_string();
        assert!(
            text.contains(needle) && text.contains("dora/timer/millis/10"),
            "{text}"
        );
    }
}

/// Sensors come from `frame_<id>` inputs in natural order; each needs its `ntp_<id>`.
#[test]
fn sensors_from_the_graph() {
    let ids = crate::sensors_from_inputs(
        [
            "tick",
            "frame_k10",
            "ntp_k10",
            "frame_k2",
            "ntp_k2",
            "frame_k1",
            "ntp_k1",
        ]
        .into_iter(),
    )
    .unwrap();
    assert_eq!(ids, ["k1", "k2", "k10"]);
    let err = crate::sensors_from_inputs(["frame_k1", "ntp_k2"].into_iter()).unwrap_err();
    assert!(chain(&err).contains("ntp_k1"), "{}", chain(&err));
    assert!(crate::sensors_from_inputs(["tick"].into_iter()).is_err());
}

/// Timer ticks send one NTP request per sensor per interval, each sensor at its own phase of
/// the interval (k1 at 0, k2 at 50 ms of 100 ms); malformed frames and replies,
/// and a frame arriving on another sensor's input, are counted and skipped.
#[test]
fn ticks_request_ntp_and_bad_input_is_skipped() {
    let (node, events, mut rx) = init_node(
        serde_json::json!({
            "id": "sync",
            "events": [
                {"time_offset_secs": 0.00, "type": "Input", "id": "tick", "data": 0},
                {"time_offset_secs": 0.01, "type": "Input", "id": "frame_k1", "data": [1, 2]},
                {"time_offset_secs": 0.02, "type": "Input", "id": "ntp_k2", "data": "garbage"},
                {"time_offset_secs": 0.03, "type": "Input", "id": "tick", "data": 0},
                {"time_offset_secs": 0.07, "type": "Input", "id": "tick", "data": 0},
                {"time_offset_secs": 0.13, "type": "Input", "id": "tick", "data": 0},
                {"time_offset_secs": 0.20, "type": "Stop"}
            ]
        }),
        TestingOptions::default(),
    );
    let config = Config::from_lookup(lookup(&[])).unwrap();
    let counters = crate::run(
        config,
        vec!["k1".into(), "k2".into()],
        crate::NtpRoutes::Broadcast,
        node,
        events,
    )
    .unwrap();
    assert_eq!(counters.malformed, 2);
    // k1 at 0 and 130 ms (due at 100), k2 at 70 ms (due at 50, next at 150); nobody at 30 ms.
    assert_eq!(counters.ntp_requests, 3);
    assert_eq!(counters.sets_sent, 0, "no frames, no sets");
    let outputs = drain_outputs(&mut rx);
    assert_eq!(output_count(&outputs, "ntp_request"), 3);
}

/// NTP routing comes from the declared outputs: none per sensor → broadcast; one per sensor →
/// unicast; a partial or unknown set → an error naming the output or sensor.
#[test]
fn ntp_routes_from_outputs() {
    let sensors: Vec<String> = vec!["k1".into(), "k2".into()];
    let r = crate::ntp_routes(["aligned_set", "ntp_request"].into_iter(), &sensors).unwrap();
    assert_eq!(r, crate::NtpRoutes::Broadcast);
    let r = crate::ntp_routes(
        ["ntp_request_k2", "aligned_set", "ntp_request_k1"].into_iter(),
        &sensors,
    )
    .unwrap();
    let crate::NtpRoutes::PerSensor(map) = r else {
        panic!("expected per-sensor routes")
    };
    assert_eq!(map["k1"].as_str(), "ntp_request_k1");
    assert_eq!(map["k2"].as_str(), "ntp_request_k2");
    let e = crate::ntp_routes(["ntp_request_k1"].into_iter(), &sensors).unwrap_err();
    assert!(
        e.to_string().contains("sensor k2 has no `ntp_request_k2`"),
        "{e}"
    );
    let e = crate::ntp_routes(
        ["ntp_request_k1", "ntp_request_k2", "ntp_request_k9"].into_iter(),
        &sensors,
    )
    .unwrap_err();
    assert!(e.to_string().contains("ntp_request_k9"), "{e}");
}

/// The loop's happy path with two sensors whose clocks run 5 ms ahead (k1) and 3 ms behind
/// (k2): eight NTP replies each synchronise them, ticks send NTP requests (one per sensor per
/// 100 ms, each stamped with the server clock), and seven frames each (30 Hz, k2 11 ms after
/// k1, delivered 30 ms after capture) come out as
/// - `frame_timing` rows, one per frame in arrival order, that place it on the server clock
///   within their stated uncertainty, carry the clock estimate (offset within the same bound)
///   and the true capture instant the frame's metadata gave;
/// - `aligned_set`s on the 30 Hz fusion grid, numbered from 0, where each sensor's knee at
///   the set's instant is the straight line between its two frames around it (placed as
///   `frame_timing` says), with those two frames named, the nearest one's skew, and (given a
///   third frame) the chord error of a parabola, 0.6·(t − t₀)(t₁ − t) m for 1.2 m/s²; the
///   knee is there within the time uncertainty times its speed of where it truly was.
///
/// dora's testing daemon sleeps in 10 ms slices and serves the node's requests one at a time,
/// so an event can reach the node 10–15 ms after its offset. The frame-wait margin is therefore
/// as long as the deadline (a set waits for the frame after it however late it comes; the
/// default 10 ms margin let such a frame be judged overdue and the set go out without it), and
/// the scripted events start after a warm-up of ticks: a freshly built test binary's first
/// events can stall for tens of milliseconds, which made every NTP round trip look longer than
/// the clock filter's 20 ms limit and left every frame unsynchronised.
#[test]
fn ntp_replies_and_frames_in_aligned_sets_out() {
    use nalgebra::{Point3, Vector3};
    use trigait_schema::{FrameTiming, Message, NtpExchange, SkeletonFrameMessage, ports};
    use trigait_skeleton::{Joint, JointSample, SkeletonFrame, TrackingState};

    const PERIOD: i64 = 33_333_333;
    const MS: i64 = 1_000_000;
    let sensors = [("k1", 5 * MS, 0), ("k2", -3 * MS, 11 * MS)];
    let dir = scratch_dir("sync-loop");
    // dora's testing clock starts at `init_node` and delivers each event at its offset from
    // there, while the NTP stamps and captures below are host-clock instants. So the events are
    // planned on a host instant a margin ahead, and `init_node` waits for it: writing the event
    // files (slow on a busy disk) then shifts nothing, where a start taken before writing them
    // made every round trip look too long to trust and every frame unplaceable.
    const MARGIN: i64 = 1_500 * MS;
    const WARM_UP: i64 = 300 * MS;
    let host_start = crate::now_nanos() + MARGIN;
    let secs = |t: i64| (t - host_start) as f64 * 1e-9;
    // Where sensor `k` (0, 1) truly saw the knee at host time `t`: a parabola in x (1.2 m/s²).
    let knee = |k: usize, t: i64| {
        let s = secs(t);
        Point3::new(0.3 + 0.8 * s + 0.6 * s * s, 0.1 * k as f64, 2.0 + 0.2 * s)
    };
    let mut events = Vec::new();
    for (k, (id, offset, _)) in sensors.iter().enumerate() {
        // Eight, so a test machine stalling a few of them past the clock filter's 20 ms delay
        // limit still leaves the four a first fit needs.
        for i in 0..8_i64 {
            let at = WARM_UP + i * 5 * MS + k as i64 * 2 * MS;
            // Sent 1 ms before its delivery, answered 0.5 ms later, 0.1 ms in the sensor.
            let t1 = host_start + at - MS;
            let t2 = t1 + MS / 2 + offset;
            let reply = NtpExchange::request(*id, 1000 + i as u64, t1).answered(t2, t2 + MS / 10);
            events.push(input_event(
                &dir,
                &format!("ntp_{id}_{i}"),
                secs(host_start + at),
                &format!("{}{id}", ports::NTP_INPUT_PREFIX),
                reply.encode().unwrap(),
            ));
        }
    }
    let mut captures = Vec::new();
    for j in 0..7_i64 {
        for (k, (id, offset, phase)) in sensors.iter().enumerate() {
            let capture = host_start + WARM_UP + 60 * MS + j * PERIOD + phase;
            let frame = SkeletonFrame {
                sensor_id: (*id).to_owned(),
                seq: j as u64,
                local_stamp_nanos: capture + offset,
                joints: vec![
                    JointSample {
                        joint: Joint::KneeLeft,
                        position_in_kinect: knee(k, capture),
                        state: TrackingState::Tracked,
                    },
                    JointSample {
                        joint: Joint::AnkleLeft,
                        position_in_kinect: Point3::new(0.1, -0.4, 2.1),
                        state: TrackingState::Inferred,
                    },
                ],
            };
            let mut event = input_event(
                &dir,
                &format!("frame_{id}_{j}"),
                secs(capture + 30 * MS),
                &format!("{}{id}", ports::FRAME_INPUT_PREFIX),
                SkeletonFrameMessage::from(frame).encode().unwrap(),
            );
            event["metadata"] = serde_json::json!({ports::TRUE_STAMP_NANOS: {"Integer": capture}});
            events.push(event);
            captures.push((k, j as u64, capture));
        }
    }
    for i in 0..35 {
        events.push(serde_json::json!(
            {"time_offset_secs": f64::from(i) * 0.02, "type": "Input", "id": "tick", "data": 0}
        ));
    }
    events.push(serde_json::json!({"time_offset_secs": 0.72, "type": "Stop"}));
    let early = host_start - crate::now_nanos();
    assert!(
        early > 0,
        "writing the events took {} ms past the {} ms margin",
        -early / MS,
        MARGIN / MS
    );
    std::thread::sleep(std::time::Duration::from_nanos(early.unsigned_abs()));
    let (node, stream, mut rx) = init_node(
        serde_json::json!({"id": "sync", "events": events}),
        TestingOptions::default(),
    );
    // A deadline well past the 30 ms transport, so a slow test machine cannot make a set go
    // out before its frames are in.
    let config = Config::from_lookup(lookup(&[
        ("LATENCY_DEADLINE_MILLIS", "300"),
        ("FRAME_WAIT_MARGIN_MILLIS", "300"),
    ]))
    .unwrap();
    let counters = crate::run(
        config,
        vec!["k1".into(), "k2".into()],
        crate::NtpRoutes::Broadcast,
        node,
        stream,
    )
    .unwrap();
    let host_end = crate::now_nanos();
    let outputs = drain_outputs(&mut rx);
    assert_eq!((counters.ntp_replies, counters.malformed), (16, 0));
    assert_eq!(counters.frames_dropped, 0, "{counters:?}");

    // NTP requests: on the server clock, alternating sensors, each sensor once per 100 ms on
    // its own phase (k2 half an interval after k1), never before its turn.
    let requests: Vec<NtpExchange> = output_arrays(&outputs, ports::NTP_REQUEST)
        .iter()
        .map(|a| NtpExchange::decode(a.as_ref()).unwrap())
        .collect();
    assert_eq!(requests.len() as u64, counters.ntp_requests);
    assert!(requests.len() >= 4, "{} requests in 0.7 s", requests.len());
    for (i, r) in requests.iter().enumerate() {
        assert_eq!(r.sensor_id, ["k1", "k2"][i % 2], "{requests:?}");
        assert_eq!(r.request_id, i as u64 + 1);
        assert!((host_start..=host_end).contains(&r.t1_nanos));
        assert!(r.t2_nanos.is_none() && r.t3_nanos.is_none() && r.t4_nanos.is_none());
        let turn = i as i64 / 2 * 100 * MS + i as i64 % 2 * 50 * MS;
        assert!(
            r.t1_nanos - requests[0].t1_nanos >= turn - MS,
            "request {i} before its turn: {requests:?}"
        );
    }

    // Frame timings: every frame once, on the server clock within the stated bound.
    let timings: Vec<FrameTiming> = output_arrays(&outputs, ports::FRAME_TIMING)
        .iter()
        .flat_map(|a| FrameTiming::decode_many(a.as_ref()).unwrap())
        .collect();
    assert_eq!(timings.len(), captures.len());
    let mut placed = std::collections::BTreeMap::new();
    for (t, (k, seq, capture)) in timings.iter().zip(&captures) {
        let (id, offset, _) = sensors[*k];
        assert_eq!((t.sensor_id.as_str(), t.seq), (id, *seq));
        assert_eq!(t.local_stamp_nanos, capture + offset);
        assert_eq!(t.true_stamp_nanos, Some(*capture));
        // The frame's joints travel with it, for the recorder's per-sensor view.
        assert_eq!(t.joints.len(), 2, "{t:?}");
        assert_eq!(t.joints[0].joint, Joint::KneeLeft);
        assert_eq!(t.joints[0].position_in_kinect, knee(*k, *capture));
        assert_eq!(t.joints[1].state, TrackingState::Inferred);
        let (server, bound) = (t.server_stamp_nanos.unwrap(), t.uncertainty_nanos.unwrap());
        assert!(
            (server - capture).abs() <= bound && bound < 20 * MS,
            "{id} #{seq}: placed {} ns off, uncertainty {bound} ns",
            server - capture
        );
        assert!((t.offset_nanos.unwrap() - offset).abs() <= bound, "{t:?}");
        placed.insert((id, *seq), (server, bound));
    }

    // Aligned sets.
    let sets: Vec<AlignedSet> = output_arrays(&outputs, ports::ALIGNED_SET)
        .iter()
        .map(|a| AlignedSet::decode(a.as_ref()).unwrap())
        .collect();
    assert_eq!(sets.len() as u64, counters.sets_sent);
    assert_eq!(output_count(&outputs, ports::ALIGNED_SET), sets.len());
    let mut checked = 0;
    for (n, set) in sets.iter().enumerate() {
        assert_eq!(set.seq, n as u64);
        assert_eq!(set.policy, Policy::Interpolate);
        // On the 30 Hz grid from the epoch (instant k at ⌊k·10⁹/30⌋ ns).
        let k = (i128::from(set.stamp_nanos) * 30 + 999_999_999) / 1_000_000_000;
        assert_eq!(i128::from(set.stamp_nanos), k * 1_000_000_000 / 30);
        if n > 0 {
            assert!(set.stamp_nanos > sets[n - 1].stamp_nanos);
        }
        // Only instants inside both sensors' frames are resampled between two of them.
        let around = |id: &'static str| {
            let seqs: Vec<u64> = (0..7).collect();
            let after = seqs
                .iter()
                .position(|s| placed[&(id, *s)].0 > set.stamp_nanos)?;
            Some((seqs[after.checked_sub(1)?], seqs[after]))
        };
        let (Some(a1), Some(a2)) = (around("k1"), around("k2")) else {
            continue;
        };
        assert!(set.missing.is_empty(), "{set:?}");
        for (k, (id, (s0, s1))) in [("k1", a1), ("k2", a2)].into_iter().enumerate() {
            let view = &set.sensors[id];
            assert_eq!(view.frame_seqs, [s0, s1], "{id} at {}", set.stamp_nanos);
            let ((t0, u0), (t1, u1)) = (placed[&(id, s0)], placed[&(id, s1)]);
            let t = set.stamp_nanos;
            let near = if t - t0 <= t1 - t { t0 } else { t1 };
            assert_eq!(view.skew_nanos, near - t);
            let i = view
                .joints
                .iter()
                .position(|s| s.joint == Joint::KneeLeft)
                .unwrap();
            let got = view.joints[i].position_in_kinect;
            let frame_knee = |s: u64| {
                let capture = captures.iter().find(|c| c.0 == k && c.1 == s).unwrap().2;
                knee(k, capture)
            };
            let f = (t - t0) as f64 / (t1 - t0) as f64;
            let chord = frame_knee(s0) + (frame_knee(s1) - frame_knee(s0)) * f;
            assert!((got - chord).norm() < 1e-9, "{id}: {got} vs {chord}");
            let (h0, h1) = ((t - t0) as f64 * 1e-9, (t1 - t) as f64 * 1e-9);
            // A set goes out as soon as a frame after its instant is in, so the estimate has
            // the frame before the pair to work with, or (first pair) possibly nothing.
            match view.interpolation_error_m[i] {
                Some(estimate) => {
                    assert!((estimate - 0.6 * h0 * h1).abs() < 1e-9, "{id}: {estimate}");
                }
                None => assert_eq!(s0, 0, "{id}: no chord error estimate between {s0} and {s1}"),
            }
            // Against where the knee truly was at the instant: off by the clock error (at
            // most the frames' uncertainty) times the speed, plus the chord error.
            let speed = Vector3::new(0.8 + 1.2 * secs(t), 0.0, 0.2).norm();
            let allowed = speed * u0.max(u1) as f64 * 1e-9 + 0.6 * h0 * h1 + 1e-9;
            let off = (got - knee(k, t)).norm();
            assert!(off <= allowed, "{id}: {off} m off, allowed {allowed}");
        }
        checked += 1;
    }
    assert!(
        checked >= 4,
        "{checked} sets between frames of {}",
        sets.len()
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// The sources' last frames and their `InputClosed` come at the same instant, and `sync` ends
/// its run on the last close: every frame is still taken in (none is synchronised here, so
/// each is counted as dropped by the buffer) and timed. dora's testing daemon hands the events
/// over one at a time, in order, so the scheduler's reordering of a real run (the closes
/// first) is tested in `order`.
#[test]
fn frames_queued_before_the_closes_are_taken_in() {
    use trigait_schema::{FrameTiming, Message, SkeletonFrameMessage, ports};
    use trigait_skeleton::SkeletonFrame;

    const FRAMES: u64 = 20;
    let dir = scratch_dir("sync-closes");
    let mut events = Vec::new();
    for seq in 0..FRAMES {
        for id in ["k1", "k2"] {
            let frame = SkeletonFrame {
                sensor_id: id.to_owned(),
                seq,
                local_stamp_nanos: 1_000_000_000 + seq as i64 * 33_333_333,
                joints: Vec::new(),
            };
            events.push(input_event(
                &dir,
                &format!("frame_{id}_{seq}"),
                0.05,
                &format!("{}{id}", ports::FRAME_INPUT_PREFIX),
                SkeletonFrameMessage::from(frame).encode().unwrap(),
            ));
        }
    }
    for id in ["k1", "k2"] {
        events.push(serde_json::json!(
            {"time_offset_secs": 0.05, "type": "InputClosed",
             "id": format!("{}{id}", ports::FRAME_INPUT_PREFIX)}
        ));
    }
    let (node, stream, mut rx) = init_node(
        serde_json::json!({"id": "sync", "events": events}),
        TestingOptions::default(),
    );
    let counters = crate::run(
        Config::from_lookup(lookup(&[])).unwrap(),
        vec!["k1".into(), "k2".into()],
        crate::NtpRoutes::Broadcast,
        node,
        stream,
    )
    .unwrap();
    assert_eq!(counters.frames_dropped, 2 * FRAMES, "{counters:?}");
    let timings = output_arrays(&drain_outputs(&mut rx), ports::FRAME_TIMING)
        .iter()
        .flat_map(|a| FrameTiming::decode_many(a.as_ref()).unwrap())
        .count();
    assert_eq!(timings as u64, 2 * FRAMES);
    std::fs::remove_dir_all(&dir).ok();
}
