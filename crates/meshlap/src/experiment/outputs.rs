//! [`Outputs`]: an experiment's output directory, every file written atomically and
//! recorded.

use super::{ExperimentError, Table};
use serde::Serialize;
use std::path::{Path, PathBuf};

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
            .map_err(|source| ExperimentError::Json { source })?;
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
        self.image(name, &chart.render()?)
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
