//! Depth frames given on the command line, as `trigait depth-metrics` and `trigait legs` take
//! them: PNG files and directories of them, read one after the other with a progress bar.

use std::path::PathBuf;

use eyre::{WrapErr as _, bail};
use indicatif::{ProgressBar, ProgressStyle};
use trigait_depth::io::list_pngs;

/// Files as given, directories replaced by their PNGs in name order. A path that does not
/// exist is an error at once, before any frame is read (a typo should not cost a long run).
pub fn expand_inputs(inputs: &[PathBuf]) -> eyre::Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    for input in inputs {
        if !input.exists() {
            bail!("{}: no such file or directory", input.display());
        }
        if input.is_dir() {
            files.extend(list_pngs(input).wrap_err("listing the input directory")?);
        } else {
            files.push(input.clone());
        }
    }
    Ok(files)
}

/// A progress bar over `len` frames on stderr (drawn only on a terminal), labelled `what`;
/// hidden for a single frame.
pub fn progress(len: usize, what: &str) -> eyre::Result<ProgressBar> {
    let bar = if len > 1 {
        ProgressBar::new(len as u64)
    } else {
        ProgressBar::hidden()
    };
    bar.set_style(
        ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} frames ({elapsed})")
            .wrap_err("progress bar template")?
            .progress_chars("=> "),
    );
    bar.set_message(what.to_owned());
    Ok(bar)
}
