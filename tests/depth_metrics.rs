//! `trigait depth-metrics` end to end: the built binary on the real recordings in
//! `../shared/data` and on bad input (an acceptance run).

// Test helpers outside `#[test]` functions panic on failure by design.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::{Path, PathBuf};
use std::process::Output;

mod common;

fn trigait(args: &[&str]) -> Output {
    common::trigait_cli("depth-metrics", args)
}

fn scratch(name: &str) -> PathBuf {
    common::scratch_dir("cli", name)
}

/// The ten Panoptic sensors with their calibration: per-sensor valid share, world floor plane
/// and noise figures, and floor heights at the dome centre that agree within 2 cm, stated as
/// `floor_height_spread_m`.
#[test]
fn panoptic_floor_heights_via_cli() {
    let Some(calib) = trigait_test_data::shared_file(
        "kinect-v2-panoptic-10-sensors/kcalibration_171026_cello3.json",
    ) else {
        return;
    };
    let dir = calib.parent().unwrap();
    let out = trigait(&[
        dir.to_str().unwrap(),
        "--calibration",
        calib.to_str().unwrap(),
        "--json",
    ]);
    let v = common::stdout_json(&out);
    assert_eq!(v["mode"], "multi_sensor");
    let spread = v["floor_height_spread_m"].as_f64().unwrap();
    assert!(spread < 0.02, "spread {spread}");
    let sensors = v["sensors"].as_array().unwrap();
    assert_eq!(sensors.len(), 10);
    let dome = v["dome_center_world_m"].as_array().unwrap();
    assert!((dome[1].as_f64().unwrap() + 1.03).abs() < 0.03);
    let heights: Vec<f64> = sensors
        .iter()
        .map(|s| s["floor_height_at_dome_m"].as_f64().unwrap())
        .collect();
    let (lo, hi) = heights
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &h| (a.min(h), b.max(h)));
    assert!((hi - lo - spread).abs() < 1e-12);
    for s in sensors {
        let n: Vec<f64> = s["floor_normal"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        assert!(n[1] > 0.99, "floor normal points up: {n:?}");
        assert!(s["floor_rms_m"].as_f64().unwrap() < 0.015);
        let share = s["valid_pixel_share"].as_f64().unwrap();
        assert!(share > 0.5 && share <= 1.0);
        assert!(s["metrics"]["edge_noise"]["rim_pixels"].as_u64().unwrap() > 0);
        assert!(s["metrics"]["structural_noise"]["rms_residual_mm"].is_number());
    }
    // The table names the same spread in millimetres.
    let table = trigait(&[
        dir.to_str().unwrap(),
        "--calibration",
        calib.to_str().unwrap(),
    ]);
    let text = String::from_utf8(table.stdout).unwrap();
    assert!(
        text.contains(&format!("spread {:.1} mm", 1000.0 * spread)),
        "{text}"
    );
}

/// The person frame with its mask reports the edge-noise band around the person, and `--out`
/// writes the colour maps that the JSON describes.
#[test]
fn person_edge_band_via_cli() {
    let Some(depth) = trigait_test_data::shared_file("kinect-v2-depth-person/004378_depth.png")
    else {
        return;
    };
    let Some(mask) = trigait_test_data::shared_file("kinect-v2-depth-person/004378_mask.png")
    else {
        return;
    };
    let out_dir = scratch("person");
    let v = common::stdout_json(&trigait(&[
        depth.to_str().unwrap(),
        "--mask",
        mask.to_str().unwrap(),
        "--out",
        out_dir.to_str().unwrap(),
        "--json",
    ]));
    let edge = &v["edge_noise"];
    assert_eq!(edge["used_mask"], true);
    let width = edge["band_width_px"]["mean"].as_f64().unwrap();
    assert!(width > 1.0 && width < 3.0, "band width {width}");
    assert!(edge["affected_share"].as_f64().unwrap() > 0.5);
    assert!(v["entropy"].is_null(), "one frame has no entropy");
    let maps = v["maps"].as_array().unwrap();
    let names: Vec<&str> = maps.iter().map(|m| m["name"].as_str().unwrap()).collect();
    assert!(
        names.contains(&"edge_band") && names.contains(&"accuracy_zones"),
        "{names:?}"
    );
    for m in maps {
        let file = Path::new(m["file"].as_str().unwrap());
        let bytes = std::fs::read(file).unwrap();
        assert_eq!(&bytes[1..4], b"PNG", "{}", file.display());
        assert!(m["entries"].as_array().is_some_and(|e| !e.is_empty()) || m["scale"].is_object());
    }
}

/// Bad input exits with code 2 and an error naming the file: an 8-bit PNG, an empty
/// directory, a missing file, a frame count that does not match the calibration.
#[test]
fn bad_input_is_a_clear_error() {
    let Some(mask) = trigait_test_data::shared_file("kinect-v2-depth-person/004378_mask.png")
    else {
        return;
    };
    let check = |args: &[&str], needle: &str| {
        let out = trigait(args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(
            err.contains(needle) && !err.contains("panicked"),
            "{args:?}: {err}"
        );
    };
    check(&[mask.to_str().unwrap()], "004378_mask.png: 8-bit");
    let empty = scratch("empty");
    check(&[empty.to_str().unwrap()], "no .png files");
    check(&["/nonexistent/depth.png"], "/nonexistent/depth.png");
    if let Some(calib) = trigait_test_data::shared_file(
        "kinect-v2-panoptic-10-sensors/kcalibration_171026_cello3.json",
    ) {
        let one = calib.with_file_name("depth_00000.png");
        check(
            &[
                one.to_str().unwrap(),
                "--calibration",
                calib.to_str().unwrap(),
            ],
            "1 depth frames for 10 sensors",
        );
    }
}

/// A recorded sequence may start with frames of all zeros (a sensor starting up): they are
/// measured as what they are, frames with no valid pixel, counted and said, so the real frame
/// after one of them comes out at half its valid share, with the single-frame metrics taken
/// from it as without the empty one. A single empty frame, or a sequence of nothing but, is an
/// error.
#[test]
fn an_empty_frame_in_a_sequence_is_counted() {
    let dir = scratch("empty-frame");
    let zero = dir.join("starting-up.png");
    trigait_depth::io::write_depth_png(&zero, &trigait_depth::DepthFrame::zeros()).unwrap();
    let zero = zero.to_str().unwrap();
    for (args, needle) in [
        (vec![zero], "every pixel is 0"),
        (vec![zero, zero], "none of the 2 frames has depth"),
    ] {
        let out = trigait(&args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: {err}");
    }
    let Some(depth) = trigait_test_data::shared_file("kinect-v2-depth-person/004378_depth.png")
    else {
        return;
    };
    let depth = depth.to_str().unwrap();
    let json = |args: &[&str]| -> serde_json::Value {
        let out = trigait(&[args, &["--json"]].concat());
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{args:?}: {err}");
        serde_json::from_slice(&out.stdout).unwrap()
    };
    let alone = json(&[depth]);
    let after = json(&[zero, depth]);
    assert_eq!(alone["frames"], 1);
    assert_eq!(after["frames"], 2);
    assert_eq!(alone["frames_without_depth"], 0);
    assert_eq!(after["frames_without_depth"], 1);
    let share = |v: &serde_json::Value| v["valid_share"].as_f64().unwrap();
    assert!(share(&alone) > 0.5, "{}", alone["valid_share"]);
    assert!((share(&after) - share(&alone) / 2.0).abs() < 1e-12);
    assert_eq!(after["resolution"], alone["resolution"]);
    assert_eq!(after["edge_noise"], alone["edge_noise"]);
    let text = trigait(&[zero, depth]);
    let stdout = String::from_utf8_lossy(&text.stdout);
    assert!(text.status.success(), "{stdout}");
    assert!(
        stdout.contains(
            "frames with no depth at all (every pixel 0, as a sensor sends while it starts up): 1"
        ),
        "{stdout}"
    );
}
