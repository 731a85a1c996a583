//! `trigait export INPUT --format trc|c3d|csv -o OUT`: joint trajectories into the files other
//! gait tools open. Wiring only; the writers are `trigait-motion`'s.

use std::path::{Path, PathBuf};

use clap::ValueEnum;
use eyre::WrapErr;
use trigait_gait::filter::Filter;

/// Arguments of `trigait export`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Motion to export: C3D/TRC markers (exported as joint centres), trigait joint files
    /// (C3D/TRC with joint-named markers, CSV) or Kinect SDK skeleton text (.txt, at 30 Hz or
    /// its time stamps).
    pub input: PathBuf,
    /// Output format; by default taken from the extension of `--output`.
    #[arg(long, value_enum)]
    pub format: Option<Format>,
    /// Output file.
    #[arg(short, long, value_name = "OUT")]
    pub output: PathBuf,
    /// Trajectory filter applied before writing: none, butterworth:<f>hz or one-euro.
    ///
    /// The file does not record it: `trigait gait` filters joint trajectories at 6 Hz by default,
    /// so give it `--filter none` for a file filtered here.
    #[arg(long, default_value = "none", value_parser = parse_filter)]
    pub filter: Filter,
}

/// Export format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Format {
    /// OpenSim TRC: millimetres, Y up, one marker per joint.
    Trc,
    /// C3D (float), millimetres, Z up, one point per joint; readable by c3dio and Vicon-style tools.
    C3d,
    /// CSV: frame, time and x/y/z of every joint in metres, Z up.
    Csv,
}

fn parse_filter(spec: &str) -> Result<Filter, String> {
    spec.parse::<Filter>().map_err(|e| e.to_string())
}

fn format_of(path: &Path) -> Option<Format> {
    let ext = path.extension()?.to_string_lossy().to_ascii_lowercase();
    match ext.as_str() {
        "trc" => Some(Format::Trc),
        "c3d" => Some(Format::C3d),
        "csv" => Some(Format::Csv),
        _ => None,
    }
}

/// Runs `trigait export`.
pub fn run(args: Args) -> eyre::Result<()> {
    crate::output::not_the_input(&args.input, &args.output)?;
    if let (Some(asked), Some(named)) = (args.format, format_of(&args.output))
        && asked != named
    {
        let name = |f: Format| f.to_possible_value().map(|v| v.get_name().to_owned());
        eyre::bail!(
            "--format {} but {} is named as {}: the file would not be read as what it holds \
             (drop --format, or change the extension)",
            name(asked).unwrap_or_default(),
            args.output.display(),
            name(named).unwrap_or_default()
        );
    }
    let format = match args.format.or_else(|| format_of(&args.output)) {
        Some(f) => f,
        None => eyre::bail!(
            "cannot tell the format of {}: pass --format trc|c3d|csv or use one of those extensions",
            args.output.display()
        ),
    };
    let clip = if crate::gait::is_sdk_text(&args.input) {
        // Kinect SDK skeleton text, read as `trigait gait` reads it (inferred joints dropped,
        // sides put back where the person walks away).
        let input = crate::gait::load_input(&args.input, false, false, None)?;
        // What the reading changed or left out (swapped sides, a cut last line) is said, as
        // `trigait gait` says it.
        for note in &input.notes {
            eprintln!("note: {note}");
        }
        input
            .clip
            .ok_or_else(|| eyre::eyre!("{}: no joints", args.input.display()))?
    } else {
        crate::gait::load_clip(&args.input)?
    };
    crate::output::create_parent(&args.output)?;
    let clip = args
        .filter
        .apply(&clip)
        .wrap_err_with(|| format!("filtering with {}", args.filter))?;
    let written = match format {
        Format::Trc => trigait_motion::write_trc(&args.output, &clip),
        Format::C3d => trigait_motion::write_c3d(&args.output, &clip),
        Format::Csv => trigait_motion::write_csv(&args.output, &clip),
    };
    written.wrap_err_with(|| format!("writing {}", args.output.display()))?;
    crate::stdout::print(&format!(
        "wrote {} ({} joints, {} frames at {:.0} Hz, filter {}) to {}\n",
        match format {
            Format::Trc => "TRC",
            Format::C3d => "C3D",
            Format::Csv => "CSV",
        },
        clip.joints().len(),
        clip.frame_count(),
        clip.rate_hz(),
        args.filter,
        args.output.display()
    ))
}
