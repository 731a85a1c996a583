//! Bad input is a clear error naming the file, never a panic.

// Test helpers outside `#[test]` functions panic on failure by design.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::PathBuf;

use trigait_depth::io::{
    list_pngs, read_depth_png, read_depth_png_as_recorded, read_mask_png, write_depth_png,
    write_gray8_png,
};
use trigait_depth::{DepthFrame, Error, HEIGHT, PIXELS, WIDTH};

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("trigait-depth-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// An 8-bit PNG of the right size is rejected as not being a depth frame.
#[test]
fn eight_bit_png_is_rejected() {
    let dir = scratch("8bit");
    let path = dir.join("preview.png");
    write_gray8_png(&path, WIDTH, HEIGHT, &vec![7; PIXELS]).unwrap();
    let err = read_depth_png(&path).unwrap_err();
    assert!(
        matches!(err, Error::NotDepthPng { bit_depth: 8, .. }),
        "{err:?}"
    );
    let msg = err.to_string();
    assert!(
        msg.contains("preview.png") && msg.contains("16-bit"),
        "{msg}"
    );
    // The same 8-bit file is a valid mask.
    assert_eq!(read_mask_png(&path).unwrap().count(), PIXELS);
}

/// A depth frame given where a mask is expected is refused, by name, rather than read as a
/// mask of every valid pixel; a label image of a few people or parts, or an 8-bit soft mask, is
/// still a mask.
#[test]
fn a_depth_image_is_not_a_mask() {
    let dir = scratch("depth-as-mask");
    let depth = dir.join("000001_depth.png");
    let ramp: Vec<u16> = (0..PIXELS).map(|i| 500 + (i % 4000) as u16).collect();
    write_depth_png(&depth, &DepthFrame::from_mm(ramp).unwrap()).unwrap();
    let err = read_mask_png(&depth).unwrap_err();
    assert!(matches!(err, Error::NotAMask { .. }), "{err:?}");
    let msg = err.to_string();
    assert!(
        msg.contains("000001_depth.png") && msg.contains("depth image"),
        "{msg}"
    );
    let labels = dir.join("labels.png");
    let six: Vec<u8> = (0..PIXELS).map(|i| (i % 7) as u8).collect();
    write_gray8_png(&labels, WIDTH, HEIGHT, &six).unwrap();
    assert_eq!(
        read_mask_png(&labels).unwrap().count(),
        PIXELS - PIXELS.div_ceil(7)
    );
    // An 8-bit soft mask (a resized one's edge) holds many values and is still a mask.
    let soft = dir.join("soft.png");
    let ramp: Vec<u8> = (0..PIXELS).map(|i| (i % 256) as u8).collect();
    write_gray8_png(&soft, WIDTH, HEIGHT, &ramp).unwrap();
    assert_eq!(
        read_mask_png(&soft).unwrap().count(),
        PIXELS - PIXELS.div_ceil(256)
    );
}

/// A PNG of the wrong size names both sizes.
#[test]
fn wrong_size_is_rejected() {
    let dir = scratch("size");
    let path = dir.join("small.png");
    write_gray8_png(&path, 64, 48, &vec![1; 64 * 48]).unwrap();
    let msg = read_depth_png(&path).unwrap_err().to_string();
    assert!(
        msg.contains("small.png") && msg.contains("64x48") && msg.contains("512x424"),
        "{msg}"
    );
    assert!(read_mask_png(&path).is_err());
}

/// An all-zero frame, an empty mask, an empty directory, a missing file and a non-PNG file
/// are errors that name the path; read as recorded, the all-zero frame is the frame it is.
#[test]
fn empty_and_missing_inputs_are_rejected() {
    let dir = scratch("empty");
    let zeros = dir.join("zeros.png");
    write_depth_png(&zeros, &DepthFrame::zeros()).unwrap();
    let err = read_depth_png(&zeros).unwrap_err();
    assert!(matches!(err, Error::NoValidPixels { .. }) && err.to_string().contains("zeros.png"));
    assert_eq!(
        read_depth_png_as_recorded(&zeros).unwrap(),
        DepthFrame::zeros()
    );
    let empty_mask = dir.join("mask.png");
    write_gray8_png(&empty_mask, WIDTH, HEIGHT, &vec![0; PIXELS]).unwrap();
    assert!(matches!(
        read_mask_png(&empty_mask),
        Err(Error::EmptyMask { .. })
    ));

    let empty_dir = scratch("empty-dir");
    std::fs::write(empty_dir.join("notes.txt"), "no frames here").unwrap();
    let err = list_pngs(&empty_dir).unwrap_err();
    assert!(matches!(err, Error::EmptyDirectory { .. }), "{err:?}");

    let missing = dir.join("missing.png");
    let err = read_depth_png(&missing).unwrap_err();
    assert!(matches!(err, Error::Io { .. }) && err.to_string().contains("missing.png"));

    let text = dir.join("fake.png");
    std::fs::write(&text, "not a png").unwrap();
    let err = read_depth_png(&text).unwrap_err();
    assert!(matches!(err, Error::PngDecode { .. }) && err.to_string().contains("fake.png"));
}

/// A written depth frame reads back identically; the directory lists PNGs in name order.
#[test]
fn depth_png_round_trip() {
    let dir = scratch("roundtrip");
    let frame = DepthFrame::from_mm((0..PIXELS).map(|i| (i % 4500) as u16).collect()).unwrap();
    write_depth_png(&dir.join("b.png"), &frame).unwrap();
    write_depth_png(&dir.join("a.png"), &frame).unwrap();
    assert_eq!(read_depth_png(&dir.join("b.png")).unwrap(), frame);
    let names: Vec<_> = list_pngs(&dir)
        .unwrap()
        .iter()
        .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names, ["a.png", "b.png"]);
}
