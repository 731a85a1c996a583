//! Checks on the files a subcommand writes.

use std::path::Path;

/// Refuses to write `output` when it is `input` (the same path, a link to it, or another name
/// of the same file): writing it would destroy what is being read.
///
/// # Errors
/// When they are the same file.
pub fn not_the_input(input: &Path, output: &Path) -> eyre::Result<()> {
    if same_file(input, output) {
        eyre::bail!(
            "refusing to write {}: it is the input file {} (pick another output path)",
            output.display(),
            input.display()
        );
    }
    Ok(())
}

/// Creates the folder `output` goes into when it does not exist yet (as `--plots` and
/// `legs --out` do for theirs).
///
/// # Errors
/// When it cannot be created.
pub fn create_parent(output: &Path) -> eyre::Result<()> {
    match output.parent() {
        Some(dir) if !dir.as_os_str().is_empty() && !dir.exists() => std::fs::create_dir_all(dir)
            .map_err(|e| {
                eyre::eyre!(
                    "creating the folder {} for {}: {e}",
                    dir.display(),
                    output.display()
                )
            }),
        _ => Ok(()),
    }
}

fn same_file(a: &Path, b: &Path) -> bool {
    let (Ok(ma), Ok(mb)) = (std::fs::metadata(a), std::fs::metadata(b)) else {
        return false;
    };
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        ma.dev() == mb.dev() && ma.ino() == mb.ino()
    }
    #[cfg(not(unix))]
    {
        let _ = (ma, mb);
        matches!(
            (std::fs::canonicalize(a), std::fs::canonicalize(b)),
            (Ok(x), Ok(y)) if x == y
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The same file under another name is refused; a new file or another file is not.
    #[test]
    fn the_input_is_not_overwritten() {
        let dir = std::env::temp_dir().join(format!("trigait-output-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let input = dir.join("walk.c3d");
        std::fs::write(&input, b"x").unwrap();
        let other = dir.join("other.c3d");
        std::fs::write(&other, b"y").unwrap();
        let err = not_the_input(&input, &dir.join(".").join("walk.c3d")).unwrap_err();
        assert!(err.to_string().contains("it is the input file"), "{err}");
        assert!(not_the_input(&input, &dir.join("new.html")).is_ok());
        assert!(not_the_input(&input, &other).is_ok());
        std::fs::remove_dir_all(&dir).ok();
    }
}
