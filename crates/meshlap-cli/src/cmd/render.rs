//! `meshlap render`.

use crate::common::{spinner, MeshInOut};
use meshlap::operator::{Operator, OperatorKind};
use meshlap::render::{render, Coloring, Colormap, RenderOptions, Scalars};
use std::path::PathBuf;

/// What to color the surface by, when no scalars are given.
#[derive(clap::ValueEnum, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ColorBy {
    /// A uniform clay color.
    #[default]
    Clay,
    /// Vertex degree (valence): shows irregular connectivity.
    Degree,
    /// Height along +y.
    Height,
}

/// A color map (see `meshlap::raster::Colormap`).
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum ColormapArg {
    /// Sequential dark purple → yellow.
    Viridis,
    /// Diverging blue → gray → red, zero in the middle (signed data).
    Coolwarm,
}

impl From<ColormapArg> for Colormap {
    fn from(c: ColormapArg) -> Self {
        match c {
            ColormapArg::Viridis => Colormap::Viridis,
            ColormapArg::Coolwarm => Colormap::Coolwarm,
        }
    }
}

/// Render a picture of a mesh to PNG (software z-buffer, no GPU or display needed).
///
/// Orthographic view framed so that the mesh fills the picture; `--azimuth` turns the
/// mesh about the vertical axis, `--elevation` tilts it towards the viewer. Two-sided
/// Lambert shading, flat by default (facets visible, as in the paper's figures) or
/// `--smooth`. Per-vertex scalars — `--color degree|height`, a NumPy file
/// (`--scalars`), or an operator's eigenvector (`--eigenvector K --kind KIND`) — are
/// shown through a color map with a color bar at the right.
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub io: MeshInOut,
    /// Image width in pixels.
    #[arg(long, default_value_t = RenderOptions::DEFAULT_SIZE)]
    pub width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = RenderOptions::DEFAULT_SIZE)]
    pub height: u32,
    /// Rotation about the vertical axis, degrees.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub azimuth: f64,
    /// Tilt about the horizontal axis, degrees.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub elevation: f64,
    /// Interpolated (smooth) normals instead of flat facets.
    #[arg(long)]
    pub smooth: bool,
    /// Darken triangle edges.
    #[arg(long)]
    pub wireframe: bool,
    /// Surface color: clay, or vertex degree or height through viridis.
    #[arg(long, value_enum, default_value_t = ColorBy::Clay, alias = "colour")]
    pub color: ColorBy,
    /// Color by the values of a float64 .npy file, one per vertex (shape (n,) or (n, 1),
    /// in the order of the cleaned mesh).
    #[arg(long, value_name = "FILE.npy", conflicts_with_all = ["color", "eigenvector"])]
    pub scalars: Option<PathBuf>,
    /// Color by eigenvector K (0 = smallest eigenvalue) of the --kind operator.
    #[arg(long, value_name = "K", requires = "kind", conflicts_with = "color")]
    pub eigenvector: Option<usize>,
    /// Operator of --eigenvector: kirchhoff (kl), tutte (tl), graph (gl), sql, sstl,
    /// cotan, … (see `meshlap operator --help`).
    #[arg(long, short, requires = "eigenvector")]
    pub kind: Option<OperatorKind>,
    /// Color map (default: viridis; coolwarm for --eigenvector).
    #[arg(long, value_enum)]
    pub colormap: Option<ColormapArg>,
    /// No color bar.
    #[arg(long)]
    pub no_legend: bool,
}

pub fn run(args: &Args) -> meshlap::Result<()> {
    let input = args.io.mesh.open()?;
    let mesh = &input.mesh;
    let scalars = if let Some(path) = &args.scalars {
        let colormap = args.colormap.map_or(Colormap::Viridis, Colormap::from);
        Some(Scalars::from_npy(path, mesh.n_vertices(), colormap)?)
    } else if let (Some(k), Some(kind)) = (args.eigenvector, args.kind) {
        let bar = spinner(format!("eigenvector {k} of the {kind} operator"));
        let op = Operator::on_input(kind, &input)?;
        let s = Scalars::eigenvector(&op, k);
        bar.finish_and_clear();
        Some(s?)
    } else {
        match args.color {
            ColorBy::Clay => None,
            ColorBy::Degree => Some(Scalars::degree(&input.topology)),
            ColorBy::Height => Some(Scalars::height(mesh)),
        }
    };
    let coloring = match scalars {
        None => Coloring::Clay,
        Some(mut s) => {
            if let Some(c) = args.colormap {
                s.colormap = c.into();
            }
            Coloring::Scalar(s)
        }
    };
    let opts = RenderOptions {
        width: args.width,
        height: args.height,
        azimuth: args.azimuth,
        elevation: args.elevation,
        smooth: args.smooth,
        wireframe: args.wireframe,
        coloring,
        legend: !args.no_legend,
        ..Default::default()
    };
    render(mesh, &opts)?.write_png(&args.io.output)?;
    eprintln!("wrote {}", args.io.output.display());
    Ok(())
}
