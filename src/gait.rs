//! `trigait gait FILE`: gait events and spatiotemporal parameters of a marker file, as a table or
//! JSON, with optional plots. Wiring only; the analysis is `trigait-gait`.

use std::path::{Path, PathBuf};

use clap::ValueEnum;
use eyre::WrapErr;
use serde::Serialize;
use trigait_gait::filter::Filter;
use trigait_gait::{
    Comparison, EventKind, EventMethod, Foot, GaitAnalysis, GaitParams, Stat, Tolerances, plot,
};
use trigait_skeleton::{Joint, MotionClip};

/// Arguments of `trigait gait`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Motion file: C3D/TRC markers (joint centres are derived), or joint trajectories as trigait
    /// exports them (C3D/TRC with joint-named markers, CSV).
    pub file: PathBuf,
    /// Gait-event detector: Zeni et al. 2008 coordinate method, or foot velocity.
    #[arg(long, value_enum, default_value_t = Method::Coordinate)]
    pub method: Method,
    /// Trajectory filter before event detection: none, butterworth:<f>hz (zero-lag, e.g.
    /// butterworth:6hz) or one-euro[:<min cut-off>hz:<beta>].
    #[arg(long, default_value = "none", value_parser = parse_filter)]
    pub filter: Filter,
    /// Print the full result (segments, excluded phases, events, strides, summary) as JSON.
    #[arg(long)]
    pub json: bool,
    /// Write trajectory and footfall plots (SVG and PNG) into this directory.
    #[arg(long, value_name = "DIR")]
    pub plots: Option<PathBuf>,
    /// Fewest complete strides (both feet together) accepted, 0 to 1000.
    #[arg(long, default_value_t = 2, value_parser = crate::ranges::count(0, 1000))]
    pub min_strides: usize,
    /// Also play the walk through the simulated Kinect pipeline (rig, Kinect v2 noise model,
    /// fusion estimator, 30 Hz) and compare its gait parameters with those of the file.
    #[arg(long)]
    pub kinect_sim: bool,
    /// Rig for `--kinect-sim`: a built-in name (thesis, ring-N) or a rig YAML file.
    #[arg(long, default_value = "thesis", requires = "kinect_sim")]
    pub rig: String,
    /// Noise seed for `--kinect-sim` (any 64-bit number).
    #[arg(long, default_value_t = 1, requires = "kinect_sim")]
    pub seed: u64,
    /// Filter applied to the simulated Kinect trajectories before their gait analysis.
    #[arg(long, default_value = "butterworth:6hz", value_parser = parse_filter, requires = "kinect_sim")]
    pub kinect_filter: Filter,
}

/// Sample rate of the simulated Kinect pipeline (a Kinect v2 delivers 30 frames/s).
const KINECT_RATE_HZ: f64 = 30.0;

/// The walk as the simulated Kinect pipeline sees it: `motion` (already on the rig's walkway)
/// observed by every sensor of `rig` at 30 Hz with the Kinect v2 noise model, and each joint
/// fused by the maximum-likelihood `fusion` estimator through [`trigait_fusion::fuse_instant`]
/// (the dataflow's `trilaterate` code). Joints no sensor reports in a frame, or
/// that the estimator cannot solve, are gaps.
pub fn simulate_kinect_pipeline(
    motion: &MotionClip,
    rig: &trigait_rig::Rig,
    seed: u64,
) -> eyre::Result<MotionClip> {
    use trigait_trilateration::{Method as Estimator, Params};
    let mut joints = Joint::LEGS.to_vec();
    joints.extend([Joint::FootLeft, Joint::FootRight]);
    let sim = trigait_sim::Simulator::new(
        rig,
        motion.clone(),
        &joints,
        &trigait_kinect::NoiseModel::default(),
    );
    let mut rngs: Vec<_> = (0..sim.sensors().len())
        .map(|s| trigait_sim::Simulator::sensor_rng(seed, s))
        .collect();
    let fusion = trigait_fusion::FusionRig::from_sensors(sim.sensors().to_vec());
    let params = Params::new(Estimator::Fusion);
    let frames = (motion.duration_secs() * KINECT_RATE_HZ).floor() as usize + 1;
    let rows = (0..frames)
        .map(|k| {
            let snapshot = sim.snapshot(k as f64 / KINECT_RATE_HZ, &mut rngs);
            let fused = trigait_eval::fuse_snapshot(&fusion, &sim, &snapshot, &params);
            sim.joints()
                .iter()
                .map(|joint| {
                    let f = fused.joints.get(joint)?;
                    f.result.as_ref().ok().map(|e| e.position)
                })
                .collect()
        })
        .collect();
    MotionClip::new(
        format!("{} via simulated Kinects ({})", motion.name(), rig.name),
        KINECT_RATE_HZ,
        sim.joints().to_vec(),
        rows,
    )
    .wrap_err("assembling the simulated Kinect trajectories")
}

/// Event detector, as named on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Method {
    /// Heel/toe position relative to the pelvis along the walking direction (Zeni 2008).
    Coordinate,
    /// Heel/toe horizontal speed against a walking-speed threshold (Ghoussayni 2004).
    Velocity,
}

impl From<Method> for EventMethod {
    fn from(m: Method) -> Self {
        match m {
            Method::Coordinate => EventMethod::Coordinate,
            Method::Velocity => EventMethod::Velocity,
        }
    }
}

fn parse_filter(spec: &str) -> Result<Filter, String> {
    spec.parse::<Filter>().map_err(|e| e.to_string())
}

/// The JSON document `--json` prints.
#[derive(Debug, Serialize)]
struct Report<'a> {
    file: String,
    filter: String,
    heel_strikes: Counts,
    toe_offs: Counts,
    #[serde(flatten)]
    analysis: &'a GaitAnalysis,
    #[serde(skip_serializing_if = "Option::is_none")]
    kinect_sim: Option<KinectSim>,
}

/// `--kinect-sim` result: the pipeline's own analysis and its difference from the file's.
#[derive(Debug, Serialize)]
struct KinectSim {
    rig: String,
    seed: u64,
    filter: String,
    rate_hz: f64,
    summary: trigait_gait::Summary,
    heel_strikes: Counts,
    /// Estimate − reference (markers) for each mean parameter.
    comparison: Comparison,
    tolerances: Tolerances,
    within_tolerances: bool,
}

#[derive(Debug, Serialize)]
struct Counts {
    left: usize,
    right: usize,
}

impl Counts {
    fn of(analysis: &GaitAnalysis, kind: EventKind) -> Self {
        Self {
            left: analysis.events_of(Foot::Left, kind).count(),
            right: analysis.events_of(Foot::Right, kind).count(),
        }
    }
}

/// Loads a motion file as joint trajectories with `trigait_motion::load_motion`: skin-marker
/// C3D/TRC files become joint centres, trigait's own exports (joint-named C3D/TRC, joint CSV)
/// are read as they are.
pub fn load_clip(path: &Path) -> eyre::Result<MotionClip> {
    trigait_motion::load_motion(path)
        .wrap_err_with(|| format!("reading joint trajectories from {}", path.display()))
}

/// Runs `trigait gait`.
pub fn run(args: Args) -> eyre::Result<()> {
    let clip = load_clip(&args.file)?;
    let clip = args
        .filter
        .apply(&clip)
        .wrap_err_with(|| format!("filtering with {}", args.filter))?;
    let mut params = GaitParams::default();
    params.events.method = args.method.into();
    params.min_strides = args.min_strides;
    let analysis = trigait_gait::analyse(&clip, &params)
        .wrap_err_with(|| format!("analysing the gait in {}", args.file.display()))?;
    let kinect_sim = if args.kinect_sim {
        Some(run_kinect_sim(&args, &clip, &params, &analysis)?)
    } else {
        None
    };
    if let Some(dir) = &args.plots {
        write_plots(dir, &args.file, &clip, &analysis)?;
    }
    if args.json {
        let report = Report {
            file: args.file.display().to_string(),
            filter: args.filter.to_string(),
            heel_strikes: Counts::of(&analysis, EventKind::HeelStrike),
            toe_offs: Counts::of(&analysis, EventKind::ToeOff),
            analysis: &analysis,
            kinect_sim,
        };
        let text = serde_json::to_string_pretty(&report).wrap_err("encoding the JSON report")?;
        print_stdout(&format!("{text}\n"))
    } else {
        let mut text = table(&args, &clip, &analysis);
        if let Some(k) = &kinect_sim {
            text.push_str(&kinect_table(&analysis, k));
        }
        print_stdout(&text)
    }
}

fn run_kinect_sim(
    args: &Args,
    clip: &MotionClip,
    params: &GaitParams,
    reference: &GaitAnalysis,
) -> eyre::Result<KinectSim> {
    let rig = crate::eval::load_rig(Some(&args.rig), None)
        .wrap_err_with(|| format!("loading rig {:?}", args.rig))?;
    let motion = clip.placed_on_walkway();
    let fused = simulate_kinect_pipeline(&motion, &rig, args.seed)?;
    let fused = args.kinect_filter.apply(&fused).wrap_err_with(|| {
        format!(
            "filtering the Kinect trajectories with {}",
            args.kinect_filter
        )
    })?;
    let analysis = trigait_gait::analyse(&fused, params)
        .wrap_err("analysing the gait seen by the simulated Kinect pipeline")?;
    let comparison = trigait_gait::compare(&reference.summary, &analysis.summary);
    let tolerances = Tolerances::ISSUE_5;
    Ok(KinectSim {
        rig: rig.name.clone(),
        seed: args.seed,
        filter: args.kinect_filter.to_string(),
        rate_hz: KINECT_RATE_HZ,
        heel_strikes: Counts::of(&analysis, EventKind::HeelStrike),
        summary: analysis.summary,
        within_tolerances: comparison.within(&tolerances),
        comparison,
        tolerances,
    })
}

fn kinect_table(reference: &GaitAnalysis, k: &KinectSim) -> String {
    use std::fmt::Write;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "\nsimulated Kinect pipeline: rig {}, {:.0} Hz, fusion estimator, filter {}, seed {}",
        k.rig, k.rate_hz, k.filter, k.seed
    );
    let _ = writeln!(
        out,
        "{:<24} {:>8} {:>8} {:>10} {:>10}",
        "parameter", "markers", "kinect", "difference", "tolerance"
    );
    let r = &reference.summary;
    let e = &k.summary;
    let c = &k.comparison;
    // (name, markers, kinect, difference, tolerance, digits)
    type Row<'a> = (&'a str, &'a Stat, &'a Stat, Option<f64>, String, usize);
    let rows: [Row; 6] = [
        (
            "stride length (m)",
            &r.stride_length_m,
            &e.stride_length_m,
            c.stride_length_m,
            format!("{}", k.tolerances.stride_length_m),
            3,
        ),
        (
            "cadence (steps/min)",
            &r.cadence_steps_per_min,
            &e.cadence_steps_per_min,
            c.cadence_pct,
            format!("{} %", k.tolerances.cadence_pct),
            1,
        ),
        (
            "step width (m)",
            &r.step_width_m,
            &e.step_width_m,
            c.step_width_m,
            format!("{}", k.tolerances.step_width_m),
            3,
        ),
        (
            "step length (m)",
            &r.step_length_m,
            &e.step_length_m,
            c.step_length_m,
            String::new(),
            3,
        ),
        (
            "speed (m/s)",
            &r.speed_mps,
            &e.speed_mps,
            c.speed_mps,
            String::new(),
            3,
        ),
        (
            "stance (%)",
            &r.stance_pct,
            &e.stance_pct,
            c.stance_pct,
            String::new(),
            1,
        ),
    ];
    for (name, a, b, d, tol, digits) in rows {
        let _ = writeln!(
            out,
            "{:<24} {:>8} {:>8} {:>10} {:>10}",
            name,
            cell(a.mean, digits),
            cell(b.mean, digits),
            cell(d, digits),
            tol
        );
    }
    let _ = writeln!(
        out,
        "within tolerance (stride length 3 cm, cadence 2 %, step width 2 cm): {}",
        if k.within_tolerances { "yes" } else { "NO" }
    );
    out
}

/// Writes `text` to stdout; a closed pipe (`trigait gait … | head`) ends quietly.
pub fn print_stdout(text: &str) -> eyre::Result<()> {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => {
            Err(e).wrap_err("writing to standard output")
        }
        _ => Ok(()),
    }
}

fn write_plots(
    dir: &Path,
    file: &Path,
    clip: &MotionClip,
    analysis: &GaitAnalysis,
) -> eyre::Result<()> {
    std::fs::create_dir_all(dir)
        .wrap_err_with(|| format!("creating the plot directory {}", dir.display()))?;
    let stem = file
        .file_stem()
        .map_or_else(|| "gait".to_owned(), |s| s.to_string_lossy().into_owned());
    let write = |name: String, bytes: &[u8]| -> eyre::Result<()> {
        let path = dir.join(name);
        std::fs::write(&path, bytes).wrap_err_with(|| format!("writing {}", path.display()))
    };
    write(
        format!("{stem}_trajectories.svg"),
        plot::trajectories_svg(clip, analysis, &[])?.as_bytes(),
    )?;
    write(
        format!("{stem}_trajectories.png"),
        &plot::trajectories_png(clip, analysis, &[])?,
    )?;
    write(
        format!("{stem}_footfall.svg"),
        plot::footfall_svg(clip, analysis)?.as_bytes(),
    )?;
    write(
        format!("{stem}_footfall.png"),
        &plot::footfall_png(clip, analysis)?,
    )?;
    Ok(())
}

fn cell(v: Option<f64>, digits: usize) -> String {
    v.map_or_else(|| "-".to_owned(), |v| format!("{v:.digits$}"))
}

/// The human-readable report.
fn table(args: &Args, clip: &MotionClip, a: &GaitAnalysis) -> String {
    use std::fmt::Write;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{}: {:.0} Hz, {:.2} s, method {}, filter {}",
        args.file.display(),
        clip.rate_hz(),
        a.duration_secs,
        a.method.name(),
        args.filter
    );
    for (i, s) in a.segments.iter().enumerate() {
        let _ = writeln!(
            out,
            "segment {i}: {:.2}-{:.2} s, walking direction ({:+.3}, {:+.3}), pelvis speed {:.2} m/s",
            s.start_secs, s.end_secs, s.direction[0], s.direction[1], s.speed_mps
        );
    }
    if a.excluded.is_empty() {
        let _ = writeln!(out, "excluded: nothing (no standing, turning or gaps)");
    }
    for p in &a.excluded {
        let _ = writeln!(
            out,
            "excluded: {} {:.2}-{:.2} s ({} frames)",
            p.reason.name(),
            p.start_secs,
            p.end_secs,
            p.frames
        );
    }
    for foot in Foot::BOTH {
        let times = |kind| {
            a.events_of(foot, kind)
                .map(|e| format!("{:.3}", e.time_secs))
                .collect::<Vec<_>>()
                .join(" ")
        };
        let _ = writeln!(
            out,
            "{:<5} heel strikes (s): {}\n{:<5} toe offs (s):     {}",
            foot.name(),
            times(EventKind::HeelStrike),
            foot.name(),
            times(EventKind::ToeOff)
        );
    }
    let s = &a.summary;
    let _ = writeln!(
        out,
        "strides: {} ({} left, {} right); partial strides at the ends give events, not parameters\n",
        s.strides, s.left_strides, s.right_strides
    );
    let _ = writeln!(
        out,
        "{:<24} {:>8} {:>8} {:>8} {:>8} {:>8} {:>3}",
        "parameter", "mean", "sd", "left", "right", "asym%", "n"
    );
    let rows: [(&str, &Stat, f64, usize); 9] = [
        ("stride length (m)", &s.stride_length_m, 1.0, 3),
        ("step length (m)", &s.step_length_m, 1.0, 3),
        ("step width (m)", &s.step_width_m, 1.0, 3),
        ("cadence (steps/min)", &s.cadence_steps_per_min, 1.0, 1),
        ("speed (m/s)", &s.speed_mps, 1.0, 3),
        ("stride time (s)", &s.stride_time_secs, 1.0, 3),
        ("stance (%)", &s.stance_pct, 1.0, 1),
        ("swing (%)", &s.swing_pct, 1.0, 1),
        ("double support (%)", &s.double_support_pct, 1.0, 1),
    ];
    for (name, stat, scale, digits) in rows {
        let scaled = |v: Option<f64>| v.map(|v| v * scale);
        let _ = writeln!(
            out,
            "{:<24} {:>8} {:>8} {:>8} {:>8} {:>8} {:>3}",
            name,
            cell(scaled(stat.mean), digits),
            cell(scaled(stat.sd), digits),
            cell(scaled(stat.left), digits),
            cell(scaled(stat.right), digits),
            cell(stat.asymmetry_pct, 1),
            stat.n
        );
    }
    if let Some(dir) = &args.plots {
        let _ = writeln!(out, "\nplots written to {}", dir.display());
    }
    out
}
