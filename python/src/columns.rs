//! A run's trace as Arrow columns: one row per record, one column per field of the trace
//! objects (docs/trace.md), in the order fields first appear. Each record goes through its own
//! `Serialize`, the one `--trace` prints with, into a serializer that writes each field straight
//! into its column ([`crate::cells`]): the columns hold what the JSONL trace holds, with no JSON
//! value built on the way; a field a record does not have is null.
//!
//! Column types: integers are `int64`, numbers `float64`, booleans `bool`, strings `utf8`;
//! arrays of numbers (positions, velocities, arrival times) are `list<float64>` (`list<int64>`
//! when every element is an integer); other nested values (a Look's frame and the robots it
//! saw, sensor values) are Arrow structs and lists as Arrow's JSON reader infers them; a field
//! whose values mix kinds (`other`: a robot id or `"boundary"`) is `utf8`, numbers written as
//! the trace writes them, and a nested field whose shapes differ between records is its JSON
//! text.

use std::sync::Arc;

use arrow_array::builder::StringBuilder;
use arrow_array::ffi::{FFI_ArrowArray, FFI_ArrowSchema};
use arrow_array::{
    Array, ArrayRef, BooleanArray, Float64Array, Int64Array, ListArray, RecordBatch, StructArray,
};
use arrow_buffer::{NullBuffer, OffsetBuffer};
use arrow_schema::{ArrowError, DataType, Field, Schema};
use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use pyo3::types::PyCapsule;
use serde::Serialize;
use serde_json::{Map, Value};

use crate::cells::{Cell, Column, Num, Table};

/// What a column's values are, from all of them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Null,
    Bool,
    Int,
    Float,
    Str,
    IntList,
    FloatList,
    Nested,
    /// Scalars of different kinds.
    Mixed,
}

fn kind_of(c: &Cell) -> Kind {
    match c {
        Cell::Null => Kind::Null,
        Cell::Bool(_) => Kind::Bool,
        Cell::Int(_) => Kind::Int,
        Cell::Float(_) => Kind::Float,
        Cell::Str(..) => Kind::Str,
        Cell::List { float: false, .. } => Kind::IntList,
        Cell::List { float: true, .. } => Kind::FloatList,
        Cell::Nested(_) => Kind::Nested,
    }
}

fn merge(a: Kind, b: Kind) -> Kind {
    use Kind::*;
    match (a, b) {
        (Null, k) | (k, Null) => k,
        (a, b) if a == b => a,
        (Int, Float) | (Float, Int) => Float,
        (IntList, FloatList) | (FloatList, IntList) => FloatList,
        (Nested, _) | (_, Nested) | (IntList | FloatList, _) | (_, IntList | FloatList) => Nested,
        _ => Mixed,
    }
}

/// The trace objects `rows` (records, or JSON values read from a trace) as one record batch.
pub fn batch<T: Serialize>(rows: &[T]) -> Result<RecordBatch, ArrowError> {
    let mut table = Table::default();
    for (i, r) in rows.iter().enumerate() {
        table
            .row(i, r)
            .map_err(|e| ArrowError::ExternalError(Box::new(e)))?;
    }
    let columns = table.into_columns();
    let mut fields = Vec::with_capacity(columns.len());
    let mut arrays = Vec::with_capacity(columns.len());
    for col in &columns {
        let kind = col
            .cells
            .iter()
            .fold(Kind::Null, |k, c| merge(k, kind_of(c)));
        let array = column(col, kind, rows.len())?;
        fields.push(Field::new(&col.name, array.data_type().clone(), true));
        arrays.push(array);
    }
    RecordBatch::try_new_with_options(
        Arc::new(Schema::new(fields)),
        arrays,
        &arrow_array::RecordBatchOptions::new().with_row_count(Some(rows.len())),
    )
}

/// Column `col` of a table of `rows` rows, as `kind`.
fn column(col: &Column, kind: Kind, rows: usize) -> Result<ArrayRef, ArrowError> {
    Ok(match kind {
        Kind::Null | Kind::Bool => {
            let (values, nulls) = scatter(col, rows, |c| match c {
                Cell::Bool(v) => Some(*v),
                _ => None,
            });
            Arc::new(BooleanArray::new(values.into_iter().collect(), nulls))
        }
        Kind::Int => {
            let (values, nulls) = scatter(col, rows, |c| match c {
                Cell::Int(v) => Some(*v),
                _ => None,
            });
            Arc::new(Int64Array::new(values.into(), nulls))
        }
        Kind::Float => {
            let (values, nulls) = scatter(col, rows, |c| match c {
                Cell::Int(v) => Some(*v as f64),
                Cell::Float(v) => Some(*v),
                _ => None,
            });
            Arc::new(Float64Array::new(values.into(), nulls))
        }
        Kind::Str | Kind::Mixed => {
            let mut b = StringBuilder::with_capacity(rows, col.text.len());
            for c in col.dense(rows) {
                match c {
                    Cell::Null => b.append_null(),
                    Cell::Str(s, e) => b.append_value(&col.text[*s..*e]),
                    other => b.append_value(col.value(other).to_string()),
                }
            }
            Arc::new(b.finish())
        }
        Kind::IntList => {
            let (values, offsets, nulls) = lists(col, rows, |n| match n {
                Num::Int(i) => i,
                Num::Float(f) => f as i64,
            });
            let item = Arc::new(Field::new_list_field(DataType::Int64, true));
            let values = Arc::new(Int64Array::from(values));
            Arc::new(ListArray::try_new(item, offsets, values, nulls)?)
        }
        Kind::FloatList => {
            let (values, offsets, nulls) = lists(col, rows, |n| match n {
                Num::Int(i) => i as f64,
                Num::Float(f) => f,
            });
            let item = Arc::new(Field::new_list_field(DataType::Float64, true));
            let values = Arc::new(Float64Array::from(values));
            Arc::new(ListArray::try_new(item, offsets, values, nulls)?)
        }
        Kind::Nested => {
            match nested(&col.name, col.dense(rows).map(|c| col.value(c))) {
                Ok(a) => a,
                // Shapes Arrow's JSON reader cannot unify: the column holds each value's JSON.
                Err(_) => column(col, Kind::Mixed, rows)?,
            }
        }
    })
}

/// The values of a column of `rows` rows whose cells `value` reads: each at its row, the
/// default and null where a record has no such field or `value` gives none.
fn scatter<T: Default + Clone>(
    col: &Column,
    rows: usize,
    value: impl Fn(&Cell) -> Option<T>,
) -> (Vec<T>, Option<NullBuffer>) {
    let mut values = vec![T::default(); rows];
    let mut valid = vec![false; rows];
    for (&r, c) in col.rows.iter().zip(&col.cells) {
        if let Some(v) = value(c) {
            values[r] = v;
            valid[r] = true;
        }
    }
    (values, Some(NullBuffer::from(valid)))
}

/// The elements of a column of arrays of numbers, as `element` reads them, with each row's
/// offsets into them; null where a record has no such field.
fn lists<T>(
    col: &Column,
    rows: usize,
    element: impl Fn(Num) -> T,
) -> (Vec<T>, OffsetBuffer<i32>, Option<NullBuffer>) {
    let mut values = Vec::with_capacity(col.nums.len());
    let mut lengths = vec![0; rows];
    let mut valid = vec![false; rows];
    for (&r, c) in col.rows.iter().zip(&col.cells) {
        if let Cell::List { start, end, .. } = *c {
            values.extend(col.nums[start..end].iter().map(|&n| element(n)));
            lengths[r] = end - start;
            valid[r] = true;
        }
    }
    (
        values,
        OffsetBuffer::from_lengths(lengths),
        Some(NullBuffer::from(valid)),
    )
}

/// A nested column through Arrow's JSON reader, fed the values themselves (serde, no text).
fn nested(name: &str, cells: impl Iterator<Item = Value>) -> Result<ArrayRef, ArrowError> {
    let rows: Vec<Value> = cells
        .map(|v| {
            let mut m = Map::new();
            if !v.is_null() {
                m.insert(name.to_string(), v);
            }
            Value::Object(m)
        })
        .collect();
    let schema = arrow_json::reader::infer_json_schema_from_iterator(rows.iter().map(Ok))?;
    let mut decoder = arrow_json::ReaderBuilder::new(Arc::new(schema))
        .with_batch_size(rows.len().max(1))
        .build_decoder()?;
    decoder.serialize(&rows)?;
    let batch = decoder
        .flush()?
        .ok_or_else(|| ArrowError::JsonError("no rows".into()))?;
    if batch.num_rows() != rows.len() {
        return Err(ArrowError::JsonError("rows lost".into()));
    }
    Ok(batch.column(0).clone())
}

/// A record batch that Python takes without a copy, through the Arrow PyCapsule interface
/// (`pyarrow.record_batch(batch)`): its buffers are handed over as they are.
#[derive(Debug)]
#[pyclass(module = "nekosim._nekosim", frozen)]
pub struct ArrowBatch(pub RecordBatch);

#[pymethods]
impl ArrowBatch {
    /// The batch as a struct array: the capsules `arrow_schema` and `arrow_array` of Arrow's C
    /// data interface. A requested schema is not followed (the interface leaves that to the
    /// consumer).
    #[pyo3(signature = (requested_schema=None))]
    fn __arrow_c_array__<'py>(
        &self,
        py: Python<'py>,
        requested_schema: Option<Bound<'py, PyAny>>,
    ) -> PyResult<(Bound<'py, PyCapsule>, Bound<'py, PyCapsule>)> {
        let _ = requested_schema;
        let data = StructArray::from(self.0.clone()).into_data();
        let schema = FFI_ArrowSchema::try_from(data.data_type())
            .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
        let array = FFI_ArrowArray::new(&data);
        Ok((
            PyCapsule::new_with_value(py, schema, c"arrow_schema")?,
            PyCapsule::new_with_value(py, array, c"arrow_array")?,
        ))
    }
}
