//! A tune's figures, one line chart against the iteration each: the best parameters so far,
//! each normalised to its bounds (like Fig. 9-10 of the flocking paper), and the fitness (the
//! best personal best's mean and the mean of the iteration's new positions).

use swarmrt_scenario::safe_fs::OutDir;

use plotters::coord::Shift;
use plotters::prelude::*;

use super::{Drawing, TAB10, draw_err, write_svg_png};
use crate::stats::fmt_num;

/// What a tune has done so far, one entry per finished iteration.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct History {
    /// The scenario's name (titles).
    pub scenario: String,
    /// The tuned keys, in `--param` order.
    pub params: Vec<String>,
    /// Each key's bounds, for the legend.
    pub bounds: Vec<(f64, f64)>,
    /// The metric's name.
    pub fitness: String,
    /// Per iteration: the best personal best's parameters, each in [0, 1] of its bounds.
    pub best_params: Vec<Vec<f64>>,
    /// Per iteration: the best personal best's mean fitness (not finite: no valid one yet).
    pub best_fitness: Vec<f64>,
    /// Per iteration: the mean fitness of its new positions' evaluations that reported one.
    pub mean_fitness: Vec<f64>,
}

/// One line of a chart.
struct Line {
    label: String,
    points: Vec<(f64, f64)>,
}

/// A line chart against the iteration.
struct Chart {
    title: String,
    y_label: String,
    /// A fixed y range, or fitted to the data.
    y_range: Option<(f64, f64)>,
    lines: Vec<Line>,
}

const SIZE: (u32, u32) = (960, 560);
const LEGEND_W: u32 = 260;

/// Writes `best_params.svg`/`.png` and `fitness.svg`/`.png` into `dir`.
pub fn write_tune_plots(dir: &OutDir, h: &History) -> anyhow::Result<()> {
    let params = Chart {
        title: format!("{}: best parameters per iteration", h.scenario),
        y_label: "share of the bounds (0 = lo, 1 = hi)".into(),
        y_range: Some((-0.05, 1.05)),
        lines: h
            .params
            .iter()
            .enumerate()
            .map(|(d, key)| Line {
                label: match h.bounds.get(d) {
                    Some((lo, hi)) => format!("{key} [{}, {}]", fmt_num(*lo), fmt_num(*hi)),
                    None => key.clone(),
                },
                points: finite_points(h.best_params.iter().map(|p| p[d])),
            })
            .collect(),
    };
    write_svg_png(&params, dir, "best_params")?;
    let fitness = Chart {
        title: format!("{}: {} per iteration", h.scenario, h.fitness),
        y_label: h.fitness.clone(),
        y_range: None,
        lines: vec![
            Line {
                label: "best personal best (mean)".into(),
                points: finite_points(h.best_fitness.iter().copied()),
            },
            Line {
                label: "mean of new positions".into(),
                points: finite_points(h.mean_fitness.iter().copied()),
            },
        ],
    };
    write_svg_png(&fitness, dir, "fitness")
}

fn finite_points(ys: impl Iterator<Item = f64>) -> Vec<(f64, f64)> {
    ys.enumerate()
        .filter(|(_, y)| y.is_finite())
        .map(|(i, y)| (i as f64, y))
        .collect()
}

impl Drawing for Chart {
    fn size(&self) -> (u32, u32) {
        SIZE
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> anyhow::Result<()> {
        root.fill(&WHITE)
            .map_err(draw_err("tune plot: background"))?;
        let (plot, legend) = root.split_horizontally(SIZE.0 - LEGEND_W);
        let pts = || self.lines.iter().flat_map(|l| &l.points);
        let x_hi = pts().map(|p| p.0).fold(0.0, f64::max).max(1.0);
        let (y0, y1) = self.y_range.unwrap_or_else(|| {
            let (lo, hi) = pts().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                (a.min(p.1), b.max(p.1))
            });
            if !(lo.is_finite() && hi.is_finite()) {
                (0.0, 1.0)
            } else if hi - lo < 1e-12 {
                let d = if lo == 0.0 { 1.0 } else { lo.abs() * 0.1 };
                (lo - d, hi + d)
            } else {
                let pad = (hi - lo) * 0.08;
                (lo - pad, hi + pad)
            }
        });
        let mut chart = ChartBuilder::on(&plot)
            .caption(&self.title, ("sans-serif", 20.0))
            .margin(14)
            .x_label_area_size(52)
            .y_label_area_size(72)
            .build_cartesian_2d(-0.2..x_hi + 0.2, y0..y1)
            .map_err(draw_err("tune plot: axes"))?;
        chart
            .configure_mesh()
            .x_desc("iteration")
            .y_desc(self.y_label.as_str())
            .x_label_formatter(&|v: &f64| {
                if (v - v.round()).abs() < 1e-9 {
                    format!("{}", v.round() as i64)
                } else {
                    String::new()
                }
            })
            .y_label_formatter(&|v: &f64| fmt_num(*v))
            .y_labels(8)
            .label_style(("sans-serif", 14.0))
            .axis_desc_style(("sans-serif", 16.0))
            .bold_line_style(BLACK.mix(0.08))
            .light_line_style(TRANSPARENT)
            .axis_style(BLACK.stroke_width(1))
            .draw()
            .map_err(draw_err("tune plot: mesh"))?;
        for (i, l) in self.lines.iter().enumerate() {
            let c = TAB10[i % TAB10.len()];
            chart
                .draw_series(LineSeries::new(l.points.iter().copied(), c.stroke_width(2)))
                .map_err(draw_err("tune plot: line"))?;
            chart
                .draw_series(l.points.iter().map(|&p| Circle::new(p, 3, c.filled())))
                .map_err(draw_err("tune plot: markers"))?;
        }
        let ink = ("sans-serif", 14.0)
            .into_font()
            .color(&RGBColor(60, 60, 60));
        let mut y = 60;
        for (i, l) in self.lines.iter().enumerate() {
            let c = TAB10[i % TAB10.len()];
            legend
                .draw(&PathElement::new(
                    vec![(8, y + 7), (36, y + 7)],
                    c.stroke_width(2),
                ))
                .and_then(|()| legend.draw(&Circle::new((22, y + 7), 3, c.filled())))
                .and_then(|()| legend.draw_text(&l.label, &ink, (44, y)))
                .map_err(draw_err("tune plot: legend"))?;
            y += 24;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_both_figures_even_before_a_valid_fitness() {
        let dir = tempfile::tempdir().unwrap();
        let mut h = History {
            scenario: "goto_simple".into(),
            params: vec!["behaviour.speed".into(), "radio.loss".into()],
            bounds: vec![(0.1, 1.5), (0.0, 0.5)],
            fitness: "steps_to_target".into(),
            best_params: vec![vec![0.5, 0.2]],
            best_fitness: vec![f64::INFINITY],
            mean_fitness: vec![f64::NAN],
        };
        let out = OutDir::open(dir.path()).unwrap();
        write_tune_plots(&out, &h).unwrap();
        h.best_params.push(vec![0.7, 0.1]);
        h.best_fitness.push(412.0);
        h.mean_fitness.push(500.0);
        write_tune_plots(&out, &h).unwrap();
        let svg = std::fs::read_to_string(dir.path().join("best_params.svg")).unwrap();
        assert!(svg.contains("behaviour.speed [0.1, 1.5]"), "{svg}");
        let svg = std::fs::read_to_string(dir.path().join("fitness.svg")).unwrap();
        assert!(svg.contains("steps_to_target per iteration"));
        for f in ["best_params.png", "fitness.png"] {
            assert_eq!(&std::fs::read(dir.path().join(f)).unwrap()[1..4], b"PNG");
        }
    }
}
