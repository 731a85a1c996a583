//! Gait plots, rendered in memory as SVG text or PNG bytes (the caller writes the files).
//!
//! * [`trajectories_svg`] / [`trajectories_png`]: the joints' paths in a 3-D view beside their
//!   X, Y and Z coordinates over time, with heel strikes (solid) and toe offs (dashed) marked and
//!   excluded phases shaded, in the manner of thesis Fig. 6.12.
//! * [`footfall_svg`] / [`footfall_png`]: a footfall diagram — footprints on the floor seen from
//!   above with the pelvis path, and below it the stance bars of each foot over time with the
//!   double-support periods where both bars overlap.
//!
//! A fresh machine has no system fonts, and plotters' bitmap backend can only draw text through
//! a font library. PNGs are therefore drawn through [`TextBitmap`], a backend wrapper that
//! renders text with the public-domain 8×8 bitmap font of the `font8x8` crate: no font files, no
//! downloads, the same labels as the SVG (ASCII only; other characters show as blanks).

use std::ops::Range;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters_backend::{
    BackendColor, BackendCoord, BackendTextStyle, DrawingErrorKind,
    text_anchor::{HPos, VPos},
};
use trigait_skeleton::{Joint, MotionClip};

use crate::{Error, EventKind, ExclusionReason, Foot, GaitAnalysis, Result};

/// Size of the trajectory figure in pixels.
pub const TRAJECTORIES_SIZE: (u32, u32) = (1600, 1000);
/// Size of the footfall figure in pixels.
pub const FOOTFALL_SIZE: (u32, u32) = (1400, 800);

const LEFT_COLOUR: RGBColor = RGBColor(200, 40, 40);
const RIGHT_COLOUR: RGBColor = RGBColor(30, 140, 60);
const PELVIS_COLOUR: RGBColor = RGBColor(90, 90, 90);
const EXCLUDED_COLOUR: RGBColor = RGBColor(225, 225, 225);

fn foot_colour(foot: Foot) -> RGBColor {
    match foot {
        Foot::Left => LEFT_COLOUR,
        Foot::Right => RIGHT_COLOUR,
    }
}

/// Colour of a joint's series: its side's hue, lighter down the leg; spine joints grey.
fn joint_colour(joint: Joint) -> RGBColor {
    let (base, step) = match joint {
        Joint::HipLeft => (LEFT_COLOUR, 0),
        Joint::KneeLeft => (LEFT_COLOUR, 1),
        Joint::AnkleLeft => (LEFT_COLOUR, 2),
        Joint::FootLeft => (LEFT_COLOUR, 3),
        Joint::HipRight => (RIGHT_COLOUR, 0),
        Joint::KneeRight => (RIGHT_COLOUR, 1),
        Joint::AnkleRight => (RIGHT_COLOUR, 2),
        Joint::FootRight => (RIGHT_COLOUR, 3),
        _ => (PELVIS_COLOUR, 0),
    };
    // Hips dark, feet light.
    let mix = |c: u8| -> u8 {
        let c = f64::from(c);
        let t = [0.0, 0.25, 0.45, 0.62][step];
        (c + (235.0 - c) * t).round().clamp(0.0, 255.0) as u8
    };
    let shade = |c: u8| -> u8 {
        if step == 0 {
            (f64::from(c) * 0.7) as u8
        } else {
            mix(c)
        }
    };
    RGBColor(shade(base.0), shade(base.1), shade(base.2))
}

/// The joints drawn by default: the leg joints the clip has, feet included.
#[must_use]
pub fn default_joints(clip: &MotionClip) -> Vec<Joint> {
    [
        Joint::HipLeft,
        Joint::KneeLeft,
        Joint::AnkleLeft,
        Joint::FootLeft,
        Joint::HipRight,
        Joint::KneeRight,
        Joint::AnkleRight,
        Joint::FootRight,
    ]
    .into_iter()
    .filter(|j| clip.has(*j))
    .collect()
}

type DrawResult<DB> =
    std::result::Result<(), DrawingAreaErrorKind<<DB as DrawingBackend>::ErrorType>>;

fn plot_error<E: std::error::Error + Send + Sync>(
    plot: &'static str,
) -> impl Fn(DrawingAreaErrorKind<E>) -> Error {
    move |e| Error::Plot {
        plot,
        message: e.to_string(),
    }
}

/// Padded range of finite values, at least `min_span` wide.
fn span(values: impl Iterator<Item = f64>, min_span: f64) -> Range<f64> {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if !lo.is_finite() {
        return 0.0..min_span.max(1.0);
    }
    let pad = ((hi - lo) * 0.05).max(1e-3);
    let (lo, hi) = (lo - pad, hi + pad);
    if hi - lo < min_span {
        let mid = (lo + hi) / 2.0;
        return mid - min_span / 2.0..mid + min_span / 2.0;
    }
    lo..hi
}

/// A gap-free piece of a trajectory: (time, position) samples.
type Polyline = Vec<(f64, nalgebra::Point3<f64>)>;

/// Picks one coordinate of a position.
type Coordinate = fn(&nalgebra::Point3<f64>) -> f64;

/// Runs of consecutive present samples of `joint`, as (t, position) polylines.
fn polylines(clip: &MotionClip, joint: Joint) -> Vec<Polyline> {
    let mut out: Vec<Polyline> = Vec::new();
    let mut current = Vec::new();
    for f in 0..clip.frame_count() {
        match clip.position(f, joint) {
            Some(p) => current.push((f as f64 / clip.rate_hz(), p)),
            None => {
                if !current.is_empty() {
                    out.push(std::mem::take(&mut current));
                }
            }
        }
    }
    if !current.is_empty() {
        out.push(current);
    }
    out
}

fn draw_trajectories<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    clip: &MotionClip,
    analysis: &GaitAnalysis,
    joints: &[Joint],
) -> DrawResult<DB> {
    root.fill(&WHITE)?;
    let title = format!(
        "{} - joint trajectories, {} heel strikes (solid) and {} toe offs (dashed)",
        clip.name(),
        analysis
            .events
            .iter()
            .filter(|e| e.kind == EventKind::HeelStrike)
            .count(),
        analysis
            .events
            .iter()
            .filter(|e| e.kind == EventKind::ToeOff)
            .count(),
    );
    let root = root.titled(&title, ("sans-serif", 22))?;
    let (left, right) = root.split_horizontally(root.dim_in_pixel().0 * 9 / 20);
    let lines: Vec<(Joint, Vec<Polyline>)> =
        joints.iter().map(|j| (*j, polylines(clip, *j))).collect();
    let all = || lines.iter().flat_map(|(_, l)| l.iter().flatten());
    let xr = span(all().map(|(_, p)| p.x), 0.5);
    let yr = span(all().map(|(_, p)| p.y), 0.5);
    let zr = span(all().map(|(_, p)| p.z).chain([0.0]), 0.5);
    let tr = 0.0..clip.duration_secs().max(1.0 / clip.rate_hz());

    // 3-D view: plotters' vertical axis is its y, so world (x, y, z) is drawn as (x, z, y).
    let mut chart = ChartBuilder::on(&left)
        .caption("3-D view (m)", ("sans-serif", 18))
        .margin(10)
        .margin_left(40)
        .build_cartesian_3d(xr.clone(), zr.clone(), yr.clone())?;
    chart.with_projection(|mut p| {
        p.yaw = 0.6;
        p.pitch = 0.35;
        p.scale = 0.85;
        p.into_matrix()
    });
    chart
        .configure_axes()
        .light_grid_style(RGBColor(235, 235, 235))
        .max_light_lines(4)
        .label_style(("sans-serif", 14))
        .draw()?;
    for (joint, runs) in &lines {
        let colour = joint_colour(*joint);
        for (k, run) in runs.iter().enumerate() {
            let series = chart.draw_series(LineSeries::new(
                run.iter().map(|(_, p)| (p.x, p.z, p.y)),
                colour.stroke_width(2),
            ))?;
            if k == 0 {
                series.label(joint.name()).legend(move |(x, y)| {
                    Rectangle::new([(x, y - 4), (x + 16, y + 4)], colour.filled())
                });
            }
        }
    }
    // Heel-strike positions of the ankles as dots on the 3-D paths.
    for e in analysis
        .events
        .iter()
        .filter(|e| e.kind == EventKind::HeelStrike)
    {
        let joint = match e.foot {
            Foot::Left => Joint::AnkleLeft,
            Foot::Right => Joint::AnkleRight,
        };
        if let Some(p) = clip.position_at(joint, e.time_secs) {
            chart.draw_series(std::iter::once(Circle::new(
                (p.x, p.z, p.y),
                5,
                foot_colour(e.foot).filled(),
            )))?;
        }
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 14))
        .position(SeriesLabelPosition::UpperLeft)
        .draw()?;

    // X, Y, Z against time.
    let panels = right.split_evenly((3, 1));
    let axes: [(&str, Range<f64>, Coordinate); 3] = [
        ("X (m)", xr, |p| p.x),
        ("Y (m)", yr, |p| p.y),
        ("Z (m)", zr, |p| p.z),
    ];
    for (panel, (label, range, coord)) in panels.iter().zip(axes) {
        let mut chart = ChartBuilder::on(panel)
            .margin(8)
            .x_label_area_size(34)
            .y_label_area_size(64)
            .build_cartesian_2d(tr.clone(), range.clone())?;
        chart
            .configure_mesh()
            .x_desc("time (s)")
            .y_desc(label)
            .label_style(("sans-serif", 14))
            .axis_desc_style(("sans-serif", 15))
            .light_line_style(RGBColor(240, 240, 240))
            .draw()?;
        for phase in &analysis.excluded {
            chart.draw_series(std::iter::once(Rectangle::new(
                [
                    (phase.start_secs, range.start),
                    (phase.end_secs + 1.0 / clip.rate_hz(), range.end),
                ],
                EXCLUDED_COLOUR.filled(),
            )))?;
        }
        for (joint, runs) in &lines {
            let colour = joint_colour(*joint);
            for run in runs {
                chart.draw_series(LineSeries::new(
                    run.iter().map(|(t, p)| (*t, coord(p))),
                    colour.stroke_width(2),
                ))?;
            }
        }
        for e in &analysis.events {
            let colour = foot_colour(e.foot);
            match e.kind {
                EventKind::HeelStrike => {
                    chart.draw_series(std::iter::once(PathElement::new(
                        vec![(e.time_secs, range.start), (e.time_secs, range.end)],
                        colour.stroke_width(2),
                    )))?;
                }
                EventKind::ToeOff => {
                    let dash = (range.end - range.start) / 24.0;
                    chart.draw_series((0..12).map(|k| {
                        let y0 = range.start + 2.0 * k as f64 * dash;
                        PathElement::new(
                            vec![(e.time_secs, y0), (e.time_secs, y0 + dash)],
                            colour.stroke_width(2),
                        )
                    }))?;
                }
            }
        }
    }
    Ok(())
}

fn draw_footfall<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    clip: &MotionClip,
    analysis: &GaitAnalysis,
) -> DrawResult<DB> {
    root.fill(&WHITE)?;
    let s = &analysis.summary;
    let fmt = |v: Option<f64>, scale: f64, digits: usize| {
        v.map_or_else(|| "-".to_owned(), |v| format!("{:.*}", digits, v * scale))
    };
    let title = format!(
        "{} - footfall: stride {} m, cadence {} steps/min, speed {} m/s, step width {} cm",
        clip.name(),
        fmt(s.stride_length_m.mean, 1.0, 2),
        fmt(s.cadence_steps_per_min.mean, 1.0, 1),
        fmt(s.speed_mps.mean, 1.0, 2),
        fmt(s.step_width_m.mean, 100.0, 1),
    );
    let root = root.titled(&title, ("sans-serif", 20))?;
    let (top, bottom) = root.split_vertically(root.dim_in_pixel().1 * 3 / 5);

    // Footprints from above: a foot outline at every heel strike, toes pointing along the
    // segment's walking direction.
    let strikes: Vec<(Foot, nalgebra::Point3<f64>, [f64; 2])> = analysis
        .events
        .iter()
        .filter(|e| e.kind == EventKind::HeelStrike)
        .filter_map(|e| {
            let joint = match e.foot {
                Foot::Left => Joint::AnkleLeft,
                Foot::Right => Joint::AnkleRight,
            };
            let p = clip.position_at(joint, e.time_secs)?;
            let d = analysis.segments.get(e.segment)?.direction;
            Some((e.foot, p, d))
        })
        .collect();
    let pelvis: Vec<(f64, f64)> = (0..clip.frame_count())
        .filter_map(|f| {
            match (
                clip.position(f, Joint::HipLeft),
                clip.position(f, Joint::HipRight),
            ) {
                (Some(l), Some(r)) => Some(nalgebra::center(&l, &r)),
                _ => clip.position(f, Joint::SpineBase),
            }
        })
        .map(|p| (p.x, p.y))
        .collect();
    let xs = pelvis
        .iter()
        .map(|p| p.0)
        .chain(strikes.iter().map(|s| s.1.x));
    let ys = pelvis
        .iter()
        .map(|p| p.1)
        .chain(strikes.iter().map(|s| s.1.y));
    let mut xr = span(xs, 1.0);
    let mut yr = span(ys, 0.6);
    // Equal scale on both axes so footprints keep their shape.
    let (w, h) = top.dim_in_pixel();
    let px_per_m = (f64::from(w.saturating_sub(90)) / (xr.end - xr.start))
        .min(f64::from(h.saturating_sub(60)) / (yr.end - yr.start));
    let grow = |r: &mut Range<f64>, pixels: f64| {
        let mid = (r.start + r.end) / 2.0;
        let half = pixels / px_per_m / 2.0;
        *r = mid - half..mid + half;
    };
    grow(&mut xr, f64::from(w.saturating_sub(90)));
    grow(&mut yr, f64::from(h.saturating_sub(60)));
    let mut chart = ChartBuilder::on(&top)
        .margin(10)
        .x_label_area_size(30)
        .y_label_area_size(60)
        .build_cartesian_2d(xr, yr)?;
    chart
        .configure_mesh()
        .x_desc("x (m)")
        .y_desc("y (m)")
        .label_style(("sans-serif", 14))
        .axis_desc_style(("sans-serif", 15))
        .light_line_style(RGBColor(240, 240, 240))
        .draw()?;
    chart
        .draw_series(LineSeries::new(pelvis, PELVIS_COLOUR.stroke_width(2)))?
        .label("pelvis path")
        .legend(|(x, y)| {
            PathElement::new(vec![(x, y), (x + 16, y)], PELVIS_COLOUR.stroke_width(2))
        });
    for foot in Foot::BOTH {
        let colour = foot_colour(foot);
        let prints = strikes.iter().filter(|s| s.0 == foot).map(|(_, p, d)| {
            // Heel 5 cm behind the ankle, toes 20 cm ahead of the heel, 9 cm wide.
            let (dx, dy) = (d[0], d[1]);
            let (lx, ly) = (-dy, dx);
            let corner = |along: f64, side: f64| {
                (p.x + dx * along + lx * side, p.y + dy * along + ly * side)
            };
            Polygon::new(
                vec![
                    corner(-0.05, -0.035),
                    corner(0.15, -0.045),
                    corner(0.17, 0.0),
                    corner(0.15, 0.045),
                    corner(-0.05, 0.035),
                ],
                colour.mix(0.6).filled(),
            )
        });
        chart
            .draw_series(prints)?
            .label(format!("{} heel strikes", foot.name()))
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 16, y + 5)], colour.filled()));
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 14))
        .position(SeriesLabelPosition::UpperLeft)
        .draw()?;

    // Stance bars over time: row 1 = left, row 0 = right.
    let tr = 0.0..clip.duration_secs().max(1.0 / clip.rate_hz());
    let mut chart = ChartBuilder::on(&bottom)
        .margin(10)
        .x_label_area_size(34)
        .y_label_area_size(60)
        .build_cartesian_2d(tr.clone(), -0.9..1.7)?;
    chart
        .configure_mesh()
        .x_desc("time (s)")
        .y_desc("stance")
        .y_labels(3)
        .y_label_formatter(&|v: &f64| match v.round() as i32 {
            1 => "left".to_owned(),
            0 => "right".to_owned(),
            _ => String::new(),
        })
        .label_style(("sans-serif", 14))
        .axis_desc_style(("sans-serif", 15))
        .disable_y_mesh()
        .draw()?;
    for phase in &analysis.excluded {
        let label = match phase.reason {
            ExclusionReason::Standing => "standing",
            ExclusionReason::Turning => "turning",
            ExclusionReason::Gap => "gap",
            ExclusionReason::TooShort => "short",
            ExclusionReason::NotAlternating => "not gait",
        };
        chart.draw_series(std::iter::once(Rectangle::new(
            [(phase.start_secs, -0.9), (phase.end_secs, 1.7)],
            EXCLUDED_COLOUR.filled(),
        )))?;
        chart.draw_series(std::iter::once(Text::new(
            label.to_owned(),
            (phase.start_secs, 1.65),
            ("sans-serif", 13),
        )))?;
    }
    // Double support: both feet in stance.
    let stance = |foot: Foot| stance_intervals(analysis, foot);
    let (left, right) = (stance(Foot::Left), stance(Foot::Right));
    for (a0, a1, _) in &left {
        for (b0, b1, _) in &right {
            let (lo, hi) = (a0.max(*b0), a1.min(*b1));
            if hi > lo {
                chart.draw_series(std::iter::once(Rectangle::new(
                    [(lo, -0.4), (hi, 1.4)],
                    RGBColor(255, 230, 150).filled(),
                )))?;
            }
        }
    }
    for (foot, row, intervals) in [(Foot::Left, 1.0, &left), (Foot::Right, 0.0, &right)] {
        let colour = foot_colour(foot);
        chart.draw_series(intervals.iter().map(|(t0, t1, complete)| {
            let style = if *complete {
                colour.filled()
            } else {
                colour.mix(0.35).filled()
            };
            Rectangle::new([(*t0, row - 0.3), (*t1, row + 0.3)], style)
        }))?;
    }
    chart.draw_series(std::iter::once(Text::new(
        "bars: stance (pale = cut by the recording or a segment end); yellow: double support"
            .to_owned(),
        (tr.start + 0.01 * (tr.end - tr.start), -0.55),
        ("sans-serif", 13),
    )))?;
    Ok(())
}

/// Stance intervals (start, end, both ends observed) of `foot`: heel strike to the next toe off
/// inside the same segment; a stance cut by a segment end is drawn to that end.
fn stance_intervals(analysis: &GaitAnalysis, foot: Foot) -> Vec<(f64, f64, bool)> {
    let mut out = Vec::new();
    for (index, segment) in analysis.segments.iter().enumerate() {
        let events: Vec<_> = analysis
            .events
            .iter()
            .filter(|e| e.foot == foot && e.segment == index)
            .collect();
        let mut open: Option<(f64, bool)> = None;
        // A toe off before any heel strike means the foot was in stance at the segment start.
        if events.first().is_some_and(|e| e.kind == EventKind::ToeOff) {
            open = Some((segment.start_secs, false));
        }
        for e in events {
            match (e.kind, open) {
                (EventKind::HeelStrike, _) => open = Some((e.time_secs, true)),
                (EventKind::ToeOff, Some((t0, seen))) => {
                    out.push((t0, e.time_secs, seen));
                    open = None;
                }
                (EventKind::ToeOff, None) => {}
            }
        }
        if let Some((t0, _)) = open {
            out.push((t0, segment.end_secs, false));
        }
    }
    out
}

/// Which figure to draw.
enum Figure<'j> {
    Trajectories(&'j [Joint]),
    Footfall,
}

impl Figure<'_> {
    fn name(&self) -> &'static str {
        match self {
            Figure::Trajectories(_) => "trajectories",
            Figure::Footfall => "footfall",
        }
    }

    fn size(&self) -> (u32, u32) {
        match self {
            Figure::Trajectories(_) => TRAJECTORIES_SIZE,
            Figure::Footfall => FOOTFALL_SIZE,
        }
    }

    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        clip: &MotionClip,
        analysis: &GaitAnalysis,
    ) -> DrawResult<DB> {
        match self {
            Figure::Trajectories(joints) => draw_trajectories(root, clip, analysis, joints),
            Figure::Footfall => draw_footfall(root, clip, analysis),
        }
    }

    /// Renders into an SVG document.
    fn svg(&self, clip: &MotionClip, analysis: &GaitAnalysis) -> Result<String> {
        let mut svg = String::new();
        {
            let root = SVGBackend::with_string(&mut svg, self.size()).into_drawing_area();
            self.draw(&root, clip, analysis)
                .map_err(plot_error(self.name()))?;
            root.present().map_err(plot_error(self.name()))?;
        }
        Ok(svg)
    }

    /// Renders into an RGB buffer through [`TextBitmap`] and encodes it as PNG.
    fn png(&self, clip: &MotionClip, analysis: &GaitAnalysis) -> Result<Vec<u8>> {
        let size = self.size();
        let mut rgb = vec![255u8; size.0 as usize * size.1 as usize * 3];
        {
            let root =
                TextBitmap::new(BitMapBackend::with_buffer(&mut rgb, size)).into_drawing_area();
            self.draw(&root, clip, analysis)
                .map_err(plot_error(self.name()))?;
            root.present().map_err(plot_error(self.name()))?;
        }
        encode_png(&rgb, size).map_err(|message| Error::Plot {
            plot: self.name(),
            message,
        })
    }
}

/// PNG-encodes an 8-bit RGB buffer.
fn encode_png(rgb: &[u8], (w, h): (u32, u32)) -> std::result::Result<Vec<u8>, String> {
    let mut out = Vec::new();
    {
        let mut encoder = png::Encoder::new(&mut out, w, h);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        let mut writer = encoder.write_header().map_err(|e| e.to_string())?;
        writer.write_image_data(rgb).map_err(|e| e.to_string())?;
        writer.finish().map_err(|e| e.to_string())?;
    }
    Ok(out)
}

/// Joint trajectories with events as SVG ([`TRAJECTORIES_SIZE`]); `joints` empty = the leg
/// joints of the clip ([`default_joints`]).
///
/// # Errors
/// [`Error::Plot`] when the backend fails.
pub fn trajectories_svg(
    clip: &MotionClip,
    analysis: &GaitAnalysis,
    joints: &[Joint],
) -> Result<String> {
    Figure::Trajectories(&pick(clip, joints)).svg(clip, analysis)
}

/// Joint trajectories with events as PNG bytes ([`TRAJECTORIES_SIZE`]).
///
/// # Errors
/// [`Error::Plot`] when the backend or the PNG encoder fails.
pub fn trajectories_png(
    clip: &MotionClip,
    analysis: &GaitAnalysis,
    joints: &[Joint],
) -> Result<Vec<u8>> {
    Figure::Trajectories(&pick(clip, joints)).png(clip, analysis)
}

/// Footfall diagram as SVG ([`FOOTFALL_SIZE`]).
///
/// # Errors
/// [`Error::Plot`] when the backend fails.
pub fn footfall_svg(clip: &MotionClip, analysis: &GaitAnalysis) -> Result<String> {
    Figure::Footfall.svg(clip, analysis)
}

/// Footfall diagram as PNG bytes ([`FOOTFALL_SIZE`]).
///
/// # Errors
/// [`Error::Plot`] when the backend or the PNG encoder fails.
pub fn footfall_png(clip: &MotionClip, analysis: &GaitAnalysis) -> Result<Vec<u8>> {
    Figure::Footfall.png(clip, analysis)
}

fn pick(clip: &MotionClip, joints: &[Joint]) -> Vec<Joint> {
    if joints.is_empty() {
        default_joints(clip)
    } else {
        joints.iter().copied().filter(|j| clip.has(*j)).collect()
    }
}

/// A drawing backend that draws text with the built-in 8×8 bitmap font and delegates everything
/// else to `B`. Used for PNGs, because plotters' bitmap backend needs a system font for text.
#[derive(Debug)]
pub struct TextBitmap<B> {
    inner: B,
}

impl<B: DrawingBackend> TextBitmap<B> {
    /// Wraps `inner`.
    pub fn new(inner: B) -> Self {
        Self { inner }
    }

    /// Glyph scale for a font size in pixels: 1 (8 px glyphs) below 26 px, then 2, ….
    fn scale(size: f64) -> i32 {
        ((size / 13.0).floor() as i32).max(1)
    }
}

impl<B: DrawingBackend> DrawingBackend for TextBitmap<B> {
    type ErrorType = B::ErrorType;

    fn get_size(&self) -> (u32, u32) {
        self.inner.get_size()
    }

    fn ensure_prepared(&mut self) -> std::result::Result<(), DrawingErrorKind<B::ErrorType>> {
        self.inner.ensure_prepared()
    }

    fn present(&mut self) -> std::result::Result<(), DrawingErrorKind<B::ErrorType>> {
        self.inner.present()
    }

    fn draw_pixel(
        &mut self,
        point: BackendCoord,
        color: BackendColor,
    ) -> std::result::Result<(), DrawingErrorKind<B::ErrorType>> {
        self.inner.draw_pixel(point, color)
    }

    fn draw_line<S: plotters_backend::BackendStyle>(
        &mut self,
        from: BackendCoord,
        to: BackendCoord,
        style: &S,
    ) -> std::result::Result<(), DrawingErrorKind<B::ErrorType>> {
        self.inner.draw_line(from, to, style)
    }

    fn draw_rect<S: plotters_backend::BackendStyle>(
        &mut self,
        upper_left: BackendCoord,
        bottom_right: BackendCoord,
        style: &S,
        fill: bool,
    ) -> std::result::Result<(), DrawingErrorKind<B::ErrorType>> {
        self.inner.draw_rect(upper_left, bottom_right, style, fill)
    }

    fn draw_path<S: plotters_backend::BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        path: I,
        style: &S,
    ) -> std::result::Result<(), DrawingErrorKind<B::ErrorType>> {
        self.inner.draw_path(path, style)
    }

    fn draw_circle<S: plotters_backend::BackendStyle>(
        &mut self,
        center: BackendCoord,
        radius: u32,
        style: &S,
        fill: bool,
    ) -> std::result::Result<(), DrawingErrorKind<B::ErrorType>> {
        self.inner.draw_circle(center, radius, style, fill)
    }

    fn fill_polygon<S: plotters_backend::BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        vert: I,
        style: &S,
    ) -> std::result::Result<(), DrawingErrorKind<B::ErrorType>> {
        self.inner.fill_polygon(vert, style)
    }

    fn blit_bitmap(
        &mut self,
        pos: BackendCoord,
        size: (u32, u32),
        src: &[u8],
    ) -> std::result::Result<(), DrawingErrorKind<B::ErrorType>> {
        self.inner.blit_bitmap(pos, size, src)
    }

    fn estimate_text_size<S: BackendTextStyle>(
        &self,
        text: &str,
        style: &S,
    ) -> std::result::Result<(u32, u32), DrawingErrorKind<B::ErrorType>> {
        let s = Self::scale(style.size()) as u32;
        Ok((8 * s * text.chars().count() as u32, 8 * s))
    }

    fn draw_text<S: BackendTextStyle>(
        &mut self,
        text: &str,
        style: &S,
        pos: BackendCoord,
    ) -> std::result::Result<(), DrawingErrorKind<B::ErrorType>> {
        let color = style.color();
        if color.alpha == 0.0 {
            return Ok(());
        }
        let s = Self::scale(style.size());
        let width = 8 * s * text.chars().count() as i32;
        let height = 8 * s;
        let anchor = style.anchor();
        let dx = match anchor.h_pos {
            HPos::Left => 0,
            HPos::Center => -width / 2,
            HPos::Right => -width,
        };
        let dy = match anchor.v_pos {
            VPos::Top => 0,
            VPos::Center => -height / 2,
            VPos::Bottom => -height,
        };
        let transform = style.transform();
        let (w, h) = self.get_size();
        for (k, ch) in text.chars().enumerate() {
            let glyph = font8x8::legacy::BASIC_LEGACY
                .get(ch as usize)
                .copied()
                .unwrap_or(font8x8::legacy::NOTHING_TO_DISPLAY);
            for (row, bits) in glyph.iter().enumerate() {
                for col in 0..8 {
                    if bits & (1 << col) == 0 {
                        continue;
                    }
                    for sy in 0..s {
                        for sx in 0..s {
                            let x = dx + (k as i32 * 8 + col) * s + sx;
                            let y = dy + row as i32 * s + sy;
                            let (x, y) = transform.transform(x, y);
                            let (x, y) = (pos.0 + x, pos.1 + y);
                            if x >= 0 && y >= 0 && x < w as i32 && y < h as i32 {
                                self.inner.draw_pixel((x, y), color)?;
                            }
                        }
                    }
                }
            }
        }
        Ok(())
    }
}
