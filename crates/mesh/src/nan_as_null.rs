//! Reports' numbers that may be NaN (or infinite), read back.
//!
//! JSON has no NaN and no infinity: `serde_json` writes a non-finite `f64`
//! as `null`, and reading `null` into an `f64` fails. A report field whose
//! value may be non-finite (a mean over no values, a statistic of an
//! infinite value, a failed measurement) carries
//! `#[serde(with = "unfold_mesh::nan_as_null")]`: it is written exactly as
//! before (the value itself, `null` when not finite) and `null` reads back
//! as NaN. An infinity, written as `null`, therefore reads back as NaN, and
//! is written again as `null`: the same text.
//!
//! Works for an `f64` and for arrays, `Vec`s and `BTreeMap` values of them
//! ([`NullAsNan`]).

use serde::de::DeserializeOwned;
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use std::collections::BTreeMap;

/// Writes `value` as it always was (`serde_json`: a non-finite `f64` as
/// `null`).
///
/// # Errors
/// The serializer's.
pub fn serialize<T: Serialize + ?Sized, S: Serializer>(
    value: &T,
    serializer: S,
) -> Result<S::Ok, S::Error> {
    value.serialize(serializer)
}

/// Reads a value whose `f64`s may be `null`: `null` is NaN.
///
/// # Errors
/// The deserializer's (neither a number nor `null` where an `f64` is).
pub fn deserialize<'de, T: NullAsNan, D: Deserializer<'de>>(
    deserializer: D,
) -> Result<T, D::Error> {
    T::deserialize_null_as_nan(deserializer)
}

/// A value whose `f64`s read `null` as NaN: `f64`, and arrays, `Vec`s and
/// `BTreeMap` values of such.
pub trait NullAsNan: Sized {
    /// Reads the value, `null` as NaN.
    ///
    /// # Errors
    /// The deserializer's.
    fn deserialize_null_as_nan<'de, D: Deserializer<'de>>(
        deserializer: D,
    ) -> Result<Self, D::Error>;
}

/// One element read through [`NullAsNan`] (for the containers).
struct Nullable<T>(T);

impl<'de, T: NullAsNan> Deserialize<'de> for Nullable<T> {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        T::deserialize_null_as_nan(deserializer).map(Nullable)
    }
}

impl NullAsNan for f64 {
    fn deserialize_null_as_nan<'de, D: Deserializer<'de>>(
        deserializer: D,
    ) -> Result<Self, D::Error> {
        Ok(Option::<f64>::deserialize(deserializer)?.unwrap_or(f64::NAN))
    }
}

impl<T: NullAsNan, const N: usize> NullAsNan for [T; N]
where
    [Nullable<T>; N]: DeserializeOwned,
{
    fn deserialize_null_as_nan<'de, D: Deserializer<'de>>(
        deserializer: D,
    ) -> Result<Self, D::Error> {
        let values = <[Nullable<T>; N]>::deserialize(deserializer)?;
        Ok(values.map(|v| v.0))
    }
}

impl<T: NullAsNan> NullAsNan for Vec<T> {
    fn deserialize_null_as_nan<'de, D: Deserializer<'de>>(
        deserializer: D,
    ) -> Result<Self, D::Error> {
        let values = Vec::<Nullable<T>>::deserialize(deserializer)?;
        Ok(values.into_iter().map(|v| v.0).collect())
    }
}

impl<K: Ord + DeserializeOwned, T: NullAsNan> NullAsNan for BTreeMap<K, T> {
    fn deserialize_null_as_nan<'de, D: Deserializer<'de>>(
        deserializer: D,
    ) -> Result<Self, D::Error> {
        let values = BTreeMap::<K, Nullable<T>>::deserialize(deserializer)?;
        Ok(values.into_iter().map(|(k, v)| (k, v.0)).collect())
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;
    use serde::{Deserialize, Serialize};
    use std::collections::BTreeMap;

    #[derive(Debug, Serialize, Deserialize)]
    struct Row {
        #[serde(with = "super")]
        x: f64,
        #[serde(with = "super")]
        a: [f64; 3],
        #[serde(with = "super")]
        m: [[f64; 2]; 2],
        #[serde(with = "super")]
        v: Vec<f64>,
        #[serde(with = "super")]
        map: BTreeMap<String, f64>,
    }

    /// Any f64: finite, NaN, infinite, signed zero, subnormal.
    fn any_f64() -> impl Strategy<Value = f64> {
        prop_oneof![
            Just(f64::NAN),
            Just(f64::INFINITY),
            Just(f64::NEG_INFINITY),
            Just(-0.0),
            Just(f64::MIN_POSITIVE / 4.0),
            any::<f64>(),
        ]
    }

    /// What a read back value must be: itself when finite, NaN otherwise
    /// (serde_json writes every non-finite number as `null`).
    fn same(read: f64, written: f64) -> bool {
        if written.is_finite() {
            read.to_bits() == written.to_bits()
        } else {
            read.is_nan()
        }
    }

    #[test]
    fn non_finite_numbers_are_written_as_null_as_before() {
        let row = Row {
            x: f64::NAN,
            a: [1.5, f64::INFINITY, f64::NEG_INFINITY],
            m: [[0.0, f64::NAN], [2.0, 3.0]],
            v: vec![f64::NAN],
            map: [("h".to_string(), f64::NAN)].into(),
        };
        let text = serde_json::to_string(&row).unwrap();
        assert_eq!(
            text,
            r#"{"x":null,"a":[1.5,null,null],"m":[[0.0,null],[2.0,3.0]],"v":[null],"map":{"h":null}}"#
        );
        let back: Row = serde_json::from_str(&text).unwrap();
        assert!(back.x.is_nan() && back.a[1].is_nan() && back.a[2].is_nan());
        assert!(back.m[0][1].is_nan() && back.v[0].is_nan() && back.map["h"].is_nan());
        assert_eq!(serde_json::to_string(&back).unwrap(), text);
    }

    #[test]
    fn a_missing_field_or_a_string_still_fails() {
        let e = serde_json::from_str::<Row>(r#"{"a":[1,2,3],"m":[[0,0],[0,0]],"v":[],"map":{}}"#)
            .unwrap_err();
        assert!(e.to_string().contains("missing field `x`"), "{e}");
        let e = serde_json::from_str::<Row>(
            r#"{"x":"1","a":[1,2,3],"m":[[0,0],[0,0]],"v":[],"map":{}}"#,
        )
        .unwrap_err();
        assert!(e.to_string().contains("invalid type"), "{e}");
        let e =
            serde_json::from_str::<Row>(r#"{"x":1,"a":[1,2],"m":[[0,0],[0,0]],"v":[],"map":{}}"#)
                .unwrap_err();
        assert!(e.to_string().contains("invalid length"), "{e}");
    }

    proptest! {
        #[test]
        fn any_number_round_trips_to_the_same_text(
            x in any_f64(),
            a in proptest::array::uniform3(any_f64()),
            v in proptest::collection::vec(any_f64(), 0..4),
        ) {
            let row = Row { x, a, m: [[x, a[0]], [a[1], a[2]]], v: v.clone(), map: BTreeMap::new() };
            let text = serde_json::to_string_pretty(&row).unwrap();
            let back: Row = serde_json::from_str(&text).unwrap();
            prop_assert!(same(back.x, x));
            for (r, w) in back.a.iter().zip(&a) {
                prop_assert!(same(*r, *w));
            }
            prop_assert_eq!(back.v.len(), v.len());
            for (r, w) in back.v.iter().zip(&v) {
                prop_assert!(same(*r, *w));
            }
            prop_assert_eq!(serde_json::to_string_pretty(&back).unwrap(), text);
        }
    }
}
