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
mod depth_files;
mod depth_metrics;
mod devices;
mod eval;
mod export;
mod gait;
mod legs;
mod output;
mod ranges;
mod report;
mod stdout;

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
    /// Gait events and spatiotemporal parameters (stride, step, cadence, speed, stance) of a walk:
    /// C3D/TRC markers, joint trajectories (C3D/TRC/CSV) or Kinect SDK skeleton text.
    Gait(gait::Args),
    /// Export joint trajectories as TRC (OpenSim), C3D or CSV.
    Export(export::Args),
    /// A self-contained HTML gait report: parameters, trajectories with events, footfall, data quality.
    Report(report::Args),
    /// List the connected Kinect v2 sensors (serial, firmware, depth pipelines) through libfreenect2.
    Devices(devices::Args),
    /// Calibrate the rig from a walk: every sensor's pose, its uncertainty, and why when undetermined.
    Calibrate(calibrate::Args),
    /// Lower-body skeleton from recorded depth frames (no Kinect SDK): person mask, hips, knees, ankles.
    Legs(legs::Args),
}

fn run(args: Args) -> eyre::Result<()> {
    match args.command {
        Command::Bench(args) => bench::run(&args),
        Command::Eval(args) => eval::run(&args),
        Command::DepthMetrics(args) => depth_metrics::run(args),
        Command::Gait(args) => gait::run(args),
        Command::Export(args) => export::run(args),
        Command::Report(args) => report::run(&args),
        Command::Devices(args) => devices::run(&args),
        Command::Calibrate(args) => calibrate::run(&args),
        Command::Legs(args) => legs::run(&args),
    }
}

/// The error and its causes on one line, as `{:#}` prints them, but without a cause whose text
/// the line already ends with (an error that names its source in its own message, such as a
/// path's "No such file or directory", would otherwise say it twice).
fn describe(err: &eyre::Report) -> String {
    let mut line = String::new();
    for cause in err.chain() {
        let text = cause.to_string();
        if line.is_empty() {
            line = text;
        } else if !line.ends_with(&text) {
            line.push_str(": ");
            line.push_str(&text);
        }
    }
    line
}

/// The last panic's message and place, kept by the quiet panic hook.
static LAST_PANIC: std::sync::Mutex<Option<String>> = std::sync::Mutex::new(None);

/// Unless the user asked for backtraces (`RUST_BACKTRACE` set and not `0`), a panic prints
/// nothing where it happens: a reader that contains a third-party parser's panic turns it into
/// its own clean error, and a panic that reaches `main` is printed there as one line.
fn install_quiet_panic_hook() {
    let wants_backtrace = std::env::var_os("RUST_BACKTRACE").is_some_and(|v| v != "0");
    if wants_backtrace {
        return;
    }
    std::panic::set_hook(Box::new(|info| {
        let message = info
            .payload()
            .downcast_ref::<&str>()
            .map(|s| (*s).to_owned())
            .or_else(|| info.payload().downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "unknown panic".to_owned());
        let place = info
            .location()
            .map(|l| format!(" at {}:{}", l.file(), l.line()))
            .unwrap_or_default();
        if let Ok(mut last) = LAST_PANIC.lock() {
            *last = Some(format!("{message}{place}"));
        }
    }));
}

fn main() -> ExitCode {
    install_quiet_panic_hook();
    let args = Args::parse();
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| run(args))) {
        Ok(Ok(())) => ExitCode::SUCCESS,
        Ok(Err(err)) => {
            eprintln!("error: {}", describe(&err));
            ExitCode::from(2)
        }
        Err(_) => {
            let last = LAST_PANIC.lock().ok().and_then(|mut l| l.take());
            eprintln!(
                "error: internal error (a bug in trigait, please report it): {}; run with \
                 RUST_BACKTRACE=1 for a backtrace",
                last.unwrap_or_else(|| "panic".to_owned())
            );
            ExitCode::from(101)
        }
    }
}

#[cfg(test)]
mod tests {
    use clap::CommandFactory;

    /// A cause already at the end of the line is not repeated; other causes follow it.
    #[test]
    fn causes_are_said_once() {
        let io = std::io::Error::new(std::io::ErrorKind::NotFound, "No such file");
        let err = eyre::Report::new(io).wrap_err("a.c3d: No such file");
        assert_eq!(super::describe(&err), "a.c3d: No such file");
        let err = eyre::eyre!("bad header").wrap_err("reading a.c3d");
        assert_eq!(super::describe(&err), "reading a.c3d: bad header");
    }

    /// The clap definition is internally consistent (no clashing flags or ids).
    #[test]
    fn cli_definition_is_consistent() {
        super::Args::command().debug_assert();
    }
}
