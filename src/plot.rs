//! Charts drawn with plotters into in-memory bitmaps, with an embedded font (no system fonts).

use anyhow::{Result, anyhow};
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

impl HeatMap<'_> {
    pub fn draw(&self) -> Result<image::RgbImage> {
        register_fonts();
        let (w, h) = (960u32, 540u32);
        let mut buf = vec![255u8; (w * h * 3) as usize];
        let err = |e: &dyn std::fmt::Display| anyhow!("drawing the chart failed: {e}");
        {
            let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
            let (main, bar) = root.split_horizontally(w - 140);
            let max = self.values.iter().copied().fold(f64::MIN_POSITIVE, f64::max).log10();
            let min = max - self.decades;
            let color =
                |v: f64| ViridisRGB::get_color_normalized(v.max(f64::MIN_POSITIVE).log10().clamp(min, max), min, max);

            let mut chart = ChartBuilder::on(&main)
                .caption(self.title, ("sans-serif", 18))
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
                .y_desc(self.bar_label)
                .y_label_formatter(&|v| format!("{:.1e}", 10f64.powf(*v)))
                .label_style(("sans-serif", 13))
                .draw()
                .map_err(|e| err(&e))?;
            let steps = 200;
            legend
                .draw_series((0..steps).map(|k| {
                    let v0 = min + (max - min) * k as f64 / steps as f64;
                    let v1 = min + (max - min) * (k + 1) as f64 / steps as f64;
                    Rectangle::new([(0.0, v0), (1.0, v1)], color(10f64.powf(v0)).filled())
                }))
                .map_err(|e| err(&e))?;
            root.present().map_err(|e| err(&e))?;
        }
        image::RgbImage::from_raw(w, h, buf).ok_or_else(|| anyhow!("chart buffer has the wrong size"))
    }
}
