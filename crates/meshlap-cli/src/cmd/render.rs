//! `meshlap render`.

use crate::common::MeshArgs;
use meshlap::render::{render, Coloring, Colormap, RenderOptions, Scalars};
use std::path::PathBuf;

/// What to colour the surface by.
#[derive(clap::ValueEnum, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ColourBy {
    /// A uniform clay colour.
    #[default]
    Clay,
    /// Vertex degree (valence): shows irregular connectivity.
    Degree,
    /// Height along +y.
    Height,
}

/// Render a picture of a mesh to PNG (software z-buffer, no GPU or display needed).
///
/// Orthographic view fitted to the mesh's bounding sphere; `--azimuth` turns the mesh
/// about the vertical axis, `--elevation` tilts it towards the viewer. Two-sided Lambert
/// shading, flat by default (facets visible, as in the paper's figures) or `--smooth`.
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub mesh: MeshArgs,
    /// Output PNG file.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Image width in pixels.
    #[arg(long, default_value_t = 800)]
    pub width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 800)]
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
    /// Surface colour.
    #[arg(long, value_enum, default_value_t = ColourBy::Clay)]
    pub colour: ColourBy,
}

pub fn run(args: &Args) -> meshlap::Result<()> {
    let input = args.mesh.open()?;
    let mesh = &input.mesh;
    let colouring = match args.colour {
        ColourBy::Clay => Coloring::Clay,
        ColourBy::Degree => Coloring::Scalar(Scalars::new(
            input.topology.degrees().iter().map(|&d| d as f64).collect(),
            Colormap::Viridis,
        )),
        ColourBy::Height => Coloring::Scalar(Scalars::new(
            mesh.positions.iter().map(|p| p[1]).collect(),
            Colormap::Viridis,
        )),
    };
    let opts = RenderOptions {
        width: args.width,
        height: args.height,
        azimuth: args.azimuth,
        elevation: args.elevation,
        smooth: args.smooth,
        wireframe: args.wireframe,
        coloring: colouring,
        ..Default::default()
    };
    render(mesh, &opts)?.write_png(&args.output)?;
    eprintln!("wrote {}", args.output.display());
    Ok(())
}
