//! Where tests find the real recordings in `../shared/data` (see that folder's README).
//!
//! The recordings are never copied into the repository: tests read them in place, next to the
//! checkout. A developer without `shared/` beside the clone can still run the suite, the tests that
//! need a file skip with a message; CI sets `CI=true`, and then a missing file fails the test
//! loudly, so a broken checkout layout can never turn into a silently green run.
//!
//! ```no_run
//! let Some(c3d) = trigait_test_data::shared_file("mocap-cmu-07_01/07_01.c3d") else {
//!     return; // not in CI and the data is absent: skipped with a message on stderr
//! };
//! assert!(c3d.is_file());
//! ```

use std::path::{Path, PathBuf};

/// Environment variable that points at the `shared/data` folder when it is not beside the clone.
pub const SHARED_DATA_ENV: &str = "TRIGAIT_SHARED_DATA";

/// The `shared/data` folder: `$TRIGAIT_SHARED_DATA`, else `<workspace>/../shared/data`.
#[must_use]
pub fn shared_data_dir() -> PathBuf {
    if let Some(dir) = std::env::var_os(SHARED_DATA_ENV) {
        return PathBuf::from(dir);
    }
    // This crate lives at <workspace>/operators/test-data.
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data")
}

/// Whether we run under CI, where missing data is an error rather than a skip.
#[must_use]
pub fn under_ci() -> bool {
    std::env::var("CI").is_ok_and(|v| !v.is_empty() && v != "false" && v != "0")
}

/// The path of `relative` inside `shared/data`, if the file exists.
///
/// # Panics
/// Under CI (`CI=true`) when the file is missing, naming the path that was looked for.
#[must_use]
pub fn shared_file(relative: &str) -> Option<PathBuf> {
    let path = shared_data_dir().join(relative);
    if path.exists() {
        return Some(path);
    }
    assert!(
        !under_ci(),
        "CI=true but the recording {} is missing (looked for {}); CI needs ../shared/data beside \
         the clone, or {SHARED_DATA_ENV} pointing at it",
        relative,
        path.display()
    );
    eprintln!(
        "skipped: {} not found (set {SHARED_DATA_ENV} or put shared/ beside the clone)",
        path.display()
    );
    None
}
