//! `trigait gait FILE`: gait events and spatiotemporal parameters of a marker file, as a table or
//! JSON, with optional plots. Wiring only; the analysis is `trigait-gait`.

use std::path::{Path, PathBuf};

use clap::ValueEnum;
use eyre::WrapErr;
use serde::Serialize;
use trigait_gait::filter::Filter;
use trigait_gait::{
    Comparison, EventKind, EventMethod, Foot, GaitAnalysis, GaitParams, Stat, Tolerances,
    TreadmillMode, plot,
};
use trigait_skeleton::{Joint, MotionClip};

/// Arguments of `trigait gait`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Motion file: C3D/TRC markers (joint centres are derived), joint trajectories as trigait
    /// exports them (C3D/TRC with joint-named markers, CSV), or Kinect v2 SDK skeleton text
    /// (`.txt`).
    pub file: PathBuf,
    /// Gait-event detector: auto (coordinate method for walking, foot velocity for running),
    /// Zeni et al. 2008 coordinate method, or foot velocity.
    #[arg(long, value_enum, default_value_t = Method::Auto)]
    pub method: Method,
    /// Treadmill walking, at SPEED m/s if given (else the belt speed is estimated from the
    /// stance feet), 0 to 10 m/s. Without the option a treadmill is detected from a fixed
    /// pelvis and periodic feet.
    #[arg(allow_negative_numbers = true, long, value_name = "SPEED", num_args = 0..=1, value_parser = crate::ranges::number(0.0, 10.0, "m/s"))]
    pub treadmill: Option<Option<f64>>,
    /// Overground walking: never apply the treadmill correction.
    #[arg(long, conflicts_with = "treadmill")]
    pub overground: bool,
    /// Kinect SDK skeleton text (.txt): keep joints the tracker only inferred (dropped by
    /// default: an occluded leg is often inferred far from the real one).
    #[arg(long)]
    pub keep_inferred: bool,
    /// Frame rate of Kinect SDK skeleton text without time stamps (read at the Kinect's 30
    /// frames/s otherwise), 1 to 1000 Hz. Files with their own rate or time stamps refuse it.
    #[arg(allow_negative_numbers = true, long, value_name = "HZ", value_parser = crate::ranges::number(1.0, 1000.0, "Hz"))]
    pub rate: Option<f64>,
    /// Find the events on the joint centres (ankles, feet, pelvis) even when the file has heel
    /// and toe markers, as on a joint export of it.
    #[arg(long)]
    pub joint_centres: bool,
    /// Trajectory filter, applied after outliers are rejected and before event detection: none,
    /// butterworth:<f>hz (zero-lag, e.g. butterworth:6hz) or one-euro[:<min cut-off>hz:<beta>].
    /// Default: butterworth:6hz for Kinect skeletons and joint trajectories (none below about
    /// 16 Hz, too slow for it), none for skin-marker files and the joint centres placed from them.
    #[arg(long, value_parser = parse_filter)]
    pub filter: Option<Filter>,
    /// Print the full result (segments, excluded phases, events, strides, summary) as JSON.
    #[arg(long)]
    pub json: bool,
    /// Write trajectory and footfall plots (SVG and PNG) into this directory.
    #[arg(long, value_name = "DIR")]
    pub plots: Option<PathBuf>,
    /// Fewest complete strides (both feet together) accepted; with 0, figures rest on single
    /// steps where no stride exists (the table marks them).
    #[arg(allow_negative_numbers = true, long, default_value_t = 0, value_parser = crate::ranges::count(0, 1000))]
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
    /// Filter applied to the simulated Kinect trajectories in their gait analysis (after its
    /// cleaning).
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
    /// Coordinate method for walking, velocity method when flight phases show running.
    Auto,
    /// Heel/toe position relative to the pelvis along the walking direction (Zeni 2008).
    Coordinate,
    /// Heel/toe horizontal speed against a walking-speed threshold (Ghoussayni 2004).
    Velocity,
}

impl From<Method> for EventMethod {
    fn from(m: Method) -> Self {
        match m {
            Method::Auto => EventMethod::Auto,
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
    notes: Vec<String>,
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
    /// The file's parameters on its joint centres (ankles), which the pipeline is compared with.
    reference: trigait_gait::Summary,
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

/// Kinect v2 SDK skeletons are delivered at 30 frames/s.
const SDK_RATE_HZ: f64 = 30.0;

/// A motion file made ready for gait analysis.
pub struct GaitInput {
    /// Joint trajectories (joint centres, a joint export, or a Kinect skeleton); `None` when
    /// the markers give no joint centres (e.g. no knee or ankle markers). Plots and
    /// `--kinect-sim` use it.
    pub clip: Option<MotionClip>,
    /// What the events are found on: heel, toe and pelvis markers when the file has them,
    /// else the clip's ankles, feet and pelvis.
    pub landmarks: trigait_gait::Landmarks,
    /// Notes on how the file was read, for the report.
    pub notes: Vec<String>,
    /// The filter the analysis applies after its cleaning: the input's default (6 Hz for a
    /// skeleton stream or joint trajectories, none for skin markers and the joint centres placed
    /// from them) until [`analyse_file`] puts `--filter` in its place.
    pub filter: Filter,
}

/// The joints a [`trigait_gait::Landmarks`] becomes for plotting: pelvis →
/// `SpineBase`, heels → ankles, toes → feet.
fn landmarks_clip(name: &str, l: &trigait_gait::Landmarks) -> eyre::Result<MotionClip> {
    let frames = (0..l.len())
        .map(|f| {
            vec![
                l.pelvis[f],
                l.heel[0][f],
                l.toe[0][f],
                l.heel[1][f],
                l.toe[1][f],
            ]
        })
        .collect();
    MotionClip::new(
        name,
        l.rate_hz,
        vec![
            Joint::SpineBase,
            Joint::AnkleLeft,
            Joint::FootLeft,
            Joint::AnkleRight,
            Joint::FootRight,
        ],
        frames,
    )
    .wrap_err("assembling the landmark trajectories")
}

/// Whether `path` is Kinect SDK skeleton text (`.txt`), which [`load_input`] reads.
pub fn is_sdk_text(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("txt"))
}

/// Reads `path` for gait analysis: Kinect SDK skeleton text (`.txt`), markers (C3D/TRC: heel,
/// toe and pelvis markers for the events, joint centres for plots when the markers allow), or
/// joint trajectories (trigait exports, CSV).
pub fn load_input(
    path: &Path,
    keep_inferred: bool,
    joint_centres: bool,
    rate_hz: Option<f64>,
) -> eyre::Result<GaitInput> {
    if path.is_dir() {
        eyre::bail!("{} is a directory: give one motion file", path.display());
    }
    let name = path
        .file_name()
        .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
    if is_sdk_text(path) {
        let log = trigait_motion::read_sdk_log(path)
            .wrap_err_with(|| format!("reading Kinect skeletons from {}", path.display()))?;
        let frames = log.frames;
        let timed = trigait_motion::is_timed(&frames);
        if timed && rate_hz.is_some() {
            eyre::bail!(
                "--rate: {} has time stamps, which place its frames; the option is for \
                 skeleton text without them",
                path.display()
            );
        }
        let rate = rate_hz.unwrap_or(SDK_RATE_HZ);
        let sdk = trigait_motion::sdk_clip(&name, &frames, rate, !keep_inferred)?;
        let clock = match (timed, rate_hz) {
            (true, _) => "placed by their time stamps",
            (false, Some(_)) => "untimed, rate given with --rate",
            (false, None) => "untimed, rate assumed (--rate to give it)",
        };
        let mut notes = vec![format!(
            "Kinect v2 SDK skeletons at {rate:.0} Hz ({clock}), camera space turned Z up; \
             {} repeated and {} missing frame numbers; {} inferred joint samples {}",
            sdk.repeated_frames,
            sdk.missing_frames,
            sdk.inferred_dropped + sdk.inferred_kept,
            if keep_inferred { "kept" } else { "dropped" }
        )];
        if let Some(cut) = log.cut_last_line {
            notes.push(cut.to_string());
        }
        if sdk.swapped_frames > 0 {
            let runs: Vec<String> = sdk
                .swapped_runs
                .iter()
                .map(|r| format!("{:.2}-{:.2} s", r.start as f64 / rate, r.end as f64 / rate))
                .collect();
            notes.push(format!(
                "left and right swapped back in {} frames walking away from the sensor ({}): \
                 the SDK fits a skeleton that faces the sensor to the person's back",
                sdk.swapped_frames,
                runs.join(", ")
            ));
        }
        let landmarks = trigait_gait::Landmarks::from_clip(&sdk.clip)?;
        if !sdk.clip.has(Joint::FootLeft) {
            notes.push("no foot joints: toe offs from the ankles".to_owned());
        }
        return Ok(GaitInput {
            filter: trigait_gait::filter::skeleton_filter(landmarks.rate_hz),
            clip: Some(sdk.clip),
            landmarks,
            notes,
        });
    }
    if rate_hz.is_some() {
        eyre::bail!(
            "--rate is for Kinect SDK skeleton text without time stamps; {} states its own rate",
            path.display()
        );
    }
    if keep_inferred {
        eyre::bail!(
            "--keep-inferred is for Kinect SDK skeleton text, whose joints carry a tracking \
             state; {} has none",
            path.display()
        );
    }
    let format = trigait_motion::MotionFormat::from_path(path)
        .map_err(|e| eyre::eyre!("{e}; Kinect SDK skeleton text (.txt) is read too"))?;
    if format == trigait_motion::MotionFormat::Csv {
        let clip = load_clip(path)?;
        let landmarks = trigait_gait::Landmarks::from_clip(&clip)?;
        return Ok(GaitInput {
            filter: trigait_gait::filter::skeleton_filter(landmarks.rate_hz),
            clip: Some(clip),
            landmarks,
            notes: vec!["joint trajectories: ankle centres stand in for the heels".to_owned()],
        });
    }
    let markers = trigait_motion::read_markers(path)
        .wrap_err_with(|| format!("reading markers from {}", path.display()))?;
    if let Some(clip) = trigait_motion::joints_from_labels(&markers) {
        trigait_motion::check_clip_scale(path, &clip)?;
        let landmarks = trigait_gait::Landmarks::from_clip(&clip)?;
        return Ok(GaitInput {
            filter: trigait_gait::filter::skeleton_filter(landmarks.rate_hz),
            clip: Some(clip),
            landmarks,
            notes: vec!["joint trajectories: ankle centres stand in for the heels".to_owned()],
        });
    }
    if joint_centres {
        let clip = trigait_motion::joint_centres(&markers)
            .wrap_err_with(|| format!("placing joint centres from {}", path.display()))?;
        trigait_motion::check_clip_scale(path, &clip)?;
        let landmarks = trigait_gait::Landmarks::from_clip(&clip)?;
        return Ok(GaitInput {
            clip: Some(clip),
            landmarks,
            notes: vec!["joint centres: ankle centres stand in for the heels".to_owned()],
            filter: Filter::None,
        });
    }
    let feet = trigait_motion::foot_markers(&markers)
        .wrap_err_with(|| format!("finding heel and pelvis markers in {}", path.display()))?;
    trigait_motion::check_foot_marker_scale(path, &feet)?;
    let mut notes = vec![format!(
        "skin markers: events and step width from heel and toe markers ({})",
        feet.labels.join(", ")
    )];
    let toe = [0, 1].map(|s| feet.toe[s].clone().unwrap_or_else(|| feet.heel[s].clone()));
    if feet.toe.iter().any(Option::is_none) {
        notes.push("a toe marker is missing: toe offs from the heel marker".to_owned());
    }
    let landmarks = trigait_gait::Landmarks {
        rate_hz: markers.rate_hz(),
        pelvis: feet.pelvis,
        heel: feet.heel,
        toe,
        heel_source: trigait_gait::HeelSource::HeelMarker,
    };
    let clip = match trigait_motion::joint_centres(&markers) {
        Ok(clip) => Some(clip),
        Err(e) => {
            notes.push(format!("no joint centres (plots show the markers): {e}"));
            None
        }
    };
    let gaps: usize = markers.gaps().iter().map(|g| g.missing_frames).sum();
    if gaps > 0 {
        notes.push(format!(
            "{} markers have gaps ({gaps} missing marker-frames in all)",
            markers.gaps().len()
        ));
    }
    Ok(GaitInput {
        clip,
        landmarks,
        notes,
        filter: Filter::None,
    })
}

/// The gait parameters `args` ask for.
fn gait_params(args: &Args) -> GaitParams {
    let mut params = GaitParams::default();
    params.events.method = args.method.into();
    params.min_strides = args.min_strides;
    params.treadmill = match (args.treadmill, args.overground) {
        (Some(speed), _) => TreadmillMode::Treadmill {
            belt_speed_mps: speed,
        },
        (None, true) => TreadmillMode::Overground,
        (None, false) => TreadmillMode::Auto,
    };
    params
}

/// Reads and analyses `args.file` (filtered after the cleaning): the input (for plots) and the
/// analysis.
pub fn analyse_file(args: &Args) -> eyre::Result<(GaitInput, GaitAnalysis)> {
    let input = load_input(
        &args.file,
        args.keep_inferred,
        args.joint_centres,
        args.rate,
    )?;
    let filter = args.filter.unwrap_or(input.filter);
    filter.validate(input.landmarks.rate_hz).wrap_err_with(|| {
        format!(
            "--filter {filter} on {} at {:.0} Hz",
            args.file.display(),
            input.landmarks.rate_hz
        )
    })?;
    let input = GaitInput { filter, ..input };
    let params = GaitParams {
        filter,
        ..gait_params(args)
    };
    let analysis = match trigait_gait::analyse_landmarks(&input.landmarks, &params) {
        Ok(a) => a,
        Err(e) => {
            // What the reading noticed (a cut-off last line, swapped sides, inferred joints
            // dropped) may be why: said before the error rather than lost with the table.
            for note in &input.notes {
                eprintln!("note: {note}");
            }
            return Err(e)
                .wrap_err_with(|| format!("analysing the gait in {}", args.file.display()));
        }
    };
    Ok((input, analysis))
}

/// The clip plots draw: the joint centres, else the landmarks as joints.
pub fn plot_clip(input: &GaitInput, file: &Path) -> eyre::Result<MotionClip> {
    match &input.clip {
        Some(c) if c.has(Joint::AnkleLeft) => Ok(c.clone()),
        _ => landmarks_clip(&file.display().to_string(), &input.landmarks),
    }
}

/// Runs `trigait gait`.
pub fn run(args: Args) -> eyre::Result<()> {
    let (input, analysis) = analyse_file(&args)?;
    let params = gait_params(&args);
    let kinect_sim = if args.kinect_sim {
        let clip = input.clip.as_ref().ok_or_else(|| {
            eyre::eyre!("--kinect-sim needs joint centres, which these markers do not give")
        })?;
        Some(run_kinect_sim(&args, clip, &params)?)
    } else {
        None
    };
    let clip = plot_clip(&input, &args.file)?;
    if let Some(dir) = &args.plots {
        write_plots(dir, &args.file, &clip, &analysis)?;
    }
    if args.json {
        let report = Report {
            file: args.file.display().to_string(),
            filter: input.filter.to_string(),
            notes: input.notes.clone(),
            heel_strikes: Counts::of(&analysis, EventKind::HeelStrike),
            toe_offs: Counts::of(&analysis, EventKind::ToeOff),
            analysis: &analysis,
            kinect_sim,
        };
        crate::stdout::print_json(&report)
    } else {
        let mut text = table(&args, &input, &analysis);
        if let Some(k) = &kinect_sim {
            text.push_str(&kinect_table(k));
        }
        crate::stdout::print(&text)
    }
}

/// The pipeline is compared with the file's own joint centres, not with its heel markers: the
/// Kinects track joint centres, so both sides then measure events and step width on the
/// ankles, and the difference is the pipeline's error rather than a change of definition.
fn run_kinect_sim(args: &Args, clip: &MotionClip, params: &GaitParams) -> eyre::Result<KinectSim> {
    let reference = trigait_gait::analyse(clip, params)
        .wrap_err("analysing the gait of the file's joint centres")?;
    let rig = crate::eval::load_rig(Some(&args.rig), None)
        .wrap_err_with(|| format!("loading rig {:?}", args.rig))?;
    let motion = clip.placed_on_walkway();
    let fused = simulate_kinect_pipeline(&motion, &rig, args.seed)?;
    let kinect_params = GaitParams {
        filter: args.kinect_filter,
        ..*params
    };
    let analysis = trigait_gait::analyse(&fused, &kinect_params)
        .wrap_err("analysing the gait seen by the simulated Kinect pipeline")?;
    let comparison = trigait_gait::compare(&reference.summary, &analysis.summary);
    let reference = reference.summary;
    let tolerances = Tolerances::ISSUE_5;
    Ok(KinectSim {
        rig: rig.name.clone(),
        seed: args.seed,
        filter: args.kinect_filter.to_string(),
        rate_hz: KINECT_RATE_HZ,
        heel_strikes: Counts::of(&analysis, EventKind::HeelStrike),
        reference,
        summary: analysis.summary,
        within_tolerances: comparison.within(&tolerances),
        comparison,
        tolerances,
    })
}

fn kinect_table(k: &KinectSim) -> String {
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
        "parameter (unit)", "joints", "kinect", "difference", "tolerance"
    );
    let r = &k.reference;
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

fn write_plots(
    dir: &Path,
    file: &Path,
    clip: &MotionClip,
    analysis: &GaitAnalysis,
) -> eyre::Result<()> {
    if dir.exists() && !dir.is_dir() {
        eyre::bail!(
            "--plots {} is a file: the plots go into a directory (give a new or existing one)",
            dir.display()
        );
    }
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
fn table(args: &Args, input: &GaitInput, a: &GaitAnalysis) -> String {
    use std::fmt::Write;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{}: {:.0} Hz, {:.2} s, method {}, filter {}",
        args.file.display(),
        a.rate_hz,
        a.duration_secs,
        a.method.name(),
        input.filter
    );
    for note in trigait_gait::report::quality_notes(&input.notes, a) {
        let _ = writeln!(out, "note: {note}");
    }
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
        "strides: {} ({} left, {} right), steps: {}; n = strides each figure rests on, \
         or steps where marked *\n",
        s.strides, s.left_strides, s.right_strides, s.steps
    );
    let _ = writeln!(
        out,
        "{:<24} {:>8} {:>8} {:>8} {:>8} {:>8} {:>4}",
        "parameter (unit)", "mean", "SD", "left", "right", "asym. %", "n"
    );
    for row in s.rows() {
        let stat = row.stat;
        let _ = writeln!(
            out,
            "{:<24} {:>8} {:>8} {:>8} {:>8} {:>8} {:>4}",
            row.label,
            cell(stat.mean, row.digits),
            cell(stat.sd, row.digits),
            cell(stat.left, row.digits),
            cell(stat.right, row.digits),
            cell(stat.asymmetry_pct, 1),
            format!("{}{}", stat.n, if stat.from_steps { "*" } else { "" })
        );
    }
    if a.timing.implausible {
        let timed: Vec<&str> = s
            .rows()
            .iter()
            .filter(|r| r.timed)
            .map(|r| r.label)
            .collect();
        let _ = writeln!(
            out,
            "\nTIMING IMPLAUSIBLE (see the note above): {} scale with the time base and are \
             wrong with it; the lengths, the width and the phase percentages are not",
            timed.join(", ")
        );
    }
    if let Some(dir) = &args.plots {
        let _ = writeln!(out, "\nplots written to {}", dir.display());
    }
    out
}
