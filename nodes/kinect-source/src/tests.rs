//! `kinect-source` contracts: configuration errors name the node, the variable and the value;
//! the simulated sensor captures on its own 30 Hz grid with its own clock and covers the
//! ground truth without holes; replay reads both SDK formats; the event loop answers only the
//! NTP requests addressed to it and skips malformed input.

use dora_node_api::integration_testing::{TestingOptions, drain_outputs};
use dora_node_api::serde_json;
use trigait_node_testing::{
    arrow_file, chain, init_node, input_event, lookup, output_arrays, output_count, scratch_dir,
};
use trigait_schema::{GroundTruth, Message, NtpExchange, SkeletonFrameMessage};

use crate::backend::{Source, sensor_clock};
use crate::config::{Backend, Config};
use trigait_sim::stream::TRUTH_STEP_NANOS;
use trigait_skeleton::{Joint, JointSample};

/// Only SENSOR_ID is required; the defaults are the thesis rig, the simulator and 30 Hz.
#[test]
fn config_defaults() {
    let c = Config::from_lookup(lookup(&[("SENSOR_ID", "k2")])).unwrap();
    assert_eq!(c.sensor_id, "k2");
    assert_eq!(c.rig.name, "thesis");
    assert_eq!(c.clock_step, None);
    assert!(matches!(c.backend, Backend::Sim { .. }));
    assert_eq!(c.period_nanos(), 33_333_333);
    assert_eq!(c.frame_phase_nanos, None);
}

/// Every configuration error names the node, the variable and the raw value.
#[test]
fn config_errors_name_node_key_and_value() {
    let err = Config::from_lookup(lookup(&[])).unwrap_err();
    assert!(
        chain(&err).contains("kinect-source: SENSOR_ID"),
        "{}",
        chain(&err)
    );
    for (key, raw) in [
        ("BACKEND", "kinect1"),
        ("CLOCK_DRIFT_PPM", "fast"),
        ("FRAME_RATE_HZ", "0"),
        ("JOINTS", "arms"),
        ("REPLAY_SPEED", "slow"),
        ("RIG", "/no/such/rig.yml"),
        ("CLOCK_STEP_AT_SECS", "-1"),
        ("CLOCK_STEP_MILLIS", "1e12"),
        ("LANE_M", "-1"),
        ("LANE_M", "wide"),
    ] {
        let mut pairs = vec![("SENSOR_ID", "k1"), (key, raw)];
        if key == "REPLAY_SPEED" {
            pairs.extend([("BACKEND", "replay"), ("REPLAY_FILE", "x.txt")]);
        }
        if key.starts_with("CLOCK_STEP") {
            pairs.extend([("CLOCK_STEP_AT_SECS", "5"), ("CLOCK_STEP_MILLIS", "1000")]);
        }
        let err = Config::from_lookup(lookup(&pairs)).unwrap_err();
        let text = chain(&err);
        assert!(
            text.contains("kinect-source") && text.contains(key),
            "{text}"
        );
        assert!(text.contains(raw), "{text}");
    }
}

/// A clock step needs both its keys; alone, either one is an error naming both.
#[test]
fn clock_step_needs_both_keys() {
    for (key, other) in [
        ("CLOCK_STEP_AT_SECS", "CLOCK_STEP_MILLIS"),
        ("CLOCK_STEP_MILLIS", "CLOCK_STEP_AT_SECS"),
    ] {
        let err = Config::from_lookup(lookup(&[("SENSOR_ID", "k1"), (key, "3")])).unwrap_err();
        let text = chain(&err);
        assert!(
            text.contains("kinect-source") && text.contains(key) && text.contains(other),
            "{text}"
        );
    }
}

/// `CLOCK_STEP_AT_SECS=0.5`, `CLOCK_STEP_MILLIS=1000`: frames captured before half a second
/// after the start carry the unstepped clock, those after it read 1 s later; the true capture
/// instant is unchanged.
#[test]
fn clock_step_moves_the_stamps() {
    let c = Config::from_lookup(lookup(&[
        ("SENSOR_ID", "k1"),
        ("CLOCK_OFFSET_MILLIS", "7"),
        ("CLOCK_JITTER_MICROS", "0"),
        ("CLOCK_STEP_AT_SECS", "0.5"),
        ("CLOCK_STEP_MILLIS", "1000"),
    ]))
    .unwrap();
    let start = 1_700_000_000_000_000_000;
    let mut source = Source::new(&c, start).unwrap();
    let mut clock = sensor_clock(&c, start);
    let (mut before, mut after) = (0, 0);
    for _ in 0..30 {
        let due = source.next_due().unwrap();
        let cap = source.capture(due, &mut clock).unwrap();
        let off = cap.frame.local_stamp_nanos - cap.true_stamp_nanos.unwrap();
        if due - start < 500_000_000 {
            assert_eq!(off, 7_000_000, "before the step");
            before += 1;
        } else {
            assert_eq!(off, 1_007_000_000, "after the step");
            after += 1;
        }
    }
    assert!(
        before >= 14 && after >= 14,
        "{before} before, {after} after"
    );
}

/// A sensor id the rig lacks and an unreadable replay file are fatal and say which key.
#[test]
fn backend_errors_name_the_key() {
    let c = Config::from_lookup(lookup(&[("SENSOR_ID", "k9")])).unwrap();
    let err = Source::new(&c, 0).unwrap_err();
    assert!(chain(&err).contains("SENSOR_ID=\"k9\""), "{}", chain(&err));
    let c = Config::from_lookup(lookup(&[
        ("SENSOR_ID", "k1"),
        ("BACKEND", "replay"),
        ("REPLAY_FILE", "/nonexistent/skeleton.txt"),
    ]))
    .unwrap();
    let err = Source::new(&c, 0).unwrap_err();
    assert!(
        chain(&err).contains("REPLAY_FILE=/nonexistent/skeleton.txt"),
        "{}",
        chain(&err)
    );
    let err = Config::from_lookup(lookup(&[("SENSOR_ID", "k1"), ("RIG", "/no/such/rig.yml")]))
        .unwrap_err();
    assert!(
        chain(&err).contains("kinect-source: RIG="),
        "{}",
        chain(&err)
    );
}

/// Without the cargo feature, `freenect2` is a clear error, not a silent stub.
#[test]
fn freenect2_without_the_feature_is_an_error() {
    let c = Config::from_lookup(lookup(&[("SENSOR_ID", "k1"), ("BACKEND", "freenect2")])).unwrap();
    let text = chain(&Source::new(&c, 0).unwrap_err());
    if cfg!(feature = "freenect2") {
        // The feature's backend runs its own loop (`freenect2::run`), never as a `Source`.
        assert!(text.contains("its own event loop"), "{text}");
    } else {
        assert!(text.contains("not built with freenect2"), "{text}");
    }
}

/// Simulated captures: 30 Hz on the sensor's phase, stamped by its clock (offset applied),
/// leg joints in the camera frame; `GROUND_TRUTH=true` makes the second sensor send the ground
/// truth every 2 ms with no hole or overlap (by default only the rig's first does).
#[test]
fn simulated_captures() {
    let c = Config::from_lookup(lookup(&[
        ("SENSOR_ID", "k2"),
        ("CLOCK_OFFSET_MILLIS", "-40"),
        ("CLOCK_JITTER_MICROS", "0"),
        ("GROUND_TRUTH", "true"),
    ]))
    .unwrap();
    let start = 1_700_000_000_000_000_000;
    let mut source = Source::new(&c, start).unwrap();
    let mut clock = sensor_clock(&c, start);
    let mut last_truth = None;
    let mut due_prev = None;
    for _ in 0..20 {
        let due = source.next_due().unwrap();
        // Sensor 2 of 3: phase a third of a period.
        assert_eq!((due - 11_111_111).rem_euclid(33_333_333), 0, "{due}");
        if let Some(p) = due_prev {
            assert_eq!(due - p, 33_333_333);
        }
        due_prev = Some(due);
        let cap = source.capture(due, &mut clock).unwrap();
        assert_eq!(cap.true_stamp_nanos, Some(due));
        assert_eq!(cap.frame.local_stamp_nanos - due, -40_000_000);
        assert!(cap.frame.joints.len() >= 4, "{:?}", cap.frame.joints);
        for row in &cap.truth {
            if let Some(l) = last_truth {
                assert_eq!(row.true_stamp_nanos - l, TRUTH_STEP_NANOS);
            }
            last_truth = Some(row.true_stamp_nanos);
            assert_eq!(row.position_in_world.len(), 6);
        }
        assert!(last_truth.unwrap() <= due && due - last_truth.unwrap() < TRUTH_STEP_NANOS);
    }
}

/// Replay plays the real SDK recordings (76- and 201-column layouts) and loops.
#[test]
fn replay_both_formats() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/data/kinect-v2-skeleton-replay");
    for (file, frames) in [
        ("JointsInfo_Straight.txt", 85),
        ("JointsInfo_Cyrille_v2_2.txt", 970),
    ] {
        let path = dir.join(file);
        let c = Config::from_lookup(lookup(&[
            ("SENSOR_ID", "k1"),
            ("BACKEND", "replay"),
            ("REPLAY_SPEED", "fast"),
            ("REPLAY_FILE", path.to_str().unwrap()),
        ]))
        .unwrap();
        let mut source = Source::new(&c, 0).unwrap();
        let mut clock = sensor_clock(&c, 0);
        let mut seqs = Vec::new();
        for i in 0..frames + 2 {
            let cap = source.capture(i, &mut clock).unwrap();
            assert!(!cap.frame.joints.is_empty());
            assert!(cap.truth.is_empty() && cap.true_stamp_nanos.is_none());
            seqs.push(cap.frame.seq);
        }
        assert_eq!(seqs.len(), frames as usize + 2, "looped past the end");
    }
}

/// A replayed walk away from the sensor comes out with left and right swapped back: the
/// Straight log's first half second, where its pelvis moves away (its depth grows), and only
/// there.
#[test]
fn replay_swaps_sides_back_walking_away() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/data/kinect-v2-skeleton-replay/JointsInfo_Straight.txt");
    let raw = trigait_motion::read_sdk_skeletons(&path).unwrap();
    let c = Config::from_lookup(lookup(&[
        ("SENSOR_ID", "k1"),
        ("BACKEND", "replay"),
        ("REPLAY_SPEED", "fast"),
        ("REPLAY_LOOP", "false"),
        ("REPLAY_FILE", path.to_str().unwrap()),
    ]))
    .unwrap();
    let mut source = Source::new(&c, 0).unwrap();
    let mut clock = sensor_clock(&c, 0);
    let at = |joints: &[JointSample], joint: Joint| {
        joints
            .iter()
            .find(|s| s.joint == joint)
            .map(|s| s.position_in_kinect)
    };
    let pelvis_depth = |f: usize| at(&raw[f].joints, Joint::SpineBase).unwrap().z;
    let mut swapped = Vec::new();
    for (f, recorded) in raw.iter().enumerate() {
        let cap = source.capture(f as i64, &mut clock).unwrap();
        let (left, right) = (Joint::HipLeft, Joint::HipRight);
        if at(&cap.frame.joints, left) == at(&recorded.joints, right) {
            assert_eq!(
                at(&cap.frame.joints, right),
                at(&recorded.joints, left),
                "frame {f}"
            );
            swapped.push(f);
        } else {
            assert_eq!(cap.frame.joints, recorded.joints, "frame {f}");
        }
    }
    assert!(source.capture(raw.len() as i64, &mut clock).is_none());
    assert!(swapped.len() >= 10, "{swapped:?}");
    for &f in &swapped {
        let (a, b) = (f.saturating_sub(3), (f + 3).min(raw.len() - 1));
        assert!(
            pelvis_depth(b) > pelvis_depth(a),
            "frame {f} swapped while walking towards the sensor: {swapped:?}"
        );
    }
}

/// The event loop: frames go out at 30 Hz while it waits, the NTP request for this sensor is
/// answered with t2 ≤ t3 on the sensor clock, one for another sensor is ignored, and a
/// malformed request is counted and skipped.
#[test]
fn event_loop_answers_own_ntp_requests() {
    let dir = scratch_dir("kinect-source-test");
    let mine = arrow_file(
        &dir,
        "mine",
        NtpExchange::request("k1", 7, 1_000).encode().unwrap(),
    );
    let other = arrow_file(
        &dir,
        "other",
        NtpExchange::request("k3", 8, 1_000).encode().unwrap(),
    );
    let (node, events, mut rx) = init_node(
        serde_json::json!({
            "id": "k1",
            "events": [
                {"time_offset_secs": 0.05, "type": "Input", "id": "ntp_request", "path": mine, "column": "msg"},
                {"time_offset_secs": 0.06, "type": "Input", "id": "ntp_request", "path": other, "column": "msg"},
                {"time_offset_secs": 0.07, "type": "Input", "id": "ntp_request", "data": [1, 2, 3]},
                {"time_offset_secs": 0.30, "type": "Stop"}
            ]
        }),
        TestingOptions {
            skip_output_time_offsets: true,
        },
    );
    let c = Config::from_lookup(lookup(&[
        ("SENSOR_ID", "k1"),
        ("CLOCK_OFFSET_MILLIS", "20"),
    ]))
    .unwrap();
    let source = Source::new(&c, crate::backend::now_nanos()).unwrap();
    let counters = crate::run(c, source, node, events).unwrap();
    assert_eq!(counters.ntp_answered, 1);
    assert_eq!(counters.malformed, 1);
    assert!(counters.frames_sent >= 5, "{counters:?}");
    let outputs = drain_outputs(&mut rx);
    let count = |id: &str| output_count(&outputs, id);
    assert_eq!(count("ntp_reply"), 1);
    assert_eq!(count("frame") as u64, counters.frames_sent);
    assert!(count("ground_truth") >= 4);
    std::fs::remove_dir_all(&dir).ok();
}

/// The loop's happy path for the simulated k1 (clock 20 ms ahead, no jitter): each
/// `ntp_request` addressed to it comes back on `ntp_reply` with its id and t1, and t2 ≤ t3
/// read on the sensor clock (host time of arrival + 20 ms); frames carry `k1`, seq 0, 1, 2, …
/// and sensor stamps 20 ms ahead of the 30 Hz grid (k1's phase is 0); their joints are in
/// k1's camera space: mapped through the thesis rig's pose of k1 they land within a few
/// centimetres (the Kinect noise model) of the ground truth at the capture instant, and
/// through another sensor's pose decimetres to metres away; k1, the rig's first sensor, sends that ground truth on
/// `ground_truth` every 2 ms without a hole, up to the last capture.
#[test]
fn ntp_requests_in_replies_frames_and_truth_out() {
    use trigait_skeleton::TrackingState;
    const OFFSET: i64 = 20_000_000;
    const PERIOD: i64 = 33_333_333;
    let dir = scratch_dir("kinect-source-loop");
    let (first, second) = (
        NtpExchange::request("k1", 7, 111),
        NtpExchange::request("k1", 9, 222),
    );
    let events = serde_json::json!([
        input_event(&dir, "first", 0.05, "ntp_request", first.encode().unwrap()),
        input_event(&dir, "second", 0.15, "ntp_request", second.encode().unwrap()),
        {"time_offset_secs": 0.30, "type": "Stop"}
    ]);
    let host_start = crate::backend::now_nanos();
    let (node, events, mut rx) = init_node(
        serde_json::json!({"id": "k1", "events": events}),
        TestingOptions::default(),
    );
    let c = Config::from_lookup(lookup(&[
        ("SENSOR_ID", "k1"),
        ("CLOCK_OFFSET_MILLIS", "20"),
        ("CLOCK_JITTER_MICROS", "0"),
    ]))
    .unwrap();
    let source = Source::new(&c, crate::backend::now_nanos()).unwrap();
    let counters = crate::run(c, source, node, events).unwrap();
    let host_end = crate::backend::now_nanos();
    let outputs = drain_outputs(&mut rx);

    // NTP: both answered, in order, on the sensor clock.
    assert_eq!(counters.ntp_answered, 2);
    let replies: Vec<NtpExchange> = output_arrays(&outputs, "ntp_reply")
        .iter()
        .map(|a| NtpExchange::decode(a.as_ref()).unwrap())
        .collect();
    assert_eq!(replies.len(), 2);
    for (reply, (request, sent_secs)) in replies.iter().zip([(&first, 0.05), (&second, 0.15)]) {
        assert_eq!(
            (reply.sensor_id.as_str(), reply.request_id, reply.t1_nanos),
            ("k1", request.request_id, request.t1_nanos)
        );
        assert_eq!(reply.t4_nanos, None, "t4 is sync's to fill in");
        let (t2, t3) = (reply.t2_nanos.unwrap(), reply.t3_nanos.unwrap());
        assert!(t2 <= t3 && t3 - t2 < 50_000_000, "t2 {t2}, t3 {t3}");
        let arrived = host_start + (sent_secs * 1e9) as i64;
        assert!(
            (arrived..=host_end).contains(&(t2 - OFFSET)),
            "t2 − 20 ms = {} is not between the request's delivery ({arrived}) and the end ({host_end})",
            t2 - OFFSET
        );
    }

    // Frames: k1, consecutive seqs, the sensor clock on k1's grid.
    let frames: Vec<_> = output_arrays(&outputs, "frame")
        .iter()
        .map(|a| SkeletonFrameMessage::decode(a.as_ref()).unwrap().frame)
        .collect();
    assert_eq!(frames.len() as u64, counters.frames_sent);
    assert!(frames.len() >= 6, "{} frames in 0.3 s", frames.len());
    for (i, f) in frames.iter().enumerate() {
        assert_eq!((f.sensor_id.as_str(), f.seq), ("k1", i as u64));
        let capture = f.local_stamp_nanos - OFFSET;
        assert_eq!(capture.rem_euclid(PERIOD), 0, "{capture} is off k1's grid");
        assert!(
            (host_start - PERIOD..=host_end).contains(&capture),
            "{capture}"
        );
        if i > 0 {
            assert_eq!(
                f.local_stamp_nanos - frames[i - 1].local_stamp_nanos,
                PERIOD
            );
        }
    }

    // Ground truth: every 2 ms, no hole, up to the last capture.
    let truth: Vec<GroundTruth> = output_arrays(&outputs, "ground_truth")
        .iter()
        .flat_map(|a| GroundTruth::decode_many(a.as_ref()).unwrap())
        .collect();
    assert_eq!(output_count(&outputs, "ground_truth"), frames.len());
    for pair in truth.windows(2) {
        assert_eq!(
            pair[1].true_stamp_nanos - pair[0].true_stamp_nanos,
            TRUTH_STEP_NANOS
        );
    }
    let last_capture = frames.last().unwrap().local_stamp_nanos - OFFSET;
    let last_truth = truth.last().unwrap().true_stamp_nanos;
    assert!(last_truth <= last_capture && last_capture - last_truth < TRUTH_STEP_NANOS);

    // Camera space: the frame's joints through k1's pose are the truth at the capture
    // instant (interpolated between its 2 ms rows), up to the sensor noise.
    let rig = trigait_rig::Rig::from_spec("thesis").unwrap();
    let truth_at = |t: i64, joint| -> Option<_> {
        let i = truth.partition_point(|r| r.true_stamp_nanos <= t);
        let (a, b) = (truth.get(i.checked_sub(1)?)?, truth.get(i)?);
        let f = (t - a.true_stamp_nanos) as f64 / (b.true_stamp_nanos - a.true_stamp_nanos) as f64;
        let (pa, pb) = (
            a.position_in_world.get(&joint)?,
            b.position_in_world.get(&joint)?,
        );
        Some(pa + (pb - pa) * f)
    };
    let median_error = |sensor: usize| {
        let pose = rig.sensors[sensor].world_from_kinect;
        let mut errors: Vec<f64> = frames
            .iter()
            .flat_map(|f| {
                let t = f.local_stamp_nanos - OFFSET;
                f.joints
                    .iter()
                    .filter(|s| s.state == TrackingState::Tracked)
                    .filter_map(move |s| {
                        let truth = truth_at(t, s.joint)?;
                        Some((pose * s.position_in_kinect - truth).norm())
                    })
                    .collect::<Vec<_>>()
            })
            .collect();
        assert!(errors.len() >= 20, "{} joints compared", errors.len());
        errors.sort_by(f64::total_cmp);
        errors[errors.len() / 2]
    };
    // Measured: 2.7–4.7 cm through k1's pose; through k2's or k3's, 0.24–3.4 m depending on
    // where the walk is, so the farther of the two is the contrast.
    let own = median_error(0);
    let other = median_error(1).max(median_error(2));
    assert!(
        own < 0.08,
        "through k1's pose: median {own} m from the truth"
    );
    assert!(
        other > 0.4,
        "through k2's or k3's pose: median {other} m at most"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// `BACKEND: recording` needs `RECORDING`; a cut-off recording and one without the sensor are
/// errors naming the file (and the line, or the sensors it has); a good one plays the
/// sensor's frames with their recorded placement.
#[test]
fn recording_backend_errors_and_plays() {
    let err =
        Config::from_lookup(lookup(&[("SENSOR_ID", "k1"), ("BACKEND", "recording")])).unwrap_err();
    assert!(
        chain(&err).contains("RECORDING is required"),
        "{}",
        chain(&err)
    );
    let dir = scratch_dir("recording-backend");
    let mut text = format!("{}\n", trigait_recording::FRAMES_HEADER);
    text.push_str(
        "k1,0,100,90,5,,,,95,knee_left,0.1,0.2,3,2\nk1,1,133,123,5,,,,128,knee_left,0.1,0.2,3,2\n",
    );
    let good = dir.join("frames.csv");
    std::fs::write(&good, &text).unwrap();
    let cut = dir.join("cut.csv");
    std::fs::write(&cut, &text[..text.len() - 3]).unwrap();
    let config = |sensor: &str, file: &std::path::Path| {
        let file = file.display().to_string();
        Config::from_lookup(lookup(&[
            ("SENSOR_ID", sensor),
            ("BACKEND", "recording"),
            ("RECORDING", file.as_str()),
            ("REPLAY_SPEED", "fast"),
        ]))
        .unwrap()
    };
    let err = Source::new(&config("k1", &cut), 0).unwrap_err();
    assert!(chain(&err).contains("cut.csv:3:"), "{}", chain(&err));
    let err = Source::new(&config("k2", &good), 0).unwrap_err();
    assert!(
        chain(&err).contains("the recording has k1"),
        "{}",
        chain(&err)
    );
    let header_only = dir.join("header.csv");
    let header = text.lines().next().unwrap();
    std::fs::write(&header_only, format!("{header}\n")).unwrap();
    let err = Source::new(&config("k1", &header_only), 0).unwrap_err();
    assert!(chain(&err).contains("holds no frames"), "{}", chain(&err));
    let c = config("k1", &good);
    let mut source = Source::new(&c, 0).unwrap();
    source.receiver_ready(0);
    let mut clock = sensor_clock(&c, 0);
    let first = source.capture(0, &mut clock).unwrap();
    assert_eq!(first.frame.local_stamp_nanos, 100);
    assert_eq!(first.recorded.map(|r| r.server_stamp_nanos), Some(Some(90)));
    assert_eq!(first.recorded.map(|r| r.received_nanos), Some(Some(95)));
}

/// The dataflow's id gives the instant it was made: the first 48 bits of a version-7 UUID are
/// Unix milliseconds (this id is one `dora run` made); another version gives none.
#[test]
fn the_dataflow_id_tells_when_it_was_made() {
    use dora_node_api::uuid::Uuid;
    let v7 = Uuid::parse_str("01a24f3a-48a7-7a90-b675-8c22e9ab4e93").unwrap();
    assert_eq!(crate::made_at_nanos(&v7), Some(1_796_625_549_479_000_000));
    let v4 = Uuid::parse_str("9b2c4d1e-7f3a-4c2b-8d1e-2f3a4b5c6d7e").unwrap();
    assert_eq!(crate::made_at_nanos(&v4), None);
}
