//! The one error a config can produce: which file, which key, what was expected.

/// A user error in a config: which file, which key, what was expected. Shown as one line:
/// control characters (a newline in a quoted key, a NUL or an escape sequence echoed from the
/// file) are escaped, never printed, and a part longer than a line should be (a megabyte key
/// or value echoed back) is cut in the middle, so the line stays short and keeps its end.
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
        let file = shorten(&escape_controls(&self.file), MAX_SHOWN_FILE);
        let message = shorten(&escape_controls(&self.message), MAX_SHOWN_MESSAGE);
        if self.key.is_empty() {
            format!("{file}: {message}")
        } else {
            let key = shorten(&escape_controls(&self.key), MAX_SHOWN_KEY);
            format!("{file}: key `{key}`: {message}")
        }
    }
}

/// Most characters of the file shown in an error (a path up to `PATH_MAX` is cut).
const MAX_SHOWN_FILE: usize = 512;
/// Most characters of the key shown in an error.
const MAX_SHOWN_KEY: usize = 256;
/// Most characters of the message shown in an error (the longest written, a list of
/// accepted names, is a few hundred).
const MAX_SHOWN_MESSAGE: usize = 1024;

/// `s` with its middle replaced by `...(N characters)...` when it has more than `max`
/// characters: the start says what it is, the end says what was expected.
pub fn shorten(s: &str, max: usize) -> String {
    let n = s.chars().count();
    if n <= max {
        return s.to_string();
    }
    let keep = max / 2;
    let head: String = s.chars().take(keep).collect();
    let tail: String = s.chars().skip(n - keep).collect();
    format!("{head}...({} characters)...{tail}", n - 2 * keep)
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_megabyte_key_and_value_make_one_short_line_that_keeps_its_end() {
        let long = "x".repeat(1 << 20);
        let e = ConfigError::new(&long, &long, format!("found {long}, expected u32"));
        let shown = e.to_string();
        assert!(shown.len() < 2000, "{} bytes", shown.len());
        assert!(shown.ends_with("expected u32"), "{shown}");
        assert!(shown.contains(&format!("...({} characters)...", (1 << 20) - 256)));
        let short = ConfigError::new("c.toml", "radio.loss", "expected a number in [0, 1]");
        assert_eq!(
            short.to_string(),
            "c.toml: key `radio.loss`: expected a number in [0, 1]"
        );
    }
}
