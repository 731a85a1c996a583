//! `trigait calibrate` as a command: its output, and how it ends when the reader goes away.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::process::{Command, Stdio};

fn trigait() -> Command {
    Command::new(env!("CARGO_BIN_EXE_trigait"))
}

/// Runs `args` with its stdout a pipe whose reader is already closed (`… | head -1` once head
/// has its line): the command ends as it would have, without a panic or an error.
fn survives_a_closed_pipe(args: &[&str]) {
    let mut child = trigait()
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{args:?}: {:?}\n{stderr}", out.status);
    assert!(
        !stderr.contains("panic") && !stderr.contains("error"),
        "{args:?}: {stderr}"
    );
}

/// `trigait calibrate --json | head -1` and the table the same way; `trigait eval` shares the
/// writer.
#[test]
fn closed_stdout_ends_quietly() {
    survives_a_closed_pipe(&["calibrate", "--json"]);
    survives_a_closed_pipe(&["calibrate"]);
    survives_a_closed_pipe(&["eval", "--trials", "1", "--json"]);
}
