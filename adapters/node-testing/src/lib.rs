//! Test scaffolding shared by the `nodes/*` unit tests (a dev-dependency only).
//!
//! Every node reads its `env:` block through `Config::from_lookup(impl Fn(&str) ->
//! Option<String>)`, checks that its errors name node, key and value by searching the whole
//! `eyre` chain, and drives `run` through dora's `DoraNode::init_testing` (testing tier (b) in
//! dora's `integration_testing.rs`): messages go in as Arrow files ([`input_event`]), and
//! what the node sent comes back as the Arrow arrays it sent ([`output_arrays`]), so a loop
//! test decodes its outputs with the message's own `decode` and checks values. One copy keeps
//! the nodes' tests the same shape and their lookups the same semantics.

#![warn(missing_docs)]
// Test scaffolding: a set-up that cannot be built is a broken test, so it panics.
#![allow(clippy::expect_used)]

use dora_node_api::arrow_v59::array::ArrayRef;
use dora_node_api::integration_testing::{
    IntegrationTestInput, OutputJson, OutputReceiver, TestingInput, TestingOptions, TestingOutput,
    output_channel,
};
use dora_node_api::{DoraNode, Event, EventStream, serde_json};

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

/// The outputs a node sent on `id`, in order, as the Arrow arrays it sent, so a test can
/// decode them with the message's own `decode` and check values, not just a count.
///
/// dora's testing tier writes each output as JSON (`data` plus its `data_type`); the only
/// reader of that form is dora's own, the one that replays recorded inputs. So the outputs
/// are replayed, as inputs, into a throwaway testing node and read back from its events:
/// dora decodes them with the declared type (floats bit for bit, nulls kept), and no second
/// JSON-to-Arrow reader is needed here.
///
/// # Panics
/// If an output on `id` lacks `data` or `data_type`, or dora cannot read it back.
#[must_use]
pub fn output_arrays(outputs: &[OutputJson], id: &str) -> Vec<ArrayRef> {
    let mut events: Vec<serde_json::Value> = outputs
        .iter()
        .filter(|o| o.get("id").and_then(serde_json::Value::as_str) == Some(id))
        .map(|o| {
            serde_json::json!({
                "time_offset_secs": 0.0,
                "type": "Input",
                "id": id,
                "data": o.get("data").expect("an output with data"),
                "data_type": o.get("data_type").expect("an output with its data type"),
            })
        })
        .collect();
    let expected = events.len();
    events.push(serde_json::json!({"time_offset_secs": 0.0, "type": "Stop"}));
    let (_node, mut stream, _rx) = init_node(
        serde_json::json!({"id": "replay", "events": events}),
        TestingOptions::default(),
    );
    let mut arrays = Vec::with_capacity(expected);
    while let Some(event) = stream.recv() {
        if let Event::Input { data, .. } = event {
            arrays.push(data.as_array().clone());
        }
    }
    assert_eq!(arrays.len(), expected, "every output on {id} read back");
    arrays
}

/// How many outputs went out on `id`.
#[must_use]
pub fn output_count(outputs: &[OutputJson], id: &str) -> usize {
    outputs
        .iter()
        .filter(|o| o.get("id").and_then(serde_json::Value::as_str) == Some(id))
        .count()
}

/// A fresh, empty scratch folder for one test (`<tmp>/trigait-<name>-<pid>`), so tests
/// running in parallel, and reruns, do not see each other's files.
///
/// `<tmp>` is the memory-backed `/dev/shm` where there is one, else the system's temporary
/// folder: dora's testing daemon reads each event's data file at its delivery time, and on a
/// disk busy writing back (as after a fresh clone's build) those reads stalled the deliveries
/// enough to make a timed test's NTP round trips untrustworthy: with a 6 GB write-back beside
/// it, the sync node's loop test failed 2 of 3 runs from the disk and passed 4 of 4 from here.
///
/// # Panics
/// If the folder cannot be made.
#[must_use]
pub fn scratch_dir(name: &str) -> std::path::PathBuf {
    let folder = format!("trigait-{name}-{}", std::process::id());
    let fresh = |base: std::path::PathBuf| -> std::io::Result<std::path::PathBuf> {
        let dir = base.join(&folder);
        if dir.exists() {
            std::fs::remove_dir_all(&dir)?;
        }
        std::fs::create_dir_all(&dir)?;
        Ok(dir)
    };
    fresh(std::path::PathBuf::from("/dev/shm"))
        .or_else(|_| fresh(std::env::temp_dir()))
        .expect("creating the scratch folder")
}

/// One testing event delivering `array` on input `input` at `time_offset_secs`, its data
/// written to `<dir>/<name>.arrow` ([`arrow_file`]); `name` must be unique within `dir`.
///
/// # Panics
/// If the file cannot be written.
#[must_use]
pub fn input_event(
    dir: &std::path::Path,
    name: &str,
    time_offset_secs: f64,
    input: &str,
    array: ArrayRef,
) -> serde_json::Value {
    let path = arrow_file(dir, name, array);
    serde_json::json!({
        "time_offset_secs": time_offset_secs,
        "type": "Input",
        "id": input,
        "path": path,
        "column": "msg",
    })
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use dora_node_api::MetadataParameters;
    use dora_node_api::arrow_v59::array::{Array, Float64Array, Int64Array, StructArray};
    use dora_node_api::arrow_v59::datatypes::{DataType, Field};
    use dora_node_api::dora_core::config::DataId;
    use dora_node_api::integration_testing::drain_outputs;

    use super::*;

    /// What a node sends comes back as the same array: floats bit for bit (NaN, −0, the
    /// infinities, 1e50 that JSON writers tend to round), nulls as nulls, a struct as a
    /// struct, several outputs in the order sent, and nothing of another output id.
    #[test]
    fn outputs_read_back_exactly() {
        let values = [1.5, f64::NAN, -0.0, f64::INFINITY, 1e50, 0.1 + 0.2];
        let floats: ArrayRef = Arc::new(Float64Array::from(values.to_vec()));
        let structs: ArrayRef = Arc::new(StructArray::from(vec![
            (
                Arc::new(Field::new("seq", DataType::Int64, false)),
                Arc::new(Int64Array::from(vec![i64::MAX, -7])) as ArrayRef,
            ),
            (
                Arc::new(Field::new("x", DataType::Float64, true)),
                Arc::new(Float64Array::from(vec![Some(2.5), None])) as ArrayRef,
            ),
        ]));
        let (mut node, _events, mut rx) = init_node(
            serde_json::json!({"id": "sender", "events": [
                {"time_offset_secs": 0.0, "type": "Stop"}
            ]}),
            TestingOptions::default(),
        );
        for (id, array) in [("a", &floats), ("b", &structs), ("a", &structs)] {
            node.send_output(
                DataId::from(id.to_owned()),
                MetadataParameters::default(),
                array.clone(),
            )
            .expect("sending");
        }
        drop(node);
        let outputs = drain_outputs(&mut rx);
        assert_eq!(
            (output_count(&outputs, "a"), output_count(&outputs, "b")),
            (2, 1)
        );
        let a = output_arrays(&outputs, "a");
        assert_eq!(a.len(), 2);
        let back = a[0]
            .as_any()
            .downcast_ref::<Float64Array>()
            .expect("a Float64 array");
        let bits = |v: &[f64]| v.iter().map(|f| f.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(back.values()), bits(&values));
        assert_eq!(back.null_count(), 0);
        for s in [&a[1], &output_arrays(&outputs, "b")[0]] {
            assert_eq!(s.to_data(), structs.to_data(), "the struct read back");
        }
    }
}
