//! The layer rule of `ARCHITECTURE.md`, checked over `cargo metadata`.
//!
//! Every workspace crate declares its layer in its manifest:
//!
//! ```toml
//! [package.metadata.trigait]
//! layer = "algorithms"
//! ```
//!
//! and a crate may depend (normal and build dependencies) only on workspace crates of its own
//! layer or below. The pure layers (data model, algorithms, composition, simulation) may not
//! depend on dora or rerun in any way, dev-dependencies included, and live in `operators/`;
//! adapters live in `adapters/` or `drivers/`, programs in `nodes/` or at the root.

// Test code panics on failure by design.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::collections::BTreeMap;
use std::path::Path;
use std::process::Command;

use serde_json::Value;

/// The layers, lowest first, as `ARCHITECTURE.md` names them.
const LAYERS: [&str; 6] = [
    "data-model",
    "algorithms",
    "composition",
    "simulation",
    "adapters",
    "programs",
];

/// The first layer that may touch dora, rerun or devices.
const FIRST_IMPURE: usize = 4;

/// Crates (or name prefixes) that only adapters and programs may use.
const IMPURE_DEPENDENCIES: [&str; 4] = ["dora-", "rerun", "re_", "libfreenect2"];

/// One workspace crate as the rule needs it.
#[derive(Debug, Clone)]
struct Crate {
    name: String,
    /// The folder of the crate relative to the workspace root (`""` for the root package).
    folder: String,
    layer: Option<usize>,
    /// `(dependency name, kind)`, kind `"normal"`, `"build"` or `"dev"`.
    dependencies: Vec<(String, String)>,
}

fn workspace_crates() -> Vec<Crate> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(cargo)
        .args([
            "metadata",
            "--format-version",
            "1",
            "--no-deps",
            "--offline",
        ])
        .current_dir(root)
        .output()
        .expect("cargo metadata runs");
    assert!(
        out.status.success(),
        "cargo metadata failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let meta: Value = serde_json::from_slice(&out.stdout).expect("cargo metadata prints JSON");
    let root = root.canonicalize().unwrap();
    meta["packages"]
        .as_array()
        .expect("packages")
        .iter()
        .map(|p| {
            let manifest = Path::new(p["manifest_path"].as_str().unwrap());
            let folder = manifest
                .parent()
                .unwrap()
                .strip_prefix(&root)
                .unwrap()
                .to_string_lossy()
                .into_owned();
            let layer = p["metadata"]["trigait"]["layer"]
                .as_str()
                .and_then(|l| LAYERS.iter().position(|x| *x == l));
            let dependencies = p["dependencies"]
                .as_array()
                .unwrap()
                .iter()
                .map(|d| {
                    let kind = d["kind"].as_str().unwrap_or("normal").to_owned();
                    (d["name"].as_str().unwrap().to_owned(), kind)
                })
                .collect();
            Crate {
                name: p["name"].as_str().unwrap().to_owned(),
                folder,
                layer,
                dependencies,
            }
        })
        .collect()
}

/// Every breach of the rule, one sentence each.
fn violations(crates: &[Crate]) -> Vec<String> {
    let layer_of: BTreeMap<&str, Option<usize>> =
        crates.iter().map(|c| (c.name.as_str(), c.layer)).collect();
    let mut out = Vec::new();
    for c in crates {
        let Some(layer) = c.layer else {
            out.push(format!(
                "{} declares no [package.metadata.trigait] layer (one of {LAYERS:?})",
                c.name
            ));
            continue;
        };
        let top = c.folder.split('/').next().unwrap_or("");
        let folder_ok = match top {
            "operators" => layer < FIRST_IMPURE,
            "adapters" | "drivers" => layer == FIRST_IMPURE,
            "nodes" | "" => layer == LAYERS.len() - 1,
            _ => false,
        };
        if !folder_ok {
            out.push(format!(
                "{} is in {}/ but declares layer {}: operators/ holds the pure layers, \
                 adapters/ and drivers/ the adapters, nodes/ and the root the programs",
                c.name, c.folder, LAYERS[layer]
            ));
        }
        for (dep, kind) in &c.dependencies {
            if layer < FIRST_IMPURE && IMPURE_DEPENDENCIES.iter().any(|p| dep.starts_with(p)) {
                out.push(format!(
                    "{} (layer {}) depends on {dep} ({kind}): the pure layers use no dora, rerun or device crate",
                    c.name, LAYERS[layer]
                ));
            }
            let Some(dep_layer) = layer_of.get(dep.as_str()).copied().flatten() else {
                continue;
            };
            let allowed = if kind == "dev" {
                // Tests may use a higher pure layer (a simulator to make test data), never an
                // adapter from a pure crate.
                layer >= FIRST_IMPURE || dep_layer < FIRST_IMPURE
            } else {
                dep_layer <= layer
            };
            if !allowed {
                out.push(format!(
                    "{} (layer {}) depends on {dep} (layer {}, {kind}): a crate may use only its own layer or below",
                    c.name, LAYERS[layer], LAYERS[dep_layer]
                ));
            }
        }
    }
    out
}

/// The workspace as it is obeys the rule.
#[test]
fn every_crate_depends_only_on_its_layer_or_below() {
    let crates = workspace_crates();
    assert!(
        crates.len() >= 20,
        "cargo metadata listed only {} crates",
        crates.len()
    );
    let v = violations(&crates);
    assert!(v.is_empty(), "layer rule broken:\n{}", v.join("\n"));
}

/// The check is not vacuous: a pure crate that gains a dora or rerun dependency, or one on a
/// higher layer, is caught, and so is a crate without a layer.
#[test]
fn the_rule_catches_a_pure_crate_that_gains_an_impure_dependency() {
    let crates = workspace_crates();
    let pure = |name: &str| {
        let mut c = crates
            .iter()
            .find(|c| c.name == name)
            .unwrap_or_else(|| panic!("{name} is a workspace crate"))
            .clone();
        assert!(c.layer.is_some_and(|l| l < FIRST_IMPURE), "{name} is pure");
        c.dependencies.clear();
        c
    };
    for (dep, kind) in [
        ("dora-node-api", "normal"),
        ("rerun", "normal"),
        ("rerun", "dev"),
        ("trigait-node-log", "normal"),
        ("trigait-sim", "normal"),
    ] {
        let mut skeleton = pure("trigait-skeleton");
        skeleton.dependencies.push((dep.into(), kind.into()));
        let mut all = crates.clone();
        all.retain(|c| c.name != "trigait-skeleton");
        all.push(skeleton);
        let v = violations(&all);
        assert!(
            v.iter()
                .any(|m| m.starts_with("trigait-skeleton") && m.contains(dep)),
            "a data-model crate depending on {dep} ({kind}) was not caught: {v:?}"
        );
    }
    let mut unlabelled = pure("trigait-gait");
    unlabelled.layer = None;
    let v = violations(&[unlabelled]);
    assert!(v.iter().any(|m| m.contains("declares no")), "{v:?}");
}

/// The one build line of DESIGN.md ("Build time"): every script and every graph's `build:`
/// builds the same thing, so none of them unifies the dependencies' features differently and
/// recompiles them after another (building `--bin trigait` alone once cost 8 minutes).
const BUILD_LINE: &str = "cargo build --release --workspace --all-targets";

#[test]
fn every_script_and_graph_builds_with_the_one_build_line() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = vec![root.join("dataflow.yml")];
    for dir in ["scripts", "dataflows"] {
        for entry in std::fs::read_dir(root.join(dir)).unwrap() {
            let path = entry.unwrap().path();
            if path
                .extension()
                .is_some_and(|e| e == "sh" || e == "yml" || e == "py")
            {
                files.push(path);
            }
        }
    }
    let mut lines = 0;
    let mut wrong = Vec::new();
    for file in &files {
        let text = std::fs::read_to_string(file).unwrap();
        for (n, line) in text.lines().enumerate() {
            let code = line.split('#').next().unwrap_or("");
            let Some(at) = code.find("cargo build") else {
                continue;
            };
            lines += 1;
            let cmd = code[at..].trim().trim_end_matches(['"', '\'', ',']);
            // A graph for hardware adds its cargo feature (`--features …/freenect2`) and
            // nothing else: the rest of the line, and so the dependencies' features, stay the
            // same.
            let hardware = cmd
                .strip_prefix(BUILD_LINE)
                .and_then(|rest| rest.trim().strip_prefix("--features "))
                .is_some_and(|f| f.split(',').all(|f| f.trim().ends_with("freenect2")));
            if cmd != BUILD_LINE && !hardware {
                wrong.push(format!("{}:{}: {cmd}", file.display(), n + 1));
            }
        }
    }
    assert!(lines >= 10, "found only {lines} build lines in {files:?}");
    assert!(
        wrong.is_empty(),
        "build lines other than `{BUILD_LINE}`:\n{}",
        wrong.join("\n")
    );
}
