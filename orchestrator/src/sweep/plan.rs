//! What a sweep runs: the varied keys and their values, the seeds, and the cross product in a
//! fixed order, with a directory name per run that resume can find again.

use std::fmt::Write as _;

/// One `--vary key=v1,v2,...`: a config key and the values it takes, as written.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Vary {
    /// Dotted config key, e.g. `radio.loss`.
    pub key: String,
    /// Values in the order given; each goes to the config through `--set key=value`.
    pub values: Vec<String>,
}

/// Parses one `--vary` argument. Values are kept as written (`0.1` and `0.10` are different
/// values), since they are both the `--set` text and the row key resume matches on.
pub fn parse_vary(spec: &str) -> Result<Vary, String> {
    let (key, list) = spec.split_once('=').ok_or_else(|| {
        format!("--vary `{spec}`: expected key=v1,v2,..., e.g. --vary radio.loss=0,0.1,0.2")
    })?;
    let key = key.trim();
    if key.is_empty() || key.split('.').any(|p| p.trim().is_empty()) {
        return Err(format!(
            "--vary `{spec}`: expected a dotted config key before `=`, e.g. radio.loss"
        ));
    }
    if key == "scenario.seed" {
        return Err(
            "--vary `scenario.seed`: seeds are swept with --seeds N and --start-seed S".into(),
        );
    }
    let mut values: Vec<String> = Vec::new();
    for v in list.split(',') {
        let v = v.trim();
        if v.is_empty() {
            return Err(format!(
                "--vary `{key}`: empty value in `{list}` (values are separated by commas)"
            ));
        }
        if values.iter().any(|w| w == v) {
            return Err(format!("--vary `{key}`: value `{v}` is given twice"));
        }
        values.push(v.to_string());
    }
    Ok(Vary {
        key: key.to_string(),
        values,
    })
}

/// One run of a sweep: an index into [`Plan::combos`] and a seed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub struct RunSpec {
    /// Which combination of varied values.
    pub combo: usize,
    /// The run's seed.
    pub seed: u64,
}

/// The cross product of the varied values and the seeds.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Plan {
    /// Varied keys, in the order of the `--vary` arguments (the first is the plots' x axis).
    pub keys: Vec<String>,
    /// Every combination of values, one value per key, the last key changing fastest.
    pub combos: Vec<Vec<String>>,
    /// The seeds, `start..start + n`.
    pub seeds: Vec<u64>,
}

impl Plan {
    /// Builds the plan; refuses a key varied twice or a seed range that overflows.
    pub fn new(varies: &[Vary], start_seed: u64, seeds: u64) -> Result<Plan, String> {
        for (i, v) in varies.iter().enumerate() {
            if varies[..i].iter().any(|w| w.key == v.key) {
                return Err(format!("--vary `{}` is given twice", v.key));
            }
        }
        if seeds == 0 {
            return Err("--seeds: expected at least 1".into());
        }
        let last = start_seed.checked_add(seeds - 1).ok_or_else(|| {
            format!("--seeds {seeds} from seed {start_seed} runs past the largest seed")
        })?;
        let mut combos: Vec<Vec<String>> = vec![Vec::new()];
        for v in varies {
            combos = combos
                .iter()
                .flat_map(|c| {
                    v.values.iter().map(move |x| {
                        let mut c = c.clone();
                        c.push(x.clone());
                        c
                    })
                })
                .collect();
        }
        Ok(Plan {
            keys: varies.iter().map(|v| v.key.clone()).collect(),
            combos,
            seeds: (start_seed..=last).collect(),
        })
    }

    /// Every run, seed-major: each combination gets the first seed before any gets the
    /// second, so an interrupted sweep still covers the whole grid.
    pub fn runs(&self) -> Vec<RunSpec> {
        self.seeds
            .iter()
            .flat_map(|&seed| (0..self.combos.len()).map(move |combo| RunSpec { combo, seed }))
            .collect()
    }

    /// The `--set key=value` overrides of a combination.
    pub fn overrides(&self, combo: usize) -> Vec<String> {
        self.keys
            .iter()
            .zip(&self.combos[combo])
            .map(|(k, v)| format!("{k}={v}"))
            .collect()
    }

    /// `key=value, key=value` for messages.
    pub fn describe(&self, combo: usize) -> String {
        self.overrides(combo).join(", ")
    }

    /// The run's directory name under `<out>/runs/`, e.g. `radio.loss=0.1_radio.delay_ticks=2_s3`.
    pub fn dir_name(&self, run: RunSpec) -> String {
        dir_name(&self.keys, &self.combos[run.combo], run.seed)
    }
}

/// Directory name of a run. Values are [`encode`]d, so `=` and `/` cannot appear raw in them:
/// for a fixed key list, distinct runs get distinct names (read back from the end: the seed
/// follows the last `_s`, each value runs up to the next `_<key>=`).
pub fn dir_name(keys: &[String], values: &[String], seed: u64) -> String {
    let mut name = String::new();
    for (k, v) in keys.iter().zip(values) {
        let _ = write!(name, "{k}={}_", encode(v));
    }
    let _ = write!(name, "s{seed}");
    name
}

/// Writes every byte outside `[A-Za-z0-9._+-]` as `~XX` (hex): safe in file names, shell
/// words and markdown links alike, and reversible.
pub fn encode(v: &str) -> String {
    let mut out = String::with_capacity(v.len());
    for b in v.bytes() {
        if b.is_ascii_alphanumeric() || matches!(b, b'.' | b'_' | b'+' | b'-') {
            out.push(b as char);
        } else {
            let _ = write!(out, "~{b:02X}");
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn vary(s: &str) -> Vary {
        parse_vary(s).unwrap()
    }

    #[test]
    fn vary_parses_and_trims() {
        assert_eq!(
            vary(" radio.loss = 0, 0.1 ,0.2"),
            Vary {
                key: "radio.loss".into(),
                values: vec!["0".into(), "0.1".into(), "0.2".into()]
            }
        );
        assert_eq!(vary("radio.loss_model=bernoulli").values, ["bernoulli"]);
    }

    #[test]
    fn vary_refuses_bad_specs_naming_them() {
        for (spec, needle) in [
            ("radio.loss", "`radio.loss`"),
            ("=0,1", "dotted config key"),
            ("radio..loss=1", "dotted config key"),
            ("radio.loss=0,,1", "`radio.loss`: empty value"),
            ("radio.loss=", "`radio.loss`: empty value"),
            ("radio.loss=0.1,0.1", "`0.1` is given twice"),
            ("scenario.seed=1,2", "--seeds"),
        ] {
            let e = parse_vary(spec).unwrap_err();
            assert!(e.contains(needle), "{spec}: {e}");
        }
    }

    #[test]
    fn plan_is_the_cross_product_seed_major() {
        let p = Plan::new(&[vary("a=1,2"), vary("b=x,y,z")], 5, 2).unwrap();
        assert_eq!(p.combos.len(), 6);
        assert_eq!(p.combos[0], ["1", "x"]);
        assert_eq!(p.combos[1], ["1", "y"]);
        assert_eq!(p.combos[5], ["2", "z"]);
        assert_eq!(p.seeds, [5, 6]);
        let runs = p.runs();
        assert_eq!(runs.len(), 12);
        assert_eq!(runs[0], RunSpec { combo: 0, seed: 5 });
        assert_eq!(runs[5], RunSpec { combo: 5, seed: 5 });
        assert_eq!(runs[6], RunSpec { combo: 0, seed: 6 });
        assert_eq!(p.overrides(4), ["a=2", "b=y"]);
    }

    #[test]
    fn plan_refuses_duplicate_keys_and_seed_overflow() {
        assert!(
            Plan::new(&[vary("a=1"), vary("a=2")], 0, 1)
                .unwrap_err()
                .contains("`a` is given twice")
        );
        assert!(Plan::new(&[vary("a=1")], u64::MAX, 2).is_err());
        assert_eq!(
            Plan::new(&[vary("a=1")], u64::MAX, 1).unwrap().seeds,
            [u64::MAX]
        );
        assert!(Plan::new(&[vary("a=1")], 0, 0).is_err());
    }

    #[test]
    fn dir_names_are_distinct_and_safe() {
        let keys = vec!["radio.loss".to_string(), "x.y_z".to_string()];
        let n = |a: &str, b: &str, s| dir_name(&keys, &[a.into(), b.into()], s);
        assert_eq!(n("0.1", "2", 3), "radio.loss=0.1_x.y_z=2_s3");
        // Separators inside values are encoded, so these cannot collide.
        assert_ne!(n("1_x.y_z=2", "3", 1), n("1", "2_x.y_z=3", 1));
        assert_ne!(n("a/b", "1", 1), n("a~2Fb", "1", 1));
        assert_ne!(n("x", "y_s2", 3), n("x", "y", 2));
        assert_eq!(n("../..", "a b", 1), "radio.loss=..~2F.._x.y_z=a~20b_s1");
    }
}
