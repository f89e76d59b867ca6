//! The paper's experiments as library functions: each takes an options struct (with
//! `Default`, the settings of its `meshlap experiment …` command, and `quick()`, the
//! reduced settings of `experiment all --quick` and the tests), opens its meshes,
//! computes, writes its tables and pictures into an output directory through
//! [`Outputs`], reports [`Progress`] events, and returns its results. The CLI only
//! parses arguments, calls these and prints.
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
//! - [`watermark`]: spectral watermarking (Ohbuchi et al. 2001/2002) under the
//!   benchmark attacks, per operator.
//! - [`all`]: every experiment into one directory, with an index.
//!
//! Only built with the `experiments` feature. Every operator uses the paper's sign
//! convention `F = D − W` (positive semi-definite).

/// `impl Default for $ty` as `$ty::paper` on [`DEFAULT_MESH_DIR`]: an experiment's
/// defaults are the paper's settings on the shared meshes (see each `paper`).
macro_rules! default_is_paper {
    ($ty:ty) => {
        impl Default for $ty {
            /// The paper's settings (`Self::paper`) on the meshes of
            /// [`DEFAULT_MESH_DIR`](crate::experiment::DEFAULT_MESH_DIR).
            fn default() -> Self {
                Self::paper(std::path::Path::new($crate::experiment::DEFAULT_MESH_DIR))
            }
        }
    };
}

pub mod all;
pub mod claims;
pub mod compression;
pub mod eigen_cost;
pub mod fairing;
pub mod figures;
pub mod meshes;
mod outputs;
mod progress;
mod table;
pub mod watermark;

pub use meshes::{short_name, DEFAULT_MESH_DIR};
pub use outputs::Outputs;
pub use progress::{Progress, ProgressFn};
pub use table::{sig, yes_no, Table};

use std::path::PathBuf;

/// Errors of the experiments.
#[derive(Debug, thiserror::Error)]
pub enum ExperimentError {
    /// A mesh could not be opened or processed (an operator, a basis, a solve or the
    /// codec failed on it); the cause is kept as the source.
    #[error("{source_name}: {source}")]
    Input {
        /// The mesh (path or builtin spec).
        source_name: String,
        /// What went wrong.
        #[source]
        source: Box<crate::Error>,
    },
    /// An option is out of range; `option` names the options-struct field.
    #[error("option `{option}` {reason}")]
    InvalidOption {
        /// The field of the options struct.
        option: &'static str,
        /// What is wrong with its value.
        reason: String,
    },
    /// The watermark experiment's message is not hexadecimal (kept as the source).
    ///
    /// Fix: give `message` as hex digits, e.g. `0xC0FFEE`.
    #[error("option `message` is not a hexadecimal message")]
    Message(#[source] crate::watermark::MessageError),
    /// Writing a result failed.
    #[error(transparent)]
    Io(#[from] crate::io::IoError),
    /// A chart could not be drawn.
    #[error(transparent)]
    Plot(#[from] crate::plot::PlotError),
    /// A picture could not be rendered.
    #[error(transparent)]
    Render(#[from] crate::render::RenderError),
    /// Serializing a result failed.
    #[error("cannot serialize results: {source}")]
    Json {
        /// serde_json's error.
        #[source]
        source: serde_json::Error,
    },
    /// Draco's results are not the JSON `bench/compression.py --json-out` writes.
    #[error("Draco results: {reason}")]
    Draco {
        /// What is wrong with them.
        reason: &'static str,
        /// The JSON parser's error, when the text is not JSON.
        #[source]
        source: Option<serde_json::Error>,
    },
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

impl ExperimentError {
    /// An [`ExperimentError::Input`] for the mesh `source_name`.
    pub fn input(source_name: &str, e: impl Into<crate::Error>) -> Self {
        ExperimentError::Input {
            source_name: source_name.to_string(),
            source: Box::new(e.into()),
        }
    }

    fn invalid(option: &'static str, reason: String) -> Self {
        ExperimentError::InvalidOption { option, reason }
    }
}
