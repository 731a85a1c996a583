//! Building blocks shared by the message codecs: column types, array builders that return errors
//! instead of panicking, and readers that name the field when the input is not what we wrote.

use std::sync::Arc;

use arrow_array::types::{ArrowPrimitiveType, Float64Type, UInt8Type};
use arrow_array::{
    Array, ArrayRef, FixedSizeListArray, Float64Array, ListArray, PrimitiveArray, StringArray,
    StructArray, UInt8Array,
};
use arrow_buffer::OffsetBuffer;
use arrow_schema::{DataType, Field, FieldRef, Fields};
use nalgebra::{Matrix3, Point3};
use trigait_skeleton::{Joint, JointSample, TrackingState};

use crate::{Error, Message, Result};

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

    /// A non-null primitive column (`b.values::<UInt64Type>(messages.iter().map(|m| m.seq))`).
    pub fn values<T: ArrowPrimitiveType>(
        &self,
        values: impl IntoIterator<Item = T::Native>,
    ) -> ArrayRef {
        Arc::new(PrimitiveArray::<T>::from_iter_values(values))
    }

    /// A nullable primitive column, `None` as null.
    pub fn optionals<T: ArrowPrimitiveType>(
        &self,
        values: impl IntoIterator<Item = Option<T::Native>>,
    ) -> ArrayRef {
        Arc::new(values.into_iter().collect::<PrimitiveArray<T>>())
    }

    pub fn strings<'a>(&self, values: impl IntoIterator<Item = &'a str>) -> ArrayRef {
        // `from_iter_values` needs an exact size hint (it panics without an upper bound), which
        // `flat_map` does not give: collect first.
        let values: Vec<&str> = values.into_iter().collect();
        Arc::new(StringArray::from_iter_values(values))
    }
}

/// [`Message::encode_many`] of a message that is one struct of `fields`: `columns` makes
/// them with a builder that names the message in its errors.
pub(crate) fn encode_struct<M: Message>(
    fields: &Fields,
    columns: impl FnOnce(&Builder) -> Result<Vec<ArrayRef>>,
) -> Result<ArrayRef> {
    let b = Builder { message: M::NAME };
    b.structs(fields, columns(&b)?)
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

// ---- reading by field name ---------------------------------------------------------------
//
// A message's decoder names each column once (`top.column::<UInt64Array>("seq")?`) and reads
// rows from the typed getter it gets back (`seq.get(row)?`); every error names the field's
// dotted path, as the hand-written `column` + `Col` + `value` sequence did.

/// An Arrow array type a column is read from, and the Rust value of one of its cells.
pub(crate) trait Cells: Array + Sized + 'static {
    /// One cell, owned.
    type Value;
    /// `col` as this array type, or [`Error::WrongType`].
    fn of<'a>(col: &Col<'a, '_>) -> Result<&'a Self>;
    /// The value at `row`, which is not null.
    fn cell(&self, row: usize) -> Self::Value;
}

impl<T: ArrowPrimitiveType> Cells for PrimitiveArray<T> {
    type Value = T::Native;
    fn of<'a>(col: &Col<'a, '_>) -> Result<&'a Self> {
        col.primitive::<T>()
    }
    fn cell(&self, row: usize) -> T::Native {
        self.value(row)
    }
}

impl Cells for StringArray {
    type Value = String;
    fn of<'a>(col: &Col<'a, '_>) -> Result<&'a Self> {
        col.strings()
    }
    fn cell(&self, row: usize) -> String {
        self.value(row).to_owned()
    }
}

/// The rows of a struct array (a message batch, or the items of a list of structs) with no
/// null rows; its columns are fetched by name as typed getters carrying their paths.
pub(crate) struct Rows<'a> {
    pub array: &'a StructArray,
    pub path: String,
}

impl<'a> Rows<'a> {
    /// `array` as the struct at `path`: [`Error::WrongType`] if it is not one,
    /// [`Error::NullValue`] if a row is null.
    pub fn new(array: &'a dyn Array, path: &str) -> Result<Self> {
        let array = Col::new(array, path).structs()?;
        no_null_rows(array, path)?;
        Ok(Rows {
            array,
            path: path.to_owned(),
        })
    }

    /// The row indices.
    pub fn rows(&self) -> std::ops::Range<usize> {
        0..self.array.len()
    }

    /// The column `name` read as `A`.
    pub fn column<A: Cells>(&self, name: &str) -> Result<Column<'a, A>> {
        let (c, path) = column(self.array, &self.path, name)?;
        let array = A::of(&Col::new(c, &path))?;
        Ok(Column { array, path })
    }

    /// The `List<A>` column `name`; its items are reported under the list's path.
    pub fn list<A: Cells>(&self, name: &str) -> Result<Lists<'a, A>> {
        let (list, path) = self.nested(name)?;
        let items = A::of(&Col::new(list.values().as_ref(), &path))?;
        Ok(Lists {
            list,
            items: Column { array: items, path },
        })
    }

    /// The `List<Struct>` column `name` and its path, for a decoder of the items.
    pub fn nested(&self, name: &str) -> Result<(&'a ListArray, String)> {
        let (c, path) = column(self.array, &self.path, name)?;
        let list = Col::new(c, &path).list()?;
        Ok((list, path))
    }

    /// The `FixedSizeList<Float64, size>` column `name`.
    pub fn tuples(&self, name: &str, size: usize) -> Result<Tuples> {
        let (c, path) = column(self.array, &self.path, name)?;
        let values = Col::new(c, &path).f64_tuples(i32::try_from(size).unwrap_or(i32::MAX))?;
        Ok(Tuples {
            values,
            size,
            rows: self.array.len(),
            path,
        })
    }
}

/// [`Message::decode_many`] of a message that is one struct: `reader` fetches the columns
/// once and returns the decoder of one row, which every row of `array` then goes through.
pub(crate) fn decode_rows<'a, M: Message, R: Fn(usize) -> Result<M>>(
    array: &'a dyn Array,
    reader: impl FnOnce(&Rows<'a>) -> Result<R>,
) -> Result<Vec<M>> {
    let top = Rows::new(array, M::NAME)?;
    let row = reader(&top)?;
    top.rows().map(row).collect()
}

/// One column of [`Rows`], read cell by cell.
pub(crate) struct Column<'a, A> {
    pub array: &'a A,
    pub path: String,
}

impl<A: Cells> Column<'_, A> {
    /// The value at `row`; null is [`Error::NullValue`].
    pub fn get(&self, row: usize) -> Result<A::Value> {
        if self.array.is_null(row) {
            Err(Error::NullValue {
                field: self.path.clone(),
                row,
            })
        } else {
            Ok(self.array.cell(row))
        }
    }

    /// The value at `row`, `None` if null.
    pub fn optional(&self, row: usize) -> Option<A::Value> {
        (!self.array.is_null(row)).then(|| self.array.cell(row))
    }
}

/// A `List<A>` column of [`Rows`], read a row's items at a time.
pub(crate) struct Lists<'a, A> {
    list: &'a ListArray,
    items: Column<'a, A>,
}

impl<A: Cells> Lists<'_, A> {
    /// The items of row `row`, none of them null.
    pub fn get(&self, row: usize) -> Result<Vec<A::Value>> {
        list_range(self.list, &self.items.path, row)?
            .map(|i| self.items.get(i))
            .collect()
    }
}

/// A `FixedSizeList<Float64, size>` column of [`Rows`].
pub(crate) struct Tuples {
    values: Vec<f64>,
    size: usize,
    rows: usize,
    pub path: String,
}

impl Tuples {
    /// The `size` values of row `row`.
    pub fn get(&self, row: usize) -> Result<&[f64]> {
        self.values
            .get(self.size * row..self.size * (row + 1))
            .ok_or_else(|| Error::BadLength {
                field: self.path.clone(),
                expected: self.size * self.rows,
                found: self.values.len(),
            })
    }

    /// Row `row` as a point (a column of size 3).
    pub fn point(&self, row: usize) -> Result<Point3<f64>> {
        let p = self.get(row)?;
        Ok(Point3::new(p[0], p[1], p[2]))
    }
}

/// The fields of [`encode_joint_samples`]: `joint`, `position_in_kinect_m` (camera frame),
/// `state`.
pub(crate) fn joint_sample_fields() -> Fields {
    Fields::from(vec![
        field("joint", DataType::UInt8),
        field(POSITION_IN_KINECT, f64_tuple(3)),
        field("state", DataType::UInt8),
    ])
}

/// Name of a camera-frame position column.
pub(crate) const POSITION_IN_KINECT: &str = "position_in_kinect_m";

/// The `joint`, `position_in_kinect_m` and `state` columns that every sensor-frame joint list
/// on the wire shares, for a message to append its own extra columns to
/// ([`decode_joint_samples`] reads them).
pub(crate) fn encode_joint_samples<'s>(
    b: &Builder,
    samples: impl Iterator<Item = &'s JointSample> + Clone,
) -> Result<Vec<ArrayRef>> {
    Ok(vec![
        b.values::<UInt8Type>(samples.clone().map(|s| joint_code(s.joint))),
        b.f64_tuples(
            3,
            point_values(samples.clone().map(|s| s.position_in_kinect)),
        )?,
        b.values::<UInt8Type>(samples.map(|s| state_code(s.state))),
    ])
}

/// Decodes the `joint`, `position_in_kinect_m` and `state` columns that every joint list on the wire
/// shares, returning the struct array too so a message reads its own extra columns from it.
pub(crate) fn decode_joint_samples<'a>(
    array: &'a dyn Array,
    path: &str,
) -> Result<(Rows<'a>, Vec<JointSample>)> {
    let items = Rows::new(array, path)?;
    let joints = items.column::<UInt8Array>("joint")?;
    let positions = items.tuples(POSITION_IN_KINECT, 3)?;
    let states = items.column::<UInt8Array>("state")?;
    let samples = items
        .rows()
        .map(|row| {
            Ok(JointSample {
                joint: joint_from_code(joints.get(row)?, &joints.path, row)?,
                position_in_kinect: positions.point(row)?,
                state: state_from_code(states.get(row)?, &states.path, row)?,
            })
        })
        .collect::<Result<Vec<_>>>()?;
    Ok((items, samples))
}
