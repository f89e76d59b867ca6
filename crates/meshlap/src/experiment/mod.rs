//! The paper's experiments as library functions: each returns data (serialisable) and
//! [`Table`]s, and writes its tables and pictures into an output directory through
//! [`Outputs`]. The CLI's `meshlap experiment …` commands only parse arguments and call
//! these.
//!
//! - [`claims`]: §2–3 — the matrix-theoretic properties of every operator measured on
//!   real meshes (Zhang 2004, §2.2–2.5 and §3), the SQL boundary-diagonal erratum, the
//!   SQL negative-weight repair (§3.7), and the smoothing limits (§2.2: the TL converges
//!   to the valence-weighted centroid, a doubly stochastic H to the centroid).
//! - [`figures`]: the paper's Figs. 1 and 4 — truncated ED reconstructions rendered.
//! - [`compression`]: §4.9 — rate–distortion of spectral compression per operator and
//!   against Draco.
//! - [`eigen_cost`]: §4.9 — the cost of the ED-transform per operator (Fig. 3) and the
//!   energy compaction of SSTL, SQL, TL, KL on smooth and sharp models.
//! - [`fairing`]: §4.10, Table 1 — CG on the SQL vs BiCG on the TL for implicit fairing.

pub mod claims;
pub mod compression;

pub mod eigen_cost;
pub mod fairing;
pub mod figures;

use serde::Serialize;
use std::path::{Path, PathBuf};

/// Errors of the experiments.
#[derive(Debug, thiserror::Error)]
pub enum ExperimentError {
    /// A mesh could not be opened or processed.
    #[error("{source_name}: {message}")]
    Input {
        /// The mesh (path or builtin spec).
        source_name: String,
        /// What went wrong.
        message: String,
    },
    /// Writing a result failed.
    #[error(transparent)]
    Io(#[from] crate::io::IoError),
    /// A chart could not be drawn.
    #[error(transparent)]
    Plot(#[from] crate::plot::PlotError),
    /// A picture could not be rendered.
    #[error(transparent)]
    Render(#[from] crate::render::RenderError),
    /// Serialising a result failed.
    #[error("cannot serialise results: {0}")]
    Json(String),
    /// The output directory cannot be created.
    #[error("cannot create {path}: {source}")]
    Dir {
        /// The directory.
        path: PathBuf,
        /// Cause.
        #[source]
        source: std::io::Error,
    },
}

/// A result table: a header and rows of already formatted cells.
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct Table {
    /// Caption.
    pub title: String,
    /// Column names.
    pub header: Vec<String>,
    /// Rows, each as long as the header.
    pub rows: Vec<Vec<String>>,
    /// Notes printed under the table.
    pub notes: Vec<String>,
}

impl Table {
    /// An empty table with a caption and column names.
    pub fn new(title: impl Into<String>, header: &[&str]) -> Self {
        Table {
            title: title.into(),
            header: header.iter().map(|s| s.to_string()).collect(),
            ..Default::default()
        }
    }

    /// Appends a row (padded or truncated to the header's width).
    pub fn push(&mut self, row: Vec<String>) {
        let mut row = row;
        row.resize(self.header.len(), String::new());
        self.rows.push(row);
    }

    /// GitHub-flavoured Markdown, columns padded for reading as plain text.
    pub fn to_markdown(&self) -> String {
        let esc = |s: &str| s.replace('|', "\\|");
        let widths: Vec<usize> = (0..self.header.len())
            .map(|c| {
                self.rows
                    .iter()
                    .map(|r| esc(&r[c]).chars().count())
                    .chain([esc(&self.header[c]).chars().count(), 3])
                    .max()
                    .unwrap_or(3)
            })
            .collect();
        let line = |cells: &[String]| {
            let mut s = String::from("|");
            for (c, w) in cells.iter().zip(&widths) {
                let e = esc(c);
                s += &format!(" {e}{} |", " ".repeat(w - e.chars().count()));
            }
            s + "\n"
        };
        let mut out = String::new();
        if !self.title.is_empty() {
            out += &format!("**{}**\n\n", self.title);
        }
        out += &line(&self.header);
        out += "|";
        for w in &widths {
            out += &format!("{}|", "-".repeat(w + 2));
        }
        out += "\n";
        for r in &self.rows {
            out += &line(r);
        }
        for n in &self.notes {
            out += &format!("\n{n}\n");
        }
        out
    }

    /// RFC 4180 CSV (header first).
    pub fn to_csv(&self) -> String {
        let cell = |s: &String| {
            if s.contains([',', '"', '\n']) {
                format!("\"{}\"", s.replace('"', "\"\""))
            } else {
                s.clone()
            }
        };
        std::iter::once(&self.header)
            .chain(&self.rows)
            .map(|r| r.iter().map(cell).collect::<Vec<_>>().join(",") + "\n")
            .collect()
    }
}

/// Formats a float with `digits` significant digits, or `n/a`.
pub fn sig(v: Option<f64>, digits: usize) -> String {
    match v {
        None => "n/a".into(),
        Some(0.0) => "0".into(),
        Some(x) if !x.is_finite() => format!("{x}"),
        Some(x) => {
            let a = x.abs();
            if (1e-3..1e5).contains(&a) {
                let decimals = (digits as i32 - 1 - a.log10().floor() as i32).max(0) as usize;
                format!("{x:.decimals$}")
            } else {
                format!("{x:.prec$e}", prec = digits.saturating_sub(1))
            }
        }
    }
}

/// `yes` / `no`, or `n/a`.
pub fn yes_no(v: Option<bool>) -> String {
    match v {
        Some(true) => "yes".into(),
        Some(false) => "no".into(),
        None => "n/a".into(),
    }
}

/// An output directory for an experiment's files, each written atomically.
#[derive(Clone, Debug)]
pub struct Outputs {
    dir: PathBuf,
    written: Vec<PathBuf>,
}

impl Outputs {
    /// Creates (if needed) and uses `dir`.
    pub fn new(dir: &Path) -> Result<Self, ExperimentError> {
        std::fs::create_dir_all(dir).map_err(|source| ExperimentError::Dir {
            path: dir.to_path_buf(),
            source,
        })?;
        Ok(Outputs {
            dir: dir.to_path_buf(),
            written: Vec::new(),
        })
    }

    /// The directory.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The files written so far.
    pub fn written(&self) -> &[PathBuf] {
        &self.written
    }

    /// The path of `name` inside the directory, recorded as written.
    pub fn path(&mut self, name: &str) -> PathBuf {
        let p = self.dir.join(name);
        self.written.push(p.clone());
        p
    }

    /// Writes text.
    pub fn text(&mut self, name: &str, text: &str) -> Result<PathBuf, ExperimentError> {
        let p = self.path(name);
        crate::io::write_atomic(&p, |w| w.write_all(text.as_bytes()))?;
        Ok(p)
    }

    /// Writes a value as pretty JSON.
    pub fn json<T: Serialize>(
        &mut self,
        name: &str,
        value: &T,
    ) -> Result<PathBuf, ExperimentError> {
        let s = serde_json::to_string_pretty(value)
            .map_err(|e| ExperimentError::Json(e.to_string()))?;
        self.text(name, &(s + "\n"))
    }

    /// Writes `stem.md` and `stem.csv` for a table.
    pub fn table(&mut self, stem: &str, table: &Table) -> Result<(), ExperimentError> {
        self.text(&format!("{stem}.md"), &table.to_markdown())?;
        self.text(&format!("{stem}.csv"), &table.to_csv())?;
        Ok(())
    }

    /// Writes a chart as PNG.
    pub fn chart(
        &mut self,
        name: &str,
        chart: &crate::plot::Chart,
    ) -> Result<PathBuf, ExperimentError> {
        let p = self.path(name);
        chart.write_png(&p)?;
        Ok(p)
    }

    /// Writes an image as PNG.
    pub fn image(
        &mut self,
        name: &str,
        image: &crate::raster::Image,
    ) -> Result<PathBuf, ExperimentError> {
        let p = self.path(name);
        image.write_png(&p)?;
        Ok(p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn markdown_and_csv() {
        let mut t = Table::new("T", &["a", "b|c"]);
        t.push(vec!["1".into(), "x,y".into()]);
        t.push(vec!["22".into()]);
        t.notes.push("note".into());
        let md = t.to_markdown();
        assert!(
            md.starts_with(
                "**T**\n\n| a   | b\\|c |\n|-----|------|\n| 1   | x,y  |\n| 22  |      |\n"
            ),
            "{md}"
        );
        assert!(md.ends_with("\nnote\n"));
        assert_eq!(t.to_csv(), "a,b|c\n1,\"x,y\"\n22,\n");
    }

    #[test]
    fn number_formatting() {
        assert_eq!(sig(Some(0.7312), 3), "0.731");
        assert_eq!(sig(Some(123.456), 3), "123");
        assert_eq!(sig(Some(1.5e-12), 2), "1.5e-12");
        assert_eq!(sig(None, 2), "n/a");
        assert_eq!(sig(Some(0.0), 2), "0");
        assert_eq!(yes_no(Some(true)), "yes");
    }

    #[test]
    fn outputs_write_atomically_into_a_new_directory() {
        let d = tempfile::tempdir().unwrap();
        let mut o = Outputs::new(&d.path().join("x/y")).unwrap();
        let mut t = Table::new("", &["k"]);
        t.push(vec!["v".into()]);
        o.table("t", &t).unwrap();
        o.json("t.json", &t).unwrap();
        assert_eq!(o.written().len(), 3);
        assert_eq!(
            std::fs::read_to_string(d.path().join("x/y/t.csv")).unwrap(),
            "k\nv\n"
        );
    }
}
