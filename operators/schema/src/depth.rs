//! `depth_frame`: one raw depth image of one sensor (`kinect-source → depth-metrics`), the
//! input of the thesis's five depth metrics (ch. 3, §5.1) on the live stream.
//!
//! ```text
//! Struct { sensor_id: Utf8, seq: UInt64, local_stamp_nanos: Int64 (sensor clock),
//!          width: UInt32, height: UInt32, depth_mm: List<UInt16> (row-major, 0 = no data) }
//! ```
//! A Kinect v2 frame is 512×424 = 217 088 values (434 KB); one `UInt16` array per frame is
//! one contiguous buffer, which dora moves through shared memory without copying it again.
//! Width and height travel with the pixels so a consumer can check them instead of guessing:
//! decoding refuses a frame whose pixel count is not `width × height` (or is empty), whatever
//! the producer. Whether the size is the one a metric expects (512×424) is the consumer's
//! check (`trigait_depth::DepthFrame::from_mm`).

use std::sync::Arc;

use arrow_array::types::{Int64Type, UInt16Type, UInt32Type, UInt64Type};
use arrow_array::{
    Array, ArrayRef, Int64Array, StringArray, UInt16Array, UInt32Array, UInt64Array,
};
use arrow_schema::{DataType, Fields};

use crate::codec::{Builder, Col, Rows, field, list_of, list_range, struct_of};
use crate::{Error, Message, Result};

/// One depth image of one sensor.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DepthFrameMessage {
    /// The sensor (`k1`).
    pub sensor_id: String,
    /// Frame number on this sensor's depth stream, from 0.
    pub seq: u64,
    /// Capture stamp on the sensor clock, nanoseconds.
    pub local_stamp_nanos: i64,
    /// Columns (Kinect v2: 512).
    pub width: u32,
    /// Rows (Kinect v2: 424).
    pub height: u32,
    /// Row-major depth in millimetres along the optical axis, 0 = no data.
    pub depth_mm: Vec<u16>,
}

impl DepthFrameMessage {
    /// Checks that the pixel count is `width × height` and not zero.
    ///
    /// # Errors
    /// [`Error::BadLength`] on `depth_frame.depth_mm`.
    pub fn validate(&self) -> Result<()> {
        self.image().check(Self::NAME, Self::PIXELS)
    }
}

/// Implements [`Message`] and [`ImageMessage`] for `$ty`, a struct with the [`Image`] fields
/// and its pixels in the field `$pixels`, as the message `$name` whose pixel column is named
/// after that field.
macro_rules! image_message {
    ($ty:ident, $name:literal, $pixels:ident) => {
        impl $crate::Message for $ty {
            const NAME: &'static str = $name;

            fn data_type() -> arrow_schema::DataType {
                $crate::depth::image_data_type::<Self>()
            }

            fn encode_many(messages: &[Self]) -> $crate::Result<arrow_array::ArrayRef> {
                $crate::depth::encode_images(messages)
            }

            fn decode_many(array: &dyn arrow_array::Array) -> $crate::Result<Vec<Self>> {
                $crate::depth::decode_images(array)
            }
        }

        impl $crate::depth::ImageMessage for $ty {
            const PIXELS: &'static str = stringify!($pixels);

            fn image(&self) -> $crate::depth::Image<&str, &[u16]> {
                $crate::depth::Image {
                    sensor_id: &self.sensor_id,
                    seq: self.seq,
                    local_stamp_nanos: self.local_stamp_nanos,
                    width: self.width,
                    height: self.height,
                    pixels: &self.$pixels,
                }
            }

            fn from_image(i: $crate::depth::Image<String, Vec<u16>>) -> Self {
                $ty {
                    sensor_id: i.sensor_id,
                    seq: i.seq,
                    local_stamp_nanos: i.local_stamp_nanos,
                    width: i.width,
                    height: i.height,
                    $pixels: i.pixels,
                }
            }
        }
    };
}
pub(crate) use image_message;

image_message!(DepthFrameMessage, "depth_frame", depth_mm);

/// One 16-bit image of one sensor's stream, the layout `depth_frame` and `ir_frame` share
/// (they differ in the name and meaning of the pixel column): `P` is the pixels, borrowed
/// when encoding and owned when decoded, and so is `S`, the sensor id.
pub(crate) struct Image<S, P> {
    pub(crate) sensor_id: S,
    pub(crate) seq: u64,
    pub(crate) local_stamp_nanos: i64,
    pub(crate) width: u32,
    pub(crate) height: u32,
    pub(crate) pixels: P,
}

impl<S, P: AsRef<[u16]>> Image<S, P> {
    /// Refuses a pixel count that is not `width × height`, or zero, naming
    /// `<message>.<pixels>`.
    fn check(&self, message: &str, pixels: &str) -> Result<()> {
        check_size(
            message,
            pixels,
            self.width,
            self.height,
            self.pixels.as_ref().len(),
        )
    }
}

/// Refuses a pixel count that is not `width × height`, or zero.
fn check_size(message: &str, pixels: &str, width: u32, height: u32, found: usize) -> Result<()> {
    let expected = usize::try_from(u64::from(width) * u64::from(height)).unwrap_or(usize::MAX);
    if expected == 0 || found != expected {
        return Err(Error::BadLength {
            field: format!("{message}.{pixels}"),
            expected,
            found,
        });
    }
    Ok(())
}

/// A message that is one [`Image`] under its own name and pixel column; its [`Message`]
/// methods are [`image_data_type`], [`encode_images`] and [`decode_images`].
pub(crate) trait ImageMessage: Message {
    /// The pixel column (`depth_mm`, `amplitude`).
    const PIXELS: &'static str;
    /// The message as an image, borrowing its pixels.
    fn image(&self) -> Image<&str, &[u16]>;
    /// The message from a decoded image.
    fn from_image(image: Image<String, Vec<u16>>) -> Self;
}

fn image_fields(pixels: &str) -> Fields {
    Fields::from(vec![
        field("sensor_id", DataType::Utf8),
        field("seq", DataType::UInt64),
        field("local_stamp_nanos", DataType::Int64),
        field("width", DataType::UInt32),
        field("height", DataType::UInt32),
        field(pixels, list_of(DataType::UInt16)),
    ])
}

/// [`Message::data_type`] of an image message.
pub(crate) fn image_data_type<M: ImageMessage>() -> DataType {
    struct_of(image_fields(M::PIXELS))
}

/// [`Message::encode_many`] of an image message: a wrong pixel count is [`Error::Encode`].
pub(crate) fn encode_images<M: ImageMessage>(messages: &[M]) -> Result<ArrayRef> {
    let message = M::NAME;
    let b = Builder { message };
    let images: Vec<Image<&str, &[u16]>> = messages.iter().map(M::image).collect();
    for m in &images {
        m.check(message, M::PIXELS).map_err(|e| Error::Encode {
            message,
            detail: e.to_string(),
        })?;
    }
    let lengths: Vec<usize> = images.iter().map(|m| m.pixels.len()).collect();
    let values: ArrayRef = Arc::new(match images.as_slice() {
        // The common case (a node sends one frame): one copy into the Arrow buffer.
        [one] => UInt16Array::from(one.pixels.to_vec()),
        _ => UInt16Array::from_iter_values(images.iter().flat_map(|m| m.pixels.iter().copied())),
    });
    b.structs(
        &image_fields(M::PIXELS),
        vec![
            b.strings(images.iter().map(|m| m.sensor_id)),
            b.values::<UInt64Type>(images.iter().map(|m| m.seq)),
            b.values::<Int64Type>(images.iter().map(|m| m.local_stamp_nanos)),
            b.values::<UInt32Type>(images.iter().map(|m| m.width)),
            b.values::<UInt32Type>(images.iter().map(|m| m.height)),
            b.list(DataType::UInt16, &lengths, values)?,
        ],
    )
}

/// [`Message::decode_many`] of an image message: a pixel count that is not `width × height`
/// is [`Error::BadLength`], whatever the producer.
pub(crate) fn decode_images<M: ImageMessage>(array: &dyn Array) -> Result<Vec<M>> {
    let (message, pixels) = (M::NAME, M::PIXELS);
    let top = Rows::new(array, message)?;
    let sensors = top.column::<StringArray>("sensor_id")?;
    let seqs = top.column::<UInt64Array>("seq")?;
    let stamps = top.column::<Int64Array>("local_stamp_nanos")?;
    let widths = top.column::<UInt32Array>("width")?;
    let heights = top.column::<UInt32Array>("height")?;
    // The pixels are sliced out of the one item buffer rather than read cell by cell.
    let (list, pixels_path) = top.nested(pixels)?;
    let values_path = format!("{pixels_path}.item");
    let values = Col::new(list.values().as_ref(), &values_path).primitive::<UInt16Type>()?;
    top.rows()
        .map(|row| {
            let range = list_range(list, &pixels_path, row)?;
            let slice = values.slice(range.start, range.len());
            if slice.null_count() > 0 {
                return Err(Error::NullValue {
                    field: values_path.clone(),
                    row,
                });
            }
            let (width, height) = (widths.get(row)?, heights.get(row)?);
            check_size(message, pixels, width, height, slice.len())?;
            Ok(M::from_image(Image {
                sensor_id: sensors.get(row)?,
                seq: seqs.get(row)?,
                local_stamp_nanos: stamps.get(row)?,
                width,
                height,
                pixels: slice.values().to_vec(),
            }))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(sensor: &str, w: u32, h: u32, seq: u64) -> DepthFrameMessage {
        DepthFrameMessage {
            sensor_id: sensor.into(),
            seq,
            local_stamp_nanos: -7 + seq as i64 * 33_333_333,
            width: w,
            height: h,
            depth_mm: (0..w * h).map(|i| (i * 37 % 4500) as u16).collect(),
        }
    }

    /// A full Kinect v2 frame, a batch of small frames and a slice of that batch survive the
    /// round trip bit for bit.
    #[test]
    fn round_trip() {
        let one = frame("k1", 512, 424, 3);
        let array = one.encode().unwrap();
        assert_eq!(array.data_type(), &DepthFrameMessage::data_type());
        assert_eq!(DepthFrameMessage::decode(array.as_ref()).unwrap(), one);

        let many = vec![
            frame("k1", 4, 3, 0),
            frame("k2", 2, 5, 1),
            frame("k3", 1, 1, 2),
        ];
        let array = DepthFrameMessage::encode_many(&many).unwrap();
        assert_eq!(
            DepthFrameMessage::decode_many(array.as_ref()).unwrap(),
            many
        );
        let sliced = array.slice(1, 2);
        assert_eq!(
            DepthFrameMessage::decode_many(sliced.as_ref()).unwrap(),
            many[1..].to_vec()
        );
    }

    /// A pixel count that is not width × height is refused on both sides, naming the field.
    #[test]
    fn size_mismatch_is_an_error() {
        let mut bad = frame("k1", 4, 3, 0);
        bad.depth_mm.pop();
        assert!(matches!(bad.encode(), Err(Error::Encode { .. })));
        let mut empty = frame("k1", 0, 3, 0);
        empty.depth_mm.clear();
        assert!(empty.validate().is_err());

        // Forge the message past the encoder: a good frame with a lying `width` column.
        let good = frame("k1", 4, 3, 0).encode().unwrap();
        let top = good
            .as_any()
            .downcast_ref::<arrow_array::StructArray>()
            .unwrap();
        let mut columns = top.columns().to_vec();
        columns[3] = Arc::new(UInt32Array::from(vec![5_u32]));
        let forged =
            arrow_array::StructArray::try_new(top.fields().clone(), columns, None).unwrap();
        let err = DepthFrameMessage::decode(&forged).unwrap_err();
        assert_eq!(
            err,
            Error::BadLength {
                field: "depth_frame.depth_mm".into(),
                expected: 15,
                found: 12
            }
        );
    }

    /// Another message, a depth list of the wrong item type or a missing column is an error
    /// with the field's path, not a panic.
    #[test]
    fn malformed_input_is_an_error() {
        let ntp = crate::NtpExchange::request("k1", 1, 2).encode().unwrap();
        let err = DepthFrameMessage::decode(ntp.as_ref()).unwrap_err();
        assert!(err.to_string().starts_with("depth_frame."), "{err}");

        let good = frame("k1", 2, 2, 0).encode().unwrap();
        let top = good
            .as_any()
            .downcast_ref::<arrow_array::StructArray>()
            .unwrap();
        // depth_mm as List<UInt32>.
        let b = Builder { message: "test" };
        let wrong_items = b
            .list(
                DataType::UInt32,
                &[4],
                Arc::new(UInt32Array::from(vec![1_u32, 2, 3, 4])),
            )
            .unwrap();
        let mut fields: Vec<_> = top.fields().iter().cloned().collect();
        fields[5] = field("depth_mm", list_of(DataType::UInt32));
        let mut columns = top.columns().to_vec();
        columns[5] = wrong_items;
        let forged =
            arrow_array::StructArray::try_new(Fields::from(fields), columns, None).unwrap();
        let err = DepthFrameMessage::decode(&forged).unwrap_err();
        assert!(
            matches!(&err, Error::WrongType { field, .. } if field == "depth_frame.depth_mm.item"),
            "{err}"
        );
        // A struct without depth_mm.
        let fields: Vec<_> = top.fields().iter().take(5).cloned().collect();
        let columns = top.columns()[..5].to_vec();
        let forged =
            arrow_array::StructArray::try_new(Fields::from(fields), columns, None).unwrap();
        assert_eq!(
            DepthFrameMessage::decode(&forged).unwrap_err(),
            Error::MissingColumn {
                field: "depth_frame.depth_mm".into()
            }
        );
        // Not a struct at all.
        let raw = UInt16Array::from(vec![1_u16; 4]);
        assert!(matches!(
            DepthFrameMessage::decode(&raw),
            Err(Error::WrongType { .. })
        ));
    }
}
