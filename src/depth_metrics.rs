//! `trigait depth-metrics`: the thesis's five Kinect v2 depth metrics (ch. 3, §5.1) on recorded
//! depth frames, and with `--calibration` the multi-sensor floor check on Panoptic frames.
//!
//! Inputs are 16-bit PNGs in millimetres (512×424, 0 = no data), given as files and/or
//! directories (their `.png` files in name order). Without `--calibration` they form one
//! sequence from one sensor, in which an all-zero frame (a sensor starting up) is measured
//! as a frame with no valid pixel and counted; with it, file i is one frame of `sensors[i]`.
//! All numbers come from `trigait-depth`, the crate a dataflow node uses on live frames;
//! `--rrd` logs the maps through `trigait-depth-rerun`, the same code as the `depth-metrics`
//! node (entities `depth/sequence/...`, or `depth/sensor_NN/...` with `--calibration`).

use std::path::{Path, PathBuf};

use eyre::{WrapErr as _, bail};
use serde::Serialize;
use trigait_depth::io::{read_depth_png, read_depth_png_as_recorded, read_mask_png};
use trigait_depth::panoptic::{FloorCheck, FloorParams, floor_check, read_panoptic_calibration};
use trigait_depth::render::{MapLegend, render_all, with_title};
use trigait_depth::{MetricsParams, SequenceAnalyzer, SequenceMaps, SequenceReport};

use crate::depth_files::{expand_inputs, progress};

/// Arguments of `trigait depth-metrics`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Depth PNGs (16-bit, millimetres, 512x424) and/or directories of them, in frame order.
    #[arg(required = true, value_name = "PNG|DIR")]
    inputs: Vec<PathBuf>,
    /// CMU Panoptic calibration (kcalibration_*.json): run the multi-sensor floor check, file i
    /// being the frame of sensors[i].
    #[arg(long, value_name = "JSON")]
    calibration: Option<PathBuf>,
    /// Object mask PNG (512x424, non-zero = object) for the edge-noise band.
    #[arg(long, value_name = "PNG")]
    mask: Option<PathBuf>,
    /// True distance of a fronto-parallel target plane in metres, 0.1 to 10 (otherwise a plane is
    /// fitted).
    #[arg(allow_negative_numbers = true, long, value_name = "METRES", value_parser = crate::ranges::number(0.1, 10.0, "m"))]
    target_distance_m: Option<f64>,
    /// Write colour-mapped PNG maps (with legends) into this directory.
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Also log the maps (accuracy zones, entropy, edge band, structural residual, depth) and
    /// the report's scalars to this rerun recording (`.rrd`); open it with `rerun FILE`.
    #[arg(long, value_name = "FILE")]
    rrd: Option<PathBuf>,
    /// Print the JSON report on stdout instead of the table.
    #[arg(long)]
    json: bool,
    /// Frames per entropy window, 2 to 1000 (thesis: 30).
    #[arg(allow_negative_numbers = true, long, default_value_t = 30, value_name = "N", value_parser = crate::ranges::count(2, 1000))]
    entropy_window: usize,
    /// Evaluate depth resolution and edge noise on every N-th frame, 1 to 100,000.
    #[arg(allow_negative_numbers = true, long, default_value_t = 1, value_name = "N", value_parser = crate::ranges::count(1, 100_000))]
    frame_stride: usize,
    /// Depth jump that separates an object from its background, millimetres, 1 to 4500.
    #[arg(long, default_value_t = 100, value_name = "MM", value_parser = clap::value_parser!(u16).range(1..=4500))]
    jump_mm: u16,
}

/// One written image and how to read it.
#[derive(Debug, Serialize)]
struct WrittenMap {
    file: PathBuf,
    #[serde(flatten)]
    legend: MapLegend,
}

#[derive(Debug, Serialize)]
struct SequenceJson<'a> {
    tool: &'static str,
    mode: &'static str,
    inputs: &'a [PathBuf],
    mask: Option<&'a Path>,
    /// Frames with no depth at all (every pixel 0), counted in the metrics as frames with no
    /// valid pixel.
    frames_without_depth: usize,
    #[serde(flatten)]
    report: &'a SequenceReport,
    maps: Vec<WrittenMap>,
}

#[derive(Debug, Serialize)]
struct SensorJson<'a> {
    sensor: usize,
    file: &'a Path,
    valid_pixel_share: f64,
    floor_normal: [f64; 3],
    floor_offset_m: f64,
    floor_rms_m: f64,
    floor_height_at_dome_m: f64,
    floor_tilt_from_y_deg: f64,
    floor_inliers: usize,
    metrics: &'a SequenceReport,
    maps: Vec<WrittenMap>,
}

#[derive(Debug, Serialize)]
struct MultiJson<'a> {
    tool: &'static str,
    mode: &'static str,
    calibration: &'a Path,
    dome_center_world_m: [f64; 3],
    dome_center_disagreement_m: f64,
    floor_height_spread_m: f64,
    floor_height_mean_m: f64,
    max_normal_angle_deg: f64,
    up_prior: [f64; 3],
    sensors: Vec<SensorJson<'a>>,
}

/// Runs the subcommand.
pub fn run(args: Args) -> eyre::Result<()> {
    let files = expand_inputs(&args.inputs)?;
    let mask = args
        .mask
        .as_deref()
        .map(|m| read_mask_png(m).wrap_err("reading --mask"))
        .transpose()?;
    if let Some(d) = args.target_distance_m
        && !(d > 0.0 && d.is_finite())
    {
        bail!("--target-distance-m {d}: expected a positive distance in metres");
    }
    if args.entropy_window < 2 {
        bail!(
            "--entropy-window {}: needs at least 2 frames",
            args.entropy_window
        );
    }
    let mut params = MetricsParams::default();
    params.accuracy.target_distance_m = args.target_distance_m;
    params.entropy_window = args.entropy_window;
    params.frame_metric_stride = args.frame_stride.max(1);
    params.edge.jump_mm = args.jump_mm;
    if let Some(out) = &args.out {
        std::fs::create_dir_all(out)
            .wrap_err_with(|| format!("creating --out {}", out.display()))?;
    }
    match &args.calibration {
        Some(calibration) => multi_sensor(&args, calibration, &files, mask, params),
        None => sequence(&args, &files, mask, params),
    }
}

/// Writes every map of `sensor` into `dir` as a PNG titled with the sensor and the metric.
fn write_maps(
    sensor: &str,
    maps: &SequenceMaps,
    params: &MetricsParams,
    dir: Option<&Path>,
) -> eyre::Result<Vec<WrittenMap>> {
    let Some(dir) = dir else {
        return Ok(Vec::new());
    };
    std::fs::create_dir_all(dir).wrap_err_with(|| format!("creating {}", dir.display()))?;
    let mut written = Vec::new();
    for (image, legend) in render_all(maps, params) {
        let file = dir.join(format!("{}.png", legend.name));
        with_title(&image, &format!("{sensor}: {}", legend.title))
            .write_png(&file)
            .wrap_err("writing a map")?;
        written.push(WrittenMap { file, legend });
    }
    Ok(written)
}

/// Opens `--rrd` when given (the logging itself is `trigait-depth-rerun`, shared with the
/// `depth-metrics` node).
fn open_rrd(args: &Args) -> eyre::Result<Option<trigait_depth_rerun::RecordingStream>> {
    args.rrd
        .as_ref()
        .map(|path| {
            trigait_depth_rerun::open(
                "trigait-depth",
                &trigait_depth_rerun::Sink::File(path.clone()),
            )
            .map_err(|e| eyre::eyre!("--rrd: {e}"))
        })
        .transpose()
}

fn log_rrd(
    rec: Option<&trigait_depth_rerun::RecordingStream>,
    sensor: &str,
    report: &SequenceReport,
    maps: &SequenceMaps,
    params: &MetricsParams,
) -> eyre::Result<()> {
    if let Some(rec) = rec {
        trigait_depth_rerun::log_report(rec, sensor, report, maps, params, &mut Vec::new())
            .wrap_err("--rrd: logging to rerun")?;
    }
    Ok(())
}

fn sequence(
    args: &Args,
    files: &[PathBuf],
    mask: Option<trigait_depth::Mask>,
    params: MetricsParams,
) -> eyre::Result<()> {
    let mut analyzer = SequenceAnalyzer::new(params, mask);
    let bar = progress(files.len(), "reading depth frames")?;
    for file in files {
        // One file must have depth to be measured; in a sequence an all-zero frame is what
        // the sensor sent (starting up, or blinded), counted as the live node counts it.
        let frame = if files.len() == 1 {
            read_depth_png(file)
        } else {
            read_depth_png_as_recorded(file)
        }
        .wrap_err("reading a depth frame")?;
        analyzer.push(&frame);
        bar.inc(1);
    }
    bar.finish_and_clear();
    let without_depth = analyzer.frames() - analyzer.frames_with_depth();
    if analyzer.frames_with_depth() == 0 {
        bail!(
            "none of the {} frames has depth (every pixel 0): nothing to measure",
            files.len()
        );
    }
    let (report, maps) = analyzer
        .report_and_maps()
        .wrap_err("computing the metrics")?;
    let sensor = match files {
        [one] => one
            .file_stem()
            .map_or_else(|| "frame".to_owned(), |s| s.to_string_lossy().into_owned()),
        _ => format!("{} frames", files.len()),
    };
    let written = write_maps(&sensor, &maps, &params, args.out.as_deref())?;
    let rec = open_rrd(args)?;
    log_rrd(rec.as_ref(), "sequence", &report, &maps, &params)?;
    // Dropping the stream flushes the file footer.
    drop(rec);
    if args.json {
        let json = SequenceJson {
            tool: "trigait depth-metrics",
            mode: "sequence",
            inputs: files,
            mask: args.mask.as_deref(),
            frames_without_depth: without_depth,
            report: &report,
            maps: written,
        };
        crate::stdout::print_json(&json)
    } else {
        let mut out = String::new();
        let source = match files {
            [one] => one.display().to_string(),
            _ => format!("{} files", files.len()),
        };
        out += &format!(
            "trigait depth-metrics: {} frame(s) from {source}, valid pixels {:.1} %\n",
            report.frames,
            100.0 * report.valid_share
        );
        if without_depth > 0 {
            out += &format!(
                "                    frames with no depth at all (every pixel 0, as a sensor \
                 sends while it starts up): {without_depth}, counted as frames with no valid \
                 pixel\n"
            );
        }
        table(&mut out, &report);
        out += &maps_written(std::slice::from_ref(&written), args.out.as_deref());
        crate::stdout::print(&out)
    }
}

fn table(out: &mut String, r: &SequenceReport) {
    if let Some(a) = &r.accuracy {
        *out += &format!(
            "accuracy            target {} at {:.3} m, tilt {:.1} deg, {} px on target\n",
            a.target.replace('_', " "),
            a.target_distance_m,
            a.target_tilt_deg,
            a.pixels_on_target
        );
        if let Some(d) = &a.depth_mm {
            *out += &format!(
                "                    depth mean {:.1} mm, sd {:.1} mm, range {:.0}-{:.0} mm; eq. 3.1 accuracy {:+.2} mm\n",
                d.mean, d.sd, d.min, d.max, a.accuracy_mm
            );
        }
        let z = &a.zones_in_cone;
        *out += &format!(
            "                    zones in 70x60 deg cone ({} px): green {:.1} %, yellow {:.1} %, red {:.1} %\n",
            z.pixels,
            100.0 * z.green,
            100.0 * z.yellow,
            100.0 * z.red
        );
    }
    if let Some(all) = &r.resolution.overall {
        *out += &format!(
            "resolution          min step {} mm, mean {:.2} mm, sd {:.2} mm, max {} mm over {} pairs\n",
            all.min_nonzero_step_mm
                .map_or("-".to_owned(), |s| s.to_string()),
            all.mean_step_mm,
            all.sd_step_mm,
            all.max_step_mm,
            all.pairs
        );
        for b in r.resolution.by_distance.iter().filter(|b| b.pairs >= 100) {
            *out += &format!(
                "                    {:.1}-{:.1} m: min {} mean {:.2} sd {:.2} max {} mm\n",
                b.from_m,
                b.to_m,
                b.min_nonzero_step_mm
                    .map_or("-".to_owned(), |s| s.to_string()),
                b.mean_step_mm,
                b.sd_step_mm,
                b.max_step_mm
            );
        }
    }
    if let Some(bits) = r
        .entropy
        .as_ref()
        .and_then(|e| e.bits.as_ref().map(|b| (e, b)))
    {
        let (e, b) = bits;
        *out += &format!(
            "entropy             mean {:.2} bits, sd {:.2} bits over {} window(s) of {} frames\n",
            b.mean, b.sd, e.windows, e.window_frames
        );
    }
    let e = &r.edge_noise;
    *out += &format!(
        "edge noise          {} rim px{}, {:.1} % affected, band width {}, {} zero + {} flying px\n",
        e.rim_pixels,
        if e.used_mask { " (mask)" } else { "" },
        100.0 * e.affected_share,
        e.band_width_px.as_ref().map_or("-".to_owned(), |w| format!(
            "{:.2} px (sd {:.2}, max {:.1})",
            w.mean, w.sd, w.max
        )),
        e.band_zero_pixels,
        e.flying_pixels
    );
    if let Some(s) = &r.structural_noise {
        *out += &format!(
            "structural noise    plane at {:.3} m, tilt {:.1} deg, rms {:.2} mm; rings {:.2} mm every {:.1} px; centre-edge {:+.2} mm\n",
            s.plane_distance_m,
            s.plane_tilt_deg,
            s.rms_residual_mm,
            s.ring_amplitude_mm,
            s.ring_period_px,
            s.centre_minus_edge_mm
        );
    }
    for n in &r.notes {
        *out += &format!("note: {n}\n");
    }
}

fn multi_sensor(
    args: &Args,
    calibration: &Path,
    files: &[PathBuf],
    mask: Option<trigait_depth::Mask>,
    params: MetricsParams,
) -> eyre::Result<()> {
    let sensors = read_panoptic_calibration(calibration).wrap_err("reading --calibration")?;
    if files.len() != sensors.len() {
        bail!(
            "{} depth frames for {} sensors in {}: give one frame per sensor, file i for sensors[i]",
            files.len(),
            sensors.len(),
            calibration.display()
        );
    }
    let rec = open_rrd(args)?;
    let bar = progress(files.len(), "analysing sensors")?;
    let mut frames = Vec::with_capacity(files.len());
    let mut reports = Vec::with_capacity(files.len());
    let mut written = Vec::with_capacity(files.len());
    for (i, (file, sensor)) in files.iter().zip(&sensors).enumerate() {
        let frame =
            read_depth_png(file).wrap_err_with(|| format!("reading the frame of sensor {i}"))?;
        let sensor_params = MetricsParams {
            intrinsics: sensor.intrinsics,
            ..params
        };
        let mut analyzer = SequenceAnalyzer::new(sensor_params, mask.clone());
        analyzer.push(&frame);
        let (report, maps) = analyzer
            .report_and_maps()
            .wrap_err_with(|| format!("metrics of sensor {i}"))?;
        log_rrd(
            rec.as_ref(),
            &format!("sensor_{i:02}"),
            &report,
            &maps,
            &sensor_params,
        )?;
        let dir = args.out.as_ref().map(|o| o.join(format!("sensor_{i:02}")));
        written.push(write_maps(
            &format!("sensor {i}"),
            &maps,
            &sensor_params,
            dir.as_deref(),
        )?);
        reports.push(report);
        frames.push(frame);
        bar.inc(1);
    }
    bar.finish_and_clear();
    drop(rec);
    let check: FloorCheck = floor_check(&frames, &sensors, &FloorParams::default())
        .wrap_err("multi-sensor floor check")?;
    if args.json {
        let sensors_json = check
            .sensors
            .iter()
            .zip(files)
            .zip(&reports)
            .zip(written)
            .map(|(((f, file), report), maps)| SensorJson {
                sensor: f.sensor,
                file,
                valid_pixel_share: f.valid_pixel_share,
                floor_normal: f.normal,
                floor_offset_m: f.offset_m,
                floor_rms_m: f.rms_m,
                floor_height_at_dome_m: f.floor_height_at_dome_m,
                floor_tilt_from_y_deg: f.tilt_from_y_deg,
                floor_inliers: f.inliers,
                metrics: report,
                maps,
            })
            .collect();
        let json = MultiJson {
            tool: "trigait depth-metrics",
            mode: "multi_sensor",
            calibration,
            dome_center_world_m: check.dome_center_world_m,
            dome_center_disagreement_m: check.dome_center_disagreement_m,
            floor_height_spread_m: check.floor_height_spread_m,
            floor_height_mean_m: check.floor_height_mean_m,
            max_normal_angle_deg: check.max_normal_angle_deg,
            up_prior: check.up_prior,
            sensors: sensors_json,
        };
        return crate::stdout::print_json(&json);
    }
    let mut out = format!(
        "trigait depth-metrics: {} sensors, calibration {}\n",
        sensors.len(),
        calibration.display()
    );
    out += "sensor  valid %  floor normal (world, unit)  offset m  rms mm  floor@dome m  structural rms mm  rings mm/px  edge px  affected %\n";
    for (f, r) in check.sensors.iter().zip(&reports) {
        let s = r.structural_noise.as_ref();
        let e = &r.edge_noise;
        out += &format!(
            "{:>6}  {:>7.1}  {:<26}  {:>8.4}  {:>6.1}  {:>12.4}  {:>17}  {:>11}  {:>7}  {:>10.1}\n",
            f.sensor,
            100.0 * f.valid_pixel_share,
            format!(
                "({:+.4}, {:+.4}, {:+.4})",
                f.normal[0], f.normal[1], f.normal[2]
            ),
            f.offset_m,
            1000.0 * f.rms_m,
            f.floor_height_at_dome_m,
            s.map_or("-".to_owned(), |s| format!("{:.2}", s.rms_residual_mm)),
            s.map_or("-".to_owned(), |s| format!(
                "{:.2}/{:.1}",
                s.ring_amplitude_mm, s.ring_period_px
            )),
            e.band_width_px
                .as_ref()
                .map_or("-".to_owned(), |w| format!("{:.2}", w.mean)),
            100.0 * e.affected_share
        );
    }
    let [x, y, z] = check.dome_center_world_m;
    out += &format!(
        "floor height at the dome centre ({x:.3}, {y:.3}, {z:.3}) m: mean {:.4} m, spread {:.1} mm over {} sensors; floor normals within {:.2} deg\n",
        check.floor_height_mean_m,
        1000.0 * check.floor_height_spread_m,
        check.sensors.len(),
        check.max_normal_angle_deg
    );
    out += &maps_written(&written, args.out.as_deref());
    crate::stdout::print(&out)
}

/// One line for every map written: how many, where, and which metrics.
fn maps_written(written: &[Vec<WrittenMap>], dir: Option<&Path>) -> String {
    let (Some(dir), count) = (dir, written.iter().map(Vec::len).sum::<usize>()) else {
        return String::new();
    };
    let mut names: Vec<&str> = written.iter().flatten().map(|w| w.legend.name).collect();
    names.sort_unstable();
    names.dedup();
    let per = if written.len() > 1 {
        format!(" in {} sensor folders", written.len())
    } else {
        String::new()
    };
    format!(
        "maps: {count} PNG files written to {}{per} ({})\n",
        dir.display(),
        names.join(", ")
    )
}
