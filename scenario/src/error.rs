//! The one error a config can produce: which file, which key, what was expected.

/// A user error in a config: which file, which key, what was expected. Shown as one line:
/// control characters (a newline in a quoted key, a NUL or an escape sequence echoed from the
/// file) are escaped, never printed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{}", self.shown())]
pub struct ConfigError {
    /// The file (or `<--set>` for an override).
    pub file: String,
    /// Dotted key path, empty when the whole file is at fault.
    pub key: String,
    /// What was expected and what was found.
    pub message: String,
}

impl ConfigError {
    /// An error in `file` at `key` (empty: the whole file).
    pub fn new(file: &str, key: impl Into<String>, message: impl Into<String>) -> ConfigError {
        ConfigError {
            file: file.to_string(),
            key: key.into(),
            message: message.into(),
        }
    }

    fn shown(&self) -> String {
        let (file, message) = (escape_controls(&self.file), escape_controls(&self.message));
        if self.key.is_empty() {
            format!("{file}: {message}")
        } else {
            format!("{file}: key `{}`: {message}", escape_controls(&self.key))
        }
    }
}

/// A failed check before it knows its file: `(dotted key, what was expected)`.
pub type KeyError = (String, String);

/// `s` with every control character escaped as Rust does (`\n`, `\u{1b}`).
pub fn escape_controls(s: &str) -> String {
    s.chars()
        .map(|c| {
            if c.is_control() {
                c.escape_default().to_string()
            } else {
                c.to_string()
            }
        })
        .collect()
}

/// `s` on one line, runs of whitespace collapsed (TOML errors span several lines).
pub fn one_line(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}
