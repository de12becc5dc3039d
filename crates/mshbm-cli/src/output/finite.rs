//! No NaN or infinity in a CSV or JSON output: a non-finite number is a failed computation,
//! and written as `NaN`, `inf` or JSON `null` it would pass for a result. Every CSV row and
//! every JSON value goes through these checks before it is written; the error names the
//! file (or standard output) and the column or field.

use std::fmt;
use std::path::Path;

use anyhow::{bail, Result};
use serde::ser::{self, Serialize};

/// Check one CSV row (`row` counted from 1 after the header) for a field that parses as a
/// non-finite number; `header` names the columns.
pub fn check_csv_line(path: &Path, header: &str, row: usize, line: &str) -> Result<()> {
    // Rust writes non-finite floats as NaN, inf, -inf: skip the parse for all other rows
    if !(line.contains("NaN") || line.contains("inf")) {
        return Ok(());
    }
    for (k, field) in line.split(',').enumerate() {
        if field.parse::<f64>().is_ok_and(|v| !v.is_finite()) {
            let column = header.split(',').nth(k).unwrap_or("?");
            bail!(
                "{}: column {column}, row {row}: the value is {field}, not a finite number; refusing to write it",
                path.display()
            );
        }
    }
    Ok(())
}

/// Check that `value` serializes without a NaN or an infinity (serde_json would write
/// `null`); `destination` names the file or "standard output" in the error.
pub fn check_json<T: Serialize + ?Sized>(destination: &str, value: &T) -> Result<()> {
    let mut finder = NonFinite::default();
    match value.serialize(&mut finder) {
        Ok(()) => Ok(()),
        Err(Found(field)) => bail!(
            "{destination}: field {field}: the value is not a finite number (NaN or infinity); refusing to write it"
        ),
    }
}

/// Serialize `value` to one line of JSON after [`check_json`].
pub fn to_json<T: Serialize + ?Sized>(destination: &str, value: &T) -> Result<String> {
    check_json(destination, value)?;
    let json = serde_json::to_string(value)?;
    // serde_json escapes C0 control characters; DEL and C1 (U+007F–U+009F), which can only
    // stand in strings, are escaped here too, so that no control character of an input
    // (a model's name) reaches a terminal
    if !json.chars().any(char::is_control) {
        return Ok(json);
    }
    Ok(json
        .chars()
        .map(|c| {
            if c.is_control() {
                format!("\\u{:04x}", u32::from(c))
            } else {
                c.to_string()
            }
        })
        .collect())
}

/// The field path of the first non-finite number (the serializer's "error").
#[derive(Debug)]
struct Found(String);

impl fmt::Display for Found {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Found {}

impl ser::Error for Found {
    fn custom<M: fmt::Display>(msg: M) -> Self {
        Found(format!("(cannot serialize: {msg})"))
    }
}

/// A serializer that only walks the value, keeping the path of the field it is in.
#[derive(Default)]
struct NonFinite {
    path: Vec<String>,
    /// Next index of each open sequence.
    index: Vec<usize>,
    /// The last string serialized (a map key).
    last_str: Option<String>,
}

impl NonFinite {
    fn float(&self, v: f64) -> Result<(), Found> {
        if v.is_finite() {
            Ok(())
        } else {
            let p = self.path.concat();
            Err(Found(if p.is_empty() {
                "(top level)".into()
            } else {
                p.trim_start_matches('.').to_string()
            }))
        }
    }

    fn element<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<(), Found> {
        let i = self.index.last().copied().unwrap_or(0);
        self.path.push(format!("[{i}]"));
        let r = value.serialize(&mut *self);
        self.path.pop();
        if let Some(last) = self.index.last_mut() {
            *last += 1;
        }
        r
    }

    fn field<T: Serialize + ?Sized>(&mut self, key: &str, value: &T) -> Result<(), Found> {
        self.path.push(format!(".{key}"));
        let r = value.serialize(&mut *self);
        self.path.pop();
        r
    }
}

macro_rules! ignore {
    ($($name:ident: $t:ty),*) => {
        $(fn $name(self, _v: $t) -> Result<(), Found> { Ok(()) })*
    };
}

impl ser::Serializer for &mut NonFinite {
    type Ok = ();
    type Error = Found;
    type SerializeSeq = Self;
    type SerializeTuple = Self;
    type SerializeTupleStruct = Self;
    type SerializeTupleVariant = Self;
    type SerializeMap = Self;
    type SerializeStruct = Self;
    type SerializeStructVariant = Self;

    ignore!(serialize_bool: bool, serialize_i8: i8, serialize_i16: i16, serialize_i32: i32,
        serialize_i64: i64, serialize_i128: i128, serialize_u8: u8, serialize_u16: u16,
        serialize_u32: u32, serialize_u64: u64, serialize_u128: u128, serialize_char: char,
        serialize_bytes: &[u8]);

    fn serialize_f32(self, v: f32) -> Result<(), Found> {
        self.float(f64::from(v))
    }
    fn serialize_f64(self, v: f64) -> Result<(), Found> {
        self.float(v)
    }
    fn serialize_str(self, v: &str) -> Result<(), Found> {
        self.last_str = Some(v.to_string());
        Ok(())
    }
    fn serialize_none(self) -> Result<(), Found> {
        Ok(())
    }
    fn serialize_some<T: Serialize + ?Sized>(self, value: &T) -> Result<(), Found> {
        value.serialize(self)
    }
    fn serialize_unit(self) -> Result<(), Found> {
        Ok(())
    }
    fn serialize_unit_struct(self, _: &'static str) -> Result<(), Found> {
        Ok(())
    }
    fn serialize_unit_variant(self, _: &'static str, _: u32, _: &'static str) -> Result<(), Found> {
        Ok(())
    }
    fn serialize_newtype_struct<T: Serialize + ?Sized>(
        self,
        _: &'static str,
        value: &T,
    ) -> Result<(), Found> {
        value.serialize(self)
    }
    fn serialize_newtype_variant<T: Serialize + ?Sized>(
        self,
        _: &'static str,
        _: u32,
        variant: &'static str,
        value: &T,
    ) -> Result<(), Found> {
        self.field(variant, value)
    }
    fn serialize_seq(self, _: Option<usize>) -> Result<Self, Found> {
        self.index.push(0);
        Ok(self)
    }
    fn serialize_tuple(self, len: usize) -> Result<Self, Found> {
        self.serialize_seq(Some(len))
    }
    fn serialize_tuple_struct(self, _: &'static str, len: usize) -> Result<Self, Found> {
        self.serialize_seq(Some(len))
    }
    fn serialize_tuple_variant(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
        len: usize,
    ) -> Result<Self, Found> {
        self.serialize_seq(Some(len))
    }
    fn serialize_map(self, _: Option<usize>) -> Result<Self, Found> {
        Ok(self)
    }
    fn serialize_struct(self, _: &'static str, _: usize) -> Result<Self, Found> {
        Ok(self)
    }
    fn serialize_struct_variant(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
        _: usize,
    ) -> Result<Self, Found> {
        Ok(self)
    }
}

macro_rules! sequence {
    ($($trait:ident: $method:ident),*) => {
        $(impl<'a> ser::$trait for &'a mut NonFinite {
            type Ok = ();
            type Error = Found;
            fn $method<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<(), Found> {
                self.element(value)
            }
            fn end(self) -> Result<(), Found> {
                self.index.pop();
                Ok(())
            }
        })*
    };
}

sequence!(SerializeSeq: serialize_element, SerializeTuple: serialize_element,
    SerializeTupleStruct: serialize_field, SerializeTupleVariant: serialize_field);

impl ser::SerializeMap for &mut NonFinite {
    type Ok = ();
    type Error = Found;
    fn serialize_key<T: Serialize + ?Sized>(&mut self, key: &T) -> Result<(), Found> {
        self.last_str = None;
        key.serialize(&mut **self)
    }
    fn serialize_value<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<(), Found> {
        let key = self.last_str.take().unwrap_or_else(|| "?".into());
        self.field(&key, value)
    }
    fn end(self) -> Result<(), Found> {
        Ok(())
    }
}

impl ser::SerializeStruct for &mut NonFinite {
    type Ok = ();
    type Error = Found;
    fn serialize_field<T: Serialize + ?Sized>(
        &mut self,
        key: &'static str,
        value: &T,
    ) -> Result<(), Found> {
        self.field(key, value)
    }
    fn end(self) -> Result<(), Found> {
        Ok(())
    }
}

impl ser::SerializeStructVariant for &mut NonFinite {
    type Ok = ();
    type Error = Found;
    fn serialize_field<T: Serialize + ?Sized>(
        &mut self,
        key: &'static str,
        value: &T,
    ) -> Result<(), Found> {
        self.field(key, value)
    }
    fn end(self) -> Result<(), Found> {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(serde::Serialize)]
    struct Contact {
        min: f64,
        series: Vec<f64>,
        note: Option<f64>,
    }

    #[test]
    fn names_the_field_of_a_nan_and_accepts_finite_values() {
        let ok = Contact {
            min: 1.0,
            series: vec![0.0, 2.0],
            note: None,
        };
        assert!(check_json("x", &ok).is_ok());
        let bad = vec![
            ok,
            Contact {
                min: 0.0,
                series: vec![1.0, f64::NAN],
                note: Some(1.0),
            },
        ];
        let e = check_json("out.json", &bad).unwrap_err().to_string();
        assert!(e.contains("out.json: field [1].series[1]"), "{e}");
        let inf = Contact {
            min: f64::NEG_INFINITY,
            series: vec![],
            note: None,
        };
        let e = check_json("stdout", &inf).unwrap_err().to_string();
        assert!(e.contains("field min"), "{e}");
        let map = serde_json::json!({"a": {"b": [1.0, 2.0]}});
        assert!(check_json("x", &map).is_ok());
    }

    #[test]
    fn csv_rows_with_nan_or_inf_are_refused_by_column() {
        let p = Path::new("f.csv");
        assert!(check_csv_line(p, "a,b", 1, "1.0,2.0").is_ok());
        assert!(check_csv_line(p, "a,method", 1, "1.0,hbm-aft").is_ok());
        let e = check_csv_line(p, "a,b,c", 4, "1.0,NaN,3")
            .unwrap_err()
            .to_string();
        assert!(e.contains("f.csv: column b, row 4"), "{e}");
        let e = check_csv_line(p, "a,b", 1, "-inf,3")
            .unwrap_err()
            .to_string();
        assert!(e.contains("column a"), "{e}");
    }
}
