//! Plots (PNG): the figures every command writes.
//!
//! Drawing needs the `plot` feature (on by default), which brings plotters
//! and image. Without it (the browser module: plotters' text goes through
//! JavaScript glue there) the same functions exist and return
//! [`crate::error::Error::Config`] with key `plot`, so code that writes figures builds
//! unchanged and says why it has none.

#[cfg(feature = "plot")]
mod draw;

#[cfg(feature = "plot")]
pub use draw::{
    encode_png, ensure_font, field_panels_png, line_plot, profiles_png, speed_scatter_png,
    stack_png, style, tick_label, Shape, PALETTE,
};

#[cfg(not(feature = "plot"))]
pub use off::{field_panels_png, line_plot, profiles_png, speed_scatter_png, stack_png};

/// Style index of reference lines (exact solutions, slopes): black, drawn
/// apart from the series' styles.
pub const REFERENCE: usize = usize::MAX;

/// One series of a [`line_plot`].
#[derive(Clone, Debug)]
pub struct Series {
    /// Legend label.
    pub label: String,
    /// Points (x, y); non-positive values are dropped on log axes.
    pub points: Vec<(f64, f64)>,
    /// Style index (colour, then marker shape), or [`REFERENCE`].
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
}

/// The figure functions of a build without the `plot` feature: each
/// returns the same error.
#[cfg(not(feature = "plot"))]
mod off {
    use super::{Axes, Series};
    use crate::couette::CouetteRun;
    use crate::error::{Error, Result};

    fn off() -> Error {
        Error::config(
            "plot",
            "png",
            "this build has no figures: sph-std's `plot` feature is off",
        )
    }

    /// No figure: see the module docs.
    ///
    /// # Errors
    /// Always.
    pub fn profiles_png(_: &CouetteRun) -> Result<Vec<u8>> {
        Err(off())
    }

    /// No figure: see the module docs.
    ///
    /// # Errors
    /// Always.
    pub fn line_plot(_: &Axes, _: &[Series]) -> Result<Vec<u8>> {
        Err(off())
    }

    /// No figure: see the module docs.
    ///
    /// # Errors
    /// Always.
    pub fn speed_scatter_png(
        _: &crate::scene::Frame,
        _: [f64; 4],
        _: &str,
        _: &[Vec<(f64, f64)>],
    ) -> Result<Vec<u8>> {
        Err(off())
    }

    /// No figure: see the module docs.
    ///
    /// # Errors
    /// Always.
    pub fn field_panels_png(
        _: &[(&crate::scene::Frame, String)],
        _: [f64; 4],
        _: impl Fn(&crate::scene::Frame, usize) -> f64,
        _: &str,
    ) -> Result<Vec<u8>> {
        Err(off())
    }

    /// No figure: see the module docs.
    ///
    /// # Errors
    /// Always.
    pub fn stack_png(_: &[Vec<u8>]) -> Result<Vec<u8>> {
        Err(off())
    }
}
