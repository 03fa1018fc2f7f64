//! What a sweep shows from its rows: one figure per chosen metric (and per combination of the
//! third and later varied keys), and `summary.md` with mean ± sd per combination.

use std::fmt::Write as _;
use swarmrt_scenario::safe_fs::OutDir;

use super::plan::encode;
use swarmrt_analysis::plot::sweep::{self as figure, Figure, Point, Series};
use swarmrt_analysis::stats::Groups;
use swarmrt_analysis::stats::fmt_num;
use swarmrt_analysis::sweep_csv::Table;

/// Metrics plotted when `--metric` is not given, each only if the runs report it.
pub const DEFAULT_METRICS: [&str; 5] = [
    "reached_target",
    "down",
    "collisions",
    "steps_to_target",
    "radio.delivered",
];

/// The metrics to show: those asked for, else the defaults this table has.
pub fn chosen_metrics(requested: &[String], table: &Table) -> Vec<String> {
    if !requested.is_empty() {
        return requested.to_vec();
    }
    DEFAULT_METRICS
        .iter()
        .filter(|m| table.metric_columns().iter().any(|c| c == *m))
        .map(|m| m.to_string())
        .collect()
}

/// A figure written to `plots/`.
#[derive(Debug, Clone, PartialEq)]
pub struct PlotFile {
    /// The metric shown.
    pub metric: String,
    /// `key=value, ...` of the third and later keys, empty with two keys or fewer.
    pub rest: String,
    /// File name without extension, inside `plots/`.
    pub stem: String,
}

/// x position of value `i` of key 0: the number itself on a numeric axis, else its index.
fn x_of(groups: &Groups, i: usize) -> f64 {
    if groups.numeric(0) {
        groups.values[0][i].parse().unwrap_or(i as f64)
    } else {
        i as f64
    }
}

/// Every index combination of the keys from `from` on (one empty combination if none).
fn index_product(groups: &Groups, from: usize) -> Vec<Vec<usize>> {
    let mut out: Vec<Vec<usize>> = vec![Vec::new()];
    for vals in groups.values.iter().skip(from) {
        out = out
            .iter()
            .flat_map(|c| {
                (0..vals.len()).map(move |i| {
                    let mut c = c.clone();
                    c.push(i);
                    c
                })
            })
            .collect();
    }
    out
}

/// The figures of one metric: x = key 0, one line per value of key 1, one figure per
/// combination of keys 2.. .
pub fn figures(groups: &Groups, scenario: &str, metric: &str) -> Vec<(PlotFile, Figure)> {
    let k = groups.keys.len();
    if k == 0 {
        return Vec::new();
    }
    let lines: Vec<Option<usize>> = if k >= 2 {
        (0..groups.values[1].len()).map(Some).collect()
    } else {
        vec![None]
    };
    let mut out = Vec::new();
    for rest in index_product(groups, 2) {
        let rest_desc = rest
            .iter()
            .enumerate()
            .map(|(j, &v)| format!("{}={}", groups.keys[j + 2], groups.values[j + 2][v]))
            .collect::<Vec<_>>()
            .join(", ");
        let mut runs_per_point: Vec<usize> = Vec::new();
        let mut series = Vec::new();
        for line in &lines {
            let mut points = Vec::new();
            for i in 0..groups.values[0].len() {
                let mut idx = vec![i];
                idx.extend(line);
                idx.extend(&rest);
                let Some(st) = groups.cells.get(&idx).and_then(|c| c.stat(metric)) else {
                    continue;
                };
                runs_per_point.push(st.n);
                points.push(Point {
                    x: x_of(groups, i),
                    mean: st.mean,
                    min: st.min,
                    max: st.max,
                });
            }
            if points.is_empty() {
                continue;
            }
            let label = match line {
                Some(j) => groups.values[1][*j].clone(),
                None => "mean".to_string(),
            };
            series.push(Series { label, points });
        }
        if series.is_empty() {
            continue;
        }
        let (lo, hi) = (
            runs_per_point.iter().min().copied().unwrap_or(0),
            runs_per_point.iter().max().copied().unwrap_or(0),
        );
        let runs = if lo == hi {
            format!("{lo} runs per point")
        } else {
            format!("{lo}–{hi} runs per point")
        };
        let mut title = format!("{scenario}: {metric} vs {}", groups.keys[0]);
        if !rest_desc.is_empty() {
            let _ = write!(title, " ({rest_desc})");
        }
        let mut stem = encode(metric);
        for (j, &v) in rest.iter().enumerate() {
            let _ = write!(
                stem,
                "_{}={}",
                groups.keys[j + 2],
                encode(&groups.values[j + 2][v])
            );
        }
        let fig = Figure {
            title,
            x_label: groups.keys[0].clone(),
            y_label: metric.to_string(),
            x_ticks: (0..groups.values[0].len())
                .map(|i| (x_of(groups, i), groups.values[0][i].clone()))
                .collect(),
            legend_title: if k >= 2 {
                groups.keys[1].clone()
            } else {
                String::new()
            },
            series,
            note: vec![
                "line: mean over seeds".into(),
                "band: min–max over seeds".into(),
                runs,
            ],
        };
        out.push((
            PlotFile {
                metric: metric.to_string(),
                rest: rest_desc,
                stem,
            },
            fig,
        ));
    }
    out
}

/// Writes every figure into `plots_dir`; returns what was written.
pub fn write_plots(
    plots_dir: &OutDir,
    groups: &Groups,
    scenario: &str,
    metrics: &[String],
) -> anyhow::Result<Vec<PlotFile>> {
    let mut written = Vec::new();
    for m in metrics {
        for (file, fig) in figures(groups, scenario, m) {
            figure::write(&fig, plots_dir, &file.stem)?;
            written.push(file);
        }
    }
    Ok(written)
}

fn md_cell(s: &str) -> String {
    s.replace('|', "\\|")
}

/// What `summary.md` says above its table.
pub struct SummaryHead<'a> {
    /// Scenario name.
    pub scenario: &'a str,
    /// The command that ran (or resumed) the sweep.
    pub command: &'a str,
    /// Mode of the runs this invocation started.
    pub mode: &'a str,
}

/// `summary.md`: the command, a table with one row per combination (runs and mean ± sd of each
/// metric over seeds, failed runs counted but left out), and the plots.
pub fn summary_md(
    head: &SummaryHead<'_>,
    table: &Table,
    groups: &Groups,
    metrics: &[String],
    plots: &[PlotFile],
) -> String {
    let mut md = String::new();
    let failed: usize = groups.cells.values().map(|c| c.failed).sum();
    let runs: usize = groups.cells.values().map(|c| c.runs).sum();
    let _ = writeln!(md, "# Sweep: {}\n", head.scenario);
    let _ = writeln!(md, "```\n{}\n```\n", head.command);
    let _ = writeln!(
        md,
        "{} rows in `sweep.csv` ({runs} finished, {failed} failed) over {} combinations; runs started by \
         this command ran in {} mode. Each cell is the mean ± sample standard deviation over \
         seeds; failed runs are left out.\n",
        table.rows.len(),
        groups.cells.len(),
        head.mode,
    );
    let mut header: Vec<String> = groups.keys.iter().map(|k| md_cell(k)).collect();
    header.push("runs".into());
    if failed > 0 {
        header.push("failed".into());
    }
    header.extend(metrics.iter().map(|m| md_cell(m)));
    let _ = writeln!(md, "| {} |", header.join(" | "));
    let _ = writeln!(md, "|{}", "---:|".repeat(header.len()));
    for (idx, cell) in &groups.cells {
        let mut row: Vec<String> = idx
            .iter()
            .enumerate()
            .map(|(i, &v)| md_cell(&groups.values[i][v]))
            .collect();
        row.push(cell.runs.to_string());
        if failed > 0 {
            row.push(cell.failed.to_string());
        }
        for m in metrics {
            row.push(match cell.stat(m) {
                Some(st) => format!("{} ± {}", fmt_num(st.mean), fmt_num(st.sd)),
                None => "–".into(),
            });
        }
        let _ = writeln!(md, "| {} |", row.join(" | "));
    }
    if !plots.is_empty() {
        let _ = writeln!(
            md,
            "\n## Plots\n\nLine: mean over seeds; band: min–max over seeds.\n"
        );
        for p in plots {
            let what = if p.rest.is_empty() {
                format!("{} vs {}", p.metric, groups.keys[0])
            } else {
                format!("{} vs {} ({})", p.metric, groups.keys[0], p.rest)
            };
            let _ = writeln!(
                md,
                "### {what}\n\n![{what}](plots/{stem}.png) ([SVG](plots/{stem}.svg))\n",
                stem = p.stem
            );
        }
    }
    md
}

#[cfg(test)]
mod tests {
    use super::*;

    fn s(v: &[&str]) -> Vec<String> {
        v.iter().map(|x| x.to_string()).collect()
    }

    fn table() -> Table {
        let mut rows = Vec::new();
        for (loss, delay, kind, seed, c) in [
            ("0", "0", "a", "1", "1"),
            ("0", "0", "a", "2", "3"),
            ("0.5", "0", "a", "1", "4"),
            ("0", "2", "a", "1", "0"),
            ("0.5", "2", "b", "1", "7"),
        ] {
            rows.push(s(&[loss, delay, kind, seed, "false", c, "r"]));
        }
        Table {
            header: s(&[
                "radio.loss",
                "radio.delay_ticks",
                "k",
                "seed",
                "failed",
                "collisions",
                "run_dir",
            ]),
            rows,
        }
    }

    #[test]
    fn figures_split_by_second_and_rest_keys() {
        let t = table();
        let keys = s(&["radio.loss", "radio.delay_ticks", "k"]);
        let g = Groups::new(&t, &keys, &[]);
        let figs = figures(&g, "goto", "collisions");
        assert_eq!(figs.len(), 2, "one figure per value of the third key");
        let (file, fig) = &figs[0];
        assert_eq!(file.stem, "collisions_k=a");
        assert_eq!(file.rest, "k=a");
        assert_eq!(fig.title, "goto: collisions vs radio.loss (k=a)");
        assert_eq!(fig.x_label, "radio.loss");
        assert_eq!(fig.legend_title, "radio.delay_ticks");
        assert_eq!(fig.series.len(), 2);
        assert_eq!(fig.series[0].label, "0");
        let p = &fig.series[0].points;
        assert_eq!(p.len(), 2);
        assert_eq!(
            (p[0].x, p[0].mean, p[0].min, p[0].max),
            (0.0, 2.0, 1.0, 3.0)
        );
        assert_eq!((p[1].x, p[1].mean), (0.5, 4.0));
        assert_eq!(fig.note[2], "1–2 runs per point");
        assert_eq!(
            fig.series[1].points.len(),
            1,
            "delay 2 has only loss 0 in k=a"
        );
        assert_eq!(figs[1].1.series.len(), 1, "k=b has one line");
    }

    #[test]
    fn summary_has_a_row_per_combination() {
        let t = table();
        let keys = s(&["radio.loss", "radio.delay_ticks", "k"]);
        let g = Groups::new(&t, &keys, &[]);
        let metrics = chosen_metrics(&[], &t);
        assert_eq!(metrics, ["collisions"]);
        let plots = vec![PlotFile {
            metric: "collisions".into(),
            rest: "k=a".into(),
            stem: "collisions_k=a".into(),
        }];
        let head = SummaryHead {
            scenario: "goto",
            command: "swarm sweep x",
            mode: "in-process",
        };
        let md = summary_md(&head, &t, &g, &metrics, &plots);
        let table_rows: Vec<&str> = md.lines().filter(|l| l.starts_with("| ")).collect();
        assert_eq!(table_rows.len(), 1 + 4, "{md}");
        assert_eq!(
            table_rows[0],
            "| radio.loss | radio.delay_ticks | k | runs | collisions |"
        );
        assert_eq!(table_rows[1], "| 0 | 0 | a | 2 | 2 ± 1.41 |");
        assert!(md.contains("(plots/collisions_k=a.png)"));
    }

    #[test]
    fn numbers_are_short() {
        assert_eq!(fmt_num(3.0), "3");
        assert_eq!(fmt_num(2.0f64.sqrt()), "1.41");
        assert_eq!(fmt_num(0.012345), "0.0123");
        assert_eq!(fmt_num(123.456), "123");
        assert_eq!(fmt_num(1234.6), "1235");
        assert_eq!(fmt_num(-0.5), "-0.5");
    }
}
