//! The figures, drawn with plotters in a font shipped in the crate (no
//! system font libraries needed).

use std::sync::Once;

use plotters::coord::CoordTranslate;
use plotters::prelude::*;
use plotters::style::{register_font, FontStyle};

use super::{Axes, Series, REFERENCE};
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
            include_bytes!("../../assets/DejaVuSans.ttf"),
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

/// Colours for successive series (Tableau 10 without its greys).
pub const PALETTE: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(23, 190, 207),
];

/// Marker shapes: after the eight colours the shapes change, so no two of
/// the first 32 series of a figure look alike.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shape {
    /// Filled circle.
    Circle,
    /// Filled triangle.
    Triangle,
    /// Filled square.
    Square,
    /// Cross.
    Cross,
}

const SHAPES: [Shape; 4] = [Shape::Circle, Shape::Triangle, Shape::Square, Shape::Cross];

/// Colour and marker of the series with style index `k`.
pub fn style(k: usize) -> (RGBColor, Shape) {
    if k == REFERENCE {
        return (RGBColor(0, 0, 0), Shape::Circle);
    }
    (
        PALETTE[k % PALETTE.len()],
        SHAPES[(k / PALETTE.len()) % SHAPES.len()],
    )
}

/// Draws markers of `shape` at `points` on a chart.
fn draw_markers<DB: DrawingBackend, CT: CoordTranslate<From = (f64, f64)>>(
    chart: &mut ChartContext<'_, DB, CT>,
    points: &[(f64, f64)],
    shape: Shape,
    color: RGBColor,
    size: i32,
) -> Result<()> {
    let fill = color.filled();
    let at = points.iter().copied();
    match shape {
        Shape::Circle => chart
            .draw_series(at.map(|p| Circle::new(p, size, fill)))
            .map(|_| ()),
        Shape::Triangle => chart
            .draw_series(at.map(|p| TriangleMarker::new(p, size + 1, fill)))
            .map(|_| ()),
        Shape::Square => chart
            .draw_series(at.map(|p| {
                EmptyElement::at(p) + Rectangle::new([(-size, -size), (size, size)], fill)
            }))
            .map(|_| ()),
        Shape::Cross => chart
            .draw_series(at.map(|p| Cross::new(p, size, color.stroke_width(2))))
            .map(|_| ()),
    }
    .map_err(plot_error)
}

/// Draws one marker of `shape` at a pixel position of `area`.
fn draw_marker_at<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    at: (i32, i32),
    shape: Shape,
    color: RGBColor,
    size: i32,
) -> Result<()> {
    let fill = color.filled();
    match shape {
        Shape::Circle => area.draw(&Circle::new(at, size, fill)),
        Shape::Triangle => area.draw(&TriangleMarker::new(at, size + 1, fill)),
        Shape::Square => area.draw(&Rectangle::new(
            [(at.0 - size, at.1 - size), (at.0 + size, at.1 + size)],
            fill,
        )),
        Shape::Cross => area.draw(&Cross::new(at, size, color.stroke_width(2))),
    }
    .map_err(plot_error)
}

/// A tick label that stays short on any scale: plain decimals from 1e-3
/// to 1e5 (at most four significant digits), `2.5e-7` style outside.
pub fn tick_label(v: f64) -> String {
    let a = v.abs();
    if a == 0.0 || !a.is_finite() {
        return format!("{v}");
    }
    if (1e-3..1e5).contains(&a) {
        let decimals = (3 - a.log10().floor() as i32).max(0) as usize;
        let text = format!("{v:.decimals$}");
        if text.contains('.') {
            text.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            text
        }
    } else {
        let text = format!("{v:.3e}");
        let (mantissa, exponent) = text.split_once('e').unwrap_or((&text, "0"));
        let mantissa = mantissa.trim_end_matches('0').trim_end_matches('.');
        format!("{mantissa}e{exponent}")
    }
}

/// One entry of a legend drawn beside a chart.
struct LegendEntry {
    label: String,
    style: usize,
    line: bool,
    markers: bool,
}

/// Draws a legend into its own column (so it never covers data).
fn draw_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    top: i32,
    entries: &[LegendEntry],
) -> Result<()> {
    for (row, e) in entries.iter().enumerate() {
        let y = top + 24 * row as i32;
        let (color, shape) = style(e.style);
        if e.line {
            area.draw(&PathElement::new(
                vec![(6, y), (36, y)],
                color.stroke_width(2),
            ))
            .map_err(plot_error)?;
        }
        if e.markers {
            draw_marker_at(area, (21, y), shape, color, 4)?;
        }
        area.draw(&Text::new(
            e.label.clone(),
            (44, y - 8),
            ("sans-serif", 15).into_font(),
        ))
        .map_err(plot_error)?;
    }
    Ok(())
}

/// Width of the legend column beside every chart.
const LEGEND_WIDTH: u32 = 290;

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

/// `profiles.png`: SPH velocity profiles (markers) against the exact
/// series (lines) at every output time, and under them the residual
/// `(u_SPH - u_exact) / U` of every particle row.
///
/// # Errors
/// If drawing fails.
pub fn profiles_png(run: &CouetteRun) -> Result<Vec<u8>> {
    ensure_font();
    let (w, h) = (1100u32, 1000u32);
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
        let stopped = if run.stop.is_some() {
            " (stopped early)"
        } else {
            ""
        };
        let caption = format!(
            "Couette flow: {} kernel, beta {}, {} across, {} viscosity, {}{stopped}",
            c.kernel, c.beta, c.particles_across, c.viscosity, c.precision
        );
        let (upper, lower) = root
            .titled(&caption, ("sans-serif", 22))
            .map_err(plot_error)?
            .split_vertically(600);
        let (top, legend) = upper.split_horizontally(w - LEGEND_WIDTH);
        let (bottom, _) = lower.split_horizontally(w - LEGEND_WIDTH);
        // One marker per particle row (the strip repeats each row).
        let stride = g.nx.max(1);
        let rows = |p: &crate::couette::Profile| {
            p.y.iter()
                .zip(&p.vx)
                .step_by(stride)
                .map(|(y, vx)| (*y, *vx))
                .collect::<Vec<_>>()
        };
        let mut chart = ChartBuilder::on(&top)
            .margin(15)
            .x_label_area_size(50)
            .y_label_area_size(70)
            .build_cartesian_2d(-0.02f64..1.02f64, y0..y1)
            .map_err(plot_error)?;
        chart
            .configure_mesh()
            .x_desc("u / U")
            .y_desc("y [mm]")
            .x_label_formatter(&|v| tick_label(*v))
            .y_label_formatter(&|v| tick_label(*v))
            .label_style(("sans-serif", 16))
            .draw()
            .map_err(plot_error)?;
        let mut entries = vec![
            LegendEntry {
                label: "lines: exact series".into(),
                style: REFERENCE,
                line: true,
                markers: false,
            },
            LegendEntry {
                label: "markers: SPH".into(),
                style: REFERENCE,
                line: false,
                markers: true,
            },
        ];
        let mut worst = 0.0f64;
        for (k, p) in run.profiles.iter().enumerate() {
            let (color, shape) = style(k);
            let line: Vec<(f64, f64)> = (0..=200)
                .map(|i| {
                    let y = g.y_lower + (g.y_upper - g.y_lower) * i as f64 / 200.0;
                    (exact.velocity(y, p.t) / u, y * 1e3)
                })
                .collect();
            chart
                .draw_series(LineSeries::new(line, color.stroke_width(2)))
                .map_err(plot_error)?;
            let points: Vec<(f64, f64)> = rows(p)
                .into_iter()
                .map(|(y, vx)| (vx / u, y * 1e3))
                .collect();
            draw_markers(&mut chart, &points, shape, color, 3)?;
            for (y, vx) in rows(p) {
                worst = worst.max(((vx - exact.velocity(y, p.t)) / u).abs());
            }
            entries.push(LegendEntry {
                label: format!("t = {} s", tick_label(p.t)),
                style: k,
                line: true,
                markers: true,
            });
        }
        draw_legend(&legend, 30, &entries)?;
        // The residual panel.
        let r = if worst.is_finite() && worst > 0.0 {
            1.1 * worst
        } else {
            1e-3
        };
        let mut chart = ChartBuilder::on(&bottom)
            .margin(15)
            .x_label_area_size(50)
            .y_label_area_size(70)
            .build_cartesian_2d(y0..y1, -r..r)
            .map_err(plot_error)?;
        chart
            .configure_mesh()
            .x_desc("y [mm]")
            .y_desc("(u_SPH - u_exact) / U")
            .x_label_formatter(&|v| tick_label(*v))
            .y_label_formatter(&|v| tick_label(*v))
            .label_style(("sans-serif", 16))
            .draw()
            .map_err(plot_error)?;
        chart
            .draw_series(LineSeries::new(
                vec![(y0, 0.0), (y1, 0.0)],
                BLACK.stroke_width(1),
            ))
            .map_err(plot_error)?;
        for (k, p) in run.profiles.iter().enumerate() {
            let (color, shape) = style(k);
            let points: Vec<(f64, f64)> = rows(p)
                .into_iter()
                .map(|(y, vx)| (y * 1e3, (vx - exact.velocity(y, p.t)) / u))
                .collect();
            draw_markers(&mut chart, &points, shape, color, 3)?;
        }
        root.present().map_err(plot_error)?;
    }
    encode_png(&buffer, w, h)
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
        // At most 30 decades: plotters' logarithmic axis does not return
        // from a range of hundreds of decades (a ratio to a near-zero
        // normaliser), and no plot reads anything there.
        let lo = lo.max(hi * 1e-30);
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
    let (w, h) = (1100u32, 700u32);
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
        let titled = root
            .titled(&axes.title, ("sans-serif", 22))
            .map_err(plot_error)?;
        let (plot, legend) = titled.split_horizontally(w - LEGEND_WIDTH);
        let mut builder = ChartBuilder::on(&plot);
        builder
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
                    .x_label_formatter(&|v| tick_label(*v))
                    .y_label_formatter(&|v| tick_label(*v))
                    .label_style(("sans-serif", 16))
                    .light_line_style(RGBColor(235, 235, 235))
                    .draw()
                    .map_err(plot_error)?;
                for s in series {
                    let (color, shape) = style(s.color);
                    let pts: Vec<(f64, f64)> = s.points.iter().filter(keep).copied().collect();
                    if s.line {
                        chart
                            .draw_series(LineSeries::new(pts.clone(), color.stroke_width(2)))
                            .map_err(plot_error)?;
                    }
                    if s.markers {
                        draw_markers(&mut chart, &pts, shape, color, 4)?;
                    }
                }
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
        let entries: Vec<LegendEntry> = series
            .iter()
            .map(|s| LegendEntry {
                label: s.label.clone(),
                style: s.color,
                line: s.line,
                markers: s.markers,
            })
            .collect();
        draw_legend(&legend, 30, &entries)?;
        root.present().map_err(plot_error)?;
    }
    encode_png(&buffer, w, h)
}

/// A scatter of particles coloured by speed (blue slow, red fast), for a
/// 2D frame in the box `[x0, x1] x [y0, y1]`, with `walls` drawn over it
/// as black polylines.
///
/// # Errors
/// If drawing fails.
pub fn speed_scatter_png(
    frame: &crate::scene::Frame,
    bounds: [f64; 4],
    title: &str,
    walls: &[Vec<(f64, f64)>],
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
        for line in walls {
            chart
                .draw_series(LineSeries::new(line.iter().copied(), BLACK.stroke_width(2)))
                .map_err(plot_error)?;
        }
        root.present().map_err(plot_error)?;
    }
    encode_png(&buffer, w, h)
}

/// Particles of 2D frames in a row of panels, coloured by a field on one
/// common scale (blue low, red high): `panels` pairs each frame with its
/// title, `value(frame, k)` is particle `k`'s value, `bounds` the box
/// `[x0, x1, y0, y1]` every panel shows.
///
/// # Errors
/// If drawing fails.
pub fn field_panels_png(
    panels: &[(&crate::scene::Frame, String)],
    bounds: [f64; 4],
    value: impl Fn(&crate::scene::Frame, usize) -> f64,
    label: &str,
) -> Result<Vec<u8>> {
    ensure_font();
    let side = 420u32;
    let (w, h) = (side * panels.len().max(1) as u32, side + 40);
    let mut buffer = vec![255u8; (w * h * 3) as usize];
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for (f, _) in panels {
        for k in 0..f.x.len() {
            let v = value(f, k);
            if v.is_finite() {
                lo = lo.min(v);
                hi = hi.max(v);
            }
        }
    }
    if hi <= lo {
        (lo, hi) = if lo.is_finite() {
            (lo, lo + 1.0)
        } else {
            (0.0, 1.0)
        };
    }
    drawable(bounds[0], bounds[1], "x")?;
    drawable(bounds[2], bounds[3], "y")?;
    {
        let root = BitMapBackend::with_buffer(&mut buffer, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_error)?;
        let titled = root
            .titled(
                &format!(
                    "{label}: {} (blue) to {} (red)",
                    tick_label(lo),
                    tick_label(hi)
                ),
                ("sans-serif", 20),
            )
            .map_err(plot_error)?;
        let areas = titled.split_evenly((1, panels.len().max(1)));
        for ((f, title), area) in panels.iter().zip(&areas) {
            let mut chart = ChartBuilder::on(area)
                .caption(title.as_str(), ("sans-serif", 16))
                .margin(8)
                .x_label_area_size(25)
                .y_label_area_size(30)
                .build_cartesian_2d(bounds[0]..bounds[1], bounds[2]..bounds[3])
                .map_err(plot_error)?;
            chart
                .configure_mesh()
                .disable_mesh()
                .x_label_formatter(&|v| tick_label(*v))
                .y_label_formatter(&|v| tick_label(*v))
                .label_style(("sans-serif", 12))
                .draw()
                .map_err(plot_error)?;
            chart
                .draw_series((0..f.x.len()).map(|k| {
                    let s = ((value(f, k) - lo) / (hi - lo)).clamp(0.0, 1.0);
                    let color = HSLColor(0.66 * (1.0 - s), 0.9, 0.5);
                    Circle::new((f.x[k][0], f.x[k][1]), 1, color.filled())
                }))
                .map_err(plot_error)?;
        }
        root.present().map_err(plot_error)?;
    }
    encode_png(&buffer, w, h)
}

/// PNG images stacked top to bottom on a white background, centred.
///
/// # Errors
/// If an image does not decode or the result does not encode.
pub fn stack_png(images: &[Vec<u8>]) -> Result<Vec<u8>> {
    let decoded = images
        .iter()
        .map(|png| {
            image::load_from_memory(png)
                .map(|i| i.to_rgb8())
                .map_err(plot_error)
        })
        .collect::<Result<Vec<_>>>()?;
    let w = decoded.iter().map(|i| i.width()).max().unwrap_or(1);
    let h = decoded.iter().map(|i| i.height()).sum::<u32>().max(1);
    let mut out = image::RgbImage::from_pixel(w, h, image::Rgb([255, 255, 255]));
    let mut y = 0;
    for i in &decoded {
        image::imageops::replace(&mut out, i, i64::from((w - i.width()) / 2), i64::from(y));
        y += i.height();
    }
    encode_png(out.as_raw(), w, h)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tick_labels_are_short_on_every_scale() {
        for (v, text) in [
            (0.0, "0"),
            (1.0, "1"),
            (0.5, "0.5"),
            (20.0, "20"),
            (0.001, "0.001"),
            (0.0025, "0.0025"),
            (1e-6, "1e-6"),
            (2.5e-7, "2.5e-7"),
            (3e5, "3e5"),
            (-0.02, "-0.02"),
            (12345.0, "12345"),
        ] {
            assert_eq!(tick_label(v), text, "{v}");
        }
        // Round-off in a key point never spells out its noise.
        assert_eq!(tick_label(0.1 + 0.2), "0.3");
        assert_eq!(tick_label(3.0000000000000004e-6), "3e-6");
    }

    #[test]
    fn no_two_of_the_first_32_styles_look_alike() {
        let styles: Vec<_> = (0..32).map(style).collect();
        for (i, a) in styles.iter().enumerate() {
            for b in &styles[i + 1..] {
                assert_ne!(a, b);
            }
            // The reference style (black) is no series' style.
            assert_ne!(*a, style(REFERENCE));
        }
    }
}
