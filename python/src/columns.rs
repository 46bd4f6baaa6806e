//! A run's trace as Arrow columns: one row per record, one column per field of the trace
//! objects (docs/trace.md), in the order fields first appear. The objects are the records
//! projected by serde, the very values `--trace` prints, so each column holds what the JSONL
//! trace holds; a field a record does not have is null.
//!
//! Column types: integers are `int64`, numbers `float64`, booleans `bool`, strings `utf8`;
//! arrays of numbers (positions, velocities, arrival times) are `list<float64>` (`list<int64>`
//! when every element is an integer); other nested values (a Look's frame and the robots it
//! saw, sensor values) are Arrow structs and lists as Arrow's JSON reader infers them; a field
//! whose values mix kinds (`other`: a robot id or `"boundary"`) is `utf8`, numbers written as
//! the trace writes them, and a nested field whose shapes differ between records is its JSON
//! text.

use std::sync::Arc;

use arrow_array::builder::{
    BooleanBuilder, Float64Builder, Int64Builder, ListBuilder, StringBuilder,
};
use arrow_array::{ArrayRef, RecordBatch};
use arrow_schema::{ArrowError, Field, Schema};
use serde_json::{Map, Value};

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

fn kind_of(v: &Value) -> Kind {
    match v {
        Value::Null => Kind::Null,
        Value::Bool(_) => Kind::Bool,
        Value::Number(n) if n.is_f64() => Kind::Float,
        Value::Number(n) if n.as_i64().is_some() => Kind::Int,
        Value::Number(_) => Kind::Float,
        Value::String(_) => Kind::Str,
        Value::Array(items) => {
            let mut k = Kind::IntList;
            for i in items {
                match kind_of(i) {
                    Kind::Int => {}
                    Kind::Float => k = Kind::FloatList,
                    _ => return Kind::Nested,
                }
            }
            k
        }
        Value::Object(_) => Kind::Nested,
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

/// The trace objects `rows` as one record batch.
pub fn batch(rows: &[Value]) -> Result<RecordBatch, ArrowError> {
    let mut names: Vec<String> = Vec::new();
    let mut seen = std::collections::HashSet::new();
    for r in rows {
        if let Value::Object(m) = r {
            for k in m.keys() {
                if seen.insert(k.clone()) {
                    names.push(k.clone());
                }
            }
        }
    }
    let mut fields = Vec::with_capacity(names.len());
    let mut arrays = Vec::with_capacity(names.len());
    for name in &names {
        let cells: Vec<&Value> = rows
            .iter()
            .map(|r| r.get(name).unwrap_or(&Value::Null))
            .collect();
        let kind = cells.iter().fold(Kind::Null, |k, v| merge(k, kind_of(v)));
        let array = column(name, kind, &cells)?;
        fields.push(Field::new(name, array.data_type().clone(), true));
        arrays.push(array);
    }
    RecordBatch::try_new_with_options(
        Arc::new(Schema::new(fields)),
        arrays,
        &arrow_array::RecordBatchOptions::new().with_row_count(Some(rows.len())),
    )
}

fn column(name: &str, kind: Kind, cells: &[&Value]) -> Result<ArrayRef, ArrowError> {
    Ok(match kind {
        Kind::Null | Kind::Bool => {
            let mut b = BooleanBuilder::with_capacity(cells.len());
            cells.iter().for_each(|v| b.append_option(v.as_bool()));
            Arc::new(b.finish())
        }
        Kind::Int => {
            let mut b = Int64Builder::with_capacity(cells.len());
            cells.iter().for_each(|v| b.append_option(v.as_i64()));
            Arc::new(b.finish())
        }
        Kind::Float => {
            let mut b = Float64Builder::with_capacity(cells.len());
            cells.iter().for_each(|v| b.append_option(v.as_f64()));
            Arc::new(b.finish())
        }
        Kind::Str | Kind::Mixed => {
            let mut b = StringBuilder::new();
            for v in cells {
                match v {
                    Value::Null => b.append_null(),
                    Value::String(s) => b.append_value(s),
                    other => b.append_value(other.to_string()),
                }
            }
            Arc::new(b.finish())
        }
        Kind::IntList => {
            let mut b = ListBuilder::new(Int64Builder::new());
            for v in cells {
                match v.as_array() {
                    Some(items) => {
                        items
                            .iter()
                            .for_each(|i| b.values().append_option(i.as_i64()));
                        b.append(true);
                    }
                    None => b.append(false),
                }
            }
            Arc::new(b.finish())
        }
        Kind::FloatList => {
            let mut b = ListBuilder::new(Float64Builder::new());
            for v in cells {
                match v.as_array() {
                    Some(items) => {
                        items
                            .iter()
                            .for_each(|i| b.values().append_option(i.as_f64()));
                        b.append(true);
                    }
                    None => b.append(false),
                }
            }
            Arc::new(b.finish())
        }
        Kind::Nested => match nested(name, cells) {
            Ok(a) => a,
            // Shapes Arrow's JSON reader cannot unify: the column holds each value's JSON.
            Err(_) => column(name, Kind::Mixed, cells)?,
        },
    })
}

/// A nested column through Arrow's JSON reader, fed the values themselves (serde, no text).
fn nested(name: &str, cells: &[&Value]) -> Result<ArrayRef, ArrowError> {
    let rows: Vec<Value> = cells
        .iter()
        .map(|v| {
            let mut m = Map::new();
            if !v.is_null() {
                m.insert(name.to_string(), (*v).clone());
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

/// `batch` in Arrow's IPC stream format (what `pyarrow.ipc.open_stream` reads).
pub fn ipc(batch: &RecordBatch) -> Result<Vec<u8>, ArrowError> {
    let mut w = arrow_ipc::writer::StreamWriter::try_new(Vec::new(), &batch.schema())?;
    w.write(batch)?;
    w.finish()?;
    w.into_inner()
}
