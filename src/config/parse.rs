//! Scenario text → `toml::Table` → `--set` overrides → typed [`Scenario`], with schema
//! errors that name the full dotted key.

use super::{GivenKeys, KeySource, Scenario};
use crate::error::{Error, Result};
use std::path::Path;

/// Read a scenario file and apply `KEY=VALUE` overrides.
pub fn load(path: &Path, overrides: &[String]) -> Result<Scenario> {
    let text = std::fs::read_to_string(path).map_err(|source| Error::ReadInput {
        path: path.to_path_buf(),
        source,
    })?;
    from_str(&text, &path.display().to_string(), overrides)
}

/// Parse scenario text (`origin` names it in messages) and apply `KEY=VALUE` overrides.
pub fn from_str(text: &str, origin: &str, overrides: &[String]) -> Result<Scenario> {
    let mut table: toml::Table = toml::from_str(text).map_err(|e| {
        let at = e.span().map_or(String::new(), |span| {
            let before = &text[..span.start.min(text.len())];
            let line = before.matches('\n').count() + 1;
            let column = before.len() - before.rfind('\n').map_or(0, |k| k + 1) + 1;
            format!(" at line {line}, column {column}")
        });
        Error::Parse {
            origin: format!("{origin}{at}"),
            message: one_line(e.message()),
        }
    })?;
    let mut given_keys = GivenKeys::default();
    given_keys.add_table(&table, KeySource::File);
    for assignment in overrides {
        apply_override(&mut table, assignment)?;
        let mut single = toml::Table::new();
        apply_override(&mut single, assignment)?;
        given_keys.add_table(&single, KeySource::Set);
    }
    let mut scenario: Scenario = serde_path_to_error::deserialize(toml::Value::Table(table))
        .map_err(|e| schema_error(origin, overrides, e))?;
    scenario.given_keys = given_keys;
    Ok(scenario)
}

fn one_line(message: &str) -> String {
    message.split_whitespace().collect::<Vec<_>>().join(" ")
}

fn schema_error(
    origin: &str,
    overrides: &[String],
    e: serde_path_to_error::Error<toml::de::Error>,
) -> Error {
    let path = e.path().to_string();
    let message = one_line(e.inner().message());
    if let Some(rest) = message.strip_prefix("unknown field `") {
        let (field, hint) = rest.split_once('`').unwrap_or((rest, ""));
        let key = if path == "." || path.is_empty() {
            field.to_string()
        } else {
            // serde_path_to_error reports the path of the enclosing table.
            let parent = path.trim_end_matches(&format!(".{field}"));
            let parent = parent.trim_end_matches(field);
            if parent.is_empty() || parent == "." {
                field.to_string()
            } else {
                format!("{}.{field}", parent.trim_end_matches('.'))
            }
        };
        let expected = hint.trim_start_matches(',').trim();
        let from_set = overrides.iter().any(|o| {
            let set_key = o.split('=').next().unwrap_or("").trim();
            set_key == key || set_key.starts_with(&format!("{key}."))
        });
        let source = if from_set {
            "given with --set".to_string()
        } else {
            format!("in {origin}")
        };
        let hint = if expected.is_empty() {
            format!(" {source}")
        } else {
            format!(" {source} ({expected})")
        };
        return Error::UnknownKey { key, hint };
    }
    if let Some(rest) = message.strip_prefix("missing field `") {
        let field = rest.split('`').next().unwrap_or(rest);
        let key = if path == "." || path.is_empty() {
            field.to_string()
        } else {
            format!("{path}.{field}")
        };
        return Error::Parse {
            origin: origin.to_string(),
            message: format!("missing key `{key}`"),
        };
    }
    Error::Parse {
        origin: origin.to_string(),
        message: format!("`{path}`: {message}"),
    }
}

/// Apply one `KEY=VALUE` override; `VALUE` is read as a TOML value (number, boolean,
/// quoted string, array) and, failing that, as a bare string (`method.basis=bspline`).
pub fn apply_override(table: &mut toml::Table, assignment: &str) -> Result<()> {
    let (key, raw) = assignment
        .split_once('=')
        .ok_or_else(|| Error::invalid("--set", assignment, "expected KEY=VALUE"))?;
    let key = key.trim();
    let raw = raw.trim();
    if key.is_empty() || key.split('.').any(str::is_empty) {
        return Err(Error::invalid("--set", assignment, "empty key"));
    }
    let value = match toml::from_str::<toml::Table>(&format!("value = {raw}")) {
        Ok(mut parsed) => parsed
            .remove("value")
            .unwrap_or_else(|| toml::Value::String(raw.to_string())),
        Err(_) => toml::Value::String(raw.to_string()),
    };
    let mut parts: Vec<&str> = key.split('.').collect();
    let last = parts.pop().unwrap_or(key);
    let mut current = table;
    let mut walked = String::new();
    for part in parts {
        if !walked.is_empty() {
            walked.push('.');
        }
        walked.push_str(part);
        let entry = current
            .entry(part.to_string())
            .or_insert_with(|| toml::Value::Table(toml::Table::new()));
        current = entry
            .as_table_mut()
            .ok_or_else(|| Error::invalid(key, raw, format!("`{walked}` is not a table")))?;
    }
    current.insert(last.to_string(), value);
    Ok(())
}

/// A float as a user would write it: plain for moderate magnitudes, scientific otherwise.
///
/// ```
/// use tlsmpm::config::display_float;
/// assert_eq!(display_float(-1.0), "-1");
/// assert_eq!(display_float(1e-300), "1e-300");
/// assert_eq!(display_float(f64::NAN), "NaN");
/// ```
pub fn display_float(value: f64) -> String {
    let magnitude = value.abs();
    if value == 0.0 || !value.is_finite() || (1e-3..1e6).contains(&magnitude) {
        format!("{value}")
    } else {
        format!("{value:e}")
    }
}

/// `Err` naming `key` unless `value` is finite and strictly positive.
pub fn require_positive(key: &str, value: f64) -> Result<()> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(Error::invalid(
            key,
            value,
            "must be a positive finite number",
        ))
    }
}
