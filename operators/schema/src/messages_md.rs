//! Keeps `MESSAGES.md`, the language-neutral message reference a stage in another language is
//! written from, honest: every field its tables list must be a field of the message's
//! [`Message::data_type`] with the same Arrow type and nullability, and every field of every
//! message must be listed, with the unit and frame its name promises (`_nanos` is ns,
//! `position_in_world_m` is metres in the world frame); likewise its joint, tracking-state, port
//! and metadata-key tables against [`Joint`], [`TrackingState`] and [`crate::ports`]. A schema
//! change without a doc change fails here, naming the field.

use std::collections::{BTreeMap, BTreeSet};

use arrow_schema::{DataType, Fields};
use trigait_skeleton::{Joint, TrackingState};

use crate::{
    DepthFrameMessage, FrameTiming, FusedPose, GroundTruth, IrFrameMessage, Message, NtpExchange,
    SensorStatus, SkeletonFrameMessage, ports,
};

const DOC: &str = include_str!("../MESSAGES.md");

/// Every message type, by name, with its Arrow type.
fn messages() -> BTreeMap<&'static str, DataType> {
    BTreeMap::from([
        (
            SkeletonFrameMessage::NAME,
            SkeletonFrameMessage::data_type(),
        ),
        (GroundTruth::NAME, GroundTruth::data_type()),
        (NtpExchange::NAME, NtpExchange::data_type()),
        (FrameTiming::NAME, FrameTiming::data_type()),
        (
            trigait_sync::AlignedSet::NAME,
            trigait_sync::AlignedSet::data_type(),
        ),
        (FusedPose::NAME, FusedPose::data_type()),
        (DepthFrameMessage::NAME, DepthFrameMessage::data_type()),
        (SensorStatus::NAME, SensorStatus::data_type()),
        (IrFrameMessage::NAME, IrFrameMessage::data_type()),
    ])
}

/// A type in the doc's notation: `UInt8`, `List<Utf8>`, `List<Struct>` (its fields are rows of
/// their own), `FixedSizeList<Float64, 3>`. A nullable list item is `T?`, an item field not named
/// `item` is `name: T`, so neither can pass for the usual ones.
fn render(data_type: &DataType) -> String {
    let item = |f: &arrow_schema::Field| {
        let name = if f.name() == "item" {
            String::new()
        } else {
            format!("{}: ", f.name())
        };
        let null = if f.is_nullable() { "?" } else { "" };
        format!("{name}{}{null}", render(f.data_type()))
    };
    match data_type {
        DataType::Struct(_) => "Struct".to_owned(),
        DataType::List(f) => format!("List<{}>", item(f)),
        DataType::FixedSizeList(f, n) => format!("FixedSizeList<{}, {n}>", item(f)),
        other => format!("{other:?}"),
    }
}

/// The struct fields inside `data_type`, through any lists.
fn children(data_type: &DataType) -> Option<&Fields> {
    match data_type {
        DataType::Struct(fields) => Some(fields),
        DataType::List(f) | DataType::FixedSizeList(f, _) => children(f.data_type()),
        _ => None,
    }
}

/// Dotted path → (type, nullable) of every field, nested ones included.
fn flatten(prefix: &str, fields: &Fields, out: &mut BTreeMap<String, (String, bool)>) {
    for f in fields {
        let path = if prefix.is_empty() {
            f.name().clone()
        } else {
            format!("{prefix}.{}", f.name())
        };
        out.insert(path.clone(), (render(f.data_type()), f.is_nullable()));
        if let Some(inner) = children(f.data_type()) {
            flatten(&path, inner, out);
        }
    }
}

/// The doc's `## ` sections: title → lines.
fn sections(doc: &str) -> BTreeMap<String, Vec<&str>> {
    let mut out: BTreeMap<String, Vec<&str>> = BTreeMap::new();
    let mut current = None;
    for line in doc.lines() {
        if let Some(title) = line.strip_prefix("## ") {
            current = Some(title.trim().to_owned());
            out.entry(title.trim().to_owned()).or_default();
        } else if let Some(title) = &current {
            out.entry(title.clone()).or_default().push(line);
        }
    }
    out
}

/// The body rows of the tables in `lines` whose header's first cell is `first`, as cells with
/// backticks removed.
fn table(lines: &[&str], first: &str) -> Vec<Vec<String>> {
    let cells = |line: &str| -> Vec<String> {
        line.trim()
            .trim_matches('|')
            .split('|')
            .map(|c| c.trim().replace('`', ""))
            .collect()
    };
    let mut rows = Vec::new();
    let mut inside = false;
    for line in lines {
        if !line.trim_start().starts_with('|') {
            inside = false;
            continue;
        }
        let row = cells(line);
        if row
            .iter()
            .all(|c| c.chars().all(|ch| ch == '-' || ch == ':'))
        {
            continue;
        }
        if !inside {
            inside = row.first().is_some_and(|c| c == first);
            if inside {
                continue;
            }
        }
        if inside {
            rows.push(row);
        }
    }
    rows
}

fn snake_case(camel: &str) -> String {
    let mut out = String::new();
    for (i, c) in camel.chars().enumerate() {
        if c.is_ascii_uppercase() && i > 0 {
            out.push('_');
        }
        out.push(c.to_ascii_lowercase());
    }
    out
}

/// The unit and frame a field's name promises (`_nanos`, `_m`, `_m2`, `_mm`, `_ppm`;
/// `_in_kinect_`, `_in_world_`) against the doc's cells.
fn unit_and_frame(path: &str, unit: &str, frame: &str) -> Option<String> {
    let name = path.rsplit('.').next().unwrap_or(path);
    let units = [
        ("_nanos", "ns"),
        ("_m2", "m²"),
        ("_mm", "mm"),
        ("_ppm", "ppm"),
        ("_m", "m"),
    ];
    if let Some((suffix, expected)) = units.iter().find(|(s, _)| name.ends_with(s))
        && unit != *expected
    {
        return Some(format!("unit {unit:?}, but {suffix} means {expected}"));
    }
    let frames = [
        ("_in_kinect_", "Kinect camera space"),
        ("_in_world_", "world"),
    ];
    frames
        .iter()
        .find(|(tag, expected)| name.contains(tag) && !frame.contains(expected))
        .map(|(tag, expected)| format!("frame {frame:?}, but {tag} means {expected}"))
}

/// Every disagreement between `doc` and the code, one sentence each.
fn check(doc: &str) -> Vec<String> {
    let mut problems = Vec::new();
    let sections = sections(doc);
    let documented: BTreeSet<&str> = sections
        .keys()
        .filter_map(|t| t.strip_prefix('`').and_then(|t| t.strip_suffix('`')))
        .collect();
    let messages = messages();
    for name in documented.iter().filter(|n| !messages.contains_key(**n)) {
        problems.push(format!(
            "section `{name}` is not a message of trigait-schema"
        ));
    }
    for (name, data_type) in &messages {
        let Some(lines) = sections.get(&format!("`{name}`")) else {
            problems.push(format!("{name}: no section \"## `{name}`\""));
            continue;
        };
        let mut code = BTreeMap::new();
        if let Some(fields) = children(data_type) {
            flatten("", fields, &mut code);
        }
        let mut seen = BTreeSet::new();
        for row in table(lines, "field") {
            let [path, ty, null, unit, frame, ..] = row.as_slice() else {
                problems.push(format!("{name}: short table row {row:?}"));
                continue;
            };
            if let Some(problem) = unit_and_frame(path, unit, frame) {
                problems.push(format!("{name}.{path}: {problem}"));
            }
            if !seen.insert(path.clone()) {
                problems.push(format!("{name}.{path}: listed twice"));
            }
            let nullable = match null.as_str() {
                "yes" => true,
                "no" => false,
                other => {
                    problems.push(format!(
                        "{name}.{path}: nullable is {other:?}, expected yes or no"
                    ));
                    continue;
                }
            };
            match code.get(path) {
                None => problems.push(format!("{name}.{path}: not a field of the message")),
                Some((code_ty, code_null)) => {
                    if code_ty != ty {
                        problems.push(format!("{name}.{path}: doc says {ty}, code has {code_ty}"));
                    }
                    if *code_null != nullable {
                        problems.push(format!(
                            "{name}.{path}: doc says nullable {nullable}, code has {code_null}"
                        ));
                    }
                }
            }
        }
        for (path, (ty, _)) in &code {
            if !seen.contains(path) {
                problems.push(format!("{name}.{path}: field ({ty}) missing from the doc"));
            }
        }
    }

    let rows = |title: &str, first: &str| {
        sections
            .get(title)
            .map(|lines| table(lines, first))
            .unwrap_or_default()
    };
    let joints: Vec<(String, String)> = rows("Joints", "id")
        .into_iter()
        .map(|r| (r[0].clone(), r.get(1).cloned().unwrap_or_default()))
        .collect();
    let expected: Vec<(String, String)> = Joint::ALL
        .iter()
        .map(|j| (j.index().to_string(), j.name().to_owned()))
        .collect();
    if joints != expected {
        problems.push(format!(
            "Joints table {joints:?} is not trigait_skeleton's {expected:?}"
        ));
    }
    let states: Vec<(String, String)> = rows("Tracking states", "state")
        .into_iter()
        .map(|r| (r[0].clone(), r.get(1).cloned().unwrap_or_default()))
        .collect();
    let expected: Vec<(String, String)> = (0..=u8::MAX)
        .filter_map(|n| TrackingState::from_index(n).map(|s| (n, s)))
        .map(|(n, s)| (n.to_string(), snake_case(&format!("{s:?}"))))
        .collect();
    if states != expected {
        problems.push(format!(
            "Tracking states table {states:?} is not trigait_skeleton's {expected:?}"
        ));
    }

    let set = |title: &str, first: &str| -> BTreeSet<String> {
        rows(title, first)
            .into_iter()
            .map(|r| r[0].clone())
            .collect()
    };
    let ports: BTreeSet<String> = [
        ports::FRAME,
        ports::GROUND_TRUTH,
        ports::NTP_REPLY,
        ports::NTP_REQUEST,
        ports::TICK,
        ports::ALIGNED_SET,
        ports::FRAME_TIMING,
        ports::FUSED_POSE,
        ports::DEPTH,
        ports::IR,
        ports::STATUS,
    ]
    .into_iter()
    .map(str::to_owned)
    .chain(
        [
            ports::NTP_REQUEST_OUTPUT_PREFIX,
            ports::FRAME_INPUT_PREFIX,
            ports::NTP_INPUT_PREFIX,
            ports::DEPTH_INPUT_PREFIX,
            ports::STATUS_INPUT_PREFIX,
        ]
        .map(|prefix| format!("{prefix}<sensor>")),
    )
    .collect();
    let doc_ports = set("Port ids", "port id");
    if doc_ports != ports {
        problems.push(format!(
            "Port ids table {doc_ports:?} is not trigait_schema::ports' {ports:?}"
        ));
    }
    let keys: BTreeSet<String> = ports::METADATA_KEYS
        .iter()
        .map(|k| (*k).to_owned())
        .collect();
    let doc_keys = set("Metadata keys", "key");
    if doc_keys != keys {
        problems.push(format!(
            "Metadata keys table {doc_keys:?} is not trigait_schema::ports' {keys:?}"
        ));
    }
    // Keys named in prose (a message's "Metadata:" line) exist too.
    for word in doc.split('`').skip(1).step_by(2) {
        if word.starts_with("trigait.") && !keys.contains(word) {
            problems.push(format!(
                "`{word}` is not a metadata key of trigait_schema::ports"
            ));
        }
    }
    problems
}

/// `MESSAGES.md` lists every field of every message with the code's Arrow type and
/// nullability, and its joint, state, port and key tables are the code's.
#[test]
fn messages_md_matches_the_schema() {
    let problems = check(DOC);
    assert!(
        problems.is_empty(),
        "operators/schema/MESSAGES.md disagrees with the code; update the doc (or the code):\n  {}",
        problems.join("\n  ")
    );
}

/// The check can fail: a changed type, a changed nullability, an undocumented field, a field the
/// message lacks, a wrong joint name, an unknown metadata key, and a unit or frame the field's
/// name contradicts are each reported by name.
#[test]
fn messages_md_check_catches_drift() {
    let cases = [
        (
            "| `set_seq` | `UInt64` | no |",
            "| `set_seq` | `Int64` | no |",
            "fused_pose.set_seq: doc says Int64, code has UInt64",
        ),
        (
            "| `t2_nanos` | `Int64` | yes |",
            "| `t2_nanos` | `Int64` | no |",
            "ntp_exchange.t2_nanos: doc says nullable false",
        ),
        (
            "| `joints.residual_m` | `Float64` | no | m | | RMS residual of the fit |\n",
            "",
            "fused_pose.joints.residual_m: field (Float64) missing",
        ),
        (
            "| `width` | `UInt32` | no |",
            "| `width_px` | `UInt32` | no |",
            "depth_frame.width_px: not a field",
        ),
        (
            "| 13 | `knee_left` |",
            "| 13 | `knee_links` |",
            "Joints table",
        ),
        (
            "| no | m | world | true joint centre |",
            "| no | mm | world | true joint centre |",
            "ground_truth.joints.position_in_world_m: unit \"mm\", but _m means m",
        ),
        (
            "| m | Kinect camera space | joint position |",
            "| m | world | joint position |",
            "skeleton_frame.joints.position_in_kinect_m: frame \"world\"",
        ),
        (
            "Metadata: `trigait.sent_nanos`.",
            "Metadata: `trigait.sent_nanoseconds`.",
            "`trigait.sent_nanoseconds` is not a metadata key",
        ),
    ];
    for (from, to, expected) in cases {
        assert!(DOC.contains(from), "the doc no longer has {from:?}");
        let problems = check(&DOC.replacen(from, to, 1));
        assert!(
            problems.iter().any(|p| p.contains(expected)),
            "{from:?} → {to:?}: expected a problem containing {expected:?}, got {problems:#?}"
        );
    }
}
