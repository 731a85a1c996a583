//! Limits on untrusted input files, applied before a parser sees them.
//!
//! A reader that trusts its input can be made to allocate without bound (a header that declares
//! more data than the file holds, a `/dev/zero` given as a file) or to spend minutes in a
//! parser (libyaml's cost grows with the square of the nesting depth: a 200 kB file nested
//! 100,000 deep took 50 s of CPU). Each reader of trigait therefore reads through
//! [`read_bounded`], with a limit that says how large its kind of file can sensibly be, and the
//! YAML/JSON readers check [`nesting_depth`] against [`MAX_NESTING`] before parsing.

use std::io::{self, Read};
use std::path::Path;

/// Deepest nesting a YAML or JSON configuration file may have, as [`nesting_depth`] counts it.
/// Rig files nest 4 deep; libyaml parses 64 levels in microseconds.
pub const MAX_NESTING: usize = 64;

/// Reads the whole file at `path` if it holds at most `max_bytes` bytes.
///
/// Never allocates more than `max_bytes + 1` bytes, also when the file's size is not known in
/// advance (a pipe, a device).
///
/// # Errors
/// The file cannot be opened or read, or it is larger than `max_bytes`
/// ([`io::ErrorKind::FileTooLarge`], the message names both sizes and `what` the file is).
pub fn read_bounded(path: &Path, max_bytes: u64, what: &str) -> io::Result<Vec<u8>> {
    let file = std::fs::File::open(path)?;
    let too_large = |size: Option<u64>| {
        let size = size.map_or_else(|| "more than that".to_owned(), |s| format!("{s} bytes"));
        io::Error::new(
            io::ErrorKind::FileTooLarge,
            format!("a {what} may have at most {max_bytes} bytes, this one has {size}"),
        )
    };
    let declared = file
        .metadata()
        .ok()
        .filter(|m| m.is_file())
        .map(|m| m.len());
    if let Some(len) = declared
        && len > max_bytes
    {
        return Err(too_large(Some(len)));
    }
    let capacity = declared.unwrap_or(0).min(max_bytes);
    let mut bytes = Vec::with_capacity(usize::try_from(capacity).unwrap_or(0));
    file.take(max_bytes.saturating_add(1))
        .read_to_end(&mut bytes)?;
    if bytes.len() as u64 > max_bytes {
        return Err(too_large(None));
    }
    Ok(bytes)
}

/// [`read_bounded`] for a text file: the bytes as UTF-8.
///
/// # Errors
/// As [`read_bounded`], and [`io::ErrorKind::InvalidData`] when the file is not UTF-8.
pub fn read_bounded_text(path: &Path, max_bytes: u64, what: &str) -> io::Result<String> {
    String::from_utf8(read_bounded(path, max_bytes, what)?)
        .map_err(|e| io::Error::new(io::ErrorKind::InvalidData, e.utf8_error()))
}

/// An upper estimate of how deeply YAML (or JSON, which is YAML's flow style) text nests.
///
/// Counted per line: the number of enclosing block indentation levels, plus each compact
/// indicator (`- `, `? `) that opens a nested collection on the line, plus the flow collections
/// (`[`, `{`) open at that point. Brackets inside quoted scalars and comments do not count. The
/// estimate is at least the depth a YAML parser reaches, and at most about twice it for
/// ordinary files, so a limit on it bounds the parser's work without rejecting sane files.
#[must_use]
pub fn nesting_depth(text: &str) -> usize {
    // Quote-unaware count as well: an upper bound on the flow depth if a quoted scalar were
    // misread as plain or the other way round, kept only for flow brackets that are not in a
    // comment. Taking the larger of the two leaves no way to hide nesting from both.
    let mut deepest = 0;
    let mut indents: Vec<usize> = Vec::new();
    let mut flow: usize = 0;
    let mut blind_flow: usize = 0;
    let mut quote: Option<char> = None;
    for line in text.lines() {
        let mut chars = line.char_indices().peekable();
        let indent = line.len() - line.trim_start_matches([' ', '\t']).len();
        let content = line[indent..].trim_end();
        let mut line_depth = 0;
        if quote.is_none() && flow == 0 && !content.is_empty() && !content.starts_with('#') {
            while indents.last().is_some_and(|&i| i >= indent) {
                indents.pop();
            }
            indents.push(indent);
            // Compact indicators at the start of the content: `- - x`, `- ? x`.
            let mut rest = content;
            while let Some(r) = rest
                .strip_prefix("- ")
                .or_else(|| rest.strip_prefix("? "))
                .or_else(|| rest.strip_prefix("-\t"))
            {
                line_depth += 1;
                rest = r.trim_start();
            }
        }
        let block_depth = indents.len() + line_depth;
        // The previous significant character on this line, for where quoted scalars start.
        let mut previous: Option<char> = None;
        let mut in_comment = false;
        while let Some((_, c)) = chars.next() {
            if in_comment {
                break;
            }
            match quote {
                Some('"') => {
                    if c == '\\' {
                        chars.next();
                    } else if c == '"' {
                        quote = None;
                    }
                }
                Some(_) => {
                    if c == '\'' {
                        if chars.peek().is_some_and(|&(_, n)| n == '\'') {
                            chars.next();
                        } else {
                            quote = None;
                        }
                    }
                }
                None => {
                    let at_token_start = previous.is_none_or(|p| {
                        p.is_whitespace() || matches!(p, '[' | '{' | ',' | ':' | '?' | '-')
                    });
                    match c {
                        '"' | '\'' if at_token_start => quote = Some(c),
                        '#' if previous.is_none_or(char::is_whitespace) => in_comment = true,
                        '[' | '{' => flow += 1,
                        ']' | '}' => flow = flow.saturating_sub(1),
                        _ => {}
                    }
                }
            }
            if !in_comment {
                match c {
                    '[' | '{' => blind_flow += 1,
                    ']' | '}' => blind_flow = blind_flow.saturating_sub(1),
                    _ => {}
                }
            }
            deepest = deepest.max(block_depth + flow.max(blind_flow));
            previous = Some(c);
        }
        deepest = deepest.max(block_depth + flow.max(blind_flow));
    }
    deepest
}

/// Checks `text` against [`MAX_NESTING`] and a byte limit before a YAML/JSON parser sees it.
///
/// # Errors
/// A message that says which limit the text exceeds.
pub fn check_config_text(text: &str, max_bytes: usize) -> Result<(), String> {
    if text.len() > max_bytes {
        return Err(format!(
            "{} bytes, more than the {max_bytes} a configuration file may have",
            text.len()
        ));
    }
    let depth = nesting_depth(text);
    if depth > MAX_NESTING {
        return Err(format!(
            "nested at least {depth} levels deep, more than the {MAX_NESTING} allowed"
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Ordinary rig YAML and JSON count a handful of levels.
    #[test]
    fn ordinary_files_are_shallow() {
        let rig = "name: lab\nsensors:\n  - id: k1\n    position: [-2.3, 2.1, 1.5]\n    look_at: [0, 0, 0.5] # aim\n  - id: k2\n    position: [1, 2, 3]\n";
        let d = nesting_depth(rig);
        assert!((3..=6).contains(&d), "{d}");
        let json = r#"{"sensors": [{"K": [[1, 2], [3, 4]], "name": "a]]]"}]}"#;
        // Five brackets deep, plus the line itself as a block node.
        assert_eq!(nesting_depth(json), 6);
    }

    /// Deep flow, block and compact nesting are all seen, also behind quotes and comments.
    #[test]
    fn deep_nesting_is_seen() {
        assert!(nesting_depth(&"[".repeat(1000)) >= 1000);
        assert!(nesting_depth(&"{a: ".repeat(1000)) >= 1000);
        assert!(nesting_depth(&"- ".repeat(1000)) >= 1000);
        let block: String = (0..200)
            .map(|i| format!("{}a{i}:\n", " ".repeat(i)))
            .collect();
        assert!(nesting_depth(&block) >= 200);
        // Closing brackets hidden in quoted scalars do not cancel real openings.
        assert!(nesting_depth(&"[ \"]\" ".repeat(500)) >= 500);
        // A quote inside a plain scalar does not swallow what follows.
        assert!(nesting_depth(&format!("a: it\"s\nb: {}", "[".repeat(500))) >= 500);
        assert!(check_config_text(&"[".repeat(100_000), 1 << 20).is_err());
        assert!(check_config_text("a: 1\n", 3).is_err());
    }

    /// Reads stop at the limit, with an error naming it.
    #[test]
    fn reads_are_bounded() {
        let dir = std::env::temp_dir().join(format!("input-limits-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("f.txt");
        std::fs::write(&file, "0123456789").unwrap();
        assert_eq!(read_bounded(&file, 10, "test file").unwrap().len(), 10);
        let err = read_bounded(&file, 9, "test file").unwrap_err();
        assert_eq!(err.kind(), io::ErrorKind::FileTooLarge);
        assert!(
            err.to_string().contains("at most 9 bytes, this one has 10"),
            "{err}"
        );
        if Path::new("/dev/zero").exists() {
            let err = read_bounded(Path::new("/dev/zero"), 1 << 16, "test file").unwrap_err();
            assert_eq!(err.kind(), io::ErrorKind::FileTooLarge);
        }
        std::fs::remove_dir_all(&dir).ok();
    }
}
