//! What a tune writes and reads back: `tune.csv` rows and the settings a resume must match.
//!
//! `tune.csv`: `eval,iteration,particle,kind,<param keys...>,seed,fitness,status`, one row per
//! evaluation. `eval` is the evaluation's place in the tune's fixed order (iteration, particle,
//! new then re-evaluations), which also names its run directory (`runs/e<eval>`). `fitness` is
//! the metric as the run reported it (empty when it has none); `status` is `ok`, `missing`
//! (the run's metrics.json lacks the metric, or it is not a number) or `failed` (the run failed,
//! or its config did not load). Rows are appended and flushed as runs finish; after each
//! iteration the file is rewritten in `eval` order, so a tune and its resumed twin write the
//! same bytes.

use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::Context;
use serde::{Deserialize, Serialize};
use swarmrt_analysis::sweep_csv::{format_line, parse_line};
use swarmrt_scenario::safe_fs::{Open, OutDir};

use super::pso::Kind;
use super::space::Param;

/// How an evaluation ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Status {
    /// The run finished and reported the metric.
    Ok,
    /// The run finished without the metric (absent, null, not a number): the worst fitness.
    Missing,
    /// The run failed, or its config did not load: the worst fitness; resume runs it again.
    Failed,
}

impl Status {
    fn as_str(self) -> &'static str {
        match self {
            Status::Ok => "ok",
            Status::Missing => "missing",
            Status::Failed => "failed",
        }
    }

    fn parse(s: &str) -> Option<Status> {
        match s {
            "ok" => Some(Status::Ok),
            "missing" => Some(Status::Missing),
            "failed" => Some(Status::Failed),
            _ => None,
        }
    }
}

/// One row of `tune.csv`.
#[derive(Debug, Clone, PartialEq)]
pub struct EvalRow {
    /// Place in the tune's order.
    pub eval: u64,
    /// Iteration (from 0).
    pub iteration: u64,
    /// Particle (from 0).
    pub particle: u64,
    /// New position or personal-best re-evaluation.
    pub kind: Kind,
    /// The parameter values the run used, as `--set` wrote them.
    pub values: Vec<String>,
    /// The run seed.
    pub seed: u64,
    /// The metric (`None` unless `status` is `Ok`).
    pub fitness: Option<f64>,
    /// How it ended.
    pub status: Status,
}

impl EvalRow {
    /// Same evaluation (everything but the outcome).
    pub fn same_eval(&self, other: &EvalRow) -> bool {
        (
            self.eval,
            self.iteration,
            self.particle,
            self.kind,
            &self.values,
            self.seed,
        ) == (
            other.eval,
            other.iteration,
            other.particle,
            other.kind,
            &other.values,
            other.seed,
        )
    }

    fn line(&self) -> String {
        let mut f = vec![
            self.eval.to_string(),
            self.iteration.to_string(),
            self.particle.to_string(),
            self.kind.as_str().to_string(),
        ];
        f.extend(self.values.iter().cloned());
        f.push(self.seed.to_string());
        f.push(self.fitness.map(|v| v.to_string()).unwrap_or_default());
        f.push(self.status.as_str().to_string());
        format_line(&f)
    }

    fn parse(fields: &[String], n: usize) -> Option<EvalRow> {
        if fields.len() != n + 7 {
            return None;
        }
        let kind = match fields[3].as_str() {
            "new" => Kind::New,
            "reeval" => Kind::Reeval,
            _ => return None,
        };
        let status = Status::parse(&fields[n + 6])?;
        let fitness = match (status, fields[n + 5].as_str()) {
            (Status::Ok, s) => Some(s.parse::<f64>().ok()?),
            (_, "") => None,
            _ => return None,
        };
        Some(EvalRow {
            eval: fields[0].parse().ok()?,
            iteration: fields[1].parse().ok()?,
            particle: fields[2].parse().ok()?,
            kind,
            values: fields[4..4 + n].to_vec(),
            seed: fields[n + 4].parse().ok()?,
            fitness,
            status,
        })
    }
}

/// The header for these parameters.
pub fn header(params: &[Param]) -> String {
    let mut h: Vec<&str> = vec!["eval", "iteration", "particle", "kind"];
    h.extend(params.iter().map(|p| p.key.as_str()));
    h.extend(["seed", "fitness", "status"]);
    format_line(&h)
}

/// Reads an existing `tune.csv`: the last whole row for each `eval` (a failed evaluation run
/// again is appended after its first row). A header for other parameters is an error; cut or
/// unreadable lines are skipped (they run again).
pub fn read(path: &Path, params: &[Param]) -> Result<BTreeMap<u64, EvalRow>, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut rows = BTreeMap::new();
    let mut lines = text.split_inclusive('\n');
    let Some(head) = lines.next() else {
        return Ok(rows);
    };
    if head != header(params) {
        return Err(format!(
            "{}: its columns are `{}`, this tune's are `{}`; give another --out",
            path.display(),
            head.trim_end(),
            header(params).trim_end()
        ));
    }
    for line in lines {
        let Some(body) = line.strip_suffix('\n') else {
            continue;
        };
        if let Some(row) = parse_line(body).and_then(|f| EvalRow::parse(&f, params.len())) {
            rows.insert(row.eval, row);
        }
    }
    Ok(rows)
}

/// `tune.csv` open for appending, one flushed line per row, in a directory held open.
pub struct TuneCsv {
    dir: OutDir,
    name: String,
    path: PathBuf,
    file: std::fs::File,
    header: String,
}

impl TuneCsv {
    /// Opens (creating with its header) `name` in `dir`, through the directory's handle.
    pub fn open(dir: &OutDir, name: &str, params: &[Param]) -> anyhow::Result<TuneCsv> {
        let header = header(params);
        let path = dir.join(name);
        let mut file = dir
            .file(name, Open::Append)
            .with_context(|| format!("cannot open {}", path.display()))?;
        if file.metadata()?.len() == 0 {
            file.write_all(header.as_bytes())?;
        }
        Ok(TuneCsv {
            dir: dir.try_clone()?,
            name: name.to_string(),
            path,
            file,
            header,
        })
    }

    /// Appends one row and flushes it.
    pub fn push(&mut self, row: &EvalRow) -> anyhow::Result<()> {
        self.file
            .write_all(row.line().as_bytes())
            .and_then(|()| self.file.flush())
            .with_context(|| format!("writing {}", self.path.display()))
    }

    /// Replaces the file with exactly `rows` (in their order), atomically, and appends to
    /// the new file from now on.
    pub fn rewrite<'a>(&mut self, rows: impl Iterator<Item = &'a EvalRow>) -> anyhow::Result<()> {
        let mut text = self.header.clone();
        for r in rows {
            text.push_str(&r.line());
        }
        write_atomic(&self.dir, &self.name, &text)?;
        self.file = self
            .dir
            .file(&self.name, Open::Append)
            .with_context(|| format!("cannot open {}", self.path.display()))?;
        Ok(())
    }
}

/// Writes `text` to `name` in `dir` through a temporary file and a rename: never a torn
/// file, and never through a planted symbolic link.
pub fn write_atomic(dir: &OutDir, name: &str, text: &str) -> anyhow::Result<()> {
    dir.write_replace(name, text)
        .with_context(|| format!("writing {}", dir.join(name).display()))
}

/// Everything that decides a tune's evaluations and their results; a resume must match it.
/// Iterations, jobs and the mode are left out: more iterations continue a tune, and both
/// modes give the same runs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Settings {
    /// The tuned keys and bounds.
    pub params: Vec<Param>,
    /// The metric.
    pub fitness: String,
    /// Maximised rather than minimised.
    pub maximize: bool,
    /// P.
    pub particles: u64,
    /// E.
    pub evaluations: u64,
    /// w.
    pub inertia: f64,
    /// c1.
    pub c1: f64,
    /// c2.
    pub c2: f64,
    /// Velocity clamp as a fraction of the bound width.
    pub vmax: f64,
    /// The swarm's seed.
    pub seed: u64,
    /// The run seeds cycled through, or none (derived from `seed`).
    pub seeds: Option<Vec<u64>>,
    /// The resolved config with `--set` applied, before any parameter.
    pub base_config: String,
}

impl Settings {
    /// Why `self` (this command) differs from `then` (the tune directory's), or `None`.
    pub fn difference(&self, then: &Settings) -> Option<String> {
        if self == then {
            return None;
        }
        if self.base_config != then.base_config {
            return Some(format!(
                "another config or --set: {}",
                crate::commands::sweep::first_difference(&self.base_config, &then.base_config)
            ));
        }
        let now = serde_json::to_value(self).ok()?;
        let was = serde_json::to_value(then).ok()?;
        let (now, was) = (now.as_object()?, was.as_object()?);
        now.iter()
            .find(|(k, v)| was.get(*k) != Some(v))
            .map(|(k, v)| {
                format!(
                    "{k} is {v} now, {} then",
                    was.get(k).cloned().unwrap_or_default()
                )
            })
            .or_else(|| Some("different settings".into()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params() -> Vec<Param> {
        vec![Param::parse("radio.loss=0:1").unwrap()]
    }

    #[test]
    fn rows_round_trip_and_later_rows_win() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("tune.csv");
        let out = OutDir::open(dir.path()).unwrap();
        let mut csv = TuneCsv::open(&out, "tune.csv", &params()).unwrap();
        let row = |eval, status, fitness| EvalRow {
            eval,
            iteration: 0,
            particle: eval,
            kind: Kind::New,
            values: vec!["0.30000000000000004".into()],
            seed: 7,
            fitness,
            status,
        };
        csv.push(&row(0, Status::Ok, Some(0.1 + 0.2))).unwrap();
        csv.push(&row(1, Status::Failed, None)).unwrap();
        csv.push(&row(1, Status::Missing, None)).unwrap();
        let mut text = std::fs::read_to_string(&path).unwrap();
        text.push_str("2,0,2,new,0.5,7,1"); // a cut line
        std::fs::write(&path, &text).unwrap();
        let back = read(&path, &params()).unwrap();
        assert_eq!(back.len(), 2);
        assert_eq!(back[&0], row(0, Status::Ok, Some(0.1 + 0.2)));
        assert_eq!(back[&1].status, Status::Missing);
        let other = vec![Param::parse("radio.range=1:2").unwrap()];
        assert!(read(&path, &other).unwrap_err().contains("radio.range"));
    }
}
