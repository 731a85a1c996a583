//! `trigait gait` end to end: the binary on the real walks, its JSON, plots and error messages.
#![allow(clippy::unwrap_used)] // tests may unwrap (STYLE.md §6); helpers outside #[test] fns need saying so

use std::path::Path;
use std::process::{Command, Output};

fn trigait(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_trigait"))
        .args(args)
        .output()
        .unwrap()
}

fn json(path: &Path, extra: &[&str]) -> serde_json::Value {
    let mut args = vec!["gait", path.to_str().unwrap(), "--json"];
    args.extend_from_slice(extra);
    let out = trigait(&args);
    assert!(
        out.status.success(),
        "trigait {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

fn mean(v: &serde_json::Value, key: &str) -> f64 {
    v["summary"][key]["mean"]
        .as_f64()
        .unwrap_or_else(|| panic!("no {key} mean in {v}"))
}

/// Heel-strike times of one foot from the JSON event list.
fn heel_strikes(v: &serde_json::Value, foot: &str) -> Vec<f64> {
    v["events"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|e| e["foot"] == foot && e["kind"] == "heel_strike")
        .map(|e| e["time_secs"].as_f64().unwrap())
        .collect()
}

/// The heel is on the floor only when it has (nearly) stopped moving forward (m/s); in swing
/// it travels at 3-4 m/s.
const HEEL_LANDED_HORIZONTAL_MPS: f64 = 1.0;

/// Heel strikes from the heel marker's height minima, as in
/// operators/gait/tests/markers.rs: first local minimum within 3 cm of the floor level after
/// each swing peak (or a descent under way at the first frame) where the heel moves forward
/// slower than [`HEEL_LANDED_HORIZONTAL_MPS`]. Without that gate the reference took a dip of
/// the heel marker late in swing (CMU 07_01 right heel at 0.933 s, 3.9 m/s forward; Rajagopal
/// left heel at 0.77 s, 3.5 m/s, 18 mm above its later stance height) for the landing, which
/// comes 0.1 s later.
fn marker_heel_strikes(path: &Path, label: &str) -> Vec<f64> {
    let set = trigait_motion::read_markers(path).unwrap();
    let column = set.marker(label).unwrap();
    let track = set.trajectory(column);
    let z: Vec<f64> = track.iter().map(|p| p.map_or(f64::NAN, |p| p.z)).collect();
    let rate = set.rate_hz();
    let horizontal_speed = |i: usize| -> f64 {
        match (track[i - 1], track[i + 1]) {
            (Some(a), Some(b)) => (b.x - a.x).hypot(b.y - a.y) * rate / 2.0,
            _ => f64::INFINITY,
        }
    };
    let mut sorted: Vec<f64> = z.iter().copied().filter(|v| v.is_finite()).collect();
    sorted.sort_by(f64::total_cmp);
    let floor = sorted[sorted.len() / 4];
    let mut peaks: Vec<usize> = Vec::new();
    if z[0] > floor + 0.1 && z[1] < z[0] {
        peaks.push(0);
    }
    peaks.extend(
        (1..z.len() - 1).filter(|&i| z[i] > z[i - 1] && z[i] >= z[i + 1] && z[i] > floor + 0.1),
    );
    let mut out = Vec::new();
    for (k, &p) in peaks.iter().enumerate() {
        let end = peaks.get(k + 1).copied().unwrap_or(z.len() - 1);
        if let Some(i) = (p + 1..end).find(|&i| {
            z[i] < z[i - 1]
                && z[i] <= z[i + 1]
                && z[i] < floor + 0.03
                && horizontal_speed(i) < HEEL_LANDED_HORIZONTAL_MPS
        }) {
            out.push(i as f64 / set.rate_hz());
        }
    }
    out
}

fn check_walk(relative: &str, heels: [&str; 2]) {
    let Some(path) = trigait_test_data::shared_file(relative) else {
        return;
    };
    for method in ["coordinate", "velocity"] {
        let v = json(&path, &["--method", method]);
        for (foot, heel) in ["left", "right"].into_iter().zip(heels) {
            let found = heel_strikes(&v, foot);
            let reference = marker_heel_strikes(&path, heel);
            assert!(!reference.is_empty());
            assert_eq!(
                found.len(),
                reference.len(),
                "{relative} {method} {foot}: {found:?} vs markers {reference:?}"
            );
            for (f, r) in found.iter().zip(&reference) {
                assert!(
                    (f - r).abs() < 0.1,
                    "{relative} {method} {foot}: {f} vs {r}"
                );
            }
            assert_eq!(v["heel_strikes"][foot].as_u64(), Some(found.len() as u64));
        }
        let cadence = mean(&v, "cadence_steps_per_min");
        let stride = mean(&v, "stride_length_m");
        let speed = mean(&v, "speed_mps");
        assert!(
            (95.0..125.0).contains(&cadence),
            "{relative}: cadence {cadence}"
        );
        assert!((1.2..1.7).contains(&stride), "{relative}: stride {stride}");
        assert!((1.0..1.6).contains(&speed), "{relative}: speed {speed}");
        assert!(v["summary"]["strides"].as_u64().unwrap() >= 2);
        assert_eq!(v["excluded"].as_array().unwrap().len(), 0);
    }
}

/// Acceptance: every heel strike of each foot in CMU 07_01, with cadence, stride length
/// and speed reported.
#[test]
fn cmu_heel_strikes_and_parameters() {
    check_walk("mocap-cmu-07_01/07_01.c3d", ["LHEE", "RHEE"]);
}

/// Acceptance: the same for the OpenSim Rajagopal walk (TRC, Y-up file).
#[test]
fn rajagopal_heel_strikes_and_parameters() {
    check_walk(
        "mocap-opensim-rajagopal-walk/Rajagopal__motion_capture_walk.trc",
        ["L.Heel", "R.Heel"],
    );
}

/// Filtering a clean mocap walk with a 6 Hz zero-lag Butterworth barely moves the parameters.
#[test]
fn butterworth_filter_keeps_mocap_parameters() {
    let Some(path) = trigait_test_data::shared_file("mocap-cmu-07_01/07_01.c3d") else {
        return;
    };
    let raw = json(&path, &[]);
    let filtered = json(&path, &["--filter", "butterworth:6hz"]);
    assert_eq!(filtered["filter"], "butterworth:6hz");
    let d = mean(&raw, "stride_length_m") - mean(&filtered, "stride_length_m");
    assert!(d.abs() < 0.01, "stride length moved {d} m");
    let c = mean(&raw, "cadence_steps_per_min") / mean(&filtered, "cadence_steps_per_min");
    assert!((c - 1.0).abs() < 0.02);
}

/// The table names the parameters and counts; `--plots` writes four non-trivial files.
#[test]
fn table_and_plots() {
    let Some(path) = trigait_test_data::shared_file("mocap-cmu-07_01/07_01.c3d") else {
        return;
    };
    let dir = std::env::temp_dir().join(format!("trigait-gait-cli-{}", std::process::id()));
    std::fs::remove_dir_all(&dir).ok();
    let out = trigait(&[
        "gait",
        path.to_str().unwrap(),
        "--plots",
        dir.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    for needle in [
        "stride length (m)",
        "cadence (steps/min)",
        "double support (%)",
        "left  heel strikes",
    ] {
        assert!(text.contains(needle), "table lacks {needle:?}:\n{text}");
    }
    for (name, min_bytes) in [
        ("07_01_trajectories.svg", 20_000),
        ("07_01_trajectories.png", 20_000),
        ("07_01_footfall.svg", 5_000),
        ("07_01_footfall.png", 5_000),
    ] {
        let bytes = std::fs::read(dir.join(name)).unwrap();
        assert!(bytes.len() > min_bytes, "{name}: {} bytes", bytes.len());
        if name.ends_with(".png") {
            assert_eq!(&bytes[1..4], b"PNG");
            // IHDR width and height, big-endian at bytes 16..24.
            let w = u32::from_be_bytes(bytes[16..20].try_into().unwrap());
            let h = u32::from_be_bytes(bytes[20..24].try_into().unwrap());
            let expected = if name.contains("footfall") {
                trigait_gait::plot::FOOTFALL_SIZE
            } else {
                trigait_gait::plot::TRAJECTORIES_SIZE
            };
            assert_eq!((w, h), expected);
        }
    }
    // A file where the directory should be is named as such, and nothing is printed.
    let file = dir.join("07_01_footfall.svg");
    let out = fails_with(
        &[
            "gait",
            path.to_str().unwrap(),
            "--plots",
            file.to_str().unwrap(),
        ],
        "is a file",
    );
    let printed = String::from_utf8_lossy(&out.stdout);
    assert!(printed.is_empty(), "{printed}");
    std::fs::remove_dir_all(&dir).ok();
}

/// Runs `trigait` with `args`, asserts exit 2 with `needle` in stderr and no panic, and returns
/// the output.
fn fails_with(args: &[&str], needle: &str) -> Output {
    let out = trigait(args);
    assert_eq!(
        out.status.code(),
        Some(2),
        "{args:?} should fail with exit 2"
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains(needle),
        "{args:?}: stderr {err:?} lacks {needle:?}"
    );
    assert!(!err.contains("panicked"), "{err}");
    out
}

/// Broken input is a clear message and exit code 2, never a panic: a missing file, a file of
/// the wrong kind, a bad filter, and a walk too short for two strides.
#[test]
fn bad_input_is_a_clear_error() {
    fails_with(&["gait", "/nonexistent/walk.c3d"], "walk.c3d");
    let dir = std::env::temp_dir().join(format!("trigait-gait-bad-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let junk = dir.join("junk.trc");
    std::fs::write(&junk, "not a trc file\n").unwrap();
    fails_with(&["gait", junk.to_str().unwrap()], "junk.trc");
    let Some(path) = trigait_test_data::shared_file("mocap-cmu-07_01/07_01.c3d") else {
        return;
    };
    fails_with(
        &["gait", path.to_str().unwrap(), "--filter", "kalman"],
        "butterworth:6hz",
    );
    // A belt speed that is not a speed.
    for speed in ["--treadmill=nan", "--treadmill=-1", "--treadmill=1e9"] {
        fails_with(&["gait", path.to_str().unwrap(), speed], "0..=10 m/s");
    }
    // Demanding more strides than a 2.6 s walk has.
    fails_with(
        &["gait", path.to_str().unwrap(), "--min-strides", "5"],
        "complete strides, need at least 5",
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// Writes trigait joint CSV text: `rows` of (hip_left, hip_right, knee_left, knee_right,
/// ankle_left, ankle_right) positions, `None` for a gap.
fn write_csv(path: &Path, rate_hz: f64, rows: &[[Option<[f64; 3]>; 6]]) {
    let joints = [
        "hip_left",
        "hip_right",
        "knee_left",
        "knee_right",
        "ankle_left",
        "ankle_right",
    ];
    let mut text = String::from("frame,time_s");
    for j in joints {
        text.push_str(&format!(",{j}_x_m,{j}_y_m,{j}_z_m"));
    }
    text.push('\n');
    for (f, row) in rows.iter().enumerate() {
        text.push_str(&format!("{f},{:.6}", f as f64 / rate_hz));
        for p in row {
            match p {
                Some([x, y, z]) => text.push_str(&format!(",{x},{y},{z}")),
                None => text.push_str(",,,"),
            }
        }
        text.push('\n');
    }
    std::fs::write(path, text).unwrap();
}

fn standing_row(t: f64) -> [Option<[f64; 3]>; 6] {
    let sway = 0.004 * (2.0 * t).sin();
    [
        Some([sway, 0.09, 0.92]),
        Some([sway, -0.09, 0.92]),
        Some([0.0, 0.09, 0.5]),
        Some([0.0, -0.09, 0.5]),
        Some([0.0, 0.09, 0.08]),
        Some([0.0, -0.09, 0.08]),
    ]
}

/// A standing subject, a clip that is all gaps, and a walk cut to under a second each give a
/// clear message with exit code 2, never a panic or made-up strides.
#[test]
fn standing_gaps_and_short_walks_are_clear_errors() {
    let dir = std::env::temp_dir().join(format!("trigait-gait-edge-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();

    let standing = dir.join("standing.csv");
    let rows: Vec<_> = (0..150).map(|f| standing_row(f as f64 / 30.0)).collect();
    write_csv(&standing, 30.0, &rows);
    fails_with(&["gait", standing.to_str().unwrap()], "no straight walking");
    fails_with(&["gait", standing.to_str().unwrap()], "standing 5.00 s");

    let gaps = dir.join("gaps.csv");
    let rows: Vec<_> = (0..90)
        .map(|f| {
            let mut row = standing_row(f as f64 / 30.0);
            row[4] = None; // the left ankle was never tracked
            row
        })
        .collect();
    write_csv(&gaps, 30.0, &rows);
    fails_with(&["gait", gaps.to_str().unwrap()], "gaps 3.00 s");

    if let Some(path) = trigait_test_data::shared_file("mocap-cmu-07_01/07_01.c3d") {
        // The first 0.9 s of the CMU walk, via a CSV export: one heel strike per foot at most.
        let full = dir.join("full.csv");
        let out = trigait(&[
            "export",
            path.to_str().unwrap(),
            "-o",
            full.to_str().unwrap(),
        ]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let text = std::fs::read_to_string(&full).unwrap();
        let short: Vec<&str> = text.lines().take(1 + 108).collect();
        let short_path = dir.join("short.csv");
        std::fs::write(&short_path, short.join("\n") + "\n").unwrap();
        // By default a walk without complete strides still gives figures from single steps;
        // with one heel strike there is not even a step. Asked for two strides, it has none.
        fails_with(
            &["gait", short_path.to_str().unwrap()],
            "found 0 complete strides and 0 steps, need at least one step",
        );
        fails_with(
            &["gait", short_path.to_str().unwrap(), "--min-strides", "2"],
            "complete strides, need at least 2",
        );
        // Ten NaN cells of the left ankle (83 ms, mid-stance) are a gap, counted, and bridged:
        // the strides around it survive.
        let column = text
            .lines()
            .next()
            .unwrap()
            .split(',')
            .position(|c| c == "ankle_left_x_m")
            .unwrap();
        let nan: Vec<String> = text
            .lines()
            .enumerate()
            .map(|(i, l)| {
                if (150..160).contains(&i) {
                    let mut cells: Vec<&str> = l.split(',').collect();
                    cells[column] = "NaN";
                    cells.join(",")
                } else {
                    l.to_owned()
                }
            })
            .collect();
        let nan_path = dir.join("nan.csv");
        std::fs::write(&nan_path, nan.join("\n") + "\n").unwrap();
        let out = trigait(&["gait", nan_path.to_str().unwrap(), "--json"]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        // The cleaning before event detection interpolates gaps up to 0.1 s and counts them in
        // `quality`; the bridged gap is no longer an excluded phase.
        let quality = &v["quality"];
        assert_eq!(quality["missing_samples"], 10, "{v}");
        assert_eq!(quality["bridged_samples"], 10, "{v}");
        assert_eq!(quality["remaining_gaps"], 0, "{v}");
        assert!(
            v["excluded"]
                .as_array()
                .unwrap()
                .iter()
                .all(|p| p["reason"] != "gap"),
            "{v}"
        );
        assert_eq!(v["heel_strikes"]["left"], 2);
        assert_eq!(v["heel_strikes"]["right"], 2);
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// Acceptance: the same walk through the simulated Kinect pipeline (thesis rig, Kinect
/// v2 noise, fusion estimator, 30 Hz, 6 Hz zero-lag Butterworth) gives stride length within
/// 3 cm, cadence within 2 % and step width within 2 cm of the marker parameters, for five noise
/// seeds of each walk, and finds the same heel strikes.
#[test]
fn kinect_pipeline_matches_markers() {
    for relative in [
        "mocap-cmu-07_01/07_01.c3d",
        "mocap-opensim-rajagopal-walk/Rajagopal__motion_capture_walk.trc",
    ] {
        let Some(path) = trigait_test_data::shared_file(relative) else {
            return;
        };
        for seed in ["1", "2", "3", "4", "5"] {
            let v = json(&path, &["--kinect-sim", "--seed", seed]);
            let k = &v["kinect_sim"];
            let c = &k["comparison"];
            let stride = c["stride_length_m"].as_f64().unwrap();
            let cadence = c["cadence_pct"].as_f64().unwrap();
            let width = c["step_width_m"].as_f64().unwrap();
            assert!(
                stride.abs() <= 0.03,
                "{relative} seed {seed}: stride {stride} m"
            );
            assert!(
                cadence.abs() <= 2.0,
                "{relative} seed {seed}: cadence {cadence} %"
            );
            assert!(
                width.abs() <= 0.02,
                "{relative} seed {seed}: step width {width} m"
            );
            assert_eq!(k["within_tolerances"], true);
            assert_eq!(
                k["heel_strikes"], v["heel_strikes"],
                "{relative} seed {seed}"
            );
        }
    }
}

/// Kinect text without time stamps is read at 30 Hz and its rhythm judged there: the Straight
/// log's swings are too quick for a human leg at that rate, which the JSON's `timing` and a
/// note say. `--rate` gives such a log its true clock; files that place their own frames (a
/// timed Kinect log, C3D) refuse it, and a rate that is not a rate is an error.
#[test]
fn an_untimed_log_gets_its_clock_checked_and_given() {
    let Some(straight) =
        trigait_test_data::shared_file("kinect-v2-skeleton-replay/JointsInfo_Straight.txt")
    else {
        return;
    };
    let assumed = json(&straight, &[]);
    assert_eq!(assumed["rate_hz"].as_f64(), Some(30.0));
    assert_eq!(assumed["timing"]["implausible"].as_bool(), Some(true));
    assert!(assumed["timing"]["median_swing_secs"].as_f64().unwrap() < 0.25);
    let text = trigait(&["gait", straight.to_str().unwrap()]);
    let stdout = String::from_utf8_lossy(&text.stdout);
    assert!(stdout.contains("TIMING IMPLAUSIBLE at 30 Hz"), "{stdout}");
    let bound = assumed["timing"]["highest_human_rate_hz"].as_f64().unwrap();
    assert!(bound < 30.0, "{}", assumed["timing"]);
    assert!(
        stdout.contains(&format!(
            "rhythm is human only if it was logged at about {bound:.0} Hz or less"
        )),
        "{stdout}"
    );
    assert!(
        stdout
            .contains("cadence (steps/min), speed (m/s), stride time (s) scale with the time base"),
        "{stdout}"
    );
    assert!(
        stdout.contains("rate assumed (--rate to give it)"),
        "{stdout}"
    );

    let given = json(&straight, &["--rate", "10"]);
    assert_eq!(given["rate_hz"].as_f64(), Some(10.0));
    let duration = given["duration_secs"].as_f64().unwrap();
    assert!((duration - 8.4).abs() < 1e-9, "{duration}");
    assert!(
        given["notes"]
            .as_array()
            .unwrap()
            .iter()
            .any(|n| n.as_str().unwrap().contains("rate given with --rate")),
        "{}",
        given["notes"]
    );

    fails_with(&["gait", "/tmp"], "is a directory");
    fails_with(&["gait", "walk.xyz"], ".txt) is read too");
    for bad in ["0", "nan", "1e9"] {
        fails_with(
            &["gait", straight.to_str().unwrap(), "--rate", bad],
            "1..=1000 Hz",
        );
    }
    if let Some(chu) =
        trigait_test_data::shared_file("kinect-v2-vicon-chu-walk/JointsInfo_before_CHU_test.txt")
    {
        fails_with(
            &["gait", chu.to_str().unwrap(), "--rate", "15"],
            "has time stamps",
        );
    }
    if let Some(cmu) = trigait_test_data::shared_file("mocap-cmu-07_01/07_01.c3d") {
        fails_with(
            &["gait", cmu.to_str().unwrap(), "--rate", "15"],
            "states its own rate",
        );
    }
}

/// A Kinect log whose last line a logger stopped writing midway (the Straight log cut inside
/// its line 59) is analysed as the log of its complete lines, with a note saying the line was
/// left out.
#[test]
fn a_log_cut_off_mid_line_is_read_to_its_last_complete_line() {
    let Some(straight) =
        trigait_test_data::shared_file("kinect-v2-skeleton-replay/JointsInfo_Straight.txt")
    else {
        return;
    };
    let text = std::fs::read_to_string(&straight).unwrap();
    let cut = &text[..40_000];
    let complete = &cut[..=cut.rfind('\n').unwrap()];
    assert_eq!(complete.lines().count(), 58);
    let dir = std::env::temp_dir().join(format!("trigait-gait-cut-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (cut_path, complete_path) = (dir.join("cut.txt"), dir.join("complete.txt"));
    std::fs::write(&cut_path, cut).unwrap();
    std::fs::write(&complete_path, complete).unwrap();
    let (a, b) = (json(&cut_path, &[]), json(&complete_path, &[]));
    let notes = a["notes"].as_array().unwrap();
    assert!(
        notes.iter().any(|n| n
            .as_str()
            .unwrap()
            .contains("the last line (59) stops midway")),
        "{notes:#?}"
    );
    assert_eq!(a["duration_secs"], b["duration_secs"]);
    assert_eq!(a["events"], b["events"]);
    assert_eq!(a["summary"], b["summary"]);
    let _ = std::fs::remove_dir_all(&dir);
}
