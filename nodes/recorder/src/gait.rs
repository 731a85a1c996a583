//! Gait events and spatiotemporal parameters of the fused walk, logged to rerun while the graph
//! runs and written to `summary.json` at the end.
//!
//! The analysis is `trigait-gait`'s [`LiveGait`] with the `trigait gait` defaults (Zeni et al.
//! 2008 coordinate method, two strides at least): every second of stream time the retained
//! fused trajectories are analysed again and events that have settled (1.5 s old) are logged;
//! at the end the rest are logged and the parameters computed over the whole recording.
//!
//! Entity paths (timeline `server_time` = the event's instant on the server clock):
//! - `gait/<left|right>/heel_strike`, `gait/<left|right>/toe_off`: one scalar per event, the
//!   height (m) of the event's joint (the ankle, standing in for the heel/toe; thesis §6.4.4
//!   tracks no foot joints), drawn as markers — next to `plots/ankle_<side>/z` it marks where on
//!   the ankle's height curve each event fell;
//! - `gait/events`: a text log line per event;
//! - `gait/cadence_steps_per_min`, `gait/stride_length_m`, `gait/speed_mps`,
//!   `gait/step_width_m`: the means, once, at the last pose; `gait/report`: the report as text.

use rerun::RecordingStream;
use trigait_gait::{EventKind, LiveGait, LiveGaitParams, LiveReport, TimedEvent};
use trigait_schema::FusedPose;

use crate::viz::SERVER_TIME;

fn kind_name(kind: EventKind) -> &'static str {
    match kind {
        EventKind::HeelStrike => "heel_strike",
        EventKind::ToeOff => "toe_off",
    }
}

/// The recorder's gait analysis.
#[derive(Debug)]
pub struct Gait {
    live: LiveGait,
    last_stamp_nanos: Option<i64>,
}

impl Gait {
    /// Logs the marker styles (static) and starts an empty analysis.
    pub fn new(rec: &RecordingStream) -> eyre::Result<Self> {
        for side in ["left", "right"] {
            for (kind, marker) in [
                ("heel_strike", rerun::components::MarkerShape::Down),
                ("toe_off", rerun::components::MarkerShape::Up),
            ] {
                rec.log_static(
                    format!("gait/{side}/{kind}"),
                    &rerun::SeriesPoints::new()
                        .with_markers([marker])
                        .with_marker_sizes([6.0_f32])
                        .with_names([format!("{side} {} (ankle z, m)", kind.replace('_', " "))]),
                )?;
            }
        }
        Ok(Self {
            live: LiveGait::new(LiveGaitParams::default()),
            last_stamp_nanos: None,
        })
    }

    /// Adds a fused pose; logs the events that settled.
    pub fn push(&mut self, rec: &RecordingStream, pose: &FusedPose) -> eyre::Result<()> {
        self.live.push(
            pose.stamp_nanos,
            pose.joints.iter().map(|(j, f)| (*j, &f.position)),
        );
        self.last_stamp_nanos = Some(
            self.last_stamp_nanos
                .map_or(pose.stamp_nanos, |t| t.max(pose.stamp_nanos)),
        );
        let events = self.live.poll();
        log_events(rec, &events)
    }

    /// Logs the remaining events and the parameters; returns the `summary.json` section (and
    /// the first rerun error, which must not cost the summary).
    pub fn finish(&mut self, rec: &RecordingStream) -> (LiveReport, eyre::Result<()>) {
        let (events, report) = self.live.finish();
        let logged = log_events(rec, &events).and_then(|()| self.log_report(rec, &report));
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

    fn log_report(&self, rec: &RecordingStream, report: &LiveReport) -> eyre::Result<()> {
        rec.reset_time();
        if let Some(t) = self.last_stamp_nanos {
            rec.set_timestamp_nanos_since_epoch(SERVER_TIME, t);
        }
        for (path, value) in [
            ("gait/cadence_steps_per_min", report.cadence_steps_per_min),
            ("gait/stride_length_m", report.stride_length_m),
            ("gait/speed_mps", report.speed_mps),
            ("gait/step_width_m", report.step_width_m),
        ] {
            if let Some(v) = value {
                rec.log(path, &rerun::Scalars::single(v))?;
            }
        }
        let text = serde_json::to_string_pretty(report).unwrap_or_default();
        rec.log(
            "gait/report",
            &rerun::TextDocument::from_markdown(format!("```json\n{text}\n```")),
        )?;
        Ok(())
    }
}

fn log_events(rec: &RecordingStream, events: &[TimedEvent]) -> eyre::Result<()> {
    for e in events {
        rec.reset_time();
        rec.set_timestamp_nanos_since_epoch(SERVER_TIME, e.stamp_nanos);
        let path = format!("gait/{}/{}", e.foot.name(), kind_name(e.kind));
        if let Some(p) = e.position {
            rec.log(path.as_str(), &rerun::Scalars::single(p.z))?;
        }
        rec.log(
            "gait/events",
            &rerun::TextLog::new(format!(
                "{} {}",
                e.foot.name(),
                kind_name(e.kind).replace('_', " ")
            ))
            .with_level(rerun::components::TextLogLevel::INFO),
        )?;
    }
    Ok(())
}
