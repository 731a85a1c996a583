//! Standard output for every subcommand: a reader that closes the pipe early
//! (`trigait calibrate --json | head -1`) ends the command quietly instead of panicking, as
//! `println!` does on a broken pipe.

use std::io::Write;

use eyre::WrapErr;

/// Writes `text` to stdout; a closed pipe ends quietly (later writes are dropped the same way).
pub fn print(text: &str) -> eyre::Result<()> {
    let mut out = std::io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => {
            Err(e).wrap_err("writing to standard output")
        }
        _ => Ok(()),
    }
}

/// Writes `value` as pretty JSON and a newline.
pub fn print_json(value: &impl serde::Serialize) -> eyre::Result<()> {
    let text = serde_json::to_string_pretty(value).wrap_err("encoding the JSON report")?;
    print(&(text + "\n"))
}

/// `println!` through [`print`]: `outln!("…", args)?`.
macro_rules! outln {
    ($($arg:tt)*) => {
        $crate::stdout::print(&format!("{}\n", format_args!($($arg)*)))
    };
}
pub(crate) use outln;
