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
