//! The metrics on real Kinect v2 frames from `../shared/data` (skipped with a message when the
//! data is absent outside CI; a failure under `CI=true`).

// Test helpers outside `#[test]` functions panic on failure by design.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use trigait_depth::edge::{EdgeParams, edge_noise};
use trigait_depth::io::{list_pngs, read_depth_png, read_mask_png};
use trigait_depth::panoptic::{FloorParams, floor_check, read_panoptic_calibration};

/// Acceptance: the 10 Panoptic sensors' floors, each fitted after undoing the lens
/// distortion and mapping to world with `M_depth · M_world2sensor`, agree on the floor height
/// at the dome centre within 2 cm, near y = −1.03 m.
#[test]
fn panoptic_floor_heights_agree() {
    let Some(calib) = trigait_test_data::shared_file(
        "kinect-v2-panoptic-10-sensors/kcalibration_171026_cello3.json",
    ) else {
        return;
    };
    let sensors = read_panoptic_calibration(&calib).unwrap();
    assert_eq!(sensors.len(), 10);
    let dir = calib.parent().unwrap();
    let frames: Vec<_> = list_pngs(dir)
        .unwrap()
        .iter()
        .map(|p| read_depth_png(p).unwrap())
        .collect();
    let check = floor_check(&frames, &sensors, &FloorParams::default()).unwrap();
    for s in &check.sensors {
        eprintln!(
            "sensor {}: valid {:.3} normal {:?} offset {:.4} rms {:.4} inliers {} height {:.4} tilt {:.2}",
            s.sensor,
            s.valid_pixel_share,
            s.normal,
            s.offset_m,
            s.rms_m,
            s.inliers,
            s.floor_height_at_dome_m,
            s.tilt_from_y_deg
        );
    }
    eprintln!(
        "dome {:?} spread {:.4} m, max normal angle {:.2}°",
        check.dome_center_world_m, check.floor_height_spread_m, check.max_normal_angle_deg
    );
    assert!(
        check.floor_height_spread_m < 0.02,
        "spread {}",
        check.floor_height_spread_m
    );
    assert!(
        (check.floor_height_mean_m + 1.03).abs() < 0.03,
        "{}",
        check.floor_height_mean_m
    );
    for s in &check.sensors {
        assert!(s.rms_m < 0.015 && s.inliers > 1000, "{s:?}");
    }
    // Back-projecting without undoing the lens distortion bends the floor: the fits get worse.
    let undistorted_rms: f64 = check.sensors.iter().map(|s| s.rms_m).sum();
    let mut raw = sensors.clone();
    for s in &mut raw {
        s.intrinsics.dist = [0.0; 5];
    }
    let ignored = floor_check(&frames, &raw, &FloorParams::default()).unwrap();
    let ignored_rms: f64 = ignored.sensors.iter().map(|s| s.rms_m).sum();
    eprintln!(
        "without undistortion: spread {:.4} m, summed rms {ignored_rms:.4} vs {undistorted_rms:.4}",
        ignored.floor_height_spread_m
    );
    assert!(
        ignored_rms > undistorted_rms,
        "{ignored_rms} vs {undistorted_rms}"
    );
    assert!(ignored.floor_height_spread_m > check.floor_height_spread_m);
}

/// Acceptance: the standing person's frame with its mask shows the no-data band of
/// §5.1.4 around the person: a rim of several hundred pixels, a clear share of it touching
/// no-data pixels, and a band a few pixels wide (the thesis reports 1–2 px on a flat target).
#[test]
fn person_edge_band_with_mask() {
    let Some(depth) = trigait_test_data::shared_file("kinect-v2-depth-person/004378_depth.png")
    else {
        return;
    };
    let Some(mask) = trigait_test_data::shared_file("kinect-v2-depth-person/004378_mask.png")
    else {
        return;
    };
    let frame = read_depth_png(&depth).unwrap();
    let mask = read_mask_png(&mask).unwrap();
    let (with_mask, _, _) = edge_noise(&frame, Some(&mask), &EdgeParams::default());
    let (without, _, _) = edge_noise(&frame, None, &EdgeParams::default());
    eprintln!("with mask: {with_mask:?}");
    eprintln!("without mask: {without:?}");
    assert!(with_mask.used_mask && !without.used_mask);
    assert!(with_mask.rim_pixels_with_background > 1000, "{with_mask:?}");
    assert!(with_mask.affected_share > 0.5, "{with_mask:?}");
    let w = with_mask.band_width_px.unwrap();
    assert!(w.mean > 1.0 && w.mean < 3.0, "{w:?}");
    assert!(w.max <= 6.0);
    assert!(with_mask.band_zero_pixels > 500);
    // The mask restricts the rim to the person; without it every depth edge counts.
    assert!(without.rim_pixels > with_mask.rim_pixels);
}
