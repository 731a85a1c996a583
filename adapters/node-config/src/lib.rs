//! Reading a dora node's `env:` block, one variable at a time.
//!
//! Every node's `Config::from_lookup` parses numbers (and a few other values) out of its
//! `env:` block, and a bad value must stop the node with an error naming the node, the
//! variable and the raw value (`sync: SLOT_MILLIS="-3" is invalid: expected …`), so a wrong
//! line in a dataflow YAML is found without reading code. Each node used to carry its own copy
//! of that parsing; these functions are the one copy.
//!
//! `lookup` is the node's variable source (`|k| std::env::var(k).ok()` in production, a fixed
//! list in tests). Values are trimmed before parsing. A variable that is not set yields the
//! default (or `None`); a default is not checked.
//!
//! This crate serves the nodes only: operator crates keep their own typed errors (`eyre` is
//! the nodes' error type).

#![warn(missing_docs)]

mod rig_stamp;

pub use rig_stamp::RigStamp;

use std::str::FromStr;

use eyre::bail;

/// The environment variables among `present` that look like a misspelt setting: one edit (a
/// letter added, dropped, changed or two swapped) away from one of `known` (`METOD` for
/// `METHOD`), each with the setting it resembles. A misspelt key is otherwise ignored without a
/// word and the default runs. Only upper-case names are considered, and settings of four
/// letters or more, so that the shell's own variables are not taken for typos.
#[must_use]
pub fn misspelt_settings<'a>(
    known: &[&'a str],
    present: impl IntoIterator<Item = String>,
) -> Vec<(String, &'a str)> {
    let mut out = Vec::new();
    for key in present {
        let shaped = !key.is_empty()
            && key
                .bytes()
                .all(|b| b.is_ascii_uppercase() || b.is_ascii_digit() || b == b'_');
        if !shaped || known.contains(&key.as_str()) {
            continue;
        }
        if let Some(like) = known
            .iter()
            .find(|k| k.len() >= 4 && one_edit_apart(k.as_bytes(), key.as_bytes()))
        {
            out.push((key, *like));
        }
    }
    out.sort();
    out
}

/// Warns of each variable of the process environment that looks like a misspelt setting of
/// `node` ([`misspelt_settings`] against its `settings`).
pub fn warn_misspelt_settings(node: &str, settings: &[&str]) {
    let present = std::env::vars_os().filter_map(|(k, _)| k.into_string().ok());
    for (key, like) in misspelt_settings(settings, present) {
        tracing::warn!("{key} is not a setting of {node} (left out): did you mean {like}?");
    }
}

/// Whether `a` and `b` differ by exactly one insertion, deletion, substitution or swap of
/// neighbours.
fn one_edit_apart(a: &[u8], b: &[u8]) -> bool {
    if a == b || a.len().abs_diff(b.len()) > 1 {
        return false;
    }
    let prefix = a.iter().zip(b).take_while(|(x, y)| x == y).count();
    let (ra, rb) = (&a[prefix..], &b[prefix..]);
    match ra.len().cmp(&rb.len()) {
        std::cmp::Ordering::Equal => {
            ra[1..] == rb[1..]
                || (ra.len() >= 2 && ra[0] == rb[1] && ra[1] == rb[0] && ra[2..] == rb[2..])
        }
        std::cmp::Ordering::Less => ra == &rb[1..],
        std::cmp::Ordering::Greater => &ra[1..] == rb,
    }
}

/// Checks the input ids the node's YAML gives it (`declared`) against the ones it reads: every
/// `required` one present, nothing but `required` and `optional` ones. A misspelt input id
/// otherwise leaves the node waiting for a message that never comes, while the run ends as if
/// all were well.
///
/// # Errors
/// `"{node}: input {id:?} is not one it reads (…): a misspelt id?"`, or
/// `"{node}: no input {id:?} among its inputs (…)"`.
pub fn check_inputs<'a>(
    node: &str,
    declared: impl IntoIterator<Item = &'a str>,
    required: &[&str],
    optional: &[&str],
) -> eyre::Result<()> {
    let declared: Vec<&str> = declared.into_iter().collect();
    let reads = || {
        required
            .iter()
            .chain(optional)
            .map(|id| format!("{id:?}"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    if let Some(id) = declared
        .iter()
        .find(|id| !required.contains(id) && !optional.contains(id))
    {
        bail!(
            "{node}: input {id:?} is not one it reads ({}): a misspelt id?",
            reads()
        );
    }
    if let Some(id) = required.iter().find(|id| !declared.contains(id)) {
        bail!(
            "{node}: no input {id:?} among its inputs ({}): it has nothing to work on",
            declared
                .iter()
                .map(|id| format!("{id:?}"))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    Ok(())
}

/// `key` parsed as `T` and accepted by `ok`, or `None` when it is not set.
///
/// # Errors
/// `"{node}: {key}={raw:?} is invalid: expected {expected}"` when the value does not parse or
/// `ok` refuses it.
pub fn env_value<T: FromStr>(
    node: &str,
    lookup: &impl Fn(&str) -> Option<String>,
    key: &str,
    ok: impl Fn(&T) -> bool,
    expected: &str,
) -> eyre::Result<Option<T>> {
    let Some(raw) = lookup(key) else {
        return Ok(None);
    };
    match raw.trim().parse::<T>() {
        Ok(v) if ok(&v) => Ok(Some(v)),
        _ => bail!("{node}: {key}={raw:?} is invalid: expected {expected}"),
    }
}

/// `key` as a finite number, `default` when it is not set.
///
/// # Errors
/// As [`env_value`], when the value is not a finite number.
pub fn env_number(
    node: &str,
    lookup: &impl Fn(&str) -> Option<String>,
    key: &str,
    default: f64,
) -> eyre::Result<f64> {
    env_number_where(node, lookup, key, default, |_| true, "a finite number")
}

/// `key` as a finite number accepted by `ok` (a range, a sign), `default` when it is not set.
///
/// # Errors
/// As [`env_value`], when the value is not a finite number or `ok` refuses it; `expected`
/// says what would be accepted (`"a cut-off in Hz above 0"`).
pub fn env_number_where(
    node: &str,
    lookup: &impl Fn(&str) -> Option<String>,
    key: &str,
    default: f64,
    ok: impl Fn(f64) -> bool,
    expected: &str,
) -> eyre::Result<f64> {
    let v = env_value(
        node,
        lookup,
        key,
        |v: &f64| v.is_finite() && ok(*v),
        expected,
    )?;
    Ok(v.unwrap_or(default))
}

/// `key` as a switch: `true`/`yes`/`1` or `false`/`no`/`0`, `default` when it is not set.
///
/// # Errors
/// As [`env_value`], expecting "true or false", for any other value.
pub fn env_flag(
    node: &str,
    lookup: &impl Fn(&str) -> Option<String>,
    key: &str,
    default: bool,
) -> eyre::Result<bool> {
    let Some(raw) = lookup(key) else {
        return Ok(default);
    };
    match flag_word(&raw) {
        Some(on) => Ok(on),
        None => bail!("{node}: {key}={raw:?} is invalid: expected true or false"),
    }
}

/// The words [`env_flag`] reads as on.
pub const TRUE_WORDS: [&str; 3] = ["true", "yes", "1"];
/// The words [`env_flag`] reads as off.
pub const FALSE_WORDS: [&str; 3] = ["false", "no", "0"];

/// `raw` (trimmed) as a switch, `None` when it is not one of [`TRUE_WORDS`] or [`FALSE_WORDS`],
/// for a variable that is a switch or a value (`RERUN=false` or `RERUN=rrd`) and must spell
/// its switch as every flag does.
#[must_use]
pub fn flag_word(raw: &str) -> Option<bool> {
    let raw = raw.trim();
    if TRUE_WORDS.contains(&raw) {
        Some(true)
    } else if FALSE_WORDS.contains(&raw) {
        Some(false)
    } else {
        None
    }
}

/// `key` parsed by its type's [`FromStr`] (an estimator, a sync policy, a backend: any enum
/// whose parse error says what it accepts), `default` when it is not set.
///
/// # Errors
/// `"{node}: {key}={raw:?} is invalid: {the type's parse error}"`.
pub fn env_parsed<T>(
    node: &str,
    lookup: &impl Fn(&str) -> Option<String>,
    key: &str,
    default: T,
) -> eyre::Result<T>
where
    T: FromStr,
    T::Err: std::fmt::Display,
{
    let Some(raw) = lookup(key) else {
        return Ok(default);
    };
    raw.trim()
        .parse::<T>()
        .map_err(|e| eyre::eyre!("{node}: {key}={raw:?} is invalid: {e}"))
}

/// The `RIG` variable (`thesis`, `ring-N` or a rig YAML file), parsed once at configuration
/// time, `thesis` when it is not set.
///
/// # Errors
/// `"{node}: RIG={raw:?}: {why}"` when the name is unknown or the file cannot be read or is not
/// a valid rig.
pub fn env_rig(
    node: &str,
    lookup: &impl Fn(&str) -> Option<String>,
) -> eyre::Result<trigait_rig::Rig> {
    let raw = lookup(RIG).unwrap_or_else(|| DEFAULT_RIG.to_owned());
    trigait_rig::Rig::from_spec(raw.trim()).map_err(|e| eyre::eyre!("{node}: {RIG}={raw:?}: {e}"))
}

/// The variable every node that needs sensor poses reads them from.
pub const RIG: &str = "RIG";

/// The rig of the thesis set-up, used when `RIG` is not set.
pub const DEFAULT_RIG: &str = "thesis";

/// The pinhole `[fx, fy, cx, cy]` (px) a source stamped on a depth frame
/// ([`trigait_schema::ports::DEPTH_PINHOLE`]), or `None` when the frame has none (the nominal
/// camera) or the stamp is not four finite numbers with positive focal lengths.
#[must_use]
pub fn stamped_pinhole(params: &dora_node_api::MetadataParameters) -> Option<[f64; 4]> {
    match params.get(trigait_schema::ports::DEPTH_PINHOLE)? {
        dora_node_api::Parameter::ListFloat(v) => {
            let k: [f64; 4] = v.as_slice().try_into().ok()?;
            (k.iter().all(|x| x.is_finite()) && k[0] > 0.0 && k[1] > 0.0).then_some(k)
        }
        _ => None,
    }
}

/// The camera to back-project a depth frame with: the pinhole its source stamped (an
/// undistorted real frame, [`stamped_pinhole`]), otherwise the nominal Kinect v2 camera.
#[must_use]
pub fn depth_camera(params: &dora_node_api::MetadataParameters) -> trigait_camera::Intrinsics {
    stamped_pinhole(params).map_or_else(trigait_camera::Intrinsics::default, |[fx, fy, cx, cy]| {
        trigait_camera::Intrinsics::pinhole(fx, fy, cx, cy)
    })
}

/// The metadata parameter [`stamped_pinhole`] reads.
#[must_use]
pub fn pinhole_parameter(k: [f64; 4]) -> dora_node_api::Parameter {
    dora_node_api::Parameter::ListFloat(k.to_vec())
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;

    #[test]
    fn misspelt_settings_are_found() {
        let known = ["METHOD", "POLICY", "RIG", "SEED", "ROBUST"];
        let present = [
            "METOD", "POLICIY", "RGI", "PATH", "HOME", "METHOD", "SEDE", "ROBUS", "robust", "SEEDS",
        ]
        .map(str::to_owned);
        assert_eq!(
            misspelt_settings(&known, present),
            [
                ("METOD".to_owned(), "METHOD"),
                ("POLICIY".to_owned(), "POLICY"),
                ("ROBUS".to_owned(), "ROBUST"),
                ("SEDE".to_owned(), "SEED"),
                ("SEEDS".to_owned(), "SEED"),
            ]
        );
    }

    #[test]
    fn inputs_are_checked_by_name() {
        let ok = check_inputs(
            "rec",
            ["fused_pose", "ground_truth"],
            &["fused_pose"],
            &["ground_truth"],
        );
        assert!(ok.is_ok());
        let typo = check_inputs("rec", ["fused_poses"], &["fused_pose"], &[]).unwrap_err();
        assert!(
            typo.to_string()
                .contains("rec: input \"fused_poses\" is not one it reads (\"fused_pose\")"),
            "{typo}"
        );
        let none = check_inputs("rec", [], &["fused_pose"], &[]).unwrap_err();
        assert!(
            none.to_string().contains("no input \"fused_pose\""),
            "{none}"
        );
    }

    fn env(pairs: &'static [(&'static str, &'static str)]) -> impl Fn(&str) -> Option<String> {
        move |k| {
            pairs
                .iter()
                .find(|(key, _)| *key == k)
                .map(|(_, v)| (*v).to_owned())
        }
    }

    /// Unset gives the default, a set value is trimmed and parsed, and a refused value names
    /// the node, the key, the raw value and what was expected.
    #[test]
    fn defaults_values_and_errors() {
        let lookup = env(&[("A", " 2.5 "), ("B", "inf"), ("C", "x"), ("N", "-1")]);
        assert_eq!(env_number("n", &lookup, "UNSET", 7.0).unwrap(), 7.0);
        assert_eq!(env_number("n", &lookup, "A", 7.0).unwrap(), 2.5);
        for key in ["B", "C"] {
            let err = env_number("node", &lookup, key, 0.0).unwrap_err();
            assert!(
                err.to_string().starts_with(&format!("node: {key}=")),
                "{err}"
            );
        }
        let err = env_number_where("node", &lookup, "N", 1.0, |v| v > 0.0, "a positive count")
            .unwrap_err()
            .to_string();
        assert_eq!(err, r#"node: N="-1" is invalid: expected a positive count"#);
        let n: Option<u64> = env_value("node", &lookup, "UNSET", |_| true, "").unwrap();
        assert_eq!(n, None);
        assert!(env_value::<u64>("node", &lookup, "N", |_| true, "a count").is_err());
    }

    /// Enums parse through their `FromStr`, and a bad value carries the type's own reason.
    #[test]
    fn parsed_values() {
        #[derive(Debug, PartialEq)]
        enum Policy {
            Slots,
            Interpolate,
        }
        impl FromStr for Policy {
            type Err = String;
            fn from_str(s: &str) -> Result<Self, String> {
                match s {
                    "slots" => Ok(Self::Slots),
                    "interpolate" => Ok(Self::Interpolate),
                    _ => Err("expected slots or interpolate".into()),
                }
            }
        }
        let lookup = env(&[("P", " slots "), ("X", "magic")]);
        assert_eq!(
            env_parsed("n", &lookup, "P", Policy::Interpolate).unwrap(),
            Policy::Slots
        );
        assert_eq!(
            env_parsed("n", &lookup, "UNSET", Policy::Interpolate).unwrap(),
            Policy::Interpolate
        );
        let err = env_parsed("n", &lookup, "X", Policy::Slots)
            .unwrap_err()
            .to_string();
        assert_eq!(
            err,
            r#"n: X="magic" is invalid: expected slots or interpolate"#
        );
    }

    /// The rig is read once: a built-in name, the default, or an error naming node and value.
    #[test]
    fn rigs() {
        let ring = env(&[("RIG", "ring-5")]);
        assert_eq!(env_rig("n", &ring).unwrap().sensors.len(), 5);
        assert_eq!(env_rig("n", &env(&[])).unwrap().sensors.len(), 3);
        let err = env_rig("n", &env(&[("RIG", "/no/such/rig.yml")]))
            .unwrap_err()
            .to_string();
        assert!(err.starts_with(r#"n: RIG="/no/such/rig.yml": "#), "{err}");
    }

    /// Switches: unset gives the default; true/yes/1 and false/no/0; anything else is an error.
    #[test]
    fn flags() {
        let lookup = env(&[("Y", " yes"), ("Z", "0"), ("M", "maybe")]);
        assert!(env_flag("n", &lookup, "UNSET", true).unwrap());
        assert!(env_flag("n", &lookup, "Y", false).unwrap());
        assert!(!env_flag("n", &lookup, "Z", true).unwrap());
        let err = env_flag("n", &lookup, "M", true).unwrap_err().to_string();
        assert_eq!(err, r#"n: M="maybe" is invalid: expected true or false"#);
        assert_eq!(flag_word(" no "), Some(false));
        assert_eq!(flag_word("1"), Some(true));
        assert_eq!(flag_word("rrd"), None);
    }

    /// A stamped pinhole reads back; a missing, short or non-positive one is the nominal camera.
    #[test]
    fn stamped_pinhole_round_trip() {
        let mut params = dora_node_api::MetadataParameters::default();
        assert_eq!(stamped_pinhole(&params), None);
        assert_eq!(depth_camera(&params), trigait_camera::Intrinsics::default());
        let k = [365.5, 365.4, 254.9, 205.4];
        params.insert(
            trigait_schema::ports::DEPTH_PINHOLE.to_owned(),
            pinhole_parameter(k),
        );
        assert_eq!(stamped_pinhole(&params), Some(k));
        assert_eq!(
            depth_camera(&params),
            trigait_camera::Intrinsics::pinhole(k[0], k[1], k[2], k[3])
        );
        for bad in [
            vec![1.0, 2.0, 3.0],
            vec![0.0, 365.0, 1.0, 1.0],
            vec![f64::NAN; 4],
        ] {
            params.insert(
                trigait_schema::ports::DEPTH_PINHOLE.to_owned(),
                dora_node_api::Parameter::ListFloat(bad),
            );
            assert_eq!(stamped_pinhole(&params), None);
        }
    }
}
