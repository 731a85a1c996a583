//! `ntp_exchange`: the four-timestamp exchange of thesis §6.4.1 as it travels `sync →
//! kinect-source → sync` (see [`trigait_sync::ntp`] for who stamps what).
//!
//! ```text
//! Struct { sensor_id: Utf8, request_id: UInt64, t1_nanos: Int64,
//!          t2_nanos: Int64?, t3_nanos: Int64?, t4_nanos: Int64? }
//! ```
//! A request carries only `t1` (server clock); the reply adds `t2`, `t3` (sensor clock); `sync`
//! adds `t4` (server clock) when the reply arrives, e.g. before logging it.

use arrow_array::types::{Int64Type, UInt64Type};
use arrow_array::{Array, ArrayRef, Int64Array, StringArray, UInt64Array};
use arrow_schema::{DataType, Fields};
use trigait_sync::NtpSample;

use crate::codec::{decode_rows, encode_struct, field, nullable, struct_of};
use crate::{Message, Result};

/// One NTP exchange in any of its three stages (request, reply, completed).
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct NtpExchange {
    /// The sensor asked.
    pub sensor_id: String,
    /// Chosen by `sync` to match replies to requests.
    pub request_id: u64,
    /// Request leaves `sync` (server clock), nanoseconds.
    pub t1_nanos: i64,
    /// Request reaches the sensor (sensor clock); set by the reply.
    pub t2_nanos: Option<i64>,
    /// Reply leaves the sensor (sensor clock); set by the reply.
    pub t3_nanos: Option<i64>,
    /// Reply reaches `sync` (server clock).
    pub t4_nanos: Option<i64>,
}

impl NtpExchange {
    /// A request from `sync`, sent at server time `t1_nanos`.
    #[must_use]
    pub fn request(sensor_id: impl Into<String>, request_id: u64, t1_nanos: i64) -> Self {
        NtpExchange {
            sensor_id: sensor_id.into(),
            request_id,
            t1_nanos,
            t2_nanos: None,
            t3_nanos: None,
            t4_nanos: None,
        }
    }

    /// The sensor's reply: received at `t2_nanos`, sent at `t3_nanos`, on its clock.
    #[must_use]
    pub fn answered(mut self, t2_nanos: i64, t3_nanos: i64) -> Self {
        self.t2_nanos = Some(t2_nanos);
        self.t3_nanos = Some(t3_nanos);
        self
    }

    /// Completed by `sync` with the arrival time of the reply.
    #[must_use]
    pub fn completed(mut self, t4_nanos: i64) -> Self {
        self.t4_nanos = Some(t4_nanos);
        self
    }

    /// The four stamps, once all are present.
    #[must_use]
    pub fn sample(&self) -> Option<NtpSample> {
        Some(NtpSample {
            t1: self.t1_nanos,
            t2: self.t2_nanos?,
            t3: self.t3_nanos?,
            t4: self.t4_nanos?,
        })
    }
}

fn fields() -> Fields {
    Fields::from(vec![
        field("sensor_id", DataType::Utf8),
        field("request_id", DataType::UInt64),
        field("t1_nanos", DataType::Int64),
        nullable("t2_nanos", DataType::Int64),
        nullable("t3_nanos", DataType::Int64),
        nullable("t4_nanos", DataType::Int64),
    ])
}

impl Message for NtpExchange {
    const NAME: &'static str = "ntp_exchange";

    fn data_type() -> DataType {
        struct_of(fields())
    }

    fn encode_many(messages: &[Self]) -> Result<ArrayRef> {
        encode_struct::<Self>(&fields(), |b| {
            Ok(vec![
                b.strings(messages.iter().map(|m| m.sensor_id.as_str())),
                b.values::<UInt64Type>(messages.iter().map(|m| m.request_id)),
                b.values::<Int64Type>(messages.iter().map(|m| m.t1_nanos)),
                b.optionals::<Int64Type>(messages.iter().map(|m| m.t2_nanos)),
                b.optionals::<Int64Type>(messages.iter().map(|m| m.t3_nanos)),
                b.optionals::<Int64Type>(messages.iter().map(|m| m.t4_nanos)),
            ])
        })
    }

    fn decode_many(array: &dyn Array) -> Result<Vec<Self>> {
        decode_rows(array, |top| {
            let sensor_ids = top.column::<StringArray>("sensor_id")?;
            let ids = top.column::<UInt64Array>("request_id")?;
            let t1 = top.column::<Int64Array>("t1_nanos")?;
            let t2 = top.column::<Int64Array>("t2_nanos")?;
            let t3 = top.column::<Int64Array>("t3_nanos")?;
            let t4 = top.column::<Int64Array>("t4_nanos")?;
            Ok(move |row| {
                Ok(NtpExchange {
                    sensor_id: sensor_ids.get(row)?,
                    request_id: ids.get(row)?,
                    t1_nanos: t1.get(row)?,
                    t2_nanos: t2.optional(row),
                    t3_nanos: t3.optional(row),
                    t4_nanos: t4.optional(row),
                })
            })
        })
    }
}
