//! PNG line charts for the experiments (eigendecomposition cost, energy compaction,
//! solver convergence, rate–distortion curves).
//!
//! A [`Chart`] holds named [`Series`] of `(x, y)` points and linear or logarithmic
//! axes ([`Scale`]). [`Chart::render`] draws it with `plotters` into an
//! [`Image`](crate::raster::Image) (text through [`crate::raster::text`]), and
//! [`Chart::write_png`] writes it through [`crate::io::write_atomic`]: a chart file is
//! either complete or absent.
//!
//! ```no_run
//! use meshlap::plot::{Chart, Scale, Series};
//! let chart = Chart::new("CG residual", "iteration", "‖r‖/‖b‖")
//!     .with_scales(Scale::Linear, Scale::Log)
//!     .with_series(vec![Series::new("SQL", vec![(0.0, 1.0), (1.0, 0.1), (2.0, 0.01)])]);
//! chart.write_png(std::path::Path::new("out/residual.png")).unwrap();
//! ```
//!
//! Only built with the `pictures` feature.

mod axis;
mod canvas;
mod chart;
mod draw;

pub use chart::{Chart, Scale, Series};

/// Errors of chart rendering.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// The chart has nothing drawable (no series, or no finite point; on a log axis,
    /// no positive value). Give at least one series with a finite point.
    #[error("chart `{0}` has no drawable points")]
    Empty(String),
    /// The picture size is outside 200×150 … 8192×8192.
    #[error("chart size {width}×{height} outside 200×150 … 8192×8192")]
    Size {
        /// Requested width.
        width: u32,
        /// Requested height.
        height: u32,
    },
    /// The drawing backend (plotters) failed.
    #[error("cannot draw chart `{title}`: {source}")]
    Draw {
        /// Chart title.
        title: String,
        /// plotters' error.
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    /// Writing the PNG failed.
    #[error(transparent)]
    Io(#[from] crate::io::IoError),
}
