//! `leg-tracker` contracts: configuration errors name node, key and value; depth frames of the
//! rendered walker come out as skeleton frames of the same sensor, seq and stamp with the legs
//! where the body was; malformed, misrouted, wrong-sized and empty frames are counted, never
//! fatal.

use dora_node_api::integration_testing::{TestingOptions, drain_outputs};
use dora_node_api::serde_json;
use trigait_body_render::{BodyShape, RenderParams, Renderer, Room};
use trigait_node_testing::{chain, init_node, input_event, lookup, output_arrays, scratch_dir};
use trigait_schema::{DepthFrameMessage, Message, SkeletonFrameMessage};
use trigait_skeleton::{Joint, TrackingState};

use crate::config::{Config, FloorSource};

/// Defaults: the floor from the rig pose, unmirrored images; `FLOOR=fit` drops the floor.
#[test]
fn config_defaults() {
    let c = Config::from_lookup(lookup(&[("SENSOR_ID", "k2")])).unwrap();
    assert_eq!(c.sensor_id, "k2");
    assert_eq!(c.rig.name, "thesis");
    assert!(!c.tracker.camera.mirrored);
    let floor = c.tracker.floor.unwrap();
    let pose = c.rig.sensors[1].world_from_kinect;
    assert!((floor.camera_height_m - pose.translation.vector.z).abs() < 1e-12);
    let c = Config::from_lookup(lookup(&[
        ("SENSOR_ID", "k1"),
        ("FLOOR", "fit"),
        ("MIRRORED", "yes"),
    ]))
    .unwrap();
    assert!(c.tracker.floor.is_none() && c.tracker.camera.mirrored);
    assert!(c.rerun.is_none());
    let c = Config::from_lookup(lookup(&[("SENSOR_ID", "k3"), ("RERUN", "rrd")])).unwrap();
    assert_eq!(
        c.rerun,
        Some(trigait_depth_rerun::Sink::File("out/legs-k3.rrd".into()))
    );
    assert_eq!("rig".parse(), Ok(FloorSource::Rig));
}

/// A missing or unknown sensor, a bad rig, floor source or flag: errors start with the node
/// and name the key and the value.
#[test]
fn config_errors_name_node_key_and_value() {
    let text = chain(&Config::from_lookup(lookup(&[])).unwrap_err());
    assert!(
        text.starts_with("leg-tracker: SENSOR_ID is required"),
        "{text}"
    );
    let text = chain(&Config::from_lookup(lookup(&[("SENSOR_ID", "k9")])).unwrap_err());
    assert!(
        text.starts_with("leg-tracker: SENSOR_ID=\"k9\" is not in the rig \"thesis\""),
        "{text}"
    );
    assert!(text.contains("k1, k2, k3"), "{text}");
    for (key, value) in [
        ("FLOOR", "ceiling"),
        ("MIRRORED", "maybe"),
        ("RERUN", "yes"),
        ("RIG", "/nonexistent/rig.yml"),
    ] {
        let text =
            chain(&Config::from_lookup(lookup(&[("SENSOR_ID", "k1"), (key, value)])).unwrap_err());
        assert!(
            text.starts_with(&format!("leg-tracker: {key}={value:?}")),
            "{text}"
        );
    }
}

/// The loop, end to end under dora's testing tier: 24 rendered frames of the walker seen by
/// thesis-rig sensor k1, with a malformed message, a frame of k2, a 640×480 frame and an
/// all-zero frame among them. Every k1 frame of the right size comes out once, in order, with
/// its seq and stamp; the zero frame without joints; the rest counted and skipped. Once the
/// tracker has the person, the hips, knees and ankles it reports lie within 6 cm (median;
/// 90 % within 20 cm while it still learns the lengths) of the rendered joint centres: a check
/// of the wiring (a mixed-up seq, sensor or camera convention is metres off). Measured: median
/// 3.0 cm, 90th percentile 12.8 cm. The accuracy after learning is the tracker crate's test.
/// With `RERUN` set, the masks and fitted legs go to an `.rrd`.
#[test]
fn depth_frames_in_skeleton_frames_out() {
    let dir = scratch_dir("leg-tracker-loop");
    let rrd = dir.join("legs.rrd");
    let config = Config::from_lookup(lookup(&[
        ("SENSOR_ID", "k1"),
        ("RERUN", rrd.to_str().unwrap()),
    ]))
    .unwrap();
    let pose = config.rig.sensors[0].world_from_kinect;
    let clip = trigait_motion::walker(&trigait_motion::WalkerParams::default(), 3.0, 100.0)
        .unwrap()
        .placed_on_walkway();
    let mut renderer = Renderer::new(RenderParams::default(), &pose, &Room::default()).unwrap();
    let mut events = Vec::new();
    let mut truths = Vec::new();
    let message = |seq: u64, sensor: &str, w: u32, h: u32, depth_mm: Vec<u16>| DepthFrameMessage {
        sensor_id: sensor.into(),
        seq,
        local_stamp_nanos: 5_000_000_000 + seq as i64 * 33_333_333,
        width: w,
        height: h,
        depth_mm,
    };
    let mut t = 0.0;
    let mut push = |events: &mut Vec<serde_json::Value>, name: &str, m: DepthFrameMessage| {
        events.push(input_event(&dir, name, t, "depth", m.encode().unwrap()));
        t += 0.003;
    };
    for seq in 0..24_u64 {
        let at = 0.5 + seq as f64 / 30.0;
        let r = renderer
            .render_pose(&BodyShape::default(), |j| clip.position_at(j, at))
            .unwrap();
        truths.push(r.joints_in_kinect.clone());
        push(
            &mut events,
            &format!("f{seq}"),
            message(seq, "k1", 512, 424, r.depth.as_mm().to_vec()),
        );
        if seq == 10 {
            push(
                &mut events,
                "k2",
                message(seq, "k2", 512, 424, r.depth.as_mm().to_vec()),
            );
            push(
                &mut events,
                "vga",
                message(seq, "k1", 640, 480, vec![1000; 640 * 480]),
            );
        }
    }
    push(
        &mut events,
        "zeros",
        message(24, "k1", 512, 424, vec![0; 512 * 424]),
    );
    events.push(serde_json::json!({"time_offset_secs": t, "type": "Input", "id": "depth", "data": [1, 2, 3]}));
    events.push(serde_json::json!({"time_offset_secs": t + 0.01, "type": "Stop"}));
    let (node, events, mut rx) = init_node(
        serde_json::json!({"id": "legs_k1", "events": events}),
        TestingOptions::default(),
    );
    let counters = crate::run(config, node, events).unwrap();
    assert_eq!(
        (
            counters.frames_sent,
            counters.malformed,
            counters.wrong_sensor,
            counters.wrong_size
        ),
        (25, 1, 1, 1),
        "{counters:?}"
    );
    assert_eq!(counters.by_status.get("no_data"), Some(&1), "{counters:?}");
    let out: Vec<_> = output_arrays(&drain_outputs(&mut rx), "frame")
        .iter()
        .map(|a| SkeletonFrameMessage::decode(a.as_ref()).unwrap().frame)
        .collect();
    assert_eq!(out.len(), 25);
    let mut errors = Vec::new();
    for (seq, frame) in out.iter().enumerate() {
        assert_eq!(frame.sensor_id, "k1");
        assert_eq!(frame.seq, seq as u64);
        assert_eq!(
            frame.local_stamp_nanos,
            5_000_000_000 + seq as i64 * 33_333_333
        );
        if seq == 24 {
            assert!(frame.joints.is_empty(), "all zeros: {:?}", frame.joints);
            continue;
        }
        if seq < 3 {
            continue;
        }
        for joint in [
            Joint::HipLeft,
            Joint::HipRight,
            Joint::KneeLeft,
            Joint::KneeRight,
            Joint::AnkleLeft,
            Joint::AnkleRight,
        ] {
            let sample = frame
                .joint(joint)
                .unwrap_or_else(|| panic!("seq {seq}: no {joint:?}"));
            assert_ne!(sample.state, TrackingState::NotTracked);
            let truth = truths[seq].iter().find(|(j, _)| *j == joint).unwrap().1;
            errors.push((sample.position_in_kinect - truth).norm());
        }
    }
    // With RERUN set, the masks and fitted legs were logged.
    assert!(std::fs::metadata(&rrd).unwrap().len() > 10_000);
    errors.sort_by(f64::total_cmp);
    let median = errors[errors.len() / 2];
    let worst = errors[errors.len() * 9 / 10];
    eprintln!(
        "median {median:.3} m, 90th percentile {worst:.3} m over {} joints",
        errors.len()
    );
    assert!(
        median < 0.06 && worst < 0.20,
        "median {median:.3} m, p90 {worst:.3} m"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// A frame's stamped pinhole (`trigait.depth_pinhole`) becomes the tracker's camera, once,
/// with the principal point moved into the tracker camera's pixel-centre convention (the same
/// rays); an unstamped frame is the configured camera.
#[test]
fn stamped_pinhole_is_the_trackers_camera() {
    let mut tracker =
        trigait_leg_tracker::LegTracker::new(trigait_leg_tracker::TrackerConfig::default())
            .unwrap();
    let configured = tracker.config().camera.intrinsics;
    let plain = dora_node_api::MetadataParameters::default();
    let nominal = crate::frame_camera(&configured, &plain);
    assert_eq!(nominal, configured);
    assert!(!crate::use_camera(&mut tracker, nominal).unwrap());
    let k = [365.456, 365.456, 254.878, 205.395];
    let mut stamped = dora_node_api::MetadataParameters::default();
    stamped.insert(
        trigait_schema::ports::DEPTH_PINHOLE.to_owned(),
        trigait_node_config::pinhole_parameter(k),
    );
    let camera = crate::frame_camera(&configured, &stamped);
    assert!(crate::use_camera(&mut tracker, camera).unwrap());
    let used = tracker.config().camera.intrinsics;
    assert_eq!(
        (used.fx, used.fy, used.width, used.height),
        (k[0], k[1], 512, 424)
    );
    // Pixel (10, 20) looks along the stamped pinhole's ray of pixel index (10, 20).
    let lens = trigait_depth::Intrinsics::pinhole(k[0], k[1], k[2], k[3]);
    let (x, y) = used.pixel_ray(10, 20);
    let (xo, yo) = lens.ray_opencv(10.0, 20.0);
    assert!(
        (x + xo).abs() < 1e-12 && (y + yo).abs() < 1e-12,
        "{x} {y} vs {xo} {yo}"
    );
    assert!(!crate::use_camera(&mut tracker, camera).unwrap());
    assert!(crate::use_camera(&mut tracker, nominal).unwrap());
}
