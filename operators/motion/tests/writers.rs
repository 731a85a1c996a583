//! Writers round-trip through our readers (and c3dio's for C3D) within 0.1 mm, gaps included.
#![allow(clippy::unwrap_used)] // tests may unwrap (STYLE.md §6); helpers outside #[test] fns need saying so

mod common;

use common::temp_path;
use nalgebra::Point3;
use trigait_motion::{
    Error, Joint, MarkerSet, MotionClip, WalkerParams, load_motion, read_c3d, read_trc, walker,
    write_c3d, write_csv, write_trc,
};

/// A full-body walker clip with gaps punched into two joints.
fn clip_with_gaps() -> MotionClip {
    let params = WalkerParams {
        all_joints: true,
        ..WalkerParams::default()
    };
    let c = walker(&params, 1.0, 60.0).unwrap();
    let frames = (0..c.frame_count())
        .map(|f| {
            c.joints()
                .iter()
                .map(|j| {
                    let gap = (*j == Joint::KneeLeft && (10..15).contains(&f))
                        || (*j == Joint::HandTipRight && f == 0);
                    if gap { None } else { c.position(f, *j) }
                })
                .collect()
        })
        .collect();
    MotionClip::new("gappy", c.rate_hz(), c.joints().to_vec(), frames).unwrap()
}

/// Every joint of `clip` matches the marker of the same name in `set` within `tol` metres, and
/// gaps are gaps in both.
fn assert_same(clip: &MotionClip, set: &MarkerSet, tol: f64) {
    assert_eq!(set.frame_count(), clip.frame_count());
    assert!((set.rate_hz() - clip.rate_hz()).abs() < 1e-9);
    assert_eq!(set.labels().len(), clip.joints().len());
    let mut compared = 0;
    for j in clip.joints() {
        let column = set
            .marker(j.name())
            .unwrap_or_else(|| panic!("no marker {j}"));
        for f in 0..clip.frame_count() {
            match (clip.position(f, *j), set.position_at_column(f, column)) {
                (Some(a), Some(b)) => {
                    assert!((a - b).norm() < tol, "{j} frame {f}: {a} vs {b}");
                    compared += 1;
                }
                (None, None) => {}
                (a, b) => panic!("{j} frame {f}: gap mismatch {a:?} vs {b:?}"),
            }
        }
    }
    assert!(compared > 1000);
}

/// TRC: header in the reference file's layout, mm, Y up; reads back equal.
#[test]
fn trc_round_trip() {
    let clip = clip_with_gaps();
    let path = temp_path("walk.trc");
    write_trc(&path, &clip).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert!(lines[0].starts_with("PathFileType\t4\t(X/Y/Z)\t"));
    assert_eq!(
        lines[1],
        "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tOrigDataRate\tOrigDataStartFrame\tOrigNumFrames"
    );
    assert_eq!(lines[2], "60.0\t60.0\t61\t25\tmm\t60.0\t1\t61");
    assert!(lines[3].starts_with("Frame#\tTime\tspine_base\t\t\tspine_mid\t\t\t"));
    assert!(lines[4].starts_with("\t\tX1\tY1\tZ1\tX2"));
    assert!(lines[5].is_empty());
    // Y up in the file: the second coordinate of the head is its height in mm.
    let head = clip.position(0, Joint::Head).unwrap();
    let fields: Vec<&str> = lines[6].split('\t').collect();
    let y_mm: f64 = fields[2 + 3 * Joint::Head.index() + 1].parse().unwrap();
    assert!((y_mm - head.z * 1e3).abs() < 1e-3);
    let set = read_trc(&path).unwrap();
    std::fs::remove_file(&path).unwrap();
    assert_same(&clip, &set, 1e-4);
    assert_eq!(set.missing_frames(set.marker("knee_left").unwrap()), 5);
}

/// C3D: our reader and c3dio's both read back what we wrote.
#[test]
fn c3d_round_trip() {
    let clip = clip_with_gaps();
    let path = temp_path("walk.c3d");
    write_c3d(&path, &clip).unwrap();
    let set = read_c3d(&path).unwrap();
    assert_same(&clip, &set, 1e-4);

    // In the file, a gap's fourth word is −1.0 (the spec's invalid flag; other readers look at
    // its sign), a sample's is ≥ 0. c3dio alone would write +255.0 there.
    let bytes = std::fs::read(&path).unwrap();
    let data_start = (usize::from(u16::from_le_bytes([bytes[16], bytes[17]])) - 1) * 512;
    let word = |frame: usize, joint: Joint| {
        let at = data_start + (frame * 25 + joint.index()) * 16 + 12;
        f32::from_le_bytes(bytes[at..at + 4].try_into().unwrap())
    };
    assert_eq!(word(12, Joint::KneeLeft), -1.0);
    assert_eq!(word(0, Joint::HandTipRight), -1.0);
    assert!(word(9, Joint::KneeLeft) >= 0.0 && word(0, Joint::HandTipLeft) >= 0.0);

    let raw = c3dio::C3d::load_path(path.clone()).unwrap();
    std::fs::remove_file(&path).unwrap();
    // POINT:DATA_START agrees with the header's pointer.
    let start = raw.parameters.get("POINT", "DATA_START").unwrap();
    let start: i16 = start.as_ref().try_into().unwrap();
    assert_eq!(usize::try_from(start).unwrap(), data_start / 512 + 1);
    assert_eq!(raw.points.labels.len(), 25);
    assert_eq!(raw.points.labels[0].trim(), "spine_base");
    assert_eq!(raw.points.frame_rate, 60.0);
    assert_eq!(raw.points.rows(), clip.frame_count());
    let units: String = raw.points.units.iter().collect();
    assert_eq!(units.trim(), "mm");
    assert_eq!(raw.points.y_screen, Some(['+', 'Z']));
    // Gaps carry a negative residual (invalid), samples a non-negative one.
    let knee = Joint::KneeLeft.index();
    assert!(raw.points[12][knee].residual < 0.0);
    assert!(raw.points[9][knee].residual >= 0.0);
    assert!(raw.points[0][Joint::HandTipRight.index()].residual < 0.0);
    let ankle = clip.position(7, Joint::AnkleRight).unwrap() * 1e3;
    let p = raw.points[7][Joint::AnkleRight.index()].point;
    assert!((f64::from(p[0]) - ankle.x).abs() < 0.1);
    assert!((f64::from(p[2]) - ankle.z).abs() < 0.1);
}

/// C3D writing refuses a wrong extension with a typed error.
#[test]
fn c3d_wrong_extension() {
    let clip = clip_with_gaps();
    let path = temp_path("walk.txt");
    assert!(matches!(
        write_c3d(&path, &clip),
        Err(Error::C3dWrite { .. })
    ));
    assert!(!path.exists());
    assert!(matches!(
        write_c3d(temp_path("no-extension"), &clip),
        Err(Error::C3dWrite { .. })
    ));
    // A folder that is not there: the operating system's words, not c3dio's Debug form.
    let nowhere = temp_path("missing-folder").join("walk.c3d");
    let text = write_c3d(&nowhere, &clip).unwrap_err().to_string();
    assert!(
        text.contains("walk.c3d") && !text.contains("Os {") && !text.contains("WriteError("),
        "{text}"
    );
}

/// CSV: metres, Z up, parses back to the same positions.
#[test]
fn csv_round_trip() {
    let clip = clip_with_gaps();
    let path = temp_path("walk.csv");
    write_csv(&path, &clip).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    std::fs::remove_file(&path).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(header.len(), 2 + 3 * 25);
    let mut rows = 0;
    for (f, line) in lines.enumerate() {
        let cells: Vec<&str> = line.split(',').collect();
        assert_eq!(cells.len(), header.len());
        for (i, j) in clip.joints().iter().enumerate() {
            let xyz: Vec<&str> = cells[2 + 3 * i..5 + 3 * i].to_vec();
            match clip.position(f, *j) {
                Some(p) => {
                    let q = Point3::new(
                        xyz[0].parse().unwrap(),
                        xyz[1].parse().unwrap(),
                        xyz[2].parse().unwrap(),
                    );
                    assert!((p - q).norm() < 1e-5, "{j} frame {f}");
                }
                None => assert!(xyz.iter().all(|c| c.is_empty())),
            }
        }
        rows += 1;
    }
    assert_eq!(rows, clip.frame_count());
}

/// `load_motion` reads every export back as the same joints (joint-named markers are not
/// mistaken for skin markers).
#[test]
fn load_motion_reads_exports() {
    let clip = clip_with_gaps();
    for name in ["walk.trc", "walk.c3d", "walk.csv"] {
        let path = temp_path(&format!("load-{name}"));
        match name.rsplit('.').next() {
            Some("trc") => write_trc(&path, &clip).unwrap(),
            Some("c3d") => write_c3d(&path, &clip).unwrap(),
            _ => write_csv(&path, &clip).unwrap(),
        }
        let back = load_motion(&path).unwrap();
        std::fs::remove_file(&path).unwrap();
        assert_eq!(back.joints(), clip.joints(), "{name}");
        assert!((back.rate_hz() - clip.rate_hz()).abs() < 1e-6, "{name}");
        for f in 0..clip.frame_count() {
            for j in clip.joints() {
                match (clip.position(f, *j), back.position(f, *j)) {
                    (Some(a), Some(b)) => assert!((a - b).norm() < 1e-4, "{name} {j} {f}"),
                    (None, None) => {}
                    (a, b) => panic!("{name} {j} frame {f}: {a:?} vs {b:?}"),
                }
            }
        }
    }
}

/// Real joint centres survive TRC and C3D export unchanged (within 0.1 mm).
#[test]
fn real_clip_round_trips() {
    let Some(source) = trigait_test_data::shared_file("mocap-cmu-07_01/07_01.c3d") else {
        return;
    };
    let clip = load_motion(&source).unwrap();
    for name in ["cmu.trc", "cmu.c3d"] {
        let path = temp_path(name);
        if name.ends_with("trc") {
            write_trc(&path, &clip).unwrap();
        } else {
            write_c3d(&path, &clip).unwrap();
        }
        let set = trigait_motion::read_markers(&path).unwrap();
        std::fs::remove_file(&path).unwrap();
        assert_same(&clip, &set, 1e-4);
    }
}
