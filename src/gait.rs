//! `trigait gait FILE`: gait events and spatiotemporal parameters of a marker file, as a table or
//! JSON, with optional plots. Wiring only; the analysis is `trigait-gait`.

use std::path::{Path, PathBuf};

use clap::ValueEnum;
use eyre::WrapErr;
use serde::Serialize;
use trigait_gait::filter::Filter;
use trigait_gait::{EventKind, EventMethod, Foot, GaitAnalysis, GaitParams, Stat, plot};
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
    /// Fewest complete strides (both feet together) accepted.
    #[arg(long, default_value_t = 2)]
    pub min_strides: usize,
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

/// Loads a motion file as joint trajectories.
///
/// * `.csv`: trigait's own joint CSV (`frame,time_s,<joint>_x_m,<joint>_y_m,<joint>_z_m,…`, as
///   `trigait export` and the recorder write it).
/// * `.c3d` / `.trc` whose markers are all named after joints (`hip_left`, … — files trigait
///   exported): the trajectories are the joints themselves.
/// * any other `.c3d` / `.trc`: skin markers, turned into joint centres by
///   `trigait_motion::joint_centres`.
pub fn load_clip(path: &Path) -> eyre::Result<MotionClip> {
    let is_csv = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("csv"));
    let clip = if is_csv {
        read_joint_csv(path)
    } else {
        trigait_motion::read_markers(path)
            .map_err(eyre::Report::from)
            .and_then(|set| match joints_from_labels(&set)? {
                Some(clip) => Ok(clip),
                None => Ok(trigait_motion::joint_centres(&set)?),
            })
    };
    clip.wrap_err_with(|| format!("reading joint trajectories from {}", path.display()))
}

/// The clip of a marker set whose every label is a joint name, else `None`.
fn joints_from_labels(set: &trigait_motion::MarkerSet) -> eyre::Result<Option<MotionClip>> {
    let joints: Option<Vec<Joint>> = set
        .labels()
        .iter()
        .map(|l| Joint::from_name(l.rsplit(':').next().unwrap_or(l)))
        .collect();
    let Some(joints) = joints.filter(|j| !j.is_empty()) else {
        return Ok(None);
    };
    let frames = (0..set.frame_count())
        .map(|f| {
            (0..joints.len())
                .map(|c| set.position_at_column(f, c))
                .collect()
        })
        .collect();
    Ok(Some(MotionClip::new(
        set.name(),
        set.rate_hz(),
        joints,
        frames,
    )?))
}

/// Reads trigait's joint CSV: header `frame,time_s,<joint>_x_m,<joint>_y_m,<joint>_z_m,…`,
/// metres, Z up, a gap as empty cells; the rate comes from the time column.
fn read_joint_csv(path: &Path) -> eyre::Result<MotionClip> {
    let text = std::fs::read_to_string(path).wrap_err("reading the file")?;
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let (_, header) = lines
        .next()
        .ok_or_else(|| eyre::eyre!("the file is empty"))?;
    let fields: Vec<&str> = header.split(',').map(str::trim).collect();
    if fields.len() < 5
        || fields[0] != "frame"
        || fields[1] != "time_s"
        || !(fields.len() - 2).is_multiple_of(3)
    {
        eyre::bail!(
            "line 1: expected the header `frame,time_s,<joint>_x_m,<joint>_y_m,<joint>_z_m,…`"
        );
    }
    let mut joints = Vec::new();
    for triple in fields[2..].chunks(3) {
        let name = triple[0].strip_suffix("_x_m").unwrap_or(triple[0]);
        let joint = Joint::from_name(name).ok_or_else(|| {
            eyre::eyre!(
                "line 1: {:?} is not `<joint>_x_m` for a known joint",
                triple[0]
            )
        })?;
        if triple[1] != format!("{name}_y_m") || triple[2] != format!("{name}_z_m") {
            eyre::bail!("line 1: expected {name}_y_m,{name}_z_m after {}", triple[0]);
        }
        joints.push(joint);
    }
    let mut times = Vec::new();
    let mut frames = Vec::new();
    for (index, line) in lines {
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        if cells.len() != fields.len() {
            eyre::bail!(
                "line {}: {} cells, the header has {}",
                index + 1,
                cells.len(),
                fields.len()
            );
        }
        let number = |cell: &str| -> eyre::Result<Option<f64>> {
            if cell.is_empty() {
                return Ok(None);
            }
            cell.parse::<f64>()
                .map(Some)
                .map_err(|_| eyre::eyre!("line {}: {cell:?} is not a number", index + 1))
        };
        times.push(number(cells[1])?.ok_or_else(|| eyre::eyre!("line {}: no time", index + 1))?);
        let mut row = Vec::with_capacity(joints.len());
        for triple in cells[2..].chunks(3) {
            row.push(
                match (number(triple[0])?, number(triple[1])?, number(triple[2])?) {
                    (Some(x), Some(y), Some(z)) => Some(nalgebra::Point3::new(x, y, z)),
                    _ => None,
                },
            );
        }
        frames.push(row);
    }
    let (Some(first), Some(last)) = (times.first(), times.last()) else {
        eyre::bail!("the file has a header but no frames");
    };
    let rate_hz = if times.len() > 1 && last > first {
        (times.len() - 1) as f64 / (last - first)
    } else {
        eyre::bail!("cannot tell the sample rate from fewer than two increasing times");
    };
    let name = path
        .file_name()
        .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
    Ok(MotionClip::new(name, rate_hz, joints, frames)?)
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
        };
        let text = serde_json::to_string_pretty(&report).wrap_err("encoding the JSON report")?;
        print_stdout(&format!("{text}\n"))
    } else {
        print_stdout(&table(&args, &clip, &analysis))
    }
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
