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

/// Checks that an axis range can be drawn: finite, increasing, and wider
/// than the round-off of its ends (plotters' tick search does not end on an
/// infinite or empty range).
fn drawable(lo: f64, hi: f64, axis: &str) -> Result<()> {
    let width = hi - lo;
    if lo.is_finite()
        && hi.is_finite()
        && width.is_finite()
        && width > 1e-12 * lo.abs().max(hi.abs())
    {
        Ok(())
    } else {
        Err(Error::config(
            "plot",
            format!("{axis} range {lo:e} .. {hi:e}"),
            "cannot draw an infinite or empty axis range",
        ))
    }
}

/// Colours for successive series (the last, black, is for references).
pub const PALETTE: [RGBColor; 9] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(0, 0, 0),
];

/// Index of black in [`PALETTE`], for reference lines.
pub const REFERENCE: usize = 8;

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
        drawable(y0, y1, "y")?;
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

/// One series of a [`line_plot`].
#[derive(Clone, Debug)]
pub struct Series {
    /// Legend label.
    pub label: String,
    /// Points (x, y); non-positive values are dropped on log axes.
    pub points: Vec<(f64, f64)>,
    /// Index into [`PALETTE`].
    pub color: usize,
    /// Draw as a line (else markers only).
    pub line: bool,
    /// Draw markers at the points.
    pub markers: bool,
}

/// Axes of a [`line_plot`].
#[derive(Clone, Debug)]
pub struct Axes {
    /// Title.
    pub title: String,
    /// x label.
    pub x: String,
    /// y label.
    pub y: String,
    /// Logarithmic x.
    pub log_x: bool,
    /// Logarithmic y.
    pub log_y: bool,
    /// Where the legend goes.
    pub legend: SeriesLabelPosition,
}

fn range(values: impl Iterator<Item = f64>, log: bool) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite() && (!log || *v > 0.0)) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return (1.0, 10.0);
    }
    if log {
        (lo / 1.5, hi * 1.5)
    } else {
        // A single value (one output time) gets a range around it.
        let (span, scale) = (hi - lo, lo.abs().max(hi.abs()));
        let pad = if span > 1e-9 * scale {
            0.05 * span
        } else if scale > 0.0 {
            0.05 * scale
        } else {
            1.0
        };
        (lo - pad, hi + pad)
    }
}

/// A PNG line plot of several series (log or linear axes).
///
/// # Errors
/// If drawing fails.
pub fn line_plot(axes: &Axes, series: &[Series]) -> Result<Vec<u8>> {
    ensure_font();
    let (w, h) = (1000u32, 700u32);
    let mut buffer = vec![255u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buffer, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_error)?;
        let keep = |p: &&(f64, f64)| {
            (!axes.log_x || p.0 > 0.0)
                && (!axes.log_y || p.1 > 0.0)
                && p.0.is_finite()
                && p.1.is_finite()
        };
        let (x0, x1) = range(
            series
                .iter()
                .flat_map(|s| s.points.iter().filter(keep).map(|p| p.0)),
            axes.log_x,
        );
        let (y0, y1) = range(
            series
                .iter()
                .flat_map(|s| s.points.iter().filter(keep).map(|p| p.1)),
            axes.log_y,
        );
        let mut builder = ChartBuilder::on(&root);
        builder
            .caption(&axes.title, ("sans-serif", 22))
            .margin(15)
            .x_label_area_size(50)
            .y_label_area_size(80);
        macro_rules! draw {
            ($chart:expr) => {{
                let mut chart = $chart;
                chart
                    .configure_mesh()
                    .x_desc(axes.x.as_str())
                    .y_desc(axes.y.as_str())
                    .label_style(("sans-serif", 16))
                    .light_line_style(RGBColor(235, 235, 235))
                    .draw()
                    .map_err(plot_error)?;
                for s in series {
                    let color = PALETTE[s.color % PALETTE.len()];
                    let pts: Vec<(f64, f64)> = s.points.iter().filter(keep).copied().collect();
                    if s.line {
                        chart
                            .draw_series(LineSeries::new(pts.clone(), color.stroke_width(2)))
                            .map_err(plot_error)?
                            .label(s.label.clone())
                            .legend(move |(x, y)| {
                                PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
                            });
                    }
                    if s.markers {
                        let drawn = chart
                            .draw_series(pts.iter().map(|p| Circle::new(*p, 4, color.filled())))
                            .map_err(plot_error)?;
                        if !s.line {
                            drawn
                                .label(s.label.clone())
                                .legend(move |(x, y)| Circle::new((x + 10, y), 4, color.filled()));
                        }
                    }
                }
                chart
                    .configure_series_labels()
                    .position(axes.legend.clone())
                    .label_font(("sans-serif", 14))
                    .background_style(WHITE.mix(0.85))
                    .border_style(BLACK)
                    .draw()
                    .map_err(plot_error)?;
            }};
        }
        drawable(x0, x1, "x")?;
        drawable(y0, y1, "y")?;
        match (axes.log_x, axes.log_y) {
            (true, true) => draw!(builder
                .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
                .map_err(plot_error)?),
            (true, false) => draw!(builder
                .build_cartesian_2d((x0..x1).log_scale(), y0..y1)
                .map_err(plot_error)?),
            (false, true) => draw!(builder
                .build_cartesian_2d(x0..x1, (y0..y1).log_scale())
                .map_err(plot_error)?),
            (false, false) => draw!(builder
                .build_cartesian_2d(x0..x1, y0..y1)
                .map_err(plot_error)?),
        }
        root.present().map_err(plot_error)?;
    }
    encode_png(&buffer, w, h)
}

/// A scatter of particles coloured by speed (blue slow, red fast), for a
/// 2D frame in the box `[x0, x1] x [y0, y1]`.
///
/// # Errors
/// If drawing fails.
pub fn speed_scatter_png(
    frame: &crate::scene::Frame,
    bounds: [f64; 4],
    title: &str,
) -> Result<Vec<u8>> {
    ensure_font();
    let (w, h) = (800u32, 820u32);
    let mut buffer = vec![255u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buffer, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_error)?;
        let speed = |v: &[f64; 3]| (v[0] * v[0] + v[1] * v[1]).sqrt();
        let vmax = frame
            .v
            .iter()
            .map(speed)
            .fold(0.0f64, f64::max)
            .max(f64::MIN_POSITIVE);
        drawable(bounds[0], bounds[1], "x")?;
        drawable(bounds[2], bounds[3], "y")?;
        let mut chart = ChartBuilder::on(&root)
            .caption(
                format!("{title} (max speed {vmax:.3e})"),
                ("sans-serif", 20),
            )
            .margin(15)
            .x_label_area_size(40)
            .y_label_area_size(50)
            .build_cartesian_2d(bounds[0]..bounds[1], bounds[2]..bounds[3])
            .map_err(plot_error)?;
        chart
            .configure_mesh()
            .x_desc("x")
            .y_desc("y")
            .label_style(("sans-serif", 14))
            .draw()
            .map_err(plot_error)?;
        chart
            .draw_series(frame.x.iter().zip(&frame.v).map(|(x, v)| {
                let s = speed(v) / vmax;
                let color = HSLColor(0.66 * (1.0 - s), 0.9, 0.5);
                Circle::new((x[0], x[1]), 2, color.filled())
            }))
            .map_err(plot_error)?;
        root.present().map_err(plot_error)?;
    }
    encode_png(&buffer, w, h)
}
