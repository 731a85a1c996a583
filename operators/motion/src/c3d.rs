//! C3D files through c3dio 0.8.
//!
//! Two quirks of c3dio shape this module:
//! * it reads the residual byte of float-format files as signed, so almost every residual comes out
//!   negative and cannot mark gaps: a gap is a NaN coordinate or exactly (0, 0, 0), the value
//!   Vicon and c3dio write for an invalid point;
//! * it trusts the file: it allocates the point grid the header declares before looking at the
//!   data (a header claiming 32767 points × 32767 frames asks for 25 GB), and it indexes and
//!   unwraps freely inside. [`check_layout`] therefore walks the header and the parameter
//!   section first, with every size checked against the file's length, and refuses what c3dio
//!   could not read safely; a panic left over is still contained as [`Error::C3d`], so bad input
//!   never takes the caller down.

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};

use c3dio::{C3d, MarkerPoint, Parameter};
use nalgebra::{Matrix3, Point3, Vector3};
use trigait_skeleton::MotionClip;

use crate::trc::metres_per_unit;
use crate::{Error, MAX_MOTION_FILE_BYTES, MarkerSet, Result};

/// c3dio's parse error in words: its own text is the variant's debug form (e.g.
/// `FrameRateMismatch(0.0, 120.0)`), which does not say which value is whose.
fn c3dio_reason(e: &c3dio::C3dParseError) -> String {
    use c3dio::C3dParseError as E;
    match e {
        E::FrameRateMismatch(header, parameter) => format!(
            "the header's frame rate ({header} Hz) disagrees with POINT:RATE ({parameter} Hz)"
        ),
        E::ScaleFactorMismatch(header, parameter) => {
            format!("the header's point scale ({header}) disagrees with POINT:SCALE ({parameter})")
        }
        E::NumFramesMismatch(a, b) => format!("the frame counts disagree ({a} against {b})"),
        E::ParameterNotFound(group, name) => format!("parameter {group}:{name} is missing"),
        E::MissingParameter(name) | E::RequiredParameterNotFound(name) => {
            format!("required parameter {name} is missing")
        }
        E::GroupNotFound(group) | E::MissingGroup(group) => {
            format!("parameter group {group} is missing")
        }
        E::InsufficientBlocks(what) => format!("the file is shorter than it declares ({what})"),
        other => format!("{other:?}"),
    }
}

fn c3d_error(path: &Path, reason: impl Into<String>) -> Error {
    Error::C3d {
        path: path.to_path_buf(),
        reason: reason.into(),
    }
}

/// The proper rotation taking a file whose vertical is `up` (its `POINT:Y_SCREEN`, e.g. `+Y`)
/// to our Z-up world, keeping the file's X axis where it can; `None` for an unknown axis.
fn world_from_up_axis(up: [char; 2]) -> Option<Matrix3<f64>> {
    let m = |rows: [[f64; 3]; 3]| {
        Matrix3::new(
            rows[0][0], rows[0][1], rows[0][2], rows[1][0], rows[1][1], rows[1][2], rows[2][0],
            rows[2][1], rows[2][2],
        )
    };
    let sign = match up[0] {
        '+' | ' ' => 1.0,
        '-' => -1.0,
        _ => return None,
    };
    Some(match (up[1].to_ascii_uppercase(), sign > 0.0) {
        ('Z', true) => Matrix3::identity(),
        ('Z', false) => m([[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]]),
        // Y up (TRC, Motion Analysis): (x, y, z) ↦ (x, −z, y).
        ('Y', true) => m([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]]),
        ('Y', false) => m([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]]),
        ('X', true) => m([[0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]]),
        ('X', false) => m([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]]),
        _ => return None,
    })
}

/// Reads the 3-D points of a C3D file into a [`MarkerSet`] in metres, Z up.
///
/// `POINT:Y_SCREEN` names the file's vertical axis: a `+Z` file (CMU, Vicon, or none given) keeps
/// its axes, a `+Y` file is turned by (x, y, z) ↦ (x, −z, y) as TRC is. `POINT:UNITS` gives
/// the length unit. Frames are indexed from 0 whatever the file's `first_frame`. A point that is
/// NaN or exactly (0, 0, 0) is a gap.
///
/// # Errors
/// [`Error::Io`] if the file cannot be read, [`Error::C3d`] if it is not a C3D file, c3dio
/// rejects it or its `Y_SCREEN` is not an axis, [`Error::UnknownUnits`] for a `POINT:UNITS` other than mm, cm or m.
pub fn read_c3d(path: impl AsRef<Path>) -> Result<MarkerSet> {
    let path = path.as_ref();
    let mut bytes = trigait_input_limits::read_bounded(path, MAX_MOTION_FILE_BYTES, "motion file")
        .map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })?;
    check_layout(&mut bytes).map_err(|reason| c3d_error(path, reason))?;
    let c3d = catch_unwind(AssertUnwindSafe(|| {
        C3d::from_bytes(&bytes).map_err(|e| c3dio_reason(&e))
    }))
    .map_err(|panic| {
        let what = panic
            .downcast_ref::<&str>()
            .map(|s| (*s).to_owned())
            .or_else(|| panic.downcast_ref::<String>().cloned())
            .unwrap_or_default();
        c3d_error(path, format!("c3dio failed on malformed content ({what})"))
    })?
    .map_err(|reason| c3d_error(path, reason))?;
    let points = &c3d.points;
    let units: String = points.units.iter().collect::<String>().trim().to_string();
    let scale = metres_per_unit(&units).ok_or_else(|| Error::UnknownUnits {
        path: path.to_path_buf(),
        units: units.clone(),
    })?;
    let world_from_file = match points.y_screen {
        None => Matrix3::identity(),
        Some(axis) => world_from_up_axis(axis).ok_or_else(|| {
            c3d_error(
                path,
                format!(
                    "unsupported POINT:Y_SCREEN {:?} (expected ±X, ±Y or ±Z)",
                    axis.iter().collect::<String>()
                ),
            )
        })?,
    };
    let rate_hz = f64::from(points.frame_rate);
    let (rows, cols) = (points.rows(), points.cols());
    // More than 255 points: POINT:LABELS continues in LABELS2, LABELS3, … (C3D spec).
    let mut all_labels = points.labels.clone();
    for k in 2.. {
        if all_labels.len() >= cols {
            break;
        }
        let Some(more) = c3d.parameters.get("POINT", &format!("LABELS{k}")) else {
            break;
        };
        let more: Vec<String> = more.try_into().unwrap_or_default();
        if more.is_empty() {
            break;
        }
        all_labels.extend(more);
    }
    if all_labels.len() < cols {
        return Err(c3d_error(
            path,
            format!("{cols} points but only {} labels", all_labels.len()),
        ));
    }
    let labels: Vec<String> = all_labels[..cols]
        .iter()
        .map(|l| l.trim().to_string())
        .collect();
    let frames = (0..rows)
        .map(|f| {
            (0..cols)
                .map(|m| {
                    let p = points[f][m].point;
                    let gap = p.iter().any(|c| !c.is_finite()) || p == [0.0; 3];
                    (!gap).then(|| {
                        let file = Vector3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]));
                        Point3::from(world_from_file * file * scale)
                    })
                })
                .collect()
        })
        .collect();
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_string())
        .unwrap_or_default();
    MarkerSet::new(name, rate_hz, labels, frames)
}

/// One parameter record of a C3D parameter section, as c3dio will see it.
struct RawParameter<'a> {
    group_id: i8,
    name: String,
    /// Bytes per element: 1 (char, byte), 2 (integer) or 4 (float).
    element_bytes: usize,
    is_float: bool,
    /// Offset of the data in the parameter section (so it can be patched) and its bytes.
    data_at: usize,
    data: &'a [u8],
}

/// The groups (id, name) and parameters of a parameter section.
type Walked<'a> = (Vec<(i8, String)>, Vec<RawParameter<'a>>);

/// Reads a 16-bit word the way the file's processor stores it (DEC and Intel little-endian,
/// SGI/MIPS big-endian).
fn word(bytes: &[u8], at: usize, big_endian: bool) -> Option<u16> {
    let b: [u8; 2] = bytes.get(at..at + 2)?.try_into().ok()?;
    Some(if big_endian {
        u16::from_be_bytes(b)
    } else {
        u16::from_le_bytes(b)
    })
}

/// Groups (id → name) and parameters of the parameter section `section`, walked with the same
/// index arithmetic as c3dio, every record checked to lie inside the section.
fn walk_parameters(section: &[u8], big_endian: bool) -> Result<Walked<'_>, String> {
    let mut groups = Vec::new();
    let mut parameters = Vec::new();
    let cut = |what: &str, at: usize| {
        format!(
            "parameter section cut inside a record ({what} at byte {at} of {})",
            section.len()
        )
    };
    let mut index = 4;
    while index + 1 < section.len() {
        let id = section[index + 1] as i8;
        if id == 0 {
            break;
        }
        let name_len = section[index] as i8;
        if name_len == i8::MIN || id == i8::MIN {
            return Err(format!(
                "parameter record at byte {index} has an invalid name length or group id"
            ));
        }
        let name_at = index + 2;
        let name_end = name_at + usize::from(name_len.unsigned_abs());
        let name = section
            .get(name_at..name_end)
            .ok_or_else(|| cut("name", name_at))?;
        let name: String = name.iter().map(|&b| b as char).collect();
        let next =
            usize::from(word(section, name_end, big_endian).ok_or_else(|| cut("link", name_end))?)
                + name_end;
        let mut at = name_end + 2;
        if id < 0 {
            groups.push((-id, name));
        } else {
            let kind = *section.get(at).ok_or_else(|| cut("type", at))? as i8;
            let element_bytes = match kind {
                -1 | 1 => 1,
                2 => 2,
                4 => 4,
                other => return Err(format!("parameter {name} has data type {other}")),
            };
            let dims = *section
                .get(at + 1)
                .ok_or_else(|| cut("dimensions", at + 1))?;
            at += 2;
            let dims_bytes = section
                .get(at..at + usize::from(dims))
                .ok_or_else(|| cut("dimensions", at))?;
            at += usize::from(dims);
            let elements: usize = dims_bytes
                .iter()
                .filter(|&&d| d != 0 && (kind == -1 || d != 1))
                .map(|&d| usize::from(d))
                .product();
            let size = elements * element_bytes;
            let data = section.get(at..at + size).ok_or_else(|| cut("data", at))?;
            parameters.push(RawParameter {
                group_id: id,
                name: name.to_ascii_uppercase(),
                element_bytes,
                is_float: kind == 4,
                data_at: at,
                data,
            });
            at += size;
        }
        let description = usize::from(*section.get(at).ok_or_else(|| cut("description", at))?);
        section
            .get(at + 1..at + 1 + description)
            .ok_or_else(|| cut("description", at + 1))?;
        index = next;
    }
    Ok((groups, parameters))
}

/// The first element of a numeric parameter as c3dio reads it (integers as `i16`, floats
/// truncated), or `None` for a char/byte parameter.
fn first_number(p: &RawParameter<'_>, big_endian: bool) -> Option<f64> {
    match (p.element_bytes, p.is_float) {
        (2, _) => word(p.data, 0, big_endian).map(|w| f64::from(w as i16)),
        (4, true) => {
            let b: [u8; 4] = p.data.get(..4)?.try_into().ok()?;
            Some(f64::from(if big_endian {
                f32::from_be_bytes(b)
            } else {
                f32::from_le_bytes(b)
            }))
        }
        _ => None,
    }
}

/// Most points per frame c3dio can read: it counts a frame's point bytes in 16 bits.
const MAX_POINTS: usize = 4095;

/// Most events c3dio can read: it takes each event's time from the 512-byte header.
const MAX_EVENTS: usize = 52;

/// Checks, before c3dio sees them, that the header and parameter section of `bytes` describe
/// a file c3dio can read within the bytes it has: signature, processor, block pointers, every
/// parameter record inside its section, the points and frames the header declares inside the
/// data section, and point and analog counts consistent with the header. An `EVENT:USED` that c3dio
/// would index past its header is set to 0 in `bytes` (events are not read here).
///
/// # Errors
/// What does not hold, for [`Error::C3d`].
fn check_layout(bytes: &mut [u8]) -> Result<(), String> {
    // Header word 1: parameter block number (≥ 2) and the key byte 0x50.
    if bytes.len() < 1024 || bytes[1] != 0x50 || bytes[0] < 2 {
        return Err("missing the C3D signature (0x50 in byte 2)".to_owned());
    }
    let parameter_block = usize::from(bytes[0]);
    let blocks = bytes.len() / 512;
    if parameter_block > blocks {
        return Err(format!(
            "the parameter section starts in block {parameter_block}, the file has {blocks}"
        ));
    }
    let big_endian = match bytes[(parameter_block - 1) * 512 + 3] {
        0x54 | 0x55 => false,
        0x56 => true,
        other => return Err(format!("unknown processor type 0x{other:02x}")),
    };
    let header = |w: usize| word(bytes, 2 * (w - 1), big_endian).unwrap_or(0);
    let (points, analog_per_frame) = (usize::from(header(2)), usize::from(header(3)));
    let (first_frame, last_frame) = (usize::from(header(4)), usize::from(header(5)));
    let data_block = usize::from(header(9));
    let analog_per_channel = usize::from(header(10));
    let scale_bytes: [u8; 4] = bytes[12..16].try_into().map_err(|_| "short header")?;
    let scale = if big_endian {
        f32::from_be_bytes(scale_bytes)
    } else {
        // DEC floats keep the sign bit where Intel has it.
        f32::from_le_bytes(scale_bytes)
    };
    if data_block <= parameter_block || data_block > blocks {
        return Err(format!(
            "the data section starts in block {data_block}: not after the parameters (block \
             {parameter_block}) and inside the file's {blocks} blocks"
        ));
    }
    // c3dio reads the parameter section from block 2 up to the data, whatever word 1 says.
    let (groups, parameters) = walk_parameters(&bytes[512..(data_block - 1) * 512], big_endian)?;
    let group_name = |id: i8| {
        groups
            .iter()
            .find(|(g, _)| *g == id)
            .map(|(_, n)| n.as_str())
    };
    let named = |group: &str, name: &str| -> Vec<&RawParameter<'_>> {
        parameters
            .iter()
            .filter(|p| {
                p.name == name
                    && group_name(p.group_id).is_some_and(|g| g.eq_ignore_ascii_case(group))
            })
            .collect()
    };
    if points == 0 {
        return Err("the header declares no 3-D points".to_owned());
    }
    if points > MAX_POINTS {
        return Err(format!(
            "the header declares {points} points per frame; c3dio reads at most {MAX_POINTS}"
        ));
    }
    if last_frame < first_frame {
        return Err(format!(
            "the header's last frame {last_frame} is before its first frame {first_frame}"
        ));
    }
    let frames = last_frame - first_frame + 1;
    let float = scale <= 0.0;
    let bytes_per_frame =
        points * if float { 16 } else { 8 } + analog_per_frame * if float { 4 } else { 2 };
    let data_bytes = bytes.len() - (data_block - 1) * 512;
    let needed = frames * bytes_per_frame;
    if needed > data_bytes {
        return Err(format!(
            "the header declares {frames} frames of {points} points and {analog_per_frame} analog \
             samples ({needed} bytes), the data section holds {data_bytes} bytes"
        ));
    }
    for used in named("POINT", "USED") {
        let declared = first_number(used, big_endian).unwrap_or(0.0);
        if declared != points as f64 {
            return Err(format!(
                "POINT:USED says {declared} points, the header {points}: which is right is \
                 unknown"
            ));
        }
    }
    for used in named("ANALOG", "USED") {
        let channels = first_number(used, big_endian).unwrap_or(0.0);
        // c3dio reads ANALOG:USED as an unsigned 16-bit count.
        let channels = if channels < 0.0 {
            channels + 65536.0
        } else {
            channels
        };
        if channels > 0.0 && channels * analog_per_channel as f64 != analog_per_frame as f64 {
            return Err(format!(
                "ANALOG:USED {channels} channels × {analog_per_channel} samples per frame do not \
                 make the header's {analog_per_frame} analog samples per frame"
            ));
        }
    }
    let event_fixes: Vec<usize> = named("EVENT", "USED")
        .into_iter()
        .filter(|p| p.element_bytes == 2)
        .filter(|p| {
            first_number(p, big_endian).is_some_and(|n| !(0.0..=MAX_EVENTS as f64).contains(&n))
        })
        .map(|p| 512 + p.data_at)
        .collect();
    for at in event_fixes {
        bytes[at] = 0;
        bytes[at + 1] = 0;
    }
    Ok(())
}

/// c3dio's write error in words: the operating system's reason where there is one (its own
/// `Display` prints the `Debug` form, `WriteError("a.c3d", Os { code: 13, … })`).
fn c3dio_write_reason(e: &c3dio::C3dWriteError) -> String {
    use c3dio::C3dWriteError as E;
    match e {
        E::WriteError(_, io)
        | E::WriteHeaderError(io)
        | E::WriteParametersError(io)
        | E::WriteDataError(io) => io.to_string(),
        E::InvalidFilePath(p) => format!("{} is not a file path c3dio can write", p.display()),
        other => format!("{other:?}"),
    }
}

/// Writes `clip` as a float-format C3D file with c3dio: one point per joint (labelled by its
/// snake_case name), millimetres, Z up as our world (`X_SCREEN` +X, `Y_SCREEN` +Z),
/// `POINT:RATE`, `POINT:SCALE` and `POINT:DATA_START` set for readers that need them. A gap is written as (0, 0, 0)
/// flagged invalid (fourth word −1.0), as the C3D spec asks.
///
/// # Errors
/// [`Error::C3dWrite`] if c3dio refuses (e.g. the extension is not `.c3d`) or fails to write,
/// [`Error::Io`] if the file cannot be re-read to flag its gaps.
pub fn write_c3d(path: impl AsRef<Path>, clip: &MotionClip) -> Result<()> {
    let path = path.as_ref();
    let write_error = |reason: String| Error::C3dWrite {
        path: path.to_path_buf(),
        reason,
    };
    // c3dio unwraps the extension; check it here so a bare name is an error, not a panic.
    if !path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("c3d"))
    {
        return Err(write_error("the file name must end in .c3d".to_string()));
    }
    let frames = clip.frame_count();
    if clip.joints().is_empty() {
        return Err(write_error("the clip has no joints".to_string()));
    }
    if frames > usize::from(u16::MAX) {
        return Err(write_error(format!(
            "{frames} frames do not fit the 16-bit frame numbers of a C3D header"
        )));
    }
    let mut c3d = C3d::new();
    // The groups c3dio's writer indexes (it panics on a missing one).
    for group in [
        "POINT",
        "ANALOG",
        "FORCE_PLATFORM",
        "EVENT",
        "EVENT_CONTEXT",
    ] {
        // c3dio writes a group's description without the length byte the C3D spec puts before
        // it; a one-byte description "\0" *is* that byte (length 0), which keeps the parameter
        // section readable by other C3D readers (checked with the Python `c3d` package).
        c3d.parameters.insert_group(group, "\0".to_string());
    }
    let rate = clip.rate_hz() as f32;
    let residual_scale = 0.1_f32;
    c3d.parameters
        .insert("POINT", "RATE", Parameter::float(rate));
    c3d.parameters
        .insert("POINT", "SCALE", Parameter::float(-residual_scale));
    let rows: Vec<Vec<MarkerPoint>> = (0..frames)
        .map(|f| {
            clip.joints()
                .iter()
                .map(|j| match clip.position(f, *j) {
                    Some(p) => {
                        let mm = p.coords * 1e3;
                        MarkerPoint::new(mm.x as f32, mm.y as f32, mm.z as f32)
                    }
                    None => {
                        let mut gap = MarkerPoint::new(0.0, 0.0, 0.0);
                        gap.residual = -residual_scale;
                        gap
                    }
                })
                .collect()
        })
        .collect();
    let points = &mut c3d.points;
    points.clear();
    for row in rows {
        points.push_row(row);
    }
    points.labels = clip.joints().iter().map(|j| j.name().to_string()).collect();
    points.descriptions = clip
        .joints()
        .iter()
        .map(|j| format!("{j} joint centre"))
        .collect();
    points.units = ['m', 'm', ' ', ' '];
    points.x_screen = Some(['+', 'X']);
    points.y_screen = Some(['+', 'Z']);
    points.frame_rate = rate;
    points.scale_factor = residual_scale;
    points.format = c3dio::DataFormat::Float;
    points.first_frame = 1;
    points.last_frame = frames as u16;
    // POINT:DATA_START must name the block the data starts in, which c3dio only decides while
    // writing: write, read the header's pointer back, store it and write again until they agree
    // (the parameter can push the section over a block boundary at most once).
    let mut data_start = None;
    for _ in 0..3 {
        if let Some(block) = data_start {
            c3d.parameters
                .insert("POINT", "DATA_START", Parameter::integer(block));
        }
        let target = PathBuf::from(path);
        catch_unwind(AssertUnwindSafe(|| c3d.write_path(target).map(|_| ())))
            .map_err(|_| write_error("c3dio panicked while writing".to_string()))?
            .map_err(|e| write_error(c3dio_write_reason(&e)))?;
        let written = header_data_block(path)?;
        if data_start == Some(written) {
            return mark_gaps_invalid(path, clip);
        }
        data_start = Some(written);
    }
    Err(write_error(
        "the data start block does not settle; c3dio's layout changed".to_string(),
    ))
}

/// Header word 9 of a C3D file c3dio wrote: the 1-based block where the data starts.
fn header_data_block(path: &Path) -> Result<i16> {
    let mut header = [0u8; 18];
    std::fs::File::open(path)
        .and_then(|mut f| std::io::Read::read_exact(&mut f, &mut header))
        .map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })?;
    Ok(i16::from_le_bytes([header[16], header[17]]))
}

/// Rewrites the fourth word of every gap to −1.0, the C3D float-format flag for an invalid point.
///
/// c3dio packs that word from a camera mask of 7 flags and a residual byte, so it cannot write a
/// negative value, and other readers would take (0, 0, 0) with residual 25.5 for a real
/// sample. The data section of c3dio's file is plain: Intel byte order, no analog, 16 bytes per
/// point, starting at the block named in header word 9.
fn mark_gaps_invalid(path: &Path, clip: &MotionClip) -> Result<()> {
    let joints = clip.joints();
    let gaps: Vec<usize> = (0..clip.frame_count())
        .flat_map(|f| (0..joints.len()).map(move |c| (f, c)))
        .filter(|(f, c)| clip.position(*f, joints[*c]).is_none())
        .map(|(f, c)| f * joints.len() + c)
        .collect();
    if gaps.is_empty() {
        return Ok(());
    }
    let io_error = |source| Error::Io {
        path: path.to_path_buf(),
        source,
    };
    let mut bytes = std::fs::read(path).map_err(io_error)?;
    let layout_error = || Error::C3dWrite {
        path: path.to_path_buf(),
        reason: "c3dio wrote an unexpected layout; cannot flag gaps as invalid".to_string(),
    };
    let parameter_block = usize::from(*bytes.first().ok_or_else(layout_error)?);
    let processor = parameter_block
        .checked_sub(1)
        .and_then(|b| bytes.get(b * 512 + 3))
        .ok_or_else(layout_error)?;
    let data_block = usize::from(u16::from_le_bytes([
        *bytes.get(16).ok_or_else(layout_error)?,
        *bytes.get(17).ok_or_else(layout_error)?,
    ]));
    if *processor != 0x54 || data_block < 2 {
        return Err(layout_error());
    }
    let data_start = (data_block - 1) * 512;
    for point in gaps {
        let at = data_start + point * 16 + 12;
        bytes
            .get_mut(at..at + 4)
            .ok_or_else(layout_error)?
            .copy_from_slice(&(-1.0_f32).to_le_bytes());
    }
    std::fs::write(path, bytes).map_err(io_error)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each supported vertical axis is turned onto +Z by a proper rotation.
    #[test]
    fn up_axes_map_to_z() {
        for (axis, up) in [
            ('Z', Vector3::z()),
            ('Y', Vector3::y()),
            ('X', Vector3::x()),
        ] {
            for (sign, s) in [('+', 1.0), ('-', -1.0)] {
                let r = world_from_up_axis([sign, axis]).unwrap();
                assert!((r * (up * s) - Vector3::z()).norm() < 1e-12, "{sign}{axis}");
                assert!((r.determinant() - 1.0).abs() < 1e-12);
                assert!((r * r.transpose() - Matrix3::identity()).norm() < 1e-12);
            }
        }
        // Y up is the TRC convention: (x, y, z) ↦ (x, −z, y).
        let r = world_from_up_axis(['+', 'Y']).unwrap();
        assert_eq!(
            r * Vector3::new(1.0, 2.0, 3.0),
            Vector3::new(1.0, -3.0, 2.0)
        );
        assert!(world_from_up_axis(['+', 'Q']).is_none());
        assert!(world_from_up_axis(['*', 'Z']).is_none());
    }
}
