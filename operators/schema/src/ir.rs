//! `ir_frame`: one infrared amplitude image of one sensor (`kinect-source` output `ir`, the
//! `freenect2` backend with `FREENECT2_IR`), the same capture as the `depth_frame` of equal
//! `seq`.
//!
//! ```text
//! Struct { sensor_id: Utf8, seq: UInt64, local_stamp_nanos: Int64 (sensor clock),
//!          width: UInt32, height: UInt32, amplitude: List<UInt16> (row-major) }
//! ```
//! The layout and checks are `depth_frame`'s (one contiguous `UInt16` buffer; a pixel count
//! that is not `width × height` is refused); a message of its own keeps a consumer from
//! reading amplitudes as millimetres.

use crate::depth::image_message;

/// One IR amplitude image of one sensor.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct IrFrameMessage {
    /// The sensor (`k1`).
    pub sensor_id: String,
    /// Frame number on this sensor's stream, the `seq` of the depth frame of the same capture.
    pub seq: u64,
    /// Capture stamp on the sensor clock, nanoseconds.
    pub local_stamp_nanos: i64,
    /// Columns (Kinect v2: 512).
    pub width: u32,
    /// Rows (Kinect v2: 424).
    pub height: u32,
    /// Row-major IR amplitude, unitless 0–65535.
    pub amplitude: Vec<u16>,
}

image_message!(IrFrameMessage, "ir_frame", amplitude);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{DepthFrameMessage, Error, Message};

    /// A frame survives the round trip; a wrong pixel count is refused naming `ir_frame`; a
    /// depth frame is not an IR frame.
    #[test]
    fn round_trip_and_not_a_depth_frame() {
        let ir = IrFrameMessage {
            sensor_id: "k1".into(),
            seq: 4,
            local_stamp_nanos: 99,
            width: 3,
            height: 2,
            amplitude: vec![0, 1, 200, 65535, 7, 8],
        };
        let array = ir.encode().unwrap();
        assert_eq!(array.data_type(), &IrFrameMessage::data_type());
        assert_eq!(IrFrameMessage::decode(array.as_ref()).unwrap(), ir);
        let mut bad = ir.clone();
        bad.amplitude.pop();
        assert!(matches!(
            bad.encode(),
            Err(Error::Encode {
                message: "ir_frame",
                ..
            })
        ));
        let depth = DepthFrameMessage {
            sensor_id: "k1".into(),
            seq: 4,
            local_stamp_nanos: 99,
            width: 3,
            height: 2,
            depth_mm: ir.amplitude.clone(),
        };
        assert!(IrFrameMessage::decode(depth.encode().unwrap().as_ref()).is_err());
        assert!(DepthFrameMessage::decode(array.as_ref()).is_err());
    }
}
