//! `meshlap experiment figures`.

use crate::common::print_json;
use indicatif::{ProgressBar, ProgressStyle};
use meshlap::experiment::figures::{error_table, figure, FigureModel};
use meshlap::experiment::Outputs;
use meshlap::input::{self, OpenOptions};
use meshlap::operator::OperatorKind;
use serde::Serialize;
use std::path::PathBuf;

/// The paper's Figs. 1 and 4, re-made as rendered PNG panels.
///
/// Fig. 1 (fig1_<model>.png): each model, its JPEG-like truncated reconstruction with the
/// normalized graph Laplacian (GL) and with the SQL and TL at the same number m of
/// coefficients. The GL's are not smooth versions of the mesh (its lowest eigenvector is
/// not constant); the GSMLs' are. Fig. 4 (fig4_4_8_sphere.png): KL, SQL and SSTL
/// reconstructions of the paper's sphere with 4-8 connectivity (builtin:sphere48:12);
/// the KL shows artifacts at the degree-4 vertices. Errors of every
/// reconstruction in figures.md/.csv and figures.json.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The mesh of Fig. 1 beside builtin:icosphere:3 (dense ED: at most 5,000 vertices).
    #[arg(long, default_value = "../shared/data/meshes/cow.obj")]
    pub mesh: String,
    /// Fraction of the coefficients kept in Fig. 1.
    #[arg(long, default_value_t = 0.05)]
    pub keep_fraction: f64,
    /// Coefficients kept in Fig. 4.
    #[arg(long, default_value_t = 24)]
    pub fig4_keep: usize,
    /// Picture size of each cell, pixels.
    #[arg(long, default_value_t = 420)]
    pub size: u32,
    /// Output directory (created if missing).
    #[arg(long, default_value = "figures")]
    pub out: PathBuf,
    /// Also print the JSON results on stdout.
    #[arg(long)]
    pub json: bool,
}

#[derive(Serialize)]
struct Results<'a> {
    fig1: &'a [meshlap::experiment::figures::Reconstruction],
    fig4: &'a [meshlap::experiment::figures::Reconstruction],
}

pub fn run(args: &Args) -> meshlap::Result<()> {
    if !(args.keep_fraction > 0.0 && args.keep_fraction <= 1.0) {
        return Err(meshlap::Error::InvalidArgument(format!(
            "--keep-fraction must be in (0, 1], got {}",
            args.keep_fraction
        )));
    }
    let mut out = Outputs::new(&args.out)?;
    let bar = ProgressBar::new_spinner();
    bar.set_style(
        ProgressStyle::with_template("{spinner} {msg} [{elapsed}]").expect("static template"),
    );
    bar.set_message("Fig. 1");
    let mut models = Vec::new();
    for (spec, name, view) in [
        (args.mesh.as_str(), None, (-60.0, 15.0)),
        ("builtin:icosphere:3", Some("Sphere"), (20.0, 20.0)),
    ] {
        let input = input::open(spec, &OpenOptions::default())?;
        let n = input.mesh.n_vertices();
        let name = name
            .map(str::to_string)
            .unwrap_or_else(|| meshlap::experiment::claims::short_name(spec));
        models.push(FigureModel {
            name,
            input,
            keep: ((n as f64 * args.keep_fraction).round() as usize).max(1),
            view,
        });
    }
    let fig1 = figure(
        &mut out,
        "fig1",
        "Fig. 1 — GL versus GSML truncated reconstructions",
        &models,
        &[OperatorKind::Graph, OperatorKind::Sql, OperatorKind::Tutte],
        args.size,
    )?;
    bar.set_message("Fig. 4");
    let sphere = input::open("builtin:sphere48:12", &OpenOptions::default())?;
    let fig4 = figure(
        &mut out,
        "fig4",
        "Fig. 4 — KL artifacts at low-degree vertices",
        &[FigureModel {
            name: "4-8 sphere".into(),
            input: sphere,
            keep: args.fig4_keep,
            view: (35.0, 30.0),
        }],
        &[
            OperatorKind::Kirchhoff,
            OperatorKind::Sql,
            OperatorKind::Sstl,
        ],
        args.size,
    )?;
    bar.finish_and_clear();
    let mut rows = fig1.clone();
    rows.extend(fig4.iter().cloned());
    let table = error_table("Truncated ED reconstructions (Figs. 1 and 4)", &rows);
    out.table("figures", &table)?;
    let results = Results {
        fig1: &fig1,
        fig4: &fig4,
    };
    out.json("figures.json", &results)?;
    if args.json {
        return print_json(&results);
    }
    println!("{}", table.to_markdown());
    eprintln!(
        "wrote {} files to {}",
        out.written().len(),
        out.dir().display()
    );
    Ok(())
}
