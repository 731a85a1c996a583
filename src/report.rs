//! `trigait report FILE -o report.html`: the gait analysis of one file as a single
//! self-contained HTML page (inline SVG, no scripts, no external resources): the parameter
//! table, the trajectories with events, a footfall diagram and the data-quality notes.
//! Wiring only; the analysis and the plots are `trigait-gait`.

use std::path::PathBuf;

use eyre::WrapErr;
use trigait_gait::GaitAnalysis;
use trigait_gait::filter::Filter;

use crate::gait::{self, GaitInput, Method};

/// Arguments of `trigait report`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Motion file, as for `trigait gait`: C3D/TRC markers, joint exports (C3D/TRC/CSV) or
    /// Kinect SDK skeleton text (.txt).
    pub file: PathBuf,
    /// Where to write the HTML page.
    #[arg(short, long, value_name = "FILE")]
    pub output: PathBuf,
    /// Gait-event detector (see `trigait gait --help`).
    #[arg(long, value_enum, default_value_t = Method::Auto)]
    pub method: Method,
    /// Trajectory filter after outlier rejection (see `trigait gait --help`; by default
    /// butterworth:6hz for skeletons and joint trajectories, none for skin-marker files).
    #[arg(long, value_parser = parse_filter)]
    pub filter: Option<Filter>,
    /// Treadmill walking, at SPEED m/s if given (else estimated).
    #[arg(long, value_name = "SPEED", num_args = 0..=1)]
    pub treadmill: Option<Option<f64>>,
    /// Overground walking: never apply the treadmill correction.
    #[arg(long, conflicts_with = "treadmill")]
    pub overground: bool,
    /// Kinect SDK skeletons: keep joints the tracker only inferred.
    #[arg(long)]
    pub keep_inferred: bool,
    /// Frame rate of Kinect SDK text without time stamps (30 Hz otherwise).
    #[arg(allow_negative_numbers = true, long, value_name = "HZ", value_parser = crate::ranges::number(1.0, 1000.0, "Hz"))]
    pub rate: Option<f64>,
}

fn parse_filter(spec: &str) -> Result<Filter, String> {
    spec.parse::<Filter>().map_err(|e| e.to_string())
}

impl Args {
    fn gait_args(&self) -> gait::Args {
        gait::Args {
            file: self.file.clone(),
            method: self.method,
            treadmill: self.treadmill,
            overground: self.overground,
            keep_inferred: self.keep_inferred,
            rate: self.rate,
            joint_centres: false,
            filter: self.filter,
            json: false,
            plots: None,
            min_strides: 0,
            kinect_sim: false,
            rig: "thesis".to_owned(),
            seed: 1,
            kinect_filter: Filter::None,
        }
    }
}

/// Runs `trigait report`.
pub fn run(args: &Args) -> eyre::Result<()> {
    crate::output::not_the_input(&args.file, &args.output)?;
    let gait_args = args.gait_args();
    let (input, analysis) = gait::analyse_file(&gait_args)?;
    let html = render(
        &args.file.display().to_string(),
        &gait_args,
        &input,
        &analysis,
    )?;
    crate::output::create_parent(&args.output)?;
    std::fs::write(&args.output, html)
        .wrap_err_with(|| format!("writing {}", args.output.display()))?;
    crate::stdout::print(&format!(
        "report of {} written to {}\n",
        args.file.display(),
        args.output.display()
    ))
}

/// The HTML page.
pub fn render(
    title: &str,
    args: &gait::Args,
    input: &GaitInput,
    a: &GaitAnalysis,
) -> eyre::Result<String> {
    let clip = gait::plot_clip(input, &args.file)?;
    Ok(trigait_gait::report::html(
        title,
        &input.filter.to_string(),
        &input.notes,
        &clip,
        a,
    )?)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A report of a real marker walk is one well-formed page with two non-empty inline SVGs
    /// and no external resources.
    #[test]
    fn report_is_valid_html_with_svgs() {
        let Some(path) = trigait_test_data::shared_file("mocap-cmu-07_01/07_01.c3d") else {
            return;
        };
        let args = Args {
            file: path,
            output: PathBuf::from("unused.html"),
            method: Method::Auto,
            filter: None,
            treadmill: None,
            overground: false,
            keep_inferred: false,
            rate: None,
        };
        let gait_args = args.gait_args();
        let (input, analysis) = gait::analyse_file(&gait_args).unwrap();
        let html = render("07_01.c3d", &gait_args, &input, &analysis).unwrap();
        assert!(html.starts_with("<!DOCTYPE html>"));
        trigait_gait::report::check_well_formed(&html).unwrap();
        let svgs: Vec<&str> = html.split("<svg").skip(1).collect();
        assert_eq!(svgs.len(), 2);
        for svg in svgs {
            let body = &svg[..svg.find("</svg>").unwrap()];
            let marks = body.matches("<polyline").count()
                + body.matches("<path").count()
                + body.matches("<rect").count()
                + body.matches("<line").count();
            assert!(marks > 10, "an SVG with {marks} marks");
        }
        assert!(!html.contains("<script"));
        assert!(!html.contains("src=\"http"));
        assert!(html.contains("stride length (m)"));
        assert!(html.contains("Data quality"));
    }
}
