//! `trigait legs`: the lower-body tracker of the `leg-tracker` node on recorded depth frames,
//! for sensors without the Kinect SDK's body tracker.
//!
//! Inputs are 16-bit PNGs in millimetres (512×424, 0 = no data), files and/or directories (their
//! `.png` files in name order), tracked as one sequence of one sensor, so stature and segment
//! lengths are learned over the first frames as on the live stream. Per frame it reports the
//! outcome and people count, the person's share of the valid pixels (with `--mask`, its IoU
//! against that mask), and hips, knees, ankles and feet in camera space with a confidence and
//! an SDK-like state. The floor comes from the sensor's pose (`--rig` and `--sensor`) or is
//! fitted to the depth. `--out` writes per frame the person mask as an 8-bit PNG (255 =
//! person) and an overlay: the depth in grey, the person tinted, the fitted legs drawn.
//!
//! A frame with no depth at all (all zeros, as a sensor sends while it starts up) is tracked
//! like any other and reported `no_data`. A file of a sequence that is not a depth frame (a
//! truncated PNG, a colour image) is listed in its place as `unreadable`, with the reason; the
//! other frames are still tracked and reported, and the run then ends with an error naming
//! how many files could not be read. A sequence of more than one frame ends with the count of
//! frames in each state.

use std::path::{Path, PathBuf};

use eyre::{WrapErr as _, bail, eyre};
use serde::Serialize;
use trigait_depth::io::{read_depth_png_as_recorded, read_mask_png, write_gray8_png};
use trigait_depth::render::Image;
use trigait_depth::{DepthFrame, HEIGHT, WIDTH};
use trigait_leg_tracker::{Camera, LegTracker, Status, TrackedFrame, TrackerConfig};
use trigait_skeleton::{Joint, TrackingState};

use crate::depth_files::{expand_inputs, progress};

/// Arguments of `trigait legs`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Depth PNGs (16-bit, millimetres, 512x424) and/or directories of them, in frame order.
    #[arg(required = true, value_name = "PNG|DIR")]
    inputs: Vec<PathBuf>,
    /// The person mask of the (single) frame (512x424, non-zero = person): report the IoU of
    /// the segmentation against it.
    #[arg(long, value_name = "PNG")]
    mask: Option<PathBuf>,
    /// Rig file or name (`thesis`, `ring-N`): with --sensor, the floor from that sensor's pose
    /// (otherwise a plane is fitted to the depth).
    #[arg(long, value_name = "RIG", requires = "sensor")]
    rig: Option<String>,
    /// The sensor's id in --rig.
    #[arg(long, value_name = "ID", requires = "rig")]
    sensor: Option<String>,
    /// Whether the images are mirrored (the column grows to the sensor's left), as the Kinect
    /// SDK and libfreenect2 record them; simulated body depth is not.
    #[arg(long, default_value_t = true, action = clap::ArgAction::Set, value_name = "BOOL")]
    mirrored: bool,
    /// Write the person mask (8-bit PNG) and an overlay image per frame into this directory.
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Print the JSON report on stdout instead of the table.
    #[arg(long)]
    json: bool,
    /// Track every frame on its own, with a fresh tracker (the floor fitted or taken afresh,
    /// nothing learned carried over): for frames of different sensors or sessions, which a
    /// sequence would follow as one person seen by one sensor.
    #[arg(long)]
    separately: bool,
}

#[derive(Debug, Serialize)]
struct FrameJson<'a> {
    file: &'a Path,
    #[serde(flatten)]
    tracked: &'a TrackedFrame,
    /// IoU of the person against `--mask`.
    iou: Option<f64>,
    mask_png: Option<PathBuf>,
    overlay_png: Option<PathBuf>,
}

/// A file of a sequence that could not be read as a depth frame: listed in its place, and the
/// rest of the sequence is still tracked.
#[derive(Debug, Serialize)]
struct UnreadableJson<'a> {
    file: &'a Path,
    status: &'static str,
    error: String,
}

#[derive(Debug, Serialize)]
#[serde(untagged)]
enum EntryJson<'a> {
    Frame(FrameJson<'a>),
    Unreadable(UnreadableJson<'a>),
}

#[derive(Debug, Serialize)]
struct ReportJson<'a> {
    tool: &'static str,
    mask: Option<&'a Path>,
    rig: Option<&'a str>,
    sensor: Option<&'a str>,
    mirrored: bool,
    frames: Vec<EntryJson<'a>>,
}

/// One input file: tracked (with its IoU and the images written), or why it could not be read.
enum Outcome {
    Tracked {
        tracked: Box<TrackedFrame>,
        iou: Option<f64>,
        mask_png: Option<PathBuf>,
        overlay_png: Option<PathBuf>,
    },
    Unreadable(trigait_depth::Error),
}

/// Runs the subcommand.
pub fn run(args: &Args) -> eyre::Result<()> {
    let files = expand_inputs(&args.inputs)?;
    let mask = match &args.mask {
        Some(_) if files.len() != 1 => bail!(
            "--mask is the person mask of one frame, but {} frames were given",
            files.len()
        ),
        Some(m) => Some(read_mask_png(m).wrap_err("reading --mask")?),
        None => None,
    };
    let mut config = TrackerConfig {
        camera: Camera {
            mirrored: args.mirrored,
            ..Camera::default()
        },
        ..TrackerConfig::default()
    };
    if let (Some(rig), Some(id)) = (&args.rig, &args.sensor) {
        let rig = trigait_rig::Rig::from_spec(rig).wrap_err_with(|| format!("--rig {rig}"))?;
        let sensor = rig.sensors.iter().find(|s| &s.id == id).ok_or_else(|| {
            eyre!(
                "--sensor {id}: not in the rig {:?} (it has {})",
                rig.name,
                rig.sensors
                    .iter()
                    .map(|s| s.id.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        })?;
        config = TrackerConfig::for_pose(&sensor.world_from_kinect, args.mirrored);
        if config.floor.is_none() {
            bail!("--sensor {id}: its pose in the rig does not stand above the floor");
        }
    }
    if let Some(out) = &args.out {
        std::fs::create_dir_all(out)
            .wrap_err_with(|| format!("creating --out {}", out.display()))?;
    }
    let camera = config.camera;
    let mut tracker = LegTracker::new(config.clone()).wrap_err("the tracker's configuration")?;
    let mut results = Vec::with_capacity(files.len());
    let bar = progress(files.len(), "tracking")?;
    for file in &files {
        bar.inc(1);
        if args.separately {
            tracker = LegTracker::new(config.clone()).wrap_err("the tracker's configuration")?;
        }
        // One file alone must be a depth frame; in a sequence, a file that is not is listed
        // in its place and the others are still tracked (the run then ends with an error).
        let depth = match read_depth_png_as_recorded(file) {
            Ok(depth) => depth,
            Err(e) if files.len() == 1 => return Err(e).wrap_err("reading a depth frame"),
            Err(e) => {
                // The frame's slot in the sequence is kept: the tracker coasts through it as
                // through a frame without data, rather than joining its neighbours up.
                tracker.track(&DepthFrame::zeros());
                results.push((file, Outcome::Unreadable(e)));
                continue;
            }
        };
        let tracked = tracker.track(&depth);
        let iou = mask
            .as_ref()
            .map(|m| trigait_leg_tracker::mask_iou(&tracked.person_mask, m.as_slice()));
        let (mask_png, overlay_png) = match &args.out {
            Some(dir) => {
                let stem = file
                    .file_stem()
                    .map_or_else(|| "frame".into(), |s| s.to_string_lossy().into_owned());
                let mask_png = dir.join(format!("{stem}_person.png"));
                let gray: Vec<u8> = if tracked.person_mask.is_empty() {
                    vec![0; WIDTH * HEIGHT]
                } else {
                    tracked
                        .person_mask
                        .iter()
                        .map(|p| if *p { 255 } else { 0 })
                        .collect()
                };
                write_gray8_png(&mask_png, WIDTH, HEIGHT, &gray)
                    .wrap_err("writing the person mask")?;
                let overlay_png = dir.join(format!("{stem}_overlay.png"));
                overlay(depth.as_mm(), &tracked, &camera)
                    .write_png(&overlay_png)
                    .wrap_err("writing the overlay")?;
                (Some(mask_png), Some(overlay_png))
            }
            None => (None, None),
        };
        results.push((
            file,
            Outcome::Tracked {
                tracked: Box::new(tracked),
                iou,
                mask_png,
                overlay_png,
            },
        ));
    }
    bar.finish_and_clear();
    if args.json {
        let report = ReportJson {
            tool: "trigait legs",
            mask: args.mask.as_deref(),
            rig: args.rig.as_deref(),
            sensor: args.sensor.as_deref(),
            mirrored: args.mirrored,
            frames: results
                .iter()
                .map(|(file, outcome)| match outcome {
                    Outcome::Tracked {
                        tracked,
                        iou,
                        mask_png,
                        overlay_png,
                    } => EntryJson::Frame(FrameJson {
                        file,
                        tracked,
                        iou: *iou,
                        mask_png: mask_png.clone(),
                        overlay_png: overlay_png.clone(),
                    }),
                    Outcome::Unreadable(e) => EntryJson::Unreadable(UnreadableJson {
                        file,
                        status: "unreadable",
                        error: reason(file, e),
                    }),
                })
                .collect(),
        };
        crate::stdout::print_json(&report)?;
    } else {
        let mut text = String::new();
        for (file, outcome) in &results {
            match outcome {
                Outcome::Tracked {
                    tracked,
                    iou,
                    mask_png,
                    overlay_png,
                } => {
                    text += &table(file, tracked, *iou, args.sensor.as_deref());
                    if let (Some(m), Some(o)) = (mask_png, overlay_png) {
                        text += &format!("  wrote {} and {}\n", m.display(), o.display());
                    }
                }
                Outcome::Unreadable(e) => {
                    text += &format!("{}: unreadable: {}\n", file.display(), reason(file, e));
                }
            }
        }
        if results.len() > 1 {
            text += &summary(&results);
        }
        crate::stdout::print(&text)?;
    }
    let unreadable: Vec<&Path> = results
        .iter()
        .filter(|(_, o)| matches!(o, Outcome::Unreadable(_)))
        .map(|(f, _)| f.as_path())
        .collect();
    match unreadable.first() {
        None => Ok(()),
        Some(first) => bail!(
            "{} of {} files could not be read as depth frames (listed in the report), the first {}",
            unreadable.len(),
            results.len(),
            first.display()
        ),
    }
}

/// Why `file` could not be read, without the file's name where the reader's error starts with
/// it (the listing names the file already).
fn reason(file: &Path, e: &trigait_depth::Error) -> String {
    let message = e.to_string();
    message
        .strip_prefix(&format!("{}: ", file.display()))
        .map(str::to_owned)
        .unwrap_or(message)
}

/// The sequence in one line: how many frames came out in each state, by the names the JSON
/// report gives them, in the order of [`Status`], then the files that could not be read.
fn summary(results: &[(&PathBuf, Outcome)]) -> String {
    let mut counts: Vec<(String, usize)> = [
        Status::NoData,
        Status::NoFloor,
        Status::Nobody,
        Status::Tracking,
        Status::NoStature,
        Status::TooClose,
        Status::NotStanding,
    ]
    .map(|s| (status_name(s), 0))
    .into();
    counts.push(("unreadable".to_owned(), 0));
    for (_, outcome) in results {
        let name = match outcome {
            Outcome::Tracked { tracked, .. } => status_name(tracked.status),
            Outcome::Unreadable(_) => "unreadable".to_owned(),
        };
        match counts.iter_mut().find(|(n, _)| *n == name) {
            Some((_, c)) => *c += 1,
            None => counts.push((name, 1)),
        }
    }
    let parts: Vec<String> = counts
        .iter()
        .filter(|(_, n)| *n > 0)
        .map(|(name, n)| format!("{name} {n}"))
        .collect();
    format!("{} frames: {}\n", results.len(), parts.join(", "))
}

/// A status by the name the JSON report gives it.
fn status_name(status: Status) -> String {
    serde_json::to_value(status)
        .ok()
        .and_then(|v| v.as_str().map(str::to_owned))
        .unwrap_or_else(|| format!("{status:?}"))
}

fn state_name(state: TrackingState) -> &'static str {
    match state {
        TrackingState::Tracked => "tracked",
        TrackingState::Inferred => "inferred",
        TrackingState::NotTracked => "not tracked",
    }
}

/// Below this share of the lower image on a rig's floor, a frame without anyone is said to
/// match the floor poorly: a walkway seen from a sensor's pose has most of it there, and a
/// frame tracked on its own fitted floor had 8 % of it on the real frame 004378.
const POOR_RIG_FLOOR_SHARE: f64 = 0.05;

/// One frame as text: outcome, people, share and IoU, then one line per joint; `sensor`, the
/// rig sensor whose floor was used, if any.
fn table(file: &Path, t: &TrackedFrame, iou: Option<f64>, sensor: Option<&str>) -> String {
    let mut s = format!(
        "{}: {}, {} person(s) in view, person {} px = {:.1} % of {} valid px",
        file.display(),
        status_name(t.status),
        t.people,
        t.person_pixels,
        100.0 * t.person_share,
        t.valid_pixels
    );
    if let Some(iou) = iou {
        s += &format!(", IoU with the mask {iou:.3}");
    }
    if t.status == Status::NotStanding
        && let Some(share) = t.reaching_share
    {
        s += &format!(
            ", {:.0} % of the person's points at thigh height reach out from under the trunk (seated or crouching): no leg joints",
            100.0 * share
        );
    } else if t.status == Status::Tracking && t.joints.is_empty() {
        s += ", no two legs found under the hips in this frame";
    } else if t.status == Status::Nobody
        && let (Some(id), Some(share)) = (sensor, t.floor_share)
        && share < POOR_RIG_FLOOR_SHARE
    {
        s += &format!(
            ", only {:.0} % of the lower image lies on the floor of {id}'s pose: is the frame that sensor's? (without --rig the floor is fitted to the frame)",
            100.0 * share
        );
    }
    if t.body_relearned {
        s += ", the stature changed (someone else, someone who stood up, or a hand over the head): the body is learned afresh";
    }
    if t.floor_refitted {
        s += ", floor fitted afresh (the one in use no longer matched the depth: the sensor moved, or these frames are another sensor's)";
    }
    s.push('\n');
    for j in &t.joints {
        let p = j.position_in_kinect;
        s += &format!(
            "  {:<12} x {:+.3} y {:+.3} z {:.3} m  {:<8} confidence {:.2}\n",
            format!("{:?}", j.joint),
            p.x,
            p.y,
            p.z,
            state_name(j.state),
            j.confidence
        );
    }
    s
}

/// The depth in grey (near = light, 0.5–4.5 m), the person tinted orange, thighs and shanks
/// as lines and the joints as squares (green tracked, yellow inferred).
fn overlay(depth_mm: &[u16], t: &TrackedFrame, camera: &Camera) -> Image {
    let mut image = Image::new(WIDTH, HEIGHT, [0, 0, 0]);
    for (i, z) in depth_mm.iter().enumerate() {
        let (x, y) = (i % WIDTH, i / WIDTH);
        if *z == 0 {
            continue;
        }
        let g = (255.0 - 215.0 * ((f64::from(*z) - 500.0) / 4000.0).clamp(0.0, 1.0)) as u8;
        let c = if t.person_mask.get(i).copied().unwrap_or(false) {
            [g, (f64::from(g) * 0.6) as u8, 0]
        } else {
            [g, g, g]
        };
        image.set(x, y, c);
    }
    let pixel = |joint: Joint| {
        let j = t.joint(joint)?;
        camera.project(&j.position_in_kinect)
    };
    for chain in [
        [
            Joint::HipLeft,
            Joint::KneeLeft,
            Joint::AnkleLeft,
            Joint::FootLeft,
        ],
        [
            Joint::HipRight,
            Joint::KneeRight,
            Joint::AnkleRight,
            Joint::FootRight,
        ],
    ] {
        for pair in chain.windows(2) {
            if let (Some(a), Some(b)) = (pixel(pair[0]), pixel(pair[1])) {
                line(&mut image, a, b, [0, 160, 255]);
            }
        }
    }
    for j in &t.joints {
        if let Some((u, v)) = camera.project(&j.position_in_kinect)
            && u >= 2.0
            && v >= 2.0
        {
            let c = match j.state {
                TrackingState::Tracked => [0, 220, 0],
                _ => [240, 220, 0],
            };
            image.fill(u as usize - 2, v as usize - 2, 5, 5, c);
        }
    }
    image
}

/// A straight line from pixel `a` to `b` (clipped by [`Image::set`]).
fn line(image: &mut Image, a: (f64, f64), b: (f64, f64), c: [u8; 3]) {
    let steps = (b.0 - a.0)
        .abs()
        .max((b.1 - a.1).abs())
        .ceil()
        .clamp(1.0, 2000.0) as usize;
    for k in 0..=steps {
        let s = k as f64 / steps as f64;
        let (u, v) = (a.0 + s * (b.0 - a.0), a.1 + s * (b.1 - a.1));
        if u >= 0.0 && v >= 0.0 {
            image.set(u as usize, v as usize, c);
        }
    }
}
