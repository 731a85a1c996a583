//! The README's calibration table: the six acceptance walks (the walker, CMU 07_01 and
//! Rajagopal, out and back on two lanes 1 m apart, on the thesis rig and ring-6, from the rig
//! perturbed by 30 cm and 20°), each with its worst sensor and how much of the error is the
//! world frame's (tilt across and along the walk, heading, origin).
//!
//! `cargo build --release --workspace --examples && target/release/examples/calibration_table`

use trigait_calibration_sim::{Scenario, simulate};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let seeds: Vec<u64> = std::env::args().nth(1).map_or_else(
        || vec![1],
        |a| a.split(',').filter_map(|s| s.parse().ok()).collect(),
    );
    println!(
        "| walk | rig | seed | error mm | shape mm | rotation ° | frame tilt x / y, heading ° | \
         frame origin x / y / z mm | fusion RMSE calibrated / true mm |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for (name, motion) in [
        ("walker", "walker"),
        ("CMU 07_01", "mocap-cmu-07_01/07_01.c3d"),
        (
            "Rajagopal",
            "mocap-opensim-rajagopal-walk/Rajagopal__motion_capture_walk.trc",
        ),
    ] {
        let motion = if motion == "walker" {
            motion.to_owned()
        } else {
            let Some(path) = trigait_test_data::shared_file(motion) else {
                continue;
            };
            path.to_string_lossy().into_owned()
        };
        for rig in ["thesis", "ring-6"] {
            for &seed in &seeds {
                let o = simulate(&Scenario::acceptance(&motion, rig, seed))?;
                let worst = |f: fn(&trigait_calibration_sim::SensorScore) -> f64| {
                    o.scores.iter().map(f).fold(0.0, f64::max)
                };
                let fe = o.frame_error;
                println!(
                    "| {name} | {rig} | {seed} | {:.1} | {:.1} | {:.2} | {:.3} / {:.3}, {:.3} | \
                     {:.1} / {:.1} / {:.1} | {:.2} / {:.2} |",
                    worst(|s| s.position_error_m) * 1e3,
                    worst(|s| s.shape_error_m) * 1e3,
                    worst(|s| s.rotation_error_rad).to_degrees(),
                    fe.rotation_rad[0].to_degrees(),
                    fe.rotation_rad[1].to_degrees(),
                    fe.rotation_rad[2].to_degrees(),
                    fe.origin_m[0] * 1e3,
                    fe.origin_m[1] * 1e3,
                    fe.origin_m[2] * 1e3,
                    o.fusion_rmse_calibrated_m * 1e3,
                    o.fusion_rmse_true_m * 1e3,
                );
                let g = &o.calibration.gauge;
                eprintln!(
                    "   gauge: {} stance samples, spread {:.2}/{:.2} m, floor rms {:.1} mm, σ rot {:.3}/{:.3}/{:.3}°, floor {:.3}° from the lab's",
                    g.stance_samples,
                    g.stance_spread_m[0],
                    g.stance_spread_m[1],
                    g.floor_rms_m * 1e3,
                    g.rotation_sigma_rad[0].to_degrees(),
                    g.rotation_sigma_rad[1].to_degrees(),
                    g.rotation_sigma_rad[2].to_degrees(),
                    o.floor_tilt_rad.to_degrees()
                );
            }
        }
    }
    Ok(())
}
