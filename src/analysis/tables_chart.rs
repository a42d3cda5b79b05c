//! A chart of the dual-scattering tables against the light inclination, one line per color
//! channel, like the attenuation plots of Zinke et al. 2008 and the thesis (ch. 3.3).

use crate::analysis::plot::register_fonts;
use crate::error::{Result, bail, invalid};
use crate::output::{write_atomically, write_png};
use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;
use precompute::fiber::Absorption;
use precompute::tables::{Quantity, Tables};
use std::path::Path;

const SIZE: (u32, u32) = (1280, 960);

/// Width in pixels of the legend strip beside each panel.
const LEGEND_WIDTH: u32 = 130;

/// Line colors of the R, G and B channels.
const CHANNELS: [(RGBColor, &str); 3] =
    [(RGBColor(210, 40, 40), "red"), (RGBColor(30, 150, 50), "green"), (RGBColor(40, 70, 210), "blue")];

/// Dash length and gap in pixels telling the quantities of a panel apart (gap 0: a solid line).
const DASHES: [(u32, u32); 4] = [(1000, 0), (10, 6), (3, 4), (18, 5)];

/// One panel: quantities sharing a unit. Angles are shown in degrees, which read more easily than
/// radians at these sizes; the tables themselves hold radians.
struct Panel {
    title: &'static str,
    y_label: &'static str,
    quantities: &'static [(Quantity, &'static str)],
    degrees: bool,
}

/// A_b is unitless and Delta_b, sigma_b are angles, so they get separate panels.
const PANELS: [Panel; 4] = [
    Panel {
        title: "attenuation per fiber",
        y_label: "fraction of incident light",
        quantities: &[(Quantity::AF, "a_f (forward)"), (Quantity::AB, "a_b (backward)")],
        degrees: false,
    },
    Panel {
        title: "longitudinal shift and width (theta_h)",
        y_label: "degrees",
        quantities: &[
            (Quantity::AlphaF, "alpha_f"),
            (Quantity::BetaF, "beta_f"),
            (Quantity::AlphaB, "alpha_b"),
            (Quantity::BetaB, "beta_b"),
        ],
        degrees: true,
    },
    Panel {
        title: "average backscattering attenuation",
        y_label: "fraction of incident light",
        quantities: &[(Quantity::ABack, "A_b")],
        degrees: false,
    },
    Panel {
        title: "backscattering shift and width (theta_h)",
        y_label: "degrees",
        quantities: &[(Quantity::DeltaB, "Delta_b"), (Quantity::SigmaB, "sigma_b")],
        degrees: true,
    },
];

/// Draws every tabulated quantity against the light inclination into `path`: a .png (bitmap) or
/// .svg (vector) file, written whole or not at all.
pub fn draw_tables(tables: &Tables, path: &Path) -> Result<()> {
    match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
        Some("png") => {
            let mut buf = vec![255u8; (SIZE.0 * SIZE.1 * 3) as usize];
            draw(&BitMapBackend::with_buffer(&mut buf, SIZE).into_drawing_area(), tables)?;
            let image = image::RgbImage::from_raw(SIZE.0, SIZE.1, buf)
                .ok_or_else(|| invalid!("chart buffer has the wrong size"))?;
            write_png(path, &image)
        }
        Some("svg") => {
            let mut svg = String::new();
            draw(&SVGBackend::with_string(&mut svg, SIZE).into_drawing_area(), tables)?;
            write_atomically(path, |tmp| Ok(std::fs::write(tmp, &svg)?))
        }
        _ => bail!("{}: unsupported chart type (use .png or .svg)", path.display()),
    }
}

fn draw<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, tables: &Tables) -> Result<()> {
    register_fonts();
    let err = |e: &dyn std::fmt::Display| invalid!("drawing the chart failed: {e}");
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let title = match &tables.fiber {
        Some(f) => {
            let absorption = match f.absorption {
                Absorption::SigmaA(s) => format!("sigma_a {s:?}"),
                Absorption::Melanin { eumelanin, pheomelanin } => {
                    format!("eumelanin {eumelanin}, pheomelanin {pheomelanin}")
                }
                Absorption::Color(c) => format!("color {c:?}"),
            };
            format!(
                "dual-scattering tables (d_b = {}): {absorption}, beta_m {}, beta_n {}, alpha {} deg, eta {}",
                tables.d_b, f.beta_m, f.beta_n, f.alpha, f.eta
            )
        }
        None => format!("dual-scattering tables (d_b = {})", tables.d_b),
    };
    let body = root.titled(&title, ("sans-serif", 20)).map_err(|e| err(&e))?;
    for (area, panel) in body.split_evenly((2, 2)).iter().zip(&PANELS) {
        draw_panel(area, panel, tables).map_err(|e| err(&e))?;
    }
    root.present().map_err(|e| err(&e))?;
    Ok(())
}

/// The y range covering every value of the panel, padded by 5% (or by 0.05 when flat).
fn y_range(panel: &Panel, tables: &Tables) -> (f64, f64) {
    let scale = if panel.degrees { 180.0 / std::f64::consts::PI } else { 1.0 };
    let values = panel.quantities.iter().flat_map(|&(q, _)| tables.values(q).iter().flat_map(|v| v.0));
    let (lo, hi) = values
        .map(|v| v * scale)
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)));
    if lo > hi {
        return (0.0, 1.0);
    }
    let pad = if hi > lo { 0.05 * (hi - lo) } else { 0.05 * hi.abs().max(1.0) };
    (lo - pad, hi + pad)
}

fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    panel: &Panel,
    tables: &Tables,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    // The legend gets its own strip right of the plot, so it never hides a curve.
    let (plot, legend) = area.split_horizontally(area.dim_in_pixel().0.saturating_sub(LEGEND_WIDTH));
    let scale = if panel.degrees { 180.0 / std::f64::consts::PI } else { 1.0 };
    let (y0, y1) = y_range(panel, tables);
    let mut chart = ChartBuilder::on(&plot)
        .caption(panel.title, ("sans-serif", 17))
        .margin(12)
        .x_label_area_size(42)
        .y_label_area_size(62)
        .build_cartesian_2d(-90.0..90.0, y0..y1)?;
    chart
        .configure_mesh()
        .x_desc("light inclination theta (degrees)")
        .y_desc(panel.y_label)
        .x_label_formatter(&|x| format!("{x:.0}"))
        .label_style(("sans-serif", 13))
        .draw()?;
    let theta_deg: Vec<f64> = tables.theta.iter().map(|t| t.to_degrees()).collect();
    for (&(q, _), &(dash, gap)) in panel.quantities.iter().zip(&DASHES) {
        for (c, &(color, _)) in CHANNELS.iter().enumerate() {
            let points: Vec<(f64, f64)> =
                theta_deg.iter().zip(tables.values(q)).map(|(&t, v)| (t, v.0[c] * scale)).collect();
            chart.draw_series(DashedLineSeries::new(points, dash, gap, color.stroke_width(2)))?;
        }
    }
    // Each quantity's dash pattern in black, then the channels' colors.
    let entries =
        panel.quantities.iter().zip(&DASHES).map(|(&(_, label), &(dash, gap))| (label.to_string(), BLACK, dash, gap));
    let entries =
        entries.chain(CHANNELS.iter().map(|&(color, name)| (format!("{name} channel"), color, DASHES[0].0, 0)));
    for (i, (label, color, dash, gap)) in entries.enumerate() {
        let y = 60 + 22 * i as i32;
        legend.draw(&DashedPathElement::new(vec![(0, y), (28, y)], dash, gap, color.stroke_width(2)))?;
        legend.draw(&Text::new(label, (34, y - 7), ("sans-serif", 13)))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use precompute::fiber::{Chiang, FiberParams};
    use precompute::lobe::h_rule;
    use precompute::tables::{D_B, TableSettings, compute};

    fn small_tables() -> Tables {
        let params = FiberParams::default();
        let settings = TableSettings { theta_count: 9, h_rule: h_rule(1.0, 1), theta_i_panels: 8, phi_panels: 4 };
        let mut tables = compute(&Chiang::new(&params).unwrap(), &settings, D_B);
        tables.fiber = Some(params);
        tables
    }

    #[test]
    fn writes_png_and_svg_and_rejects_other_types() {
        let dir = tempfile::tempdir().unwrap();
        let tables = small_tables();
        let png = dir.path().join("tables.png");
        draw_tables(&tables, &png).unwrap();
        let image = image::open(&png).unwrap();
        assert_eq!((image.width(), image.height()), SIZE);
        let svg = dir.path().join("tables.svg");
        draw_tables(&tables, &svg).unwrap();
        let text = std::fs::read_to_string(&svg).unwrap();
        for label in ["a_f (forward)", "beta_b", "A_b", "sigma_b", "red channel", "light inclination theta"] {
            assert!(text.contains(label), "the SVG lacks {label}");
        }
        let bad = dir.path().join("tables.txt");
        assert!(draw_tables(&tables, &bad).is_err());
        assert!(!bad.exists());
    }
}
