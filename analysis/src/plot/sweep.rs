//! One sweep figure: a metric against a varied key, one line per value of another key, mean
//! over seeds with a min–max band. Drawn as SVG and PNG with the run plots' embedded font.

use swarmrt_scenario::safe_fs::OutDir;

use plotters::coord::Shift;
use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint, Ranged};
use plotters::prelude::*;

use super::{Drawing, TAB10, draw_err, write_svg_png};
use crate::stats::fmt_num;

/// One x position of a line.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Point {
    /// Position on the x axis.
    pub x: f64,
    /// Mean over seeds (the line).
    pub mean: f64,
    /// Smallest value over seeds (band bottom).
    pub min: f64,
    /// Largest value over seeds (band top).
    pub max: f64,
}

/// One line of the figure.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Legend text.
    pub label: String,
    /// Points in x order.
    pub points: Vec<Point>,
}

/// Everything a figure shows.
#[derive(Debug, Clone, PartialEq)]
pub struct Figure {
    /// Title line.
    pub title: String,
    /// x axis description (the varied key).
    pub x_label: String,
    /// y axis description (the metric).
    pub y_label: String,
    /// Tick positions and their labels: exactly the swept values.
    pub x_ticks: Vec<(f64, String)>,
    /// Legend heading (the key the lines stand for), empty for a single line.
    pub legend_title: String,
    /// The lines.
    pub series: Vec<Series>,
    /// Last legend lines: what the line and band mean.
    pub note: Vec<String>,
}

/// Figure size in pixels.
const SIZE: (u32, u32) = (960, 560);
/// Width of the legend column on the right.
const LEGEND_W: u32 = 230;

fn colour(i: usize) -> RGBColor {
    TAB10[i % TAB10.len()]
}

/// Axis range covering `lo..hi` with a margin; a flat range gets room around it, and data
/// that never goes below zero gets no negative axis.
fn padded(lo: f64, hi: f64, frac: f64) -> (f64, f64) {
    if !(lo.is_finite() && hi.is_finite()) {
        return (0.0, 1.0);
    }
    let span = hi - lo;
    let (a, b) = if span.abs() < 1e-12 {
        let d = if lo == 0.0 { 1.0 } else { lo.abs() * 0.1 };
        (lo - d, hi + d)
    } else {
        (lo - span * frac, hi + span * frac)
    };
    (if lo >= 0.0 { a.max(0.0) } else { a }, b)
}

/// A linear x axis whose ticks are exactly the swept values.
struct SweptAxis {
    lo: f64,
    hi: f64,
    ticks: Vec<f64>,
}

impl Ranged for SweptAxis {
    type FormatOption = DefaultFormatting;
    type ValueType = f64;

    fn map(&self, v: &f64, limit: (i32, i32)) -> i32 {
        let t = (v - self.lo) / (self.hi - self.lo);
        limit.0 + (f64::from(limit.1 - limit.0) * t).round() as i32
    }

    fn key_points<Hint: KeyPointHint>(&self, hint: Hint) -> Vec<f64> {
        if hint.weight().allow_light_points() {
            Vec::new()
        } else {
            self.ticks.clone()
        }
    }

    fn range(&self) -> std::ops::Range<f64> {
        self.lo..self.hi
    }
}

fn draw<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, fig: &Figure) -> anyhow::Result<()> {
    root.fill(&WHITE)
        .map_err(draw_err("sweep plot: background"))?;
    let (plot, legend) = root.split_horizontally(SIZE.0 - LEGEND_W);

    let xs: Vec<f64> = fig.x_ticks.iter().map(|t| t.0).collect();
    let (x_lo, x_hi) = xs
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
            (a.min(x), b.max(x))
        });
    let (x0, x1) = if x_hi > x_lo {
        let pad = (x_hi - x_lo) * 0.05;
        (x_lo - pad, x_hi + pad)
    } else if x_lo.is_finite() {
        (x_lo - 0.5, x_lo + 0.5)
    } else {
        (0.0, 1.0)
    };
    let points = fig.series.iter().flat_map(|s| &s.points);
    let (y_lo, y_hi) = points.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
        (a.min(p.min), b.max(p.max))
    });
    let (y0, y1) = padded(y_lo, y_hi, 0.08);

    let label_of = |v: &f64| {
        fig.x_ticks
            .iter()
            .find(|(x, _)| (x - v).abs() <= 1e-9 * (1.0 + x.abs()))
            .map(|(_, l)| l.clone())
            .unwrap_or_default()
    };
    let mut chart = ChartBuilder::on(&plot)
        .caption(&fig.title, ("sans-serif", 20.0))
        .margin(14)
        .x_label_area_size(52)
        .y_label_area_size(72)
        .build_cartesian_2d(
            SweptAxis {
                lo: x0,
                hi: x1,
                ticks: xs,
            },
            y0..y1,
        )
        .map_err(draw_err("sweep plot: axes"))?;
    chart
        .configure_mesh()
        .x_desc(fig.x_label.as_str())
        .y_desc(fig.y_label.as_str())
        .x_label_formatter(&label_of)
        .y_label_formatter(&|v: &f64| fmt_num(*v))
        .y_labels(8)
        .label_style(("sans-serif", 14.0))
        .axis_desc_style(("sans-serif", 16.0))
        .bold_line_style(BLACK.mix(0.08))
        .light_line_style(TRANSPARENT)
        .axis_style(BLACK.stroke_width(1))
        .draw()
        .map_err(draw_err("sweep plot: mesh"))?;

    for (i, s) in fig.series.iter().enumerate() {
        let c = colour(i);
        if s.points.len() >= 2 {
            let mut band: Vec<(f64, f64)> = s.points.iter().map(|p| (p.x, p.max)).collect();
            band.extend(s.points.iter().rev().map(|p| (p.x, p.min)));
            chart
                .draw_series(std::iter::once(Polygon::new(band, c.mix(0.15).filled())))
                .map_err(draw_err("sweep plot: band"))?;
        } else {
            // A single x: whiskers instead of a band.
            chart
                .draw_series(
                    s.points.iter().map(|p| {
                        PathElement::new(vec![(p.x, p.min), (p.x, p.max)], c.stroke_width(2))
                    }),
                )
                .map_err(draw_err("sweep plot: whisker"))?;
        }
        chart
            .draw_series(LineSeries::new(
                s.points.iter().map(|p| (p.x, p.mean)),
                c.stroke_width(2),
            ))
            .map_err(draw_err("sweep plot: line"))?;
        chart
            .draw_series(
                s.points
                    .iter()
                    .map(|p| Circle::new((p.x, p.mean), 4, c.filled())),
            )
            .map_err(draw_err("sweep plot: markers"))?;
    }
    draw_legend(&legend, fig)
}

/// The legend column: heading, one entry per line, then the note.
fn draw_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    fig: &Figure,
) -> anyhow::Result<()> {
    let ink = RGBColor(60, 60, 60);
    let text = ("sans-serif", 14.0).into_font().color(&ink);
    let head = ("sans-serif", 15.0).into_font().color(&BLACK);
    let mut y = 60;
    if !fig.legend_title.is_empty() {
        area.draw_text(&fig.legend_title, &head, (8, y))
            .map_err(draw_err("sweep plot: legend"))?;
        y += 26;
    }
    for (i, s) in fig.series.iter().enumerate() {
        let c = colour(i);
        area.draw(&Rectangle::new(
            [(8, y + 1), (36, y + 13)],
            c.mix(0.15).filled(),
        ))
        .and_then(|()| {
            area.draw(&PathElement::new(
                vec![(8, y + 7), (36, y + 7)],
                c.stroke_width(2),
            ))
        })
        .and_then(|()| area.draw(&Circle::new((22, y + 7), 4, c.filled())))
        .and_then(|()| area.draw_text(&s.label, &text, (44, y)))
        .map_err(draw_err("sweep plot: legend"))?;
        y += 24;
    }
    y += 12;
    for line in &fig.note {
        area.draw_text(line, &text, (8, y))
            .map_err(draw_err("sweep plot: legend"))?;
        y += 20;
    }
    Ok(())
}

/// Writes the figure as `<stem>.svg` and `<stem>.png` in `dir`.
pub fn write(fig: &Figure, dir: &OutDir, stem: &str) -> anyhow::Result<()> {
    write_svg_png(fig, dir, stem)
}

impl Drawing for Figure {
    fn size(&self) -> (u32, u32) {
        SIZE
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> anyhow::Result<()> {
        draw(root, self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn figure(series: Vec<Series>) -> Figure {
        Figure {
            title: "goto: collisions vs radio.loss".into(),
            x_label: "radio.loss".into(),
            y_label: "collisions".into(),
            x_ticks: vec![(0.0, "0".into()), (0.1, "0.1".into()), (0.4, "0.4".into())],
            legend_title: "radio.delay_ticks".into(),
            series,
            note: vec!["line: mean over 3 seeds".into(), "band: min–max".into()],
        }
    }

    /// The trimmed contents of every `<text>` element.
    fn svg_texts(svg: &str) -> Vec<String> {
        svg.split("<text")
            .skip(1)
            .filter_map(|t| {
                let body = t.split_once('>')?.1;
                Some(body.split_once("</text>")?.0.trim().to_string())
            })
            .collect()
    }

    fn line(label: &str, ys: &[f64]) -> Series {
        Series {
            label: label.into(),
            points: [0.0, 0.1, 0.4]
                .iter()
                .zip(ys)
                .map(|(&x, &y)| Point {
                    x,
                    mean: y,
                    min: y - 1.0,
                    max: y + 1.0,
                })
                .collect(),
        }
    }

    #[test]
    fn writes_svg_and_png_with_labels() {
        let dir = tempfile::tempdir().unwrap();
        let (svg, png) = (dir.path().join("f.svg"), dir.path().join("f.png"));
        write(
            &figure(vec![
                line("0", &[1.0, 2.0, 3.0]),
                line("8", &[2.0, 2.0, 5.0]),
            ]),
            &OutDir::open(dir.path()).unwrap(),
            "f",
        )
        .unwrap();
        let text = std::fs::read_to_string(&svg).unwrap();
        assert!(text.starts_with("<svg"));
        let texts = svg_texts(&text);
        for needle in [
            "goto: collisions vs radio.loss",
            "radio.loss",
            "collisions",
            "radio.delay_ticks",
            "0.1",
            "0.4",
            "8",
            "band: min–max",
        ] {
            assert!(
                texts.iter().any(|t| t == needle),
                "svg lacks {needle}: {texts:?}"
            );
        }
        // y ticks of whole numbers read as whole numbers.
        assert!(texts.iter().any(|t| t == "2"), "{texts:?}");
        let bytes = std::fs::read(&png).unwrap();
        assert_eq!(&bytes[1..4], b"PNG");
    }

    #[test]
    fn flat_and_single_point_figures_draw() {
        let dir = tempfile::tempdir().unwrap();
        let (svg, png) = (dir.path().join("f.svg"), dir.path().join("f.png"));
        let mut fig = figure(vec![Series {
            label: "all".into(),
            points: vec![Point {
                x: 0.0,
                mean: 0.0,
                min: 0.0,
                max: 0.0,
            }],
        }]);
        fig.x_ticks.truncate(1);
        write(&fig, &OutDir::open(dir.path()).unwrap(), "f").unwrap();
        assert!(svg.is_file() && png.is_file());
        assert_eq!(padded(0.0, 0.0, 0.1), (0.0, 1.0));
        assert_eq!(padded(1.0, 3.0, 0.5), (0.0, 4.0));
        assert_eq!(padded(-1.0, 1.0, 0.5), (-2.0, 2.0));
    }
}
