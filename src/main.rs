//! `trigait`: the command-line front door to the same operators the dataflow runs.
//!
//! `main` parses, `run` works, and every error is printed once with its whole chain (`{:#}`) and
//! exit code 2, in the manner of ripgrep. Each subcommand lives in its own module and only wires
//! arguments to an `operators/` crate, so a number printed here and one produced inside the
//! dataflow come from the same code.

use std::process::ExitCode;

use clap::{Parser, Subcommand};

mod bench;
mod calibrate;
mod depth_metrics;
mod devices;
mod eval;
mod export;
mod gait;

/// Markerless 3-D gait tracking from several Kinect v2 depth sensors.
#[derive(Debug, Parser)]
#[command(name = "trigait", version, about, long_about = None)]
pub struct Args {
    #[command(subcommand)]
    command: Command,
}

// Each variant's doc comment is its one-line help in `trigait --help`.
#[derive(Debug, Subcommand)]
enum Command {
    /// Estimator throughput as ratios against linear trilateration and against SciPy.
    Bench(bench::Args),
    /// Score the estimators on a simulated rig against ground truth and the Cramér–Rao bound.
    Eval(eval::Args),
    /// Kinect v2 depth accuracy: the thesis's five depth metrics, maps, and a multi-sensor floor check.
    DepthMetrics(depth_metrics::Args),
    /// Gait events and spatiotemporal parameters (stride, step, cadence, speed, stance) of a C3D/TRC walk.
    Gait(gait::Args),
    /// Export joint trajectories as TRC (OpenSim), C3D or CSV.
    Export(export::Args),
    /// List the connected Kinect v2 sensors (serial, firmware, depth pipelines) through libfreenect2.
    Devices(devices::Args),
    /// Calibrate the rig from a walk: every sensor's pose, its uncertainty, and why when undetermined.
    Calibrate(calibrate::Args),
}

fn run(args: Args) -> eyre::Result<()> {
    match args.command {
        Command::Bench(args) => bench::run(&args),
        Command::Eval(args) => eval::run(&args),
        Command::DepthMetrics(args) => depth_metrics::run(args),
        Command::Gait(args) => gait::run(args),
        Command::Export(args) => export::run(args),
        Command::Devices(args) => devices::run(&args),
        Command::Calibrate(args) => calibrate::run(&args),
    }
}

fn main() -> ExitCode {
    match run(Args::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {err:#}");
            ExitCode::from(2)
        }
    }
}

#[cfg(test)]
mod tests {
    use clap::CommandFactory;

    /// The clap definition is internally consistent (no clashing flags or ids).
    #[test]
    fn cli_definition_is_consistent() {
        super::Args::command().debug_assert();
    }
}
