//! The depth metrics' maps and report, logged to rerun when asked, written once for both
//! callers: the `depth-metrics` dataflow node (live frames) and `trigait depth-metrics --rrd`
//! (recorded frames).
//!
//! Why a separate crate and not a `rerun` feature of `trigait-depth`: `trigait-depth` is an
//! operator crate and stays free of I/O frameworks (DESIGN.md, "Algorithms live in `operators/`
//! as plain Rust libraries"; STYLE.md §6: operators never import rerun). A cargo feature would
//! not keep it so in practice: the workspace is built as one (`cargo build --workspace`), so
//! features unify and every build of `trigait-depth` — its unit tests and benchmark included —
//! would compile rerun as soon as one crate asked for the feature. As its own crate the
//! adapter is compiled only into the two binaries that log, and the metric code cannot
//! accidentally depend on rerun types.
//!
//! What is logged, per sensor, under `depth/<sensor>/`:
//! - `maps/<name>`: every map of [`trigait_depth::render::render_all`] as a colour-mapped RGB
//!   image (512×424, the legend strip cropped off): `depth` (mean depth, §3.1), `accuracy_zones`
//!   (§3.1/§5.1.1 green/yellow/red), `entropy` (§3.3, eq. 3.3), `edge_band` (§3.4) and
//!   `structural_residual` (§3.5). Maps a report cannot have (entropy of one frame, accuracy
//!   without a plane) are simply absent.
//! - `maps/<name>/legend`: the legend in words (static, once per map).
//! - `metrics/<name>`: one scalar per report number ([`scalars`]).
//!
//! Every call logs at the `depth_frames` sequence timeline set to the frames pushed so far, so a
//! viewer scrubs through the report updates of a live run.

pub use rerun::{RecordingStream, RecordingStreamError};
use trigait_depth::render::{MapLegend, render_all};
use trigait_depth::{HEIGHT, MetricsParams, SequenceMaps, SequenceReport, WIDTH};

/// Sequence timeline: frames pushed to the analyzer when the report was made.
pub const TIMELINE: &str = "depth_frames";

/// Root entity of everything logged here.
pub const ROOT: &str = "depth";

/// Where a recording goes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Sink {
    /// An `.rrd` file (its folder is created).
    File(std::path::PathBuf),
    /// A running viewer's gRPC proxy (`rerun+http://127.0.0.1:9876/proxy`).
    Connect(String),
}

impl Sink {
    /// `rrd` files go to `default_file`; a `rerun+http://…` url connects; any other value is a
    /// file path.
    #[must_use]
    pub fn from_spec(spec: &str, default_file: &std::path::Path) -> Self {
        let spec = spec.trim();
        if spec == "rrd" {
            Self::File(default_file.to_owned())
        } else if spec.starts_with("rerun") || spec.starts_with("http") {
            Self::Connect(spec.to_owned())
        } else {
            Self::File(spec.into())
        }
    }
}

/// Opens a recording of application `app_id` into `sink`. Drop the stream to flush the file.
///
/// # Errors
/// The folder or file cannot be created, or the url is not a rerun proxy url.
pub fn open(app_id: &'static str, sink: &Sink) -> Result<RecordingStream, String> {
    let builder = rerun::RecordingStreamBuilder::new(app_id);
    match sink {
        Sink::File(path) => {
            if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir)
                    .map_err(|e| format!("creating {}: {e}", dir.display()))?;
            }
            builder
                .save(path)
                .map_err(|e| format!("opening {}: {e}", path.display()))
        }
        Sink::Connect(url) => {
            let viewer: Box<dyn rerun::sink::LogSink> =
                Box::new(trigait_rerun_viewer::ViewerSink::new(url)?);
            builder
                .set_sinks(vec![viewer])
                .map_err(|e| format!("connecting to {url:?}: {e}"))
        }
    }
}

/// Entity of map `name` of `sensor`.
#[must_use]
pub fn map_entity(sensor: &str, name: &str) -> String {
    format!("{ROOT}/{sensor}/maps/{name}")
}

/// Entity of scalar `name` of `sensor`.
#[must_use]
pub fn scalar_entity(sensor: &str, name: &str) -> String {
    format!("{ROOT}/{sensor}/metrics/{name}")
}

/// The report's numbers as `(name, value)`; a metric the report lacks is left out, so a plot
/// never shows a made-up zero.
#[must_use]
pub fn scalars(report: &SequenceReport) -> Vec<(&'static str, f64)> {
    let mut out = vec![("valid_share", report.valid_share)];
    if let Some(a) = &report.accuracy {
        out.push(("accuracy_mm", a.accuracy_mm));
        out.push(("target_distance_m", a.target_distance_m));
        if let Some(sd) = a.temporal_sd_mm {
            out.push(("temporal_sd_mm", sd));
        }
        if let Some(d) = &a.depth_mm {
            out.push(("depth_sd_mm", d.sd));
        }
        out.push(("zone_green_share", a.zones_in_cone.green));
        out.push(("zone_yellow_share", a.zones_in_cone.yellow));
        out.push(("zone_red_share", a.zones_in_cone.red));
    }
    if let Some(r) = &report.resolution.overall {
        if let Some(s) = r.min_nonzero_step_mm {
            out.push(("resolution_min_step_mm", f64::from(s)));
        }
        out.push(("resolution_mean_step_mm", r.mean_step_mm));
    }
    if let Some(bits) = report.entropy.as_ref().and_then(|e| e.bits.as_ref()) {
        out.push(("entropy_mean_bits", bits.mean));
    }
    if let Some(w) = &report.edge_noise.band_width_px {
        out.push(("edge_band_width_px", w.mean));
    }
    out.push(("edge_affected_share", report.edge_noise.affected_share));
    if let Some(s) = &report.structural_noise {
        out.push(("structural_rms_mm", s.rms_residual_mm));
        out.push(("ring_amplitude_mm", s.ring_amplitude_mm));
        out.push(("ring_period_px", s.ring_period_px));
    }
    out
}

/// What one [`log_report`] call logged.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Logged {
    /// Map names logged as images.
    pub maps: Vec<&'static str>,
    /// Scalars logged.
    pub scalars: usize,
}

/// Logs `sensor`'s maps and report scalars at `depth_frames = report.frames`.
///
/// Legends are logged statically the first time a map appears (`legends_logged` remembers
/// which; keep one per sensor).
///
/// # Errors
/// rerun refused a log call (a closed sink).
pub fn log_report(
    rec: &RecordingStream,
    sensor: &str,
    report: &SequenceReport,
    maps: &SequenceMaps,
    params: &MetricsParams,
    legends_logged: &mut Vec<&'static str>,
) -> Result<Logged, RecordingStreamError> {
    rec.set_time_sequence(TIMELINE, i64::try_from(report.frames).unwrap_or(i64::MAX));
    let mut logged = Logged::default();
    for (image, legend) in render_all(maps, params) {
        let entity = map_entity(sensor, legend.name);
        if !legends_logged.contains(&legend.name) {
            rec.log_static(
                format!("{entity}/legend"),
                &rerun::TextDocument::from_markdown(legend_markdown(&legend)),
            )?;
            legends_logged.push(legend.name);
        }
        // The map is the top 512×424 of the rendered image; the legend strip below it is
        // replaced by the text document above.
        let map_bytes = image.rgb[..3 * WIDTH * HEIGHT].to_vec();
        rec.log(
            entity.as_str(),
            &rerun::Image::from_rgb24(map_bytes, [WIDTH as u32, HEIGHT as u32]),
        )?;
        logged.maps.push(legend.name);
    }
    for (name, value) in scalars(report) {
        rec.log(scalar_entity(sensor, name), &rerun::Scalars::single(value))?;
        logged.scalars += 1;
    }
    Ok(logged)
}

/// Entity of a leg tracker's debugging output: `legs/<sensor>/<name>`.
#[must_use]
pub fn legs_entity(sensor: &str, name: &str) -> String {
    format!("legs/{sensor}/{name}")
}

/// Logs what a leg tracker made of `sensor`'s depth frame `seq` (on [`TIMELINE`]), for
/// debugging: the person mask as an 8-bit image (`legs/<sensor>/person_mask`, 255 = person;
/// nothing when no person was found), the fitted joints as camera-space points
/// (`legs/<sensor>/joints`, metres, labelled) and each leg's hip → knee → ankle → foot
/// polyline (`legs/<sensor>/model`).
///
/// # Errors
/// rerun refused a log call (a closed sink).
pub fn log_legs(
    rec: &RecordingStream,
    sensor: &str,
    seq: u64,
    person_mask: &[bool],
    joints: &[(String, [f32; 3])],
    chains: &[Vec<[f32; 3]>],
) -> Result<(), RecordingStreamError> {
    rec.set_time_sequence(TIMELINE, i64::try_from(seq).unwrap_or(i64::MAX));
    if person_mask.len() == WIDTH * HEIGHT {
        let bytes: Vec<u8> = person_mask
            .iter()
            .map(|p| if *p { 255 } else { 0 })
            .collect();
        rec.log(
            legs_entity(sensor, "person_mask"),
            &rerun::Image::from_l8(bytes, [WIDTH as u32, HEIGHT as u32]),
        )?;
    }
    rec.log(
        legs_entity(sensor, "joints"),
        &rerun::Points3D::new(joints.iter().map(|(_, p)| *p))
            .with_labels(joints.iter().map(|(name, _)| name.clone())),
    )?;
    rec.log(
        legs_entity(sensor, "model"),
        &rerun::LineStrips3D::new(chains.iter().cloned()),
    )?;
    Ok(())
}

/// The entity of `sensor`'s device state (`sensors/k1/device`).
#[must_use]
pub fn device_entity(sensor: &str) -> String {
    format!("sensors/{sensor}/device")
}

/// Logs a sensor's device state at `stamp_nanos` (host clock) on the `host_time` timeline: a
/// text line (a warning while degraded) and `device/degraded` as 0 or 1, so the viewer shows
/// when a stalled or unplugged sensor stopped sending and when it came back.
///
/// # Errors
/// rerun refused a log call (a closed sink).
pub fn log_device_state(
    rec: &RecordingStream,
    sensor: &str,
    stamp_nanos: i64,
    degraded: bool,
    detail: &str,
) -> Result<(), RecordingStreamError> {
    rec.set_timestamp_nanos_since_epoch("host_time", stamp_nanos);
    let level = if degraded {
        rerun::components::TextLogLevel::WARN
    } else {
        rerun::components::TextLogLevel::INFO
    };
    let entity = device_entity(sensor);
    rec.log(
        entity.as_str(),
        &rerun::TextLog::new(format!("{sensor}: {detail}")).with_level(level),
    )?;
    rec.log(
        format!("{entity}/degraded"),
        &rerun::Scalars::single(f64::from(u8::from(degraded))),
    )
}

/// A legend as markdown: what the map shows, its discrete colours and its colour scale.
#[must_use]
pub fn legend_markdown(legend: &MapLegend) -> String {
    let mut md = format!("**{}**: {}\n\n", legend.name, legend.shows);
    for e in &legend.entries {
        md += &format!(
            "- rgb({}, {}, {}): {}\n",
            e.rgb[0], e.rgb[1], e.rgb[2], e.meaning
        );
    }
    if let Some(s) = &legend.scale {
        md += &format!(
            "- colour map `{}` from {} to {} {}\n",
            s.colormap, s.min, s.max, s.unit
        );
    }
    md
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use trigait_depth::sim::{Scene, SimParams, Simulator};
    use trigait_depth::{MetricsParams, SequenceAnalyzer};

    use super::*;

    fn report_and_maps(frames: usize) -> (SequenceReport, SequenceMaps) {
        let sim = SimParams {
            noise_sd_mm: 1.5,
            ring_amplitude_mm: 2.0,
            ..SimParams::default()
        };
        let mut sim = Simulator::new(&Scene::wall(2.0), sim).unwrap();
        let mut a = SequenceAnalyzer::new(MetricsParams::default(), None);
        for _ in 0..frames {
            a.push(&sim.next_frame());
        }
        a.report_and_maps().unwrap()
    }

    /// A tracked frame logs its mask, joints and model; an empty mask logs no image.
    #[test]
    fn logs_a_tracked_frame() {
        let (rec, storage) = rerun::RecordingStreamBuilder::new("test").memory().unwrap();
        let mask = vec![true; WIDTH * HEIGHT];
        let joints = vec![("knee_left".to_owned(), [0.1, -0.4, 2.0])];
        let chains = vec![vec![[0.1, 0.1, 2.0], [0.1, -0.4, 2.0]]];
        log_legs(&rec, "k1", 3, &mask, &joints, &chains).unwrap();
        log_legs(&rec, "k1", 4, &[], &[], &[]).unwrap();
        rec.flush_blocking().unwrap();
        assert!(!storage.take().is_empty());
        assert_eq!(legs_entity("k2", "joints"), "legs/k2/joints");
    }

    /// A wall sequence logs the five maps and the scalars of every metric it has; a one-frame
    /// sequence has no entropy map and no entropy or temporal-sd scalar (nothing made up).
    #[test]
    fn logs_every_map_the_report_has() {
        let (rec, storage) = rerun::RecordingStreamBuilder::new("test").memory().unwrap();
        let (report, maps) = report_and_maps(5);
        let mut legends = Vec::new();
        let logged = log_report(
            &rec,
            "k1",
            &report,
            &maps,
            &MetricsParams::default(),
            &mut legends,
        )
        .unwrap();
        assert_eq!(
            logged.maps,
            [
                "depth",
                "accuracy_zones",
                "entropy",
                "edge_band",
                "structural_residual"
            ]
        );
        let names: Vec<_> = scalars(&report).into_iter().map(|(n, _)| n).collect();
        assert!(names.contains(&"ring_amplitude_mm") && names.contains(&"temporal_sd_mm"));
        assert_eq!(logged.scalars, names.len());
        // Legends only once.
        log_report(
            &rec,
            "k1",
            &report,
            &maps,
            &MetricsParams::default(),
            &mut legends,
        )
        .unwrap();
        assert_eq!(legends.len(), 5);
        rec.flush_blocking().unwrap();
        assert!(!storage.take().is_empty());

        let (one, one_maps) = report_and_maps(1);
        let names: Vec<_> = scalars(&one).into_iter().map(|(n, _)| n).collect();
        assert!(!names.contains(&"entropy_mean_bits") && !names.contains(&"temporal_sd_mm"));
        assert!(
            !render_all(&one_maps, &MetricsParams::default())
                .iter()
                .any(|(_, l)| l.name == "entropy")
        );
    }
}
