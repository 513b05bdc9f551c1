//! The one JSON emitter: pretty JSON with a final newline, refused when a number is not finite.
//!
//! serde_json writes NaN and ±∞ as `null`, which a reader cannot tell from a value that is
//! absent; a result that overflowed must be an error naming what overflowed, never a `null` with
//! exit code 0. [`to_bytes`] first walks the value with a serializer that only checks numbers and
//! remembers the path to each (`points[3].u_arcsec`).

use serde::Serialize;
use serde::ser::{self, Impossible};
use std::fmt;

/// A number that is not finite, at a path in the value.
#[derive(Debug)]
pub struct NonFinite {
    /// Where: `points[3].u_arcsec`.
    pub path: String,
    /// The value (NaN, inf or -inf).
    pub value: f64,
}

impl fmt::Display for NonFinite {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} is {} (a result overflowed or is undefined)",
            if self.path.is_empty() {
                "the value"
            } else {
                &self.path
            },
            self.value
        )
    }
}

impl std::error::Error for NonFinite {}

impl ser::Error for NonFinite {
    fn custom<T: fmt::Display>(msg: T) -> Self {
        NonFinite {
            path: msg.to_string(),
            value: f64::NAN,
        }
    }
}

/// `value` as pretty JSON with a final newline.
///
/// # Errors
/// A number that is not finite, with its path.
///
/// ```
/// use gonio_io::json::to_bytes;
/// #[derive(serde::Serialize)]
/// struct P { u_arcsec: f64 }
/// assert_eq!(to_bytes(&P { u_arcsec: 0.5 }).unwrap(), b"{\n  \"u_arcsec\": 0.5\n}\n");
/// let e = to_bytes(&vec![P { u_arcsec: 1.0 }, P { u_arcsec: f64::INFINITY }]).unwrap_err();
/// assert_eq!(e.path, "[1].u_arcsec");
/// ```
pub fn to_bytes<T: Serialize + ?Sized>(value: &T) -> Result<Vec<u8>, NonFinite> {
    check_finite(value)?;
    let mut v = serde_json::to_vec_pretty(value).map_err(|e| NonFinite {
        path: e.to_string(),
        value: f64::NAN,
    })?;
    v.push(b'\n');
    Ok(v)
}

/// Checks that every number in `value` is finite.
///
/// # Errors
/// The first number that is not, with its path.
pub fn check_finite<T: Serialize + ?Sized>(value: &T) -> Result<(), NonFinite> {
    let mut c = Checker { path: Vec::new() };
    value.serialize(&mut c)
}

/// Checks that a result is finite before it is shown or written; the error names the input it
/// came from (`readings.csv: the calibration is not finite: points[3].u_arcsec is inf …`).
///
/// # Errors
/// The first number that is not finite.
pub fn finite_result<T: Serialize + ?Sized>(
    value: &T,
    input: &std::path::Path,
    what: &str,
) -> anyhow::Result<()> {
    check_finite(value).map_err(|e| {
        anyhow::anyhow!(
            "{}: {what} is not finite: {e}; check the input's values",
            input.display()
        )
    })
}

#[derive(Debug)]
enum Seg {
    Field(&'static str),
    Key(String),
    Index(usize),
}

struct Checker {
    path: Vec<Seg>,
}

impl Checker {
    fn fail(&self, value: f64) -> NonFinite {
        let mut path = String::new();
        for s in &self.path {
            match s {
                Seg::Field(f) => {
                    if !path.is_empty() {
                        path.push('.');
                    }
                    path.push_str(f);
                }
                Seg::Key(k) => {
                    if !path.is_empty() {
                        path.push('.');
                    }
                    path.push_str(&gonio_core::text::short(k));
                }
                Seg::Index(i) => path.push_str(&format!("[{i}]")),
            }
        }
        NonFinite { path, value }
    }
    fn float(&self, v: f64) -> Result<(), NonFinite> {
        if v.is_finite() {
            Ok(())
        } else {
            Err(self.fail(v))
        }
    }
}

/// Collects a map key as text.
struct KeyText;

macro_rules! key_display {
    ($($m:ident: $t:ty),*) => {$(
        fn $m(self, v: $t) -> Result<String, NonFinite> { Ok(v.to_string()) }
    )*};
}

impl ser::Serializer for KeyText {
    type Ok = String;
    type Error = NonFinite;
    type SerializeSeq = Impossible<String, NonFinite>;
    type SerializeTuple = Impossible<String, NonFinite>;
    type SerializeTupleStruct = Impossible<String, NonFinite>;
    type SerializeTupleVariant = Impossible<String, NonFinite>;
    type SerializeMap = Impossible<String, NonFinite>;
    type SerializeStruct = Impossible<String, NonFinite>;
    type SerializeStructVariant = Impossible<String, NonFinite>;
    key_display!(serialize_bool: bool, serialize_i8: i8, serialize_i16: i16, serialize_i32: i32,
        serialize_i64: i64, serialize_u8: u8, serialize_u16: u16, serialize_u32: u32,
        serialize_u64: u64, serialize_f32: f32, serialize_f64: f64, serialize_char: char,
        serialize_str: &str);
    fn serialize_bytes(self, _: &[u8]) -> Result<String, NonFinite> {
        Ok("bytes".into())
    }
    fn serialize_none(self) -> Result<String, NonFinite> {
        Ok("null".into())
    }
    fn serialize_some<T: Serialize + ?Sized>(self, v: &T) -> Result<String, NonFinite> {
        v.serialize(self)
    }
    fn serialize_unit(self) -> Result<String, NonFinite> {
        Ok(String::new())
    }
    fn serialize_unit_struct(self, n: &'static str) -> Result<String, NonFinite> {
        Ok(n.into())
    }
    fn serialize_unit_variant(
        self,
        _: &'static str,
        _: u32,
        v: &'static str,
    ) -> Result<String, NonFinite> {
        Ok(v.into())
    }
    fn serialize_newtype_struct<T: Serialize + ?Sized>(
        self,
        _: &'static str,
        v: &T,
    ) -> Result<String, NonFinite> {
        v.serialize(self)
    }
    fn serialize_newtype_variant<T: Serialize + ?Sized>(
        self,
        _: &'static str,
        _: u32,
        v: &'static str,
        _: &T,
    ) -> Result<String, NonFinite> {
        Ok(v.into())
    }
    fn serialize_seq(self, _: Option<usize>) -> Result<Self::SerializeSeq, NonFinite> {
        Err(ser::Error::custom("a sequence as a map key"))
    }
    fn serialize_tuple(self, _: usize) -> Result<Self::SerializeTuple, NonFinite> {
        Err(ser::Error::custom("a tuple as a map key"))
    }
    fn serialize_tuple_struct(
        self,
        _: &'static str,
        _: usize,
    ) -> Result<Self::SerializeTupleStruct, NonFinite> {
        Err(ser::Error::custom("a tuple as a map key"))
    }
    fn serialize_tuple_variant(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
        _: usize,
    ) -> Result<Self::SerializeTupleVariant, NonFinite> {
        Err(ser::Error::custom("a tuple as a map key"))
    }
    fn serialize_map(self, _: Option<usize>) -> Result<Self::SerializeMap, NonFinite> {
        Err(ser::Error::custom("a map as a map key"))
    }
    fn serialize_struct(
        self,
        _: &'static str,
        _: usize,
    ) -> Result<Self::SerializeStruct, NonFinite> {
        Err(ser::Error::custom("a struct as a map key"))
    }
    fn serialize_struct_variant(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
        _: usize,
    ) -> Result<Self::SerializeStructVariant, NonFinite> {
        Err(ser::Error::custom("a struct as a map key"))
    }
}

macro_rules! ok_scalars {
    ($($m:ident: $t:ty),*) => {$(
        fn $m(self, _: $t) -> Result<(), NonFinite> { Ok(()) }
    )*};
}

/// A sequence or map being checked: counts its elements for the path.
struct Compound<'a> {
    c: &'a mut Checker,
    index: usize,
}

impl Compound<'_> {
    fn element<T: Serialize + ?Sized>(&mut self, v: &T) -> Result<(), NonFinite> {
        self.c.path.push(Seg::Index(self.index));
        self.index += 1;
        v.serialize(&mut *self.c)?;
        self.c.path.pop();
        Ok(())
    }
    fn field<T: Serialize + ?Sized>(&mut self, k: &'static str, v: &T) -> Result<(), NonFinite> {
        self.c.path.push(Seg::Field(k));
        v.serialize(&mut *self.c)?;
        self.c.path.pop();
        Ok(())
    }
}

/// The element-wise compounds (sequence, tuple, tuple struct, tuple variant): each element is
/// checked at the next index.
macro_rules! compound_elements {
    ($($tr:ident::$m:ident),*) => {$(
        impl ser::$tr for Compound<'_> {
            type Ok = ();
            type Error = NonFinite;
            fn $m<T: Serialize + ?Sized>(&mut self, v: &T) -> Result<(), NonFinite> {
                self.element(v)
            }
            fn end(self) -> Result<(), NonFinite> {
                Ok(())
            }
        }
    )*};
}

/// The named-field compounds (struct, struct variant): each field is checked under its name.
macro_rules! compound_fields {
    ($($tr:ident),*) => {$(
        impl ser::$tr for Compound<'_> {
            type Ok = ();
            type Error = NonFinite;
            fn serialize_field<T: Serialize + ?Sized>(
                &mut self,
                k: &'static str,
                v: &T,
            ) -> Result<(), NonFinite> {
                self.field(k, v)
            }
            fn end(self) -> Result<(), NonFinite> {
                Ok(())
            }
        }
    )*};
}

compound_elements!(
    SerializeSeq::serialize_element,
    SerializeTuple::serialize_element,
    SerializeTupleStruct::serialize_field,
    SerializeTupleVariant::serialize_field
);
compound_fields!(SerializeStruct, SerializeStructVariant);

impl ser::SerializeMap for Compound<'_> {
    type Ok = ();
    type Error = NonFinite;
    fn serialize_key<T: Serialize + ?Sized>(&mut self, k: &T) -> Result<(), NonFinite> {
        let key = k.serialize(KeyText)?;
        self.c.path.push(Seg::Key(key));
        Ok(())
    }
    fn serialize_value<T: Serialize + ?Sized>(&mut self, v: &T) -> Result<(), NonFinite> {
        v.serialize(&mut *self.c)?;
        self.c.path.pop();
        Ok(())
    }
    fn end(self) -> Result<(), NonFinite> {
        Ok(())
    }
}

impl<'a> ser::Serializer for &'a mut Checker {
    type Ok = ();
    type Error = NonFinite;
    type SerializeSeq = Compound<'a>;
    type SerializeTuple = Compound<'a>;
    type SerializeTupleStruct = Compound<'a>;
    type SerializeTupleVariant = Compound<'a>;
    type SerializeMap = Compound<'a>;
    type SerializeStruct = Compound<'a>;
    type SerializeStructVariant = Compound<'a>;
    ok_scalars!(serialize_bool: bool, serialize_i8: i8, serialize_i16: i16, serialize_i32: i32,
        serialize_i64: i64, serialize_u8: u8, serialize_u16: u16, serialize_u32: u32,
        serialize_u64: u64, serialize_char: char, serialize_str: &str, serialize_bytes: &[u8]);
    fn serialize_f32(self, v: f32) -> Result<(), NonFinite> {
        self.float(f64::from(v))
    }
    fn serialize_f64(self, v: f64) -> Result<(), NonFinite> {
        self.float(v)
    }
    fn serialize_none(self) -> Result<(), NonFinite> {
        Ok(())
    }
    fn serialize_some<T: Serialize + ?Sized>(self, v: &T) -> Result<(), NonFinite> {
        v.serialize(self)
    }
    fn serialize_unit(self) -> Result<(), NonFinite> {
        Ok(())
    }
    fn serialize_unit_struct(self, _: &'static str) -> Result<(), NonFinite> {
        Ok(())
    }
    fn serialize_unit_variant(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
    ) -> Result<(), NonFinite> {
        Ok(())
    }
    fn serialize_newtype_struct<T: Serialize + ?Sized>(
        self,
        _: &'static str,
        v: &T,
    ) -> Result<(), NonFinite> {
        v.serialize(self)
    }
    fn serialize_newtype_variant<T: Serialize + ?Sized>(
        self,
        _: &'static str,
        _: u32,
        variant: &'static str,
        v: &T,
    ) -> Result<(), NonFinite> {
        self.path.push(Seg::Field(variant));
        v.serialize(&mut *self)?;
        self.path.pop();
        Ok(())
    }
    fn serialize_seq(self, _: Option<usize>) -> Result<Compound<'a>, NonFinite> {
        Ok(Compound { c: self, index: 0 })
    }
    fn serialize_tuple(self, _: usize) -> Result<Compound<'a>, NonFinite> {
        Ok(Compound { c: self, index: 0 })
    }
    fn serialize_tuple_struct(self, _: &'static str, _: usize) -> Result<Compound<'a>, NonFinite> {
        Ok(Compound { c: self, index: 0 })
    }
    fn serialize_tuple_variant(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
        _: usize,
    ) -> Result<Compound<'a>, NonFinite> {
        Ok(Compound { c: self, index: 0 })
    }
    fn serialize_map(self, _: Option<usize>) -> Result<Compound<'a>, NonFinite> {
        Ok(Compound { c: self, index: 0 })
    }
    fn serialize_struct(self, _: &'static str, _: usize) -> Result<Compound<'a>, NonFinite> {
        Ok(Compound { c: self, index: 0 })
    }
    fn serialize_struct_variant(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
        _: usize,
    ) -> Result<Compound<'a>, NonFinite> {
        Ok(Compound { c: self, index: 0 })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeMap;

    #[test]
    fn paths_through_maps_options_and_flattened_fields() {
        #[derive(Serialize)]
        struct Inner {
            e_um: Option<f64>,
        }
        #[derive(Serialize)]
        struct Outer {
            name: String,
            #[serde(flatten)]
            inner: Inner,
            by_head: BTreeMap<String, Vec<f64>>,
        }
        let mut m = BTreeMap::new();
        m.insert("h2".to_string(), vec![0.0, f64::NAN]);
        let v = Outer {
            name: "x".into(),
            inner: Inner { e_um: Some(1.0) },
            by_head: m,
        };
        assert_eq!(check_finite(&v).unwrap_err().path, "by_head.h2[1]");
        let v = Outer {
            name: "x".into(),
            inner: Inner {
                e_um: Some(f64::INFINITY),
            },
            by_head: BTreeMap::new(),
        };
        assert_eq!(check_finite(&v).unwrap_err().path, "e_um");
        let v = Outer {
            name: "x".into(),
            inner: Inner { e_um: None },
            by_head: BTreeMap::new(),
        };
        assert!(to_bytes(&v).is_ok());
    }
}
