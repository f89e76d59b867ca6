//! `meshlap compaction`.

use super::spectrum::BasisArgs;
use crate::common::print_json;
use meshlap::io::write_atomic;
use meshlap::operator::OperatorKind;
use meshlap::spectral::compaction::{positions_compaction, Compaction};
use meshlap::spectral::EigenPath;
use serde::Serialize;
use std::path::PathBuf;

/// Energy compaction (transform efficiency, Zhang 2004 §4.9) of the geometry in an
/// operator's ED-transform: for every m, the fraction of the energy of the spectral
/// coefficients of x, y, z (and in total) held by the first m (lowest-frequency)
/// coefficients. Higher is better compaction. The paper finds the order SSTL, SQL,
/// TL, KL (best first) on smooth models and roughly the reverse on models with sharp
/// transitions (builtin:cube, builtin:step).
///
/// Vertex positions are used as given unless --centre moves the centroid to the
/// origin (the first coefficient of a GSML is the centroid, which otherwise dominates
/// the energy).
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub basis: BasisArgs,
    /// Translate the mesh's centroid to the origin first.
    #[arg(long)]
    pub centre: bool,
    /// Write every m as CSV: m,x,y,z,total.
    #[arg(long, value_name = "FILE")]
    pub csv: Option<PathBuf>,
    /// Print machine-readable JSON (every m; arrays indexed by m − 1).
    #[arg(long)]
    pub json: bool,
}

#[derive(Serialize)]
struct CompactionJson<'a> {
    source: &'a str,
    kind: OperatorKind,
    path: EigenPath,
    vertices: usize,
    centred: bool,
    /// Mean of η(m) over m (area under the curve).
    mean_efficiency: f64,
    /// Smallest m holding 90%, 99% and 99.9% of the energy.
    m_90: usize,
    m_99: usize,
    m_999: usize,
    #[serde(flatten)]
    compaction: &'a Compaction,
}

pub fn run(args: &Args) -> meshlap::Result<()> {
    let input = args.basis.mesh.open()?;
    let n = input.mesh.n_vertices();
    let op = args.basis.operator(&input)?;
    let (comp, path) = positions_compaction(
        &op,
        &input.mesh.positions,
        args.centre,
        &args.basis.options(),
    )?;
    if let Some(csv) = &args.csv {
        write_atomic(csv, |w| {
            writeln!(w, "m,x,y,z,total")?;
            for m in 0..comp.len() {
                writeln!(
                    w,
                    "{},{:.17e},{:.17e},{:.17e},{:.17e}",
                    m + 1,
                    comp.per_coordinate[0][m],
                    comp.per_coordinate[1][m],
                    comp.per_coordinate[2][m],
                    comp.total[m]
                )?;
            }
            Ok(())
        })?;
    }
    if args.json {
        return print_json(&CompactionJson {
            source: &input.source,
            kind: args.basis.kind,
            path,
            vertices: n,
            centred: args.centre,
            mean_efficiency: comp.mean_efficiency(),
            m_90: comp.coefficients_for(0.9),
            m_99: comp.coefficients_for(0.99),
            m_999: comp.coefficients_for(0.999),
            compaction: &comp,
        });
    }
    println!(
        "{} ED-transform of {} ({n} vertices{}), {} path",
        args.basis.kind,
        input.source,
        if args.centre { ", centred" } else { "" },
        path
    );
    println!(
        "mean efficiency {:.6}; 90% of the energy in {} coefficients, 99% in {}, 99.9% in {}",
        comp.mean_efficiency(),
        comp.coefficients_for(0.9),
        comp.coefficients_for(0.99),
        comp.coefficients_for(0.999)
    );
    println!(
        "{:>7}  {:>10}  {:>10}  {:>10}  {:>10}",
        "m", "x", "y", "z", "total"
    );
    let mut m = 1;
    while m <= n {
        println!(
            "{:>7}  {:>10.6}  {:>10.6}  {:>10.6}  {:>10.6}",
            m,
            comp.per_coordinate[0][m - 1],
            comp.per_coordinate[1][m - 1],
            comp.per_coordinate[2][m - 1],
            comp.total[m - 1]
        );
        m = if m < 10 { m + 1 } else { m * 2 };
    }
    Ok(())
}
