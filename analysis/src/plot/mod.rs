//! One plotting module for every figure swarmrt draws: a run's trajectories
//! ([`trajectory`]) and its behaviour's per-tick tables ([`series`]), a sweep's metric plots
//! ([`sweep`]), a tune's progress ([`tune`]) and the benchmark figures ([`bench`]).
//!
//! They share what is here: the embedded font (plotters' `ab_glyph` feature, so no system
//! font library is needed), the tab10 palette, plotters' errors as `anyhow` errors, and one
//! writer that renders a [`Drawing`] as SVG and as PNG.

pub mod bench;
pub mod series;
pub mod sweep;
pub mod trajectory;
pub mod tune;

use std::fmt::Display;
use std::path::Path;
use std::sync::OnceLock;

use anyhow::{Context, anyhow};
use plotters::coord::Shift;
use plotters::prelude::*;
use swarmrt_scenario::safe_fs;

/// The embedded font, registered with plotters as "sans-serif".
static FONT_BYTES: &[u8] = include_bytes!("../../assets/DejaVuSans.ttf");

/// tab10, a palette readers know.
pub const TAB10: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

/// Registers the embedded font once; later calls return the first outcome.
pub fn ensure_font() -> anyhow::Result<()> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        plotters::style::register_font("sans-serif", FontStyle::Normal, FONT_BYTES).is_ok()
    });
    if ok {
        Ok(())
    } else {
        Err(anyhow!("the embedded plot font could not be loaded"))
    }
}

/// Turns a plotters drawing error into an `anyhow::Error` naming what was being drawn
/// (plotters' error types are not `'static` for every backend, so keep only the message).
pub fn draw_err<E: Display>(what: &'static str) -> impl Fn(E) -> anyhow::Error {
    move |e| anyhow!("drawing the {what}: {e}")
}

/// A figure that can be drawn on any plotters backend.
pub trait Drawing {
    /// Width and height in pixels.
    fn size(&self) -> (u32, u32);
    /// Draws the whole figure on `root`.
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> anyhow::Result<()>;
}

/// Writes `fig` as an SVG and a PNG of the same size. A symbolic link planted at either name
/// is refused, never followed (`swarmrt_scenario::safe_fs`): plotters writes a PNG by its
/// path, following links, so it writes into a directory made for this call alone (0700), and
/// the PNG is renamed into place from there.
pub fn write_svg_png(fig: &impl Drawing, svg_path: &Path, png_path: &Path) -> anyhow::Result<()> {
    ensure_font()?;
    let size = fig.size();
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        fig.draw(&root)?;
        root.present().map_err(draw_err("svg"))?;
    }
    safe_fs::write_nofollow(svg_path, svg)
        .with_context(|| format!("writing {}", svg_path.display()))?;
    // Refused before drawing, so a planted link costs no rendering; the rename below
    // refuses it again (and would replace a link, never write through it).
    safe_fs::refuse_symlink(png_path).with_context(|| format!("writing {}", png_path.display()))?;
    let parent = png_path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    // An unwritable directory gets a clear I/O error here.
    let private = safe_fs::PrivateDir::new(parent, "png")
        .with_context(|| format!("writing {}", png_path.display()))?;
    let drawn = private.path().join("plot.png");
    {
        let root = BitMapBackend::new(&drawn, size).into_drawing_area();
        fig.draw(&root)?;
        root.present()
            .map_err(|e| anyhow!("writing {}: {e}", png_path.display()))?;
    }
    safe_fs::rename_nofollow(&drawn, png_path)
        .with_context(|| format!("writing {}", png_path.display()))?;
    Ok(())
}
