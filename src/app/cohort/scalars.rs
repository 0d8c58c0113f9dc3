//! A report's scalars as the cohort table's cells: keys joined by dots.

use std::collections::BTreeMap;

/// The scalars of a JSON value, keys joined by dots (numbers as written,
/// booleans as 0 and 1; at the top level the `provenance` section is left
/// out).
pub fn flatten(prefix: &str, v: &serde_json::Value, out: &mut BTreeMap<String, String>) {
    match v {
        serde_json::Value::Number(n) => {
            out.insert(prefix.to_string(), n.to_string());
        }
        serde_json::Value::Bool(b) => {
            out.insert(prefix.to_string(), u8::from(*b).to_string());
        }
        serde_json::Value::Object(map) => {
            for (k, v) in map {
                if prefix.is_empty() && k == "provenance" {
                    continue;
                }
                let key = if prefix.is_empty() {
                    k.clone()
                } else {
                    format!("{prefix}.{k}")
                };
                flatten(&key, v, out);
            }
        }
        _ => {}
    }
}
