//! The gait panel: events, stance/swing, the parameter table and the flexion curves of the fused
//! walk, logged to rerun while the graph runs; the parameters go to `summary.json` at the end.
//!
//! The analysis is `trigait-gait`'s [`LiveGait`] with the `trigait gait` defaults for a skeleton
//! stream (Zeni et al. 2008 coordinate method, a 6 Hz low-pass after the cleaning): every second
//! of stream time the retained fused trajectories are analysed again in full, and the events
//! that analysis keeps that have settled (1.5 s old) are logged, so no marker stands for a foot
//! in the air or a contact too short to be one; when one is a heel strike, the table and the
//! flexion curves are redrawn from that same analysis. At the end the rest is logged and the
//! parameters computed over the whole recording.
//!
//! It runs on a thread of its own, fed the poses through a channel: a full analysis takes tens
//! of milliseconds (35 ms for a 24 s window on the 2-core machine, 140 ms for 10 min), which on
//! the event loop would hold up the poses behind it.
//!
//! Entity paths (each event at its own instant on the `time` and `server_time` timelines):
//! - `gait/phase/<left|right>`: the foot's state, `stance` from a heel strike, `swing` from a
//!   toe off (a state timeline);
//! - `gait/events/<left|right>/<heel_strike|toe_off>`: one marker per event at the height (m)
//!   of the event's joint (the ankle, standing in for the heel and toe; thesis §6.4.4 tracks no
//!   foot joints);
//! - `gait/log`: a text line per event; `gait/parameters`: the parameter table (markdown);
//! - `flexion/<knee|hip>/<left|right>/cycles` (the last [`SHOWN_CYCLES`] cycles) and `…/mean`
//!   (all cycles): sagittal flexion over the gait cycle ([`trigait_gait::angles`]) drawn as a
//!   2-D chart, x = % of the cycle from heel strike, y = −degrees (up is flexion), with its grid
//!   and tick labels in `flexion/<knee|hip>/grid` and `…/ticks`.

use std::collections::BTreeMap;

use rerun::Color;
use trigait_gait::{
    CYCLE_SAMPLES, EventKind, EventMethod, Foot, LiveGait, LiveGaitParams, LiveReport, Summary,
    TimedEvent, flexion_cycles,
};
use trigait_schema::FusedPose;

use crate::viz::{self, Viz};

/// Cycles drawn one by one per foot (the mean uses them all).
pub const SHOWN_CYCLES: usize = 10;

fn kind_name(kind: EventKind) -> &'static str {
    match kind {
        EventKind::HeelStrike => "heel_strike",
        EventKind::ToeOff => "toe_off",
    }
}

fn foot_colour(foot: Foot) -> Color {
    match foot {
        Foot::Left => viz::LEFT,
        Foot::Right => viz::RIGHT,
    }
}

fn faded(c: Color, alpha: u8) -> Color {
    let [r, g, b, _] = c.to_array();
    Color::from_unmultiplied_rgba(r, g, b, alpha)
}

/// One flexion chart's curves of one foot.
#[derive(Debug, Default)]
struct Curves {
    /// The last [`SHOWN_CYCLES`] cycles.
    recent: std::collections::VecDeque<Vec<f64>>,
    /// Point-wise sums over all cycles, for the mean.
    sum: Vec<f64>,
    count: usize,
}

impl Curves {
    fn push(&mut self, curve: &[f64]) {
        if self.sum.is_empty() {
            self.sum = vec![0.0; curve.len()];
        }
        self.sum.iter_mut().zip(curve).for_each(|(s, v)| *s += v);
        self.count += 1;
        self.recent.push_back(curve.to_vec());
        while self.recent.len() > SHOWN_CYCLES {
            self.recent.pop_front();
        }
    }

    fn mean(&self) -> Vec<f64> {
        self.sum.iter().map(|s| s / self.count as f64).collect()
    }
}

/// Chart coordinates of a curve sampled at 0 %, 1 %, …, 100 %.
fn strip(curve: &[f64]) -> Vec<[f32; 2]> {
    let last = (curve.len().max(2) - 1) as f64;
    curve
        .iter()
        .enumerate()
        .map(|(i, v)| [(100.0 * i as f64 / last) as f32, viz::chart_y(*v)])
        .collect()
}

enum Message {
    Pose(i64, Vec<(trigait_skeleton::Joint, nalgebra::Point3<f64>)>),
    Finish,
}

/// The recorder's gait analysis, live and on the final `report.html` page alike: the `trigait
/// gait` defaults for a skeleton stream, the fused joints low-passed after the cleaning
/// ([`trigait_gait::filter::SKELETON_FILTER`]; none where the stream's rate cannot carry it,
/// [`trigait_gait::filter::Filter::or_none_at`]), so the events logged and `summary.json` agree
/// with the page.
pub(crate) fn gait_params() -> trigait_gait::GaitParams {
    trigait_gait::GaitParams {
        filter: trigait_gait::filter::SKELETON_FILTER,
        ..trigait_gait::GaitParams::default()
    }
}

fn live_params() -> LiveGaitParams {
    LiveGaitParams {
        gait: gait_params(),
        ..LiveGaitParams::default()
    }
}

/// The recorder's gait analysis: the handle of its thread.
#[derive(Debug)]
pub struct Gait {
    tx: std::sync::mpsc::Sender<Message>,
    worker: Option<std::thread::JoinHandle<(LiveReport, eyre::Result<()>)>>,
}

impl Gait {
    /// Logs the static styles (markers, states, chart grids) and starts the analysis thread.
    pub fn new(viz: &Viz) -> eyre::Result<Self> {
        for foot in Foot::BOTH {
            let side = foot.name();
            let colour = foot_colour(foot);
            for (kind, marker) in [
                ("heel_strike", rerun::components::MarkerShape::Down),
                ("toe_off", rerun::components::MarkerShape::Up),
            ] {
                viz.log_static(
                    format!("{}/{side}/{kind}", viz::EVENTS),
                    &rerun::SeriesPoints::new()
                        .with_markers([marker])
                        .with_marker_sizes([6.0_f32])
                        .with_colors([if kind == "toe_off" {
                            faded(colour, 200)
                        } else {
                            colour
                        }])
                        .with_names([format!("{side} {}", kind.replace('_', " "))]),
                )?;
            }
            viz.log_static(
                format!("{}/{side}", viz::PHASE),
                &rerun::StateConfiguration::new()
                    .with_values(["stance", "swing"])
                    .with_labels([format!("{side} foot on the floor"), format!("{side} swing")])
                    .with_colors([colour, faded(colour, 70)]),
            )?;
        }
        chart_frame(viz, viz::KNEE, viz::KNEE_RANGE_DEG)?;
        chart_frame(viz, viz::HIP, viz::HIP_RANGE_DEG)?;
        let (tx, rx) = std::sync::mpsc::channel();
        let mut worker = Worker {
            viz: viz.clone(),
            live: LiveGait::new(live_params()),
            last_stamp_nanos: None,
            drawn_until: BTreeMap::new(),
            knee: BTreeMap::new(),
            hip: BTreeMap::new(),
            method: None,
        };
        let worker = std::thread::Builder::new()
            .name("gait".into())
            .spawn(move || worker.run(&rx))
            .map_err(|e| eyre::eyre!("starting the gait analysis thread: {e}"))?;
        Ok(Self {
            tx,
            worker: Some(worker),
        })
    }

    /// Hands a fused pose to the analysis thread.
    pub fn push(&mut self, pose: &FusedPose) -> eyre::Result<()> {
        let joints = pose.joints.iter().map(|(j, f)| (*j, f.position)).collect();
        self.tx
            .send(Message::Pose(pose.stamp_nanos, joints))
            .map_err(|_| eyre::eyre!("the gait analysis thread has stopped"))
    }

    /// Waits for the analysis to log the remaining events, the final table and curves; returns
    /// the `summary.json` section (and the first rerun error, which must not cost the summary).
    pub fn finish(&mut self) -> (LiveReport, eyre::Result<()>) {
        self.tx.send(Message::Finish).ok();
        match self.worker.take().map(std::thread::JoinHandle::join) {
            Some(Ok(done)) => done,
            _ => {
                let (_, mut report) = LiveGait::new(live_params()).finish();
                report.reason = Some("the gait analysis thread failed".to_owned());
                (report, Err(eyre::eyre!("the gait analysis thread failed")))
            }
        }
    }
}

/// The analysis thread's state.
struct Worker {
    viz: Viz,
    live: LiveGait,
    last_stamp_nanos: Option<i64>,
    /// End stamp of the last cycle drawn, per foot.
    drawn_until: BTreeMap<Foot, i64>,
    knee: BTreeMap<Foot, Curves>,
    hip: BTreeMap<Foot, Curves>,
    /// The event detector the last analysis chose (the parameters' `Auto` picks one).
    method: Option<EventMethod>,
}

impl Worker {
    fn run(&mut self, rx: &std::sync::mpsc::Receiver<Message>) -> (LiveReport, eyre::Result<()>) {
        let mut first_error = None;
        while let Ok(Message::Pose(stamp, joints)) = rx.recv() {
            if let Err(e) = self.push(stamp, &joints) {
                first_error.get_or_insert(e);
            }
        }
        let (report, logged) = self.finish();
        (report, first_error.map_or(logged, Err))
    }

    fn push(
        &mut self,
        stamp_nanos: i64,
        joints: &[(trigait_skeleton::Joint, nalgebra::Point3<f64>)],
    ) -> eyre::Result<()> {
        if self.last_stamp_nanos.is_none() {
            self.viz.set_time(stamp_nanos);
            self.viz.log(
                viz::PARAMETERS,
                &rerun::TextDocument::from_markdown(
                    "No complete stride yet: the table fills in once a foot has struck the \
                     floor twice in a straight stretch of walking (events settle 1.5 s after \
                     they happen).",
                ),
            )?;
        }
        self.live
            .push(stamp_nanos, joints.iter().map(|(j, p)| (*j, p)));
        self.last_stamp_nanos = Some(
            self.last_stamp_nanos
                .map_or(stamp_nanos, |t| t.max(stamp_nanos)),
        );
        let events = self.live.poll();
        log_events(&self.viz, &events)?;
        if events.iter().any(|e| e.kind == EventKind::HeelStrike) {
            self.redraw(false)?;
        }
        Ok(())
    }

    fn finish(&mut self) -> (LiveReport, eyre::Result<()>) {
        let drawn = self.redraw(true);
        let (events, report) = self.live.finish();
        let logged = drawn
            .and_then(|()| log_events(&self.viz, &events))
            .and_then(|()| self.log_final(&report));
        tracing::info!(
            "gait: {} heel strikes left, {} right; {}",
            report.heel_strikes.left,
            report.heel_strikes.right,
            match (&report.cadence_steps_per_min, &report.reason) {
                (Some(c), _) => format!("cadence {c:.1} steps/min over {} strides", report.strides),
                (None, Some(r)) => format!("no parameters: {r}"),
                (None, None) => "no parameters".to_owned(),
            }
        );
        (report, logged)
    }

    /// The strides so far: the table, and the flexion cycles not drawn yet (settled ones only
    /// unless `all`).
    fn redraw(&mut self, all: bool) -> eyre::Result<()> {
        let viz = &self.viz;
        let Some(live) = self.live.analysis() else {
            return Ok(());
        };
        let Ok(analysis) = &live.analysis else {
            return Ok(());
        };
        if let Some(t) = self.last_stamp_nanos {
            viz.set_time(t);
        }
        self.method = Some(analysis.method);
        if !all {
            viz.log(
                viz::PARAMETERS,
                &rerun::TextDocument::from_markdown(parameter_table(
                    &analysis.summary,
                    analysis.method,
                    "so far",
                )),
            )?;
        }
        let (cycles, _) = flexion_cycles(&live.clip, analysis);
        let mut changed = false;
        for c in cycles {
            let end = live.stamp_nanos(c.end_secs);
            let drawn = self.drawn_until.get(&c.foot).copied().unwrap_or(i64::MIN);
            if end <= drawn || (!all && end > live.settled_until_nanos) {
                continue;
            }
            self.drawn_until.insert(c.foot, end);
            self.knee.entry(c.foot).or_default().push(&c.knee_deg);
            self.hip.entry(c.foot).or_default().push(&c.hip_deg);
            changed = true;
        }
        if changed {
            for (root, curves) in [(viz::KNEE, &self.knee), (viz::HIP, &self.hip)] {
                for (foot, c) in curves {
                    log_curves(viz, root, *foot, c)?;
                }
            }
        }
        Ok(())
    }

    fn log_final(&self, report: &LiveReport) -> eyre::Result<()> {
        if let Some(t) = self.last_stamp_nanos {
            self.viz.set_time(t);
        }
        let text = match (&report.parameters, &report.reason) {
            (Some(summary), _) => {
                parameter_table(summary, self.method.unwrap_or(report.method), "whole run")
            }
            (None, Some(reason)) => format!("No gait parameters for this run: {reason}."),
            (None, None) => "No gait parameters for this run.".to_owned(),
        };
        self.viz
            .log(viz::PARAMETERS, &rerun::TextDocument::from_markdown(text))?;
        Ok(())
    }
}

/// The parameter table as markdown: one row per parameter with its unit, mean, SD, left and
/// right means and the left/right asymmetry; `scope` says what the strides cover.
#[must_use]
pub fn parameter_table(summary: &Summary, method: EventMethod, scope: &str) -> String {
    let method = match method {
        EventMethod::Coordinate => "the coordinate method (Zeni et al. 2008)",
        EventMethod::Velocity => "the foot-velocity method (after Ghoussayni et al. 2004)",
        EventMethod::Auto => "the method chosen for walking or running",
    };
    let rows = summary.rows();
    let cell = trigait_gait::report::cell;
    let mut out = format!(
        "**{} strides** ({} left, {} right) and {} steps, {scope}; events by {method}. \
         Asymmetry: (left − right) / mean.\n\n\
         | parameter | mean | SD | left | right | asymmetry (%) |\n\
         |---|---:|---:|---:|---:|---:|\n",
        summary.strides, summary.left_strides, summary.right_strides, summary.steps
    );
    for row in &rows {
        let (name, stat, digits) = (row.label, row.stat, row.digits);
        let note = if stat.from_steps { " ¹" } else { "" };
        out.push_str(&format!(
            "| {name}{note} | {} | {} | {} | {} | {} |\n",
            cell(stat.mean, digits),
            cell(stat.sd, digits),
            cell(stat.left, digits),
            cell(stat.right, digits),
            cell(stat.asymmetry_pct, 1),
        ));
    }
    if rows.iter().any(|r| r.stat.from_steps) {
        out.push_str("\n¹ from single steps: no complete stride gave this figure.\n");
    }
    out
}

/// The chart's static frame: grid lines every 10 % and 10°, and tick labels.
fn chart_frame(viz: &Viz, root: &str, (lo, hi): (f64, f64)) -> eyre::Result<()> {
    let grey = Color::from_rgb(70, 70, 70);
    let mut lines = Vec::new();
    let mut colours = Vec::new();
    let mut tick_at = Vec::new();
    let mut tick_text = Vec::new();
    for i in 0..=10 {
        let x = 10.0 * i as f32;
        lines.push(vec![[x, viz::chart_y(lo)], [x, viz::chart_y(hi)]]);
        colours.push(grey);
        if i % 2 == 0 {
            tick_at.push([x, viz::chart_y(lo) + 0.5]);
            tick_text.push(format!("{x:.0} %"));
        }
    }
    let steps = ((hi - lo) / 10.0).round() as i32;
    for i in 0..=steps {
        let deg = lo + 10.0 * f64::from(i);
        lines.push(vec![[0.0, viz::chart_y(deg)], [100.0, viz::chart_y(deg)]]);
        colours.push(if deg.abs() < 1e-9 {
            Color::from_rgb(150, 150, 150)
        } else {
            grey
        });
        // rerun draws a label under its point: raise it by about half a line at the default
        // zoom so it sits beside its grid line.
        tick_at.push([-6.0, viz::chart_y(deg) - 4.0]);
        tick_text.push(format!("{deg:.0}°"));
    }
    viz.log_static(
        format!("{root}/grid"),
        &rerun::LineStrips2D::new(lines)
            .with_colors(colours)
            .with_radii([rerun::components::Radius::new_ui_points(0.5)]),
    )?;
    viz.log_static(
        format!("{root}/ticks"),
        &rerun::Points2D::new(tick_at)
            .with_radii([rerun::components::Radius::new_ui_points(0.1)])
            .with_colors([Color::from_rgb(190, 190, 190)])
            .with_labels(tick_text)
            .with_show_labels(true),
    )?;
    Ok(())
}

fn log_curves(viz: &Viz, root: &str, foot: Foot, curves: &Curves) -> eyre::Result<()> {
    let colour = foot_colour(foot);
    let side = foot.name();
    viz.log(
        format!("{root}/{side}/cycles"),
        &rerun::LineStrips2D::new(curves.recent.iter().map(|c| strip(c)))
            .with_colors([faded(colour, 110)])
            .with_radii([rerun::components::Radius::new_ui_points(0.8)]),
    )?;
    let mean = curves.mean();
    debug_assert_eq!(mean.len(), CYCLE_SAMPLES);
    viz.log(
        format!("{root}/{side}/mean"),
        &rerun::LineStrips2D::new([strip(&mean)])
            .with_colors([colour])
            .with_radii([rerun::components::Radius::new_ui_points(2.0)])
            .with_labels([format!("{side}, mean of {}", curves.count)])
            .with_show_labels(false),
    )?;
    Ok(())
}

fn log_events(viz: &Viz, events: &[TimedEvent]) -> eyre::Result<()> {
    for e in events {
        viz.set_time(e.stamp_nanos);
        let side = e.foot.name();
        if let Some(p) = e.position {
            viz.log(
                format!("{}/{side}/{}", viz::EVENTS, kind_name(e.kind)),
                &rerun::Scalars::single(p.z),
            )?;
        }
        viz.log(
            format!("{}/{side}", viz::PHASE),
            &rerun::StateChange::single(match e.kind {
                EventKind::HeelStrike => "stance",
                EventKind::ToeOff => "swing",
            }),
        )?;
        viz.log(
            viz::LOG,
            &rerun::TextLog::new(format!("{side} {}", kind_name(e.kind).replace('_', " ")))
                .with_level(rerun::components::TextLogLevel::INFO),
        )?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The table names every parameter with its unit and prints a dash for what is missing.
    #[test]
    fn parameter_table_has_units_and_dashes() {
        let empty = trigait_gait::summarise(&[]);
        let t = parameter_table(&empty, EventMethod::Coordinate, "so far");
        for head in [
            "stride length (m)",
            "cadence (steps/min)",
            "speed (m/s)",
            "asymmetry (%)",
        ] {
            assert!(t.contains(head), "{t}");
        }
        assert!(t.contains("**0 strides**"), "{t}");
        assert!(t.contains("| – |"), "{t}");
        let curve: Vec<f64> = (0..CYCLE_SAMPLES).map(|i| i as f64).collect();
        let s = strip(&curve);
        assert_eq!(s.first(), Some(&[0.0, 0.0]));
        assert_eq!(s.last(), Some(&[100.0, viz::chart_y(100.0)]));
    }
}
