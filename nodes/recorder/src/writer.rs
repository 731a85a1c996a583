//! The recorder's writer thread: it brings the files in `OUTPUT_DIR` up to date while the run
//! goes, so that no disk write, rename or sort runs on the event loop (a disk busy writing
//! back a large build stalled the poses behind such writes by up to 0.4 s).
//!
//! Every `LIVE_UPDATE_SECS` the event loop hands the thread what is new since the last update
//! ([`Update`]: the new `trajectory.csv` frames, the new lines of the raw recording, the
//! summary of the run so far without its percentiles and the samples they come from) over a
//! channel that holds one update. The thread appends and flushes the files, recomputes the
//! percentiles over every sample it was handed, renames `summary.json` into place
//! (`"complete": false`) and waits (at most [`RRD_FLUSH_TIMEOUT`]) for rerun's sinks to
//! write out what the recording holds.
//!
//! When the disk is slower than the data, the channel is full at the next update: the event
//! loop does not wait and does not queue a second update, it keeps the update and merges the
//! next ones into it ([`Handoff`], [`Coalesce`]) until the thread takes it. Nothing is dropped
//! (rows and lines are appended, samples extended, the newer summary replaces the older), so
//! the files catch up in one larger write once the disk does, and what waits in memory is only
//! what the disk has not taken yet. At the end the event loop hands over what is left, waiting
//! now, and joins the thread before the final files are written whole (`"complete": true`).

use std::sync::mpsc::{Receiver, SyncSender, TrySendError};
use std::time::Duration;

use eyre::Context;
use tracing::{error, warn};

use crate::export::{CsvRows, LiveCsv, write_summary};
use crate::recording::{Lines, Recording};
use crate::stats::{Samples, Summary};

/// The longest the thread waits for rerun's sinks at an update: a viewer that stalls delays
/// the other files by no more than this.
pub const RRD_FLUSH_TIMEOUT: Duration = Duration::from_secs(2);

/// Something that a newer one of its kind can be merged into, so that one value stands for
/// both (what a [`Handoff`] does when its receiver is behind).
pub trait Coalesce {
    /// Merges `newer` (handed on after `self`) into `self`.
    fn absorb(&mut self, newer: Self);
}

/// What is new since the last update.
#[derive(Debug, Default)]
pub struct Update {
    /// New frames of `trajectory.csv`.
    pub csv: CsvRows,
    /// New lines of the raw recording.
    pub lines: Lines,
    /// The samples that came since the last update.
    pub samples: Samples,
    /// The summary of the run so far, percentiles not filled in (`None`: leave `summary.json`).
    pub summary: Option<Summary>,
}

impl Coalesce for Update {
    fn absorb(&mut self, newer: Self) {
        self.csv.absorb(newer.csv);
        self.lines.absorb(newer.lines);
        self.samples.absorb(newer.samples);
        if newer.summary.is_some() {
            self.summary = newer.summary;
        }
    }
}

/// The sending side of a channel that holds one value, for a sender that must never wait:
/// a value the channel has no room for is kept, the next ones merged into it, and offered
/// again with each.
#[derive(Debug)]
pub struct Handoff<T> {
    tx: SyncSender<T>,
    waiting: Option<T>,
    coalesced: u64,
}

impl<T: Coalesce> Handoff<T> {
    /// Sends over `tx` (a `sync_channel(1)`).
    #[must_use]
    pub fn new(tx: SyncSender<T>) -> Self {
        Self {
            tx,
            waiting: None,
            coalesced: 0,
        }
    }

    /// Hands `value` on, merged after the value still waiting if there is one; never waits.
    /// Returns `false` once the receiver is gone (the value then waits for [`Self::finish`],
    /// which reports it).
    pub fn offer(&mut self, value: T) -> bool {
        let value = match self.waiting.take() {
            Some(mut older) => {
                older.absorb(value);
                self.coalesced += 1;
                older
            }
            None => value,
        };
        match self.tx.try_send(value) {
            Ok(()) => true,
            Err(TrySendError::Full(value)) => {
                self.waiting = Some(value);
                true
            }
            Err(TrySendError::Disconnected(value)) => {
                self.waiting = Some(value);
                false
            }
        }
    }

    /// Updates merged into an earlier one because the receiver was behind.
    #[must_use]
    pub fn coalesced(&self) -> u64 {
        self.coalesced
    }

    /// Hands on what is waiting merged with `last`, waiting for room, and closes the channel.
    ///
    /// # Errors
    /// When the receiver is gone.
    pub fn finish(mut self, last: T) -> eyre::Result<()> {
        let value = match self.waiting.take() {
            Some(mut older) => {
                older.absorb(last);
                older
            }
            None => last,
        };
        self.tx
            .send(value)
            .map_err(|_| eyre::eyre!("the receiving thread is gone"))
    }
}

/// What the thread writes to.
pub struct Files {
    /// The live `trajectory.csv`.
    pub csv: LiveCsv,
    /// The raw recording, when one is written.
    pub recording: Option<Recording>,
    /// The rerun recording (a clone of the event loop's: flushing it writes out what every
    /// clone logged).
    pub rec: rerun::RecordingStream,
    /// `OUTPUT_DIR`, for `summary.json`.
    pub dir: std::path::PathBuf,
}

/// How the thread's updates went.
#[derive(Debug, Clone, Copy, Default)]
pub struct Finished {
    /// Updates that failed to write.
    pub failed: u64,
    /// Updates merged into a later one because the thread was behind ([`Handoff::coalesced`]).
    pub coalesced: u64,
    /// Updates written.
    pub written: u64,
    /// The longest an update took on the thread (the `.rrd` flush included).
    pub longest_write: Duration,
}

/// The writer thread, seen from the event loop.
pub struct Writer {
    handoff: Handoff<Update>,
    thread: std::thread::JoinHandle<(Finished, eyre::Result<()>)>,
    gone_reported: bool,
}

impl Writer {
    /// Starts the thread on `files`.
    ///
    /// # Errors
    /// When the thread cannot be started.
    pub fn spawn(files: Files) -> eyre::Result<Self> {
        let (tx, rx) = std::sync::mpsc::sync_channel(1);
        let thread = std::thread::Builder::new()
            .name("recorder-writer".into())
            .spawn(move || write_loop(files, &rx))
            .context("starting the writer thread")?;
        Ok(Self {
            handoff: Handoff::new(tx),
            thread,
            gone_reported: false,
        })
    }

    /// Hands `update` to the thread without waiting ([`Handoff::offer`]).
    pub fn offer(&mut self, update: Update) {
        if !self.handoff.offer(update) && !self.gone_reported {
            self.gone_reported = true;
            error!("recorder: the writer thread stopped; the files are written at the end only");
        }
    }

    /// Hands over `last` with what is waiting, waits for the thread to write it and to end,
    /// and returns how many updates failed to write.
    ///
    /// # Errors
    /// When the last update could not be written, or the thread stopped before it (it
    /// panicked): the raw recording then lacks what it had not appended.
    pub fn finish(self, last: Update) -> eyre::Result<Finished> {
        let coalesced = self.handoff.coalesced();
        let handed = self.handoff.finish(last);
        let (mut finished, last) = self
            .thread
            .join()
            .map_err(|_| eyre::eyre!("the writer thread panicked"))?;
        handed.context("the writer thread stopped before the end")?;
        last?;
        finished.coalesced = coalesced;
        Ok(finished)
    }
}

/// The thread: applies each update as it comes, until the event loop closes the channel.
/// Returns how the updates went (the first failure is logged, later ones counted) and the
/// last one's result.
fn write_loop(mut files: Files, rx: &Receiver<Update>) -> (Finished, eyre::Result<()>) {
    let mut samples = Samples::default();
    let mut unwritten = Update::default();
    let mut finished = Finished::default();
    let mut unflushed = 0_u64;
    let mut last = Ok(());
    while let Ok(update) = rx.recv() {
        let started = std::time::Instant::now();
        unwritten.absorb(update);
        // The recording first, so that the summary never claims more than it holds. A viewer
        // that is not there fails this without waiting: warned once, not a failed update.
        if let Err(e) = files.rec.flush_with_timeout(RRD_FLUSH_TIMEOUT) {
            unflushed += 1;
            if unflushed == 1 {
                warn!("flushing the rerun recording (further failures not shown): {e}");
            }
        }
        last = write_update(&mut files, &mut unwritten, &mut samples);
        finished.written += 1;
        finished.longest_write = finished.longest_write.max(started.elapsed());
        if let Err(e) = &last {
            finished.failed += 1;
            if finished.failed == 1 {
                error!(
                    "recorder: updating the files while the run goes failed (further failures counted): {e:#}"
                );
            }
        }
    }
    (finished, last)
}

/// Writes `update` (what it still holds after a failure is retried with the next): the CSV
/// rows and recording lines appended, then `summary.json` with the percentiles over `samples`
/// (every sample handed over so far).
fn write_update(files: &mut Files, update: &mut Update, samples: &mut Samples) -> eyre::Result<()> {
    samples.absorb(std::mem::take(&mut update.samples));
    files.csv.append(&mut update.csv)?;
    if let Some(recording) = &mut files.recording {
        recording.append(&mut update.lines)?;
    }
    if let Some(mut summary) = update.summary.take() {
        samples.fill(&mut summary);
        write_summary(&files.dir, &summary)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    impl Coalesce for Vec<u32> {
        fn absorb(&mut self, newer: Self) {
            self.extend(newer);
        }
    }

    /// A receiver that is behind: the sender never waits, the values the channel had no room
    /// for are merged in order into one, and `finish` delivers it; nothing is lost or repeated.
    #[test]
    fn a_full_channel_coalesces_without_waiting_or_losing() {
        let (tx, rx) = std::sync::mpsc::sync_channel(1);
        let mut handoff = Handoff::new(tx);
        assert!(handoff.offer(vec![1]));
        // The channel is full: these wait, merged.
        assert!(handoff.offer(vec![2]));
        assert!(handoff.offer(vec![3, 4]));
        assert_eq!(handoff.coalesced(), 1);
        assert_eq!(rx.try_recv().unwrap(), vec![1]);
        // Room again: the merged value goes with the next one merged in.
        assert!(handoff.offer(vec![5]));
        assert_eq!(rx.try_recv().unwrap(), vec![2, 3, 4, 5]);
        assert!(rx.try_recv().is_err());
        assert!(handoff.offer(vec![6]));
        assert!(handoff.offer(vec![7]));
        let reader = std::thread::spawn(move || rx.iter().flatten().collect::<Vec<_>>());
        handoff.finish(vec![8]).unwrap();
        assert_eq!(reader.join().unwrap(), vec![6, 7, 8]);
    }

    /// A receiver that is gone: `offer` says so and keeps the value, `finish` fails.
    #[test]
    fn a_gone_receiver_is_reported() {
        let (tx, rx) = std::sync::mpsc::sync_channel(1);
        drop(rx);
        let mut handoff = Handoff::new(tx);
        assert!(!handoff.offer(vec![1]));
        assert!(handoff.finish(vec![2]).is_err());
    }

    /// Updates merged: CSV rows continue in frame order with the first batch's header, lines
    /// and samples are appended, the newest summary wins.
    #[test]
    fn updates_merge_in_order() {
        use nalgebra::Point3;
        use trigait_skeleton::Joint;
        let row = |x: f64| vec![Some(Point3::new(x, 0.0, 0.5))];
        let mut first = Update {
            csv: CsvRows {
                start: Some((vec![Joint::KneeLeft], 30.0)),
                first_frame: 0,
                rows: vec![row(0.0), row(1.0)],
            },
            ..Update::default()
        };
        first.absorb(Update {
            csv: CsvRows {
                start: None,
                first_frame: 2,
                rows: vec![row(2.0)],
            },
            ..Update::default()
        });
        assert_eq!(first.csv.start, Some((vec![Joint::KneeLeft], 30.0)));
        assert_eq!(first.csv.first_frame, 0);
        assert_eq!(first.csv.rows, vec![row(0.0), row(1.0), row(2.0)]);
        // After a write the rows are taken out; the next batch's frame number is kept.
        let mut written = CsvRows {
            start: None,
            first_frame: 3,
            rows: Vec::new(),
        };
        written.absorb(CsvRows {
            start: None,
            first_frame: 3,
            rows: vec![row(3.0)],
        });
        assert_eq!((written.first_frame, written.rows.len()), (3, 1));
    }
}
