//! The cells of a trace's columns ([`crate::columns`]), written by serializing each trace
//! object into a [`Table`]: every field of the object lands in its column as a typed cell, in
//! the terms of the JSON value `serde_json` would make of it (an integer, a number, a string,
//! an array of numbers), without that value being built. A field whose value is anything else
//! (an object, an array of non-numbers) is kept as its JSON value.

use std::collections::HashMap;
use std::fmt::{self, Write as _};

use serde::ser::{self, Impossible, Serialize, Serializer};
use serde_json::Value;

/// One field of one record, as the JSON trace holds it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Cell {
    /// No such field, `null`, or a number JSON cannot hold (NaN, infinities).
    Null,
    Bool(bool),
    Int(i64),
    /// A number with a fraction, or an integer beyond `i64`.
    Float(f64),
    /// `text[start..end]` of its column.
    Str(usize, usize),
    /// `nums[start..end]` of its column; `float` when an element is a [`Num::Float`].
    List {
        start: usize,
        end: usize,
        float: bool,
    },
    /// `nested[i]` of its column.
    Nested(usize),
}

/// An element of an array of numbers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Num {
    Int(i64),
    Float(f64),
}

impl From<Num> for Value {
    fn from(n: Num) -> Value {
        match n {
            Num::Int(i) => i.into(),
            Num::Float(f) => f.into(),
        }
    }
}

/// A field's cells, one for each record that has the field (`rows`, increasing, are those
/// records), and the text, numbers and values they point into.
#[derive(Debug, Default)]
pub struct Column {
    pub name: String,
    pub rows: Vec<usize>,
    pub cells: Vec<Cell>,
    pub text: String,
    pub nums: Vec<Num>,
    pub nested: Vec<Value>,
}

impl Column {
    /// The cells of records `0..n`, null where a record does not have the field.
    pub fn dense(&self, n: usize) -> impl Iterator<Item = &Cell> + '_ {
        let mut next = self.rows.iter().zip(&self.cells).peekable();
        (0..n).map(move |row| match next.next_if(|(r, _)| **r == row) {
            Some((_, c)) => c,
            None => &Cell::Null,
        })
    }

    /// Cell `c` as the JSON value the trace holds.
    pub fn value(&self, c: &Cell) -> Value {
        match *c {
            Cell::Null => Value::Null,
            Cell::Bool(b) => Value::Bool(b),
            Cell::Int(i) => i.into(),
            Cell::Float(f) => f.into(),
            Cell::Str(s, e) => Value::String(self.text[s..e].to_string()),
            Cell::List { start, end, .. } => {
                Value::Array(self.nums[start..end].iter().map(|&n| n.into()).collect())
            }
            Cell::Nested(i) => self.nested[i].clone(),
        }
    }

    /// The cell of JSON value `v`.
    fn cell(&mut self, v: Value) -> Cell {
        match v {
            Value::Null => Cell::Null,
            Value::Bool(b) => Cell::Bool(b),
            Value::Number(n) => match n.as_i64() {
                Some(i) if !n.is_f64() => Cell::Int(i),
                _ => n.as_f64().map_or(Cell::Null, Cell::Float),
            },
            Value::String(s) => self.str(&s),
            Value::Array(items) if items.iter().all(Value::is_number) => {
                let start = self.nums.len();
                let mut float = false;
                for i in &items {
                    let n = match i.as_i64() {
                        Some(v) if !i.is_f64() => Num::Int(v),
                        _ => Num::Float(i.as_f64().unwrap_or(f64::NAN)),
                    };
                    float |= matches!(n, Num::Float(_));
                    self.nums.push(n);
                }
                Cell::List {
                    start,
                    end: self.nums.len(),
                    float,
                }
            }
            v => {
                self.nested.push(v);
                Cell::Nested(self.nested.len() - 1)
            }
        }
    }

    fn str(&mut self, s: &str) -> Cell {
        let start = self.text.len();
        self.text.push_str(s);
        Cell::Str(start, self.text.len())
    }
}

/// Why a record could not be written as cells.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The value is not a scalar or an array of numbers: it is kept as a JSON value instead.
    #[error("a nested value")]
    Nested,
    #[error("{0}")]
    Custom(String),
}

impl ser::Error for Error {
    fn custom<T: fmt::Display>(msg: T) -> Self {
        Error::Custom(msg.to_string())
    }
}

/// How many columns that followed a column [`Table`] remembers.
const FOLLOWERS: usize = 8;

/// The columns of the records written so far, in the order their fields first appear.
#[derive(Debug)]
pub struct Table {
    columns: Vec<Column>,
    index: HashMap<String, usize>,
    /// `next[0]`: the columns records began with; `next[c + 1]`: the columns of the fields that
    /// followed column `c`'s; most recent first. Records of one kind have their fields in one
    /// order, so a field is nearly always among the few that followed the previous one, and
    /// found there without a lookup by name.
    next: Vec<Vec<usize>>,
    /// The key being read.
    key: String,
}

impl Default for Table {
    fn default() -> Self {
        Table {
            columns: Vec::new(),
            index: HashMap::new(),
            next: vec![Vec::new()],
            key: String::new(),
        }
    }
}

impl Table {
    /// Writes trace object `r` as record number `row` (rows are written in order).
    pub fn row<T: Serialize + ?Sized>(&mut self, row: usize, r: &T) -> Result<(), Error> {
        r.serialize(Row {
            table: self,
            row,
            prev: None,
            at: None,
        })
    }

    /// The columns, in the order their fields first appeared.
    pub fn into_columns(self) -> Vec<Column> {
        self.columns
    }

    /// The column of field `key`, coming after the field in column `prev` in its record.
    fn find(&mut self, prev: Option<usize>, key: &str) -> usize {
        let p = prev.map_or(0, |c| c + 1);
        let columns = &self.columns;
        let followers = &mut self.next[p];
        if let Some(k) = followers.iter().position(|&c| same(&columns[c].name, key)) {
            followers[..=k].rotate_right(1);
            return followers[0];
        }
        let at = match self.index.get(key) {
            Some(&i) => i,
            None => {
                let i = self.columns.len();
                self.columns.push(Column {
                    name: key.to_string(),
                    ..Column::default()
                });
                self.index.insert(key.to_string(), i);
                self.next.push(Vec::new());
                i
            }
        };
        let followers = &mut self.next[p];
        followers.insert(0, at);
        followers.truncate(FOLLOWERS);
        at
    }

    /// Writes `v` as the cell of record `row` in column `at`.
    fn field<V: Serialize + ?Sized>(&mut self, row: usize, at: usize, v: &V) -> Result<(), Error> {
        let col = &mut self.columns[at];
        // A field written twice in one object: the last value holds, as in a JSON object.
        if col.rows.last() == Some(&row) {
            col.rows.pop();
            col.cells.pop();
        }
        let (text, nums) = (col.text.len(), col.nums.len());
        let cell = match v.serialize(CellWriter { col: &mut *col }) {
            Ok(c) => c,
            Err(Error::Nested) => {
                col.text.truncate(text);
                col.nums.truncate(nums);
                let v = serde_json::to_value(v).map_err(|e| Error::Custom(e.to_string()))?;
                col.cell(v)
            }
            Err(e) => return Err(e),
        };
        col.rows.push(row);
        col.cells.push(cell);
        Ok(())
    }
}

/// Whether two field names are equal, compared in place: names are short, and `==` calls the C
/// library for each comparison.
fn same(a: &str, b: &str) -> bool {
    a.len() == b.len() && a.bytes().zip(b.bytes()).all(|(x, y)| x == y)
}

/// Serializes one trace object into the table: its fields go to their columns.
struct Row<'a> {
    table: &'a mut Table,
    row: usize,
    /// The column of the previous field.
    prev: Option<usize>,
    /// The column of the key just read.
    at: Option<usize>,
}

impl Row<'_> {
    fn field<V: Serialize + ?Sized>(&mut self, key: &str, v: &V) -> Result<(), Error> {
        let at = self.table.find(self.prev, key);
        self.prev = Some(at);
        self.table.field(self.row, at, v)
    }
}

/// Serializer methods that give `$err` for what they do not take.
macro_rules! refuse {
    ($err:expr; $($method:ident($($arg:ty),*)),* $(,)?) => {
        $(fn $method(self, $(_: $arg),*) -> Result<Self::Ok, Self::Error> {
            Err($err)
        })*
    };
}

/// Serializer methods for compound values that give `$err`.
macro_rules! refuse_compound {
    ($err:expr; $($kind:ident),* $(,)?) => {
        $(refuse_compound!(@ $kind $err);)*
    };
    (@ newtype_variant $err:expr) => {
        fn serialize_newtype_variant<T: Serialize + ?Sized>(
            self,
            _: &'static str,
            _: u32,
            _: &'static str,
            _: &T,
        ) -> Result<Self::Ok, Self::Error> {
            Err($err)
        }
    };
    (@ seq $err:expr) => {
        fn serialize_seq(self, _: Option<usize>) -> Result<Self::SerializeSeq, Self::Error> {
            Err($err)
        }
    };
    (@ tuple $err:expr) => {
        fn serialize_tuple(self, _: usize) -> Result<Self::SerializeTuple, Self::Error> {
            Err($err)
        }
    };
    (@ tuple_struct $err:expr) => {
        fn serialize_tuple_struct(
            self,
            _: &'static str,
            _: usize,
        ) -> Result<Self::SerializeTupleStruct, Self::Error> {
            Err($err)
        }
    };
    (@ tuple_variant $err:expr) => {
        fn serialize_tuple_variant(
            self,
            _: &'static str,
            _: u32,
            _: &'static str,
            _: usize,
        ) -> Result<Self::SerializeTupleVariant, Self::Error> {
            Err($err)
        }
    };
    (@ map $err:expr) => {
        fn serialize_map(self, _: Option<usize>) -> Result<Self::SerializeMap, Self::Error> {
            Err($err)
        }
    };
    (@ struct $err:expr) => {
        fn serialize_struct(
            self,
            _: &'static str,
            _: usize,
        ) -> Result<Self::SerializeStruct, Self::Error> {
            Err($err)
        }
    };
    (@ struct_variant $err:expr) => {
        fn serialize_struct_variant(
            self,
            _: &'static str,
            _: u32,
            _: &'static str,
            _: usize,
        ) -> Result<Self::SerializeStructVariant, Self::Error> {
            Err($err)
        }
    };
}

/// A trace object that is not an object has no fields.
macro_rules! no_fields {
    ($($method:ident($($arg:ty),*)),* $(,)?) => {
        $(fn $method(self, $(_: $arg),*) -> Result<(), Error> {
            Ok(())
        })*
    };
}

fn not_an_object() -> Error {
    Error::Custom("a trace record is not an object".into())
}

impl<'a> Serializer for Row<'a> {
    type Ok = ();
    type Error = Error;
    type SerializeSeq = Impossible<(), Error>;
    type SerializeTuple = Impossible<(), Error>;
    type SerializeTupleStruct = Impossible<(), Error>;
    type SerializeTupleVariant = Impossible<(), Error>;
    type SerializeMap = Self;
    type SerializeStruct = Self;
    type SerializeStructVariant = Impossible<(), Error>;

    no_fields!(
        serialize_bool(bool),
        serialize_i8(i8),
        serialize_i16(i16),
        serialize_i32(i32),
        serialize_i64(i64),
        serialize_u8(u8),
        serialize_u16(u16),
        serialize_u32(u32),
        serialize_u64(u64),
        serialize_f32(f32),
        serialize_f64(f64),
        serialize_char(char),
        serialize_str(&str),
        serialize_bytes(&[u8]),
        serialize_none(),
        serialize_unit(),
        serialize_unit_struct(&'static str),
        serialize_unit_variant(&'static str, u32, &'static str),
    );

    fn serialize_some<T: Serialize + ?Sized>(self, v: &T) -> Result<(), Error> {
        v.serialize(self)
    }
    fn serialize_newtype_struct<T: Serialize + ?Sized>(
        self,
        _: &'static str,
        v: &T,
    ) -> Result<(), Error> {
        v.serialize(self)
    }
    fn serialize_map(self, _: Option<usize>) -> Result<Self, Error> {
        Ok(self)
    }
    fn serialize_struct(self, _: &'static str, _: usize) -> Result<Self, Error> {
        Ok(self)
    }

    refuse_compound!(not_an_object(); newtype_variant, seq, tuple, tuple_struct, tuple_variant, struct_variant);
}

impl ser::SerializeMap for Row<'_> {
    type Ok = ();
    type Error = Error;

    fn serialize_key<K: Serialize + ?Sized>(&mut self, key: &K) -> Result<(), Error> {
        let mut buf = std::mem::take(&mut self.table.key);
        buf.clear();
        let read = key.serialize(Key { buf: &mut buf });
        let at = read.map(|()| self.table.find(self.prev, &buf));
        self.table.key = buf;
        self.at = Some(at?);
        self.prev = self.at;
        Ok(())
    }

    fn serialize_value<V: Serialize + ?Sized>(&mut self, v: &V) -> Result<(), Error> {
        let at = self
            .at
            .take()
            .ok_or_else(|| Error::Custom("a value without its key".into()))?;
        self.table.field(self.row, at, v)
    }

    fn end(self) -> Result<(), Error> {
        Ok(())
    }
}

impl ser::SerializeStruct for Row<'_> {
    type Ok = ();
    type Error = Error;

    fn serialize_field<V: Serialize + ?Sized>(
        &mut self,
        key: &'static str,
        v: &V,
    ) -> Result<(), Error> {
        self.field(key, v)
    }

    fn end(self) -> Result<(), Error> {
        Ok(())
    }
}

/// Reads a field's name into `buf`, as JSON writes a key: strings as they are, integers and
/// unit variants as their text.
struct Key<'a> {
    buf: &'a mut String,
}

fn not_a_key() -> Error {
    Error::Custom("a trace field's name is not a string".into())
}

impl Key<'_> {
    fn text(self, v: impl fmt::Display) -> Result<(), Error> {
        write!(self.buf, "{v}").map_err(|e| Error::Custom(e.to_string()))
    }
}

impl Serializer for Key<'_> {
    type Ok = ();
    type Error = Error;
    type SerializeSeq = Impossible<(), Error>;
    type SerializeTuple = Impossible<(), Error>;
    type SerializeTupleStruct = Impossible<(), Error>;
    type SerializeTupleVariant = Impossible<(), Error>;
    type SerializeMap = Impossible<(), Error>;
    type SerializeStruct = Impossible<(), Error>;
    type SerializeStructVariant = Impossible<(), Error>;

    fn serialize_str(self, v: &str) -> Result<(), Error> {
        self.buf.push_str(v);
        Ok(())
    }
    fn serialize_char(self, v: char) -> Result<(), Error> {
        self.buf.push(v);
        Ok(())
    }
    fn serialize_i8(self, v: i8) -> Result<(), Error> {
        self.text(v)
    }
    fn serialize_i16(self, v: i16) -> Result<(), Error> {
        self.text(v)
    }
    fn serialize_i32(self, v: i32) -> Result<(), Error> {
        self.text(v)
    }
    fn serialize_i64(self, v: i64) -> Result<(), Error> {
        self.text(v)
    }
    fn serialize_u8(self, v: u8) -> Result<(), Error> {
        self.text(v)
    }
    fn serialize_u16(self, v: u16) -> Result<(), Error> {
        self.text(v)
    }
    fn serialize_u32(self, v: u32) -> Result<(), Error> {
        self.text(v)
    }
    fn serialize_u64(self, v: u64) -> Result<(), Error> {
        self.text(v)
    }
    fn serialize_unit_variant(self, _: &'static str, _: u32, v: &'static str) -> Result<(), Error> {
        self.serialize_str(v)
    }
    fn serialize_newtype_struct<T: Serialize + ?Sized>(
        self,
        _: &'static str,
        v: &T,
    ) -> Result<(), Error> {
        v.serialize(self)
    }
    fn collect_str<T: fmt::Display + ?Sized>(self, v: &T) -> Result<(), Error> {
        self.text(v)
    }

    refuse!(not_a_key();
        serialize_bool(bool),
        serialize_f32(f32),
        serialize_f64(f64),
        serialize_bytes(&[u8]),
        serialize_none(),
        serialize_unit(),
        serialize_unit_struct(&'static str),
    );

    fn serialize_some<T: Serialize + ?Sized>(self, _: &T) -> Result<(), Error> {
        Err(not_a_key())
    }

    refuse_compound!(not_a_key(); newtype_variant, seq, tuple, tuple_struct, tuple_variant, map, struct, struct_variant);
}

/// Writes one field's value into its column as a cell: scalars and arrays of numbers; anything
/// else gives [`Error::Nested`] (the caller then keeps the JSON value).
struct CellWriter<'a> {
    col: &'a mut Column,
}

/// An integer as JSON holds it: beyond `i64`, a number with a fraction.
fn uint(v: u64) -> Num {
    i64::try_from(v).map_or(Num::Float(v as f64), Num::Int)
}

/// A number JSON can hold (JSON has no NaN or infinities: `serde_json` makes them `null`).
fn finite(v: f64) -> Option<f64> {
    v.is_finite().then_some(v)
}

impl From<Num> for Cell {
    fn from(n: Num) -> Cell {
        match n {
            Num::Int(i) => Cell::Int(i),
            Num::Float(f) => Cell::Float(f),
        }
    }
}

impl<'a> Serializer for CellWriter<'a> {
    type Ok = Cell;
    type Error = Error;
    type SerializeSeq = List<'a>;
    type SerializeTuple = List<'a>;
    type SerializeTupleStruct = List<'a>;
    type SerializeTupleVariant = Impossible<Cell, Error>;
    type SerializeMap = Impossible<Cell, Error>;
    type SerializeStruct = Impossible<Cell, Error>;
    type SerializeStructVariant = Impossible<Cell, Error>;

    fn serialize_bool(self, v: bool) -> Result<Cell, Error> {
        Ok(Cell::Bool(v))
    }
    fn serialize_i8(self, v: i8) -> Result<Cell, Error> {
        Ok(Cell::Int(v.into()))
    }
    fn serialize_i16(self, v: i16) -> Result<Cell, Error> {
        Ok(Cell::Int(v.into()))
    }
    fn serialize_i32(self, v: i32) -> Result<Cell, Error> {
        Ok(Cell::Int(v.into()))
    }
    fn serialize_i64(self, v: i64) -> Result<Cell, Error> {
        Ok(Cell::Int(v))
    }
    fn serialize_u8(self, v: u8) -> Result<Cell, Error> {
        Ok(Cell::Int(v.into()))
    }
    fn serialize_u16(self, v: u16) -> Result<Cell, Error> {
        Ok(Cell::Int(v.into()))
    }
    fn serialize_u32(self, v: u32) -> Result<Cell, Error> {
        Ok(Cell::Int(v.into()))
    }
    fn serialize_u64(self, v: u64) -> Result<Cell, Error> {
        Ok(uint(v).into())
    }
    fn serialize_f32(self, v: f32) -> Result<Cell, Error> {
        self.serialize_f64(v.into())
    }
    fn serialize_f64(self, v: f64) -> Result<Cell, Error> {
        Ok(finite(v).map_or(Cell::Null, Cell::Float))
    }
    fn serialize_char(self, v: char) -> Result<Cell, Error> {
        let mut b = [0; 4];
        Ok(self.col.str(v.encode_utf8(&mut b)))
    }
    fn serialize_str(self, v: &str) -> Result<Cell, Error> {
        Ok(self.col.str(v))
    }
    fn collect_str<T: fmt::Display + ?Sized>(self, v: &T) -> Result<Cell, Error> {
        let start = self.col.text.len();
        write!(self.col.text, "{v}").map_err(|e| Error::Custom(e.to_string()))?;
        Ok(Cell::Str(start, self.col.text.len()))
    }
    fn serialize_none(self) -> Result<Cell, Error> {
        Ok(Cell::Null)
    }
    fn serialize_some<T: Serialize + ?Sized>(self, v: &T) -> Result<Cell, Error> {
        v.serialize(self)
    }
    fn serialize_unit(self) -> Result<Cell, Error> {
        Ok(Cell::Null)
    }
    fn serialize_unit_struct(self, _: &'static str) -> Result<Cell, Error> {
        Ok(Cell::Null)
    }
    fn serialize_unit_variant(
        self,
        _: &'static str,
        _: u32,
        v: &'static str,
    ) -> Result<Cell, Error> {
        Ok(self.col.str(v))
    }
    fn serialize_newtype_struct<T: Serialize + ?Sized>(
        self,
        _: &'static str,
        v: &T,
    ) -> Result<Cell, Error> {
        v.serialize(self)
    }
    fn serialize_seq(self, _: Option<usize>) -> Result<List<'a>, Error> {
        Ok(List {
            start: self.col.nums.len(),
            float: false,
            col: self.col,
        })
    }
    fn serialize_tuple(self, len: usize) -> Result<List<'a>, Error> {
        self.serialize_seq(Some(len))
    }
    fn serialize_tuple_struct(self, _: &'static str, len: usize) -> Result<List<'a>, Error> {
        self.serialize_seq(Some(len))
    }

    refuse!(Error::Nested; serialize_bytes(&[u8]));

    refuse_compound!(Error::Nested; newtype_variant, tuple_variant, map, struct, struct_variant);
}

/// An array being written: numbers go to the column's `nums`; anything else makes the array
/// nested.
struct List<'a> {
    col: &'a mut Column,
    start: usize,
    float: bool,
}

impl List<'_> {
    fn push<T: Serialize + ?Sized>(&mut self, v: &T) -> Result<(), Error> {
        let n = v.serialize(Number)?;
        self.float |= matches!(n, Num::Float(_));
        self.col.nums.push(n);
        Ok(())
    }

    fn done(self) -> Result<Cell, Error> {
        Ok(Cell::List {
            start: self.start,
            end: self.col.nums.len(),
            float: self.float,
        })
    }
}

impl ser::SerializeSeq for List<'_> {
    type Ok = Cell;
    type Error = Error;
    fn serialize_element<T: Serialize + ?Sized>(&mut self, v: &T) -> Result<(), Error> {
        self.push(v)
    }
    fn end(self) -> Result<Cell, Error> {
        self.done()
    }
}

impl ser::SerializeTuple for List<'_> {
    type Ok = Cell;
    type Error = Error;
    fn serialize_element<T: Serialize + ?Sized>(&mut self, v: &T) -> Result<(), Error> {
        self.push(v)
    }
    fn end(self) -> Result<Cell, Error> {
        self.done()
    }
}

impl ser::SerializeTupleStruct for List<'_> {
    type Ok = Cell;
    type Error = Error;
    fn serialize_field<T: Serialize + ?Sized>(&mut self, v: &T) -> Result<(), Error> {
        self.push(v)
    }
    fn end(self) -> Result<Cell, Error> {
        self.done()
    }
}

/// An array's element: a number, or [`Error::Nested`].
struct Number;

impl Serializer for Number {
    type Ok = Num;
    type Error = Error;
    type SerializeSeq = Impossible<Num, Error>;
    type SerializeTuple = Impossible<Num, Error>;
    type SerializeTupleStruct = Impossible<Num, Error>;
    type SerializeTupleVariant = Impossible<Num, Error>;
    type SerializeMap = Impossible<Num, Error>;
    type SerializeStruct = Impossible<Num, Error>;
    type SerializeStructVariant = Impossible<Num, Error>;

    fn serialize_i8(self, v: i8) -> Result<Num, Error> {
        Ok(Num::Int(v.into()))
    }
    fn serialize_i16(self, v: i16) -> Result<Num, Error> {
        Ok(Num::Int(v.into()))
    }
    fn serialize_i32(self, v: i32) -> Result<Num, Error> {
        Ok(Num::Int(v.into()))
    }
    fn serialize_i64(self, v: i64) -> Result<Num, Error> {
        Ok(Num::Int(v))
    }
    fn serialize_u8(self, v: u8) -> Result<Num, Error> {
        Ok(Num::Int(v.into()))
    }
    fn serialize_u16(self, v: u16) -> Result<Num, Error> {
        Ok(Num::Int(v.into()))
    }
    fn serialize_u32(self, v: u32) -> Result<Num, Error> {
        Ok(Num::Int(v.into()))
    }
    fn serialize_u64(self, v: u64) -> Result<Num, Error> {
        Ok(uint(v))
    }
    fn serialize_f32(self, v: f32) -> Result<Num, Error> {
        self.serialize_f64(v.into())
    }
    fn serialize_f64(self, v: f64) -> Result<Num, Error> {
        // A `null` element makes the array nested.
        finite(v).map(Num::Float).ok_or(Error::Nested)
    }
    fn serialize_some<T: Serialize + ?Sized>(self, v: &T) -> Result<Num, Error> {
        v.serialize(self)
    }
    fn serialize_newtype_struct<T: Serialize + ?Sized>(
        self,
        _: &'static str,
        v: &T,
    ) -> Result<Num, Error> {
        v.serialize(self)
    }

    refuse!(Error::Nested;
        serialize_bool(bool),
        serialize_char(char),
        serialize_str(&str),
        serialize_bytes(&[u8]),
        serialize_none(),
        serialize_unit(),
        serialize_unit_struct(&'static str),
        serialize_unit_variant(&'static str, u32, &'static str),
    );

    refuse_compound!(Error::Nested; newtype_variant, seq, tuple, tuple_struct, tuple_variant, map, struct, struct_variant);
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    /// The cells of `rows`, by column, as JSON values.
    fn cells(rows: &[Value]) -> Vec<(String, Vec<Value>)> {
        let mut t = Table::default();
        for (i, r) in rows.iter().enumerate() {
            t.row(i, r).unwrap();
        }
        t.into_columns()
            .into_iter()
            .map(|c| {
                let v = c.dense(rows.len()).map(|x| c.value(x)).collect();
                (c.name, v)
            })
            .collect()
    }

    /// Each kind of JSON value comes back as it went in, fields in order of first appearance.
    #[test]
    fn cells_hold_the_json_values() {
        let rows = [
            json!({"t": 0.5, "seq": 1, "kind": "spawn", "pos": [1.0, 2], "ids": [1, 2]}),
            json!({"t": 1.0, "seq": 2, "kind": "look", "frame": {"x": 1}, "seen": [[1, 2]],
                   "big": 18446744073709551615u64, "ok": true, "none": null, "mix": [1, "a"]}),
            json!({"t": 2.0, "seq": 3, "pos": [], "kind": "x", "seq2": -3}),
        ];
        let got = cells(&rows);
        let names: Vec<&str> = got.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(
            names,
            [
                "t", "seq", "kind", "pos", "ids", "frame", "seen", "big", "ok", "none", "mix",
                "seq2"
            ]
        );
        for (i, row) in rows.iter().enumerate() {
            for (name, col) in &got {
                let want = row.get(name).cloned().unwrap_or(Value::Null);
                let have = col[i].clone();
                if name == "big" && i == 1 {
                    // Beyond i64: a float, as JSON's readers take it.
                    assert_eq!(have, json!(18446744073709551615u64 as f64));
                } else {
                    assert_eq!(have, want, "row {i} field {name}");
                }
            }
        }
    }

    #[derive(serde::Serialize)]
    struct Odd {
        nan: f64,
        with_nan: Vec<f64>,
        unit: (),
        word: Word,
        wrapped: Wrapped,
        tuple: (u8, f32),
    }

    #[derive(serde::Serialize)]
    enum Word {
        Boundary,
    }

    #[derive(serde::Serialize)]
    struct Wrapped(Vec<u32>);

    /// Values JSON holds differently from Rust: as `serde_json::to_value` makes them.
    #[test]
    fn cells_follow_serde_json() {
        let odd = Odd {
            nan: f64::NAN,
            with_nan: vec![1.0, f64::INFINITY],
            unit: (),
            word: Word::Boundary,
            wrapped: Wrapped(vec![3, 4]),
            tuple: (1, 0.5),
        };
        let want = serde_json::to_value(&odd).unwrap();
        let mut t = Table::default();
        t.row(0, &odd).unwrap();
        for c in t.into_columns() {
            let have = c.cells.first().map_or(Value::Null, |x| c.value(x));
            assert_eq!(have, want[&c.name], "field {}", c.name);
        }
    }

    /// A field written twice: the last value holds.
    #[test]
    fn a_repeated_field_keeps_its_last_value() {
        struct Twice;
        impl Serialize for Twice {
            fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
                use serde::ser::SerializeMap;
                let mut m = s.serialize_map(None)?;
                m.serialize_entry("a", &[1.0, 2.0])?;
                m.serialize_entry("b", "x")?;
                m.serialize_entry("a", &3)?;
                m.end()
            }
        }
        let mut t = Table::default();
        t.row(0, &Twice).unwrap();
        t.row(1, &Twice).unwrap();
        let cols = t.into_columns();
        assert_eq!(cols[0].rows, [0, 1]);
        assert_eq!(cols[0].cells, [Cell::Int(3), Cell::Int(3)]);
    }
}
