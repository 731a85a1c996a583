//! The four-timestamp exchange of thesis §6.4.1 (eq. 6.1–6.3).
//!
//! # Who is the client
//!
//! In the thesis each Kinect PC is an NTP client of the fusion server. In our dataflow the
//! `sync` node *initiates* the exchange instead: it stamps `t1` on its own clock (the dataflow's
//! reference, "server time") and sends a request to a source; the source stamps `t2` when the
//! request arrives and `t3` when it replies, both on the sensor's clock; `sync` stamps `t4` when
//! the reply arrives. So `t1`, `t4` are server time and `t2`, `t3` are sensor-local time. The
//! sources stay stateless (answer and forget) and the offset lands where it is used: in `sync`,
//! which maps every frame to server time. The arithmetic is eq. 6.2 unchanged; with these roles
//! the offset `t` it yields is how far the **sensor clock is ahead of the server clock**:
//!
//! ```text
//!   local = server + offset        offset = ((t2 − t1) − (t4 − t3)) / 2
//!   delay = (t2 − t1) + (t4 − t3)  |error of offset| ≤ delay / 2   (eq. 6.3)
//! ```

/// One completed exchange: `t1`, `t4` on the server (sync node) clock, `t2`, `t3` on the
/// sensor's clock, all in nanoseconds (see the module docs for the roles).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct NtpSample {
    /// Request leaves the sync node (server clock).
    pub t1: i64,
    /// Request reaches the sensor (sensor clock).
    pub t2: i64,
    /// Reply leaves the sensor (sensor clock).
    pub t3: i64,
    /// Reply reaches the sync node (server clock).
    pub t4: i64,
}

/// Why a sample was not used; every field is in nanoseconds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Rejection {
    /// `t4 < t1`: the reply came back before the request left, on the server's own clock.
    ReplyBeforeRequest {
        /// `t4 − t1`.
        round_trip_nanos: i64,
    },
    /// `t3 < t2`: the sensor replied before it received the request, on its own clock.
    NegativeProcessing {
        /// `t3 − t2`.
        processing_nanos: i64,
    },
    /// The round trip minus the sensor's processing time is negative: impossible on a real link.
    NegativeDelay {
        /// `(t2 − t1) + (t4 − t3)`.
        delay_nanos: i64,
    },
    /// The timestamps are so far apart that the arithmetic would overflow `i64`.
    Overflow,
    /// The round-trip delay exceeds [`ClockFilterParams::max_delay_nanos`](crate::ClockFilterParams::max_delay_nanos).
    DelayAboveLimit {
        /// The sample's delay.
        delay_nanos: i64,
        /// The configured limit.
        limit_nanos: i64,
    },
    /// The request was sent before the newest sample already accepted (a reordered or replayed
    /// reply).
    OutOfOrder {
        /// This sample's `t1`.
        t1: i64,
        /// `t1` of the newest accepted sample.
        newest_t1: i64,
    },
    /// The offset disagrees with the current estimate by more than the error bounds allow, and
    /// not (yet) consistently enough to be a clock step.
    Inconsistent {
        /// Measured minus predicted offset.
        residual_nanos: i64,
        /// What the residual was allowed to be.
        allowed_nanos: i64,
    },
}

impl std::fmt::Display for Rejection {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Rejection::ReplyBeforeRequest { round_trip_nanos } => {
                write!(f, "reply before request (t4 - t1 = {round_trip_nanos} ns)")
            }
            Rejection::NegativeProcessing { processing_nanos } => {
                write!(
                    f,
                    "negative processing time (t3 - t2 = {processing_nanos} ns)"
                )
            }
            Rejection::NegativeDelay { delay_nanos } => {
                write!(f, "negative round-trip delay ({delay_nanos} ns)")
            }
            Rejection::Overflow => f.write_str("timestamps too far apart (i64 overflow)"),
            Rejection::DelayAboveLimit {
                delay_nanos,
                limit_nanos,
            } => write!(f, "delay {delay_nanos} ns above the limit {limit_nanos} ns"),
            Rejection::OutOfOrder { t1, newest_t1 } => {
                write!(
                    f,
                    "out of order (t1 = {t1} ns, newest accepted t1 = {newest_t1} ns)"
                )
            }
            Rejection::Inconsistent {
                residual_nanos,
                allowed_nanos,
            } => write!(
                f,
                "offset residual {residual_nanos} ns exceeds the allowed {allowed_nanos} ns"
            ),
        }
    }
}

/// What one valid exchange measures (thesis eq. 6.2–6.3).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct NtpMeasurement {
    /// Sensor clock minus server clock, nanoseconds (eq. 6.2, `t`).
    pub offset_nanos: i64,
    /// Round-trip network delay without the sensor's processing time (eq. 6.2, `d`).
    pub delay_nanos: i64,
    /// Server time the offset refers to: the midpoint of `t1` and `t4`.
    pub server_mid_nanos: i64,
}

impl NtpMeasurement {
    /// The eq. 6.3 bound on the offset error, `d / 2` (rounded up).
    #[must_use]
    pub fn error_bound_nanos(&self) -> i64 {
        self.delay_nanos.saturating_add(1) / 2
    }
}

impl NtpSample {
    /// Offset and delay (eq. 6.2), or why the timestamps cannot come from a real exchange.
    ///
    /// Exact in 128-bit integers, so any `i64` input is handled without panicking.
    pub fn measure(&self) -> Result<NtpMeasurement, Rejection> {
        let (t1, t2, t3, t4) = (
            i128::from(self.t1),
            i128::from(self.t2),
            i128::from(self.t3),
            i128::from(self.t4),
        );
        let round_trip = t4 - t1;
        if round_trip < 0 {
            return Err(Rejection::ReplyBeforeRequest {
                round_trip_nanos: saturate(round_trip),
            });
        }
        let processing = t3 - t2;
        if processing < 0 {
            return Err(Rejection::NegativeProcessing {
                processing_nanos: saturate(processing),
            });
        }
        let delay = round_trip - processing;
        if delay < 0 {
            return Err(Rejection::NegativeDelay {
                delay_nanos: saturate(delay),
            });
        }
        // Floor division keeps the offset exact to the nanosecond for either sign.
        let offset = ((t2 - t1) - (t4 - t3)).div_euclid(2);
        let mid = t1 + round_trip / 2;
        match (
            i64::try_from(offset),
            i64::try_from(delay),
            i64::try_from(mid),
        ) {
            (Ok(offset_nanos), Ok(delay_nanos), Ok(server_mid_nanos)) => Ok(NtpMeasurement {
                offset_nanos,
                delay_nanos,
                server_mid_nanos,
            }),
            _ => Err(Rejection::Overflow),
        }
    }
}

fn saturate(v: i128) -> i64 {
    i64::try_from(v).unwrap_or(if v < 0 { i64::MIN } else { i64::MAX })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Eq. 6.1 forward, eq. 6.2 back: with symmetric delays the offset is exact and the delay is
    /// the sum of both legs.
    #[test]
    fn symmetric_exchange_recovers_offset() {
        let offset = 12_345_678; // sensor ahead by 12.3 ms
        let (d1, d2, processing) = (300_000, 300_000, 50_000);
        let t1 = 1_000_000_000;
        let t2 = t1 + d1 + offset;
        let t3 = t2 + processing;
        let t4 = t3 - offset + d2;
        let m = NtpSample { t1, t2, t3, t4 }.measure().unwrap();
        assert_eq!(m.offset_nanos, offset);
        assert_eq!(m.delay_nanos, d1 + d2);
        assert_eq!(m.error_bound_nanos(), 300_000);
        assert_eq!(m.server_mid_nanos, t1 + (d1 + d2 + processing) / 2);
    }

    /// With asymmetric delays the error is (d1 − d2)/2, inside the ±d/2 bound of eq. 6.3.
    #[test]
    fn asymmetric_error_is_within_bound() {
        let offset = -40_000_000;
        let (d1, d2) = (900_000, 100_000);
        let t1 = 5_000;
        let t2 = t1 + d1 + offset;
        let t3 = t2 + 1_000;
        let t4 = t3 - offset + d2;
        let m = NtpSample { t1, t2, t3, t4 }.measure().unwrap();
        assert_eq!(m.offset_nanos - offset, (d1 - d2) / 2);
        assert!((m.offset_nanos - offset).abs() <= m.error_bound_nanos());
    }

    /// Impossible stamps are rejected with the reason, and extreme values do not overflow.
    #[test]
    fn garbage_is_rejected() {
        let s = NtpSample {
            t1: 10,
            t2: 0,
            t3: 0,
            t4: 5,
        };
        assert_eq!(
            s.measure(),
            Err(Rejection::ReplyBeforeRequest {
                round_trip_nanos: -5
            })
        );
        let s = NtpSample {
            t1: 0,
            t2: 10,
            t3: 5,
            t4: 20,
        };
        assert_eq!(
            s.measure(),
            Err(Rejection::NegativeProcessing {
                processing_nanos: -5
            })
        );
        let s = NtpSample {
            t1: 0,
            t2: 0,
            t3: 30,
            t4: 20,
        };
        assert_eq!(
            s.measure(),
            Err(Rejection::NegativeDelay { delay_nanos: -10 })
        );
        let s = NtpSample {
            t1: i64::MIN,
            t2: i64::MAX,
            t3: i64::MAX,
            t4: i64::MAX,
        };
        assert_eq!(s.measure(), Err(Rejection::Overflow));
    }
}
