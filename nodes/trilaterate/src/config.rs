//! `trilaterate` configuration, read from the node's `env:` block.
//!
//! | env var | type | default | meaning |
//! |---|---|---|---|
//! | `METHOD` | `geometric`, `linear`, `nls`, `fusion` | `fusion` | the estimator |
//! | `ROBUST` | bool | `false` | wrap it in outlier rejection |
//! | `RIG` | `thesis`, `ring-N` or a YAML path | `thesis` | sensor poses (must match the sources') |
//! | `RESAMPLING_WEIGHTS` | bool | `true` | widen each observation's covariance by `sync`'s resampling-error estimate ([`trigait_fusion`]) |

use trigait_node_config::{env_flag, env_parsed, env_rig};
use trigait_rig::Rig;
use trigait_trilateration::{Method, Params};

/// Env var: method.
pub const METHOD: &str = "METHOD";
/// Env var: robust.
pub const ROBUST: &str = "ROBUST";
/// Env var: resampling weights.
pub const RESAMPLING_WEIGHTS: &str = "RESAMPLING_WEIGHTS";

/// Every variable the node reads, to spot a misspelt one.
const SETTINGS: &[&str] = &[METHOD, ROBUST, RESAMPLING_WEIGHTS, trigait_node_config::RIG];

const NODE: &str = "trilaterate";

/// The node's configuration.
#[derive(Debug, Clone)]
pub struct Config {
    /// Estimator settings.
    pub params: Params,
    /// The rig.
    pub rig: Rig,
    /// Whether `sync`'s resampling-error estimate widens the covariances.
    pub resampling_weights: bool,
}

impl Config {
    /// From the process environment.
    pub fn from_env() -> eyre::Result<Self> {
        trigait_node_config::warn_misspelt_settings(NODE, SETTINGS);
        Self::from_lookup(|k| std::env::var(k).ok())
    }

    /// From any lookup (tests).
    pub fn from_lookup(lookup: impl Fn(&str) -> Option<String>) -> eyre::Result<Self> {
        if let Some(raw) = lookup(METHOD)
            && let Some((method, _)) = raw.trim().split_once("+robust")
        {
            eyre::bail!(
                "{NODE}: {METHOD}={raw:?} is invalid: the estimator is `{method}`; robustness is \
                 its own setting, {ROBUST}: \"true\""
            );
        }
        let method = env_parsed(NODE, &lookup, METHOD, Method::Fusion)?;
        let robust = env_flag(NODE, &lookup, ROBUST, false)?;
        let resampling_weights = env_flag(NODE, &lookup, RESAMPLING_WEIGHTS, true)?;
        let rig = env_rig(NODE, &lookup)?;
        Ok(Config {
            params: Params::new(method).with_robust(robust),
            rig,
            resampling_weights,
        })
    }

    /// The estimator's name as reported (`fusion`, `fusion+robust`).
    #[must_use]
    pub fn estimator_name(&self) -> String {
        if self.params.robust {
            format!("{}+robust", self.params.method)
        } else {
            self.params.method.to_string()
        }
    }
}
