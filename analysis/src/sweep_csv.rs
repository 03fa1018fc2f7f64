//! `sweep.csv`: one row per finished run, appended whole and flushed as each run ends, so an
//! interrupted or killed sweep keeps every finished row and resume can read them back.
//!
//! Columns: the varied keys, `seed`, the run's scalar metrics flattened with dotted keys
//! (sorted; numbers, booleans and `mode`), then `run_dir` (relative to the sweep directory).
//! The metric columns are fixed by the first row written; later rows leave a missing metric
//! empty and drop metrics the header lacks.

use std::borrow::Cow;
use std::collections::{BTreeMap, BTreeSet};
use std::io::Write;
use std::path::Path;

use anyhow::Context;
use swarmrt_scenario::safe_fs::{Open, OutDir};

/// The seed column.
pub const SEED: &str = "seed";
/// The run directory column, always last.
pub const RUN_DIR: &str = "run_dir";
/// The metric saying a run failed (`true`/`false`); every header has it.
pub const FAILED: &str = "failed";
/// The only string metric kept: which mode ran (`processes` or `in-process`).
const MODE: &str = "mode";

/// Quotes a field if it holds a comma, quote or line break (RFC 4180).
pub fn quote(field: &str) -> Cow<'_, str> {
    if field.contains([',', '"', '\n', '\r']) {
        Cow::Owned(format!("\"{}\"", field.replace('"', "\"\"")))
    } else {
        Cow::Borrowed(field)
    }
}

/// One CSV line (without its newline) as a record.
pub fn format_line<S: AsRef<str>>(fields: &[S]) -> String {
    let mut line = fields
        .iter()
        .map(|f| quote(f.as_ref()))
        .collect::<Vec<_>>()
        .join(",");
    line.push('\n');
    line
}

/// Splits one CSV line (no line breaks inside fields); `None` if its quotes are malformed.
pub fn parse_line(line: &str) -> Option<Vec<String>> {
    let mut fields = Vec::new();
    let mut chars = line.chars().peekable();
    loop {
        let mut field = String::new();
        if chars.peek() == Some(&'"') {
            chars.next();
            loop {
                match chars.next()? {
                    '"' if chars.peek() == Some(&'"') => {
                        chars.next();
                        field.push('"');
                    }
                    '"' => break,
                    c => field.push(c),
                }
            }
            match chars.next() {
                None => {
                    fields.push(field);
                    return Some(fields);
                }
                Some(',') => fields.push(field),
                Some(_) => return None,
            }
        } else {
            loop {
                match chars.next() {
                    None => {
                        fields.push(field);
                        return Some(fields);
                    }
                    Some(',') => break,
                    Some('"') => return None,
                    Some(c) => field.push(c),
                }
            }
            fields.push(field);
        }
    }
}

/// The scalar metrics of a `metrics.json`, flattened with dotted keys: numbers and booleans as
/// JSON writes them, plus `mode`; other strings, arrays and nulls are left out.
pub fn flatten(metrics: &serde_json::Value) -> BTreeMap<String, String> {
    fn walk(prefix: &str, v: &serde_json::Value, out: &mut BTreeMap<String, String>) {
        match v {
            serde_json::Value::Object(map) => {
                for (k, v) in map {
                    let key = if prefix.is_empty() {
                        k.clone()
                    } else {
                        format!("{prefix}.{k}")
                    };
                    walk(&key, v, out);
                }
            }
            serde_json::Value::Number(n) => {
                out.insert(prefix.to_string(), n.to_string());
            }
            serde_json::Value::Bool(b) => {
                out.insert(prefix.to_string(), b.to_string());
            }
            serde_json::Value::String(s) if prefix == MODE => {
                out.insert(prefix.to_string(), s.clone());
            }
            _ => {}
        }
    }
    let mut out = BTreeMap::new();
    walk("", metrics, &mut out);
    out
}

/// A finished run, ready to become a row.
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    /// The varied values, in key order.
    pub values: Vec<String>,
    /// The seed.
    pub seed: u64,
    /// Flattened metrics ([`flatten`]); must hold [`FAILED`].
    pub metrics: BTreeMap<String, String>,
    /// The run directory relative to the sweep directory.
    pub run_dir: String,
}

impl Row {
    /// True if the run failed (resume runs it again).
    pub fn failed(&self) -> bool {
        self.metrics.get(FAILED).map(String::as_str) != Some("false")
    }
}

/// The header a first row implies: varied keys, seed, its metrics (sorted), run_dir.
fn header_for(keys: &[String], row: &Row) -> Vec<String> {
    let mut metrics: BTreeSet<&str> = row.metrics.keys().map(String::as_str).collect();
    metrics.insert(FAILED);
    let mut header = keys.to_vec();
    header.push(SEED.into());
    header.extend(
        metrics
            .into_iter()
            .filter(|m| *m != SEED && *m != RUN_DIR && !keys.iter().any(|k| k == m))
            .map(String::from),
    );
    header.push(RUN_DIR.into());
    header
}

/// `sweep.csv` read back: header and whole rows.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Table {
    /// Column names.
    pub header: Vec<String>,
    /// Rows with exactly `header.len()` fields.
    pub rows: Vec<Vec<String>>,
}

impl Table {
    /// Index of a column.
    pub fn col(&self, name: &str) -> Option<usize> {
        self.header.iter().position(|h| h == name)
    }

    /// Metric columns: everything between `seed` and `run_dir`.
    pub fn metric_columns(&self) -> &[String] {
        let start = self.col(SEED).map_or(0, |i| i + 1);
        let end = self.col(RUN_DIR).unwrap_or(self.header.len());
        &self.header[start.min(end)..end]
    }

    /// Reads `path`. Lines that are not whole rows (a line cut by a kill, wrong field count)
    /// are skipped and counted; a missing or foreign header is an error naming the file.
    pub fn read(path: &Path) -> Result<(Table, usize), String> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| format!("{}: cannot read: {e}", path.display()))?;
        let mut lines = text.split_inclusive('\n');
        let header = lines
            .next()
            .filter(|l| l.ends_with('\n'))
            .and_then(|l| parse_line(l.trim_end_matches(['\n', '\r'])))
            .filter(|h| {
                h.len() >= 2 && h.iter().any(|c| c == SEED) && h.last().map(String::as_str) == Some(RUN_DIR)
            })
            .ok_or_else(|| {
                format!(
                    "{}: not a sweep.csv (expected a header ending in `{RUN_DIR}` with a `{SEED}` column)",
                    path.display()
                )
            })?;
        let mut rows = Vec::new();
        let mut skipped = 0;
        for line in lines {
            match line
                .strip_suffix('\n')
                .and_then(|l| parse_line(l.trim_end_matches('\r')))
            {
                Some(r) if r.len() == header.len() => rows.push(r),
                _ => skipped += 1,
            }
        }
        Ok((Table { header, rows }, skipped))
    }
}

/// Appends rows to `sweep.csv`. The header is fixed by the first successful run, so a run that
/// failed early (few metrics) cannot decide the columns: failed rows wait until a success
/// (or [`SweepCsv::finish`]) writes the header.
pub struct SweepCsv {
    dir: OutDir,
    name: String,
    keys: Vec<String>,
    header: Option<Vec<String>>,
    file: Option<std::fs::File>,
    waiting: Vec<Row>,
    /// Metrics some run had that the header lacks (reported once each).
    pub ignored: BTreeSet<String>,
}

impl SweepCsv {
    /// A writer for `name` in `dir` (written through the directory's handle) with these
    /// varied keys. With `existing`, rows go under its header; the file is rewritten first to
    /// hold exactly its rows (dropping cut lines and the rows resume will run again).
    pub fn open(
        dir: &OutDir,
        name: &str,
        keys: &[String],
        existing: Option<&Table>,
    ) -> anyhow::Result<Self> {
        let mut csv = SweepCsv {
            dir: dir.try_clone()?,
            name: name.to_string(),
            keys: keys.to_vec(),
            header: None,
            file: None,
            waiting: Vec::new(),
            ignored: BTreeSet::new(),
        };
        if let Some(t) = existing {
            let mut text = format_line(&t.header);
            for r in &t.rows {
                text.push_str(&format_line(r));
            }
            csv.dir
                .write_replace(name, text)
                .with_context(|| format!("writing {}", csv.dir.join(name).display()))?;
            csv.header = Some(t.header.clone());
            csv.file = Some(csv.append_to()?);
        }
        Ok(csv)
    }

    fn append_to(&self) -> anyhow::Result<std::fs::File> {
        self.dir
            .file(&self.name, Open::Append)
            .with_context(|| format!("opening {}", self.dir.join(&self.name).display()))
    }

    /// Adds a row: written and flushed now, unless it failed and no header exists yet.
    pub fn push(&mut self, row: Row) -> anyhow::Result<()> {
        if self.header.is_none() {
            if row.failed() {
                self.waiting.push(row);
                return Ok(());
            }
            self.start(&row)?;
        }
        self.write(&row)
    }

    /// Writes rows still waiting for a header (every run so far failed).
    pub fn finish(&mut self) -> anyhow::Result<()> {
        if self.header.is_none()
            && let Some(first) = self.waiting.first().cloned()
        {
            self.start(&first)?;
        }
        Ok(())
    }

    /// Writes the header implied by `row` to a new file, then any waiting rows.
    fn start(&mut self, row: &Row) -> anyhow::Result<()> {
        let header = header_for(&self.keys, row);
        let path = self.dir.join(&self.name);
        let mut file = self
            .dir
            .file(&self.name, Open::Create)
            .with_context(|| format!("creating {}", path.display()))?;
        file.write_all(format_line(&header).as_bytes())
            .with_context(|| format!("writing {}", path.display()))?;
        drop(file);
        self.file = Some(self.append_to()?);
        self.header = Some(header);
        for r in std::mem::take(&mut self.waiting) {
            self.write(&r)?;
        }
        Ok(())
    }

    /// One row as one `write` of a whole line, so a kill never leaves half a row.
    fn write(&mut self, row: &Row) -> anyhow::Result<()> {
        let (Some(header), Some(file)) = (&self.header, self.file.as_mut()) else {
            anyhow::bail!("sweep.csv written before its header");
        };
        let k = self.keys.len();
        let mut fields: Vec<String> = Vec::with_capacity(header.len());
        fields.extend(row.values.iter().cloned());
        fields.push(row.seed.to_string());
        for col in &header[k + 1..header.len() - 1] {
            fields.push(row.metrics.get(col).cloned().unwrap_or_default());
        }
        fields.push(row.run_dir.clone());
        for m in row.metrics.keys() {
            if !header.contains(m) && !self.keys.contains(m) {
                self.ignored.insert(m.clone());
            }
        }
        file.write_all(format_line(&fields).as_bytes())
            .and_then(|()| file.flush())
            .with_context(|| format!("writing {}", self.dir.join(&self.name).display()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn quoting_round_trips() {
        let fields = ["plain", "a,b", "say \"hi\"", "", "x"];
        let line = format_line(&fields);
        assert_eq!(line, "plain,\"a,b\",\"say \"\"hi\"\"\",,x\n");
        assert_eq!(parse_line(line.trim_end()).unwrap(), fields);
        assert_eq!(parse_line("").unwrap(), [""]);
        assert_eq!(parse_line("a,").unwrap(), ["a", ""]);
        assert!(parse_line("\"open").is_none());
        assert!(parse_line("a\"b").is_none());
        assert!(parse_line("\"a\"b").is_none());
    }

    #[test]
    fn flatten_keeps_scalars_and_mode() {
        let m = json!({
            "mode": "in-process", "scenario": "s", "ticks": 60, "failed": false,
            "wall_seconds": 0.5, "radio": {"sent": 10, "inner": {"x": 1}},
            "unscheduled_deaths": [], "failure": null,
        });
        let f = flatten(&m);
        let keys: Vec<&str> = f.keys().map(String::as_str).collect();
        assert_eq!(
            keys,
            [
                "failed",
                "mode",
                "radio.inner.x",
                "radio.sent",
                "ticks",
                "wall_seconds"
            ]
        );
        assert_eq!(f["wall_seconds"], "0.5");
        assert_eq!(f["failed"], "false");
    }

    fn row(values: &[&str], seed: u64, metrics: serde_json::Value) -> Row {
        Row {
            values: values.iter().map(|s| s.to_string()).collect(),
            seed,
            metrics: flatten(&metrics),
            run_dir: format!("runs/{}-s{seed}", values.join("-")),
        }
    }

    #[test]
    fn header_waits_for_a_successful_run_and_rows_read_back() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("sweep.csv");
        let keys = vec!["a".to_string(), "b".to_string()];
        let mut csv =
            SweepCsv::open(&OutDir::open(dir.path()).unwrap(), "sweep.csv", &keys, None).unwrap();
        csv.push(row(&["1", "x"], 1, json!({"failed": true, "ticks": 3})))
            .unwrap();
        assert!(
            !path.exists(),
            "a failed first run must not fix the columns"
        );
        csv.push(row(
            &["2", "y,z"],
            1,
            json!({"failed": false, "ticks": 60, "seed": 1, "radio": {"sent": 4}}),
        ))
        .unwrap();
        csv.push(row(
            &["1", "y"],
            2,
            json!({"failed": false, "ticks": 60, "extra": 1}),
        ))
        .unwrap();
        csv.finish().unwrap();
        assert_eq!(csv.ignored.iter().collect::<Vec<_>>(), ["extra"]);

        let (t, skipped) = Table::read(&path).unwrap();
        assert_eq!(skipped, 0);
        assert_eq!(
            t.header,
            ["a", "b", "seed", "failed", "radio.sent", "ticks", "run_dir"]
        );
        assert_eq!(t.metric_columns(), ["failed", "radio.sent", "ticks"]);
        assert_eq!(t.rows.len(), 3);
        // The waiting failed row goes right under the header.
        assert_eq!(t.rows[0][..4], ["1", "x", "1", "true"]);
        assert_eq!(t.rows[0][4], "", "missing metric left empty");
        assert_eq!(
            t.rows[1],
            ["2", "y,z", "1", "false", "4", "60", "runs/2-y,z-s1"]
        );
        assert_eq!(t.rows[2][4..6], ["", "60"]);
    }

    #[test]
    fn only_failures_still_get_a_header() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("sweep.csv");
        let mut csv = SweepCsv::open(
            &OutDir::open(dir.path()).unwrap(),
            "sweep.csv",
            &["a".to_string()],
            None,
        )
        .unwrap();
        csv.push(row(&["1"], 1, json!({"failed": true}))).unwrap();
        csv.finish().unwrap();
        let (t, _) = Table::read(&path).unwrap();
        assert_eq!(t.header, ["a", "seed", "failed", "run_dir"]);
        assert_eq!(t.rows, [["1", "1", "true", "runs/1-s1"]]);
    }

    #[test]
    fn a_link_planted_as_sweep_csv_is_refused_and_its_target_untouched() {
        let dir = tempfile::tempdir().unwrap();
        let victim = dir.path().join("victim");
        std::fs::write(&victim, "keep").unwrap();
        let path = dir.path().join("sweep.csv");
        std::os::unix::fs::symlink(&victim, &path).unwrap();
        let mut csv = SweepCsv::open(
            &OutDir::open(dir.path()).unwrap(),
            "sweep.csv",
            &["a".to_string()],
            None,
        )
        .unwrap();
        let err = csv
            .push(row(&["1"], 1, json!({"failed": false})))
            .unwrap_err();
        assert!(
            format!("{err:#}").contains("is a symbolic link; refusing to follow it"),
            "{err:#}"
        );
        assert_eq!(std::fs::read_to_string(&victim).unwrap(), "keep");
    }

    #[test]
    fn cut_lines_are_skipped_and_reopen_rewrites() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("sweep.csv");
        std::fs::write(
            &path,
            "a,seed,failed,run_dir\n1,1,false,r1\n2,1,false\n\"x,1,false,r3\n3,1,fal",
        )
        .unwrap();
        let (t, skipped) = Table::read(&path).unwrap();
        assert_eq!(skipped, 3);
        assert_eq!(t.rows, [["1", "1", "false", "r1"]]);
        let mut csv = SweepCsv::open(
            &OutDir::open(dir.path()).unwrap(),
            "sweep.csv",
            &["a".to_string()],
            Some(&t),
        )
        .unwrap();
        csv.push(row(&["4"], 1, json!({"failed": false}))).unwrap();
        assert_eq!(
            std::fs::read_to_string(&path).unwrap(),
            "a,seed,failed,run_dir\n1,1,false,r1\n4,1,false,runs/4-s1\n"
        );
    }

    #[test]
    fn foreign_files_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("sweep.csv");
        for text in ["", "tick,id,x\n1,2,3\n", "seed,run_dir"] {
            std::fs::write(&path, text).unwrap();
            let e = Table::read(&path).unwrap_err();
            assert!(e.contains("not a sweep.csv"), "{text:?}: {e}");
        }
    }
}
