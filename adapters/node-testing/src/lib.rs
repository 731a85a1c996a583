//! Test scaffolding shared by the `nodes/*` unit tests (a dev-dependency only).
//!
//! Every node reads its `env:` block through `Config::from_lookup(impl Fn(&str) ->
//! Option<String>)`, checks that its errors name node, key and value by searching the whole
//! `eyre` chain, and drives `run` through dora's `DoraNode::init_testing` (testing tier (b) in
//! dora's `integration_testing.rs`). These helpers were copied into each node's `tests.rs`;
//! one copy keeps the nodes' tests the same shape and their lookups the same semantics.

#![warn(missing_docs)]
// Test scaffolding: a set-up that cannot be built is a broken test, so it panics.
#![allow(clippy::expect_used)]

use dora_node_api::integration_testing::{
    IntegrationTestInput, OutputReceiver, TestingInput, TestingOptions, TestingOutput,
    output_channel,
};
use dora_node_api::{DoraNode, EventStream, serde_json};

/// An env lookup over `key = value` pairs, standing in for the process environment so tests
/// never touch it. When a key appears twice, the first pair wins (a test can put a bad value
/// in front of a default).
pub fn lookup(pairs: &[(&str, &str)]) -> impl Fn(&str) -> Option<String> + use<> {
    let pairs: Vec<(String, String)> = pairs
        .iter()
        .map(|(k, v)| ((*k).to_owned(), (*v).to_owned()))
        .collect();
    move |key| pairs.iter().find(|(k, _)| k == key).map(|(_, v)| v.clone())
}

/// The whole error chain joined by `": "`, as `{:#}` prints it, so a test can look for the
/// node, key and value wherever the context put them.
#[must_use]
pub fn chain(err: &eyre::Report) -> String {
    err.chain()
        .map(ToString::to_string)
        .collect::<Vec<_>>()
        .join(": ")
}

/// A node fed the events of `input` (an `IntegrationTestInput` as JSON: `{"id": …,
/// "events": […]}`), its outputs sent to the returned receiver (read it with
/// `drain_outputs`). Keep the receiver alive while the node runs.
///
/// # Panics
/// If `input` is not a valid `IntegrationTestInput` or dora's testing set-up fails.
#[must_use]
pub fn init_node(
    input: serde_json::Value,
    options: TestingOptions,
) -> (DoraNode, EventStream, OutputReceiver) {
    let input: IntegrationTestInput =
        serde_json::from_value(input).expect("events are a valid IntegrationTestInput");
    let (tx, rx) = output_channel();
    let (node, events) = DoraNode::init_testing(
        TestingInput::Input(input),
        TestingOutput::ToChannel(tx),
        options,
    )
    .expect("dora's init_testing");
    (node, events, rx)
}

/// Writes `array` as a one-column Arrow IPC file `<dir>/<name>.arrow` (column `msg`), the form
/// a testing event takes real message data in: `{"type": "Input", "id": …, "path": <file>,
/// "column": "msg"}`.
///
/// # Panics
/// If the file cannot be written.
#[must_use]
pub fn arrow_file(
    dir: &std::path::Path,
    name: &str,
    array: dora_node_api::arrow_v59::array::ArrayRef,
) -> std::path::PathBuf {
    use dora_node_api::arrow_v59::array::RecordBatch;
    use dora_node_api::arrow_v59::datatypes::{Field, Schema};
    use dora_node_api::arrow_v59::ipc::writer::FileWriter;
    let path = dir.join(format!("{name}.arrow"));
    let schema = std::sync::Arc::new(Schema::new(vec![Field::new(
        "msg",
        array.data_type().clone(),
        false,
    )]));
    let batch = RecordBatch::try_new(schema.clone(), vec![array]).expect("one column batch");
    let file = std::fs::File::create(&path).expect("creating the arrow file");
    let mut writer = FileWriter::try_new(file, &schema).expect("an arrow file writer");
    writer.write(&batch).expect("writing the batch");
    writer.finish().expect("finishing the arrow file");
    path
}
