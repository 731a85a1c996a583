//! Malformed, truncated or incomplete input gives typed errors, never a panic.
#![allow(clippy::unwrap_used)] // tests may unwrap (STYLE.md §6); helpers outside #[test] fns need saying so

mod common;

use std::path::PathBuf;

use common::temp_path;
use trigait_motion::{Error, joint_centres, load_motion, read_c3d, read_markers, read_trc};

const CMU: &str = "mocap-cmu-07_01/07_01.c3d";
const RAJAGOPAL: &str = "mocap-opensim-rajagopal-walk/Rajagopal__motion_capture_walk.trc";

/// A file in the temp directory, removed when dropped.
struct TempFile(PathBuf);

impl TempFile {
    fn new(name: &str, bytes: &[u8]) -> Self {
        let path = temp_path(name);
        std::fs::write(&path, bytes).unwrap();
        Self(path)
    }
}

impl Drop for TempFile {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
    }
}

/// A TRC cut off after 100 of its 238 rows, or in the middle of a row, is `Truncated`.
#[test]
fn truncated_trc() {
    let Some(path) = trigait_test_data::shared_file(RAJAGOPAL) else {
        return;
    };
    let text = std::fs::read_to_string(path).unwrap();
    let rows: Vec<&str> = text.lines().collect();
    let cut = rows[..6 + 100].join("\n") + "\n";
    let file = TempFile::new("rows.trc", cut.as_bytes());
    match read_trc(&file.0) {
        Err(Error::Truncated { expected, got, .. }) => assert_eq!((expected, got), (238, 100)),
        other => panic!("expected Truncated, got {other:?}"),
    }
    let mid_row = &text[..text.len() / 2];
    let file = TempFile::new("midrow.trc", mid_row.as_bytes());
    assert!(matches!(
        read_trc(&file.0),
        Err(Error::Truncated { expected: 238, .. })
    ));
}

/// A repeated row, more rows than announced, or a partial row appended after them are errors
/// naming the line, not a clip whose later frames all sit one frame late.
#[test]
fn extra_or_repeated_trc_rows_name_the_line() {
    let Some(path) = trigait_test_data::shared_file(RAJAGOPAL) else {
        return;
    };
    let text = std::fs::read_to_string(path).unwrap();
    let rows: Vec<&str> = text.lines().collect();
    let with = |edit: &dyn Fn(&mut Vec<String>)| {
        let mut r: Vec<String> = rows.iter().map(|s| (*s).to_owned()).collect();
        edit(&mut r);
        r.join("\n")
    };
    let repeated = with(&|r| r.insert(100, r[99].clone())) + "\n";
    let appended = with(&|r| r.push("239\t2.3\t1.0".to_owned()));
    let file = TempFile::new("repeated.trc", repeated.as_bytes());
    match read_trc(&file.0) {
        Err(Error::Trc { line, reason, .. }) => {
            assert_eq!(line, 101, "{reason}");
            assert!(reason.contains("must increase"), "{reason}");
        }
        other => panic!("expected a Trc error, got {other:?}"),
    }
    let file = TempFile::new("appended.trc", appended.as_bytes());
    match read_trc(&file.0) {
        Err(Error::Trc { reason, .. }) => {
            assert!(reason.contains("after the 238 frames"), "{reason}");
        }
        other => panic!("expected a Trc error, got {other:?}"),
    }
}

/// A CSV row out of time order, off the rows' even spacing, or with a NaN time is an error
/// naming its line.
#[test]
fn csv_times_must_be_even_and_finite() {
    let walk = trigait_motion::walker(&trigait_motion::WalkerParams::default(), 2.0, 30.0).unwrap();
    let good = temp_path("good.csv");
    trigait_motion::write_csv(&good, &walk).unwrap();
    let text = std::fs::read_to_string(&good).unwrap();
    assert!(load_motion(&good).is_ok());
    std::fs::remove_file(&good).ok();
    let rows: Vec<&str> = text.lines().collect();
    let time_of =
        |line: usize| -> f64 { rows[line - 1].split(',').nth(1).unwrap().parse().unwrap() };
    // Line 11 moved 40 % of the way towards line 12: still in order, off the grid.
    let off_grid = format!("{:.6}", time_of(10) + 0.4 * (time_of(12) - time_of(10)));
    let with_time = |line: usize, time: &str| {
        let mut r: Vec<String> = rows.iter().map(|s| (*s).to_owned()).collect();
        let mut cells: Vec<&str> = rows[line - 1].split(',').collect();
        cells[1] = time;
        r[line - 1] = cells.join(",");
        r.join("\n") + "\n"
    };
    let before = rows[9].split(',').nth(1).unwrap().to_owned();
    for (time, needle) in [
        (before.as_str(), "must increase"),
        (off_grid.as_str(), "evenly spaced"),
        ("nan", "not a finite number"),
    ] {
        let file = TempFile::new("times.csv", with_time(11, time).as_bytes());
        match load_motion(&file.0) {
            Err(Error::Csv { line, reason, .. }) => {
                assert!(reason.contains(needle), "{time}: {reason}");
                assert_eq!(line, 11, "{time}: {reason}");
            }
            other => panic!("{time}: expected a Csv error, got {other:?}"),
        }
    }
    // The clock jumps 100 s forward at line 30: that line is named, with the real spacing.
    let jumped: Vec<String> = rows
        .iter()
        .enumerate()
        .map(|(i, row)| {
            let mut cells: Vec<String> = row.split(',').map(str::to_owned).collect();
            if i + 1 >= 30 {
                cells[1] = format!("{:.6}", time_of(i + 1) + 100.0);
            }
            cells.join(",")
        })
        .collect();
    let file = TempFile::new("jumped.csv", (jumped.join("\n") + "\n").as_bytes());
    match load_motion(&file.0) {
        Err(Error::Csv { line, reason, .. }) => {
            assert_eq!(line, 30, "{reason}");
            assert!(reason.contains("0.033333 s apart (median)"), "{reason}");
        }
        other => panic!("expected a Csv error, got {other:?}"),
    }
}

/// A number that is not a number names its line.
#[test]
fn malformed_trc_value_names_the_line() {
    let Some(path) = trigait_test_data::shared_file(RAJAGOPAL) else {
        return;
    };
    let text = std::fs::read_to_string(path).unwrap();
    let mut rows: Vec<String> = text.lines().map(String::from).collect();
    rows[9] = rows[9].replacen("\t-", "\tminus", 1);
    let file = TempFile::new("value.trc", (rows.join("\n") + "\n").as_bytes());
    match read_trc(&file.0) {
        Err(Error::Trc { line, reason, .. }) => {
            assert_eq!(line, 10);
            assert!(reason.contains("not a number"), "{reason}");
        }
        other => panic!("expected Trc error, got {other:?}"),
    }
}

/// Garbage with either extension is rejected by the right reader.
#[test]
fn garbage_files() {
    let noise: Vec<u8> = (0..5000u32)
        .map(|i| (i.wrapping_mul(2_654_435_761) >> 13) as u8)
        .collect();
    let c3d = TempFile::new("noise.c3d", &noise);
    assert!(matches!(read_c3d(&c3d.0), Err(Error::C3d { .. })));
    let trc = TempFile::new("noise.trc", &noise);
    assert!(matches!(read_trc(&trc.0), Err(Error::Trc { line: 1, .. })));
    let empty = TempFile::new("empty.c3d", b"");
    assert!(matches!(load_motion(&empty.0), Err(Error::C3d { .. })));
    assert!(matches!(
        read_markers(temp_path("does-not-exist.trc")),
        Err(Error::Io { .. })
    ));
}

/// A C3D cut short after its parameter section is an error (c3dio may keep the whole frames it
/// got; then we see fewer frames, never a panic).
#[test]
fn truncated_c3d() {
    let Some(path) = trigait_test_data::shared_file(CMU) else {
        return;
    };
    let bytes = std::fs::read(path).unwrap();
    for len in [600, 2000, bytes.len() / 2] {
        let file = TempFile::new(&format!("cut{len}.c3d"), &bytes[..len]);
        match read_c3d(&file.0) {
            Err(Error::C3d { .. }) => {}
            Ok(set) => assert!(set.frame_count() < 316, "cut at {len} still has all frames"),
            Err(other) => panic!("unexpected error {other:?}"),
        }
    }
}

/// A header whose frame rate disagrees with `POINT:RATE` is an error that says which is which
/// (c3dio's own text is `FrameRateMismatch(0.0, 120.0)`).
#[test]
fn c3d_rate_mismatch_is_said_in_words() {
    let Some(path) = trigait_test_data::shared_file(CMU) else {
        return;
    };
    let mut bytes = std::fs::read(path).unwrap();
    // Header words 11-12 (bytes 20..24): the frame rate, a float.
    bytes[20..24].copy_from_slice(&0.0_f32.to_le_bytes());
    let file = TempFile::new("rate0.c3d", &bytes);
    match read_c3d(&file.0) {
        Err(Error::C3d { reason, .. }) => {
            assert!(
                reason.contains("frame rate (0 Hz) disagrees with POINT:RATE (120 Hz)"),
                "{reason}"
            );
        }
        other => panic!("expected a C3d error, got {other:?}"),
    }
}

/// A `POINT:USED` that disagrees with the header's point count is refused, naming both.
#[test]
fn c3d_point_count_disagreement_is_refused() {
    let Some(path) = trigait_test_data::shared_file(CMU) else {
        return;
    };
    let mut bytes = std::fs::read(path).unwrap();
    // A group record is [name length, −id, name …], a parameter record [name length, id, name,
    // next offset (2 bytes), type, dimensions, data …].
    let find = |bytes: &[u8], name: &[u8], id: Option<i8>| {
        bytes.windows(name.len()).enumerate().position(|(i, w)| {
            i >= 2
                && w == name
                && usize::from(bytes[i - 2]) == name.len()
                && id.map_or((bytes[i - 1] as i8) < 0, |id| bytes[i - 1] as i8 == id)
        })
    };
    let point = find(&bytes, b"POINT", None).unwrap();
    let id = -(bytes[point - 1] as i8);
    let used = find(&bytes, b"USED", Some(id)).unwrap();
    bytes[used + 8..used + 10].copy_from_slice(&0_i16.to_le_bytes());
    let file = TempFile::new("used0.c3d", &bytes);
    match read_c3d(&file.0) {
        Err(Error::C3d { reason, .. }) => {
            assert!(
                reason.contains("POINT:USED says 0 points, the header 41"),
                "{reason}"
            );
        }
        other => panic!("expected a C3d error, got {other:?}"),
    }
}

/// An unknown extension is named in the error.
#[test]
fn unknown_extension() {
    match load_motion("walk.bvh") {
        Err(Error::UnknownExtension { extension, .. }) => assert_eq!(extension, "bvh"),
        other => panic!("expected UnknownExtension, got {other:?}"),
    }
    assert!(matches!(
        load_motion("walk"),
        Err(Error::UnknownExtension { extension, .. }) if extension.is_empty()
    ));
}

/// A recording without pelvis markers cannot give hip centres: `MissingMarker`.
#[test]
fn missing_pelvis_markers() {
    let Some(path) = trigait_test_data::shared_file(RAJAGOPAL) else {
        return;
    };
    let text = std::fs::read_to_string(path).unwrap();
    let renamed = text.replace("R.ASIS", "R.Hip1").replace("L.ASIS", "L.Hip1");
    let file = TempFile::new("nopelvis.trc", renamed.as_bytes());
    let set = read_trc(&file.0).unwrap();
    match joint_centres(&set) {
        Err(Error::MissingMarker { role, .. }) => assert_eq!(role, "left ASIS"),
        other => panic!("expected MissingMarker, got {other:?}"),
    }
    assert!(matches!(
        load_motion(&file.0),
        Err(Error::MissingMarker { .. })
    ));
}

/// The recorder's thesis-format text export is named for what it is when given as Kinect SDK
/// text, with the files of the same run to read instead.
#[test]
fn the_thesis_text_export_is_named() {
    let path = temp_path("trajectory.txt");
    std::fs::write(
        &path,
        format!(
            "{}\n# world frame, metres; columns: t_secs hip_left_x hip_left_y hip_left_z\n0.0 0.1 0.2 0.9\n",
            trigait_motion::THESIS_TEXT_HEADER
        ),
    )
    .unwrap();
    let text = trigait_motion::read_sdk_skeletons(&path)
        .unwrap_err()
        .to_string();
    assert!(
        text.contains("thesis-format export") && text.contains("trajectory.csv"),
        "{text}"
    );
}
