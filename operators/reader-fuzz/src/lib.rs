//! Tests only: `tests/fuzz.rs` feeds ≥ 10,000 mutants of the real recordings in
//! `../shared/data` (and of rig YAML) to every file reader and config parser of trigait, and
//! fails on any panic, any input slower than 10 s, and heap growth above its stated bound. It
//! lives in its own crate so that it builds from the readers alone, without the CLI's
//! dependencies.
