//! Benchmark: 30 s of walking (the walker out and back on two lanes, 12 passes of 2.5 s) seen by the six sensors of
//! `ring-6`, calibrated from the perturbed rig on one core; printed against a baseline measured
//! in the same run (one pass weighing and fusing every report of the same frames).
//!
//! `cargo build --release --workspace --examples && taskset -c 0 target/release/examples/calibrate_30s`

use trigait_calibration_sim::{Scenario, simulate};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    for (rig, from_data) in [("ring-6", false), ("ring-6", true), ("thesis", false)] {
        let o = simulate(&Scenario {
            motion: "walker".into(),
            rig: rig.into(),
            perturb: (0.3, 20.0),
            from_data,
            lane_m: Some(1.0),
            laps: 6,
            turn_secs: 1.0,
            swap: None,
            seed: 1,
        })?;
        let worst = o
            .scores
            .iter()
            .map(|s| s.position_error_m)
            .fold(0.0, f64::max);
        println!(
            "{rig} from {}: {:.1} s of walk ({} sensors): calibration {:.3} s = {:.1}× the \
             fusion pass ({:.4} s); {} iterations; worst position error {:.1} mm; fusion RMSE \
             {:.2} vs {:.2} mm",
            o.calibration.initial,
            o.duration_secs,
            o.scores.len(),
            o.calibrate_secs,
            o.calibrate_secs / o.fusion_pass_secs,
            o.fusion_pass_secs,
            o.calibration.iterations,
            worst * 1e3,
            o.fusion_rmse_calibrated_m * 1e3,
            o.fusion_rmse_true_m * 1e3
        );
    }
    Ok(())
}
