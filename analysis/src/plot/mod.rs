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
use std::sync::OnceLock;

use anyhow::{Context, anyhow};
use plotters::coord::Shift;
use plotters::prelude::*;
use swarmrt_scenario::safe_fs::{self, OutDir};

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

/// Writes `fig` as `<stem>.svg` and `<stem>.png` of the same size into `dir`. Both are drawn
/// in memory and written through the directory's handle, each atomically (`<name>.tmp`, then
/// renamed): a symbolic link planted at either name is refused, never followed, and a plot is
/// whole or absent.
pub fn write_svg_png(fig: &impl Drawing, dir: &OutDir, stem: &str) -> anyhow::Result<()> {
    let (svg_name, png_name) = (format!("{stem}.svg"), format!("{stem}.png"));
    ensure_font()?;
    let size = fig.size();
    // Refused before drawing, so a planted link costs no rendering.
    for name in [&svg_name, &png_name] {
        if dir.stat(name).is_some_and(|e| e.is_symlink) {
            return Err(safe_fs::symlink_error(&dir.join(name)))
                .with_context(|| format!("writing {}", dir.join(name).display()));
        }
    }
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        fig.draw(&root)?;
        root.present().map_err(draw_err("svg"))?;
    }
    dir.write_replace(&svg_name, svg)
        .with_context(|| format!("writing {}", dir.join(&svg_name).display()))?;
    let png = png_bytes(fig, size)?;
    dir.write_replace(&png_name, png)
        .with_context(|| format!("writing {}", dir.join(&png_name).display()))?;
    Ok(())
}

/// `fig` drawn on an RGB bitmap and encoded as PNG, as plotters' `BitMapBackend::new(path)`
/// saves one (the image crate's PNG encoder with its defaults), but in memory.
fn png_bytes(fig: &impl Drawing, (w, h): (u32, u32)) -> anyhow::Result<Vec<u8>> {
    let mut rgb = vec![0u8; w as usize * h as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (w, h)).into_drawing_area();
        fig.draw(&root)?;
        root.present().map_err(draw_err("png"))?;
    }
    let img = image::RgbImage::from_raw(w, h, rgb).ok_or_else(|| anyhow!("png buffer size"))?;
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png)
        .map_err(|e| anyhow!("encoding the png: {e}"))?;
    Ok(out.into_inner())
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Square;

    impl Drawing for Square {
        fn size(&self) -> (u32, u32) {
            (64, 48)
        }
        fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> anyhow::Result<()> {
            root.fill(&WHITE).map_err(draw_err("test"))?;
            root.draw(&Rectangle::new([(8, 8), (40, 30)], TAB10[0].filled()))
                .map_err(draw_err("test"))?;
            root.draw_text("x", &("sans-serif", 12).into_font().color(&BLACK), (44, 10))
                .map_err(draw_err("test"))?;
            Ok(())
        }
    }

    /// The PNG drawn in memory is byte for byte the one plotters saves by path.
    #[test]
    fn the_png_drawn_in_memory_is_plotters_own() {
        ensure_font().unwrap();
        let dir = tempfile::tempdir().unwrap();
        let by_path = dir.path().join("by-path.png");
        {
            let root = BitMapBackend::new(&by_path, Square.size()).into_drawing_area();
            Square.draw(&root).unwrap();
            root.present().unwrap();
        }
        let out = OutDir::open(dir.path()).unwrap();
        write_svg_png(&Square, &out, "in-memory").unwrap();
        assert_eq!(
            std::fs::read(dir.path().join("in-memory.png")).unwrap(),
            std::fs::read(&by_path).unwrap()
        );
        assert!(
            std::fs::read_to_string(dir.path().join("in-memory.svg"))
                .unwrap()
                .contains("<svg")
        );
    }
}
