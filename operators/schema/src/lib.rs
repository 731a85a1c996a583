//! The Arrow messages that cross trigait's dataflow edges, defined once (DESIGN.md: "One message
//! schema crate … Nodes never invent ad-hoc byte layouts").
//!
//! | message | edge | Rust type |
//! |---|---|---|
//! | `skeleton_frame` | `kinect-source → sync` | [`SkeletonFrameMessage`] (a [`trigait_skeleton::SkeletonFrame`]) |
//! | `ntp_exchange` | `sync ↔ kinect-source` (thesis §6.4.1) | [`NtpExchange`] |
//! | `aligned_set` | `sync → trilaterate` | [`trigait_sync::AlignedSet`] |
//! | `fused_pose` | `trilaterate → recorder` | [`FusedPose`] |
//! | `frame_timing` | `sync → recorder` | [`FrameTiming`] |
//! | `ground_truth` | one simulated `kinect-source → recorder` | [`GroundTruth`] (world frame, once per true instant) |
//! | `depth_frame` | `kinect-source → depth-metrics` | [`DepthFrameMessage`] |
//!
//! Port ids and metadata keys are in [`ports`]. `MESSAGES.md` beside this crate's `Cargo.toml`
//! describes every message language-neutrally (a table per message: field, Arrow type,
//! nullability, unit, frame), for stages written in other languages; a test keeps it in step
//! with the types here.
//!
//! Every message is a `StructArray` with **one row per message** (a node sends one row; a
//! recording may hold many), nested with `List<Struct>` for joints and sensors. Points are
//! `FixedSizeList<Float64, 3>` in metres, covariances `FixedSizeList<Float64, 9>` row-major in m²,
//! timestamps `Int64` nanoseconds, joints `UInt8` Kinect v2 `JointType` numbers, tracking states
//! `UInt8` SDK numbers. A position's field name says its frame: `position_in_kinect_m` (the
//! sensor's camera space) or `position_in_world_m`. [`Message::data_type`] gives the exact type
//! for `output_types` checks and for readers in other languages.
//!
//! Decoding never trusts its input: a wrong type, a missing column, a wrong tuple length, a null
//! where a value is required or an out-of-range code is an [`Error`] naming the field by its
//! dotted path (`aligned_set.sensors.joints.position_in_kinect_m`), never a panic.
//!
//! Only `arrow-array`, `arrow-schema` and `arrow-buffer` are used, not the `arrow` umbrella: the
//! umbrella also compiles compute kernels, casts and formatting (arrow-cast, -arith, -ord,
//! -select, -string) that encoding and decoding do not need. They are the same crates (major 59)
//! that `dora-node-api`'s `arrow-v59` feature re-exports, so an `ArrayRef` from here is the one
//! `send_output` takes.
#![warn(missing_docs)]

mod aligned;
mod codec;
mod depth;
mod fused;
mod ir;
#[cfg(test)]
mod messages_md;
mod ntp;
pub mod ports;
mod skeleton;
mod status;
mod timing;
mod truth;

pub use arrow_array::{Array, ArrayRef};
pub use arrow_schema::DataType;
pub use depth::DepthFrameMessage;
pub use fused::{FusedJoint, FusedPose};
pub use ir::IrFrameMessage;
pub use ntp::NtpExchange;
pub use skeleton::SkeletonFrameMessage;
pub use status::SensorStatus;
pub use timing::FrameTiming;
pub use truth::GroundTruth;

/// What can go wrong encoding or decoding a message. `field` is a dotted path from the message
/// name (`skeleton_frame.joints.state`); `row` indexes the array that field lives in.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The array at `field` has another Arrow type.
    #[error("{field}: expected {expected}, found {found}")]
    WrongType {
        /// Dotted path of the field.
        field: String,
        /// The type this schema uses.
        expected: String,
        /// The type found.
        found: String,
    },
    /// A struct lacks a column.
    #[error("{field}: missing column")]
    MissingColumn {
        /// Dotted path of the missing column.
        field: String,
    },
    /// A fixed-size tuple or a column has the wrong length.
    #[error("{field}: expected length {expected}, found {found}")]
    BadLength {
        /// Dotted path of the field.
        field: String,
        /// Length this schema uses.
        expected: usize,
        /// Length found.
        found: usize,
    },
    /// A null where the schema requires a value.
    #[error("{field}: null in row {row}")]
    NullValue {
        /// Dotted path of the field.
        field: String,
        /// Row within that field's array.
        row: usize,
    },
    /// A value outside its domain (joint number 30, tracking state 7, unknown policy name, …).
    #[error("{field}: invalid value {value} in row {row}, expected {expected}")]
    InvalidValue {
        /// Dotted path of the field.
        field: String,
        /// Row within that field's array.
        row: usize,
        /// The value found.
        value: String,
        /// What would have been valid.
        expected: &'static str,
    },
    /// [`Message::decode`] wants exactly one message.
    #[error("{message}: expected exactly one row, found {found}")]
    RowCount {
        /// Message name.
        message: &'static str,
        /// Rows found.
        found: usize,
    },
    /// Arrow refused to build the arrays from a value (e.g. a confidence list of the wrong
    /// length).
    #[error("{message}: cannot encode: {detail}")]
    Encode {
        /// Message name.
        message: &'static str,
        /// What was wrong.
        detail: String,
    },
}

/// This crate's result type.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// A type that crosses a dataflow edge as Arrow.
pub trait Message: Sized {
    /// The message name, first component of every error path.
    const NAME: &'static str;

    /// The Arrow type of the encoded array (a `Struct`).
    #[must_use]
    fn data_type() -> DataType;

    /// Encodes `messages` as one array, one row each.
    fn encode_many(messages: &[Self]) -> Result<ArrayRef>;

    /// Decodes every row of `array`.
    fn decode_many(array: &dyn Array) -> Result<Vec<Self>>;

    /// Encodes one message as a one-row array (what a node sends).
    fn encode(&self) -> Result<ArrayRef> {
        Self::encode_many(std::slice::from_ref(self))
    }

    /// Decodes an array that must hold exactly one message.
    fn decode(array: &dyn Array) -> Result<Self> {
        let mut all = Self::decode_many(array)?;
        match (all.pop(), all.len()) {
            (Some(one), 0) => Ok(one),
            (last, rest) => Err(Error::RowCount {
                message: Self::NAME,
                found: rest + usize::from(last.is_some()),
            }),
        }
    }
}
