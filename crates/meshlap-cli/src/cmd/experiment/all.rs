//! `meshlap experiment all`: every experiment of the paper in one command.

use clap::{Args as ClapArgs, Parser};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Run every experiment of the paper, each with its defaults, into one directory.
///
/// DIR/claims (§2–3 properties, SQL erratum, repair, smoothing limits), DIR/figures
/// (Figs. 1 and 4), DIR/eigen-cost (Fig. 3 and §4.9 energy compaction), DIR/fairing
/// (Table 1 on cow, horse, bunny, Igea), DIR/compression (§4.9 rate–distortion per
/// operator), and DIR/README.md indexing the results. The paper's meshes are read from
/// --meshes (default ../shared/data/meshes, i.e. run from the repository root).
/// --quick uses small meshes and sizes (a few minutes on 2 cores).
#[derive(ClapArgs, Debug)]
pub struct Args {
    /// Output directory (created if missing).
    #[arg(long, default_value = "experiments")]
    pub out: PathBuf,
    /// Directory with the shared test meshes (cow.obj, horse.ply, stanford-bunny.obj, igea.ply, …).
    #[arg(long, default_value = "../shared/data/meshes")]
    pub meshes: PathBuf,
    /// Small meshes and sizes only.
    #[arg(long)]
    pub quick: bool,
}

/// Parses a sibling experiment's arguments from words, so that each runs with exactly
/// the defaults of its own command.
#[derive(Parser, Debug)]
struct Wrap<T: ClapArgs> {
    #[command(flatten)]
    inner: T,
}

fn parse<T: ClapArgs>(words: &[String]) -> meshlap::Result<T> {
    Wrap::<T>::try_parse_from(std::iter::once("meshlap".to_string()).chain(words.iter().cloned()))
        .map(|w| w.inner)
        .map_err(|e| {
            meshlap::Error::InvalidArgument(e.to_string().lines().next().unwrap_or("").to_string())
        })
}

fn words(v: &[&str]) -> Vec<String> {
    v.iter().map(|s| s.to_string()).collect()
}

fn mesh(dir: &Path, name: &str) -> String {
    dir.join(name).to_string_lossy().into_owned()
}

pub fn run(args: &Args) -> meshlap::Result<()> {
    let out = |name: &str| args.out.join(name).to_string_lossy().into_owned();
    let m = |name: &str| mesh(&args.meshes, name);
    let (cow, woody, teapot, bunny, horse, igea) = (
        m("cow.obj"),
        m("woody.obj"),
        m("teapot.obj"),
        m("stanford-bunny.obj"),
        m("horse.ply"),
        m("igea.ply"),
    );
    let mut index = vec![
        "# meshlap: the experiments of Zhang 2004".to_string(),
        String::new(),
        format!(
            "Produced by `meshlap experiment all --out {}{}`.",
            args.out.display(),
            if args.quick { " --quick" } else { "" }
        ),
        String::new(),
    ];
    let mut step = |title: &str,
                    dir: &str,
                    f: &mut dyn FnMut() -> meshlap::Result<()>|
     -> meshlap::Result<()> {
        eprintln!("== {title}");
        let t = Instant::now();
        f()?;
        index.push(format!(
            "- [{title}]({dir}/) — {:.1} s",
            t.elapsed().as_secs_f64()
        ));
        Ok(())
    };

    let mut claims = words(&[
        "--out",
        &out("claims"),
        "--mesh",
        &cow,
        "--mesh",
        &woody,
        "--mesh",
        "builtin:grid:12",
        "--mesh",
        "builtin:icosahedron",
        "--boundary-mesh",
        &teapot,
        "--boundary-mesh",
        &bunny,
        "--repair-mesh",
        &cow,
        "--repair-mesh",
        &teapot,
        "--repair-mesh",
        &horse,
        "--limit-mesh",
        &woody,
    ]);
    if args.quick {
        claims = words(&[
            "--out",
            &out("claims"),
            "--mesh",
            &woody,
            "--mesh",
            "builtin:grid:12",
            "--boundary-mesh",
            &teapot,
            "--repair-mesh",
            &cow,
            "--limit-mesh",
            &woody,
        ]);
    }
    step(
        "§2–3 claims: operator properties, SQL erratum, SQL repair, smoothing limits",
        "claims",
        &mut || super::claims::run(&parse(&claims)?),
    )?;

    let figures = words(&[
        "--out",
        &out("figures"),
        "--mesh",
        if args.quick {
            "builtin:icosphere:2"
        } else {
            &cow
        },
    ]);
    step(
        "Figs. 1 and 4: GL vs GSML reconstructions, KL artifacts",
        "figures",
        &mut || super::figures::run(&parse(&figures)?),
    )?;

    let mut eigen = words(&[
        "--out",
        &out("eigen-cost"),
        "--mesh",
        &bunny,
        "--mesh",
        &horse,
    ]);
    if args.quick {
        eigen = words(&[
            "--out",
            &out("eigen-cost"),
            "--mesh",
            "builtin:icosphere:4",
            "--sizes",
            "100,200,400",
            "--compaction-size",
            "400",
        ]);
    }
    step(
        "Fig. 3 and §4.9: cost of the ED transforms, energy compaction",
        "eigen-cost",
        &mut || super::eigen_cost::run(&parse(&eigen)?),
    )?;

    let fairing = if args.quick {
        words(&["--out", &out("fairing"), &cow, "--repeat", "1"])
    } else {
        words(&["--out", &out("fairing"), &cow, &horse, &bunny, &igea])
    };
    step(
        "Table 1: implicit fairing with CG and BiCG",
        "fairing",
        &mut || super::fairing::run(&parse(&fairing)?),
    )?;

    let compression = if args.quick {
        words(&[
            "--out",
            &out("compression"),
            "builtin:icosphere:3",
            "builtin:step:12",
        ])
    } else {
        words(&[
            "--out",
            &out("compression"),
            "builtin:icosphere:4",
            "builtin:cube:8",
            "builtin:step:20",
            &cow,
        ])
    };
    step(
        "§4.9: spectral compression per operator",
        "compression",
        &mut || super::compression::run(&parse(&compression)?),
    )?;

    let text = index.join("\n") + "\n";
    meshlap::io::write_atomic(&args.out.join("README.md"), |w| {
        w.write_all(text.as_bytes())
    })?;
    eprintln!("wrote {}", args.out.join("README.md").display());
    Ok(())
}
