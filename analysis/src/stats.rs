//! The rows of `sweep.csv` grouped by combination of varied values, with per-metric mean,
//! sample standard deviation, min and max over seeds: what the plots and the summary show.

use std::collections::BTreeMap;

use crate::sweep_csv::{FAILED, SEED, Table};

/// Mean, spread and count of one metric in one combination.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stat {
    /// Runs with a value.
    pub n: usize,
    /// Arithmetic mean.
    pub mean: f64,
    /// Sample standard deviation (n - 1); 0 for a single run.
    pub sd: f64,
    /// Smallest value.
    pub min: f64,
    /// Largest value.
    pub max: f64,
}

impl Stat {
    /// Statistics of `values`, `None` if empty.
    pub fn of(values: &[f64]) -> Option<Stat> {
        let n = values.len();
        if n == 0 {
            return None;
        }
        let mean = values.iter().sum::<f64>() / n as f64;
        let sd = if n > 1 {
            (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
        } else {
            0.0
        };
        let min = values.iter().copied().fold(f64::INFINITY, f64::min);
        let max = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        Some(Stat {
            n,
            mean,
            sd,
            min,
            max,
        })
    }
}

/// The finished runs of one combination.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Cell {
    /// Runs that did not fail.
    pub runs: usize,
    /// Runs that failed (left out of the statistics).
    pub failed: usize,
    /// Values of each metric over the runs that did not fail.
    pub values: BTreeMap<String, Vec<f64>>,
}

impl Cell {
    /// Statistics of a metric in this combination.
    pub fn stat(&self, metric: &str) -> Option<Stat> {
        Stat::of(self.values.get(metric).map_or(&[][..], Vec::as_slice))
    }
}

/// Rows grouped by combination. Each key's values are ordered numerically when all are
/// numbers, else in the order first given (the command's order, then any older rows').
#[derive(Debug, Clone, PartialEq)]
pub struct Groups {
    /// The varied keys.
    pub keys: Vec<String>,
    /// Each key's values, in display order.
    pub values: Vec<Vec<String>>,
    /// Cells by index of each key's value, so the map's order is the display order.
    pub cells: BTreeMap<Vec<usize>, Cell>,
}

/// A CSV cell as a number: numbers, `true` as 1 and `false` as 0; empty is no value.
pub fn number(s: &str) -> Option<f64> {
    match s {
        "true" => Some(1.0),
        "false" => Some(0.0),
        _ => s.parse::<f64>().ok().filter(|v| v.is_finite()),
    }
}

impl Groups {
    /// Groups `table`'s rows; `order` gives each key's values as the command listed them.
    pub fn new(table: &Table, keys: &[String], order: &[Vec<String>]) -> Groups {
        let k = keys.len();
        let mut values: Vec<Vec<String>> = order.to_vec();
        values.resize(k, Vec::new());
        for row in &table.rows {
            for (i, list) in values.iter_mut().enumerate() {
                if !list.contains(&row[i]) {
                    list.push(row[i].clone());
                }
            }
        }
        // Only values that occur in rows, numerically sorted where possible.
        for (i, list) in values.iter_mut().enumerate() {
            list.retain(|v| table.rows.iter().any(|r| &r[i] == v));
            if list.iter().all(|v| v.parse::<f64>().is_ok()) {
                list.sort_by(|a, b| {
                    let (x, y) = (
                        a.parse::<f64>().unwrap_or(0.0),
                        b.parse::<f64>().unwrap_or(0.0),
                    );
                    x.total_cmp(&y)
                });
            }
        }
        let failed_col = table.col(FAILED);
        let metrics = table.metric_columns();
        let first_metric = table.col(SEED).map_or(0, |i| i + 1);
        let mut cells: BTreeMap<Vec<usize>, Cell> = BTreeMap::new();
        for row in &table.rows {
            let idx: Vec<usize> = (0..k)
                .map(|i| {
                    values[i]
                        .iter()
                        .position(|v| v == &row[i])
                        .expect("every row value is listed")
                })
                .collect();
            let cell = cells.entry(idx).or_default();
            if failed_col.is_some_and(|c| row[c] != "false") {
                cell.failed += 1;
                continue;
            }
            cell.runs += 1;
            for (j, m) in metrics.iter().enumerate() {
                if let Some(v) = number(&row[first_metric + j]) {
                    cell.values.entry(m.clone()).or_default().push(v);
                }
            }
        }
        Groups {
            keys: keys.to_vec(),
            values,
            cells,
        }
    }

    /// True when every value of key `i` is a number (a numeric plot axis).
    pub fn numeric(&self, i: usize) -> bool {
        self.values[i].iter().all(|v| v.parse::<f64>().is_ok())
    }
}

/// A number in a table: integers as integers, else three significant digits.
pub fn fmt_num(x: f64) -> String {
    if !x.is_finite() {
        return x.to_string();
    }
    if x.fract() == 0.0 && x.abs() < 1e15 {
        return format!("{x:.0}");
    }
    let magnitude = x.abs().log10().floor() as i32;
    let decimals = (2 - magnitude).clamp(0, 9) as usize;
    let s = format!("{x:.decimals$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn s(v: &[&str]) -> Vec<String> {
        v.iter().map(|x| x.to_string()).collect()
    }

    #[test]
    fn stat_mean_sd_min_max() {
        let st = Stat::of(&[2.0, 4.0, 4.0, 4.0, 5.0, 5.0, 7.0, 9.0]).unwrap();
        assert_eq!(st.n, 8);
        assert_eq!(st.mean, 5.0);
        assert!((st.sd - (32.0f64 / 7.0).sqrt()).abs() < 1e-12);
        assert_eq!((st.min, st.max), (2.0, 9.0));
        assert_eq!(Stat::of(&[3.0]).unwrap().sd, 0.0);
        assert!(Stat::of(&[]).is_none());
    }

    #[test]
    fn groups_order_values_and_skip_failed_runs() {
        let table = Table {
            header: s(&["loss", "kind", "seed", "failed", "x", "run_dir"]),
            rows: vec![
                s(&["0.4", "b", "1", "false", "10", "r"]),
                s(&["0.1", "a", "1", "false", "1", "r"]),
                s(&["0.1", "a", "2", "false", "3", "r"]),
                s(&["0.1", "a", "3", "true", "", "r"]),
                s(&["0.1", "b", "1", "false", "true", "r"]),
                s(&["0.05", "a", "1", "false", "", "r"]),
            ],
        };
        let keys = s(&["loss", "kind"]);
        let g = Groups::new(&table, &keys, &[s(&["0.4", "0.1", "0.2"]), s(&["b", "a"])]);
        // Numeric key sorted, unused 0.2 dropped, older 0.05 kept; strings in command order.
        assert_eq!(g.values, [s(&["0.05", "0.1", "0.4"]), s(&["b", "a"])]);
        assert!(g.numeric(0) && !g.numeric(1));
        let c = &g.cells[&vec![1, 1]];
        assert_eq!((c.runs, c.failed), (2, 1));
        assert_eq!(c.stat("x").unwrap().mean, 2.0);
        assert_eq!(g.cells[&vec![1, 0]].stat("x").unwrap().mean, 1.0);
        assert!(
            g.cells[&vec![0, 1]].stat("x").is_none(),
            "empty is no value"
        );
        assert_eq!(g.cells.len(), 4);
    }
}
