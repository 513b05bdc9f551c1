//! Helpers shared by the CLI tests.

use serde_json::Value;
use std::collections::BTreeSet;

/// Every key path of a JSON value into `out` (`edges[].slope` for the members of an array's
/// objects): the shape of an output, for contract tests.
pub fn key_paths(v: &Value, prefix: &str, out: &mut BTreeSet<String>) {
    match v {
        Value::Object(m) => {
            for (k, x) in m {
                let p = if prefix.is_empty() {
                    k.clone()
                } else {
                    format!("{prefix}.{k}")
                };
                out.insert(p.clone());
                key_paths(x, &p, out);
            }
        }
        Value::Array(a) => {
            for x in a {
                key_paths(x, &format!("{prefix}[]"), out);
            }
        }
        _ => {}
    }
}
