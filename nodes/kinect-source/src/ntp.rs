//! Answering `sync`'s `ntp_request`s (thesis §6.4.1), the same for every backend: a request for
//! another sensor is ignored, a malformed one skipped and counted, and the reply carries the
//! sensor clock's receive and send stamps.

use dora_node_api::dora_core::config::DataId;
use dora_node_api::{DoraNode, MetadataParameters};
use eyre::Context;
use tracing::warn;
use trigait_schema::{Array, Message, NtpExchange, ports};

/// What the node counts of the requests it was sent.
pub struct NtpCounts<'a> {
    /// Requests answered.
    pub answered: &'a mut u64,
    /// Inputs that were no `ntp_exchange` (skipped).
    pub malformed: &'a mut u64,
}

/// Where and for whom a source answers.
pub struct Responder {
    out: DataId,
    sensor_id: String,
}

impl Responder {
    /// Replies on the `ntp_reply` output to requests for `sensor_id`.
    pub fn new(sensor_id: &str) -> Self {
        Responder {
            out: DataId::from(ports::NTP_REPLY.to_owned()),
            sensor_id: sensor_id.to_owned(),
        }
    }

    /// Answers the request in `data` if it is addressed to this sensor, and counts it. `t2` is
    /// its receive stamp on the sensor clock; `t3` is called only for a request of this
    /// sensor, just before the reply is encoded, for the send stamp (a backend may note there
    /// that the receiver listens). The reply keeps the request's metadata.
    ///
    /// # Errors
    /// Encoding or sending the reply failed.
    pub fn answer(
        &self,
        node: &mut DoraNode,
        parameters: MetadataParameters,
        data: &dyn Array,
        t2: i64,
        t3: impl FnOnce() -> i64,
        counts: NtpCounts<'_>,
    ) -> eyre::Result<()> {
        let request = match NtpExchange::decode(data) {
            Ok(r) => r,
            Err(e) => {
                *counts.malformed += 1;
                warn!("skipping a malformed ntp_request: {e}");
                return Ok(());
            }
        };
        if request.sensor_id != self.sensor_id {
            return Ok(());
        }
        let reply = request.answered(t2, t3());
        let array = reply.encode().context("encoding the NTP reply")?;
        node.send_output(self.out.clone(), parameters, array)
            .context("kinect-source: sending ntp_reply")?;
        *counts.answered += 1;
        Ok(())
    }
}
