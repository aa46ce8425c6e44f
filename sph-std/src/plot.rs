//! Plots (PNG) with plotters, using a font shipped in the crate (no system
//! font libraries needed).

use std::sync::Once;

use plotters::prelude::*;
use plotters::style::{register_font, FontStyle};

use crate::couette::CouetteRun;
use crate::error::{Error, Result};

static FONT: Once = Once::new();

/// Registers DejaVu Sans (free licence, `assets/DejaVu-LICENSE.txt`) as
/// plotters' sans-serif font.
pub fn ensure_font() {
    FONT.call_once(|| {
        let _ = register_font(
            "sans-serif",
            FontStyle::Normal,
            include_bytes!("../assets/DejaVuSans.ttf"),
        );
    });
}

fn plot_error(e: impl std::fmt::Display) -> Error {
    Error::config("plot", "profiles.png", format!("cannot draw the plot: {e}"))
}

/// Colours for successive series.
pub const PALETTE: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
];

/// Encodes an RGB buffer as PNG.
///
/// # Errors
/// If the encoder fails.
pub fn encode_png(buffer: &[u8], width: u32, height: u32) -> Result<Vec<u8>> {
    let mut png = Vec::new();
    image::codecs::png::PngEncoder::new(&mut png)
        .write_image(buffer, width, height, image::ColorType::Rgb8)
        .map_err(plot_error)?;
    Ok(png)
}

use image::ImageEncoder;

/// `profiles.png`: SPH velocity profiles (points) against the exact series
/// (lines) at every output time.
///
/// # Errors
/// If drawing fails.
pub fn profiles_png(run: &CouetteRun) -> Result<Vec<u8>> {
    ensure_font();
    let (w, h) = (1000u32, 700u32);
    let mut buffer = vec![255u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buffer, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_error)?;
        let g = &run.geometry;
        let exact = run.exact();
        let u = run.config.u_wall;
        let (y0, y1) = (g.y_lower * 1e3, g.y_upper * 1e3);
        let c = &run.config;
        let caption = format!(
            "Couette flow: {} kernel, beta {}, {} across, {} viscosity, {}",
            c.kernel, c.beta, c.particles_across, c.viscosity, c.precision
        );
        let mut chart = ChartBuilder::on(&root)
            .caption(caption, ("sans-serif", 22))
            .margin(15)
            .x_label_area_size(50)
            .y_label_area_size(60)
            .build_cartesian_2d(-0.02f64..1.02f64, y0..y1)
            .map_err(plot_error)?;
        chart
            .configure_mesh()
            .x_desc("u / U")
            .y_desc("y [mm]")
            .label_style(("sans-serif", 16))
            .draw()
            .map_err(plot_error)?;
        for (k, p) in run.profiles.iter().enumerate() {
            let color = PALETTE[k % PALETTE.len()];
            let line: Vec<(f64, f64)> = (0..=200)
                .map(|i| {
                    let y = g.y_lower + (g.y_upper - g.y_lower) * i as f64 / 200.0;
                    (exact.velocity(y, p.t) / u, y * 1e3)
                })
                .collect();
            chart
                .draw_series(LineSeries::new(line, color.stroke_width(2)))
                .map_err(plot_error)?
                .label(format!("t = {} s", p.t))
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
                });
            // One marker per particle row (the strip repeats each row).
            let stride = g.nx.max(1);
            chart
                .draw_series(
                    p.y.iter()
                        .zip(&p.vx)
                        .step_by(stride)
                        .map(|(y, vx)| Circle::new((vx / u, y * 1e3), 3, color.filled())),
                )
                .map_err(plot_error)?;
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .label_font(("sans-serif", 16))
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()
            .map_err(plot_error)?;
        root.present().map_err(plot_error)?;
    }
    encode_png(&buffer, w, h)
}
