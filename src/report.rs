//! `trigait report FILE -o report.html`: the gait analysis of one file as a single
//! self-contained HTML page (inline SVG, no scripts, no external resources): the parameter
//! table, the trajectories with events, a footfall diagram and the data-quality notes.
//! Wiring only; the analysis and the plots are `trigait-gait`.

use std::fmt::Write;
use std::path::PathBuf;

use eyre::WrapErr;
use trigait_gait::filter::Filter;
use trigait_gait::{GaitAnalysis, Stat, plot};

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
    /// Trajectory filter before event detection (see `trigait gait --help`).
    #[arg(long, default_value = "none", value_parser = parse_filter)]
    pub filter: Filter,
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
    #[arg(long, value_name = "HZ", value_parser = crate::ranges::number(1.0, 1000.0, "Hz"))]
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
    let gait_args = args.gait_args();
    let (input, analysis) = gait::analyse_file(&gait_args)?;
    let html = render(
        &args.file.display().to_string(),
        &gait_args,
        &input,
        &analysis,
    )?;
    std::fs::write(&args.output, html)
        .wrap_err_with(|| format!("writing {}", args.output.display()))?;
    crate::stdout::print(&format!(
        "report of {} written to {}\n",
        args.file.display(),
        args.output.display()
    ))
}

/// Escapes text for HTML element content and attribute values.
fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

fn cell(v: Option<f64>, digits: usize) -> String {
    v.map_or_else(|| "–".to_owned(), |v| format!("{v:.digits$}"))
}

/// An SVG from the plot module, made embeddable: any XML declaration dropped.
fn inline_svg(svg: &str) -> &str {
    svg.find("<svg").map_or(svg, |i| &svg[i..])
}

/// The HTML page.
pub fn render(
    title: &str,
    args: &gait::Args,
    input: &GaitInput,
    a: &GaitAnalysis,
) -> eyre::Result<String> {
    let clip = gait::plot_clip(input, &args.file)?;
    let trajectories = plot::trajectories_svg(&clip, a, &[])?;
    let footfall = plot::footfall_svg(&clip, a)?;
    let mut h = String::new();
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <title>Gait report: {t}</title>\n<style>\n\
         body {{ font-family: sans-serif; margin: 2em; max-width: 80em; }}\n\
         table {{ border-collapse: collapse; }}\n\
         td, th {{ border: 1px solid #bbb; padding: 0.2em 0.6em; text-align: right; }}\n\
         th:first-child, td:first-child {{ text-align: left; }}\n\
         figure {{ margin: 1em 0; }}\n\
         svg {{ max-width: 100%; height: auto; }}\n\
         </style>\n</head>\n<body>\n<h1>Gait report</h1>\n<p>{t}: {rate:.0} Hz, {dur:.2} s, \
         method {m}, filter {f}</p>\n",
        t = escape(title),
        rate = a.rate_hz,
        dur = a.duration_secs,
        m = escape(a.method.name()),
        f = escape(&args.filter.to_string()),
    );
    let s = &a.summary;
    let _ = write!(
        h,
        "<h2>Parameters</h2>\n<p>{} strides ({} left, {} right), {} steps. n is the number of \
         strides a figure rests on, or of steps where marked *.</p>\n<table>\n<thead><tr>\
         <th>parameter</th><th>mean</th><th>sd</th><th>left</th><th>right</th>\
         <th>asymmetry %</th><th>n</th></tr></thead>\n<tbody>\n",
        s.strides, s.left_strides, s.right_strides, s.steps
    );
    let rows: [(&str, &Stat, usize); 9] = [
        ("stride length (m)", &s.stride_length_m, 3),
        ("step length (m)", &s.step_length_m, 3),
        ("step width (m)", &s.step_width_m, 3),
        ("cadence (steps/min)", &s.cadence_steps_per_min, 1),
        ("speed (m/s)", &s.speed_mps, 3),
        ("stride time (s)", &s.stride_time_secs, 3),
        ("stance (%)", &s.stance_pct, 1),
        ("swing (%)", &s.swing_pct, 1),
        ("double support (%)", &s.double_support_pct, 1),
    ];
    for (name, stat, digits) in rows {
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td>\
             <td>{}{}</td></tr>",
            escape(name),
            cell(stat.mean, digits),
            cell(stat.sd, digits),
            cell(stat.left, digits),
            cell(stat.right, digits),
            cell(stat.asymmetry_pct, 1),
            stat.n,
            if stat.from_steps { "*" } else { "" }
        );
    }
    h.push_str("</tbody>\n</table>\n<h2>Trajectories and events</h2>\n<figure>\n");
    h.push_str(inline_svg(&trajectories));
    h.push_str(
        "\n<figcaption>Joint trajectories per axis with heel strikes and toe offs.\
         </figcaption>\n</figure>\n<h2>Footfall</h2>\n<figure>\n",
    );
    h.push_str(inline_svg(&footfall));
    h.push_str(
        "\n<figcaption>Stance phases of each foot over time; shaded stretches were excluded.\
         </figcaption>\n</figure>\n<h2>Data quality</h2>\n<ul>\n",
    );
    for note in gait::quality_notes(&input.notes, a) {
        let _ = writeln!(h, "<li>{}</li>", escape(&note));
    }
    if a.excluded.is_empty() {
        h.push_str("<li>nothing excluded (no standing, turning or gaps)</li>\n");
    }
    for p in &a.excluded {
        let _ = writeln!(
            h,
            "<li>excluded: {} {:.2}–{:.2} s ({} frames)</li>",
            escape(p.reason.name()),
            p.start_secs,
            p.end_secs,
            p.frames
        );
    }
    h.push_str("</ul>\n</body>\n</html>\n");
    Ok(h)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Tags opened and closed in `html` balance (void elements aside), in order.
    fn balanced(html: &str) -> Result<(), String> {
        let void = ["meta", "br", "img", "hr", "link", "input"];
        let mut stack: Vec<String> = Vec::new();
        let mut rest = html;
        while let Some(i) = rest.find('<') {
            rest = &rest[i + 1..];
            let end = rest.find('>').ok_or("unclosed tag")?;
            let tag = &rest[..end];
            rest = &rest[end + 1..];
            if tag.starts_with('!') || tag.starts_with('?') {
                continue;
            }
            let self_closing = tag.ends_with('/');
            let closing = tag.starts_with('/');
            let name: String = tag
                .trim_start_matches('/')
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || *c == '-' || *c == ':')
                .collect::<String>()
                .to_ascii_lowercase();
            if name.is_empty() {
                return Err(format!("bad tag <{tag}>"));
            }
            if closing {
                match stack.pop() {
                    Some(open) if open == name => {}
                    other => return Err(format!("</{name}> closes {other:?}")),
                }
            } else if !self_closing && !void.contains(&name.as_str()) {
                stack.push(name);
            }
        }
        if stack.is_empty() {
            Ok(())
        } else {
            Err(format!("unclosed {stack:?}"))
        }
    }

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
            filter: Filter::None,
            treadmill: None,
            overground: false,
            keep_inferred: false,
            rate: None,
        };
        let gait_args = args.gait_args();
        let (input, analysis) = gait::analyse_file(&gait_args).unwrap();
        let html = render("07_01.c3d", &gait_args, &input, &analysis).unwrap();
        assert!(html.starts_with("<!DOCTYPE html>"));
        balanced(&html).unwrap();
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

    /// Text from a file name cannot inject markup.
    #[test]
    fn escapes() {
        assert_eq!(
            escape("<a href='x'>&</a>"),
            "&lt;a href=&#39;x&#39;&gt;&amp;&lt;/a&gt;"
        );
    }
}
