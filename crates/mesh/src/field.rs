//! Named per-vertex / per-element data arrays ("fields") that ride along with a
//! mesh to the writers (VTK point data and cell data).

use crate::MeshError;

/// The values of a field, in one of the element types the file formats store.
/// Values are tuple-major: tuple `i`, component `c` is at `i * components + c`.
#[derive(Debug, Clone, PartialEq)]
pub enum FieldValues {
    /// 64-bit floats.
    F64(Vec<f64>),
    /// 32-bit floats.
    F32(Vec<f32>),
    /// 64-bit signed integers.
    I64(Vec<i64>),
    /// 32-bit signed integers.
    I32(Vec<i32>),
    /// Unsigned bytes (labels, colours).
    U8(Vec<u8>),
}

impl FieldValues {
    /// Number of scalar values.
    pub fn len(&self) -> usize {
        match self {
            FieldValues::F64(v) => v.len(),
            FieldValues::F32(v) => v.len(),
            FieldValues::I64(v) => v.len(),
            FieldValues::I32(v) => v.len(),
            FieldValues::U8(v) => v.len(),
        }
    }

    /// True when there are no values.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Value `i` converted to f64 (exact for every variant but large i64).
    pub fn get_f64(&self, i: usize) -> Option<f64> {
        match self {
            FieldValues::F64(v) => v.get(i).copied(),
            FieldValues::F32(v) => v.get(i).map(|&x| x as f64),
            FieldValues::I64(v) => v.get(i).map(|&x| x as f64),
            FieldValues::I32(v) => v.get(i).map(|&x| x as f64),
            FieldValues::U8(v) => v.get(i).map(|&x| x as f64),
        }
    }

    /// All values converted to f64.
    pub fn to_f64(&self) -> Vec<f64> {
        (0..self.len()).filter_map(|i| self.get_f64(i)).collect()
    }

    /// A short name of the element type ("f64", "i32", ...).
    pub fn type_name(&self) -> &'static str {
        match self {
            FieldValues::F64(_) => "f64",
            FieldValues::F32(_) => "f32",
            FieldValues::I64(_) => "i64",
            FieldValues::I32(_) => "i32",
            FieldValues::U8(_) => "u8",
        }
    }

    /// The tuples at `rows` (each `components` values wide), in that order.
    fn select(&self, rows: &[usize], components: usize) -> FieldValues {
        fn pick<T: Copy>(v: &[T], rows: &[usize], c: usize) -> Vec<T> {
            let mut out = Vec::with_capacity(rows.len() * c);
            for &r in rows {
                out.extend_from_slice(&v[r * c..(r + 1) * c]);
            }
            out
        }
        match self {
            FieldValues::F64(v) => FieldValues::F64(pick(v, rows, components)),
            FieldValues::F32(v) => FieldValues::F32(pick(v, rows, components)),
            FieldValues::I64(v) => FieldValues::I64(pick(v, rows, components)),
            FieldValues::I32(v) => FieldValues::I32(pick(v, rows, components)),
            FieldValues::U8(v) => FieldValues::U8(pick(v, rows, components)),
        }
    }
}

/// A named array of `tuples()` tuples with `components` values each.
#[derive(Debug, Clone, PartialEq)]
pub struct Field {
    name: String,
    components: usize,
    values: FieldValues,
}

impl Field {
    /// A field; fails if `components == 0` or the value count is not a
    /// multiple of `components`.
    pub fn new(
        name: impl Into<String>,
        components: usize,
        values: FieldValues,
    ) -> Result<Self, MeshError> {
        let name = name.into();
        if components == 0 || !values.len().is_multiple_of(components) {
            return Err(MeshError::FieldComponents {
                name,
                len: values.len(),
                components,
            });
        }
        Ok(Field {
            name,
            components,
            values,
        })
    }

    /// A one-component f64 field.
    pub fn scalars(name: impl Into<String>, values: Vec<f64>) -> Self {
        Field {
            name: name.into(),
            components: 1,
            values: FieldValues::F64(values),
        }
    }

    /// A one-component i32 field (labels).
    pub fn labels(name: impl Into<String>, values: Vec<i32>) -> Self {
        Field {
            name: name.into(),
            components: 1,
            values: FieldValues::I32(values),
        }
    }

    /// A three-component f64 field (vectors).
    pub fn vectors(name: impl Into<String>, values: &[[f64; 3]]) -> Self {
        Field {
            name: name.into(),
            components: 3,
            values: FieldValues::F64(values.iter().flatten().copied().collect()),
        }
    }

    /// The field's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Values per tuple.
    pub fn components(&self) -> usize {
        self.components
    }

    /// Number of tuples (`values.len() / components`).
    pub fn tuples(&self) -> usize {
        self.values.len() / self.components
    }

    /// The raw values.
    pub fn values(&self) -> &FieldValues {
        &self.values
    }

    /// Component `c` of tuple `i` as f64.
    pub fn get(&self, i: usize, c: usize) -> Option<f64> {
        if c >= self.components {
            return None;
        }
        self.values.get_f64(i * self.components + c)
    }

    /// The field restricted to (or repeated along) `rows`.
    pub fn select(&self, rows: &[usize]) -> Field {
        Field {
            name: self.name.clone(),
            components: self.components,
            values: self.values.select(rows, self.components),
        }
    }
}

/// An ordered set of fields with unique names (point data or cell data).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Fields {
    fields: Vec<Field>,
}

impl Fields {
    /// No fields.
    pub fn new() -> Self {
        Fields::default()
    }

    /// Adds a field, replacing one of the same name (keeping its position).
    pub fn insert(&mut self, field: Field) {
        if let Some(f) = self.fields.iter_mut().find(|f| f.name == field.name) {
            *f = field;
        } else {
            self.fields.push(field);
        }
    }

    /// The field called `name`.
    pub fn get(&self, name: &str) -> Option<&Field> {
        self.fields.iter().find(|f| f.name == name)
    }

    /// Removes and returns the field called `name`.
    pub fn remove(&mut self, name: &str) -> Option<Field> {
        let i = self.fields.iter().position(|f| f.name == name)?;
        Some(self.fields.remove(i))
    }

    /// The fields in insertion order.
    pub fn iter(&self) -> std::slice::Iter<'_, Field> {
        self.fields.iter()
    }

    /// Number of fields.
    pub fn len(&self) -> usize {
        self.fields.len()
    }

    /// True when there are no fields.
    pub fn is_empty(&self) -> bool {
        self.fields.is_empty()
    }

    /// Checks that every field has exactly `n` tuples.
    pub fn check_tuples(&self, n: usize) -> Result<(), MeshError> {
        for f in &self.fields {
            if f.tuples() != n {
                return Err(MeshError::FieldLength {
                    name: f.name.clone(),
                    expected: n,
                    found: f.tuples(),
                });
            }
        }
        Ok(())
    }

    /// Every field restricted to (or repeated along) `rows`.
    pub fn select(&self, rows: &[usize]) -> Fields {
        Fields {
            fields: self.fields.iter().map(|f| f.select(rows)).collect(),
        }
    }
}

impl<'a> IntoIterator for &'a Fields {
    type Item = &'a Field;
    type IntoIter = std::slice::Iter<'a, Field>;
    fn into_iter(self) -> Self::IntoIter {
        self.fields.iter()
    }
}

impl FromIterator<Field> for Fields {
    fn from_iter<I: IntoIterator<Item = Field>>(iter: I) -> Self {
        let mut fs = Fields::new();
        for f in iter {
            fs.insert(f);
        }
        fs
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn field_rejects_bad_component_count() {
        assert!(Field::new("a", 3, FieldValues::F64(vec![1.0; 4])).is_err());
        assert!(Field::new("a", 0, FieldValues::F64(vec![])).is_err());
        let f = Field::new("a", 2, FieldValues::I32(vec![1, 2, 3, 4])).unwrap();
        assert_eq!(f.tuples(), 2);
        assert_eq!(f.get(1, 1), Some(4.0));
        assert_eq!(f.get(1, 2), None);
    }

    #[test]
    fn fields_insert_replaces_and_select_repeats_rows() {
        let mut fs = Fields::new();
        fs.insert(Field::scalars("a", vec![1.0, 2.0]));
        fs.insert(Field::labels("b", vec![5, 6]));
        fs.insert(Field::scalars("a", vec![3.0, 4.0]));
        assert_eq!(fs.len(), 2);
        assert_eq!(fs.iter().next().unwrap().get(0, 0), Some(3.0));
        assert!(fs.check_tuples(2).is_ok());
        assert!(fs.check_tuples(3).is_err());
        let s = fs.select(&[1, 1, 0]);
        assert_eq!(
            s.get("b").unwrap().values(),
            &FieldValues::I32(vec![6, 6, 5])
        );
    }
}
