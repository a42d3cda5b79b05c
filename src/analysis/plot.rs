//! Charts drawn with plotters into in-memory bitmaps, with an embedded font (no system fonts).

use crate::error::{Result, invalid};
use plotters::prelude::*;
use plotters::style::FontStyle;
use std::sync::Once;

/// Registers the embedded DejaVu Sans as "sans-serif" once per process.
pub fn register_fonts() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The font is compiled in and valid; a failure here is a build defect.
        plotters::style::register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular())
            .unwrap_or_else(|_| panic!("embedded DejaVu font rejected"));
    });
}

/// A heat map of `values` (rows top to bottom, spanning x in `xs` and y in `ys`) on a log10 color
/// scale over `decades` decades below the maximum, with labeled axes and a labeled color bar.
pub struct HeatMap<'a> {
    pub title: &'a str,
    pub x_label: &'a str,
    pub y_label: &'a str,
    pub bar_label: &'a str,
    pub xs: (f64, f64),
    pub ys: (f64, f64),
    pub width: usize,
    pub height: usize,
    pub values: &'a [f64],
    pub decades: f64,
}

impl<'a> HeatMap<'a> {
    /// A lat-long image of directions in [`precompute::lobe`]'s layout (azimuth -pi..pi, inclination
    /// pi/2 at the top), over four decades.
    pub fn lat_long(title: &'a str, bar_label: &'a str, width: usize, height: usize, values: &'a [f64]) -> Self {
        use std::f64::consts::{FRAC_PI_2, PI};
        HeatMap {
            title,
            x_label: "azimuth phi (rad)",
            y_label: "inclination theta (rad)",
            bar_label,
            xs: (-PI, PI),
            ys: (-FRAC_PI_2, FRAC_PI_2),
            width,
            height,
            values,
            decades: 4.0,
        }
    }

    /// The heat map alone, with its color bar.
    pub fn draw(&self) -> Result<image::RgbImage> {
        let max = self.values.iter().copied().fold(f64::MIN_POSITIVE, f64::max).log10();
        draw_maps(self.title, std::slice::from_ref(self), (max - self.decades, max), (960, 540), 1)
    }

    /// Draws the map into `area` with log10 values over `range` (the color bar is drawn apart).
    fn draw_on<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, plotters::coord::Shift>,
        caption: &str,
        range: (f64, f64),
    ) -> Result<()> {
        let err = |e: &dyn std::fmt::Display| invalid!("drawing the chart failed: {e}");
        let (min, max) = range;
        let color =
            |v: f64| ViridisRGB::get_color_normalized(v.max(f64::MIN_POSITIVE).log10().clamp(min, max), min, max);
        let mut chart = ChartBuilder::on(area)
            .caption(caption, ("sans-serif", 18))
            .margin(12)
            .x_label_area_size(45)
            .y_label_area_size(60)
            .build_cartesian_2d(self.xs.0..self.xs.1, self.ys.0..self.ys.1)
            .map_err(|e| err(&e))?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc(self.x_label)
            .y_desc(self.y_label)
            .label_style(("sans-serif", 14))
            .draw()
            .map_err(|e| err(&e))?;
        let dx = (self.xs.1 - self.xs.0) / self.width as f64;
        let dy = (self.ys.1 - self.ys.0) / self.height as f64;
        chart
            .draw_series((0..self.width * self.height).map(|i| {
                let (x, y) = ((i % self.width) as f64, (i / self.width) as f64);
                let (x0, y0) = (self.xs.0 + x * dx, self.ys.1 - y * dy);
                Rectangle::new([(x0, y0), (x0 + dx, y0 - dy)], color(self.values[i]).filled())
            }))
            .map_err(|e| err(&e))?;
        Ok(())
    }
}

/// Heat maps side by side (`cols` per row) on one log10 color scale over `range`, each captioned
/// with its own title, with one color bar labeled by the first map's `bar_label`.
pub fn heat_maps(title: &str, maps: &[HeatMap], decades: f64, cols: usize) -> Result<image::RgbImage> {
    let max = maps.iter().flat_map(|m| m.values.iter().copied()).fold(f64::MIN_POSITIVE, f64::max).log10();
    let cols = cols.clamp(1, maps.len().max(1));
    let rows = maps.len().div_ceil(cols).max(1);
    draw_maps(title, maps, (max - decades, max), (140 + 700 * cols as u32, 40 + 380 * rows as u32), cols)
}

fn draw_maps(
    title: &str,
    maps: &[HeatMap],
    range: (f64, f64),
    (w, h): (u32, u32),
    cols: usize,
) -> Result<image::RgbImage> {
    register_fonts();
    let mut buf = vec![255u8; (w * h * 3) as usize];
    let err = |e: &dyn std::fmt::Display| invalid!("drawing the chart failed: {e}");
    let (min, max) = range;
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        let (main, bar) = root.split_horizontally(w - 140);
        if maps.len() == 1 {
            maps[0].draw_on(&main, title, range)?;
        } else {
            let body = main.titled(title, ("sans-serif", 20)).map_err(|e| err(&e))?;
            let rows = maps.len().div_ceil(cols);
            for (area, map) in body.split_evenly((rows, cols)).iter().zip(maps) {
                map.draw_on(area, map.title, range)?;
            }
        }
        let color = |v: f64| ViridisRGB::get_color_normalized(v.clamp(min, max), min, max);
        let mut legend = ChartBuilder::on(&bar)
            .margin_top(42)
            .margin_bottom(57)
            .margin_right(12)
            .y_label_area_size(75)
            .build_cartesian_2d(0.0..1.0, min..max)
            .map_err(|e| err(&e))?;
        legend
            .configure_mesh()
            .disable_mesh()
            .disable_x_axis()
            .y_desc(maps.first().map_or("", |m| m.bar_label))
            .y_label_formatter(&|v| format!("{:.1e}", 10f64.powf(*v)))
            .label_style(("sans-serif", 13))
            .draw()
            .map_err(|e| err(&e))?;
        let steps = 200;
        legend
            .draw_series((0..steps).map(|k| {
                let v0 = min + (max - min) * k as f64 / steps as f64;
                let v1 = min + (max - min) * (k + 1) as f64 / steps as f64;
                Rectangle::new([(0.0, v0), (1.0, v1)], color(v0).filled())
            }))
            .map_err(|e| err(&e))?;
        root.present().map_err(|e| err(&e))?;
    }
    image::RgbImage::from_raw(w, h, buf).ok_or_else(|| invalid!("chart buffer has the wrong size"))
}

/// How a [`CellMap`] maps values to colors.
#[derive(Clone, Copy, Debug)]
pub enum CellScale {
    /// Viridis over [lo, hi], clamped.
    Linear { lo: f64, hi: f64 },
    /// Viridis over log10, from `decades` below `hi` to `hi`; zero and below get the lowest color.
    Log { hi: f64, decades: f64 },
    /// Blue (negative) through white (zero) to red (positive), saturating at +-`limit`.
    Diverging { limit: f64 },
}

impl CellScale {
    fn color(self, v: f64) -> RGBColor {
        match self {
            CellScale::Linear { lo, hi } => ViridisRGB::get_color_normalized(v.clamp(lo, hi), lo, hi),
            CellScale::Log { hi, decades } => {
                let top = hi.log10();
                let l = if v > 0.0 { v.log10().clamp(top - decades, top) } else { top - decades };
                ViridisRGB::get_color_normalized(l, top - decades, top)
            }
            CellScale::Diverging { limit } => {
                let t = (v / limit).clamp(-1.0, 1.0);
                let mix = |a: u8, t: f64| (255.0 + (a as f64 - 255.0) * t.abs()).round() as u8;
                let (r, g, b) = if t < 0.0 { (40, 90, 200) } else { (200, 40, 40) };
                RGBColor(mix(r, t), mix(g, t), mix(b, t))
            }
        }
    }
}

/// Small multiples of labeled grids of cells, one panel per series: each cell colored by its
/// value and printed with it, non-finite values shown as "NaN" on gray. Values are row-major with
/// row 0 at the bottom (the first y label).
pub struct CellMap<'a> {
    pub title: &'a str,
    pub x_label: &'a str,
    pub y_label: &'a str,
    pub x_ticks: &'a [String],
    pub y_ticks: &'a [String],
    pub panels: &'a [(String, Vec<f64>)],
    pub scale: CellScale,
    /// Formats a cell's value.
    pub format: &'a dyn Fn(f64) -> String,
}

impl CellMap<'_> {
    /// Draws into a .png or .svg file, written whole or not at all.
    pub fn write(&self, path: &std::path::Path) -> Result<()> {
        let cols = self.panels.len().clamp(1, 3);
        let rows = self.panels.len().div_ceil(cols).max(1);
        let size = (560 * cols as u32, 40 + 430 * rows as u32);
        match path.extension().and_then(|e| e.to_str()) {
            Some("png") => {
                let mut buf = vec![255u8; (size.0 * size.1 * 3) as usize];
                self.draw(&BitMapBackend::with_buffer(&mut buf, size).into_drawing_area(), cols, rows)?;
                let image = image::RgbImage::from_raw(size.0, size.1, buf)
                    .ok_or_else(|| invalid!("chart buffer has the wrong size"))?;
                crate::output::write_png(path, &image)
            }
            Some("svg") => {
                let mut svg = String::new();
                self.draw(&SVGBackend::with_string(&mut svg, size).into_drawing_area(), cols, rows)?;
                crate::output::write_atomically(path, |tmp| Ok(std::fs::write(tmp, &svg)?))
            }
            _ => Err(invalid!("{}: unsupported chart type (use .png or .svg)", path.display())),
        }
    }

    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, plotters::coord::Shift>,
        cols: usize,
        rows: usize,
    ) -> Result<()> {
        register_fonts();
        let err = |e: &dyn std::fmt::Display| invalid!("drawing the chart failed: {e}");
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let body = root.titled(self.title, ("sans-serif", 20)).map_err(|e| err(&e))?;
        let (nx, ny) = (self.x_ticks.len(), self.y_ticks.len());
        for (area, (name, values)) in body.split_evenly((rows, cols)).iter().zip(self.panels) {
            let mut chart = ChartBuilder::on(area)
                .caption(name, ("sans-serif", 16))
                .margin(8)
                .x_label_area_size(40)
                .y_label_area_size(55)
                .build_cartesian_2d((0..nx).into_segmented(), (0..ny).into_segmented())
                .map_err(|e| err(&e))?;
            let tick = |ticks: &[String], v: &SegmentValue<usize>| match v {
                SegmentValue::CenterOf(i) => ticks.get(*i).cloned().unwrap_or_default(),
                _ => String::new(),
            };
            chart
                .configure_mesh()
                .disable_mesh()
                .x_desc(self.x_label)
                .y_desc(self.y_label)
                .x_labels(nx)
                .y_labels(ny)
                .x_label_formatter(&|v| tick(self.x_ticks, v))
                .y_label_formatter(&|v| tick(self.y_ticks, v))
                .label_style(("sans-serif", 11))
                .draw()
                .map_err(|e| err(&e))?;
            let cell = |i: usize| (i % nx, i / nx);
            chart
                .draw_series((0..nx * ny).map(|i| {
                    let (x, y) = cell(i);
                    let v = values[i];
                    let fill = if v.is_finite() { self.scale.color(v) } else { RGBColor(170, 170, 170) };
                    Rectangle::new(
                        [
                            (SegmentValue::Exact(x), SegmentValue::Exact(y)),
                            (SegmentValue::Exact(x + 1), SegmentValue::Exact(y + 1)),
                        ],
                        fill.filled(),
                    )
                }))
                .map_err(|e| err(&e))?;
            chart
                .draw_series((0..nx * ny).map(|i| {
                    let (x, y) = cell(i);
                    let v = values[i];
                    let text = if v.is_finite() { (self.format)(v) } else { "NaN".to_string() };
                    let dark =
                        v.is_finite() && matches!(self.scale, CellScale::Linear { .. } | CellScale::Log { .. }) && {
                            let c = self.scale.color(v);
                            (c.0 as u32 + c.1 as u32 + c.2 as u32) < 330
                        };
                    let style = ("sans-serif", 9).into_font().color(if dark { &WHITE } else { &BLACK }).pos(
                        plotters::style::text_anchor::Pos::new(
                            plotters::style::text_anchor::HPos::Center,
                            plotters::style::text_anchor::VPos::Center,
                        ),
                    );
                    Text::new(text, (SegmentValue::CenterOf(x), SegmentValue::CenterOf(y)), style)
                }))
                .map_err(|e| err(&e))?;
        }
        root.present().map_err(|e| err(&e))?;
        Ok(())
    }
}
