//! Port ids and metadata keys shared by the dataflow's nodes, defined once so a producer and its
//! consumers cannot drift apart (STYLE.md §6: "defined once as consts").
//!
//! | port | node | message | meaning |
//! |---|---|---|---|
//! | [`FRAME`] | `kinect-source` out | `skeleton_frame` | one body frame, camera frame, sensor clock |
//! | [`GROUND_TRUTH`] | `kinect-source` out (one simulated source per graph), `recorder` in | `ground_truth`, many rows | true joints in the world frame at true instants on the server clock |
//! | [`NTP_REPLY`] | `kinect-source` out | `ntp_exchange` | request answered with t2/t3 |
//! | [`NTP_REQUEST`] | `sync` out | `ntp_exchange` | request with t1, addressed by `sensor_id` |
//! | [`TICK`] | `sync` in | dora timer | paces NTP requests, set deadlines, timing batches |
//! | [`ALIGNED_SET`] | `sync` out | `aligned_set` | frames of all sensors at one instant |
//! | [`FRAME_TIMING`] | `sync` out | `frame_timing`, many rows | server-clock placement of frames |
//! | [`FUSED_POSE`] | `trilaterate` out | `fused_pose` | world joints with covariance |
//! | [`DEPTH`] | `kinect-source` out (optional) | `depth_frame` | one raw depth image, sensor clock |
//!
//! `sync` takes one `frame_<sensor>` and one `ntp_<sensor>` input per source, so the sensor set
//! comes from the graph ([`FRAME_INPUT_PREFIX`], [`NTP_INPUT_PREFIX`]).

/// `kinect-source` output: a `skeleton_frame`.
pub const FRAME: &str = "frame";
/// `kinect-source` output (the one simulated source that sends it) and `recorder` input:
/// ground truth.
pub const GROUND_TRUTH: &str = "ground_truth";
/// `kinect-source` output: the answered NTP request.
pub const NTP_REPLY: &str = "ntp_reply";
/// `kinect-source` input and `sync` output: NTP requests.
pub const NTP_REQUEST: &str = "ntp_request";
/// `sync` output id prefix for one source's NTP requests: `ntp_request_k1`. With one output per
/// source a request reaches only its sensor; a single broadcast [`NTP_REQUEST`] reaches every
/// source, n² deliveries per NTP round, which at 16 sensors queues frames behind requests.
pub const NTP_REQUEST_OUTPUT_PREFIX: &str = "ntp_request_";
/// `sync` input: the timer that paces NTP requests, set deadlines and timing batches
/// (`dora/timer/millis/10`).
pub const TICK: &str = "tick";
/// `sync` output: aligned sets.
pub const ALIGNED_SET: &str = "aligned_set";
/// `sync` output: frame timings.
pub const FRAME_TIMING: &str = "frame_timing";
/// `trilaterate` output: fused poses.
pub const FUSED_POSE: &str = "fused_pose";
/// `kinect-source` output (optional, `DEPTH_RATE_HZ`): a `depth_frame`.
pub const DEPTH: &str = "depth";
/// Output id of a source's IR amplitude images (`ir_frame`, optional; a real sensor's source).
pub const IR: &str = "ir";
/// Output id of a source's device state (`sensor_status`, optional; a real sensor's source).
pub const STATUS: &str = "status";
/// `depth-metrics` input id prefix for a source's depth frames: `depth_k1`.
pub const DEPTH_INPUT_PREFIX: &str = "depth_";
/// Input id prefix of `depth-metrics`' per-sensor device state (`status_k1`).
pub const STATUS_INPUT_PREFIX: &str = "status_";
/// `sync`/`recorder` input id prefix for a source's frames: `frame_k1`.
pub const FRAME_INPUT_PREFIX: &str = "frame_";
/// `sync` input id prefix for a source's NTP replies: `ntp_k1`.
pub const NTP_INPUT_PREFIX: &str = "ntp_";

/// Metadata key (integer, ns since the UNIX epoch): when the source sent the frame.
pub const SENT_NANOS: &str = "trigait.sent_nanos";
/// Metadata key (integer, ns) on a simulated frame: its true capture instant on the server clock,
/// the `true_stamp_nanos` of [`crate::FrameTiming`] and [`crate::GroundTruth`].
pub const TRUE_STAMP_NANOS: &str = "trigait.true_stamp_nanos";
/// Metadata key (integer, ns) on a frame replayed from a recording: the server-clock stamp the
/// recording's `sync` gave it (`frame_timing.server_stamp_nanos`); a `sync` with
/// `TIMESTAMPS: recorded` places the frame there instead of mapping it with NTP.
pub const RECORDED_SERVER_STAMP_NANOS: &str = "trigait.recorded_server_stamp_nanos";
/// Metadata key (integer, ns) on a frame replayed from a recording: the uncertainty of
/// [`RECORDED_SERVER_STAMP_NANOS`] (`frame_timing.uncertainty_nanos`).
pub const RECORDED_UNCERTAINTY_NANOS: &str = "trigait.recorded_uncertainty_nanos";
/// Metadata key (integer, ns) on a frame replayed from a recording: the server clock when the
/// recording's `sync` received it (`frame_timing.received_nanos`); a `sync` with
/// `TIMESTAMPS: recorded` takes the replayed frames in that order and at that clock reading,
/// so its deadline decisions are the recorded run's.
pub const RECORDED_RECEIVED_NANOS: &str = "trigait.recorded_received_nanos";
/// Metadata key (integer, ns): send time of the newest frame that made a set go out (or the
/// `sync` clock when a deadline did); forwarded by `trilaterate`, read by `recorder` for the
/// end-to-end latency.
pub const TRIGGER_SENT_NANOS: &str = "trigait.trigger_sent_nanos";
/// Metadata key (string) on an aligned set: why `sync` handed it on when it did — `frames`
/// (every sensor's frames after the instant were in), `overdue` (a sensor's next frame was late
/// past the wait margin and was not waited for), `deadline` (the latency deadline passed) or
/// `end` (the run ended); forwarded by `trilaterate`, counted by `recorder`.
pub const SYNC_RELEASE: &str = "trigait.sync_release";
/// Metadata key (list of 2 integers, ns) on an aligned set: `sync`'s wait budget, the frame
/// wait margin and the latency deadline; forwarded by `trilaterate`, reported by `recorder`.
pub const SYNC_WAIT_BUDGET_NANOS: &str = "trigait.sync_wait_budget_nanos";

/// Metadata key (string): the [`RIG_FINGERPRINT`] of the rig the node that first sent the
/// message read from its `RIG` (sources stamp their frames; `sync` forwards the sources' stamp
/// on its sets and timings; `trilaterate` forwards it on its poses). Every node that reads a
/// rig compares it with its own and stops with an error naming both nodes when they differ.
pub const RIG_FINGERPRINT: &str = "trigait.rig_fingerprint";
/// Metadata key (string): the name of that rig (`thesis`, `ring-5`, a file stem), for errors.
pub const RIG_NAME: &str = "trigait.rig_name";
/// Metadata key (string): the node whose `RIG` it is (`k1`), for errors.
pub const RIG_NODE: &str = "trigait.rig_node";

/// Metadata key (bool): on a source's last frame when it ends its stream as planned
/// (`STOP_AFTER_SECS`), so `sync` takes the closed input for the run's end, not a failure.
pub const END_OF_STREAM: &str = "trigait.end_of_stream";

/// Metadata key (bool): on the sets `sync` sends once a source has sent its planned last frame
/// ([`END_OF_STREAM`]), and on the poses made of them: the run is winding down, and what these
/// sets' latency says is not the steady state's (the `recorder` reports them apart).
pub const WIND_DOWN: &str = "trigait.wind_down";

/// Metadata key (list of 4 floats, px: fx, fy, cx, cy) on a `depth_frame` a source has
/// undistorted: the frame is an ideal distortion-free pinhole with these intrinsics, in
/// `trigait_camera::Intrinsics`' convention (pixel index u looks along (u − cx)/fx). A frame
/// without it is the nominal camera (`Intrinsics::default()`).
pub const DEPTH_PINHOLE: &str = "trigait.depth_pinhole";

/// Every metadata key above (the message reference documents each).
pub const METADATA_KEYS: &[&str] = &[
    SENT_NANOS,
    TRUE_STAMP_NANOS,
    RECORDED_SERVER_STAMP_NANOS,
    RECORDED_UNCERTAINTY_NANOS,
    RECORDED_RECEIVED_NANOS,
    TRIGGER_SENT_NANOS,
    SYNC_RELEASE,
    SYNC_WAIT_BUDGET_NANOS,
    RIG_FINGERPRINT,
    RIG_NAME,
    RIG_NODE,
    END_OF_STREAM,
    WIND_DOWN,
    DEPTH_PINHOLE,
];

/// The sensor id of a `sync`/`recorder` input id with `prefix` (`frame_k1` → `k1`).
#[must_use]
pub fn sensor_of<'a>(input_id: &'a str, prefix: &str) -> Option<&'a str> {
    input_id.strip_prefix(prefix).filter(|s| !s.is_empty())
}

/// Sorts sensor ids naturally (`k2` before `k10`), the slot order of the `slots` policy.
pub fn sort_sensor_ids(ids: &mut [String]) {
    ids.sort_by_key(|a| natural_key(a));
}

fn natural_key(id: &str) -> (String, u64, String) {
    let digits_at = id.find(|c: char| c.is_ascii_digit()).unwrap_or(id.len());
    let (head, rest) = id.split_at(digits_at);
    let digits_end = rest
        .find(|c: char| !c.is_ascii_digit())
        .unwrap_or(rest.len());
    let (digits, tail) = rest.split_at(digits_end);
    (
        head.to_owned(),
        digits.parse().unwrap_or(0),
        tail.to_owned(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Input ids map to sensor ids; an empty suffix or another prefix is not a sensor.
    #[test]
    fn sensor_ids_from_inputs() {
        assert_eq!(sensor_of("frame_k1", FRAME_INPUT_PREFIX), Some("k1"));
        assert_eq!(sensor_of("frame_", FRAME_INPUT_PREFIX), None);
        assert_eq!(sensor_of("ntp_k1", FRAME_INPUT_PREFIX), None);
    }

    /// Natural order: k1, k2, …, k10, not k1, k10, k2.
    #[test]
    fn natural_sort() {
        let mut ids: Vec<String> = ["k10", "k2", "k1", "a", "k11"].map(String::from).to_vec();
        sort_sensor_ids(&mut ids);
        assert_eq!(ids, ["a", "k1", "k2", "k10", "k11"]);
    }
}
