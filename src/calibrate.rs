//! `trigait calibrate`: the rig from the walk itself, on a simulated walk scored against the
//! true rig (`trigait-calibration-sim`), or on a trial recording's per-sensor joint tracks
//! (`--recording`, `trigait-recording`); this module only wires arguments and prints.

use std::fmt::Write as _;
use std::path::PathBuf;

use eyre::WrapErr;
use serde::Serialize;
use trigait_calibration_sim::{Outcome, Scenario, simulate};

/// Calibrates a rig from a simulated walk, starting from a perturbed rig (or from the data
/// alone), and scores the result against the true rig.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Motion: `walker` or a C3D/TRC marker file, placed on the walkway.
    #[arg(long, conflicts_with = "recording", default_value = "walker")]
    motion: String,
    /// The true rig: `thesis`, `ring-N` or a YAML rig file.
    #[arg(long, conflicts_with = "recording", default_value = "thesis")]
    rig: String,
    /// Perturbation of the rough rig the calibration starts from: metres each sensor is moved (in
    /// a random direction) and degrees it is turned about the vertical (left or right at random).
    #[arg(long, conflicts_with = "recording", default_value = "0.3,20", value_parser = parse_perturb)]
    perturb: (f64, f64),
    /// Where the adjustment starts: `rig` (the perturbed rig) or `data` (pairwise alignment).
    #[arg(long, default_value = "rig", value_parser = ["rig", "data"])]
    init: String,
    /// Path: `lanes` (out and back, the way back `--lane-m` to the side) or `straight` (one pass).
    #[arg(long, conflicts_with = "recording", default_value = "lanes", value_parser = ["lanes", "straight"])]
    path: String,
    /// Distance between the outbound and the return lane, metres (0: back on the same line).
    #[arg(allow_negative_numbers = true, long, conflicts_with = "recording", default_value_t = 1.0, value_parser = crate::ranges::number(0.0, 10.0, "m"))]
    lane_m: f64,
    /// Out-and-back laps.
    #[arg(allow_negative_numbers = true, long, conflicts_with = "recording", default_value_t = 1, value_parser = crate::ranges::count(1, 50))]
    laps: usize,
    /// Time between the passes while the walker turns (not simulated: nothing is reported), s.
    #[arg(allow_negative_numbers = true, long, conflicts_with = "recording", default_value_t = 1.0, value_parser = crate::ranges::number(0.0, 60.0, "s"))]
    turn_secs: f64,
    /// A sensor whose skeleton output has left and right swapped throughout.
    #[arg(long, conflicts_with = "recording")]
    swap: Option<String>,
    /// Seed of the sensor noise and of the perturbation.
    #[arg(long, conflicts_with = "recording", default_value_t = 1)]
    seed: u64,
    /// Write the calibrated rig here (a rig YAML file the graphs read).
    #[arg(long)]
    output: Option<PathBuf>,
    /// Print the report as JSON instead of tables.
    #[arg(long)]
    json: bool,
    /// Also write a rerun recording (`.rrd`) of the sensors and their joint tracks before (the
    /// rough rig) and after the calibration; open it with `rerun FILE`.
    #[arg(long)]
    rrd: Option<PathBuf>,
    /// Calibrate from a trial recording instead (a recorder's `OUTPUT_DIR`, or its
    /// `frames.csv`: the frames on their recorded server stamps); `--init rig` then starts from
    /// `--start-rig`. The simulation options do not apply.
    #[arg(long)]
    recording: Option<PathBuf>,
    /// With `--recording` and `--init rig`: the rough rig to start from (`thesis`, `ring-N` or
    /// a YAML file; default: the recording's own `rig.yml`, the rig the trial ran with).
    #[arg(long, requires = "recording")]
    start_rig: Option<String>,
}

fn parse_perturb(s: &str) -> Result<(f64, f64), String> {
    let parts: Vec<&str> = s.split(',').collect();
    let [m, deg] = parts.as_slice() else {
        return Err(format!("expected METRES,DEGREES (e.g. 0.3,20), got {s:?}"));
    };
    let m: f64 = m.trim().parse().map_err(|e| format!("{m:?}: {e}"))?;
    let deg: f64 = deg.trim().parse().map_err(|e| format!("{deg:?}: {e}"))?;
    if !(m.is_finite() && deg.is_finite() && m >= 0.0 && deg >= 0.0) {
        return Err(format!(
            "perturbation must be two non-negative numbers, got {s:?}"
        ));
    }
    Ok((m, deg))
}

/// `trigait calibrate --recording DIR`.
fn run_recording(args: &Args, given: &std::path::Path) -> eyre::Result<()> {
    // The directory, or its frames file.
    let dir = match given.parent() {
        Some(parent)
            if given.is_file()
                && given.file_name() == Some(trigait_recording::FRAMES_FILE.as_ref()) =>
        {
            if parent.as_os_str().is_empty() {
                std::path::Path::new(".")
            } else {
                parent
            }
        }
        _ => given,
    };
    let frames_path = dir.join(trigait_recording::FRAMES_FILE);
    let frames = trigait_recording::read_frames(&frames_path)
        .wrap_err_with(|| format!("reading the recording {}", dir.display()))?;
    if !frames.is_empty() && frames.iter().all(|f| f.server_stamp_nanos.is_none()) {
        eyre::bail!(
            "{}: none of its {} frames has a server stamp, so the sensors share no clock to \
             calibrate on (was the recording made with `sync` ahead of the recorder?)",
            frames_path.display(),
            frames.len()
        );
    }
    let tracks = trigait_recording::calibration_tracks(&frames);
    let start = match (&args.start_rig, args.init.as_str()) {
        (_, "data") => None,
        (Some(spec), _) => Some(
            trigait_rig::Rig::from_spec(spec)
                .map_err(|e| eyre::eyre!("--start-rig {spec:?}: {e}"))?,
        ),
        (None, _) => {
            let path = dir.join(trigait_recording::RIG_FILE);
            Some(
                trigait_rig::Rig::from_spec(&path.display().to_string()).map_err(|e| {
                    eyre::eyre!(
                        "the recording's rig {}: {e} (or give --start-rig)",
                        path.display()
                    )
                })?,
            )
        }
    };
    let initial = start
        .as_ref()
        .map_or(trigait_calibration::Initial::FromData, |rig| {
            trigait_calibration::Initial::Rig(rig)
        });
    let timer = std::time::Instant::now();
    let calibration =
        trigait_calibration::calibrate(&tracks, initial, &trigait_calibration::Params::default())
            .wrap_err_with(|| format!("calibrating from {}", frames_path.display()))?;
    let secs = timer.elapsed().as_secs_f64();
    let name = dir.file_name().map_or_else(
        || "recording".to_owned(),
        |n| n.to_string_lossy().into_owned(),
    );
    if let Some(path) = &args.output {
        write_rig(path, &format!("{name}-calibrated"), &calibration)?;
    }
    if let Some(path) = &args.rrd {
        write_rrd(path, &tracks, start.as_ref(), &calibration)?;
    }
    if args.json {
        crate::stdout::print_json(&calibration)?;
    } else {
        let mut out = String::new();
        let _ = writeln!(
            out,
            "trigait calibrate: recording {} ({} frames, {} sensors), start from {}, {} iterations, {secs:.3} s",
            dir.display(),
            frames.len(),
            tracks.len(),
            calibration.initial,
            calibration.iterations
        );
        if let Some(rig) = &start {
            let unused: Vec<&str> = rig
                .sensors
                .iter()
                .map(|s| s.id.as_str())
                .filter(|id| !tracks.iter().any(|t| t.id == *id))
                .collect();
            if !unused.is_empty() {
                let _ = writeln!(
                    out,
                    "note: the rig started from ({}) has sensors the recording has no frames of, left out: {}",
                    rig.name,
                    unused.join(", ")
                );
            }
        }
        render_sensors(&mut out, &calibration);
        render_findings(&mut out, &calibration);
        crate::stdout::print(&out)?;
    }
    Ok(())
}

fn write_rig(
    path: &std::path::Path,
    name: &str,
    calibration: &trigait_calibration::Calibration,
) -> eyre::Result<()> {
    trigait_recording::write_calibrated_rig(path, name, calibration)
        .wrap_err("writing the calibrated rig")
}

/// `--rrd`: the sensors and tracks before and after (`trigait-calibration-rerun`).
fn write_rrd(
    path: &std::path::Path,
    tracks: &[trigait_calibration::SensorTrack],
    start: Option<&trigait_rig::Rig>,
    calibration: &trigait_calibration::Calibration,
) -> eyre::Result<()> {
    let rec = trigait_calibration_rerun::save("trigait-calibrate", path)
        .map_err(|e| eyre::eyre!("--rrd: {e}"))?;
    trigait_calibration_rerun::log_calibration(&rec, tracks, start, calibration)
        .wrap_err_with(|| format!("logging to {}", path.display()))?;
    rec.flush_blocking()
        .wrap_err_with(|| format!("writing {}", path.display()))
}

/// Runs `trigait calibrate`.
pub fn run(args: &Args) -> eyre::Result<()> {
    if let Some(dir) = &args.recording {
        return run_recording(args, dir);
    }
    let scenario = Scenario {
        motion: args.motion.clone(),
        rig: args.rig.clone(),
        perturb: args.perturb,
        from_data: args.init == "data",
        lane_m: (args.path == "lanes").then_some(args.lane_m),
        laps: args.laps,
        turn_secs: args.turn_secs,
        swap: args.swap.clone(),
        seed: args.seed,
    };
    let outcome = simulate(&scenario).wrap_err("calibrating a simulated walk")?;
    if let Some(path) = &args.output {
        write_rig(
            path,
            &format!("{}-calibrated", outcome.rig),
            &outcome.calibration,
        )?;
    }
    if let Some(path) = &args.rrd {
        let start = (!scenario.from_data).then_some(&outcome.rough);
        write_rrd(path, &outcome.tracks, start, &outcome.calibration)?;
    }
    if args.json {
        crate::stdout::print_json(&JsonReport::new(&outcome))?;
    } else {
        crate::stdout::print(&render(&outcome))?;
    }
    Ok(())
}

/// `--json` output.
#[derive(Debug, Serialize)]
struct JsonReport<'a> {
    #[serde(flatten)]
    outcome: &'a Outcome,
    /// Calibrated poses: id, position (m), yaw/pitch/roll (deg), as in rig files.
    poses: Vec<(String, [f64; 3], [f64; 3])>,
}

impl<'a> JsonReport<'a> {
    fn new(outcome: &'a Outcome) -> Self {
        let poses = outcome
            .calibration
            .sensors
            .iter()
            .filter_map(|s| {
                let p = s.world_from_kinect?;
                let t = p.translation.vector;
                Some((
                    s.id.clone(),
                    [t.x, t.y, t.z],
                    trigait_calibration::yaw_pitch_roll_deg(&p.rotation),
                ))
            })
            .collect();
        Self { outcome, poses }
    }
}

fn render(o: &Outcome) -> String {
    let c = &o.calibration;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "trigait calibrate: motion {} ({:.1} s), rig {} ({} sensors), start from {}, {} iterations, {:.3} s",
        o.motion,
        o.duration_secs,
        o.rig,
        c.sensors.len(),
        c.initial,
        c.iterations,
        o.calibrate_secs
    );
    render_sensors(&mut out, c);
    let _ = writeln!(
        out,
        "\nagainst the truth (its world frame fixed from the true joints the same way; shape: \
         after the rigid motion that best maps the true sensor centres onto the calibrated ones):"
    );
    let _ = writeln!(
        out,
        "{:<6} {:>12} {:>12} {:>12} {:>16} {:>16}",
        "sensor", "error mm", "error deg", "shape mm", "rough rig mm", "rough rig deg"
    );
    for s in &o.scores {
        let _ = writeln!(
            out,
            "{:<6} {:>12.1} {:>12.3} {:>12.1} {:>16.0} {:>16.1}",
            s.id,
            s.position_error_m * 1e3,
            s.rotation_error_rad.to_degrees(),
            s.shape_error_m * 1e3,
            s.rough_position_error_m * 1e3,
            s.rough_rotation_error_rad.to_degrees()
        );
    }
    let g = &c.gauge;
    let _ = writeln!(
        out,
        "\nworld frame: up from the plane of {} pelvis samples (RMS {:.1} mm), floor from {} stance \
         ankle samples (spread {:.2} m along, {:.2} m across the walk, RMS {:.1} mm), ankle height \
         {:.3} m; σ rotation x/y/z {:.3}/{:.3}/{:.3} deg; {:.0} mm and {:.2} deg from the motion's \
         own frame",
        g.pelvis_samples,
        g.pelvis_rms_m * 1e3,
        g.stance_samples,
        g.stance_spread_m[0],
        g.stance_spread_m[1],
        g.floor_rms_m * 1e3,
        g.ankle_height_m,
        g.rotation_sigma_rad[0].to_degrees(),
        g.rotation_sigma_rad[1].to_degrees(),
        g.rotation_sigma_rad[2].to_degrees(),
        o.frame_offset_m * 1e3,
        o.frame_rotation_rad.to_degrees()
    );
    let _ = writeln!(
        out,
        "fusion RMSE on a fresh draw ({} joint samples): true rig {:.1} mm, calibrated rig {:.1} mm ({:.3}×)",
        o.fusion_samples,
        o.fusion_rmse_true_m * 1e3,
        o.fusion_rmse_calibrated_m * 1e3,
        o.fusion_rmse_calibrated_m / o.fusion_rmse_true_m
    );
    let _ = writeln!(
        out,
        "time: calibration {:.3} s = {:.1}× one single-sensor fusion pass over the same frames ({:.4} s)",
        o.calibrate_secs,
        o.calibrate_secs / o.fusion_pass_secs.max(1e-9),
        o.fusion_pass_secs
    );
    render_findings(&mut out, c);
    out
}

/// The per-sensor table: pose, uncertainty, residual, outliers, swaps.
fn render_sensors(out: &mut String, c: &trigait_calibration::Calibration) {
    let _ = writeln!(
        out,
        "\n{:<6} {:>22} {:>19} {:>22} {:>20} {:>9} {:>8} {:>8} {:>9}",
        "sensor",
        "position x/y/z m",
        "ypr deg",
        "σ x/y/z mm",
        "σ rot x/y/z deg",
        "resid mm",
        "outliers",
        "swapped",
        "reference"
    );
    for s in &c.sensors {
        let Some(p) = s.world_from_kinect else {
            let _ = writeln!(out, "{:<6} not calibrated", s.id);
            continue;
        };
        let t = p.translation.vector;
        let ypr = trigait_calibration::yaw_pitch_roll_deg(&p.rotation);
        let [sx, sy, sz] = s.position_sigma_m;
        let [rx, ry, rz] = s.rotation_sigma_rad;
        let _ = writeln!(
            out,
            "{:<6} {:>22} {:>19} {:>22} {:>20} {:>9.1} {:>8} {:>8} {:>9}",
            s.id,
            format!("{:.3} {:.3} {:.3}", t.x, t.y, t.z),
            format!("{:.1} {:.1} {:.1}", ypr[0], ypr[1], ypr[2]),
            format!("{:.1} {:.1} {:.1}", sx * 1e3, sy * 1e3, sz * 1e3),
            format!(
                "{:.2} {:.2} {:.2}",
                rx.to_degrees(),
                ry.to_degrees(),
                rz.to_degrees()
            ),
            s.residual_rms_m * 1e3,
            s.outliers,
            s.swapped_frames,
            if s.reference { "yes" } else { "" }
        );
    }
}

/// The findings, or that there are none.
fn render_findings(out: &mut String, c: &trigait_calibration::Calibration) {
    if c.findings.is_empty() {
        let _ = writeln!(
            out,
            "\nevery pose determined within tolerance; nothing to report"
        );
    } else {
        let _ = writeln!(out, "\nfindings:");
        for f in &c.findings {
            let _ = writeln!(out, "  - {}", f.message);
        }
    }
}
