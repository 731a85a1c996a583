//! The metrics on real Kinect v2 frames from `../shared/data` (skipped with a message when the
//! data is absent outside CI; a failure under `CI=true`).

use trigait_depth::edge::{EdgeParams, edge_noise};
use trigait_depth::io::{list_pngs, read_depth_png, read_mask_png};
use trigait_depth::panoptic::{FloorParams, floor_check, read_panoptic_calibration};

/// Issue 6 acceptance: the 10 Panoptic sensors' floors, each fitted after undoing the lens
/// distortion and mapping to world with `M_depth · M_world2sensor`, agree on the floor height
/// at the dome centre within 2 cm, near y = −1.03 m.
#[test]
fn issue_6_panoptic_floor_heights_agree() {
    let Some(calib) =
        trigait_test_data::shared_file("kinect-v2-panoptic-10-sensors/kcalibration_171026_cello3.json")
    else {
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
            s.sensor, s.valid_pixel_share, s.normal, s.offset_m, s.rms_m, s.inliers,
            s.floor_height_at_dome_m, s.tilt_from_y_deg
        );
    }
    eprintln!("dome {:?} spread {:.4} m, max normal angle {:.2}°", check.dome_center_world_m,
        check.floor_height_spread_m, check.max_normal_angle_deg);
    assert!(check.floor_height_spread_m < 0.02, "spread {}", check.floor_height_spread_m);
    assert!((check.floor_height_mean_m + 1.03).abs() < 0.03, "{}", check.floor_height_mean_m);
    for s in &check.sensors {
        assert!(s.rms_m < 0.015 && s.inliers > 1000, "{s:?}");
    }
}
