//! `--set key=value`: overrides applied to the parsed TOML table before it is deserialized,
//! so an overridden key is checked exactly like one written in the file.

use crate::error::KeyError;

/// Applies one `key=value` override; the value is read as TOML (`0.2`, `true`, `"x"`, `[1, 2]`)
/// and, failing that, as a bare string.
pub fn apply_override(table: &mut toml::Table, ov: &str) -> Result<(), KeyError> {
    let (key, raw) = ov.split_once('=').ok_or_else(|| {
        (
            ov.to_string(),
            "expected key=value, e.g. radio.loss=0.2".to_string(),
        )
    })?;
    let key = key.trim();
    let parts: Vec<&str> = key.split('.').collect();
    if key.is_empty() || parts.iter().any(|p| p.is_empty()) {
        return Err((
            key.to_string(),
            "expected a dotted key like radio.loss".to_string(),
        ));
    }
    let raw = raw.trim();
    let value = match toml::from_str::<toml::Table>(&format!("v = {raw}")) {
        Ok(mut t) => t.remove("v").expect("parsed key v"),
        // A number TOML cannot hold (`--seed 18446744073709551615`, `1e400`, `.5`) is not
        // meant as a string: say so instead of "invalid type: string".
        Err(_) if raw.parse::<f64>().is_ok() && raw.contains(|c: char| c.is_ascii_digit()) => {
            return Err((
                key.to_string(),
                format!(
                    "expected a TOML number (an integer in [{}, {}] or a float such as 0.5 or 1e3), got {raw}",
                    i64::MIN,
                    i64::MAX
                ),
            ));
        }
        Err(_) => toml::Value::String(raw.to_string()),
    };
    let mut cur = table;
    for part in &parts[..parts.len() - 1] {
        let entry = cur
            .entry(part.to_string())
            .or_insert_with(|| toml::Value::Table(toml::Table::new()));
        cur = entry.as_table_mut().ok_or_else(|| {
            (
                key.to_string(),
                format!("`{part}` is not a table, so it has no sub-keys"),
            )
        })?;
    }
    cur.insert(parts[parts.len() - 1].to_string(), value);
    Ok(())
}
