//! Mutation fuzzing of every file reader and config parser, run by `cargo test --release`.
//!
//! The corpus is built at test time from the real recordings in `../shared/data` (C3D, TRC,
//! PNG depth frames and masks, the Panoptic calibration JSON, Kinect SDK skeleton text), a CSV
//! that `write_csv` makes from one of them, and rig YAML (the repository's rig and a generated
//! ring). Each seed file gets a fixed number of mutants from a seeded generator (byte flips,
//! interesting 16-bit words in the header and parameter region, truncations, splices, numeric
//! and structural tokens in text, nesting bombs), so every run reads the same inputs.
//!
//! Every mutant is written to a file and given to its reader (and, for motion, the joint
//! centres after it) on a worker thread, inside `catch_unwind`. The run fails on any panic,
//! on any input that takes longer than [`TIMEOUT`], on fewer than [`MIN_INPUTS`] inputs, and when
//! the heap in use while one input is read grows by more than [`PEAK_BOUND_BYTES`] (measured
//! by the counting allocator below; one allocation larger than [`REFUSE_BYTES`] is refused, so a
//! reader that trusts a lying header aborts the test instead of the machine).
//!
//! Under `CI=true` a missing recording fails the test (via `trigait-test-data`); elsewhere the
//! kinds whose files are missing are skipped with a message.

// The counting allocator implements `GlobalAlloc`, an unsafe trait; it only forwards to the
// system allocator and counts.
#![allow(unsafe_code)]
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::alloc::{GlobalAlloc, Layout, System};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// Heap in use, bytes.
static LIVE: AtomicUsize = AtomicUsize::new(0);
/// Highest [`LIVE`] since the last reset.
static PEAK: AtomicUsize = AtomicUsize::new(0);

/// One allocation above this is refused (the test aborts with "memory allocation failed").
const REFUSE_BYTES: usize = 2 << 30;

/// Growth of the heap while one input is read, at most (the largest seed is 4.8 MB).
const PEAK_BOUND_BYTES: usize = 256 << 20;

/// One input may take this long.
const TIMEOUT: Duration = Duration::from_secs(10);

/// Fewest mutated inputs a run must read.
const MIN_INPUTS: usize = 10_000;

struct Counting;

// SAFETY: every call forwards to `System` with the caller's layout; the counters are atomics.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if layout.size() > REFUSE_BYTES {
            return std::ptr::null_mut();
        }
        // SAFETY: forwarded unchanged.
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            let live = LIVE.fetch_add(layout.size(), Ordering::Relaxed) + layout.size();
            PEAK.fetch_max(live, Ordering::Relaxed);
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: forwarded unchanged.
        unsafe { System.dealloc(ptr, layout) };
        LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if new_size > REFUSE_BYTES {
            return std::ptr::null_mut();
        }
        // SAFETY: forwarded unchanged.
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if !p.is_null() {
            if new_size >= layout.size() {
                let grown = new_size - layout.size();
                let live = LIVE.fetch_add(grown, Ordering::Relaxed) + grown;
                PEAK.fetch_max(live, Ordering::Relaxed);
            } else {
                LIVE.fetch_sub(layout.size() - new_size, Ordering::Relaxed);
            }
        }
        p
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// SplitMix64: a small deterministic generator, so the corpus needs no dependency.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// Which reader a file goes to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    C3d,
    Trc,
    Csv,
    Sdk,
    DepthPng,
    MaskPng,
    Calibration,
    Rig,
}

impl Kind {
    fn extension(self) -> &'static str {
        match self {
            Kind::C3d => "c3d",
            Kind::Trc => "trc",
            Kind::Csv => "csv",
            Kind::Sdk => "txt",
            Kind::DepthPng | Kind::MaskPng => "png",
            Kind::Calibration => "json",
            Kind::Rig => "yml",
        }
    }

    fn is_text(self) -> bool {
        matches!(
            self,
            Kind::Trc | Kind::Csv | Kind::Sdk | Kind::Calibration | Kind::Rig
        )
    }
}

/// Reads `path` with the reader of `kind`; `Ok` or `Err` both pass, only a panic fails.
fn read(kind: Kind, path: &Path) {
    match kind {
        Kind::C3d | Kind::Trc => {
            if let Ok(markers) = trigait_motion::read_markers(path) {
                let _ = trigait_motion::joint_centres(&markers);
            }
        }
        Kind::Csv => {
            let _ = trigait_motion::read_csv(path);
        }
        Kind::Sdk => {
            let _ = trigait_motion::read_sdk_log(path);
        }
        Kind::DepthPng => {
            let _ = trigait_depth::io::read_depth_png(path);
        }
        Kind::MaskPng => {
            let _ = trigait_depth::io::read_mask_png(path);
        }
        Kind::Calibration => {
            let _ = trigait_depth::panoptic::read_panoptic_calibration(path);
        }
        Kind::Rig => {
            let _ = trigait_rig::Rig::from_file(path);
        }
    }
}

/// CRC-32 (ISO-HDLC, as PNG uses), so that chunk-aware PNG mutants get past the checksum.
fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in bytes {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 == 1 {
                (crc >> 1) ^ 0xEDB8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

/// Mutates a byte inside one PNG chunk (IHDR most often) and fixes that chunk's CRC.
fn mutate_png_chunk(bytes: &mut [u8], rng: &mut Rng) {
    let mut chunks = Vec::new();
    let mut at = 8;
    while at + 12 <= bytes.len() {
        let len = u32::from_be_bytes(bytes[at..at + 4].try_into().unwrap()) as usize;
        if at + 12 + len > bytes.len() {
            break;
        }
        chunks.push((at, len));
        at += 12 + len;
    }
    if chunks.is_empty() {
        return;
    }
    // IHDR is the first chunk: mutate it half of the time.
    let (start, len) = if rng.below(2) == 0 {
        chunks[0]
    } else {
        chunks[rng.below(chunks.len())]
    };
    if len > 0 {
        let i = start + 8 + rng.below(len.min(64));
        bytes[i] = rng.next() as u8;
    }
    let crc = crc32(&bytes[start + 4..start + 8 + len]);
    bytes[start + 8 + len..start + 12 + len].copy_from_slice(&crc.to_be_bytes());
}

/// Tokens that break text parsers in interesting ways.
const TOKENS: [&str; 16] = [
    "",
    "NaN",
    "-inf",
    "1e308",
    "-1",
    "0",
    "4294967296",
    "18446744073709551616",
    "\t",
    "\n",
    ",",
    "[",
    "{",
    "\"",
    "&a",
    "*a",
];

/// Interesting 16-bit words for binary headers.
const WORDS: [u16; 9] = [0, 1, 2, 0x00ff, 0x0100, 0x7fff, 0x8000, 0xfffe, 0xffff];

/// One mutant of `seed`.
fn mutate(kind: Kind, seed: &[u8], rng: &mut Rng) -> Vec<u8> {
    let mut bytes = seed.to_vec();
    let structural = if kind == Kind::C3d {
        // Header and parameter section: where a C3D's sizes live.
        let parameter_end = (usize::from(u16::from_le_bytes([bytes[16], bytes[17]])))
            .saturating_sub(1)
            .saturating_mul(512);
        parameter_end.clamp(512, bytes.len())
    } else {
        bytes.len().min(4096)
    };
    match rng.below(if kind.is_text() { 7 } else { 5 }) {
        0 => {
            // One or two random bytes anywhere near the front.
            for _ in 0..=rng.below(2) {
                let i = rng.below(structural);
                bytes[i] = rng.next() as u8;
            }
        }
        1 => {
            // An interesting word at an even offset of the header/parameter region.
            let i = rng.below(structural.saturating_sub(1)) & !1;
            let w = WORDS[rng.below(WORDS.len())];
            let w = if rng.below(2) == 0 {
                w.to_le_bytes()
            } else {
                w.to_be_bytes()
            };
            bytes[i..i + 2].copy_from_slice(&w);
        }
        2 => bytes.truncate(rng.below(bytes.len())),
        3 => {
            // Splice: copy a run of bytes over another place.
            let n = 1 + rng.below(256);
            let from = rng.below(bytes.len().saturating_sub(n));
            let to = rng.below(bytes.len().saturating_sub(n));
            let run: Vec<u8> = bytes[from..(from + n).min(bytes.len())].to_vec();
            let end = (to + run.len()).min(bytes.len());
            bytes[to..end].copy_from_slice(&run[..end - to]);
        }
        4 => {
            if matches!(kind, Kind::DepthPng | Kind::MaskPng) {
                mutate_png_chunk(&mut bytes, rng);
            } else {
                let i = rng.below(bytes.len());
                bytes[i] ^= 1 << rng.below(8);
            }
        }
        5 => {
            // Replace a field (between separators) by a token, one to three times.
            for _ in 0..=rng.below(3) {
                let at = rng.below(bytes.len());
                let is_sep = |b: u8| matches!(b, b'\t' | b'\n' | b',' | b' ' | b':');
                let start = bytes[..at]
                    .iter()
                    .rposition(|&b| is_sep(b))
                    .map_or(0, |p| p + 1);
                let end = bytes[at..]
                    .iter()
                    .position(|&b| is_sep(b))
                    .map_or(bytes.len(), |p| at + p);
                let token = TOKENS[rng.below(TOKENS.len())].as_bytes();
                bytes.splice(start..end.max(start), token.iter().copied());
                if bytes.is_empty() {
                    break;
                }
            }
        }
        _ => {
            // Structure bombs: a line repeated, or deep nesting inserted.
            let at = rng.below(bytes.len());
            if rng.below(2) == 0 {
                let start = bytes[..at]
                    .iter()
                    .rposition(|&b| b == b'\n')
                    .map_or(0, |p| p + 1);
                let end = bytes[at..]
                    .iter()
                    .position(|&b| b == b'\n')
                    .map_or(bytes.len(), |p| at + p + 1);
                let line = bytes[start..end].to_vec();
                let copies = 1 + rng.below(2000);
                let mut grown = bytes[..end].to_vec();
                for _ in 0..copies {
                    grown.extend_from_slice(&line);
                }
                grown.extend_from_slice(&bytes[end..]);
                bytes = grown;
            } else {
                let open = [b"[".as_slice(), b"{a: ", b"- ", b"{\"a\":"][rng.below(4)];
                let depth = 1 + rng.below(100_000);
                let bomb: Vec<u8> = open
                    .iter()
                    .copied()
                    .cycle()
                    .take(open.len() * depth)
                    .collect();
                bytes.splice(at..at, bomb);
            }
        }
    }
    if bytes.is_empty() {
        bytes.push(b'\n');
    }
    bytes
}

/// A seed file and how many mutants it gets.
struct Seed {
    kind: Kind,
    name: String,
    bytes: Vec<u8>,
    mutants: usize,
}

/// The seeds; a missing recording is skipped outside CI and fails under CI.
fn seeds(scratch: &Path) -> Vec<Seed> {
    let mut seeds = Vec::new();
    let mut add = |kind: Kind, relative: &str, mutants: usize| {
        if let Some(path) = trigait_test_data::shared_file(relative) {
            seeds.push(Seed {
                kind,
                name: relative.to_owned(),
                bytes: std::fs::read(path).unwrap(),
                mutants,
            });
        }
    };
    add(Kind::C3d, "mocap-cmu-07_01/07_01.c3d", 4000);
    add(
        Kind::C3d,
        "mocap-biomechzoo-child-walk-fp/HC039A17.c3d",
        300,
    );
    add(Kind::C3d, "mocap-bts-walk-6fp/BTS.c3d", 200);
    add(Kind::C3d, "mocap-ktk-cgm2-walk-4fp/walk.c3d", 40);
    add(
        Kind::C3d,
        "mocap-gaitalytics-treadmill-walk/treadmill_events.c3d",
        40,
    );
    add(
        Kind::Trc,
        "mocap-opensim-rajagopal-walk/Rajagopal__motion_capture_walk.trc",
        1200,
    );
    add(
        Kind::Sdk,
        "kinect-v2-skeleton-replay/JointsInfo_Straight.txt",
        800,
    );
    add(
        Kind::DepthPng,
        "kinect-v2-panoptic-10-sensors/depth_00000.png",
        900,
    );
    add(
        Kind::DepthPng,
        "kinect-v2-depth-person/004378_depth.png",
        300,
    );
    add(Kind::MaskPng, "kinect-v2-depth-person/004378_mask.png", 600);
    add(
        Kind::Calibration,
        "kinect-v2-panoptic-10-sensors/kcalibration_171026_cello3.json",
        1200,
    );
    // A joint CSV made by our writer from a real recording.
    if let Some(cmu) = trigait_test_data::shared_file("mocap-cmu-07_01/07_01.c3d") {
        let clip = trigait_motion::load_motion(&cmu).unwrap();
        let csv = scratch.join("seed.csv");
        trigait_motion::write_csv(&csv, &clip).unwrap();
        seeds.push(Seed {
            kind: Kind::Csv,
            name: "07_01 joints as CSV".to_owned(),
            bytes: std::fs::read(&csv).unwrap(),
            mutants: 1000,
        });
    }
    // Rig YAML: the repository's rig, and a 16-sensor ring as the library writes it.
    let thesis = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../rigs/thesis.yml");
    seeds.push(Seed {
        kind: Kind::Rig,
        name: "rigs/thesis.yml".to_owned(),
        bytes: std::fs::read(thesis).unwrap(),
        mutants: 700,
    });
    let ring = trigait_rig::Rig::builtin("ring-16").unwrap();
    seeds.push(Seed {
        kind: Kind::Rig,
        name: "ring-16 as YAML".to_owned(),
        bytes: serde_yaml::to_string(&ring.to_rig_file())
            .unwrap()
            .into_bytes(),
        mutants: 500,
    });
    seeds
}

/// What one input did.
struct Outcome {
    label: String,
    panic: Option<String>,
    elapsed: Duration,
    peak_growth: usize,
}

/// Every reader survives ≥ 10,000 mutants of the real files: no panic, none slower than 10 s,
/// and the heap grows by at most 256 MiB while any one is read.
#[test]
fn readers_survive_mutated_real_files() {
    let scratch = std::env::temp_dir().join(format!("trigait-fuzz-{}", std::process::id()));
    std::fs::create_dir_all(&scratch).unwrap();
    let seeds = seeds(&scratch);
    if seeds.iter().all(|s| s.kind == Kind::Rig) {
        eprintln!("skipped: no recordings in ../shared/data (only the rig YAML would be fuzzed)");
        return;
    }
    // Panics are counted, not printed.
    std::panic::set_hook(Box::new(|_| {}));
    let started = Instant::now();
    let (tx, rx) = mpsc::channel::<Outcome>();
    let worker_dir = scratch.clone();
    let total: usize = seeds.iter().map(|s| s.mutants + 1).sum();
    let worker = std::thread::spawn(move || {
        for (s, seed) in seeds.iter().enumerate() {
            let mut rng = Rng(0x5EED_0000 + s as u64);
            for m in 0..=seed.mutants {
                // Mutant 0 is the seed itself: the readers must accept the real file.
                let bytes = if m == 0 {
                    seed.bytes.clone()
                } else {
                    mutate(seed.kind, &seed.bytes, &mut rng)
                };
                let path = worker_dir.join(format!("input.{}", seed.kind.extension()));
                std::fs::write(&path, &bytes).unwrap();
                drop(bytes);
                let base = LIVE.load(Ordering::Relaxed);
                PEAK.store(base, Ordering::Relaxed);
                let t = Instant::now();
                let result = catch_unwind(AssertUnwindSafe(|| read(seed.kind, &path)));
                let elapsed = t.elapsed();
                let peak_growth = PEAK.load(Ordering::Relaxed).saturating_sub(base);
                let panic = result.err().map(|p| {
                    p.downcast_ref::<&str>()
                        .map(|s| (*s).to_owned())
                        .or_else(|| p.downcast_ref::<String>().cloned())
                        .unwrap_or_default()
                });
                let label = format!("{} mutant {m}", seed.name);
                if tx
                    .send(Outcome {
                        label,
                        panic,
                        elapsed,
                        peak_growth,
                    })
                    .is_err()
                {
                    return;
                }
            }
        }
    });
    let mut panics = Vec::new();
    let mut inputs = 0;
    let mut slowest = (Duration::ZERO, String::new());
    let mut largest = (0, String::new());
    while inputs < total {
        let outcome = match rx.recv_timeout(TIMEOUT) {
            Ok(o) => o,
            Err(mpsc::RecvTimeoutError::Timeout) => {
                panic!("an input took more than {TIMEOUT:?} (after {inputs} inputs)")
            }
            Err(mpsc::RecvTimeoutError::Disconnected) => break,
        };
        inputs += 1;
        if let Some(message) = outcome.panic {
            panics.push(format!("{}: {message}", outcome.label));
        }
        if outcome.elapsed > slowest.0 {
            slowest = (outcome.elapsed, outcome.label.clone());
        }
        if outcome.peak_growth > largest.0 {
            largest = (outcome.peak_growth, outcome.label);
        }
    }
    worker.join().ok();
    let _ = std::panic::take_hook();
    std::fs::remove_dir_all(&scratch).ok();
    eprintln!(
        "fuzz: {inputs} inputs in {:.1} s, {} panics, slowest {:.3} s ({}), largest heap growth \
         {:.1} MiB ({})",
        started.elapsed().as_secs_f64(),
        panics.len(),
        slowest.0.as_secs_f64(),
        slowest.1,
        largest.0 as f64 / f64::from(1 << 20),
        largest.1
    );
    assert!(
        panics.is_empty(),
        "{} panics, first: {:#?}",
        panics.len(),
        &panics[..panics.len().min(20)]
    );
    assert!(inputs >= MIN_INPUTS, "only {inputs} inputs");
    assert!(
        largest.0 <= PEAK_BOUND_BYTES,
        "{} grew the heap by {} bytes",
        largest.1,
        largest.0
    );
}
