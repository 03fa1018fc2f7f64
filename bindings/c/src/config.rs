//! The run's resolved config (`SWARMRT_CONFIG`), read by dotted keys, so a C robot needs no
//! TOML parser: `map.goal.x`, `map.bounds.2` or `map.bounds[2]`,
//! `robots.start.groups[1].goal[0]`.
//!
//! The resolved config holds every key the run uses with its value, except optional ones
//! that are unset (e.g. `robots.lidar.angles_deg`, `robots.start.groups`): those are absent,
//! and a robot applies the same default the Rust robot does. Numbers are read with the `toml`
//! crate, as the Rust robot reads them, so both see the same bits.

use std::path::Path;

use crate::error::Error;

/// A parsed config.
#[derive(Debug, Clone, PartialEq)]
pub struct Config {
    root: toml::Table,
}

/// Why a key could not be read as asked.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum KeyError {
    /// The key is not of the form `a.b.0.c` / `a.b[0].c`.
    Malformed,
    /// The value exists but has another type.
    WrongType,
}

/// One step of a key path.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Step<'a> {
    Name(&'a str),
    Index(usize),
}

/// Splits `a.b[0].c` / `a.b.0.c` into steps; `None` when malformed.
fn steps(key: &str) -> Option<Vec<Step<'_>>> {
    let mut out = Vec::new();
    for part in key.split('.') {
        let (name, mut rest) = match part.find('[') {
            Some(i) => (&part[..i], &part[i..]),
            None => (part, ""),
        };
        match name {
            "" if out.is_empty() || rest.is_empty() => return None,
            "" => {}
            n if n.bytes().all(|b| b.is_ascii_digit()) => out.push(Step::Index(n.parse().ok()?)),
            n => out.push(Step::Name(n)),
        }
        while !rest.is_empty() {
            let close = rest.find(']')?;
            out.push(Step::Index(rest[1..close].parse().ok()?));
            rest = &rest[close + 1..];
            if !rest.is_empty() && !rest.starts_with('[') {
                return None;
            }
        }
    }
    (!out.is_empty()).then_some(out)
}

impl Config {
    /// Parses TOML text.
    pub fn parse(text: &str) -> Result<Config, Error> {
        let root = text.parse::<toml::Table>().map_err(|e| Error::Config {
            path: "<text>".into(),
            message: e.message().to_string(),
        })?;
        Ok(Config { root })
    }

    /// Reads and parses the file at `path`.
    pub fn load(path: &Path) -> Result<Config, Error> {
        let err = |message: String| Error::Config {
            path: path.display().to_string(),
            message,
        };
        let text = std::fs::read_to_string(path).map_err(|e| err(e.to_string()))?;
        let root = text
            .parse::<toml::Table>()
            .map_err(|e| err(e.message().trim().to_string()))?;
        Ok(Config { root })
    }

    /// The value at `key`: `Ok(None)` when absent.
    pub fn get(&self, key: &str) -> Result<Option<&toml::Value>, KeyError> {
        let steps = steps(key).ok_or(KeyError::Malformed)?;
        let mut at: Option<&toml::Value> = None;
        for step in steps {
            let next = match (at, step) {
                (None, Step::Name(n)) => self.root.get(n),
                (None, Step::Index(_)) => return Err(KeyError::Malformed),
                (Some(toml::Value::Table(t)), Step::Name(n)) => t.get(n),
                (Some(toml::Value::Array(a)), Step::Index(i)) => a.get(i),
                // `groups.0` on a table, `bounds.x` on an array, a step into a number.
                (Some(_), _) => return Err(KeyError::WrongType),
            };
            match next {
                Some(v) => at = Some(v),
                None => return Ok(None),
            }
        }
        Ok(at)
    }

    /// A number (integers are converted).
    pub fn f64(&self, key: &str) -> Result<Option<f64>, KeyError> {
        match self.get(key)? {
            None => Ok(None),
            Some(toml::Value::Float(f)) => Ok(Some(*f)),
            Some(toml::Value::Integer(i)) => Ok(Some(*i as f64)),
            Some(_) => Err(KeyError::WrongType),
        }
    }

    /// An integer (a float is a wrong type, even a whole one).
    pub fn i64(&self, key: &str) -> Result<Option<i64>, KeyError> {
        match self.get(key)? {
            None => Ok(None),
            Some(toml::Value::Integer(i)) => Ok(Some(*i)),
            Some(_) => Err(KeyError::WrongType),
        }
    }

    /// The number of elements of an array or of keys of a table.
    pub fn len(&self, key: &str) -> Result<Option<usize>, KeyError> {
        match self.get(key)? {
            None => Ok(None),
            Some(toml::Value::Array(a)) => Ok(Some(a.len())),
            Some(toml::Value::Table(t)) => Ok(Some(t.len())),
            Some(_) => Err(KeyError::WrongType),
        }
    }

    /// A string.
    pub fn str(&self, key: &str) -> Result<Option<&str>, KeyError> {
        match self.get(key)? {
            None => Ok(None),
            Some(toml::Value::String(s)) => Ok(Some(s)),
            Some(_) => Err(KeyError::WrongType),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TEXT: &str = r#"
[map]
bounds = [0.0, 0.0, 12.0, 12.5]
[map.goal]
x = 10.0
y = 10
[robots]
count = 9
[robots.start]
groups = [{ x = 1.0, y = 2.0, goal = [3.0, 4.0] }, { x = 5.0, y = 6.0 }]
[behaviour]
kind = "goto"
"#;

    #[test]
    fn dotted_and_indexed_keys_read_the_same_values() {
        let c = Config::parse(TEXT).unwrap();
        assert_eq!(c.f64("map.goal.x"), Ok(Some(10.0)));
        assert_eq!(c.f64("map.goal.y"), Ok(Some(10.0)), "integers convert");
        assert_eq!(c.f64("map.bounds.3"), Ok(Some(12.5)));
        assert_eq!(c.f64("map.bounds[3]"), Ok(Some(12.5)));
        assert_eq!(c.f64("robots.start.groups[0].goal[1]"), Ok(Some(4.0)));
        assert_eq!(c.f64("robots.start.groups.0.goal.1"), Ok(Some(4.0)));
        assert_eq!(c.i64("robots.count"), Ok(Some(9)));
        assert_eq!(c.len("robots.start.groups"), Ok(Some(2)));
        assert_eq!(c.len("map.bounds"), Ok(Some(4)));
        assert_eq!(c.str("behaviour.kind"), Ok(Some("goto")));
    }

    #[test]
    fn absent_keys_wrong_types_and_malformed_keys_are_told_apart() {
        let c = Config::parse(TEXT).unwrap();
        assert_eq!(c.f64("robots.start.groups[1].goal[0]"), Ok(None));
        assert_eq!(c.f64("robots.lidar.angles_deg.0"), Ok(None));
        assert_eq!(c.len("robots.lidar.angles_deg"), Ok(None));
        assert_eq!(c.f64("map.bounds.9"), Ok(None));
        assert_eq!(c.i64("map.goal.x"), Err(KeyError::WrongType));
        assert_eq!(c.f64("behaviour.kind"), Err(KeyError::WrongType));
        assert_eq!(c.f64("map.bounds.x"), Err(KeyError::WrongType));
        assert_eq!(c.f64("map.goal.x.y"), Err(KeyError::WrongType));
        for bad in [
            "",
            ".",
            "map..goal",
            "map.bounds[",
            "map.bounds[x]",
            "[0]",
            "a[0]b",
        ] {
            assert_eq!(c.get(bad), Err(KeyError::Malformed), "{bad:?}");
        }
    }

    #[test]
    fn a_bad_file_names_itself() {
        let e = Config::load(Path::new("/nonexistent/config.toml")).unwrap_err();
        assert!(e.to_string().contains("/nonexistent/config.toml"), "{e}");
        let e = Config::parse("x = [").unwrap_err();
        assert!(e.to_string().starts_with("config <text>:"), "{e}");
    }
}
