//! The trajectory figure of a run: the map, every robot's path, start and end markers.
//!
//! Rendered twice with plotters, once as SVG and once as PNG (see [`super`]).

use swarmrt_scenario::safe_fs::OutDir;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use swarmrt_protocol::RobotState;
use swarmrt_scenario::Config;

use super::{Drawing, TAB10, draw_err, write_svg_png};

/// One robot's path for the plot.
#[derive(Debug, Clone, PartialEq)]
pub struct RobotTrack {
    /// The robot id.
    pub id: u32,
    /// Positions in tick order; the first is the start.
    pub points: Vec<(f64, f64)>,
    /// The robot's state at the end of the run.
    pub final_state: RobotState,
}

/// Length of the long side of the figure in pixels.
const LONG_SIDE: u32 = 900;
/// Height of the title line in the header, pixels.
const TITLE_H: u32 = 40;
/// Height of one legend row in the header, pixels.
const LEGEND_ROW_H: u32 = 24;
/// Gap between the header and the top of the plot area, room for the top tick label.
const TOP_GAP: u32 = 10;
/// Width of the y label area (tick labels and "y (m)").
const LEFT: u32 = 72;
/// Height of the x label area (tick labels and "x (m)").
const BOTTOM: u32 = 56;
/// Right margin, room for the last x tick label.
const RIGHT: u32 = 28;
/// Smallest plot area width, so the title fits (the legend wraps).
const MIN_PLOT_W: u32 = 460;
/// Smallest plot area height, so a very flat map still reads.
const MIN_PLOT_H: u32 = 200;

/// Qualitative palette for the first robots (tab10 without red, green and grey, which mean
/// "down or dead", "goal" and "obstacle" here).
const PALETTE: [RGBColor; 7] = [
    TAB10[0], TAB10[1], TAB10[4], TAB10[5], TAB10[6], TAB10[8], TAB10[9],
];
const OBSTACLE_FILL: RGBColor = RGBColor(170, 170, 170);
const OBSTACLE_EDGE: RGBColor = RGBColor(110, 110, 110);
const GOAL: RGBColor = RGBColor(0, 150, 0);
const CROSS: RGBColor = RGBColor(214, 39, 40);
const LEGEND_INK: RGBColor = RGBColor(60, 60, 60);

/// Colour of the `i`-th track: the palette first, then golden-angle hues.
fn track_colour(i: usize) -> RGBColor {
    if let Some(c) = PALETTE.get(i) {
        return *c;
    }
    let hue = (i as f64 * 0.618_033_988_75).fract();
    let light = if i.is_multiple_of(2) { 0.42 } else { 0.55 };
    let bc = HSLColor(hue, 0.70, light).to_backend_color();
    RGBColor(bc.rgb.0, bc.rgb.1, bc.rgb.2)
}

/// Pixel geometry of the figure and the data window it shows (equal scale on both axes).
#[derive(Debug, Clone, PartialEq)]
struct Layout {
    width: u32,
    height: u32,
    /// Header height (title and legend rows) in pixels.
    header: u32,
    /// Legend items (indices into [`LEGEND`]) per row.
    legend: Vec<Vec<usize>>,
    plot_w: u32,
    plot_h: u32,
    x: (f64, f64),
    y: (f64, f64),
    /// Pixels per metre.
    scale: f64,
}

/// Running bounding box over finite points.
#[derive(Debug, Clone, Copy)]
struct BBox {
    min_x: f64,
    min_y: f64,
    max_x: f64,
    max_y: f64,
}

impl BBox {
    fn empty() -> Self {
        BBox {
            min_x: f64::INFINITY,
            min_y: f64::INFINITY,
            max_x: f64::NEG_INFINITY,
            max_y: f64::NEG_INFINITY,
        }
    }

    fn add(&mut self, x: f64, y: f64) {
        if x.is_finite() && y.is_finite() {
            self.min_x = self.min_x.min(x);
            self.min_y = self.min_y.min(y);
            self.max_x = self.max_x.max(x);
            self.max_y = self.max_y.max(y);
        }
    }

    fn is_empty(&self) -> bool {
        self.min_x > self.max_x || self.min_y > self.max_y
    }
}

/// The region that must be visible: bounds, goal, obstacles and every track point.
fn content_box(cfg: &Config, tracks: &[RobotTrack]) -> BBox {
    let map = &cfg.map;
    let mut b = BBox::empty();
    let [x0, y0, x1, y1] = map.bounds;
    b.add(x0, y0);
    b.add(x1, y1);
    for g in cfg.goals() {
        b.add(g.x - g.radius.abs(), g.y - g.radius.abs());
        b.add(g.x + g.radius.abs(), g.y + g.radius.abs());
    }
    for c in &map.circles {
        b.add(c.x - c.r.abs(), c.y - c.r.abs());
        b.add(c.x + c.r.abs(), c.y + c.r.abs());
    }
    for r in &map.rectangles {
        b.add(r.x_min, r.y_min);
        b.add(r.x_max, r.y_max);
    }
    for p in map.polygons.iter().flat_map(|p| p.points.iter()) {
        b.add(p[0], p[1]);
    }
    for &(x, y) in tracks.iter().flat_map(|t| t.points.iter()) {
        b.add(x, y);
    }
    if b.is_empty() {
        b = BBox {
            min_x: 0.0,
            min_y: 0.0,
            max_x: 1.0,
            max_y: 1.0,
        };
    }
    b
}

/// Centred window of width `span` around the middle of `[lo, hi]`.
fn centred(lo: f64, hi: f64, span: f64) -> (f64, f64) {
    let mid = lo / 2.0 + hi / 2.0;
    (mid - span / 2.0, mid + span / 2.0)
}

/// Chooses the figure size (long side [`LONG_SIDE`]) and a data window with equal scale.
fn layout(cfg: &Config, tracks: &[RobotTrack]) -> Layout {
    let b = content_box(cfg, tracks);
    // Spans, never zero (and never overflowing to infinity for huge coordinates).
    let min_span = |lo: f64, hi: f64| {
        let s = hi / 2.0 - lo / 2.0;
        let floor = (lo.abs().max(hi.abs()) * 1e-9).max(1e-6);
        if s.is_finite() {
            s.max(floor)
        } else {
            f64::MAX / 4.0
        }
    };
    let half_dx = min_span(b.min_x, b.max_x);
    let half_dy = min_span(b.min_y, b.max_y);
    // A small margin around the content, the same in metres on every side.
    let pad = half_dx.max(half_dy) * 0.06;
    let dx = 2.0 * (half_dx + pad);
    let dy = 2.0 * (half_dy + pad);

    let widths = legend_widths();
    let mut rows = 1;
    let mut guard = 0;
    loop {
        let header = header_height(rows);
        let avail_w = f64::from(LONG_SIDE - LEFT - RIGHT);
        let avail_h = f64::from(LONG_SIDE - header - TOP_GAP - BOTTOM);
        let scale = (avail_w / dx).min(avail_h / dy);
        let plot_w = ((dx * scale).round() as u32).clamp(MIN_PLOT_W, avail_w as u32);
        let plot_h = ((dy * scale).round() as u32).clamp(MIN_PLOT_H, avail_h as u32);
        let width = LEFT + plot_w + RIGHT;
        let legend = legend_rows(width, &widths);
        guard += 1;
        if legend.len() > rows && guard < LEGEND.len() {
            // A narrower figure needs more legend rows: recompute with a taller header.
            rows = legend.len();
            continue;
        }
        // Re-derive the window from the whole pixel sizes so both axes share one scale.
        let x = centred(b.min_x, b.max_x, f64::from(plot_w) / scale);
        let y = centred(b.min_y, b.max_y, f64::from(plot_h) / scale);
        return Layout {
            width,
            height: header + TOP_GAP + plot_h + BOTTOM,
            header,
            legend,
            plot_w,
            plot_h,
            x,
            y,
            scale,
        };
    }
}

/// Header height for a legend of `rows` rows.
fn header_height(rows: usize) -> u32 {
    TITLE_H + LEGEND_ROW_H * rows.max(1) as u32 + 6
}

/// Legend markers.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Mark {
    Path,
    Start,
    EndActive,
    EndDown,
    Goal,
    Obstacle,
}

/// The legend: marker and label.
const LEGEND: [(Mark, &str); 6] = [
    (Mark::Path, "path (one colour per robot)"),
    (Mark::Start, "start"),
    (Mark::EndActive, "end, active"),
    (Mark::EndDown, "end, down/dead"),
    (Mark::Goal, "goal"),
    (Mark::Obstacle, "obstacle"),
];
/// Legend font size.
const LEGEND_FONT: f64 = 14.0;
/// Width of a legend marker, gap to its label, gap between items (pixels).
const MARKER_W: i32 = 22;
const MARKER_GAP: i32 = 6;
const ITEM_GAP: i32 = 18;

/// Pixel width of each legend item (marker and label) in the embedded font.
fn legend_widths() -> Vec<i32> {
    let font = ("sans-serif", LEGEND_FONT).into_font();
    LEGEND
        .iter()
        .map(|(_, label)| {
            let text_w = font
                .box_size(label)
                .map(|(w, _)| w as i32)
                .unwrap_or(label.len() as i32 * 8);
            MARKER_W + MARKER_GAP + text_w
        })
        .collect()
}

/// Greedy wrapping of the legend items into rows that fit `width` pixels.
fn legend_rows(width: u32, widths: &[i32]) -> Vec<Vec<usize>> {
    let avail = width as i32 - 60;
    let mut rows: Vec<Vec<usize>> = vec![Vec::new()];
    let mut used = 0;
    for (i, &w) in widths.iter().enumerate() {
        let row = rows.last_mut().expect("at least one row");
        if !row.is_empty() && used + ITEM_GAP + w > avail {
            rows.push(vec![i]);
            used = w;
        } else {
            used += if row.is_empty() { w } else { ITEM_GAP + w };
            row.push(i);
        }
    }
    rows
}

/// Tick label text: fixed decimals chosen from the span, scientific for huge values.
fn tick_label(v: f64, span: f64, max_abs: f64) -> String {
    if max_abs >= 1e5 {
        if v == 0.0 {
            return "0".to_string();
        }
        // "1.50e6" -> "1.5e6", "1.00e6" -> "1e6".
        let sci = format!("{v:.2e}");
        return match sci.split_once('e') {
            Some((mantissa, exp)) if mantissa.contains('.') => {
                let m = mantissa.trim_end_matches('0').trim_end_matches('.');
                format!("{m}e{exp}")
            }
            _ => sci,
        };
    }
    let decimals = (1.0 - span.log10().floor()).clamp(0.0, 6.0) as usize;
    let s = format!("{v:.decimals$}");
    // Avoid "-0" and "-0.0".
    if s.trim_start_matches('-')
        .chars()
        .all(|c| c == '0' || c == '.')
    {
        s.trim_start_matches('-').to_string()
    } else {
        s
    }
}

/// Title text: "<scenario name> seed <seed>: N robots".
fn title(cfg: &Config, n: usize) -> String {
    let noun = if n == 1 { "robot" } else { "robots" };
    format!(
        "{} seed {}: {n} {noun}",
        cfg.scenario.name, cfg.scenario.seed
    )
}

/// Points of a closed circle polygon in data coordinates.
fn circle_points(cx: f64, cy: f64, r: f64) -> Vec<(f64, f64)> {
    const N: usize = 128;
    (0..=N)
        .map(|k| {
            let a = std::f64::consts::TAU * k as f64 / N as f64;
            (cx + r * a.cos(), cy + r * a.sin())
        })
        .collect()
}

/// Draws the header: the title on the first line and the marker legend below it.
fn draw_header<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    lay: &Layout,
    title_text: &str,
) -> anyhow::Result<()> {
    let w = lay.width as i32;
    // Title, shrunk if the scenario name is very long.
    let mut size = 22.0;
    let mut style = TextStyle::from(("sans-serif", size).into_font()).color(&BLACK);
    while size > 10.0 {
        let (tw, _) = area
            .estimate_text_size(title_text, &style)
            .map_err(draw_err("trajectory plot: title size"))?;
        if (tw as i32) < w - 20 {
            break;
        }
        size -= 1.0;
        style = TextStyle::from(("sans-serif", size).into_font()).color(&BLACK);
    }
    let style = style.pos(Pos::new(HPos::Center, VPos::Top));
    area.draw_text(title_text, &style, (w / 2, 8))
        .map_err(draw_err("trajectory plot: title"))?;

    // Legend: rows of (marker, label) pairs, each row centred.
    let label_style = TextStyle::from(("sans-serif", LEGEND_FONT).into_font())
        .color(&LEGEND_INK)
        .pos(Pos::new(HPos::Left, VPos::Center));
    let widths = legend_widths();
    for (r, row) in lay.legend.iter().enumerate() {
        let total: i32 =
            row.iter().map(|&i| widths[i]).sum::<i32>() + ITEM_GAP * (row.len() as i32 - 1).max(0);
        let mut x = ((w - total) / 2).max(4);
        let y = (TITLE_H + LEGEND_ROW_H * r as u32 + LEGEND_ROW_H / 2) as i32;
        for &i in row {
            let (mark, label) = LEGEND[i];
            draw_legend_mark(area, mark, x, y)?;
            area.draw_text(label, &label_style, (x + MARKER_W + MARKER_GAP, y))
                .map_err(draw_err("trajectory plot: legend label"))?;
            x += widths[i] + ITEM_GAP;
        }
    }
    Ok(())
}

/// Draws one legend marker in the box starting at `x`, centred vertically on `y`.
fn draw_legend_mark<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    mark: Mark,
    x: i32,
    y: i32,
) -> anyhow::Result<()> {
    let cx = x + MARKER_W / 2;
    let ink = LEGEND_INK;
    let res = match mark {
        Mark::Path => area.draw(&PathElement::new(
            vec![(x, y), (x + MARKER_W, y)],
            PALETTE[0].stroke_width(2),
        )),
        Mark::Start => area.draw(&Circle::new((cx, y), 6, ink.stroke_width(1))),
        Mark::EndActive => area.draw(&Circle::new((cx, y), 5, ink.filled())),
        Mark::EndDown => area
            .draw(&PathElement::new(
                vec![(cx - 5, y - 5), (cx + 5, y + 5)],
                CROSS.stroke_width(2),
            ))
            .and_then(|()| {
                area.draw(&PathElement::new(
                    vec![(cx - 5, y + 5), (cx + 5, y - 5)],
                    CROSS.stroke_width(2),
                ))
            }),
        Mark::Goal => area
            .draw(&Circle::new((cx, y), 8, GOAL.mix(0.12).filled()))
            .and_then(|()| area.draw(&Circle::new((cx, y), 8, GOAL.stroke_width(2)))),
        Mark::Obstacle => {
            let corners = [(cx - 7, y - 7), (cx + 7, y + 7)];
            area.draw(&Rectangle::new(corners, OBSTACLE_FILL.filled()))
                .and_then(|()| area.draw(&Rectangle::new(corners, OBSTACLE_EDGE.stroke_width(1))))
        }
    };
    res.map_err(draw_err("trajectory plot: legend marker"))
}

/// Draws the whole figure on `root`, whose size is `lay.width` x `lay.height`.
fn draw_figure<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    lay: &Layout,
    cfg: &Config,
    tracks: &[RobotTrack],
    axes: (&str, &str),
) -> anyhow::Result<()> {
    root.fill(&WHITE)
        .map_err(draw_err("trajectory plot: background"))?;
    let (header, body) = root.split_vertically(lay.header + TOP_GAP);
    draw_header(&header, lay, &title(cfg, tracks.len()))?;

    let body = body.margin(0, 0, 0, RIGHT);
    let span = (lay.x.1 - lay.x.0).max(lay.y.1 - lay.y.0);
    let max_abs = [lay.x.0, lay.x.1, lay.y.0, lay.y.1]
        .iter()
        .fold(0.0_f64, |m, v| m.max(v.abs()));
    let fmt = move |v: &f64| tick_label(*v, span, max_abs);

    let mut chart = ChartBuilder::on(&body)
        .x_label_area_size(BOTTOM)
        .y_label_area_size(LEFT)
        .build_cartesian_2d(lay.x.0..lay.x.1, lay.y.0..lay.y.1)
        .map_err(draw_err("trajectory plot: axes"))?;
    chart
        .configure_mesh()
        .x_desc(axes.0)
        .y_desc(axes.1)
        .x_labels((lay.plot_w / 90).max(3) as usize)
        .y_labels((lay.plot_h / 70).max(3) as usize)
        .x_label_formatter(&fmt)
        .y_label_formatter(&fmt)
        .label_style(("sans-serif", 14.0))
        .axis_desc_style(("sans-serif", 16.0))
        .bold_line_style(BLACK.mix(0.08))
        .light_line_style(TRANSPARENT)
        .axis_style(BLACK.stroke_width(1))
        .draw()
        .map_err(draw_err("trajectory plot: mesh"))?;

    let map = &cfg.map;
    let area = chart.plotting_area();
    let px = |metres: f64, lo: f64, hi: f64| (metres.abs() * lay.scale).clamp(lo, hi);

    // Goal (under everything), obstacles, then the arena walls.
    let mut goal_rings = Vec::new();
    for g in cfg.goals() {
        let ring = circle_points(g.x, g.y, g.radius.abs());
        area.draw(&Polygon::new(ring.clone(), GOAL.mix(0.12).filled()))
            .map_err(draw_err("trajectory plot: goal"))?;
        goal_rings.push(ring);
    }
    for c in &map.circles {
        let ring = circle_points(c.x, c.y, c.r.abs());
        area.draw(&Polygon::new(ring.clone(), OBSTACLE_FILL.filled()))
            .and_then(|()| area.draw(&PathElement::new(ring, OBSTACLE_EDGE.stroke_width(1))))
            .map_err(draw_err("trajectory plot: circle obstacle"))?;
    }
    for r in &map.rectangles {
        let corners = [(r.x_min, r.y_min), (r.x_max, r.y_max)];
        area.draw(&Rectangle::new(corners, OBSTACLE_FILL.filled()))
            .and_then(|()| area.draw(&Rectangle::new(corners, OBSTACLE_EDGE.stroke_width(1))))
            .map_err(draw_err("trajectory plot: rectangle obstacle"))?;
    }
    for p in &map.polygons {
        let pts: Vec<(f64, f64)> = p.points.iter().map(|q| (q[0], q[1])).collect();
        if pts.is_empty() {
            continue;
        }
        let mut ring = pts.clone();
        ring.push(pts[0]);
        area.draw(&Polygon::new(pts, OBSTACLE_FILL.filled()))
            .and_then(|()| area.draw(&PathElement::new(ring, OBSTACLE_EDGE.stroke_width(1))))
            .map_err(draw_err("trajectory plot: polygon obstacle"))?;
    }
    // A closed path rather than a rectangle: the SVG backend ignores a rectangle's stroke width.
    let [bx0, by0, bx1, by1] = map.bounds;
    let frame = vec![(bx0, by0), (bx1, by0), (bx1, by1), (bx0, by1), (bx0, by0)];
    area.draw(&PathElement::new(frame, BLACK.stroke_width(2)))
        .map_err(draw_err("trajectory plot: bounds"))?;
    for ring in goal_rings {
        area.draw(&PathElement::new(ring, GOAL.stroke_width(2)))
            .map_err(draw_err("trajectory plot: goal"))?;
    }

    // Paths first, markers on top of all paths.
    let line_w = if tracks.len() <= 30 { 2 } else { 1 };
    let clean: Vec<Vec<(f64, f64)>> = tracks
        .iter()
        .map(|t| {
            t.points
                .iter()
                .copied()
                .filter(|(x, y)| x.is_finite() && y.is_finite())
                .collect()
        })
        .collect();
    for (i, pts) in clean.iter().enumerate() {
        let Some(&first) = pts.first() else { continue };
        let mut path = pts.clone();
        if path.len() == 1 {
            path.push(first);
        }
        area.draw(&PathElement::new(
            path,
            track_colour(i).stroke_width(line_w),
        ))
        .map_err(draw_err("trajectory plot: path"))?;
    }
    let body_r = px(cfg.robots.radius, 3.0, 30.0).round() as i32;
    let dot_r = px(cfg.robots.radius, 2.5, 30.0).round() as i32;
    let arm = body_r.max(4);
    for (i, pts) in clean.iter().enumerate() {
        let (Some(&start), Some(&end)) = (pts.first(), pts.last()) else {
            continue;
        };
        let colour = track_colour(i);
        area.draw(&Circle::new(start, body_r, colour.stroke_width(line_w)))
            .map_err(draw_err("trajectory plot: start marker"))?;
        let end_marker = match tracks[i].final_state {
            RobotState::Active | RobotState::Frozen | RobotState::Restarting => {
                area.draw(&Circle::new(end, dot_r, colour.filled()))
            }
            RobotState::Down | RobotState::Dead => {
                let style = CROSS.stroke_width(2);
                area.draw(
                    &(EmptyElement::at(end)
                        + PathElement::new(vec![(-arm, -arm), (arm, arm)], style)
                        + PathElement::new(vec![(-arm, arm), (arm, -arm)], style)),
                )
            }
        };
        end_marker.map_err(draw_err("trajectory plot: end marker"))?;
    }
    Ok(())
}

/// Draws the map (bounds as a frame, obstacles filled grey, goal as a green disc outline), each robot's path in a distinct colour, start positions (hollow circle of robot radius), end positions (filled dot when Active, a red cross when Down or Dead), and a title "<scenario name> seed <seed>: N robots" plus a small legend for the markers. Writes both an SVG and a PNG (about 900 px on the long side, aspect ratio of the map kept, axis labels in metres).
///
/// The files are `<stem>.svg` and `<stem>.png` in `dir`.
pub fn write_trajectory_plots(
    cfg: &Config,
    tracks: &[RobotTrack],
    dir: &OutDir,
    stem: &str,
) -> anyhow::Result<()> {
    write_figure(cfg, tracks, ("x (m)", "y (m)"), dir, stem)
}

fn write_figure(
    cfg: &Config,
    tracks: &[RobotTrack],
    axes: (&'static str, &'static str),
    dir: &OutDir,
    stem: &str,
) -> anyhow::Result<()> {
    super::ensure_font()?;
    let fig = TrajectoryFigure {
        lay: layout(cfg, tracks),
        cfg,
        tracks,
        axes,
    };
    write_svg_png(&fig, dir, stem)
}

/// The side view of an aerial run: the same figure in the (y, z) plane, looking west along
/// x. `tracks` hold `(y, z)` points; obstacles are drawn as their y extent up to their
/// height (the ceiling for those without one), each goal at its height.
pub fn write_side_view_plots(
    cfg: &Config,
    tracks: &[RobotTrack],
    dir: &OutDir,
    stem: &str,
) -> anyhow::Result<()> {
    write_figure(&side_view(cfg), tracks, ("y (m)", "z (m)"), dir, stem)
}

/// `cfg` projected on the (y, z) plane for [`write_side_view_plots`].
fn side_view(cfg: &Config) -> Config {
    use swarmrt_scenario::RectObstacle;
    let mut side = cfg.clone();
    let top = cfg.map.height.unwrap_or(1.0);
    let [_, y0, _, y1] = cfg.map.bounds;
    let m = &mut side.map;
    m.bounds = [y0, 0.0, y1, top];
    let column = |y_min: f64, y_max: f64, h: Option<f64>| RectObstacle {
        x_min: y_min,
        y_min: 0.0,
        x_max: y_max,
        y_max: h.unwrap_or(top).min(top),
        height: None,
    };
    let mut rects: Vec<RectObstacle> = Vec::new();
    rects.extend(
        cfg.map
            .circles
            .iter()
            .map(|c| column(c.y - c.r, c.y + c.r, c.height)),
    );
    rects.extend(
        cfg.map
            .rectangles
            .iter()
            .map(|r| column(r.y_min, r.y_max, r.height)),
    );
    rects.extend(cfg.map.polygons.iter().map(|p| {
        let ys = p.points.iter().map(|q| q[1]);
        let lo = ys.clone().fold(f64::INFINITY, f64::min);
        let hi = ys.fold(f64::NEG_INFINITY, f64::max);
        column(lo, hi, p.height)
    }));
    m.rectangles = rects;
    m.circles.clear();
    m.polygons.clear();
    m.goal.x = cfg.map.goal.y;
    m.goal.y = cfg.map.goal.z.unwrap_or(0.0);
    for (g, group) in side.robots.start.groups.iter_mut().enumerate() {
        // Each group's goal at its height (goal_of gives aerial robots one).
        if let Some(id) = (0..cfg.robots.count).find(|&i| cfg.start_group(i) == g) {
            let goal = cfg.goal_of(id);
            group.goal = Some([goal.y, goal.z.unwrap_or(0.0)]);
        }
    }
    side.robots.aerial = None;
    side.scenario.name = format!("{} (side view)", cfg.scenario.name);
    side
}

struct TrajectoryFigure<'a> {
    lay: Layout,
    cfg: &'a Config,
    tracks: &'a [RobotTrack],
    axes: (&'static str, &'static str),
}

impl Drawing for TrajectoryFigure<'_> {
    fn size(&self) -> (u32, u32) {
        (self.lay.width, self.lay.height)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> anyhow::Result<()> {
        draw_figure(root, &self.lay, self.cfg, self.tracks, self.axes)
    }
}

#[cfg(test)]
mod tests;
