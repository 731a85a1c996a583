//! Building blocks shared by the message codecs: column types, array builders that return errors
//! instead of panicking, and readers that name the field when the input is not what we wrote.

use std::sync::Arc;

use arrow_array::types::{ArrowPrimitiveType, Float64Type, UInt8Type};
use arrow_array::{
    Array, ArrayRef, FixedSizeListArray, Float64Array, ListArray, PrimitiveArray, StringArray,
    StructArray,
};
use arrow_buffer::OffsetBuffer;
use arrow_schema::{DataType, Field, FieldRef, Fields};
use nalgebra::{Matrix3, Point3};
use trigait_skeleton::{Joint, JointSample, TrackingState};

use crate::{Error, Result};

// ---- types --------------------------------------------------------------------------------

/// A non-nullable field.
pub(crate) fn field(name: &str, data_type: DataType) -> FieldRef {
    Arc::new(Field::new(name, data_type, false))
}

/// A nullable field.
pub(crate) fn nullable(name: &str, data_type: DataType) -> FieldRef {
    Arc::new(Field::new(name, data_type, true))
}

/// `FixedSizeList<Float64, size>`: a point (3) or a row-major 3×3 matrix (9).
pub(crate) fn f64_tuple(size: i32) -> DataType {
    DataType::FixedSizeList(
        Arc::new(Field::new_list_field(DataType::Float64, false)),
        size,
    )
}

/// `List<item>` with non-null items.
pub(crate) fn list_of(item: DataType) -> DataType {
    DataType::List(Arc::new(Field::new_list_field(item, false)))
}

pub(crate) fn struct_of(fields: Fields) -> DataType {
    DataType::Struct(fields)
}

// ---- building ----------------------------------------------------------------------------

/// Builds arrays for one message type, turning arrow's construction errors into [`Error::Encode`].
#[derive(Clone, Copy)]
pub(crate) struct Builder {
    pub message: &'static str,
}

impl Builder {
    fn err(&self, detail: impl std::fmt::Display) -> Error {
        Error::Encode {
            message: self.message,
            detail: detail.to_string(),
        }
    }

    pub fn structs(&self, fields: &Fields, arrays: Vec<ArrayRef>) -> Result<ArrayRef> {
        StructArray::try_new(fields.clone(), arrays, None)
            .map(|a| Arc::new(a) as ArrayRef)
            .map_err(|e| self.err(e))
    }

    /// A list column: row i holds `lengths[i]` consecutive items of `values`.
    pub fn list(&self, item: DataType, lengths: &[usize], values: ArrayRef) -> Result<ArrayRef> {
        let total: usize = lengths.iter().sum();
        if i32::try_from(total).is_err() {
            return Err(self.err(format!(
                "{total} list items exceed the i32 offsets of a List"
            )));
        }
        if total != values.len() {
            return Err(self.err(format!("{total} list items but {} values", values.len())));
        }
        let offsets = OffsetBuffer::from_lengths(lengths.iter().copied());
        ListArray::try_new(
            Arc::new(Field::new_list_field(item, false)),
            offsets,
            values,
            None,
        )
        .map(|a| Arc::new(a) as ArrayRef)
        .map_err(|e| self.err(e))
    }

    /// A `FixedSizeList<Float64, size>` column from `size` values per row.
    pub fn f64_tuples(&self, size: i32, values: Vec<f64>) -> Result<ArrayRef> {
        FixedSizeListArray::try_new(
            Arc::new(Field::new_list_field(DataType::Float64, false)),
            size,
            Arc::new(Float64Array::from(values)),
            None,
        )
        .map(|a| Arc::new(a) as ArrayRef)
        .map_err(|e| self.err(e))
    }

    pub fn strings<'a>(&self, values: impl IntoIterator<Item = &'a str>) -> ArrayRef {
        // `from_iter_values` needs an exact size hint (it panics without an upper bound), which
        // `flat_map` does not give: collect first.
        let values: Vec<&str> = values.into_iter().collect();
        Arc::new(StringArray::from_iter_values(values))
    }
}

pub(crate) fn point_values(points: impl IntoIterator<Item = Point3<f64>>) -> Vec<f64> {
    points.into_iter().flat_map(|p| [p.x, p.y, p.z]).collect()
}

/// Row-major, as a reader of the column expects (`[c00, c01, c02, c10, …]`).
pub(crate) fn matrix_values(matrices: impl IntoIterator<Item = Matrix3<f64>>) -> Vec<f64> {
    matrices
        .into_iter()
        .flat_map(|m| {
            [
                m[(0, 0)],
                m[(0, 1)],
                m[(0, 2)],
                m[(1, 0)],
                m[(1, 1)],
                m[(1, 2)],
                m[(2, 0)],
                m[(2, 1)],
                m[(2, 2)],
            ]
        })
        .collect()
}

pub(crate) fn joint_code(joint: Joint) -> u8 {
    // 25 joints: always fits.
    u8::try_from(joint.index()).unwrap_or(u8::MAX)
}

pub(crate) fn state_code(state: TrackingState) -> u8 {
    state as u8
}

// ---- reading ------------------------------------------------------------------------------

/// A column being read, with the dotted path used in errors (`aligned_set.sensors.joints.state`).
#[derive(Clone, Copy)]
pub(crate) struct Col<'a, 'p> {
    pub array: &'a dyn Array,
    pub path: &'p str,
}

fn type_name(array: &dyn Array) -> String {
    array.data_type().to_string()
}

impl<'a, 'p> Col<'a, 'p> {
    pub fn new(array: &'a dyn Array, path: &'p str) -> Self {
        Col { array, path }
    }

    fn wrong(&self, expected: &str) -> Error {
        Error::WrongType {
            field: self.path.to_owned(),
            expected: expected.to_owned(),
            found: type_name(self.array),
        }
    }

    pub fn structs(&self) -> Result<&'a StructArray> {
        self.array
            .as_any()
            .downcast_ref::<StructArray>()
            .ok_or_else(|| self.wrong("Struct"))
    }

    pub fn list(&self) -> Result<&'a ListArray> {
        self.array
            .as_any()
            .downcast_ref::<ListArray>()
            .ok_or_else(|| self.wrong("List"))
    }

    pub fn strings(&self) -> Result<&'a StringArray> {
        self.array
            .as_any()
            .downcast_ref::<StringArray>()
            .ok_or_else(|| self.wrong("Utf8"))
    }

    pub fn primitive<T: ArrowPrimitiveType>(&self) -> Result<&'a PrimitiveArray<T>> {
        self.array
            .as_any()
            .downcast_ref::<PrimitiveArray<T>>()
            .ok_or_else(|| self.wrong(&T::DATA_TYPE.to_string()))
    }

    /// A `FixedSizeList<Float64, size>` with no nulls anywhere; returns the flat values.
    pub fn f64_tuples(&self, size: i32) -> Result<Vec<f64>> {
        let expected = format!("FixedSizeList({size} x Float64)");
        let list = self
            .array
            .as_any()
            .downcast_ref::<FixedSizeListArray>()
            .ok_or_else(|| self.wrong(&expected))?;
        if list.value_length() != size {
            return Err(Error::BadLength {
                field: self.path.to_owned(),
                expected: usize::try_from(size).unwrap_or(0),
                found: usize::try_from(list.value_length()).unwrap_or(0),
            });
        }
        let width = usize::try_from(size).unwrap_or(0);
        let mut out = Vec::with_capacity(list.len() * width);
        for row in 0..list.len() {
            if list.is_null(row) {
                return Err(self.null(row));
            }
            let item = list.value(row);
            let values = item
                .as_any()
                .downcast_ref::<PrimitiveArray<Float64Type>>()
                .ok_or_else(|| self.wrong(&expected))?;
            if values.len() != width {
                return Err(Error::BadLength {
                    field: self.path.to_owned(),
                    expected: width,
                    found: values.len(),
                });
            }
            for k in 0..width {
                if values.is_null(k) {
                    return Err(self.null(row));
                }
                out.push(values.value(k));
            }
        }
        Ok(out)
    }

    pub fn null(&self, row: usize) -> Error {
        Error::NullValue {
            field: self.path.to_owned(),
            row,
        }
    }
}

/// The column `name` of `parent` (a struct at `parent_path`), with its path.
pub(crate) fn column<'a>(
    parent: &'a StructArray,
    parent_path: &str,
    name: &str,
) -> Result<(&'a dyn Array, String)> {
    let path = format!("{parent_path}.{name}");
    match parent.column_by_name(name) {
        Some(c) => Ok((c.as_ref(), path)),
        None => Err(Error::MissingColumn { field: path }),
    }
}

/// Non-null value of a primitive column.
pub(crate) fn value<T: ArrowPrimitiveType>(
    array: &PrimitiveArray<T>,
    path: &str,
    row: usize,
) -> Result<T::Native> {
    if array.is_null(row) {
        Err(Error::NullValue {
            field: path.to_owned(),
            row,
        })
    } else {
        Ok(array.value(row))
    }
}

/// Possibly-null value of a primitive column.
pub(crate) fn optional<T: ArrowPrimitiveType>(
    array: &PrimitiveArray<T>,
    row: usize,
) -> Option<T::Native> {
    (!array.is_null(row)).then(|| array.value(row))
}

/// Non-null value of a string column.
pub(crate) fn string(array: &StringArray, path: &str, row: usize) -> Result<String> {
    if array.is_null(row) {
        Err(Error::NullValue {
            field: path.to_owned(),
            row,
        })
    } else {
        Ok(array.value(row).to_owned())
    }
}

/// The item range of list row `row` (no null rows allowed).
pub(crate) fn list_range(
    list: &ListArray,
    path: &str,
    row: usize,
) -> Result<std::ops::Range<usize>> {
    if list.is_null(row) {
        return Err(Error::NullValue {
            field: path.to_owned(),
            row,
        });
    }
    let offsets = list.value_offsets();
    let start = offsets.get(row).copied().unwrap_or(0);
    let end = offsets.get(row + 1).copied().unwrap_or(start);
    let (start, end) = (
        usize::try_from(start).unwrap_or(0),
        usize::try_from(end).unwrap_or(0),
    );
    if start > end || end > list.values().len() {
        return Err(Error::BadLength {
            field: path.to_owned(),
            expected: end,
            found: list.values().len(),
        });
    }
    Ok(start..end)
}

pub(crate) fn joint_from_code(code: u8, path: &str, row: usize) -> Result<Joint> {
    Joint::from_index(usize::from(code)).ok_or_else(|| Error::InvalidValue {
        field: path.to_owned(),
        row,
        value: code.to_string(),
        expected: "a Kinect v2 JointType number, 0..=24",
    })
}

pub(crate) fn state_from_code(code: u8, path: &str, row: usize) -> Result<TrackingState> {
    TrackingState::from_index(code).ok_or_else(|| Error::InvalidValue {
        field: path.to_owned(),
        row,
        value: code.to_string(),
        expected: "a TrackingState number: 0 not tracked, 1 inferred, 2 tracked",
    })
}

/// Rejects struct-level nulls (a whole message or item missing).
pub(crate) fn no_null_rows(array: &StructArray, path: &str) -> Result<()> {
    match (0..array.len()).find(|&row| array.is_null(row)) {
        Some(row) => Err(Error::NullValue {
            field: path.to_owned(),
            row,
        }),
        None => Ok(()),
    }
}

/// Decodes the `joint`, `position_m` and `state` columns that every joint list on the wire
/// shares, returning the struct array too so a message reads its own extra columns from it.
pub(crate) fn decode_joint_samples<'a>(
    array: &'a dyn Array,
    path: &str,
) -> Result<(&'a StructArray, Vec<JointSample>)> {
    let items = Col::new(array, path).structs()?;
    no_null_rows(items, path)?;
    let (c, joint_path) = column(items, path, "joint")?;
    let joints = Col::new(c, &joint_path).primitive::<UInt8Type>()?;
    let (c, pos_path) = column(items, path, "position_m")?;
    let positions = Col::new(c, &pos_path).f64_tuples(3)?;
    let (c, state_path) = column(items, path, "state")?;
    let states = Col::new(c, &state_path).primitive::<UInt8Type>()?;
    let mut samples = Vec::with_capacity(items.len());
    for row in 0..items.len() {
        let p = positions
            .get(3 * row..3 * row + 3)
            .ok_or_else(|| Error::BadLength {
                field: pos_path.clone(),
                expected: 3 * items.len(),
                found: positions.len(),
            })?;
        samples.push(JointSample {
            joint: joint_from_code(value(joints, &joint_path, row)?, &joint_path, row)?,
            position_in_kinect: Point3::new(p[0], p[1], p[2]),
            state: state_from_code(value(states, &state_path, row)?, &state_path, row)?,
        });
    }
    Ok((items, samples))
}
