//! `trigait` as an outside tester drives it with hostile input: numbers out of range, a C3D
//! header that lies about its size, a rig YAML nested 100,000 deep, and rigs on which nothing
//! can be solved. Each must end in one clear error line and a non-zero exit, fast, never in an
//! abort, a panic with a backtrace, or a table of NaN.
//!
//! The binary runs without `RUST_BACKTRACE` (the environment of a user who did not ask for
//! backtraces).

// Test helpers outside `#[test]` functions panic on failure by design.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::PathBuf;
use std::process::{Command, Output};
use std::time::{Duration, Instant};

fn trigait(args: &[&str]) -> (Output, Duration) {
    let started = Instant::now();
    let out = Command::new(env!("CARGO_BIN_EXE_trigait"))
        .args(args)
        .env_remove("RUST_BACKTRACE")
        .env_remove("RUST_LIB_BACKTRACE")
        .output()
        .expect("the trigait binary runs");
    (out, started.elapsed())
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("trigait-hostile-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// Asserts a failed run that printed `expected` and no panic or backtrace.
fn assert_clean_failure(out: &Output, expected: &str, what: &str) {
    let err = stderr(out);
    assert!(
        !out.status.success() && out.status.code().is_some(),
        "{what}: {:?}\n{err}",
        out.status
    );
    assert!(
        err.contains(expected),
        "{what}: expected {expected:?} in\n{err}"
    );
    for bad in [
        "panicked",
        "stack backtrace",
        "RUST_BACKTRACE=1` environment",
    ] {
        assert!(!err.contains(bad), "{what}: {bad:?} in\n{err}");
    }
}

/// Out-of-range numbers, negative ones written as separate arguments too, are clap errors
/// (exit 2) that state the range.
#[test]
fn out_of_range_numbers_are_clap_errors() {
    let cases: [(&[&str], &str); 17] = [
        (&["calibrate", "--lane-m", "-1"], "0..=10 m"),
        (&["calibrate", "--laps", "-3"], "1..=50"),
        (&["calibrate", "--turn-secs", "inf"], "0..=60 s"),
        (&["calibrate", "--turn-secs", "1e9"], "0..=60 s"),
        (&["calibrate", "--turn-secs", "nan"], "0..=60 s"),
        (&["calibrate", "--turn-secs=-1"], "0..=60 s"),
        (&["calibrate", "--laps", "100000"], "1..=50"),
        (&["calibrate", "--laps", "4294967295"], "1..=50"),
        (&["calibrate", "--lane-m", "nan"], "0..=10 m"),
        (&["eval", "--duration-secs", "1e9"], "0.1..=600 s"),
        (&["eval", "--duration-secs", "NaN"], "0.1..=600 s"),
        (&["eval", "--rate-hz", "1e9"], "1..=1000 Hz"),
        (&["eval", "--trials", "4294967296"], "1..=10000"),
        (&["eval", "--threads", "0"], "1..=256"),
        (
            &["depth-metrics", "x.png", "--entropy-window", "4294967296"],
            "2..=1000",
        ),
        (
            &[
                "depth-metrics",
                "x.png",
                "--entropy-window",
                "18446744073709551615",
            ],
            "2..=1000",
        ),
        (&["bench", "--problems", "0"], "1..=1000000"),
    ];
    for (args, range) in cases {
        let (out, elapsed) = trigait(args);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {}", stderr(&out));
        assert_clean_failure(&out, range, &format!("{args:?}"));
        assert!(
            elapsed < Duration::from_secs(5),
            "{args:?} took {elapsed:?}"
        );
    }
    // The help says the ranges too.
    let (out, _) = trigait(&["eval", "--help"]);
    let help = String::from_utf8_lossy(&out.stdout);
    assert!(
        help.contains("1 to 10,000") && help.contains("0.1 to 600"),
        "{help}"
    );
}

/// A C3D header claiming 32767 points × 32767 frames is refused before anything is allocated,
/// by every command that reads motion.
#[test]
fn lying_c3d_header_is_a_clean_error() {
    let Some(cmu) = trigait_test_data::shared_file("mocap-cmu-07_01/07_01.c3d") else {
        return;
    };
    let mut bytes = std::fs::read(cmu).unwrap();
    // Word 2: points per frame; word 4/5: first/last frame (Intel byte order).
    bytes[2..4].copy_from_slice(&32767u16.to_le_bytes());
    bytes[6..8].copy_from_slice(&1u16.to_le_bytes());
    bytes[8..10].copy_from_slice(&32767u16.to_le_bytes());
    let file = scratch("lying.c3d");
    std::fs::write(&file, &bytes).unwrap();
    let path = file.to_str().unwrap();
    let out_file = scratch("out.csv");
    for args in [
        vec!["gait", path],
        vec!["eval", "--motion", path, "--trials", "1"],
        vec!["export", path, "-o", out_file.to_str().unwrap()],
    ] {
        let (out, elapsed) = trigait(&args);
        assert_clean_failure(&out, "points per frame", &format!("{args:?}"));
        assert_eq!(
            stderr(&out).lines().count(),
            1,
            "{args:?}: one line: {}",
            stderr(&out)
        );
        assert!(
            elapsed < Duration::from_secs(5),
            "{args:?} took {elapsed:?}"
        );
    }
    // The frames alone, with a plausible point count, are checked against the file too.
    let mut bytes =
        std::fs::read(trigait_test_data::shared_file("mocap-cmu-07_01/07_01.c3d").unwrap())
            .unwrap();
    bytes[8..10].copy_from_slice(&32767u16.to_le_bytes());
    std::fs::write(&file, &bytes).unwrap();
    let (out, _) = trigait(&["gait", path]);
    assert_clean_failure(&out, "the data section holds", "frames beyond the file");
}

/// A 200 kB rig YAML nested 100,000 deep fails in well under a second with a clear error.
#[test]
fn deeply_nested_rig_yaml_fails_fast() {
    let file = scratch("deep.yml");
    let text = format!("sensors: {}\n", "[".repeat(100_000) + &"]".repeat(100_000));
    std::fs::write(&file, &text).unwrap();
    let (out, elapsed) = trigait(&["eval", "--rig", file.to_str().unwrap(), "--trials", "1"]);
    assert_clean_failure(&out, "nested", "deep rig");
    assert!(elapsed < Duration::from_secs(2), "took {elapsed:?}");
}

/// `eval` on rigs where no sample is solved by every method exits non-zero and says which
/// method solved what and why; no table of NaN is printed.
#[test]
fn eval_with_nothing_solvable_is_an_error() {
    let collinear = scratch("collinear.yml");
    std::fs::write(
        &collinear,
        "sensors:\n\
         \x20 - {id: a, position: [-2.0, 2.5, 1.5], look_at: [0, 0, 0.5]}\n\
         \x20 - {id: b, position: [0.0, 2.5, 1.5], look_at: [0, 0, 0.5]}\n\
         \x20 - {id: c, position: [2.0, 2.5, 1.5], look_at: [0, 0, 0.5]}\n",
    )
    .unwrap();
    let collinear = collinear.to_str().unwrap().to_owned();
    for args in [
        vec!["eval", "--rig", collinear.as_str(), "--trials", "1"],
        vec!["eval", "--rig", "thesis", "--sensors", "2", "--trials", "1"],
        vec!["eval", "--rig", "thesis", "--sensors", "1", "--trials", "1"],
    ] {
        let (out, _) = trigait(&args);
        assert_clean_failure(
            &out,
            "no joint sample was solved by every method",
            &format!("{args:?}"),
        );
        let err = stderr(&out);
        assert!(
            err.contains("linear solved") && err.contains("fusion solved"),
            "{err}"
        );
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(!stdout.contains("NaN"), "{stdout}");
    }
}

/// A recording whose frames carry no server stamp (no `sync` ahead of the recorder) is refused
/// with that reason, not with "too little motion", whether the directory or its frames file is
/// given; the simulation's options beside `--recording` are refused, not ignored.
#[test]
fn calibrate_says_what_a_recording_lacks() {
    let dir = scratch("unsynced");
    std::fs::create_dir_all(&dir).unwrap();
    let mut text = format!("{}\n", trigait_recording::FRAMES_HEADER);
    for seq in 0..30_i64 {
        for sensor in ["k1", "k2"] {
            text.push_str(&format!(
                "{sensor},{seq},{},,,,,,,hip_left,0.1,0.2,2.5,2\n",
                seq * 33_333_333
            ));
        }
    }
    let frames = dir.join(trigait_recording::FRAMES_FILE);
    std::fs::write(&frames, text).unwrap();
    for given in [&dir, &frames] {
        let (out, elapsed) = trigait(&["calibrate", "--recording", given.to_str().unwrap()]);
        assert_clean_failure(
            &out,
            "none of its 60 frames has a server stamp",
            &given.display().to_string(),
        );
        assert!(elapsed < Duration::from_secs(5), "took {elapsed:?}");
    }
    let (out, _) = trigait(&[
        "calibrate",
        "--recording",
        dir.to_str().unwrap(),
        "--laps",
        "3",
    ]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert_clean_failure(&out, "cannot be used with", "--laps beside --recording");
}

/// A walk in millimetres whose file says metres is refused, naming the likely unit, by the
/// commands that read motion; the same walk in metres is read.
#[test]
fn a_walk_in_millimetres_is_named_as_such() {
    let clip = trigait_motion::walker(&trigait_motion::WalkerParams::default(), 4.0, 30.0).unwrap();
    let metres = scratch("walk_m.csv");
    trigait_motion::write_csv(&metres, &clip).unwrap();
    let text = std::fs::read_to_string(&metres).unwrap();
    let mut lines = text.lines();
    let mut scaled = format!("{}\n", lines.next().unwrap());
    for line in lines {
        let cells: Vec<String> = line
            .split(',')
            .enumerate()
            .map(|(i, c)| match c.parse::<f64>() {
                Ok(v) if i >= 2 => format!("{:.3}", v * 1000.0),
                _ => c.to_owned(),
            })
            .collect();
        scaled.push_str(&cells.join(","));
        scaled.push('\n');
    }
    let millimetres = scratch("walk_mm.csv");
    std::fs::write(&millimetres, scaled).unwrap();
    let out_file = scratch("walk_out.trc");
    let mm = millimetres.to_str().unwrap();
    for args in [
        vec!["gait", mm],
        vec!["export", mm, "-o", out_file.to_str().unwrap()],
    ] {
        let (out, _) = trigait(&args);
        assert_clean_failure(
            &out,
            "are the coordinates in millimetres?",
            &format!("{args:?}"),
        );
    }
    let (out, _) = trigait(&[
        "export",
        metres.to_str().unwrap(),
        "-o",
        out_file.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
}
