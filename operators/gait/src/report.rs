//! The gait report as text lines and as one self-contained HTML page: what `trigait report`
//! writes for a file and the recorder node writes at the end of a graph run.

use std::fmt::Write;

use trigait_skeleton::MotionClip;

use crate::{GaitAnalysis, Result, SummaryRow, plot};

/// One line per data-quality fact of `a` (and the reading `notes`): what the report's
/// data-quality section and the table's footer say.
pub fn quality_notes(notes: &[String], a: &GaitAnalysis) -> Vec<String> {
    let mut out: Vec<String> = notes.to_vec();
    let q = &a.quality;
    out.push(format!(
        "{} of {} landmark samples missing in the input; rejected {} (jumps {}, limb length {}, \
         leg merged into the other {}); bridged {} (gaps up to 0.1 s); {} still missing",
        q.missing_samples,
        q.samples,
        q.rejected(),
        q.rejected_jumps,
        q.rejected_limb_length,
        q.rejected_merged_legs,
        q.bridged_samples,
        q.remaining_gaps
    ));
    if let Some(floor) = a.floor.filter(|f| f.applied) {
        out.push(format!(
            "floor levelled: the resting feet lie on a plane tilted by {:.1} deg ({} samples)",
            floor.tilt_deg, floor.samples
        ));
    }
    if a.rejected_events > 0 {
        out.push(format!(
            "{} proposed events dropped: the foot was airborne",
            a.rejected_events
        ));
    }
    if a.stationary_events > 0 {
        out.push(format!(
            "{} proposed events dropped: the foot did not swing (under {:.2} m forward in the \
             {:.1} s before a heel strike or after a toe off)",
            a.stationary_events,
            crate::events::MIN_SWING_TRAVEL_M,
            crate::events::SWING_WINDOW_SECS,
        ));
    }
    if a.short_contacts > 0 {
        let limit = if a.running { "80 ms" } else { "0.25 s" };
        out.push(format!(
            "{} proposed events dropped: a heel strike and its own toe off within {limit} (the \
             less prominent of the two went)",
            a.short_contacts
        ));
    }
    let left_out: Vec<String> = a
        .inconsistent_strides
        .iter()
        .map(|s| {
            travel_mismatch(
                "stride",
                s.foot,
                (s.start_secs, s.end_secs),
                s.stride_length_m,
                s.pelvis_travel_m,
            )
        })
        .chain(a.inconsistent_steps.iter().filter_map(|s| {
            Some(travel_mismatch(
                "step",
                s.foot,
                (s.start_secs, s.end_secs),
                s.step_length_m?,
                s.pelvis_travel_m,
            ))
        }))
        .collect();
    if !left_out.is_empty() {
        out.push(format!(
            "left out of the figures, as the heel strikes that bound them cannot both be where \
             a foot landed (the body travels about as far as the heel between them): {}",
            left_out.join("; ")
        ));
    }
    if a.timing.implausible {
        out.push(format!(
            "TIMING IMPLAUSIBLE at {:.0} Hz: median swing {} over {} swings, median step {} over \
             {} steps{}; no human leg swings in under {:.2} s or steps in under {:.2} s, and \
             nobody walks faster than {} m/s with a foot always on the floor, so the file's \
             time base is probably wrong and every duration, cadence and speed with it; \
             {}(for untimed Kinect text, give the true frame rate: `trigait gait --rate`)",
            a.rate_hz,
            seconds(a.timing.median_swing_secs),
            a.timing.swings,
            seconds(a.timing.median_step_secs),
            a.timing.steps,
            a.timing
                .median_walking_speed_mps
                .map_or_else(String::new, |v| format!(
                    ", median walking speed {v:.2} m/s over {} strides",
                    a.timing.walking_strides
                )),
            crate::timing::MIN_HUMAN_SWING_SECS,
            crate::timing::MIN_HUMAN_STEP_SECS,
            crate::timing::MAX_HUMAN_WALKING_SPEED_MPS,
            human_rate(&a.timing).map_or_else(String::new, |hz| format!(
                "its rhythm is human only if it was logged at about {hz:.0} Hz or less "
            )),
        ));
    }
    out.push(if a.flights.is_empty() {
        "no flight phases (one foot always on the floor)".to_owned()
    } else {
        format!(
            "{} flight phases (both feet off the floor): {}",
            a.flights.len(),
            a.flights
                .iter()
                .map(|f| format!("{:.2}-{:.2} s", f.start_secs, f.end_secs))
                .collect::<Vec<_>>()
                .join(", ")
        )
    });
    out.push(format!(
        "method {}{}",
        a.method.name(),
        if a.running {
            " (running: flight phases found)"
        } else {
            " (walking)"
        }
    ));
    out.push(match &a.treadmill {
        Some(t) => format!(
            "treadmill ({}), belt {:.3} m/s ({}): stride and step length and speed are belt-corrected",
            if t.declared { "declared" } else { "detected" },
            t.belt_speed_mps,
            if t.speed_estimated {
                format!("estimated from {} stance-foot samples", t.stance_samples)
            } else {
                "given".to_owned()
            }
        ),
        None => "overground".to_owned(),
    });
    if let Some(t) = a
        .treadmill
        .filter(|t| t.declared && t.pelvis_travel_m > crate::treadmill::MAX_PELVIS_TRAVEL_M)
    {
        out.push(format!(
            "the pelvis ranged {:.1} m from its middle position, which it does not on a \
             treadmill: is this an overground walk? (declared a treadmill, it was corrected as \
             one)",
            t.pelvis_travel_m
        ));
    }
    out.push(format!("step width from {}", a.heel_source.name()));
    out
}

/// One step or stride whose heel-to-heel length and pelvis travel disagree, in words.
fn travel_mismatch(
    what: &str,
    foot: crate::Foot,
    (start, end): (f64, f64),
    length: f64,
    travel: Option<f64>,
) -> String {
    format!(
        "{} {what} {start:.2}-{end:.2} s, {length:.2} m heel to heel while the pelvis moved {}",
        foot.name(),
        travel.map_or_else(|| "an unknown distance".to_owned(), |t| format!("{t:.2} m")),
    )
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

/// The bound on the true rate of a clip whose rhythm is not human at its stated rate (none
/// below 1 Hz, which no frame rate is).
fn human_rate(t: &crate::Timing) -> Option<f64> {
    t.highest_human_rate_hz
        .filter(|hz| t.implausible && *hz >= 1.0)
}

/// A duration to the hundredth of a second, or a dash.
fn seconds(v: Option<f64>) -> String {
    v.map_or_else(|| "-".to_owned(), |s| format!("{s:.2} s"))
}

/// A table cell: the value to `digits` decimals, or an en dash when there is none.
#[must_use]
pub fn cell(v: Option<f64>, digits: usize) -> String {
    v.map_or_else(|| "–".to_owned(), |v| format!("{v:.digits$}"))
}

/// An SVG from the plot module, made embeddable: any XML declaration dropped.
fn inline_svg(svg: &str) -> &str {
    svg.find("<svg").map_or(svg, |i| &svg[i..])
}

/// The page up to and including `<body>`.
fn page_head(title: &str) -> String {
    format!(
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <title>Gait report: {t}</title>\n<style>\n\
         body {{ font-family: sans-serif; margin: 2em; max-width: 80em; }}\n\
         table {{ border-collapse: collapse; }}\n\
         td, th {{ border: 1px solid #bbb; padding: 0.2em 0.6em; text-align: right; }}\n\
         th:first-child, td:first-child {{ text-align: left; }}\n\
         figure {{ margin: 1em 0; }}\n\
         svg {{ max-width: 100%; height: auto; }}\n\
         .warning {{ border: 2px solid #c00; background: #fee; padding: 0.5em 1em; }}\n\
         tr.suspect td {{ color: #a00; }}\n\
         </style>\n</head>\n<body>\n",
        t = escape(title)
    )
}

/// The gait report of `clip` as one self-contained HTML page (inline SVG, no scripts, no
/// external resources): a header naming `title`, its rate, duration, event method and
/// `filter`; the parameter table (mean, sd, left, right, asymmetry, n); the per-axis
/// trajectories with events and the footfall diagram; the data-quality notes ([`quality_notes`]
/// of `notes`) and the excluded phases.
///
/// # Errors
/// When a plot cannot be drawn.
pub fn html(
    title: &str,
    filter: &str,
    notes: &[String],
    clip: &MotionClip,
    a: &GaitAnalysis,
) -> Result<String> {
    let trajectories = plot::trajectories_svg(clip, a, &[])?;
    let footfall = plot::footfall_svg(clip, a)?;
    let mut h = page_head(title);
    let _ = write!(
        h,
        "<h1>Gait report</h1>\n<p>{t}: {rate:.0} Hz, {dur:.2} s, method {m}, filter {f}</p>\n",
        t = escape(title),
        rate = a.rate_hz,
        dur = a.duration_secs,
        m = escape(a.method.name()),
        f = escape(filter),
    );
    let s = &a.summary;
    h.push_str("<h2>Parameters</h2>\n");
    if a.timing.implausible {
        let _ = writeln!(
            h,
            "<p class=\"warning\"><strong>The time base looks wrong.</strong> At {:.0} Hz the \
             median swing lasts {} and the median step {}, faster than any human leg. The \
             stride time, the cadence and the speed (marked red) are wrong with it; the lengths, \
             the width and the stance and swing percentages do not depend on it. {} For Kinect \
             text without time stamps, give the true frame rate with <code>--rate</code>.</p>",
            a.rate_hz,
            seconds(a.timing.median_swing_secs),
            seconds(a.timing.median_step_secs),
            human_rate(&a.timing).map_or_else(String::new, |hz| format!(
                "Its rhythm is human only if the file was logged at about {hz:.0} Hz or less."
            )),
        );
    }
    let _ = write!(
        h,
        "<p>{} strides ({} left, {} right), {} steps. n is the number of \
         strides a figure rests on, or of steps where marked *.</p>\n<table>\n<thead><tr>\
         <th>parameter</th><th>mean</th><th>sd</th><th>left</th><th>right</th>\
         <th>asymmetry %</th><th>n</th></tr></thead>\n<tbody>\n",
        s.strides, s.left_strides, s.right_strides, s.steps
    );
    for SummaryRow {
        label: name,
        stat,
        digits,
        timed,
    } in s.rows()
    {
        let _ = writeln!(
            h,
            "<tr{}><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td>\
             <td>{}{}</td></tr>",
            if timed && a.timing.implausible {
                " class=\"suspect\""
            } else {
                ""
            },
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
    for note in quality_notes(notes, a) {
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

/// The page for a run or file that gave no gait parameters: `title`, why (`reason`) and the
/// reading `notes`, in the same layout as [`html`].
#[must_use]
pub fn html_without_analysis(title: &str, reason: &str, notes: &[String]) -> String {
    let mut h = page_head(title);
    let _ = write!(
        h,
        "<h1>Gait report</h1>\n<p>{}</p>\n<h2>No gait parameters</h2>\n<p>{}</p>\n\
         <h2>Data quality</h2>\n<ul>\n",
        escape(title),
        escape(reason)
    );
    for note in notes {
        let _ = writeln!(h, "<li>{}</li>", escape(note));
    }
    h.push_str("</ul>\n</body>\n</html>\n");
    h
}

/// Whether the tags opened and closed in `html` balance (void elements aside), in order: the
/// check the tests of every writer of these pages make.
///
/// # Errors
/// The first tag out of place.
pub fn check_well_formed(html: &str) -> std::result::Result<(), String> {
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Text from a file name cannot inject markup.
    #[test]
    fn escapes() {
        assert_eq!(
            escape("<a href='x'>&</a>"),
            "&lt;a href=&#39;x&#39;&gt;&amp;&lt;/a&gt;"
        );
    }

    /// The page without an analysis is well formed and says why, escaped; the checker finds
    /// a misnested tag.
    #[test]
    fn page_without_analysis() {
        let page = html_without_analysis("run <1>", "too short: 0.5 s", &["a & b".to_owned()]);
        check_well_formed(&page).unwrap();
        assert!(page.contains("run &lt;1&gt;") && page.contains("too short: 0.5 s"));
        assert!(page.contains("<li>a &amp; b</li>"));
        assert!(check_well_formed("<p><b>x</p></b>").is_err());
        assert!(check_well_formed("<ul><li>x</li>").is_err());
    }
}
