//! Plots render: SVG and PNG of the expected size, with content (not blank), without any
//! system font.
#![allow(clippy::unwrap_used)] // a test that cannot unwrap has failed

mod common;

use common::Walk;
use trigait_gait::plot::{
    FOOTFALL_SIZE, TRAJECTORIES_SIZE, footfall_png, footfall_svg, trajectories_png,
    trajectories_svg,
};
use trigait_gait::{GaitParams, analyse};

/// Decodes a PNG and returns (width, height, RGB pixels).
fn decode(png_bytes: &[u8]) -> (u32, u32, Vec<[u8; 3]>) {
    let decoder = png::Decoder::new(std::io::Cursor::new(png_bytes));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!(info.color_type, png::ColorType::Rgb);
    let pixels = buf[..info.buffer_size()]
        .chunks_exact(3)
        .map(|c| [c[0], c[1], c[2]])
        .collect();
    (info.width, info.height, pixels)
}

/// Share of pixels close to `colour` (per channel within 40).
fn share(pixels: &[[u8; 3]], colour: [u8; 3]) -> f64 {
    let near = pixels
        .iter()
        .filter(|p| (0..3).all(|i| p[i].abs_diff(colour[i]) <= 40))
        .count();
    near as f64 / pixels.len() as f64
}

fn write_for_inspection(name: &str, bytes: &[u8]) {
    let dir = std::env::temp_dir().join("trigait-gait-plots");
    std::fs::create_dir_all(&dir).ok();
    std::fs::write(dir.join(name), bytes).ok();
}

/// Both figures render as PNG of the documented size, with both feet's colours, dark text and
/// a mostly white background; and as SVG with axis labels and series.
#[test]
fn figures_render() {
    let (clip, _) = Walk::default().build();
    let analysis = analyse(&clip, &GaitParams::default()).unwrap();

    let png = trajectories_png(&clip, &analysis, &[]).unwrap();
    write_for_inspection("trajectories.png", &png);
    let (w, h, pixels) = decode(&png);
    assert_eq!((w, h), TRAJECTORIES_SIZE);
    let white = share(&pixels, [255, 255, 255]);
    assert!((0.3..0.97).contains(&white), "white share {white}");
    assert!(
        share(&pixels, [200, 40, 40]) > 0.001,
        "no left (red) series"
    );
    assert!(
        share(&pixels, [30, 140, 60]) > 0.001,
        "no right (green) series"
    );
    assert!(share(&pixels, [0, 0, 0]) > 0.001, "no text or axes");

    let png = footfall_png(&clip, &analysis).unwrap();
    write_for_inspection("footfall.png", &png);
    let (w, h, pixels) = decode(&png);
    assert_eq!((w, h), FOOTFALL_SIZE);
    assert!(share(&pixels, [200, 40, 40]) > 0.002);
    assert!(share(&pixels, [30, 140, 60]) > 0.002);
    assert!(share(&pixels, [255, 230, 150]) > 0.002, "no double support");

    let svg = trajectories_svg(&clip, &analysis, &[]).unwrap();
    write_for_inspection("trajectories.svg", svg.as_bytes());
    assert!(svg.starts_with("<svg"));
    for needle in [
        "time (s)",
        "X (m)",
        "Z (m)",
        "ankle_left",
        "3-D view",
        "<polyline",
    ] {
        assert!(svg.contains(needle), "SVG lacks {needle:?}");
    }
    let svg = footfall_svg(&clip, &analysis).unwrap();
    write_for_inspection("footfall.svg", svg.as_bytes());
    for needle in ["left heel strikes", "pelvis path", "cadence", "<polygon"] {
        assert!(svg.contains(needle), "SVG lacks {needle:?}");
    }
}

/// The PNG text is drawn by the built-in bitmap font: a figure with a long title has more dark
/// pixels than the same figure's axes alone would give, and rendering twice is deterministic.
#[test]
fn png_text_is_drawn_and_deterministic() {
    let (clip, _) = Walk::default().build();
    let analysis = analyse(&clip, &GaitParams::default()).unwrap();
    let a = footfall_png(&clip, &analysis).unwrap();
    let b = footfall_png(&clip, &analysis).unwrap();
    assert_eq!(a, b);
    let (w, _, pixels) = decode(&a);
    // The title band (top 30 rows) holds the title's glyphs.
    let title_dark = pixels[..30 * w as usize]
        .iter()
        .filter(|p| p.iter().all(|c| *c < 80))
        .count();
    assert!(title_dark > 500, "title pixels {title_dark}");
}
