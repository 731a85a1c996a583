use trigait_skeleton::{ClipError, Joint};

/// Why a gait analysis, filter or plot could not be produced.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The clip lacks a joint the analysis needs.
    #[error("the clip has no {joint} trajectory (needed: {why})", joint = joint.name())]
    MissingJoint {
        /// The absent joint.
        joint: Joint,
        /// What it is needed for.
        why: &'static str,
    },
    /// No straight walking was found: the subject stood, turned, or the data has gaps.
    #[error(
        "no straight walking of at least {min_segment_secs:.2} s found in {duration_secs:.2} s of \
         motion (standing {standing_secs:.2} s, turning {turning_secs:.2} s, gaps \
         {gap_secs:.2} s, walking too briefly {short_secs:.2} s, feet not alternating (hopping, \
         jumping) {not_alternating_secs:.2} s)"
    )]
    NoWalking {
        /// Length of the clip.
        duration_secs: f64,
        /// Time the pelvis moved slower than the walking threshold.
        standing_secs: f64,
        /// Time the heading changed faster than the turning threshold.
        turning_secs: f64,
        /// Time a needed joint was missing (gap, NaN).
        gap_secs: f64,
        /// Time of walking runs shorter than the minimum segment length.
        short_secs: f64,
        /// Time the pelvis travelled but the feet did not alternate.
        not_alternating_secs: f64,
        /// The minimum segment length that was asked for.
        min_segment_secs: f64,
    },
    /// Too few complete strides for parameters.
    #[error(
        "found {got} complete strides{}, need at least {} (heel strikes: {heel_strikes_left} \
         left, {heel_strikes_right} right, in {walking_secs:.2} s of straight walking; excluded: \
         standing {standing_secs:.2} s, turning {turning_secs:.2} s, gaps {gap_secs:.2} s); a \
         stride runs from one heel strike to the next of the same foot inside one straight segment",
        if *need == 0 { format!(" and {steps} steps") } else { String::new() },
        if *need == 0 { "one step".to_owned() } else { need.to_string() }
    )]
    TooFewStrides {
        /// Complete strides found (both feet).
        got: usize,
        /// Strides needed; with 0, one step (heel strike to the other foot's next) suffices.
        need: usize,
        /// Single steps found.
        steps: usize,
        /// Left heel strikes found.
        heel_strikes_left: usize,
        /// Right heel strikes found.
        heel_strikes_right: usize,
        /// Time spent in straight walking segments.
        walking_secs: f64,
        /// Time excluded as standing.
        standing_secs: f64,
        /// Time excluded as turning.
        turning_secs: f64,
        /// Time excluded for missing joints (gaps, NaN).
        gap_secs: f64,
    },
    /// A numeric parameter is out of range.
    #[error("parameter {name} = {value} is invalid: expected {expected}")]
    BadParameter {
        /// Parameter name as written in the CLI/YAML.
        name: &'static str,
        /// The rejected value.
        value: f64,
        /// What would have been accepted.
        expected: &'static str,
    },
    /// A filter specification string could not be parsed.
    #[error("unknown filter {spec:?}: expected {expected}")]
    BadFilterSpec {
        /// The rejected text.
        spec: String,
        /// Accepted forms.
        expected: &'static str,
    },
    /// A filtered or derived clip could not be rebuilt.
    #[error("could not build the motion clip")]
    Clip(#[from] ClipError),
    /// The plotting backend failed.
    #[error("plot {plot:?} could not be drawn: {message}")]
    Plot {
        /// Which plot.
        plot: &'static str,
        /// The backend's message.
        message: String,
    },
}

/// Result alias for this crate.
pub type Result<T> = std::result::Result<T, Error>;
