//! `trigait eval`: Monte Carlo comparison of the estimators on a simulated rig.

use std::fmt::Write as _;
use std::path::Path;

use eyre::{WrapErr, bail, eyre};
use trigait_eval::{EvalConfig, MethodSpec, Report};
use trigait_kinect::NoiseModel;
use trigait_rig::Rig;
use trigait_sim::Simulator;
use trigait_skeleton::{Joint, MotionClip};

/// Plays a motion through simulated Kinects many times and scores every estimator against the
/// ground truth and the Cramér–Rao bound.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Motion: `walker` (the embedded parametric walker) or a C3D/TRC marker file, whose
    /// joint centres are derived from its markers. Either is placed on the rig's walkway.
    #[arg(long, default_value = "walker")]
    motion: String,
    /// Rig: `thesis`, `ring-N` or a YAML rig file [default: thesis, or ring-N with --sensors N].
    #[arg(long)]
    rig: Option<String>,
    /// Use only the first N sensors of the rig (without --rig: the built-in ring-N, 3 to 64),
    /// 1 to 256.
    #[arg(allow_negative_numbers = true, long, value_parser = crate::ranges::count(1, 256))]
    sensors: Option<usize>,
    /// Independent noise draws of the whole motion, 1 to 10,000.
    #[arg(allow_negative_numbers = true, long, default_value_t = 20, value_parser = crate::ranges::count(1, 10_000))]
    trials: usize,
    /// Seed of the first trial (trial k uses seed + k; any 64-bit number).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Methods, comma-separated: geometric, linear, nls, fusion, each optionally `+robust`.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "geometric,linear,nls,fusion,fusion+robust"
    )]
    methods: Vec<MethodSpec>,
    /// Joints: `legs` (hips, knees, ankles), `all`, or comma-separated names (knee_left, …).
    #[arg(long, default_value = "legs")]
    joints: String,
    /// Duration of the walker, seconds, 0.1 to 600 (it crosses the 3 m walkway in about 2.5 s).
    #[arg(allow_negative_numbers = true, long, default_value_t = 2.5, value_parser = crate::ranges::number(0.1, 600.0, "s"))]
    duration_secs: f64,
    /// Sampling rate of the walker, Hz, 1 to 1000 (the Kinect v2 frame rate is 30 Hz).
    #[arg(allow_negative_numbers = true, long, default_value_t = 30.0, value_parser = crate::ranges::number(1.0, 1000.0, "Hz"))]
    rate_hz: f64,
    /// Worker threads, 1 to 256 [default: all cores].
    #[arg(allow_negative_numbers = true, long, value_parser = crate::ranges::count(1, 256))]
    threads: Option<usize>,
    /// Print the report as JSON on stdout instead of tables.
    #[arg(long)]
    json: bool,
}

/// Runs `trigait eval`.
pub fn run(args: &Args) -> eyre::Result<()> {
    if args.trials == 0 {
        bail!("--trials must be at least 1");
    }
    let rig = load_rig(args.rig.as_deref(), args.sensors)?;
    let motion = load_motion(&args.motion, args.duration_secs, args.rate_hz)?;
    let joints = parse_joints(&args.joints)?;
    let sim = Simulator::new(&rig, motion, &joints, &NoiseModel::default());
    if sim.joints().is_empty() {
        bail!(
            "motion {:?} defines none of the requested joints ({})",
            sim.motion().name(),
            args.joints
        );
    }
    let config = EvalConfig {
        methods: args.methods.clone(),
        trials: args.trials,
        seed: args.seed,
        threads: args.threads.unwrap_or(EvalConfig::default().threads).max(1),
        ..EvalConfig::default()
    };
    let bar = indicatif::ProgressBar::new(args.trials as u64).with_style(
        indicatif::ProgressStyle::with_template("{prefix} [{bar:30}] {pos}/{len} trials ({eta})")
            .map_err(|e| eyre!("progress template: {e}"))?,
    );
    bar.set_prefix("eval");
    let report = trigait_eval::evaluate(&sim, &rig.name, &config, &|done| {
        bar.set_position(done as u64);
    });
    bar.finish_and_clear();
    require_common_samples(&report)?;
    if args.json {
        crate::stdout::print_json(&report)?;
    } else {
        crate::stdout::print(&render(&report))?;
    }
    Ok(())
}

/// The comparison needs samples that every method solved; without any, every statistic would
/// be NaN or zero and read as a perfect score. The error says what each method solved and why
/// the others failed.
fn require_common_samples(report: &Report) -> eyre::Result<()> {
    if report.common_samples > 0 {
        return Ok(());
    }
    let per_method: Vec<String> = report
        .methods
        .iter()
        .map(|m| {
            let failures: Vec<String> = m
                .own
                .failures
                .iter()
                .map(|(reason, n)| format!("{n} {reason}"))
                .collect();
            let failures = if failures.is_empty() {
                String::new()
            } else {
                format!(" (unsolved: {})", failures.join(", "))
            };
            format!("{} solved {}{failures}", m.method, m.own.solved)
        })
        .collect();
    bail!(
        "no joint sample was solved by every method, so the methods cannot be compared: of {} \
         joint samples, {}; a joint was seen by {:.2} of the rig's {} sensors on average \
         (trilateration needs at least 3 sensors that are not in a line, and the motion in their view)",
        report.joint_samples,
        per_method.join("; "),
        report.visibility.mean_sensors_reporting,
        report.sensors.len()
    )
}

/// A ratio for the table, or a dash when it is not a number.
fn ratio(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.2}")
    } else {
        "–".to_owned()
    }
}

/// The rig from `--rig`/`--sensors`.
pub fn load_rig(spec: Option<&str>, sensors: Option<usize>) -> eyre::Result<Rig> {
    let mut rig = match (spec, sensors) {
        (Some(spec), _) => Rig::from_spec(spec)?,
        (None, Some(n)) => Rig::builtin(&format!("ring-{n}"))
            .ok_or_else(|| eyre!("--sensors {n}: the ring rig takes 3 to 64 sensors"))?,
        (None, None) => Rig::from_spec("thesis")?,
    };
    if let Some(n) = sensors {
        if n == 0 || n > rig.sensors.len() {
            bail!(
                "--sensors {n}: rig {:?} has {} sensors",
                rig.name,
                rig.sensors.len()
            );
        }
        rig.sensors.truncate(n);
    }
    Ok(rig)
}

/// The motion from `--motion`, placed on the walkway.
pub fn load_motion(spec: &str, duration_secs: f64, rate_hz: f64) -> eyre::Result<MotionClip> {
    let clip = if spec == "walker" {
        let params = trigait_motion::WalkerParams::default();
        trigait_motion::walker(&params, duration_secs, rate_hz).wrap_err("generating the walker")?
    } else {
        let path = Path::new(spec);
        if !path.exists() {
            bail!("motion {spec:?} is neither `walker` nor an existing C3D/TRC file");
        }
        trigait_motion::load_motion(path)
            .wrap_err_with(|| format!("loading motion {}", path.display()))?
    };
    Ok(clip.placed_on_walkway())
}

/// Joints from `--joints`.
pub fn parse_joints(spec: &str) -> eyre::Result<Vec<Joint>> {
    match spec.trim() {
        "legs" => Ok(Joint::LEGS.to_vec()),
        "all" => Ok(Joint::ALL.to_vec()),
        list => list
            .split(',')
            .map(|name| {
                Joint::from_name(name.trim())
                    .ok_or_else(|| eyre!("unknown joint {name:?} (e.g. knee_left, ankle_right)"))
            })
            .collect(),
    }
}

fn mm(v: f64) -> String {
    if v.is_finite() {
        format!("{:.1}", v * 1e3)
    } else {
        "–".to_owned()
    }
}

/// The sentence under the table when the range-only methods print identical rows, which
/// would otherwise look like a bug: with three sensors, three ranges fix the three unknowns
/// exactly, so every range method finds the same point (thesis §4.2; its §5.2 results agree).
fn range_methods_agree(r: &Report) -> Option<String> {
    let range: Vec<_> = r
        .methods
        .iter()
        .filter(|m| ["geometric", "linear", "nls"].contains(&m.method.as_str()))
        .collect();
    let first = range.first()?;
    let same = range.len() > 1
        && range.iter().all(|m| {
            (m.rmse_m - first.rmse_m).abs() < 1e-7 && (m.p95_m - first.p95_m).abs() < 1e-7
        });
    (same && r.sensors.len() == 3).then(|| {
        let names: Vec<&str> = range.iter().map(|m| m.method.as_str()).collect();
        format!(
            "({} agree: with 3 sensors the 3 ranges fix the 3 coordinates exactly, so every range-only method finds the same point.)",
            names.join(", ")
        )
    })
}

/// The human-readable tables.
fn render(r: &Report) -> String {
    let mut out = String::new();
    let v = &r.visibility;
    let _ = writeln!(
        out,
        "trigait eval: motion {} ({} frames at {} Hz), rig {} ({} sensors: {}), {} trials from seed {}",
        r.motion,
        r.frames,
        r.rate_hz,
        r.rig,
        r.sensors.len(),
        r.sensors.join(", "),
        r.trials,
        r.seed
    );
    let _ = writeln!(
        out,
        "{} joint samples, {} solved by every method (the statistics below are over those);\n\
         a joint is reported by {:.2} sensors on average (tracked {:.1} %, inferred {:.1} %, not seen {:.1} %)\n",
        r.joint_samples,
        r.common_samples,
        v.mean_sensors_reporting,
        v.tracked_share * 100.0,
        v.inferred_share * 100.0,
        v.not_tracked_share * 100.0
    );
    let _ = writeln!(
        out,
        "{:<15} {:>8} {:>8} {:>8} {:>8} {:>22} {:>8} {:>10} {:>16} {:>11}",
        "method",
        "solved %",
        "RMSE mm",
        "mean mm",
        "p95 mm",
        "RMSE x / y / z mm",
        "CRB mm",
        "RMSE/CRB ×",
        "best 1 sensor mm",
        "vs linear %"
    );
    for m in &r.methods {
        let xyz = format!(
            "{} / {} / {}",
            mm(m.rmse_xyz_m[0]),
            mm(m.rmse_xyz_m[1]),
            mm(m.rmse_xyz_m[2])
        );
        let _ = writeln!(
            out,
            "{:<15} {:>8.1} {:>8} {:>8} {:>8} {:>22} {:>8} {:>10} {:>16} {:>11}",
            m.method,
            m.own.coverage * 100.0,
            mm(m.rmse_m),
            mm(m.mean_m),
            mm(m.p95_m),
            xyz,
            mm(m.crb_rmse_m),
            ratio(m.rmse_over_crb),
            mm(m.best_single_sensor_rmse_m),
            if !m.gain_over_linear.is_finite() {
                "–".to_owned()
            } else if m.gain_over_linear.abs() < 0.005 {
                "0".to_owned()
            } else {
                format!("{:.0}", -m.gain_over_linear * 100.0)
            }
        );
    }
    if let Some(note) = range_methods_agree(r) {
        let _ = writeln!(out, "{note}");
    }
    let _ = writeln!(out, "\nRMSE per joint");
    let _ = write!(out, "{:<15}", "joint");
    for m in &r.methods {
        let _ = write!(out, " {:>16}", format!("{} mm", m.method));
    }
    let _ = writeln!(out);
    for joint in &r.joints {
        let _ = write!(out, "{joint:<15}");
        for m in &r.methods {
            let value = m.per_joint_rmse_m.get(joint).copied().unwrap_or(f64::NAN);
            let _ = write!(out, " {:>16}", mm(value));
        }
        let _ = writeln!(out);
    }
    let _ = writeln!(out, "\nEach method on every sample it solved:");
    for m in &r.methods {
        let unsolved: Vec<String> = m
            .own
            .failures
            .iter()
            .map(|(reason, n)| format!("{n} {reason}"))
            .collect();
        let _ = writeln!(
            out,
            "  {:<15} {:>7} solved, RMSE {:>6} mm (CRB {:>6} mm){}",
            m.method,
            m.own.solved,
            mm(m.own.rmse_m),
            mm(m.own.crb_rmse_m),
            if unsolved.is_empty() {
                String::new()
            } else {
                format!(", unsolved: {}", unsolved.join(", "))
            }
        );
    }
    let _ = writeln!(
        out,
        "\nsolved: share of all joint samples the method solved. CRB: Cramér–Rao bound of the method's\n\
         data model (ranges only, or full 3-D reports). RMSE/CRB: how many times the bound. best 1\n\
         sensor: the single sensor with the lowest RMSE. vs linear: RMSE change against the thesis's\n\
         linear trilateration (§4.2.2)."
    );
    out
}
