//! Graph tests of the smoothing stage and the recorder's gait analysis: `dataflows/filtered.yml` is `dataflow.yml` with a `filter` node (One-Euro) between
//! `trilaterate` and `recorder`. Both graphs run headless (`dora run --stop-after`, 12 s and 24 s);
//! the recorder's `summary.json`, `trajectory.csv` and `.rrd` are read back.
//!
//! What could be wrong and is checked: the filtered graph does not run or its poses do not
//! reach the recorder; the "filter" passes poses through unchanged (jitter as high as without
//! it) or lags so much that the error against ground truth grows; the recorder finds no gait
//! events, logs them nowhere, or reports a cadence far from the simulated walker's 105
//! steps/min (`WalkerParams::default`).

// Test helpers outside `#[test]` functions panic on failure by design.
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use common::{Run, f, run_graph};
use serde_json::Value;

const FILTERED: &str = "dataflows/filtered.yml";
const PLAIN: &str = "dataflow.yml";
/// The embedded walker's cadence (`trigait_motion::WalkerParams::default()`).
const WALKER_CADENCE: f64 = 105.0;
/// Its speed: 0.70 m steps at 105 steps/min.
const WALKER_SPEED_MPS: f64 = 0.70 * 105.0 / 60.0;

fn gait(s: &Value) -> &Value {
    let g = &s["gait"];
    assert!(g.is_object(), "summary.json has no gait section: {s:#}");
    g
}

/// The filtered graph runs, its recorder receives the filter's poses (every set fused, none
/// dropped, all of them in the `.rrd`), and the filter changed nothing but positions: the
/// per-joint covariance/σ export and sensor lists are still there.
#[test]
fn filtered_graph_runs_and_poses_reach_the_recorder() {
    let run = run_graph(FILTERED);
    let s = run.summary();
    let sets = s["sets_fused"].as_u64().unwrap();
    assert!(
        sets >= 250,
        "only {sets} filtered poses in 12 s at 30 Hz: {s:#}"
    );
    run.assert_no_sets_lost();
    assert_eq!(s["malformed_inputs"], 0, "{s:#}");
    // Six joints in every complete set. An incomplete set (a sensor not yet synchronised at
    // start-up) may lack a joint that only the missing sensor saw.
    let complete = sets.saturating_sub(s["incomplete_sets"].as_u64().unwrap());
    assert!(s["joints_fused"].as_u64().unwrap() >= complete * 6, "{s:#}");
    let temporal = run.rrd().temporal;
    assert_eq!(
        temporal.get("world/fused").copied(),
        Some(sets),
        "{temporal:#?}"
    );
    // The sensors used survive the filter: most joints are fused from several sensors (the
    // first ones may come from one sensor while the others synchronise).
    let by_count = s["joints_by_sensors_used"].as_object().unwrap();
    let count = |k: &str| by_count.get(k).and_then(Value::as_u64).unwrap_or(0);
    let total: u64 = by_count.values().filter_map(Value::as_u64).sum();
    let multi = total - count("0") - count("1");
    assert!(
        2 * multi > total,
        "{multi} of {total} joints fused from several sensors: {s:#}"
    );
}

/// The One-Euro stage measurably smooths the poses: the hips' median frame-to-frame second
/// difference drops below 60 % of `dataflow.yml`'s. A causal filter cannot do that without
/// lag, and the lag shows in the error against the simulator's ground truth (taken at the
/// fusion instant): the error it adds, √(RMSE_filtered² − RMSE_plain²), divided by the
/// walker's speed is the delay it is equivalent to, and that must stay under 60 ms (the
/// default One-Euro cut-off at walking speed, 1 Hz + 2 Hz·s/m × 1.2 m/s ≈ 3.5 Hz, is a
/// 45 ms time constant).
#[test]
fn filter_lowers_jitter_with_bounded_lag() {
    let plain = run_graph(PLAIN);
    let filtered = run_graph(FILTERED);
    let (raw, n_raw) = common::hip_jitter_mm(&plain.trajectory());
    let (smooth, n_smooth) = common::hip_jitter_mm(&filtered.trajectory());
    let rmse = |r: &Run| f(&r.summary()["rmse_all_m"]);
    let (rmse_raw, rmse_smooth) = (rmse(&plain), rmse(&filtered));
    assert!(rmse_raw.is_finite() && rmse_smooth.is_finite());
    let lag_error = (rmse_smooth.powi(2) - rmse_raw.powi(2)).max(0.0).sqrt();
    let delay_ms = lag_error / WALKER_SPEED_MPS * 1e3;
    eprintln!(
        "hip jitter (median |Δ²x|): dataflow.yml {raw:.2} mm ({n_raw}), filtered.yml \
         {smooth:.2} mm ({n_smooth}), ratio {:.2}; RMSE vs truth {:.1} mm → {:.1} mm, \
         equivalent delay {delay_ms:.0} ms",
        smooth / raw,
        rmse_raw * 1e3,
        rmse_smooth * 1e3
    );
    assert!(raw > 0.3, "no jitter to remove in dataflow.yml? {raw} mm");
    assert!(smooth < 0.6 * raw, "jitter {smooth:.2} mm vs {raw:.2} mm");
    assert!(
        delay_ms < 60.0,
        "RMSE {rmse_smooth} m vs {rmse_raw} m: the filter lags like a {delay_ms:.0} ms delay"
    );
}

/// Gait events of both feet are in `summary.json` and in the `.rrd` (one marker row per
/// reported event, heel strikes and toe offs per foot), and the cadence from the fused
/// strides is the walker's 105 steps/min within 5 %.
#[test]
fn gait_events_in_rrd_and_summary() {
    let run = run_graph(FILTERED);
    let s = run.summary();
    let g = gait(&s);
    eprintln!("filtered.yml gait: {g:#}");
    for foot in ["left", "right"] {
        let hs = g["heel_strikes"][foot].as_u64().unwrap();
        let to = g["toe_offs"][foot].as_u64().unwrap();
        assert!(
            hs >= 3 && to >= 3,
            "{foot}: {hs} heel strikes, {to} toe offs: {g:#}"
        );
    }
    assert!(g["reason"].is_null(), "{g:#}");
    assert!(g["strides"].as_u64().unwrap() >= 2, "{g:#}");
    let cadence = f(&g["cadence_steps_per_min"]);
    assert!(
        (cadence / WALKER_CADENCE - 1.0).abs() < 0.05,
        "cadence {cadence} vs the walker's {WALKER_CADENCE}: {g:#}"
    );
    assert!(
        f(&g["stride_length_m"]) > 1.0 && f(&g["stride_length_m"]) < 1.8,
        "{g:#}"
    );

    let rrd = run.rrd();
    let (temporal, statics) = (&rrd.temporal, &rrd.statics);
    for foot in ["left", "right"] {
        let rows = |kind: &str| {
            temporal
                .get(&format!("gait/events/{foot}/{kind}"))
                .copied()
                .unwrap_or(0)
        };
        assert!(rows("heel_strike") >= 3, "{foot}: {temporal:#?}");
        assert!(rows("toe_off") >= 3, "{foot}: {temporal:#?}");
        assert_eq!(
            rows("heel_strike") + rows("toe_off"),
            g["events_reported"][foot].as_u64().unwrap(),
            "{foot}: every reported event has a marker: {temporal:#?}"
        );
        assert!(statics.contains_key(&format!("gait/events/{foot}/heel_strike")));
        // Each event switches its foot's stance/swing state.
        assert_eq!(
            temporal.get(&format!("gait/phase/{foot}")).copied(),
            g["events_reported"][foot].as_u64(),
            "{foot}: {temporal:#?}"
        );
    }
    assert!(temporal.get("gait/log").copied().unwrap_or(0) >= 12);
    // The placeholder, an update per analysis that found a heel strike, the final table.
    assert!(temporal.get("gait/parameters").copied().unwrap_or(0) >= 3);
}

/// The recorder analyses the gait in the unfiltered graph too; its cadence is reported next
/// to the filtered one (the Zeni coordinate method's 4 cm prominence rides over Kinect noise).
#[test]
fn unfiltered_graph_reports_gait_too() {
    let run = run_graph(PLAIN);
    let s = run.summary();
    let g = gait(&s);
    eprintln!(
        "dataflow.yml gait: heel strikes {} / {}, strides {}, cadence {}, reason {}",
        g["heel_strikes"]["left"],
        g["heel_strikes"]["right"],
        g["strides"],
        g["cadence_steps_per_min"],
        g["reason"]
    );
    let cadence = f(&g["cadence_steps_per_min"]);
    assert!(
        (cadence / WALKER_CADENCE - 1.0).abs() < 0.05,
        "cadence {cadence}: {g:#}"
    );
}
