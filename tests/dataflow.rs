//! Whole-graph tests: every graph runs headless with `dora run <graph> --stop-after 12s` (24 s
//! for `dataflow.yml`, see `common::run_graph`; the
//! dora CLI from `pip install dora-rs-cli==1.1.0`, which `scripts/test.sh` puts in `.venv/`),
//! then its `summary.json` is checked against the acceptance criteria and its `.rrd` is read
//! back with rerun-sdk 0.36.3 (`scripts/rrd_rows.py`): entity paths and row counts.
//!
//! Graphs run one at a time (a lock) so their latencies are not measured against each other;
//! each runs in its own folder under `target/dataflow-tests/`, node binaries are the release
//! builds of this workspace.

// Test helpers outside `#[test]` functions panic on failure by design (clippy.toml allows it
// only inside them).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::time::{Duration, Instant};

use common::{
    LOCK, Run, f, finish, kill_9, node_pid, rrd_blueprint_of, run_graph, spawn_graph,
    wait_until_streaming, workspace,
};
use serde_json::Value;

/// What `trigait eval` reports for fusion on the thesis rig with the same endless walk the
/// sources play (static sets: every sensor at the same instant).
fn eval_fusion_rmse() -> f64 {
    let clip = trigait_motion::walker(&trigait_motion::WalkerParams::default(), 2.5, 100.0)
        .unwrap()
        .placed_on_walkway();
    let lap = trigait_motion::there_and_back(&clip).unwrap();
    let rig = trigait_rig::Rig::from_spec("thesis").unwrap();
    let sim = trigait_sim::Simulator::new(
        &rig,
        lap,
        &trigait_skeleton::Joint::LEGS,
        &trigait_kinect::NoiseModel::default(),
    );
    let config = trigait_eval::EvalConfig {
        methods: vec![trigait_eval::MethodSpec::plain(
            trigait_trilateration::Method::Fusion,
        )],
        trials: 4,
        ..trigait_eval::EvalConfig::default()
    };
    let report = trigait_eval::evaluate(&sim, &rig.name, &config, &|_| {});
    report.methods[0].rmse_m
}

/// The latency budget: latency (frame sent → pose recorded) p50 ≤ 5 ms and p99 ≤ 20 ms on one host, in
/// the steady state. The first second of poses is the recorder's warm-up, reported apart
/// (dora and zenoh open their routes on the first messages): it must hold no more than a
/// second's poses and a backlog, and none of them may wait a second. Says why a run is over it.
fn over_latency_budget(s: &Value) -> Option<String> {
    let latency = &s["latency_ms"];
    let warmup = &s["warmup"];
    if f(&latency["p50"]) > 5.0 || f(&latency["p99"]) > 20.0 {
        Some(format!("steady-state latency over 5 / 20 ms: {latency:#}"))
    } else if f(&warmup["secs"]) > 1.0
        || warmup["poses"].as_u64().unwrap() > 45
        || f(&warmup["latency_ms"]["max"]) >= 1000.0
    {
        Some(format!(
            "warm-up over a second, 45 poses or a 1 s wait: {warmup:#}"
        ))
    } else {
        None
    }
}

/// The (cached) run of `file` checked by [`check_simulated`] and held to the latency budget
/// ([`over_latency_budget`]). A shared host that starves the graph's processes for a moment
/// breaks the budget in one run and not the next: the project's CI runner once measured a
/// sixteen-sensor p99 of 25.8 ms (p50 2.7 ms, sources losing up to 26 frames each) where an
/// idle 2-core machine measures 3.7 ms. So a run over the budget is printed and the graph run
/// once more, uncached; that run must pass the same checks and hold the budget. A change that
/// slows every run still fails.
fn simulated_within_budget(file: &str, sensors: usize, ntp: bool) -> (Run, Value) {
    let run = run_graph(file);
    let s = check_simulated(&run, sensors, ntp);
    let Some(why) = over_latency_budget(&s) else {
        return (run, s);
    };
    eprintln!("{file}: first run over the latency budget, running it again: {why}");
    let again = common::run_graph_again(file);
    let s = check_simulated(&again, sensors, ntp);
    if let Some(why) = over_latency_budget(&s) {
        panic!("{file}: over the latency budget in two runs; the second: {why}");
    }
    (again, s)
}

/// Live means fresh: a pose reaches the recorder at most `bound_ms` after its fusion instant
/// for the `quantile` (`"p99"` or `"p95"`) of the steady-state poses (`age_ms`; the first sets
/// wait for every sensor's clock sync and are reported under `warmup`, the last ones, while the
/// sources shut down, under `wind_down`). `sync` hands a set on once every sensor's frame after the
/// instant is in, or a sensor's frame is overdue; the deadline is the exception, not the rule.
fn assert_fresh(s: &Value, quantile: &str, bound_ms: f64) {
    let age = &s["age_ms"];
    let wait = &s["sync_wait"];
    eprintln!("age {age:#}, sync wait {wait:#}");
    assert!(
        f(&age[quantile]) <= bound_ms,
        "age {quantile} over {bound_ms} ms: {age:#}, sync wait {wait:#}"
    );
    let released = &wait["released"];
    let count = |k: &str| released[k].as_u64().unwrap_or(0);
    let sets = s["sets_fused"].as_u64().unwrap();
    assert!(count("frames") * 2 >= sets, "{wait:#}");
    assert!(count("deadline") * 100 <= sets, "{wait:#}");
    assert_eq!(f(&wait["frame_wait_margin_ms"]), 10.0, "{wait:#}");
    // The sources end the run themselves: the poses after the first one's last frame are its
    // wind-down, reported apart, and that is the last second at most, not the run.
    let wind_down = &s["wind_down"];
    let poses = wind_down["poses"].as_u64().unwrap();
    assert!((1..=30).contains(&poses), "{wind_down:#}");
}

/// Checks shared by every simulated graph: sets flow without drops, one every 1/30 s from the
/// first to the last, every sensor is synchronised to < 1 ms for ≥ 99 % of its frames, and the
/// recording holds what the summary counted.
fn check_simulated(run: &Run, sensors: usize, ntp_below_1ms: bool) -> Value {
    let s = run.summary();
    let sets = s["sets_fused"].as_u64().unwrap();
    // The sets start once every sensor's clock is synchronised. At 16 sensors on 2 cores that
    // took up to 4.1 s of the 12 (CI), so 7.5 s of sets; with 3 or 5 under 3.7 s.
    let least = if sensors > 5 { 225 } else { 250 };
    assert!(sets >= least, "only {sets} sets in 12 s at 30 Hz: {s:#}");
    // From the first set on, none missing: one per 1/30 s.
    let stamp = |key: &str| s[key].as_i64().unwrap();
    let span_secs =
        (stamp("last_pose_stamp_nanos") - stamp("first_pose_stamp_nanos")) as f64 * 1e-9;
    let expected = (span_secs * 30.0).round() as u64 + 1;
    assert!(
        sets * 100 >= expected * 99,
        "{sets} sets over {span_secs:.2} s at 30 Hz: {s:#}"
    );
    run.assert_no_sets_lost();
    let ntp = s["ntp"].as_object().unwrap();
    assert_eq!(ntp.len(), sensors, "{s:#}");
    for (id, n) in ntp {
        // Synchronised for most of the run. At 16 sensors on 2 cores start-up exchanges are
        // slow and rejected for up to 3.5 s (CI: 104 of a sensor's frames before its fourth
        // accepted exchange), so the bound is half the frames that came in.
        let checked = n["frames_checked"].as_u64().unwrap();
        let frames_in = s["frames_in"][id.as_str()].as_u64().unwrap();
        assert!(checked * 2 > frames_in && checked > 150, "{id}: {n:#}");
        assert!(
            !ntp_below_1ms || f(&n["share_below_1ms"]) >= 0.99,
            "{id}: NTP error ≥ 1 ms too often: {n:#}"
        );
    }
    assert_eq!(s["frames_in"].as_object().unwrap().len(), sensors);
    // Sensor edges ride dora's direct path; a frame lost there is reported, not fatal.
    eprintln!("frames lost per source: {}", s["frames_lost"]);
    let rrd = run.rrd();
    let (temporal, statics) = (&rrd.temporal, &rrd.statics);
    assert_eq!(
        temporal.get("world/fused").copied(),
        Some(sets),
        "{temporal:#?}"
    );
    assert!(
        temporal
            .get("trajectories/x/knee_left")
            .copied()
            .unwrap_or(0)
            >= sets * 9 / 10,
        "{temporal:#?}"
    );
    // Every pose's latency is plotted, warm-up included.
    assert_eq!(
        temporal.get("timing/latency_ms").copied(),
        Some(sets),
        "{temporal:#?}"
    );
    for k in 1..=sensors {
        let frames = s["frames_in"][format!("k{k}")].as_u64().unwrap();
        assert_eq!(
            temporal.get(&format!("world/sensors/k{k}/joints")).copied(),
            Some(frames)
        );
        assert!(
            temporal
                .get(&format!("sync/offset_ms/k{k}"))
                .copied()
                .unwrap_or(0)
                > 200
        );
        assert!(
            statics.contains_key(&format!("world/sensors/k{k}")),
            "{statics:#?}"
        );
        assert!(statics.contains_key(&format!("world/sensors/k{k}/frustum")));
    }
    assert!(
        statics.contains_key("world/fused"),
        "annotation context: {statics:#?}"
    );
    let blueprint = &rrd.blueprint;
    assert!(
        blueprint.iter().any(|p| p == "viewport")
            && blueprint
                .iter()
                .filter(|p| p.starts_with("view/") && !p.ends_with("ViewContents"))
                .count()
                >= 5,
        "default blueprint: {blueprint:#?}"
    );
    s
}

/// Acceptance on `dataflow.yml`: ≥ 10 s of walking fused with RMSE within 1.2× of
/// `trigait eval` for the same rig and method, NTP error < 1 ms on ≥ 99 % of frames with
/// offsets up to ±50 ms and drift up to 100 ppm, no dropped sets, latency p50 ≤ 5 ms and
/// p99 ≤ 20 ms, the thesis text/CSV exports, and a readable `.rrd`.
#[test]
fn default_graph_meets_acceptance() {
    let (run, s) = simulated_within_budget("dataflow.yml", 3, true);
    let rmse = f(&s["rmse_all_m"]);
    let eval = eval_fusion_rmse();
    eprintln!(
        "dataflow.yml: RMSE {rmse:.4} m vs eval {eval:.4} m; latency {:#}",
        s["latency_ms"]
    );
    assert!(
        rmse <= 1.2 * eval,
        "dataflow RMSE {rmse} m vs eval {eval} m"
    );
    assert!(rmse > 0.1 * eval, "suspiciously small RMSE {rmse}");
    for joint in [
        "hip_left",
        "knee_left",
        "ankle_left",
        "hip_right",
        "knee_right",
        "ankle_right",
    ] {
        assert!(f(&s["rmse_m"][joint]) < 0.1, "{joint}: {s:#}");
    }
    assert_fresh(&s, "p99", 50.0);
    let text = std::fs::read_to_string(run.out_dir.join("trajectory.txt")).unwrap();
    let rows = text.lines().filter(|l| !l.starts_with('#')).count();
    assert!(
        (250..=1000).contains(&rows),
        "{rows} rows: ring of 1000 per joint"
    );
    let clip = run.trajectory();
    assert!((clip.rate_hz() - 30.0).abs() < 0.1, "{}", clip.rate_hz());
    let mut legs = trigait_skeleton::Joint::LEGS.to_vec();
    legs.sort_by_key(|j| j.index());
    assert_eq!(clip.joints(), legs);
    for name in ["trajectory.trc", "trajectory.c3d"] {
        let markers = trigait_motion::read_markers(run.out_dir.join(name)).unwrap();
        assert_eq!(markers.frame_count(), clip.frame_count(), "{name}");
    }
    // The run's gait report: one well-formed page with its two figures and a parameter table.
    let report = std::fs::read_to_string(run.out_dir.join("report.html")).unwrap();
    trigait_gait::report::check_well_formed(&report).unwrap();
    assert_eq!(report.matches("<svg").count(), 2);
    let cell = "<td>cadence (steps/min)</td><td>";
    let page_cadence: f64 = report
        .split(cell)
        .nth(1)
        .and_then(|rest| rest.split('<').next())
        .and_then(|v| v.trim().parse().ok())
        .expect("no cadence in the report");
    // `summary.json`'s gait and the page analyse the run alike: the same low-pass, the same
    // cadence (the live analysis's grid is its own, so to within 1 %).
    let g = &s["gait"];
    assert_eq!(g["filter"], "butterworth:6hz", "{g:#}");
    let live_cadence = f(&g["cadence_steps_per_min"]);
    assert!(
        (page_cadence / live_cadence - 1.0).abs() < 0.01,
        "report.html {page_cadence} steps/min, summary.json {live_cadence}"
    );
}

/// The default graph's recording opens with the gait-lab layout: read back from the `.rrd`, its
/// blueprint has the 3-D walkway with a framing eye, the stance/swing state timeline, the
/// heel-strike/toe-off plot, the parameter table, knee and hip flexion charts, one trajectory
/// panel per axis and the clock offset and sync error in separate panels; each view's origin
/// holds the data it is meant to show; and the skeleton's annotation context declares exactly
/// the joints logged, with no keypoint connection the viewer could fail to resolve (it warns
/// "Keypoint connection … could not be resolved" for one whose joint a pose lacks).
#[test]
fn default_graph_opens_with_the_gait_lab_layout() {
    let run = run_graph("dataflow.yml");
    let s = run.summary();
    let sets = s["sets_fused"].as_u64().unwrap();
    let rrd = run.rrd();
    let bp = rrd_blueprint_of(&run.out_dir.join("trigait.rrd"));
    assert_eq!(bp["viewport"]["has_root"], true, "{bp:#}");
    assert_eq!(bp["viewport"]["auto_views"], false, "{bp:#}");
    let views = bp["views"].as_array().unwrap();
    let view = |class: &str, origin: &str| -> &Value {
        views
            .iter()
            .find(|v| {
                v["class"] == class
                    && v["origin"].as_str().map(|o| o.trim_start_matches('/')) == Some(origin)
            })
            .unwrap_or_else(|| panic!("no {class} view of {origin}: {bp:#}"))
    };
    // Temporal rows under an entity path (the view's content `$origin/**`).
    let rows_under = |origin: &str| -> u64 {
        rrd.temporal
            .iter()
            .filter(|(p, _)| *p == origin || p.starts_with(&format!("{origin}/")))
            .map(|(_, n)| n)
            .sum()
    };
    let scene = view("3D", "world");
    assert!(
        scene["properties"]
            .as_array()
            .unwrap()
            .iter()
            .any(|p| p == "EyeControls3D"),
        "{scene:#}"
    );
    for k in 1..=3 {
        assert!(
            rrd.statics
                .contains_key(&format!("world/sensors/k{k}/label"))
        );
    }
    assert!(rrd.statics.contains_key("world/walkway"));
    assert_eq!(rrd.temporal.get("world/fused_bones").copied(), Some(sets));
    let events = s["gait"]["events_reported"].clone();
    let reported = events["left"].as_u64().unwrap() + events["right"].as_u64().unwrap();
    assert!(reported >= 12, "{:#}", s["gait"]);
    for (class, origin, at_least) in [
        ("StateTimeline", "gait/phase", reported),
        ("TimeSeries", "gait/events", reported),
        ("TextDocument", "gait/parameters", 3),
        ("2D", "flexion/knee", 2),
        ("2D", "flexion/hip", 2),
        ("TimeSeries", "trajectories/x", sets * 6 * 9 / 10),
        ("TimeSeries", "trajectories/y", sets * 6 * 9 / 10),
        ("TimeSeries", "trajectories/z", sets * 6 * 9 / 10),
        ("TimeSeries", "sync/offset_ms", 600),
        ("TimeSeries", "sync/error_ms", 600),
        ("TimeSeries", "timing", sets),
    ] {
        let v = view(class, origin);
        let contents = v["contents"].as_array().unwrap();
        assert!(
            contents.iter().any(|q| q == "$origin/**" || q == "$origin"),
            "{v:#}"
        );
        let rows = rows_under(origin);
        assert!(
            rows >= at_least,
            "{origin}: {rows} rows, expected ≥ {at_least}"
        );
    }
    assert!(rrd.statics.contains_key("key"), "{:#?}", rrd.statics);
    view("TextDocument", "key");
    // Flexion curves of both feet, drawn as each stride settled.
    for joint in ["knee", "hip"] {
        for foot in ["left", "right"] {
            assert!(
                rrd.temporal
                    .contains_key(&format!("flexion/{joint}/{foot}/mean")),
                "{:#?}",
                rrd.temporal
            );
        }
    }
    let ctx = &bp["annotation"]["world/fused"];
    let legs: Vec<u64> = {
        let mut l: Vec<u64> = trigait_skeleton::Joint::LEGS
            .iter()
            .map(|j| j.index() as u64)
            .collect();
        l.sort_unstable();
        l
    };
    let ids = |key: &str| -> Vec<u64> {
        ctx[key]
            .as_array()
            .unwrap_or_else(|| panic!("{key}: {bp:#}"))
            .iter()
            .map(|v| v.as_u64().unwrap())
            .collect()
    };
    assert_eq!(ids("keypoints"), legs, "{ctx:#}");
    assert_eq!(ids("logged_ever"), legs, "{ctx:#}");
    let every = ids("logged_every_pose");
    assert!(
        ids("connections").iter().all(|c| every.contains(c)),
        "a connection names a joint some pose lacks: {ctx:#}"
    );
}

/// The thesis slot schedule leaves inter-sensor skew that interpolation removes: on the same
/// walker, `interpolate` has the lower RMSE.
#[test]
fn interpolate_beats_slots() {
    let slots = run_graph("dataflows/slots.yml");
    let s = slots.summary();
    assert!(s["sets_fused"].as_u64().unwrap() > 100, "{s:#}");
    let interp = run_graph("dataflow.yml").summary();
    let (a, b) = (f(&interp["rmse_all_m"]), f(&s["rmse_all_m"]));
    eprintln!("RMSE interpolate {a:.4} m, slots {b:.4} m");
    assert!(a < b, "interpolate {a} m should beat slots {b} m");
}

/// A sensor is its source block and its `sync` lines: in every simulated graph, 3 to 16
/// sensors, the recorder and trilaterate have the same inputs, and `sync` has two inputs and
/// one output per source.
#[test]
fn adding_a_sensor_touches_only_its_source_and_sync() {
    let node = |file: &str, id: &str| -> serde_yaml::Value {
        let v: serde_yaml::Value =
            serde_yaml::from_str(&std::fs::read_to_string(workspace().join(file)).unwrap())
                .unwrap();
        v["nodes"]
            .as_sequence()
            .unwrap()
            .iter()
            .find(|n| n["id"] == id)
            .unwrap_or_else(|| panic!("{file} has no node {id}"))
            .clone()
    };
    let keys = |v: &serde_yaml::Value| -> Vec<String> {
        v.as_mapping()
            .map(|m| m.keys().map(|k| k.as_str().unwrap().to_owned()).collect())
            .unwrap_or_default()
    };
    for (file, n) in [
        ("dataflow.yml", 3),
        ("dataflows/five-sensors.yml", 5),
        ("dataflows/sixteen-sensors.yml", 16),
    ] {
        let recorder = node(file, "recorder");
        assert_eq!(
            keys(&recorder["inputs"]),
            ["fused_pose", "frame_timing", "ground_truth"],
            "{file}"
        );
        assert_eq!(keys(&node(file, "trilaterate")["inputs"]), ["aligned_set"]);
        let sync = node(file, "sync");
        assert_eq!(
            keys(&sync["inputs"]).len(),
            2 * n + 1,
            "{file}: tick + frame/ntp"
        );
        assert_eq!(
            sync["outputs"].as_sequence().unwrap().len(),
            n + 2,
            "{file}: aligned_set, frame_timing + one ntp_request each"
        );
    }
}

/// Five sensors: no code change, only YAML — the same four binaries and build lines as
/// `dataflow.yml`, two more source blocks — and it runs with no dropped sets within the
/// latency budget.
#[test]
fn five_sensor_graph_differs_only_in_yaml() {
    let load = |file: &str| -> serde_yaml::Value {
        serde_yaml::from_str(&std::fs::read_to_string(workspace().join(file)).unwrap()).unwrap()
    };
    let nodes = |v: &serde_yaml::Value| -> Vec<(String, String, String)> {
        v["nodes"]
            .as_sequence()
            .unwrap()
            .iter()
            .map(|n| {
                (
                    n["id"].as_str().unwrap().to_owned(),
                    n["path"]
                        .as_str()
                        .unwrap()
                        .trim_start_matches("../")
                        .to_owned(),
                    n["build"].as_str().unwrap().to_owned(),
                )
            })
            .collect()
    };
    let three = nodes(&load("dataflow.yml"));
    let five = nodes(&load("dataflows/five-sensors.yml"));
    let binaries = |n: &[(String, String, String)]| {
        n.iter()
            .map(|(_, p, b)| (p.clone(), b.clone()))
            .collect::<std::collections::BTreeSet<_>>()
    };
    assert_eq!(binaries(&three), binaries(&five));
    let ids =
        |n: &[(String, String, String)]| n.iter().map(|(i, _, _)| i.clone()).collect::<Vec<_>>();
    let mut expected = ids(&three);
    expected.splice(3..3, ["k4".to_owned(), "k5".to_owned()]);
    assert_eq!(ids(&five), expected);
    let (_, s) = simulated_within_budget("dataflows/five-sensors.yml", 5, false);
    eprintln!(
        "five sensors: RMSE {:.4} m, latency {:#}",
        f(&s["rmse_all_m"]),
        s["latency_ms"]
    );
    assert!(f(&s["rmse_all_m"]) < 0.05, "{s:#}");
}

/// Sixteen sensors at 30 Hz on one host: no code change, every sensor fused and
/// recorded, no set lost, latency p50 ≤ 5 ms and p99 ≤ 20 ms. The NTP share is reported, not
/// asserted (the 1 ms bound is asked of `dataflow.yml`). Measured on the 2-core development
/// machine: p99 4.8–8.0 ms; with a compile running beside it, 100+ ms (dataflows/README.md).
#[test]
fn sixteen_sensor_graph_scales() {
    let (_, s) = simulated_within_budget("dataflows/sixteen-sensors.yml", 16, false);
    eprintln!(
        "sixteen sensors: RMSE {:.4} m, dropped sets {}, latency {:#}, warm-up {:#}",
        f(&s["rmse_all_m"]),
        s["dropped_sets"],
        s["latency_ms"],
        s["warmup"]
    );
    assert!(f(&s["rmse_all_m"]) < 0.05, "{s:#}");
    // Sixteen sources on 2 loaded cores starve now and then: a frame comes late or is lost,
    // and `sync` releases its set when overdue or, for at most 1 % of the sets (asserted),
    // at the 100 ms deadline. Over the ~270 poses of a 12 s run that 1 % is the 3 worst,
    // so p99 is those poses' age (92.8 ms in one clean-clone CI, with 2 deadline releases
    // and 19 frames lost by one source). p95 is the tail of the release rule itself: 44.6 ms
    // p99 with `scripts/sync_wait.sh` on an idle machine, while waiting out the old 100 ms
    // margin puts every set past 90 ms.
    assert_fresh(&s, "p95", 60.0);
}

/// The replay graph plays both SDK recordings through sync and fusion into the recording.
#[test]
fn replay_graph_runs() {
    let run = run_graph("dataflows/replay.yml");
    let s = run.summary();
    for k in ["k1", "k2", "k3"] {
        assert!(s["frames_in"][k].as_u64().unwrap_or(0) > 250, "{k}: {s:#}");
    }
    assert!(s["sets_fused"].as_u64().unwrap() > 200, "{s:#}");
    assert!(s["rmse_all_m"].is_null(), "no ground truth in a replay");
    let temporal = run.rrd().temporal;
    assert!(
        temporal
            .get("world/sensors/k2/joints")
            .copied()
            .unwrap_or(0)
            > 250
    );
}

/// Killing one source (SIGKILL) mid-run: fusion continues with the other two, the summary
/// counts the gap and the incomplete sets, and the recording is still valid.
#[test]
fn killing_a_source_mid_run() {
    let graph = std::fs::read_to_string(workspace().join("dataflow.yml")).unwrap();
    let _guard = LOCK.lock().unwrap_or_else(|e| e.into_inner());
    let (child, dir) = spawn_graph("kill-source", &graph, "12s");
    let victim = node_pid(&dir, "trigait-kinect-source-node", Some("SENSOR_ID=k2"));
    // Let the graph start and stream (poses reach the recording) before k2 dies.
    wait_until_streaming(&dir);
    std::thread::sleep(Duration::from_secs(1));
    kill_9(victim);
    let run = finish(child, dir);
    run.assert_sets_delivered();
    let s = run.summary();
    let gaps = s["gaps"].as_array().unwrap();
    assert!(
        gaps.iter()
            .any(|g| g["sensor"] == "k2" && g["until_end"] == true && f(&g["duration_secs"]) > 3.0),
        "{s:#}\n{}",
        run.log
    );
    assert!(s["incomplete_sets"].as_u64().unwrap() > 100, "{s:#}");
    assert!(
        s["sets_fused"].as_u64().unwrap() >= 250,
        "fusion continued: {s:#}"
    );
    assert!(f(&s["rmse_all_m"]) < 0.1, "{s:#}");
    let frames = s["frames_in"].as_object().unwrap();
    assert!(frames["k2"].as_u64().unwrap() < frames["k1"].as_u64().unwrap() * 2 / 3);
    let temporal = run.rrd().temporal;
    assert_eq!(
        temporal.get("world/fused").copied(),
        s["sets_fused"].as_u64()
    );
}

/// Killing the recorder (SIGKILL) mid-run: `summary.json` (marked incomplete), the trajectory
/// CSV and a loadable `.rrd` are on disk and cover the run up to at most 1 s before the kill.
#[test]
fn killing_the_recorder_mid_run_keeps_its_files() {
    // The default graph as it is: writing as it goes is the recorder's default.
    let graph = std::fs::read_to_string(workspace().join("dataflow.yml")).unwrap();
    let _guard = LOCK.lock().unwrap_or_else(|e| e.into_inner());
    assert!(!graph.contains("LIVE_UPDATE_SECS"));
    let (child, dir) = spawn_graph("kill-recorder", &graph, "10s");
    let victim = node_pid(&dir, "trigait-recorder-node", None);
    wait_until_streaming(&dir);
    std::thread::sleep(Duration::from_secs(3));
    let killed_at = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_nanos() as i64;
    kill_9(victim);
    let run = finish(child, dir);
    let s = run.summary();
    assert_eq!(s["complete"], false, "{s:#}");
    let (first, last) = (
        s["first_pose_stamp_nanos"].as_i64().unwrap(),
        s["last_pose_stamp_nanos"].as_i64().unwrap(),
    );
    let lost_secs = (killed_at - last) as f64 * 1e-9;
    assert!(
        (0.0..=1.0).contains(&lost_secs),
        "summary.json ends {lost_secs:.3} s before the kill: {s:#}"
    );
    assert!(s["sets_fused"].as_u64().unwrap() > 60, "{s:#}");
    let clip = run.trajectory();
    let csv_end_secs = (clip.frame_count() - 1) as f64 / clip.rate_hz();
    let csv_lost_secs = (killed_at - first) as f64 * 1e-9 - csv_end_secs;
    assert!(
        (0.0..=1.0).contains(&csv_lost_secs),
        "trajectory.csv ends {csv_lost_secs:.3} s before the kill ({} frames)",
        clip.frame_count()
    );
    // The recording holds every pose up to 1 s before the kill: at 30 Hz from the first pose's
    // instant, that many at least.
    let temporal = run.rrd().temporal;
    let fused = temporal.get("world/fused").copied().unwrap_or(0);
    let due = ((killed_at - 1_000_000_000 - first) as f64 / (1e9 / 30.0)).floor() as u64 + 1;
    eprintln!(
        "killed recorder: summary.json ends {lost_secs:.3} s, trajectory.csv {csv_lost_secs:.3} s before the kill; {fused} fused rows in the .rrd, {due} due"
    );
    assert!(
        fused >= due,
        "{fused} fused rows in the .rrd, {due} poses were fused by 1 s before the kill"
    );
}

/// The recorder told to stream to a viewer that is not running: the run ends on time, says
/// once that no viewer takes the stream, and its `.rrd` holds every fused pose. Before, the
/// recorder's logging waited for the viewer after 100 messages, the `.rrd` stopped at 57
/// rows, and the recorder never exited.
#[test]
fn a_viewer_that_is_not_there_holds_up_nothing() {
    let graph = std::fs::read_to_string(workspace().join("dataflow.yml"))
        .unwrap()
        .replace(
            "      OUTPUT_DIR: out\n",
            // A port nothing listens on.
            "      OUTPUT_DIR: out\n      RERUN_CONNECT: rerun+http://127.0.0.1:9/proxy\n",
        );
    assert!(graph.contains("RERUN_CONNECT"));
    let _guard = LOCK.lock().unwrap_or_else(|e| e.into_inner());
    let (child, dir) = spawn_graph("no-viewer", &graph, "5s");
    let run = finish(child, dir);
    assert!(run.success, "{}", run.log);
    assert_eq!(
        run.log.matches("no rerun viewer takes the stream").count(),
        1,
        "{}",
        run.log
    );
    let s = run.summary();
    assert_eq!(s["complete"], true, "{s:#}");
    let sets = s["sets_fused"].as_u64().unwrap();
    assert!(sets > 100, "{s:#}");
    let fused = run.rrd().temporal.get("world/fused").copied().unwrap_or(0);
    assert_eq!(fused, sets, "fused rows in the .rrd against poses fused");
}

/// A malformed rig file, an unknown policy, an unknown estimator, nodes given different rigs, a
/// misspelt input id and a source given another's `SENSOR_ID` each stop the graph with an error naming the node and
/// the key (for rigs: both nodes; for the sensor: the input and the id it carries).
#[test]
fn config_errors_stop_the_graph_naming_node_and_key() {
    let graph = std::fs::read_to_string(workspace().join("dataflow.yml")).unwrap();
    let dir = workspace().join("target/dataflow-tests");
    std::fs::create_dir_all(&dir).unwrap();
    let bad_rig = dir.join("malformed-rig.yml");
    std::fs::write(
        &bad_rig,
        "sensors:\n  - id: k1\n    position: [0, 0, oops]\n",
    )
    .unwrap();
    let cases = [
        (
            "bad-policy",
            graph.replace("POLICY: interpolate", "POLICY: round-robin"),
            "sync: POLICY=\"round-robin\"",
            true,
        ),
        (
            "bad-method",
            graph.replace("METHOD: fusion", "METHOD: kalman"),
            "trilaterate: METHOD=\"kalman\"",
            true,
        ),
        (
            "other-rig",
            graph.replace(
                "      METHOD: fusion\n      RIG: thesis",
                "      METHOD: fusion\n      RIG: ring-3",
            ),
            // Any source's stamp may be the one sync passed on first.
            "trilaterate: RIG is rig \"ring-3\" (3 sensors) but k|sent data made with rig \"thesis\" (3 sensors)",
            false,
        ),
        (
            "sources-disagree",
            graph.replace(
                "      SENSOR_ID: k2\n      RIG: thesis",
                "      SENSOR_ID: k2\n      RIG: ring-3",
            ),
            "sync: the sources disagree on the rig",
            false,
        ),
        (
            "misspelt-input",
            graph.replace(
                "      fused_pose:\n        source: trilaterate/fused_pose",
                "      fused_poses:\n        source: trilaterate/fused_pose",
            ),
            "recorder: input \"fused_poses\" is not one it reads",
            // Checked once dora has given the node its inputs: the rest of the graph runs on.
            false,
        ),
        (
            // A copied source block whose SENSOR_ID was not changed.
            "copied-sensor-id",
            graph.replace("      SENSOR_ID: k3\n", "      SENSOR_ID: k2\n"),
            "sync: input |k3 carries messages of sensor \"k2\"",
            false,
        ),
        (
            "bad-rig",
            graph.replace(
                "      METHOD: fusion\n      RIG: thesis",
                &format!("      METHOD: fusion\n      RIG: {}", bad_rig.display()),
            ),
            "trilaterate: RIG=",
            true,
        ),
    ];
    let _guard = LOCK.lock().unwrap_or_else(|e| e.into_inner());
    // A bad value stops its node before the graph starts, so dora stops the graph at once; a
    // rig mismatch shows only in the first messages, and the node that finds it stops with
    // the error while the rest of the graph runs to its end (6 s here).
    for (name, text, expected, at_start) in cases {
        assert_ne!(text, graph, "{name}: the replacement must change the graph");
        let (child, dir) = spawn_graph(name, &text, if at_start { "20s" } else { "6s" });
        let started = Instant::now();
        let run = finish(child, dir);
        assert!(!run.success, "{name}: the graph should fail\n{}", run.log);
        for part in expected.split('|') {
            assert!(
                run.log.contains(part),
                "{name}: log lacks {part:?}:\n{}",
                run.log
            );
        }
        assert!(
            !at_start || started.elapsed() < Duration::from_secs(19),
            "{name}: failed only at stop-after"
        );
    }
}
