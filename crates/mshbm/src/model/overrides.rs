//! `--set key=value` overrides of a model file, applied to the parsed TOML before the model
//! is read (so that the model's own checks see the overridden values).

use crate::error::{Error, Result};

/// Apply one `key=value` override to a parsed model file. The key is a dotted path
/// (`contact.gap`, `damping.alpha`, `contacts.0.gap` for the first element of an array);
/// the value is parsed as a TOML value (number, boolean, array, quoted string) and taken
/// as a bare string otherwise. Missing tables on the path are created; a key that the
/// model does not know is then reported when the model is read.
pub fn apply_override(root: &mut toml::Value, assignment: &str) -> Result<()> {
    let err = |message: &str| Error::Override {
        assignment: assignment.to_string(),
        message: message.to_string(),
    };
    let (key, raw) = assignment
        .split_once('=')
        .ok_or_else(|| err("expected key=value"))?;
    let key = key.trim();
    let raw = raw.trim();
    if key.is_empty() || key.split('.').any(str::is_empty) {
        return Err(err("the key must be a dotted path such as `contact.gap`"));
    }
    let value = toml::from_str::<toml::Table>(&format!("v = {raw}"))
        .ok()
        .and_then(|mut t| t.remove("v"))
        .unwrap_or_else(|| toml::Value::String(raw.to_string()));
    let parts: Vec<&str> = key.split('.').collect();
    let mut node = root;
    for (k, part) in parts.iter().enumerate() {
        let last = k + 1 == parts.len();
        node = match node {
            toml::Value::Table(t) => {
                if last {
                    t.insert(part.to_string(), value);
                    return Ok(());
                }
                t.entry(part.to_string())
                    .or_insert_with(|| toml::Value::Table(toml::Table::new()))
            }
            toml::Value::Array(a) => {
                let i: usize = part
                    .parse()
                    .map_err(|_| err(&format!("`{part}` is not an array index")))?;
                let len = a.len();
                let slot = a.get_mut(i).ok_or_else(|| {
                    err(&format!(
                        "index {i} out of range (array has {len} elements)"
                    ))
                })?;
                if last {
                    *slot = value;
                    return Ok(());
                }
                slot
            }
            _ => return Err(err(&format!("`{}` is not a table", parts[..k].join(".")))),
        };
    }
    Ok(())
}
