//! `trigait bench`: estimator throughput as ratios against baselines measured in the same run —
//! every method against the thesis's `linear`, and our `nls` against SciPy's `least_squares` on
//! identical problems.
//!
//! Absolute solve rates on a shared machine are noise; ratios measured back to back are not.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use eyre::{WrapErr, bail, eyre};
use serde::{Deserialize, Serialize};
use trigait_kinect::NoiseModel;
use trigait_sim::Simulator;
use trigait_skeleton::Joint;
use trigait_trilateration::{Method, Observation, Params, estimate};

/// Times the estimators on simulated frames, and SciPy on the same NLS problems.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Rig: `thesis`, `ring-N` or a YAML rig file.
    #[arg(long, default_value = "ring-6")]
    rig: String,
    /// Joint observations to solve (frames × leg joints of the walker), 1 to 1,000,000.
    #[arg(allow_negative_numbers = true, long, default_value_t = 3000, value_parser = crate::ranges::count(1, 1_000_000))]
    problems: usize,
    /// Seed of the simulated noise (any 64-bit number).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Python interpreter with NumPy and SciPy for the SciPy baseline (scripts/bench.sh sets up
    /// one in .venv); without it the SciPy comparison is skipped with a message.
    #[arg(long)]
    python: Option<PathBuf>,
    /// Where to write the exported NLS problems [default: a file in the temp directory].
    #[arg(long)]
    export: Option<PathBuf>,
}

/// One range-only problem as exported to SciPy.
#[derive(Debug, Serialize)]
struct NlsProblem {
    sensors: Vec<[f64; 3]>,
    ranges: Vec<f64>,
    sigmas: Vec<f64>,
    start: [f64; 3],
}

#[derive(Debug, Deserialize)]
struct ScipyResult {
    solves_per_sec: f64,
    solutions: Vec<[f64; 3]>,
    scipy: String,
}

/// Runs `trigait bench`.
pub fn run(args: &Args) -> eyre::Result<()> {
    let rig = crate::eval::load_rig(Some(&args.rig), None)?;
    let clip = trigait_motion::walker(&trigait_motion::WalkerParams::default(), 2.5, 30.0)
        .wrap_err("generating the walker")?
        .placed_on_walkway();
    let sim = Simulator::new(&rig, clip, &Joint::LEGS, &NoiseModel::default());
    let inputs = problems(&sim, args.seed, args.problems);
    if inputs.is_empty() {
        bail!("no joint was seen by three sensors on rig {:?}", rig.name);
    }
    crate::stdout::outln!(
        "trigait bench: {} joint observations from the walker on rig {} ({} sensors), one thread",
        inputs.len(),
        rig.name,
        rig.sensors.len()
    )?;

    let linear_rate = solves_per_sec(&inputs, &Params::new(Method::Linear));
    crate::stdout::outln!(
        "\n{:<15} {:>14} {:>12}",
        "method",
        "solves/s",
        "vs linear ×"
    )?;
    let mut nls_rate = 0.0;
    for (method, robust) in [
        (Method::Geometric, false),
        (Method::Linear, false),
        (Method::Nls, false),
        (Method::Fusion, false),
        (Method::Fusion, true),
    ] {
        let params = Params::new(method).with_robust(robust);
        let rate = if method == Method::Linear && !robust {
            linear_rate
        } else {
            solves_per_sec(&inputs, &params)
        };
        if method == Method::Nls {
            nls_rate = rate;
        }
        let name = if robust {
            format!("{method}+robust")
        } else {
            method.to_string()
        };
        crate::stdout::outln!("{name:<15} {rate:>14.0} {:>11.2}×", rate / linear_rate)?;
    }

    let export = args
        .export
        .clone()
        .unwrap_or_else(|| std::env::temp_dir().join("trigait-nls-problems.json"));
    let ours = export_problems(&inputs, &export)?;
    crate::stdout::outln!(
        "\nexported {} NLS problems to {}",
        ours.len(),
        export.display()
    )?;
    let Some(python) = &args.python else {
        crate::stdout::outln!(
            "SciPy baseline skipped: pass --python PATH (scripts/bench.sh installs NumPy and SciPy into .venv)"
        )?;
        return Ok(());
    };
    let scipy = run_scipy(python, &export)?;
    let max_diff = ours
        .iter()
        .zip(&scipy.solutions)
        .map(|(a, b)| {
            let d: f64 = (0..3).map(|i| (a[i] - b[i]).powi(2)).sum();
            d.sqrt()
        })
        .fold(0.0, f64::max);
    crate::stdout::outln!(
        "scipy.optimize.least_squares (SciPy {}, method=lm): {:.0} solves/s; trigait nls: {:.0} solves/s = {:.1}× SciPy",
        scipy.scipy,
        scipy.solves_per_sec,
        nls_rate,
        nls_rate / scipy.solves_per_sec
    )?;
    crate::stdout::outln!("largest difference between the two solutions: {max_diff:.2e} m")?;
    if max_diff > 1e-6 {
        bail!("SciPy and trigait disagree by {max_diff:.3e} m on the same problems");
    }
    Ok(())
}

/// `count` noisy observations of leg joints seen by at least three sensors, from as many
/// walks across the rig (each with its own noise) as it takes.
fn problems(sim: &Simulator, seed: u64, count: usize) -> Vec<Vec<Observation>> {
    let motion = sim.motion();
    let fusion = trigait_fusion::FusionRig::from_sensors(sim.sensors().to_vec());
    let mut out = Vec::with_capacity(count);
    for walk in 0..1000 {
        let mut rngs: Vec<_> = (0..sim.sensors().len())
            .map(|s| Simulator::sensor_rng(seed.wrapping_add(walk), s))
            .collect();
        let before = out.len();
        for frame in 0..motion.frame_count() {
            let snapshot = sim.snapshot(frame as f64 / motion.rate_hz(), &mut rngs);
            let mut observed = trigait_eval::observe_snapshot(&fusion, sim, &snapshot);
            for joint in sim.joints() {
                let Some(seen) = observed.joints.remove(joint) else {
                    continue;
                };
                if seen.observations.len() >= 3 && out.len() < count {
                    out.push(seen.observations);
                }
            }
        }
        if out.len() >= count || out.len() == before {
            break;
        }
    }
    out
}

/// Best of five passes over all inputs, solves per second.
fn solves_per_sec(inputs: &[Vec<Observation>], params: &Params) -> f64 {
    let mut best = f64::INFINITY;
    for _ in 0..5 {
        let start = Instant::now();
        for obs in inputs {
            std::hint::black_box(estimate(std::hint::black_box(obs), params).ok());
        }
        best = best.min(start.elapsed().as_secs_f64());
    }
    inputs.len() as f64 / best
}

/// Writes the NLS problems (with the linear start our solver uses) and returns our solutions.
fn export_problems(inputs: &[Vec<Observation>], path: &Path) -> eyre::Result<Vec<[f64; 3]>> {
    let mut problems = Vec::with_capacity(inputs.len());
    let mut solutions = Vec::with_capacity(inputs.len());
    for obs in inputs {
        let (Ok(start), Ok(nls)) = (
            estimate(obs, &Params::new(Method::Linear)),
            estimate(obs, &Params::new(Method::Nls)),
        ) else {
            continue;
        };
        problems.push(NlsProblem {
            sensors: obs
                .iter()
                .map(|o| o.sensor_in_world().coords.into())
                .collect(),
            ranges: obs.iter().map(Observation::range_m).collect(),
            sigmas: obs.iter().map(Observation::range_sigma_m).collect(),
            start: start.position.coords.into(),
        });
        solutions.push(nls.position.coords.into());
    }
    let json = serde_json::json!({ "problems": problems });
    std::fs::write(path, serde_json::to_vec(&json)?)
        .wrap_err_with(|| format!("writing {}", path.display()))?;
    Ok(solutions)
}

fn run_scipy(python: &Path, problems: &Path) -> eyre::Result<ScipyResult> {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("scripts/bench_scipy_nls.py");
    let output = Command::new(python)
        .arg(&script)
        .arg(problems)
        .output()
        .wrap_err_with(|| format!("running {}", python.display()))?;
    if !output.status.success() {
        return Err(eyre!(
            "the SciPy baseline failed ({}): {}",
            output.status,
            String::from_utf8_lossy(&output.stderr).trim()
        ));
    }
    serde_json::from_slice(&output.stdout).wrap_err("reading the SciPy baseline's JSON")
}
