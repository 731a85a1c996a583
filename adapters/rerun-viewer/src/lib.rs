//! A live viewer as a rerun sink that does not hold up the node logging to it when no viewer
//! is there.
//!
//! rerun's own [`GrpcSink`] queues up to 100 messages while it connects and then makes every
//! further `send` wait until a viewer takes them: a recorder told to stream to a viewer that
//! is not running stopped logging within seconds (a message per entity per batch), its `.rrd`
//! (behind the same stream) stopped growing, and it never exited. [`ViewerSink`] hands the
//! gRPC client messages only while it is connected, plus a few while it first connects (the
//! blueprint and the first poses, for a viewer that is just starting). Everything else is
//! dropped and counted, with a warning at the first and the count at the end: the live view is
//! a view, and the file sink beside it keeps the whole run.
//!
//! Limits: rerun's client does not reconnect once a connection is lost, so a viewer closed
//! mid-run sees nothing more of it; and a viewer that is connected but stops reading can still
//! slow the node, since a connected client's queue (100 messages) waits for it.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use rerun::log::{ChunkBatcherConfig, LogMsg};
use rerun::sink::{GrpcSink, GrpcSinkConnectionState, LogSink, SinkFlushError};
use tracing::warn;

/// Messages handed to a client that has not connected yet: fewer than its queue of 100, so
/// that a flush still finds room in it.
pub const MAX_QUEUED_UNCONNECTED: u64 = 64;

/// A sink streaming to the viewer at `url` that drops what no connected viewer takes.
pub struct ViewerSink {
    grpc: GrpcSink,
    url: String,
    /// Messages handed to the client since it last was connected.
    queued_unconnected: AtomicU64,
    dropped: AtomicU64,
}

impl ViewerSink {
    /// Streams to the rerun proxy at `url` (e.g. `rerun+http://127.0.0.1:9876/proxy`).
    ///
    /// # Errors
    /// The url is not a rerun proxy url.
    pub fn new(url: &str) -> Result<Self, String> {
        let uri: rerun::external::re_uri::ProxyUri = url
            .parse()
            .map_err(|e| format!("{url:?} is not a rerun proxy url: {e}"))?;
        Ok(Self {
            grpc: GrpcSink::new(uri),
            url: url.to_owned(),
            queued_unconnected: AtomicU64::new(0),
            dropped: AtomicU64::new(0),
        })
    }

    fn connected(&self) -> bool {
        matches!(self.grpc.status(), GrpcSinkConnectionState::Connected)
    }
}

impl Drop for ViewerSink {
    /// Says how much the live view missed, when the stream closes.
    fn drop(&mut self) {
        let dropped = self.dropped.load(Ordering::Relaxed);
        if dropped > 0 {
            warn!(
                "{dropped} rerun messages for the viewer at {} were dropped: no viewer took them",
                self.url
            );
        }
    }
}

impl LogSink for ViewerSink {
    fn send(&self, msg: LogMsg) {
        let pass = match self.grpc.status() {
            GrpcSinkConnectionState::Connected => {
                self.queued_unconnected.store(0, Ordering::Relaxed);
                true
            }
            GrpcSinkConnectionState::Connecting { .. } => {
                self.queued_unconnected.fetch_add(1, Ordering::Relaxed) < MAX_QUEUED_UNCONNECTED
            }
            GrpcSinkConnectionState::Disconnected(_) => false,
        };
        if pass {
            self.grpc.send(msg);
        } else if self.dropped.fetch_add(1, Ordering::Relaxed) == 0 {
            warn!(
                "no rerun viewer takes the stream at {} (none connected, or it went away): the \
                 live view misses what follows (the .rrd, if one is written, keeps everything)",
                self.url
            );
        }
    }

    fn flush_blocking(&self, timeout: Duration) -> Result<(), SinkFlushError> {
        if self.connected() {
            self.grpc.flush_blocking(timeout)
        } else {
            // A flush command would wait in the client's queue for a viewer that is not there.
            Err(SinkFlushError::Failed {
                message: format!("no rerun viewer connected at {}", self.url),
            })
        }
    }

    fn default_batcher_config(&self) -> ChunkBatcherConfig {
        self.grpc.default_batcher_config()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// With nothing listening, logging and flushing return at once, and the file sink beside
    /// the viewer gets every row. (With rerun's plain `GrpcSink` in its place, the 101st
    /// message waits for a viewer for ever: the run is bounded here by a thread and a timeout.)
    #[test]
    fn no_viewer_blocks_nothing() {
        let dir = std::env::temp_dir().join(format!("trigait-viewer-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("run.rrd");
        let file_path = path.clone();
        let (done_tx, done_rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            // A port nothing listens on.
            let viewer = ViewerSink::new("rerun+http://127.0.0.1:9/proxy").unwrap();
            let file = rerun::sink::FileSink::new(&file_path).unwrap();
            let rec = rerun::RecordingStreamBuilder::new("trigait-test")
                .set_sinks(vec![
                    Box::new(file) as Box<dyn LogSink>,
                    Box::new(viewer) as Box<dyn LogSink>,
                ])
                .unwrap();
            // Many entities, as a recorder logs: each batch the stream sends is a message per
            // entity, so the client's queue of 100 fills within a few batches.
            for i in 0..4000 {
                rec.set_time_sequence("frame", i);
                rec.log(
                    format!("points/{}", i % 80),
                    &rerun::Points3D::new([[i as f32, 0.0, 0.0]]),
                )
                .unwrap();
                if i % 200 == 0 {
                    rec.flush_with_timeout(Duration::from_millis(200)).ok();
                }
            }
            rec.flush_blocking().ok();
            drop(rec);
            done_tx.send(()).ok();
        });
        done_rx
            .recv_timeout(Duration::from_secs(60))
            .expect("logging without a viewer did not finish within 60 s");
        let bytes = std::fs::metadata(&path).unwrap().len();
        assert!(bytes > 20_000, "the .rrd holds {bytes} bytes");
        std::fs::remove_dir_all(&dir).ok();
    }
}
