//! Reading depth frames and masks from PNG files and directories, writing PNGs.
//!
//! Plain functions so the metric code stays free of I/O: the CLI calls these, a dataflow node
//! builds [`DepthFrame`]s from its messages instead.

use std::fs::File;
use std::io::{BufReader, BufWriter};
use std::path::{Path, PathBuf};

use crate::frame::{DepthFrame, HEIGHT, Mask, PIXELS, WIDTH};
use crate::{Error, Result};

fn open_png(
    path: &Path,
    transformations: png::Transformations,
) -> Result<png::Reader<BufReader<File>>> {
    let file = File::open(path).map_err(|source| Error::Io {
        path: path.to_owned(),
        source,
    })?;
    // A 512×424 frame decodes to at most 1.7 MB (RGBA, 16 bits); 8 MiB also covers the
    // decoder's text chunks, so a PNG that declares more fails before it allocates.
    let mut decoder =
        png::Decoder::new_with_limits(BufReader::new(file), png::Limits { bytes: 8 << 20 });
    decoder.set_transformations(transformations);
    decoder.read_info().map_err(|source| Error::PngDecode {
        path: path.to_owned(),
        source,
    })
}

fn check_size(path: &Path, info: &png::Info<'_>) -> Result<()> {
    if info.width as usize != WIDTH || info.height as usize != HEIGHT {
        return Err(Error::WrongSize {
            what: path.display().to_string(),
            width: info.width as usize,
            height: info.height as usize,
        });
    }
    Ok(())
}

fn read_pixels(path: &Path, reader: &mut png::Reader<BufReader<File>>) -> Result<Vec<u8>> {
    let size = reader
        .output_buffer_size()
        .ok_or_else(|| Error::WrongSize {
            what: path.display().to_string(),
            width: reader.info().width as usize,
            height: reader.info().height as usize,
        })?;
    let mut buf = vec![0; size];
    let out = reader
        .next_frame(&mut buf)
        .map_err(|source| Error::PngDecode {
            path: path.to_owned(),
            source,
        })?;
    buf.truncate(out.buffer_size());
    Ok(buf)
}

/// Reads a 512×424 16-bit grayscale PNG of depths in millimetres.
///
/// # Errors
/// The file is missing or unreadable, not a PNG, not 16-bit grayscale (an 8-bit preview),
/// not 512×424, or has no non-zero pixel. Each error names the file.
pub fn read_depth_png(path: &Path) -> Result<DepthFrame> {
    let frame = read_depth_png_as_recorded(path)?;
    frame.ensure_valid(&path.display().to_string())?;
    Ok(frame)
}

/// Reads a depth PNG as [`read_depth_png`] does, but keeps a frame with no non-zero pixel:
/// in a recorded sequence an all-zero frame is a frame the sensor sent with nothing in it
/// (while it starts up, or blinded), which a tracker reports as such rather than a broken file.
///
/// # Errors
/// As [`read_depth_png`], except for the all-zero frame.
pub fn read_depth_png_as_recorded(path: &Path) -> Result<DepthFrame> {
    let mut reader = open_png(path, png::Transformations::IDENTITY)?;
    let info = reader.info();
    check_size(path, info)?;
    if info.bit_depth != png::BitDepth::Sixteen || info.color_type != png::ColorType::Grayscale {
        return Err(Error::NotDepthPng {
            path: path.to_owned(),
            bit_depth: info.bit_depth as u8,
            color: format!("{:?}", info.color_type),
        });
    }
    let bytes = read_pixels(path, &mut reader)?;
    if bytes.len() != 2 * PIXELS {
        return Err(Error::WrongLength {
            got: bytes.len() / 2,
            expected: PIXELS,
        });
    }
    let depth: Vec<u16> = bytes
        .chunks_exact(2)
        .map(|b| u16::from_be_bytes([b[0], b[1]]))
        .collect();
    DepthFrame::from_mm(depth)
}

/// Most distinct non-zero values a 16-bit mask PNG may hold: a binary mask holds one, a
/// body-index or label image one per person or part. A depth image, the likeliest wrong file
/// and 16-bit as a Kinect's are, holds thousands. An 8-bit mask may hold any (a resized or soft
/// mask's edge).
pub const MAX_MASK_LABELS: usize = 64;

/// Reads a 512×424 mask PNG (any bit depth or colour type): a pixel is inside when any of its
/// colour channels is non-zero (alpha is ignored).
///
/// # Errors
/// The file is missing or unreadable, not a PNG, not 512×424, holds more than
/// [`MAX_MASK_LABELS`] distinct non-zero values in 16 bits (a depth image given as a mask), or
/// the mask is empty.
pub fn read_mask_png(path: &Path) -> Result<Mask> {
    let mut reader = open_png(path, png::Transformations::EXPAND)?;
    check_size(path, reader.info())?;
    let (color, depth) = reader.output_color_type();
    let bytes = read_pixels(path, &mut reader)?;
    let bytes_per_sample = if depth == png::BitDepth::Sixteen {
        2
    } else {
        1
    };
    let channels = color.samples();
    let colour_channels = match color {
        png::ColorType::GrayscaleAlpha | png::ColorType::Rgba => channels - 1,
        _ => channels,
    };
    let stride = channels * bytes_per_sample;
    if bytes.len() != stride * PIXELS {
        return Err(Error::WrongLength {
            got: bytes.len() / stride.max(1),
            expected: PIXELS,
        });
    }
    let colour_bytes = colour_channels * bytes_per_sample;
    let mut labels = std::collections::HashSet::new();
    for px in bytes.chunks_exact(stride) {
        let c = &px[..colour_bytes];
        if c.iter().any(|&b| b != 0) && labels.len() <= MAX_MASK_LABELS {
            labels.insert(c);
        }
    }
    if bytes_per_sample == 2 && labels.len() > MAX_MASK_LABELS {
        return Err(Error::NotAMask {
            what: path.display().to_string(),
            limit: MAX_MASK_LABELS,
        });
    }
    let inside: Vec<bool> = bytes
        .chunks_exact(stride)
        .map(|px| px[..colour_bytes].iter().any(|&b| b != 0))
        .collect();
    let mask = Mask::from_bools(inside)?;
    if mask.count() == 0 {
        return Err(Error::EmptyMask {
            what: path.display().to_string(),
        });
    }
    Ok(mask)
}

/// The `.png` files directly inside `dir`, sorted by file name (frame order).
///
/// # Errors
/// The directory cannot be listed or holds no PNG.
pub fn list_pngs(dir: &Path) -> Result<Vec<PathBuf>> {
    let io_err = |source| Error::Io {
        path: dir.to_owned(),
        source,
    };
    let mut files = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(io_err)? {
        let path = entry.map_err(io_err)?.path();
        let is_png = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("png"));
        if is_png && path.is_file() {
            files.push(path);
        }
    }
    if files.is_empty() {
        return Err(Error::EmptyDirectory {
            path: dir.to_owned(),
        });
    }
    files.sort();
    Ok(files)
}

fn write_png(
    path: &Path,
    width: usize,
    height: usize,
    color: png::ColorType,
    depth: png::BitDepth,
    data: &[u8],
) -> Result<()> {
    let enc_err = |source| Error::PngEncode {
        path: path.to_owned(),
        source,
    };
    let file = File::create(path).map_err(|source| Error::Io {
        path: path.to_owned(),
        source,
    })?;
    let w = u32::try_from(width).map_err(|_| Error::WrongSize {
        what: path.display().to_string(),
        width,
        height,
    })?;
    let h = u32::try_from(height).map_err(|_| Error::WrongSize {
        what: path.display().to_string(),
        width,
        height,
    })?;
    let mut encoder = png::Encoder::new(BufWriter::new(file), w, h);
    encoder.set_color(color);
    encoder.set_depth(depth);
    let mut writer = encoder.write_header().map_err(enc_err)?;
    writer.write_image_data(data).map_err(enc_err)?;
    writer.finish().map_err(enc_err)
}

/// Writes a depth frame as a 16-bit grayscale PNG (the format [`read_depth_png`] reads).
///
/// # Errors
/// The file cannot be created or written.
pub fn write_depth_png(path: &Path, frame: &DepthFrame) -> Result<()> {
    let bytes: Vec<u8> = frame.as_mm().iter().flat_map(|z| z.to_be_bytes()).collect();
    write_png(
        path,
        WIDTH,
        HEIGHT,
        png::ColorType::Grayscale,
        png::BitDepth::Sixteen,
        &bytes,
    )
}

/// Writes an 8-bit RGB image (`rgb.len() == 3·width·height`).
///
/// # Errors
/// The file cannot be created or written, or the buffer does not match the size.
pub fn write_rgb_png(path: &Path, width: usize, height: usize, rgb: &[u8]) -> Result<()> {
    if rgb.len() != 3 * width * height {
        return Err(Error::WrongLength {
            got: rgb.len() / 3,
            expected: width * height,
        });
    }
    write_png(
        path,
        width,
        height,
        png::ColorType::Rgb,
        png::BitDepth::Eight,
        rgb,
    )
}

/// Writes an 8-bit grayscale image (`gray.len() == width·height`), e.g. a mask.
///
/// # Errors
/// The file cannot be created or written, or the buffer does not match the size.
pub fn write_gray8_png(path: &Path, width: usize, height: usize, gray: &[u8]) -> Result<()> {
    if gray.len() != width * height {
        return Err(Error::WrongLength {
            got: gray.len(),
            expected: width * height,
        });
    }
    write_png(
        path,
        width,
        height,
        png::ColorType::Grayscale,
        png::BitDepth::Eight,
        gray,
    )
}
