//! The tuned keys: `--param key=lo:hi` parsed, checked against the config before anything
//! runs, and a swarm position turned into `--set` overrides.

use std::path::Path;

use serde::{Deserialize, Serialize};
use swarmrt_scenario::Config;

use crate::config::load_config;

/// One tuned config key.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Param {
    /// The dotted config key.
    pub key: String,
    /// Lower bound.
    pub lo: f64,
    /// Upper bound.
    pub hi: f64,
    /// The key holds an integer: positions are rounded (within the bounds).
    pub integer: bool,
}

impl Param {
    /// Parses `key=lo:hi` (not yet checked against a config: `integer` is false).
    pub fn parse(spec: &str) -> Result<Param, String> {
        let (key, range) = spec
            .split_once('=')
            .ok_or_else(|| format!("--param {spec}: expected KEY=LO:HI, e.g. radio.loss=0:0.5"))?;
        let key = key.trim();
        let (lo, hi) = range
            .split_once(':')
            .ok_or_else(|| format!("--param {spec}: expected KEY=LO:HI, e.g. {key}=0:1"))?;
        let num = |s: &str| s.trim().parse::<f64>().ok().filter(|v| v.is_finite());
        let (Some(lo), Some(hi)) = (num(lo), num(hi)) else {
            return Err(format!(
                "--param {key}: bounds must be finite numbers, got {range}"
            ));
        };
        if lo >= hi {
            return Err(format!("--param {key}: expected lo < hi, got {range}"));
        }
        if key.is_empty() {
            return Err(format!("--param {spec}: no key"));
        }
        Ok(Param {
            key: key.to_string(),
            lo,
            hi,
            integer: false,
        })
    }

    /// The value a position `x` sets, as written to `--set` and `tune.csv`: integers rounded
    /// into the bounds, floats as Rust writes them back exactly (`0.5`, `2.0`, `1e-7`).
    pub fn value(&self, x: f64) -> String {
        if self.integer {
            let v = x.round().clamp(self.lo.ceil(), self.hi.floor());
            format!("{}", v as i64)
        } else {
            format!("{x:?}")
        }
    }

    /// `key=value` for a position `x`.
    pub fn set(&self, x: f64) -> String {
        format!("{}={}", self.key, self.value(x))
    }

    /// The value `x` sets as a share of the bounds, 0 at `lo` and 1 at `hi`.
    pub fn normalise(&self, x: f64) -> f64 {
        let v = if self.integer {
            x.round().clamp(self.lo.ceil(), self.hi.floor())
        } else {
            x
        };
        (v - self.lo) / (self.hi - self.lo)
    }
}

/// What the resolved config holds at a dotted key.
fn value_at<'a>(table: &'a toml::Table, key: &str) -> Option<&'a toml::Value> {
    let mut parts = key.split('.');
    let mut cur = table.get(parts.next()?)?;
    for p in parts {
        cur = cur.as_table()?.get(p)?;
    }
    Some(cur)
}

/// Checks every `--param` against the config as `--set` gives it (`set`): a known key holding
/// a number, whose midpoint and both bounds each load as a valid config. Marks integer keys.
/// Errors name the flag and the key (exit 2).
pub fn resolve(
    specs: &[String],
    config: &Path,
    set: &[String],
    base: &Config,
) -> Result<Vec<Param>, String> {
    let resolved: toml::Table =
        toml::from_str(&base.to_toml()).map_err(|e| format!("the resolved config: {e}"))?;
    let mut params: Vec<Param> = Vec::new();
    for spec in specs {
        let mut p = Param::parse(spec)?;
        if params.iter().any(|q| q.key == p.key) {
            return Err(format!("--param {}: given twice", p.key));
        }
        if p.key == "scenario.seed" {
            return Err(
                "--param scenario.seed: the run seed is not a parameter; each evaluation gets \
                 its own (--seed, --seeds)"
                    .into(),
            );
        }
        for s in set {
            if s.split_once('=').map_or(s.as_str(), |(k, _)| k).trim() == p.key {
                return Err(format!(
                    "key `{}` is given both to --set and to --param",
                    p.key
                ));
            }
        }
        match value_at(&resolved, &p.key) {
            Some(toml::Value::Integer(_)) => p.integer = true,
            Some(toml::Value::Float(_)) | None => {}
            Some(other) => {
                return Err(format!(
                    "--param {}: not a number in this config (it is {} `{}`)",
                    p.key,
                    other.type_str(),
                    other
                ));
            }
        }
        if p.integer && p.lo.ceil() > p.hi.floor() {
            return Err(format!(
                "--param {}: an integer key, and no integer lies in {}:{}",
                p.key, p.lo, p.hi
            ));
        }
        for (what, x) in [
            ("midpoint", (p.lo + p.hi) / 2.0),
            ("lower bound", p.lo),
            ("upper bound", p.hi),
        ] {
            let mut with = set.to_vec();
            with.push(p.set(x));
            load_config(config, &with)
                .map_err(|e| format!("--param {} ({what} {}): {e}", p.key, p.value(x)))?;
        }
        params.push(p);
    }
    Ok(params)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parse_refuses_bad_bounds() {
        let p = Param::parse("radio.loss=0:0.5").unwrap();
        assert_eq!((p.key.as_str(), p.lo, p.hi), ("radio.loss", 0.0, 0.5));
        for bad in [
            "radio.loss=0.5:0.5",
            "radio.loss=1:0",
            "radio.loss=0:inf",
            "radio.loss=nan:1",
            "radio.loss=0",
            "radio.loss",
            "=0:1",
        ] {
            assert!(Param::parse(bad).is_err(), "{bad}");
        }
        assert!(
            Param::parse("radio.loss=1:0")
                .unwrap_err()
                .contains("radio.loss")
        );
    }

    #[test]
    fn values_round_trip_and_integers_round_within_bounds() {
        let f = Param::parse("a.b=0:3").unwrap();
        assert_eq!(f.value(2.0), "2.0");
        assert_eq!(f.value(0.1 + 0.2), "0.30000000000000004");
        assert_eq!(f.value(1e-7), "1e-7");
        let i = Param {
            integer: true,
            ..Param::parse("a.b=0.6:3.4").unwrap()
        };
        assert_eq!(i.value(0.6), "1");
        assert_eq!(i.value(3.4), "3");
        assert_eq!(i.value(2.5), "3");
        assert_eq!(i.set(1.2), "a.b=1");
    }
}
