//! `sync` contracts: the policy and its knobs come from YAML with errors naming node, key and
//! value; the sensor set comes from the graph's inputs; bad input is counted, never fatal.

use dora_node_api::integration_testing::{TestingOptions, drain_outputs};
use dora_node_api::serde_json;
use trigait_node_testing::{chain, init_node, lookup};
use trigait_sync::Policy;

use crate::config::Config;

/// Defaults: interpolate at 30 Hz, 100 ms deadline, NTP every 100 ms, sensors from inputs.
#[test]
fn config_defaults_and_policy() {
    let c = Config::from_lookup(lookup(&[])).unwrap();
    assert_eq!(c.params.policy, Policy::Interpolate);
    assert_eq!(c.params.latency_deadline_nanos, 100_000_000);
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
}

/// An unknown policy (or interpolation, or a bad number) stops the node with its key named.
#[test]
fn config_errors_name_node_key_and_value() {
    for (key, raw) in [
        ("POLICY", "round-robin"),
        ("INTERPOLATION", "spline"),
        ("FUSION_RATE_HZ", "fast"),
        ("SLOT_MILLIS", "-3"),
        ("NTP_INTERVAL_MILLIS", "x"),
        ("SENSORS", " , "),
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
    let requests = outputs
        .iter()
        .filter(|o| o.get("id").and_then(|v| v.as_str()) == Some("ntp_request"))
        .count();
    assert_eq!(requests, 3);
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
