//! A behaviour's per-tick table as a line plot: chosen columns against one, one line per
//! column and per value of a grouping column (e.g. p'(t) and p̄(t) per flock).

use swarmrt_scenario::safe_fs::OutDir;

use plotters::coord::Shift;
use plotters::prelude::*;
use swarmrt_agent::behaviour::{Series, SeriesPlot};

use super::{Drawing, TAB10, draw_err, write_svg_png};

/// One line: legend and points.
type Line = (String, Vec<(f64, f64)>);

struct Figure {
    title: String,
    x_label: String,
    y_label: String,
    lines: Vec<Line>,
}

/// The lines `plot` asks for from `s`; columns it names that `s` lacks give no line.
fn lines(s: &Series, plot: &SeriesPlot) -> Vec<Line> {
    let col = |name: &str| s.columns.iter().position(|c| *c == name);
    let Some(x) = col(plot.x) else {
        return Vec::new();
    };
    let group = plot.group_by.and_then(col);
    let mut groups: Vec<f64> = match group {
        Some(g) => s.rows.iter().map(|r| r[g]).collect(),
        None => vec![0.0],
    };
    groups.sort_by(f64::total_cmp);
    groups.dedup();
    let mut out = Vec::new();
    for &gv in &groups {
        for name in &plot.lines {
            let Some(y) = col(name) else { continue };
            let pts: Vec<(f64, f64)> = s
                .rows
                .iter()
                .filter(|r| group.is_none_or(|g| r[g] == gv))
                .map(|r| (r[x], r[y]))
                .filter(|(a, b)| a.is_finite() && b.is_finite())
                .collect();
            let label = match (plot.group_by, group) {
                (Some(g), Some(_)) if groups.len() > 1 => format!("{name}, {g} {gv}"),
                _ => name.to_string(),
            };
            out.push((label, pts));
        }
    }
    out
}

impl Drawing for Figure {
    fn size(&self) -> (u32, u32) {
        (960, 540)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> anyhow::Result<()> {
        root.fill(&WHITE).map_err(draw_err("background"))?;
        let all = self.lines.iter().flat_map(|(_, p)| p.iter());
        let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, 0.0f64, f64::MIN);
        for &(x, y) in all {
            x0 = x0.min(x);
            x1 = x1.max(x);
            y0 = y0.min(y);
            y1 = y1.max(y);
        }
        if x0 >= x1 {
            (x0, x1) = (0.0, 1.0);
        }
        if y1 <= y0 {
            y1 = y0 + 1.0;
        }
        let y1 = y1 + (y1 - y0) * 0.05;
        let mut chart = ChartBuilder::on(root)
            .caption(&self.title, ("sans-serif", 20))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(draw_err("axes"))?;
        chart
            .configure_mesh()
            .x_desc(&self.x_label)
            .y_desc(&self.y_label)
            .max_light_lines(1)
            .label_style(("sans-serif", 14))
            .draw()
            .map_err(draw_err("grid"))?;
        for (i, (label, pts)) in self.lines.iter().enumerate() {
            let c = TAB10[i % TAB10.len()];
            chart
                .draw_series(LineSeries::new(pts.iter().copied(), c.stroke_width(2)))
                .map_err(draw_err("line"))?
                .label(label.as_str())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 18, y)], c.stroke_width(2))
                });
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(("sans-serif", 14))
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(draw_err("legend"))?;
        Ok(())
    }
}

/// Draws `plot` of `s` as `<plot.file>.svg` and `.png` in `dir`.
pub fn write_series_plot(s: &Series, plot: &SeriesPlot, dir: &OutDir) -> anyhow::Result<()> {
    let fig = Figure {
        title: plot.title.clone(),
        x_label: plot.x.to_string(),
        y_label: plot.y_label.to_string(),
        lines: lines(s, plot),
    };
    write_svg_png(&fig, dir, plot.file)
}
