use nalgebra::Point3;

use crate::{Error, Result};

/// Marker trajectories of one trial: the raw input from which joint centres are derived.
///
/// Positions are in metres in the world frame (Z up), converted by the reader. A frame in which a
/// marker was not seen is `None`; readers never fill gaps, so what is missing stays visible to
/// whoever uses the data (joint centres, gait events).
///
/// Labels are kept as the file writes them (e.g. `liu:LKNE`); lookups ignore case and anything
/// up to the last `:` (the Vicon subject prefix).
#[derive(Debug, Clone, PartialEq)]
pub struct MarkerSet {
    name: String,
    rate_hz: f64,
    labels: Vec<String>,
    /// Row-major: `positions[frame * labels.len() + column]`.
    positions: Vec<Option<Point3<f64>>>,
}

/// How many frames one marker is missing in.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MarkerGaps {
    /// The marker's label as in the file.
    pub label: String,
    /// Frames in which it is missing.
    pub missing_frames: usize,
}

/// The part of a label after the last `:` (the Vicon subject prefix is dropped), trimmed.
fn base_label(label: &str) -> &str {
    label.rsplit(':').next().unwrap_or(label).trim()
}

/// A label reduced for alias matching: prefix dropped, lowercase, without `.`, `_`, `-` and spaces,
/// so `R.ASIS`, `RASIS` and `liu:R_ASIS` all become `rasis`.
pub(crate) fn normalised_label(label: &str) -> String {
    base_label(label)
        .chars()
        .filter(|c| !matches!(c, '.' | '_' | '-' | ' '))
        .flat_map(char::to_lowercase)
        .collect()
}

/// An anatomical landmark a skin marker may sit on, as the joint centres and gait events use it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Landmark {
    /// Anterior superior iliac spine (one per side).
    Asis,
    /// Posterior superior iliac spine (one per side).
    Psis,
    /// Sacrum: a single marker standing for the PSIS mid-point.
    Sacrum,
    /// Lateral femoral epicondyle.
    KneeLateral,
    /// Medial femoral epicondyle.
    KneeMedial,
    /// Lateral malleolus.
    AnkleLateral,
    /// Medial malleolus.
    AnkleMedial,
    /// Calcaneus (posterior heel).
    Heel,
    /// Forefoot: second metatarsal head or toe, else another metatarsal head.
    Toe,
}

impl Landmark {
    /// Every landmark, in the order of [`MARKER_NAMES`].
    pub const ALL: [Landmark; 9] = [
        Landmark::Asis,
        Landmark::Psis,
        Landmark::Sacrum,
        Landmark::KneeLateral,
        Landmark::KneeMedial,
        Landmark::AnkleLateral,
        Landmark::AnkleMedial,
        Landmark::Heel,
        Landmark::Toe,
    ];

    /// Whether there is one marker per side (all but the sacrum).
    #[must_use]
    pub fn sided(self) -> bool {
        self != Landmark::Sacrum
    }

    /// The accepted names of this landmark, normalised (see [`MARKER_NAMES`]).
    #[must_use]
    pub fn aliases(self) -> &'static [&'static str] {
        MARKER_NAMES
            .iter()
            .find(|(l, _)| *l == self)
            .map_or(&[], |(_, names)| *names)
    }

    /// The accepted labels for `side` (`'l'` or `'r'`), normalised, most specific first: each
    /// `{}` alias with the side letter and with the side word (`left`/`right`).
    #[must_use]
    pub fn labels_for(self, side: char) -> Vec<String> {
        let word = if side == 'l' { "left" } else { "right" };
        let aliases = self.aliases();
        let letter = aliases.iter().map(|a| a.replace("{}", &side.to_string()));
        let worded = aliases
            .iter()
            .filter(|a| a.contains("{}"))
            .map(|a| a.replace("{}", word));
        letter.chain(worded).collect()
    }
}

/// The marker names accepted for each [`Landmark`]: the one table every lookup uses.
///
/// Names are compared *normalised*: the part after the last `:` (Vicon subject prefix), lower
/// case, without `.`, `_`, `-` and spaces, so `R.ASIS`, `RASIS`, `liu:R_ASIS` and `'r asis'` are
/// one name. `{}` is the side: the letter `l`/`r` or the word `left`/`right`. The first alias
/// the file holds wins, so each list goes from the most to the least specific.
///
/// | landmark | accepted names | seen in |
/// |---|---|---|
/// | ASIS | `{}asis` `{}asi` `{}fwt` | OpenSim `R.ASIS`, gaitalytics `RASIS`, Plug-in Gait / CGM2 `RASI`, BTS `r asis`, CMU `RFWT` (front waist) |
/// | PSIS | `{}psis` `{}psi` `{}bwt` | `R.PSIS`, `RPSIS`, PiG / CGM2 `RPSI`, CMU `RBWT` |
/// | sacrum | `sacr` `sacrum` `s2` `vsacral` `sacral` | PiG `SACR`, BTS `sacrum`, OpenSim `S2`, `V.Sacral` |
/// | lateral knee | `{}kne` `{}knee` `{}kneelat` `{}latknee` `{}lfe` `{}lek` `{}knee1` `{}lkne` | PiG / CGM2 `LKNE`, OpenSim `R.Knee`, gaitalytics `LLEK`, BTS `l knee 1` |
/// | medial knee | `{}knm` `{}mkne` `{}kneemed` `{}kneemedial` `{}medknee` `{}mfe` `{}mek` | OpenSim `R.Knee.Medial`, gaitalytics `LMEK` |
/// | lateral ankle | `{}ank` `{}ankle` `{}anklelat` `{}latankle` `{}lmal` `{}lm` `{}lank` | PiG / CGM2 `LANK`, OpenSim `R.Ankle`, gaitalytics `LLM` |
/// | medial ankle | `{}anm` `{}mank` `{}anklemed` `{}anklemedial` `{}medankle` `{}mmal` `{}mm` | OpenSim `R.Ankle.Medial`, gaitalytics `LMM` |
/// | heel | `{}hee` `{}heel` `{}cal` `{}calc` | PiG `LHEE`, OpenSim `R.Heel`, BTS `l heel` |
/// | toe | `{}toe` `{}mt2` `{}toe2` `{}met` `{}p2m` `{}mt5` `{}mt1` | PiG `LTOE`, gaitalytics `LMT2`, BTS `l met`, OpenSim `R.Toe`, `R.MT5` last |
pub const MARKER_NAMES: &[(Landmark, &[&str])] = &[
    (Landmark::Asis, &["{}asis", "{}asi", "{}fwt"]),
    (Landmark::Psis, &["{}psis", "{}psi", "{}bwt"]),
    (
        Landmark::Sacrum,
        &["sacr", "sacrum", "s2", "vsacral", "sacral"],
    ),
    (
        Landmark::KneeLateral,
        &[
            "{}kne",
            "{}knee",
            "{}kneelat",
            "{}latknee",
            "{}lfe",
            "{}lek",
            "{}knee1",
            "{}lkne",
        ],
    ),
    (
        Landmark::KneeMedial,
        &[
            "{}knm",
            "{}mkne",
            "{}kneemed",
            "{}kneemedial",
            "{}medknee",
            "{}mfe",
            "{}mek",
        ],
    ),
    (
        Landmark::AnkleLateral,
        &[
            "{}ank",
            "{}ankle",
            "{}anklelat",
            "{}latankle",
            "{}lmal",
            "{}lm",
            "{}lank",
        ],
    ),
    (
        Landmark::AnkleMedial,
        &[
            "{}anm",
            "{}mank",
            "{}anklemed",
            "{}anklemedial",
            "{}medankle",
            "{}mmal",
            "{}mm",
        ],
    ),
    (Landmark::Heel, &["{}hee", "{}heel", "{}cal", "{}calc"]),
    (
        Landmark::Toe,
        &[
            "{}toe", "{}mt2", "{}toe2", "{}met", "{}p2m", "{}mt5", "{}mt1",
        ],
    ),
];

/// Whether a label looks like a raw skin marker rather than a model output (angles, forces,
/// moments, powers, bone points, virtual centres, unlabelled `*12`), for error messages that list
/// what a file holds.
fn looks_like_marker(label: &str) -> bool {
    let n = normalised_label(label);
    let model_suffix = [
        "angles", "force", "forces", "moment", "moments", "power", "powers",
    ]
    .iter()
    .any(|s| n.ends_with(s));
    let bone_point = n.len() == 4
        && [
            "pel", "lfe", "rfe", "lti", "rti", "lfo", "rfo", "lto", "rto", "hed", "trx",
        ]
        .iter()
        .any(|p| n.starts_with(p))
        && matches!(n.chars().last(), Some('o' | 'a' | 'l' | 'p'));
    !(n.is_empty() || label.trim_start().starts_with('*') || model_suffix || bone_point)
}

impl MarkerSet {
    /// Builds a marker set from per-frame positions, one entry per label in `labels` order.
    ///
    /// Non-finite coordinates are stored as gaps.
    ///
    /// # Errors
    /// [`Error::BadMarkerSet`] for a non-positive rate, no frames, or a frame whose length differs
    /// from the number of labels.
    pub fn new(
        name: impl Into<String>,
        rate_hz: f64,
        labels: Vec<String>,
        frames: Vec<Vec<Option<Point3<f64>>>>,
    ) -> Result<Self> {
        let name = name.into();
        if !(rate_hz.is_finite() && rate_hz > 0.0) {
            return Err(Error::BadMarkerSet {
                name,
                reason: format!("sample rate must be positive, got {rate_hz} Hz"),
            });
        }
        if frames.is_empty() {
            return Err(Error::BadMarkerSet {
                name,
                reason: "no frames".to_string(),
            });
        }
        let mut positions = Vec::with_capacity(frames.len() * labels.len());
        for (frame, row) in frames.into_iter().enumerate() {
            if row.len() != labels.len() {
                return Err(Error::BadMarkerSet {
                    name,
                    reason: format!(
                        "frame {frame} has {} positions for {} labels",
                        row.len(),
                        labels.len()
                    ),
                });
            }
            positions.extend(
                row.into_iter()
                    .map(|p| p.filter(|p| p.coords.iter().all(|c| c.is_finite()))),
            );
        }
        Ok(Self {
            name,
            rate_hz,
            labels,
            positions,
        })
    }

    /// Where the set came from (file name).
    #[must_use]
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Frames per second.
    #[must_use]
    pub fn rate_hz(&self) -> f64 {
        self.rate_hz
    }

    /// Labels in column order, as written in the file.
    #[must_use]
    pub fn labels(&self) -> &[String] {
        &self.labels
    }

    /// Number of frames; frame 0 is at t = 0.
    #[must_use]
    pub fn frame_count(&self) -> usize {
        self.positions.len() / self.labels.len().max(1)
    }

    /// Time of the last frame.
    #[must_use]
    pub fn duration_secs(&self) -> f64 {
        self.frame_count().saturating_sub(1) as f64 / self.rate_hz
    }

    /// The column of the marker called `label`, compared case-insensitively on the part after the
    /// last `:` (so `LHEE` finds `liu:LHEE`).
    #[must_use]
    pub fn marker(&self, label: &str) -> Option<usize> {
        let wanted = base_label(label);
        self.labels
            .iter()
            .position(|l| base_label(l).eq_ignore_ascii_case(wanted))
    }

    /// The column of the first of `aliases` the set holds, compared after dropping the prefix,
    /// case, `.`, `_`, `-` and spaces (so `"RASIS"` finds `R.ASIS`). Marker names differ between
    /// labs; this lets one list cover Vicon, OpenSim and Plug-in Gait spellings.
    #[must_use]
    pub fn find_marker(&self, aliases: &[&str]) -> Option<usize> {
        let labels: Vec<String> = self.labels.iter().map(|l| normalised_label(l)).collect();
        aliases.iter().find_map(|alias| {
            let alias = normalised_label(alias);
            labels.iter().position(|l| *l == alias)
        })
    }

    /// The column of `landmark` on `side` (`'l'`/`'r'`; ignored for the sacrum), by
    /// [`MARKER_NAMES`].
    #[must_use]
    pub fn landmark(&self, landmark: Landmark, side: char) -> Option<usize> {
        let names = if landmark.sided() {
            landmark.labels_for(side)
        } else {
            landmark.aliases().iter().map(|a| a.to_string()).collect()
        };
        let refs: Vec<&str> = names.iter().map(String::as_str).collect();
        self.find_marker(&refs)
    }

    /// The labels that look like raw skin markers (model outputs, bone points and unlabelled
    /// `*n` points left out), as written in the file: what an error lists as found.
    #[must_use]
    pub fn marker_labels(&self) -> Vec<&str> {
        self.labels
            .iter()
            .map(|l| base_label(l))
            .filter(|l| looks_like_marker(l))
            .collect()
    }

    /// Position of marker `label` in `frame`; `None` for a gap or an unknown label or frame.
    #[must_use]
    pub fn position(&self, frame: usize, label: &str) -> Option<Point3<f64>> {
        self.position_at_column(frame, self.marker(label)?)
    }

    /// Position of the marker in `column` in `frame`; `None` for a gap or out of range.
    #[must_use]
    pub fn position_at_column(&self, frame: usize, column: usize) -> Option<Point3<f64>> {
        if column >= self.labels.len() || frame >= self.frame_count() {
            return None;
        }
        self.positions
            .get(frame * self.labels.len() + column)
            .copied()
            .flatten()
    }

    /// The whole trajectory of the marker in `column`, one entry per frame (empty when the column
    /// does not exist).
    #[must_use]
    pub fn trajectory(&self, column: usize) -> Vec<Option<Point3<f64>>> {
        if column >= self.labels.len() {
            return Vec::new();
        }
        (0..self.frame_count())
            .map(|f| self.position_at_column(f, column))
            .collect()
    }

    /// Number of frames in which the marker in `column` is missing.
    #[must_use]
    pub fn missing_frames(&self, column: usize) -> usize {
        self.trajectory(column)
            .iter()
            .filter(|p| p.is_none())
            .count()
    }

    /// Per-marker gap counts, for every marker with at least one missing frame.
    #[must_use]
    pub fn gaps(&self) -> Vec<MarkerGaps> {
        (0..self.labels.len())
            .map(|column| MarkerGaps {
                label: self.labels[column].clone(),
                missing_frames: self.missing_frames(column),
            })
            .filter(|g| g.missing_frames > 0)
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn set() -> MarkerSet {
        let p = |x: f64| Some(Point3::new(x, 0.0, 0.0));
        MarkerSet::new(
            "t",
            100.0,
            vec!["liu:LHEE".into(), "R.ASIS".into()],
            vec![
                vec![p(1.0), None],
                vec![p(2.0), p(f64::NAN)],
                vec![None, p(3.0)],
            ],
        )
        .unwrap()
    }

    /// Lookups ignore the subject prefix and case; aliases also ignore punctuation.
    #[test]
    fn lookups() {
        let s = set();
        assert_eq!(s.marker("LHEE"), Some(0));
        assert_eq!(s.marker("lhee"), Some(0));
        assert_eq!(s.marker("other:LHEE"), Some(0));
        assert_eq!(s.marker("RASIS"), None);
        assert_eq!(s.find_marker(&["RFWT", "RASIS"]), Some(1));
        assert_eq!(s.position(1, "LHEE").unwrap().x, 2.0);
        assert_eq!(s.position(5, "LHEE"), None);
        assert_eq!(s.frame_count(), 3);
        assert!((s.duration_secs() - 0.02).abs() < 1e-12);
    }

    /// NaN and None are gaps, counted per marker.
    #[test]
    fn gaps_are_counted() {
        let s = set();
        assert_eq!(
            s.gaps(),
            vec![
                MarkerGaps {
                    label: "liu:LHEE".into(),
                    missing_frames: 1
                },
                MarkerGaps {
                    label: "R.ASIS".into(),
                    missing_frames: 2
                }
            ]
        );
    }

    /// Ragged frames and bad rates are typed errors.
    #[test]
    fn rejects_malformed() {
        assert!(matches!(
            MarkerSet::new("x", 0.0, vec!["a".into()], vec![vec![None]]),
            Err(Error::BadMarkerSet { .. })
        ));
        assert!(matches!(
            MarkerSet::new("x", 1.0, vec!["a".into()], vec![vec![None, None]]),
            Err(Error::BadMarkerSet { .. })
        ));
        assert!(matches!(
            MarkerSet::new("x", 1.0, vec!["a".into()], vec![]),
            Err(Error::BadMarkerSet { .. })
        ));
    }
}
