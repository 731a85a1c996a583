//! `trigait eval` as a user runs it: the acceptance runs on the real mocap
//! recordings, and clear errors for bad input.

// Test helpers outside `#[test]` functions panic on failure by design.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::process::{Command, Output};

use serde_json::Value;

fn trigait(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_trigait"))
        .args(args)
        .output()
        .expect("the trigait binary runs")
}

fn eval_json(args: &[&str]) -> Value {
    let mut all = vec!["eval", "--json"];
    all.extend_from_slice(args);
    let out = trigait(&all);
    assert!(
        out.status.success(),
        "trigait {all:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("eval --json prints JSON")
}

fn method<'a>(report: &'a Value, name: &str) -> &'a Value {
    report["methods"]
        .as_array()
        .and_then(|ms| ms.iter().find(|m| m["method"] == name))
        .unwrap_or_else(|| panic!("method {name} missing from {report}"))
}

fn f(v: &Value, key: &str) -> f64 {
    v[key]
        .as_f64()
        .unwrap_or_else(|| panic!("{key} is not a number in {v}"))
}

/// The acceptance criteria on one motion and rig: the four methods are reported with
/// RMSE, CRB and best-single-sensor figures; fusion is within 10 % of its Cramér–Rao bound and
/// at least 38 % below linear trilateration.
fn check_acceptance(report: &Value) {
    for name in ["geometric", "linear", "nls", "fusion"] {
        let m = method(report, name);
        for key in ["rmse_m", "crb_rmse_m", "best_single_sensor_rmse_m"] {
            let v = f(m, key);
            assert!(v.is_finite() && v > 0.0, "{name}.{key} = {v}");
        }
    }
    let fusion = method(report, "fusion");
    let linear = method(report, "linear");
    let ratio = f(fusion, "rmse_m") / f(fusion, "crb_rmse_m");
    assert!(ratio <= 1.10, "fusion RMSE / CRB = {ratio:.3}");
    let below = 1.0 - f(fusion, "rmse_m") / f(linear, "rmse_m");
    assert!(
        below >= 0.38,
        "fusion only {:.1} % below linear",
        below * 100.0
    );
    // The same comparison on the samples both solved, as the report states it.
    assert!(f(fusion, "gain_over_linear") >= 0.38);
}

/// `trigait eval --motion 07_01.c3d --rig thesis --trials 20 --json` (an acceptance run).
#[test]
fn cmu_walk_on_thesis_rig() {
    let Some(c3d) = trigait_test_data::shared_file("mocap-cmu-07_01/07_01.c3d") else {
        return;
    };
    let report = eval_json(&[
        "--motion",
        c3d.to_str().unwrap(),
        "--rig",
        "thesis",
        "--trials",
        "20",
    ]);
    assert_eq!(report["frames"], 316);
    assert_eq!(report["trials"], 20);
    assert_eq!(report["sensors"].as_array().unwrap().len(), 3);
    check_acceptance(&report);
}

/// `trigait eval --motion Rajagopal…trc --rig ring-6 --trials 20 --json` (an acceptance run).
#[test]
fn rajagopal_walk_on_ring_6() {
    let Some(trc) = trigait_test_data::shared_file(
        "mocap-opensim-rajagopal-walk/Rajagopal__motion_capture_walk.trc",
    ) else {
        return;
    };
    let report = eval_json(&[
        "--motion",
        trc.to_str().unwrap(),
        "--rig",
        "ring-6",
        "--trials",
        "20",
    ]);
    assert_eq!(report["frames"], 238);
    assert_eq!(report["sensors"].as_array().unwrap().len(), 6);
    check_acceptance(&report);
}

/// The default run (embedded walker, thesis rig) needs no files and prints readable tables.
#[test]
fn default_eval_prints_tables() {
    let out = trigait(&["eval", "--trials", "3"]);
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    for needle in ["rig thesis", "fusion", "RMSE per joint", "knee_left", "CRB"] {
        assert!(text.contains(needle), "{needle:?} missing from:\n{text}");
    }
}

/// The same seed gives the same report whatever the thread count; another seed differs.
#[test]
fn seeded_and_thread_independent() {
    let a = eval_json(&["--trials", "4", "--threads", "1", "--seed", "3"]);
    let b = eval_json(&["--trials", "4", "--threads", "2", "--seed", "3"]);
    let c = eval_json(&["--trials", "4", "--threads", "1", "--seed", "4"]);
    for name in ["linear", "fusion"] {
        let (ra, rb) = (f(method(&a, name), "rmse_m"), f(method(&b, name), "rmse_m"));
        assert!((ra - rb).abs() < 1e-12, "{name}: {ra} vs {rb}");
        assert_eq!(method(&a, name)["p95_m"], method(&b, name)["p95_m"]);
        assert_ne!(method(&a, name)["rmse_m"], method(&c, name)["rmse_m"]);
    }
}

/// Bad input is a one-line error and exit code 2, naming what was wrong.
#[test]
fn bad_input_is_a_clear_error() {
    let dir = std::env::temp_dir().join(format!("trigait-eval-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bad_rig = dir.join("bad-rig.yml");
    std::fs::write(&bad_rig, "sensors:\n  - id: k1\n    position: [0, 0, 1]\n").unwrap();
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["--rig", "triangle"], "unknown rig \"triangle\""),
        (
            vec!["--methods", "fusion,kalman"],
            "unknown estimator \"kalman\"",
        ),
        (
            vec!["--motion", "nowhere.c3d"],
            "neither `walker` nor an existing",
        ),
        (
            vec!["--rig", bad_rig.to_str().unwrap()],
            "sensor \"k1\": `look_at`",
        ),
        (vec!["--rig", "thesis", "--sensors", "5"], "has 3 sensors"),
        (vec!["--joints", "tail"], "unknown joint \"tail\""),
        (vec!["--trials", "0"], "0 is not in 1..=10000"),
    ];
    for (args, expected) in cases {
        let mut all = vec!["eval"];
        all.extend(args.iter());
        let out = trigait(&all);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{all:?}: {stderr}");
        assert!(stderr.contains(expected), "{all:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{all:?}: {stderr}");
    }
    let truncated = dir.join("truncated.trc");
    std::fs::write(&truncated, "PathFileType\t4\t(X/Y/Z)\ttruncated.trc\n").unwrap();
    let out = trigait(&["eval", "--motion", truncated.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("loading motion"));
    std::fs::remove_dir_all(&dir).ok();
}

/// `trigait bench` prints each estimator's throughput as a ratio to linear trilateration, and
/// without a Python interpreter says how to get the SciPy baseline instead of failing.
#[test]
fn bench_prints_ratios_against_linear() {
    let export = std::env::temp_dir().join(format!("trigait-bench-{}.json", std::process::id()));
    let out = trigait(&[
        "bench",
        "--problems",
        "300",
        "--export",
        export.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("300 joint observations"), "{text}");
    let linear = text.lines().find(|l| l.starts_with("linear")).unwrap();
    assert!(linear.trim_end().ends_with("1.00×"), "{linear}");
    assert!(text.contains("SciPy baseline skipped"), "{text}");
    let problems: Value = serde_json::from_slice(&std::fs::read(&export).unwrap()).unwrap();
    let first = &problems["problems"][0];
    assert_eq!(
        first["sensors"].as_array().unwrap().len(),
        first["ranges"].as_array().unwrap().len()
    );
    std::fs::remove_file(&export).ok();
}
