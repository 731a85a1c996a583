//! `trigait export` round trips: joint centres of a real walk written as TRC, C3D and CSV, read
//! back (TRC by our reader, C3D through c3dio) equal within 1e-4 m, and `trigait gait` on the
//! exported files finds the same heel strikes as on the original.
#![allow(clippy::unwrap_used)] // tests may unwrap (STYLE.md §6); helpers outside #[test] fns need saying so

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use trigait_skeleton::MotionClip;

fn trigait(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_trigait"))
        .args(args)
        .output()
        .unwrap()
}

fn scratch(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("trigait-export-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Largest distance between matching samples; gaps must match exactly.
fn max_difference(a: &MotionClip, b: &MotionClip) -> f64 {
    assert_eq!(a.frame_count(), b.frame_count());
    assert_eq!(a.joints(), b.joints());
    assert!((a.rate_hz() - b.rate_hz()).abs() < 1e-6);
    let mut worst: f64 = 0.0;
    for f in 0..a.frame_count() {
        for j in a.joints() {
            match (a.position(f, *j), b.position(f, *j)) {
                (Some(p), Some(q)) => worst = worst.max((p - q).norm()),
                (None, None) => {}
                (p, q) => panic!("frame {f} {j}: {p:?} vs {q:?}"),
            }
        }
    }
    worst
}

/// The clip as joint trajectories, read back from a joint-named marker file.
fn read_back(path: &Path) -> MotionClip {
    let set = trigait_motion::read_markers(path).unwrap();
    let joints: Vec<_> = set
        .labels()
        .iter()
        .map(|l| trigait_skeleton::Joint::from_name(l).unwrap())
        .collect();
    let frames = (0..set.frame_count())
        .map(|f| {
            (0..joints.len())
                .map(|c| set.position_at_column(f, c))
                .collect()
        })
        .collect();
    MotionClip::new(set.name(), set.rate_hz(), joints, frames).unwrap()
}

fn heel_strike_times(path: &Path, extra: &[&str]) -> Vec<f64> {
    let mut args = vec!["gait", path.to_str().unwrap(), "--json"];
    args.extend_from_slice(extra);
    let out = trigait(&args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    v["events"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|e| e["kind"] == "heel_strike")
        .map(|e| e["time_secs"].as_f64().unwrap())
        .collect()
}

/// Acceptance: TRC and C3D exports of the CMU walk's joint centres read back within
/// 1e-4 m (TRC with our reader, C3D through c3dio), CSV too, and the gait events survive.
#[test]
fn exports_round_trip() {
    let Some(source) = trigait_test_data::shared_file("mocap-cmu-07_01/07_01.c3d") else {
        return;
    };
    let original = trigait_motion::load_motion(&source).unwrap();
    // The export carries joint centres, so the original is analysed on its joint centres too
    // (by default it uses its heel markers, which an export does not keep).
    let original_events = heel_strike_times(&source, &["--joint-centres"]);
    assert_eq!(original_events.len(), 4);
    let dir = scratch("round-trip");
    for (name, format) in [
        ("walk.trc", "trc"),
        ("walk.c3d", "c3d"),
        ("walk.csv", "csv"),
    ] {
        let out_path = dir.join(name);
        let out = trigait(&[
            "export",
            source.to_str().unwrap(),
            "--format",
            format,
            "-o",
            out_path.to_str().unwrap(),
        ]);
        assert!(
            out.status.success(),
            "{format}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(String::from_utf8_lossy(&out.stdout).contains("316 frames"));
        if format != "csv" {
            let back = read_back(&out_path);
            let worst = max_difference(&original, &back);
            assert!(worst < 1e-4, "{format}: {worst} m");
        }
        // The same analysis as the original's: an export is a joint-trajectory file, which
        // `trigait gait` low-passes by default, and the joint centres placed from markers are
        // not, so the filter is named to compare the data, not the defaults.
        let events = heel_strike_times(&out_path, &["--filter", "none"]);
        assert_eq!(events.len(), original_events.len(), "{format}");
        for (a, b) in events.iter().zip(&original_events) {
            assert!((a - b).abs() < 1e-3, "{format}: {a} vs {b}");
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// The export format follows the output extension; an unknown one is a clear error, and a
/// filtered export differs from the raw one but only by millimetres on a clean walk.
#[test]
fn format_from_extension_and_filter() {
    let Some(source) = trigait_test_data::shared_file(
        "mocap-opensim-rajagopal-walk/Rajagopal__motion_capture_walk.trc",
    ) else {
        return;
    };
    let dir = scratch("formats");
    let raw = dir.join("raw.trc");
    let smooth = dir.join("smooth.trc");
    let src = source.to_str().unwrap();
    assert!(
        trigait(&["export", src, "-o", raw.to_str().unwrap()])
            .status
            .success()
    );
    let out = trigait(&[
        "export",
        src,
        "-o",
        smooth.to_str().unwrap(),
        "--filter",
        "butterworth:6hz",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let worst = max_difference(&read_back(&raw), &read_back(&smooth));
    // A 6 Hz cut-off rounds the foot's landing by up to ~1.5 cm and leaves the rest.
    assert!(
        worst > 1e-4 && worst < 0.03,
        "filter moved joints by {worst} m"
    );
    let bad = dir.join("walk.xyz");
    let out = trigait(&["export", src, "-o", bad.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--format trc|c3d|csv"));
    // A format the extension contradicts, and writing over the input, are refused; the input
    // is left as it was.
    let out = trigait(&[
        "export",
        src,
        "-o",
        raw.to_str().unwrap(),
        "--format",
        "csv",
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--format csv but"));
    let before = std::fs::read(&raw).unwrap();
    for cmd in ["export", "report"] {
        let out = trigait(&[cmd, raw.to_str().unwrap(), "-o", raw.to_str().unwrap()]);
        assert_eq!(out.status.code(), Some(2), "{cmd}");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(stderr.contains("it is the input file"), "{cmd}: {stderr}");
        assert_eq!(
            std::fs::read(&raw).unwrap(),
            before,
            "{cmd} changed its input"
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// Kinect SDK skeleton text exports as `trigait gait` reads it (85 frames of the Straight
/// walk, its joints), into a folder made for it; the report goes into a new folder too.
#[test]
fn kinect_text_exports_into_a_new_folder() {
    let Some(straight) =
        trigait_test_data::shared_file("kinect-v2-skeleton-replay/JointsInfo_Straight.txt")
    else {
        return;
    };
    let dir = scratch("kinect-text");
    let trc = dir.join("new").join("straight.trc");
    let out = trigait(&[
        "export",
        straight.to_str().unwrap(),
        "-o",
        trc.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let clip = read_back(&trc);
    assert_eq!(clip.frame_count(), 85);
    assert!(clip.has(trigait_skeleton::Joint::AnkleLeft));
    let html = dir.join("pages").join("straight.html");
    let out = trigait(&[
        "report",
        straight.to_str().unwrap(),
        "-o",
        html.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(html.exists());
    std::fs::remove_dir_all(&dir).ok();
}
