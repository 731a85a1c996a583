//! The evaluation harness on the embedded walker: statistics are like for like, efficient
//! estimators sit at their bound, and specs parse as the CLI accepts them.

// Test helpers outside `#[test]` functions panic on failure by design.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use trigait_eval::{EvalConfig, MethodSpec, evaluate};
use trigait_kinect::NoiseModel;
use trigait_rig::Rig;
use trigait_sim::Simulator;
use trigait_skeleton::Joint;
use trigait_trilateration::Method;

fn walker_on(rig: &str) -> (Simulator, Rig) {
    let rig = Rig::from_spec(rig).unwrap();
    let clip = trigait_motion::walker(&trigait_motion::WalkerParams::default(), 2.5, 30.0)
        .unwrap()
        .placed_on_walkway();
    (
        Simulator::new(&rig, clip, &Joint::LEGS, &NoiseModel::default()),
        rig,
    )
}

/// On a 5-sensor ring: NLS and fusion reach their Cramér–Rao bounds within 10 %, fusion beats
/// every range-only method and the best single sensor, and every method is scored on the same
/// common samples.
#[test]
fn efficient_methods_reach_their_bounds() {
    let (sim, rig) = walker_on("ring-5");
    let config = EvalConfig {
        trials: 8,
        ..EvalConfig::default()
    };
    let report = evaluate(&sim, &rig.name, &config, &|_| {});
    assert_eq!(report.methods.len(), 5);
    assert!(report.common_samples > 0 && report.common_samples <= report.joint_samples);
    let by = |name: &str| report.methods.iter().find(|m| m.method == name).unwrap();
    for name in ["nls", "fusion"] {
        let ratio = by(name).rmse_over_crb;
        assert!((0.9..=1.1).contains(&ratio), "{name}: RMSE/CRB {ratio}");
    }
    for name in ["geometric", "linear", "nls"] {
        assert!(by("fusion").rmse_m < by(name).rmse_m, "fusion vs {name}");
    }
    assert!(by("fusion").rmse_m < by("fusion").best_single_sensor_rmse_m);
    assert!(by("linear").gain_over_linear.abs() < 1e-12);
    // Fusion solves everything a range-only method solves, and more.
    assert!(by("fusion").own.solved >= by("linear").own.solved);
    let per_joint: usize = by("fusion").per_joint_rmse_m.len();
    assert_eq!(per_joint, 6);
}

/// The progress callback sees every trial finish exactly once.
#[test]
fn progress_counts_trials() {
    let (sim, rig) = walker_on("thesis");
    let config = EvalConfig {
        trials: 5,
        methods: vec![MethodSpec::plain(Method::Fusion)],
        threads: 2,
        ..EvalConfig::default()
    };
    let seen = std::sync::Mutex::new(Vec::new());
    let _ = evaluate(&sim, &rig.name, &config, &|done| {
        seen.lock().unwrap().push(done)
    });
    let mut seen = seen.into_inner().unwrap();
    seen.sort_unstable();
    assert_eq!(seen, vec![1, 2, 3, 4, 5]);
}

/// Method specs parse with and without `+robust`, and unknown names are rejected.
#[test]
fn method_specs_parse() {
    let spec: MethodSpec = "nls+robust".parse().unwrap();
    assert_eq!(spec.method, Method::Nls);
    assert!(spec.robust);
    assert_eq!(spec.name(), "nls+robust");
    assert_eq!(
        "fusion".parse::<MethodSpec>().unwrap(),
        MethodSpec::plain(Method::Fusion)
    );
    assert!("bogus+robust".parse::<MethodSpec>().is_err());
}
