//! Which rig a message was made with, carried in its metadata.
//!
//! Every node that needs sensor poses reads them from its own `RIG` variable, so a graph names
//! its rig in several places, and a source on `ring-5` feeding a `trilaterate` on `thesis`
//! would fuse nonsense without a word. Sources therefore stamp each frame with their rig's
//! [`Rig::fingerprint`]; `sync` forwards the stamp on what it sends, and each node that holds
//! a rig checks every stamp it receives against its own.

use dora_node_api::{MetadataParameters, Parameter};
use eyre::bail;
use trigait_rig::Rig;
use trigait_schema::ports::{RIG_FINGERPRINT, RIG_NAME, RIG_NODE};

/// A node's rig, as stamped on messages.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RigStamp {
    /// The node whose `RIG` it is.
    pub node: String,
    /// The rig's name.
    pub name: String,
    /// [`Rig::fingerprint`].
    pub fingerprint: String,
}

impl RigStamp {
    /// The stamp of `rig`, read by `node`.
    #[must_use]
    pub fn new(node: &str, rig: &Rig) -> Self {
        let name = if rig.name.is_empty() {
            "(unnamed)".to_owned()
        } else {
            rig.name.clone()
        };
        Self {
            node: node.to_owned(),
            name,
            fingerprint: rig.fingerprint(),
        }
    }

    /// Writes the stamp into `params` (replacing one already there).
    pub fn insert_into(&self, params: &mut MetadataParameters) {
        for (key, value) in [
            (RIG_FINGERPRINT, &self.fingerprint),
            (RIG_NAME, &self.name),
            (RIG_NODE, &self.node),
        ] {
            params.insert(key.to_owned(), Parameter::String(value.clone()));
        }
    }

    /// The stamp in `params`, if the sender put one there.
    #[must_use]
    pub fn from_params(params: &MetadataParameters) -> Option<Self> {
        let text = |key: &str| match params.get(key) {
            Some(Parameter::String(s)) => Some(s.clone()),
            _ => None,
        };
        Some(Self {
            fingerprint: text(RIG_FINGERPRINT)?,
            name: text(RIG_NAME).unwrap_or_else(|| "(unnamed)".to_owned()),
            node: text(RIG_NODE).unwrap_or_else(|| "(unknown node)".to_owned()),
        })
    }

    /// Checks that `theirs` (from a message) is the same rig as `self` (this node's).
    ///
    /// # Errors
    /// When the fingerprints differ, naming both nodes and both rigs.
    pub fn check(&self, theirs: &RigStamp) -> eyre::Result<()> {
        if self.fingerprint == theirs.fingerprint {
            return Ok(());
        }
        let same_name = if self.name == theirs.name {
            " (same name, other poses or sensor ids)"
        } else {
            ""
        };
        bail!(
            "{}: RIG is rig {:?} ({} sensors) but {} sent data made with rig {:?} ({} sensors){same_name}; every node of a graph must be given the same rig",
            self.node,
            self.name,
            sensor_count(&self.fingerprint),
            theirs.node,
            theirs.name,
            sensor_count(&theirs.fingerprint),
        )
    }

    /// [`Self::check`] against the stamp in `params`, if any (a sender that stamps nothing,
    /// like a third-party source, is not checked).
    ///
    /// # Errors
    /// As [`Self::check`].
    pub fn check_params(&self, params: &MetadataParameters) -> eyre::Result<()> {
        match Self::from_params(params) {
            Some(theirs) => self.check(&theirs),
            None => Ok(()),
        }
    }
}

fn sensor_count(fingerprint: &str) -> &str {
    fingerprint.split(':').next().unwrap_or("?")
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;

    /// A stamp survives the metadata; the same rig passes, another fails with both nodes and
    /// both rigs named; no stamp is not checked.
    #[test]
    fn stamps_compare_rigs() {
        let thesis = Rig::from_spec("thesis").unwrap();
        let ours = RigStamp::new("trilaterate", &thesis);
        let mut params = MetadataParameters::default();
        RigStamp::new("k1", &thesis).insert_into(&mut params);
        assert_eq!(
            RigStamp::from_params(&params).unwrap(),
            RigStamp::new("k1", &thesis)
        );
        ours.check_params(&params).unwrap();

        let mut params = MetadataParameters::default();
        RigStamp::new("k2", &Rig::from_spec("ring-5").unwrap()).insert_into(&mut params);
        let err = ours.check_params(&params).unwrap_err().to_string();
        for part in [
            "trilaterate",
            "\"thesis\"",
            "k2",
            "\"ring-5\"",
            "3 sensors",
            "5 sensors",
        ] {
            assert!(err.contains(part), "{part:?} not in {err}");
        }
        ours.check_params(&MetadataParameters::default()).unwrap();
    }
}
