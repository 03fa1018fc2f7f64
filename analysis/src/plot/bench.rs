//! Benchmark figures: panels of log-log line charts, written as SVG and PNG (see [`super`]).

use std::path::Path;

use anyhow::Context;
use swarmrt_scenario::safe_fs::OutDir;

use plotters::coord::Shift;
use plotters::prelude::*;

use super::{Drawing, TAB10, draw_err, write_svg_png};

/// One line of a panel.
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend label.
    pub name: String,
    /// (x, y) points; non-positive or non-finite values are skipped (log axes).
    pub points: Vec<(f64, f64)>,
    /// Index into the palette (same transport, same colour in every panel).
    pub colour: usize,
    /// Dashed line (e.g. a p99 beside a median).
    pub dashed: bool,
}

/// One chart.
#[derive(Debug, Clone)]
pub struct Panel {
    /// Title above the chart.
    pub title: String,
    /// X axis label.
    pub x_desc: String,
    /// Y axis label.
    pub y_desc: String,
    /// The lines.
    pub series: Vec<Series>,
    /// Where the legend goes (where the lines are not).
    pub legend: Legend,
}

/// Corner of a panel for its legend.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Legend {
    /// Top left.
    #[default]
    UpperLeft,
    /// Top right.
    UpperRight,
    /// Bottom left.
    LowerLeft,
    /// Bottom right.
    LowerRight,
}

/// tab10 without grey and olive: one colour per transport, the same in every panel.
const PALETTE: [RGBColor; 8] = [
    TAB10[0], TAB10[1], TAB10[2], TAB10[3], TAB10[4], TAB10[5], TAB10[6], TAB10[9],
];

const PANEL_W: u32 = 640;
const PANEL_H: u32 = 460;
const TITLE_H: u32 = 44;

/// Axis range covering `values` on a log scale, with a little room.
fn log_range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
    for v in values.filter(|v| v.is_finite() && *v > 0.0) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return (1.0, 10.0);
    }
    if hi <= lo * 1.0001 {
        return (lo / 2.0, hi * 2.0);
    }
    (lo / 1.4, hi * 1.4)
}

/// Short tick label for a log axis. With `sparse` (an axis spanning a decade or more) only
/// 1, 2 and 5 times a power of ten are labelled (the others stay as grid lines), so labels
/// never run into each other.
fn label(v: f64, sparse: bool) -> String {
    let a = v.abs();
    if sparse && a > 0.0 {
        let mantissa = a / 10f64.powf(a.log10().floor());
        if ![1.0, 2.0, 5.0, 10.0]
            .iter()
            .any(|m| (mantissa - m).abs() < 1e-6 * m)
        {
            return String::new();
        }
    }
    if a >= 1e9 {
        format!("{}G", trim(v / 1e9))
    } else if a >= 1e6 {
        format!("{}M", trim(v / 1e6))
    } else if a >= 1e3 {
        format!("{}k", trim(v / 1e3))
    } else {
        trim(v)
    }
}

fn trim(v: f64) -> String {
    let s = format!("{v:.2}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    s.to_string()
}

fn draw_panel<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, p: &Panel) -> anyhow::Result<()> {
    let usable: Vec<Vec<(f64, f64)>> = p
        .series
        .iter()
        .map(|s| {
            s.points
                .iter()
                .copied()
                .filter(|(x, y)| x.is_finite() && y.is_finite() && *x > 0.0 && *y > 0.0)
                .collect()
        })
        .collect();
    let xr = log_range(usable.iter().flatten().map(|p| p.0));
    let yr = log_range(usable.iter().flatten().map(|p| p.1));
    let mut chart = ChartBuilder::on(area)
        .caption(&p.title, ("sans-serif", 18.0))
        .margin(12)
        .x_label_area_size(44)
        .y_label_area_size(64)
        .build_cartesian_2d((xr.0..xr.1).log_scale(), (yr.0..yr.1).log_scale())
        .map_err(draw_err("benchmark figure: axes"))?;
    chart
        .configure_mesh()
        .x_desc(p.x_desc.as_str())
        .y_desc(p.y_desc.as_str())
        .x_label_formatter(&|v| label(*v, xr.1 / xr.0 >= 10.0))
        .y_label_formatter(&|v| label(*v, yr.1 / yr.0 >= 10.0))
        .label_style(("sans-serif", 13.0))
        .axis_desc_style(("sans-serif", 14.0))
        .bold_line_style(BLACK.mix(0.08))
        .light_line_style(TRANSPARENT)
        .draw()
        .map_err(draw_err("benchmark figure: mesh"))?;
    for (s, pts) in p.series.iter().zip(&usable) {
        if pts.is_empty() {
            continue;
        }
        let colour = PALETTE[s.colour % PALETTE.len()];
        let style = colour.stroke_width(2);
        let drawn = if s.dashed {
            chart.draw_series(DashedLineSeries::new(pts.iter().copied(), 6, 4, style))
        } else {
            chart.draw_series(LineSeries::new(pts.iter().copied(), style))
        };
        drawn
            .map_err(draw_err("benchmark figure: line"))?
            .label(s.name.as_str())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], style));
        chart
            .draw_series(
                pts.iter()
                    .map(|&(x, y)| Circle::new((x, y), 3, colour.filled())),
            )
            .map_err(draw_err("benchmark figure: points"))?;
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.3))
        .label_font(("sans-serif", 12.0))
        .position(match p.legend {
            Legend::UpperLeft => SeriesLabelPosition::UpperLeft,
            Legend::UpperRight => SeriesLabelPosition::UpperRight,
            Legend::LowerLeft => SeriesLabelPosition::LowerLeft,
            Legend::LowerRight => SeriesLabelPosition::LowerRight,
        })
        .draw()
        .map_err(draw_err("benchmark figure: legend"))?;
    Ok(())
}

fn draw_figure<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    panels: &[Panel],
    cols: usize,
) -> anyhow::Result<()> {
    root.fill(&WHITE)
        .map_err(draw_err("benchmark figure: background"))?;
    let (head, body) = root.split_vertically(TITLE_H);
    head.draw(&Text::new(
        title.to_string(),
        (14, 12),
        ("sans-serif", 20.0).into_font(),
    ))
    .map_err(draw_err("benchmark figure: title"))?;
    let rows = panels.len().div_ceil(cols);
    let cells = body.split_evenly((rows, cols));
    for (cell, p) in cells.iter().zip(panels) {
        draw_panel(cell, p)?;
    }
    Ok(())
}

/// Writes `<stem>.svg` and `<stem>.png` in `dir` (checked and opened as an
/// [`OutDir`]): `panels` in a grid of up to two columns.
pub fn write_figure(dir: &Path, stem: &str, title: &str, panels: &[Panel]) -> anyhow::Result<()> {
    let fig = BenchFigure {
        title,
        panels,
        cols: panels.len().clamp(1, 2),
    };
    let out = OutDir::create(dir).with_context(|| format!("writing into {}", dir.display()))?;
    write_svg_png(&fig, &out, stem)
}

struct BenchFigure<'a> {
    title: &'a str,
    panels: &'a [Panel],
    cols: usize,
}

impl Drawing for BenchFigure<'_> {
    fn size(&self) -> (u32, u32) {
        let rows = self.panels.len().div_ceil(self.cols).max(1);
        (PANEL_W * self.cols as u32, TITLE_H + PANEL_H * rows as u32)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> anyhow::Result<()> {
        draw_figure(root, self.title, self.panels, self.cols)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn figure_with_empty_and_degenerate_series() {
        let dir = tempfile::tempdir().unwrap();
        let panels = vec![
            Panel {
                title: "a".into(),
                x_desc: "x".into(),
                y_desc: "y".into(),
                series: vec![
                    Series {
                        name: "one".into(),
                        points: vec![(64.0, 1e4), (1024.0, 2e4), (1e6, 5e5)],
                        colour: 0,
                        dashed: false,
                    },
                    Series {
                        name: "p99".into(),
                        points: vec![(64.0, 3e4), (1024.0, f64::NAN), (1e6, 0.0)],
                        colour: 0,
                        dashed: true,
                    },
                ],
                legend: Legend::UpperLeft,
            },
            Panel {
                title: "empty".into(),
                x_desc: "x".into(),
                y_desc: "y".into(),
                series: vec![],
                legend: Legend::LowerRight,
            },
            Panel {
                title: "single point".into(),
                x_desc: "x".into(),
                y_desc: "y".into(),
                series: vec![Series {
                    name: "s".into(),
                    points: vec![(3.0, 7.0)],
                    colour: 9,
                    dashed: false,
                }],
                legend: Legend::UpperRight,
            },
        ];
        write_figure(dir.path(), "fig", "test figure", &panels).unwrap();
        let svg = std::fs::read_to_string(dir.path().join("fig.svg")).unwrap();
        assert!(svg.contains("test figure") && svg.contains("single point"));
        let png = std::fs::read(dir.path().join("fig.png")).unwrap();
        assert_eq!(&png[1..4], b"PNG");
        assert_eq!(label(1_500_000.0, false), "1.5M");
        assert_eq!(label(1_500_000.0, true), "");
        assert_eq!(label(50.0, true), "50");
        assert_eq!(label(70.0, true), "");
        assert_eq!(label(2e3, true), "2k");
    }
}
