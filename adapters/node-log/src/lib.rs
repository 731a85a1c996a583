//! Logging for the `nodes/*` binaries: one [`tracing`] subscriber per node, and dora's input
//! drops reported as warnings.
//!
//! A node calls [`init`] once at the top of `main` and then logs with `tracing::warn!`,
//! `info!` and `error!` (structured fields where natural: `warn!(sensor = %id, "source
//! stopped")`). Each event becomes one line on **stderr**, which dora captures into its logs
//! and `dora run` prints after its own `HH:MM:SS stdout <node-id>:` prefix:
//!
//! ```text
//! WARN recorder: source stopped sensor=k2
//! WARN sync: dora_node_api::event_stream: discarding buffered input due to queue size limit input=frame_k2
//! ```
//!
//! The line names the node (the name given to [`init`], e.g. `kinect-source k2`) because dora
//! only knows the node id and a node run by hand has no prefix at all. Events of the
//! `trigait_*` crates need nothing more; events of other crates (dora, zenoh, rerun) also
//! name their target, so a warning from dora's event stream reads as dora's. There is no
//! timestamp: dora stamps every line it captures.
//!
//! The filter comes from `RUST_LOG` (`RUST_LOG=debug`, `RUST_LOG=info,trigait_sync_node=debug`)
//! and is [`DEFAULT_FILTER`] when `RUST_LOG` is unset or unreadable. A few warnings of dora and
//! zenoh are diagnostics, not faults, and came from every node at every start ([`DEMOTED`]: the
//! tracing of dora's first large sends, zenoh's scouting delay); they are treated as `debug`,
//! shown only when `RUST_LOG` lets `debug` through somewhere. Colours are used only
//! when stderr is a terminal. Records of the `log` crate (rerun logs through it) are
//! forwarded to the same subscriber.
//!
//! Installing a subscriber also makes dora-node-api's own `tracing` warnings visible — the
//! workspace builds it without its `tracing` feature, which only drops dora's own subscriber
//! set-up, not its events. Before, "event channel full; dropping zenoh input" and "discarding
//! buffered input due to queue size limit" went nowhere. [`warn_drops`] adds the totals: how
//! many messages dora dropped on each input since the last call.
//!
//! Errors that stop a node are not logged here: `main` returns them and dora prints them with
//! the node id (the graph tests check that the node and the key are named).

#![warn(missing_docs)]

use std::fmt;
use std::io::IsTerminal;

use dora_node_api::EventStream;
use dora_node_api::dora_core::config::DataId;
use tracing::field::{Field, Visit};
use tracing::level_filters::LevelFilter;
use tracing::{Event, Level, Subscriber};
use tracing_subscriber::EnvFilter;
use tracing_subscriber::fmt::format::Writer;
use tracing_subscriber::fmt::{FmtContext, FormatEvent, FormatFields, MakeWriter};
use tracing_subscriber::layer::{Context, Layer, SubscriberExt};
use tracing_subscriber::registry::LookupSpan;
use tracing_subscriber::util::SubscriberInitExt;

/// The filter when `RUST_LOG` is unset: our warnings and summaries, and zenoh (dora's
/// transport, chatty at `info`) only when something goes wrong.
pub const DEFAULT_FILTER: &str = "info,zenoh=warn";

/// A warning another crate logs that is a diagnostic, not a fault: events of a target starting
/// with `target` whose message contains `contains`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Demoted {
    /// Target prefix (`dora_node_api`).
    pub target: &'static str,
    /// Part of the message.
    pub contains: &'static str,
}

/// The warnings treated as `debug`. Matched on their text, because they share their target
/// with real warnings (`dora_node_api::node` also says when a publish failed and a message was
/// dropped, zenoh's orchestrator when it cannot connect):
/// - dora-node-api 1.1 traces each hop of a node's first three large sends at `warn`, tagged
///   `diagnostic` with the number of the dora issue it investigates (a Windows-only stall): six
///   to nine lines per output of every graph;
/// - zenoh warns in every process that its scouting delay elapsed before its start conditions
///   were met, which on one host (no peers to find) is always the case.
pub const DEMOTED: &[Demoted] = &[
    Demoted {
        target: "dora_node_api",
        contains: "#2742 diagnostic)",
    },
    Demoted {
        target: "zenoh::net::runtime::orchestrator",
        contains: "Scouting delay elapsed before start conditions are met",
    },
];

/// Installs the process's subscriber: one line per event on stderr, starting with the level
/// and `node` (`"sync"`, `"kinect-source k2"`), filtered by `RUST_LOG` (default
/// [`DEFAULT_FILTER`]). Call it once, first thing in `main`.
///
/// A second call (or another subscriber already installed) leaves the first in place and says
/// so on stderr: logging set-up never stops a node.
pub fn init(node: &str) {
    let filter = filter(std::env::var(EnvFilter::DEFAULT_ENV).ok().as_deref());
    let ansi = std::io::stderr().is_terminal();
    if let Err(e) = subscriber(node, filter, std::io::stderr, ansi).try_init() {
        // No subscriber of ours to report through.
        eprintln!("{node}: logging not set up: {e}");
    }
}

/// The filter for a `RUST_LOG` value: its directives, or [`DEFAULT_FILTER`] when it is unset,
/// blank or does not parse.
#[must_use]
pub fn filter(rust_log: Option<&str>) -> EnvFilter {
    rust_log
        .filter(|s| !s.trim().is_empty())
        .and_then(|s| EnvFilter::try_new(s).ok())
        .unwrap_or_else(|| EnvFilter::new(DEFAULT_FILTER))
}

/// The subscriber [`init`] installs, writing to `writer` (tests pass a buffer). The [`DEMOTED`]
/// warnings pass only if `filter` lets `debug` through for some target.
pub fn subscriber<W>(
    node: &str,
    filter: EnvFilter,
    writer: W,
    ansi: bool,
) -> impl Subscriber + Send + Sync + 'static
where
    W: for<'w> MakeWriter<'w> + Send + Sync + 'static,
{
    let demote = Demote {
        show: filter
            .max_level_hint()
            .is_some_and(|max| max >= LevelFilter::DEBUG),
    };
    tracing_subscriber::fmt()
        .with_writer(writer)
        .with_ansi(ansi)
        .event_format(NodeFormat {
            node: node.to_owned(),
        })
        .with_env_filter(filter)
        .finish()
        .with(demote)
}

/// Drops the [`DEMOTED`] events unless `show`.
struct Demote {
    show: bool,
}

impl<S: Subscriber> Layer<S> for Demote {
    fn event_enabled(&self, event: &Event<'_>, _ctx: Context<'_, S>) -> bool {
        self.show || !is_demoted(event)
    }
}

/// Whether `event` is one of the [`DEMOTED`] (errors never are).
fn is_demoted(event: &Event<'_>) -> bool {
    let meta = event.metadata();
    if *meta.level() == Level::ERROR {
        return false;
    }
    let mut candidates = DEMOTED
        .iter()
        .filter(|d| meta.target().starts_with(d.target))
        .peekable();
    if candidates.peek().is_none() {
        return false;
    }
    let mut message = Message(String::new());
    event.record(&mut message);
    candidates.any(|d| message.0.contains(d.contains))
}

/// The `message` field of an event, as text.
struct Message(String);

impl Visit for Message {
    fn record_str(&mut self, field: &Field, value: &str) {
        if field.name() == "message" {
            value.clone_into(&mut self.0);
        }
    }

    fn record_debug(&mut self, field: &Field, value: &dyn fmt::Debug) {
        if field.name() == "message" {
            self.0 = format!("{value:?}");
        }
    }
}

/// Logs a warning for every input on which dora dropped messages since the last call (queue
/// full: the node is slower than its inputs) and returns the counts, sorted by input id. Call
/// it once per turn of the event loop; the recorder also adds the counts to `summary.json`.
pub fn warn_drops(events: &mut EventStream) -> Vec<(DataId, u64)> {
    let mut drops: Vec<(DataId, u64)> = events
        .drain_drop_counts()
        .into_iter()
        .filter(|(_, n)| *n > 0)
        .collect();
    drops.sort_unstable_by(|a, b| a.0.as_str().cmp(b.0.as_str()));
    for (input, dropped) in &drops {
        tracing::warn!(%input, dropped, "dora dropped messages on this input (queue full)");
    }
    drops
}

/// `LEVEL node: [spans: ][target: ]message fields`.
struct NodeFormat {
    node: String,
}

impl<S, N> FormatEvent<S, N> for NodeFormat
where
    S: Subscriber + for<'a> LookupSpan<'a>,
    N: for<'a> FormatFields<'a> + 'static,
{
    fn format_event(
        &self,
        ctx: &FmtContext<'_, S, N>,
        mut writer: Writer<'_>,
        event: &Event<'_>,
    ) -> fmt::Result {
        let meta = event.metadata();
        let level = meta.level();
        if writer.has_ansi_escapes() {
            let colour = match *level {
                Level::ERROR => "31",
                Level::WARN => "33",
                Level::INFO => "32",
                Level::DEBUG => "34",
                Level::TRACE => "35",
            };
            write!(writer, "\x1b[{colour}m{level}\x1b[0m {}: ", self.node)?;
        } else {
            write!(writer, "{level} {}: ", self.node)?;
        }
        if let Some(scope) = ctx.event_scope() {
            for span in scope.from_root() {
                write!(writer, "{}: ", span.name())?;
            }
        }
        if !meta.target().starts_with("trigait") {
            write!(writer, "{}: ", meta.target())?;
        }
        ctx.format_fields(writer.by_ref(), event)?;
        writeln!(writer)
    }
}

#[cfg(test)]
mod tests {
    use std::sync::{Arc, Mutex};

    use super::*;

    /// A `MakeWriter` into a shared buffer.
    #[derive(Clone, Default)]
    struct Buffer(Arc<Mutex<Vec<u8>>>);

    impl std::io::Write for Buffer {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            self.0
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner)
                .extend_from_slice(buf);
            Ok(buf.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    impl<'w> MakeWriter<'w> for Buffer {
        type Writer = Self;
        fn make_writer(&'w self) -> Self {
            self.clone()
        }
    }

    fn logged(rust_log: Option<&str>, log: impl FnOnce()) -> String {
        let buffer = Buffer::default();
        let sub = subscriber("kinect-source k2", filter(rust_log), buffer.clone(), false);
        tracing::subscriber::with_default(sub, log);
        let bytes = buffer.0.lock().unwrap().clone();
        String::from_utf8(bytes).unwrap()
    }

    /// Every line starts with the level and the node; our own crates' events carry no target,
    /// other crates' events name theirs; fields follow the message.
    #[test]
    fn lines_name_the_node_and_foreign_targets() {
        let out = logged(None, || {
            tracing::warn!(sensor = %"k1", "source stopped");
            tracing::info!(target: "dora_node_api::event_stream", input = %"frame_k1", "event channel full");
            tracing::error!(target: "trigait_sync_node", "data lost");
        });
        assert_eq!(
            out,
            "WARN kinect-source k2: source stopped sensor=k1\n\
             INFO kinect-source k2: dora_node_api::event_stream: event channel full input=frame_k1\n\
             ERROR kinect-source k2: data lost\n"
        );
    }

    /// The default filter shows `info` and up, and zenoh only from `warn`; `RUST_LOG` replaces
    /// it, and a value that does not parse falls back to the default.
    #[test]
    fn filter_defaults_to_info_and_quiet_zenoh() {
        let emit = || {
            tracing::debug!("debug line");
            tracing::info!("info line");
            tracing::info!(target: "zenoh::net", "zenoh info");
            tracing::warn!(target: "zenoh::net", "zenoh warn");
        };
        let default = logged(None, emit);
        assert!(!default.contains("debug line"), "{default}");
        assert!(default.contains("info line"), "{default}");
        assert!(!default.contains("zenoh info"), "{default}");
        assert!(default.contains("zenoh warn"), "{default}");
        assert_eq!(logged(Some("  "), emit), default);
        assert_eq!(logged(Some("info,zenoh=[bad"), emit), default);
        let debug = logged(Some("debug"), emit);
        assert!(debug.contains("debug line"), "{debug}");
        assert!(debug.contains("zenoh info"), "{debug}");
    }

    /// dora's send diagnostics and zenoh's scouting delay are hidden by default and shown when
    /// `RUST_LOG` asks for `debug`; dora's and zenoh's other warnings, ours, and any error with
    /// the same words stay visible.
    #[test]
    fn diagnostics_are_debug_real_warnings_stay() {
        let emit = || {
            let output = "ground_truth";
            tracing::warn!(
                target: "dora_node_api::node",
                "output `{output}`: 4296 B -> zenoh direct path (dora-rs/dora#2742 diagnostic)"
            );
            tracing::warn!(
                target: "zenoh::net::runtime::orchestrator",
                "Scouting delay elapsed before start conditions are met."
            );
            tracing::warn!(
                target: "dora_node_api::node",
                "zenoh publish failed (closed); message dropped"
            );
            tracing::warn!(
                target: "dora_node_api::event_stream",
                input = %"frame_k1",
                "discarding buffered input due to queue size limit"
            );
            tracing::warn!(target: "zenoh::net::runtime::orchestrator", "Unable to connect");
            tracing::error!(
                target: "dora_node_api::node",
                "send stalled (dora-rs/dora#2742 diagnostic)"
            );
            tracing::warn!("source stopped");
        };
        let default = logged(None, emit);
        assert!(!default.contains("zenoh direct path"), "{default}");
        assert!(!default.contains("Scouting delay"), "{default}");
        for real in [
            "message dropped",
            "discarding buffered input due to queue size limit input=frame_k1",
            "Unable to connect",
            "ERROR kinect-source k2: dora_node_api::node: send stalled",
            "WARN kinect-source k2: source stopped",
        ] {
            assert!(default.contains(real), "{real}: {default}");
        }
        assert_eq!(default.lines().count(), 5, "{default}");
        let debug = logged(Some("info,trigait_sync_node=debug"), emit);
        assert!(debug.contains("zenoh direct path"), "{debug}");
        assert!(debug.contains("Scouting delay"), "{debug}");
        assert_eq!(debug.lines().count(), 7, "{debug}");
    }
}
