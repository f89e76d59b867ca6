//! Discrete mesh Laplacian operators as sparse n×n matrices.
//!
//! **Sign convention.** Every operator here is written `F = D − W` as in Zhang (2004):
//! positive (semi-)definite where the theory says so, zero row sums for the GSMLs, and
//! `F·x` pointing *outwards* on a convex surface. libigl's `cotmatrix` and
//! pmp-library's Laplacians are the negatives of ours.
//!
//! | kind | matrix | symmetric | zero row sum | module |
//! |---|---|---|---|---|
//! | Kirchhoff (KL) | `K = diag(d) − A` | yes | yes | [`kirchhoff`] |
//! | Tutte (TL) | `T = I − D⁻¹A` | no | yes | [`tutte`] |
//! | normalized graph (GL) | `G = I − D^{-1/2} A D^{-1/2}` | yes | no | [`graph`] |
//! | symmetric quasi-Laplacian (SQL) | `S = D − W` (Zhang §3.7) | yes | yes | [`sql`] |
//! | second-order symmetric Tutte (SSTL) | `J = TᵀT` | yes | yes | [`sstl`] |
//! | second-order Tutte | `T²` | no | yes | [`tutte2`] |
//! | scale-dependent (SDL) | `I − W̃`, `w_ij ∝ 1/‖x_i − x_j‖` row-normalised | no | yes | [`sdl`] |
//! | cotangent (Pinkall–Polthier) | `L_ij = −½(cot α + cot β)` + mass matrix | yes | yes | [`cotan`] |
//! | mean-value (Floater 2003) | `I − W̃`, `w_ij = (tan δ/2 + tan γ/2)/‖x_i − x_j‖` | no | yes | [`mean_value`] |
//!
//! All matrices are in the vertex order of the (cleaned) mesh; `d_i` is the number of
//! distinct neighbours of vertex i.

pub(crate) mod assemble;
pub mod cotan;
pub mod csr;
pub(crate) mod geometry;
pub mod graph;
pub mod kirchhoff;
pub mod mean_value;
pub mod sdl;
pub mod sql;
pub mod sstl;
pub mod symmetrize;
pub mod tutte;
pub mod tutte2;

use crate::mesh::{topology::Topology, TriMesh};
use crate::SparseMatrix;
use serde::Serialize;
use std::str::FromStr;

/// Errors of operator assembly.
#[derive(Debug, thiserror::Error)]
pub enum OperatorError {
    /// The mesh is unsuitable.
    #[error(transparent)]
    Mesh(#[from] crate::mesh::MeshError),
    /// An operator that divides by the degree met a vertex without neighbours.
    #[error("vertex {vertex} has no neighbours; clean the mesh first")]
    IsolatedVertex {
        /// The isolated vertex.
        vertex: u32,
    },
    /// A geometric operator met a zero-length edge.
    #[error("edge ({a}, {b}) has zero length; the {kind} operator is undefined there")]
    ZeroLengthEdge {
        /// First endpoint.
        a: u32,
        /// Second endpoint.
        b: u32,
        /// Operator name.
        kind: &'static str,
    },
    /// A geometric operator met a degenerate triangle: zero area to rounding (collinear
    /// or coincident corners, a needle thinner than the rounding of its edge lengths)
    /// or an area that overflows. Fix: `meshlap clean` drops faces with a repeated
    /// vertex; collapse or remove the named face (or use a combinatorial operator).
    #[error(
        "face {face} ({a}, {b}, {c}) is degenerate (zero area to rounding); the {kind} operator is undefined there"
    )]
    DegenerateFace {
        /// Face index in the mesh.
        face: u32,
        /// Face corners.
        a: u32,
        /// Face corners.
        b: u32,
        /// Face corners.
        c: u32,
        /// Operator name.
        kind: &'static str,
    },
    /// An assembled weight overflowed (coordinates so large or so small that the
    /// weights around the named vertex leave the range of `f64`). Fix: rescale the
    /// mesh (`meshlap` writes nothing in that case).
    #[error("the {kind} weights around vertex {vertex} are not finite (coordinates too large or too small to represent them); rescale the mesh")]
    NonFinite {
        /// A vertex whose row has a non-finite entry.
        vertex: u32,
        /// Operator name.
        kind: &'static str,
    },
    /// Unknown operator name.
    #[error("unknown operator `{0}`; choose one of kirchhoff (kl), tutte (tl), graph (gl), sql, sstl, tutte2 (t2), sdl, cotan, mean-value (mv)")]
    UnknownKind(String),
    /// Unknown name of an assembly option (`--sql-diagonal`, `--mass`).
    #[error("unknown {what} `{name}`; choose one of {choices}")]
    UnknownOption {
        /// The option.
        what: &'static str,
        /// The name given.
        name: String,
        /// The accepted names.
        choices: &'static str,
    },
}

/// The operators meshlap assembles.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum OperatorKind {
    /// Kirchhoff operator (graph Laplacian) `K = diag(d) − A`.
    Kirchhoff,
    /// Tutte Laplacian `T = I − D⁻¹A` (the uniform / umbrella operator).
    Tutte,
    /// Normalized graph Laplacian `G = I − D^{-1/2} A D^{-1/2}`.
    Graph,
    /// Zhang's symmetric quasi-Laplacian.
    Sql,
    /// Zhang's second-order symmetric Tutte Laplacian `TᵀT`.
    Sstl,
    /// Second-order Tutte Laplacian `T²`.
    Tutte2,
    /// Scale-dependent Laplacian (inverse edge-length weights).
    Sdl,
    /// Cotangent Laplace–Beltrami stiffness matrix.
    Cotan,
    /// Floater's mean-value weights.
    MeanValue,
}

impl OperatorKind {
    /// Every kind, in the order of the table above.
    pub const ALL: [OperatorKind; 9] = [
        OperatorKind::Kirchhoff,
        OperatorKind::Tutte,
        OperatorKind::Graph,
        OperatorKind::Sql,
        OperatorKind::Sstl,
        OperatorKind::Tutte2,
        OperatorKind::Sdl,
        OperatorKind::Cotan,
        OperatorKind::MeanValue,
    ];

    /// Canonical name (as accepted on the command line).
    pub fn name(self) -> &'static str {
        match self {
            OperatorKind::Kirchhoff => "kirchhoff",
            OperatorKind::Tutte => "tutte",
            OperatorKind::Graph => "graph",
            OperatorKind::Sql => "sql",
            OperatorKind::Sstl => "sstl",
            OperatorKind::Tutte2 => "tutte2",
            OperatorKind::Sdl => "sdl",
            OperatorKind::Cotan => "cotan",
            OperatorKind::MeanValue => "mean-value",
        }
    }

    /// True for operators that depend on connectivity only.
    pub fn is_combinatorial(self) -> bool {
        !matches!(
            self,
            OperatorKind::Sdl | OperatorKind::Cotan | OperatorKind::MeanValue
        )
    }

    /// True when the operator is symmetric by construction, exactly: each
    /// off-diagonal pair `F_ij`, `F_ji` is written from one computed value, so the
    /// matrix equals its transpose bit for bit (tested on every test mesh;
    /// [`csr::csr_of`] relies on it).
    pub fn is_symmetric(self) -> bool {
        matches!(
            self,
            OperatorKind::Kirchhoff
                | OperatorKind::Graph
                | OperatorKind::Sql
                | OperatorKind::Sstl
                | OperatorKind::Cotan
        )
    }
}

impl std::fmt::Display for OperatorKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for OperatorKind {
    type Err = OperatorError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Ok(match s.to_ascii_lowercase().as_str() {
            "kirchhoff" | "kl" | "k" => OperatorKind::Kirchhoff,
            "tutte" | "tl" | "t" | "uniform" | "umbrella" => OperatorKind::Tutte,
            "graph" | "gl" | "normalized" => OperatorKind::Graph,
            "sql" | "quasi" => OperatorKind::Sql,
            "sstl" | "j" => OperatorKind::Sstl,
            "tutte2" | "t2" => OperatorKind::Tutte2,
            "sdl" | "scale-dependent" => OperatorKind::Sdl,
            "cotan" | "cot" | "cotangent" | "laplace-beltrami" => OperatorKind::Cotan,
            "mean-value" | "mv" | "mvc" | "meanvalue" => OperatorKind::MeanValue,
            _ => return Err(OperatorError::UnknownKind(s.to_string())),
        })
    }
}

/// Options of [`Operator::assemble`].
#[derive(Clone, Copy, Debug, Default)]
pub struct OperatorOptions {
    /// Boundary diagonal of the SQL (see [`sql::BoundaryDiagonal`]).
    pub sql_boundary: sql::BoundaryDiagonal,
    /// Mass matrix of the cotangent operator.
    pub mass: cotan::MassKind,
}

/// An assembled operator.
#[derive(Clone, Debug)]
pub struct Operator {
    /// Which operator.
    pub kind: OperatorKind,
    /// The n×n matrix, `F = D − W` sign convention.
    pub matrix: SparseMatrix,
    /// Lumped (diagonal) mass matrix, for the cotangent operator.
    pub mass: Option<Vec<f64>>,
}

impl Operator {
    /// Assembles `kind` with the default [`OperatorOptions`] on an opened mesh (its
    /// cleaned mesh and connectivity), as every front end does without options.
    pub fn on_input(
        kind: OperatorKind,
        input: &crate::input::Input,
    ) -> Result<Self, OperatorError> {
        Self::assemble(
            kind,
            &input.mesh,
            &input.topology,
            &OperatorOptions::default(),
        )
    }

    /// Assembles `kind` on `mesh` with connectivity `topo`, on a worker of rayon's pool
    /// ([`crate::par::on_worker`]).
    pub fn assemble(
        kind: OperatorKind,
        mesh: &TriMesh,
        topo: &Topology,
        opts: &OperatorOptions,
    ) -> Result<Self, OperatorError> {
        crate::par::on_worker(|| Self::assemble_here(kind, mesh, topo, opts))
    }

    /// [`Self::assemble`] on the calling thread.
    fn assemble_here(
        kind: OperatorKind,
        mesh: &TriMesh,
        topo: &Topology,
        opts: &OperatorOptions,
    ) -> Result<Self, OperatorError> {
        let mut mass = None;
        let matrix = match kind {
            OperatorKind::Kirchhoff => kirchhoff::kirchhoff(topo),
            OperatorKind::Tutte => tutte::tutte(topo)?,
            OperatorKind::Graph => graph::graph(topo)?,
            OperatorKind::Sql => sql::sql(topo, opts.sql_boundary)?,
            OperatorKind::Sstl => sstl::sstl(topo)?,
            OperatorKind::Tutte2 => tutte2::tutte2(topo)?,
            OperatorKind::Sdl => sdl::sdl(mesh, topo)?,
            OperatorKind::Cotan => {
                let (l, m) = cotan::cotan(mesh, topo, opts.mass)?;
                mass = Some(m);
                l
            }
            OperatorKind::MeanValue => mean_value::mean_value(mesh, topo)?,
        };
        Ok(Operator { kind, matrix, mass })
    }

    /// The lumped mass as an n×n diagonal sparse matrix (the cotangent operator's,
    /// [`cotan::MassKind`]); `None` for the other kinds, which have no mass matrix.
    pub fn mass_matrix(&self) -> Option<SparseMatrix> {
        let mass = self.mass.as_ref()?;
        let n = mass.len();
        let symbolic = faer::sparse::SymbolicSparseColMat::new_checked(
            n,
            n,
            (0..=n).collect(),
            None,
            (0..n).collect(),
        );
        Some(faer::sparse::SparseColMat::new(symbolic, mass.clone()))
    }

    /// The matrix as compressed rows (`scipy.sparse.csr_array`'s layout), sign
    /// `F = D − W`: the CSC arrays moved as they are for an exactly symmetric kind
    /// ([`OperatorKind::is_symmetric`]), a parallel transpose for the others
    /// ([`csr::csr_of`]).
    pub fn into_csr(self) -> csr::Csr {
        csr::csr_of(self.matrix, self.kind.is_symmetric())
    }
}

/// The last guard of the geometric operators: every entry of `matrix` (and of the
/// mass diagonal) is finite, or [`OperatorError::NonFinite`] names a vertex (row) where
/// one is not. The operators' own checks (degenerate faces, zero-length edges) come
/// first; this catches overflow of well-shaped but extremely scaled meshes.
pub(crate) fn check_finite(
    matrix: &SparseMatrix,
    mass: Option<&[f64]>,
    kind: &'static str,
) -> Result<(), OperatorError> {
    // In parallel over chunks of the value array; the first bad entry in column order
    // is named, as a sequential scan would.
    if let Some(p) = first_non_finite(matrix.val()) {
        let col_ptr = matrix.col_ptr();
        let j = col_ptr.partition_point(|&q| q <= p) - 1;
        let vertex = matrix.row_idx_of_col_raw(j)[p - col_ptr[j]] as u32;
        return Err(OperatorError::NonFinite { vertex, kind });
    }
    if let Some(v) = mass.and_then(first_non_finite) {
        return Err(OperatorError::NonFinite {
            vertex: v as u32,
            kind,
        });
    }
    Ok(())
}

/// [`check_finite`] after an assembly that tested its columns as it wrote them:
/// `flagged` is false only if every entry of `matrix` is known to be finite (a
/// column's diagonal that sums its off-diagonal weights is non-finite exactly when one
/// of its entries is). The value array is then not read again; a flagged matrix is
/// scanned as [`check_finite`] does, to name the first bad entry in column order (a
/// flag raised by an overflowing test sum whose entries are all finite finds none).
/// The mass diagonal is always checked.
pub(crate) fn check_finite_flagged(
    matrix: &SparseMatrix,
    flagged: bool,
    mass: Option<&[f64]>,
    kind: &'static str,
) -> Result<(), OperatorError> {
    if flagged {
        check_finite(matrix, mass, kind)
    } else {
        match mass.and_then(first_non_finite) {
            Some(v) => Err(OperatorError::NonFinite {
                vertex: v as u32,
                kind,
            }),
            None => Ok(()),
        }
    }
}

/// Index of the first entry of `x` that is NaN or infinite. In parallel over chunks,
/// each tested without early exit (a branch-free `&` of `is_finite`, which the compiler
/// vectorises); only the first failing chunk is searched entry by entry.
pub(crate) fn first_non_finite(x: &[f64]) -> Option<usize> {
    use rayon::prelude::*;
    const CHUNK: usize = 1 << 14;
    let c = x
        .par_chunks(CHUNK)
        .position_first(|c| !c.iter().fold(true, |ok, v| ok & v.is_finite()))?;
    let start = c * CHUNK;
    x[start..]
        .iter()
        .position(|v| !v.is_finite())
        .map(|k| start + k)
}

/// Vertex degrees as `f64`, or an error naming an isolated vertex.
pub(crate) fn degrees_checked(topo: &Topology) -> Result<Vec<f64>, OperatorError> {
    degree_map_checked(topo, |d| d)
}

/// `f(d_v)` for every vertex degree `d_v`, in one parallel pass over the adjacency
/// offsets; [`OperatorError::IsolatedVertex`] (the first) if a degree is zero.
pub(crate) fn degree_map_checked(
    topo: &Topology,
    f: impl Fn(f64) -> f64 + Sync,
) -> Result<Vec<f64>, OperatorError> {
    use rayon::prelude::*;
    use std::sync::atomic::{AtomicBool, Ordering};
    let isolated = AtomicBool::new(false);
    let out: Vec<f64> = topo
        .adjacency_offsets()
        .par_windows(2)
        .with_min_len(4096)
        .map(|w| {
            let d = w[1] - w[0];
            if d == 0 {
                isolated.store(true, Ordering::Relaxed);
            }
            f(f64::from(d))
        })
        .collect();
    if isolated.load(Ordering::Relaxed) {
        let v = topo
            .adjacency_offsets()
            .windows(2)
            .position(|w| w[1] == w[0]);
        return Err(OperatorError::IsolatedVertex {
            vertex: v.unwrap_or(0) as u32,
        });
    }
    Ok(out)
}

#[cfg(test)]
pub(crate) mod test_util {
    use crate::mesh::{builtin, topology::Topology, TriMesh};
    use crate::SparseMatrix;

    /// Generated meshes of every kind: closed, with boundary, several valences.
    pub fn meshes() -> Vec<(&'static str, TriMesh)> {
        vec![
            ("tetrahedron", builtin::tetrahedron()),
            ("icosahedron", builtin::icosahedron()),
            ("icosphere2", builtin::icosphere(2).unwrap()),
            ("torus", builtin::torus(9, 7).unwrap()),
            ("grid", builtin::grid(6).unwrap()),
            ("cube", builtin::cube(3).unwrap()),
            ("step", builtin::step(5).unwrap()),
        ]
    }

    /// 3,000 separate triangles, those at `bad` collinear: more faces than one
    /// parallel chunk of the geometric operators, so the faults fall in different
    /// chunks.
    pub fn triangles_with_degenerate(bad: &[usize]) -> TriMesh {
        let (mut v, mut f) = (Vec::new(), Vec::new());
        for i in 0..3000u32 {
            let x = f64::from(i);
            let h = if bad.contains(&(i as usize)) {
                0.0
            } else {
                1.0
            };
            v.extend([[x, 0.0, 0.0], [x + 1.0, 0.0, 0.0], [x + 0.5, h, 0.0]]);
            f.push([3 * i, 3 * i + 1, 3 * i + 2]);
        }
        TriMesh::new(v, f)
    }

    /// `assemble` names the first of several degenerate faces (face 1,500 of 1,500, 2,048
    /// and 2,900) on pools of 1–3 threads, and succeeds without them.
    pub fn first_degenerate_face_is_named<T: std::fmt::Debug + Send>(
        assemble: impl Fn(&TriMesh, &Topology) -> Result<T, super::OperatorError> + Sync,
    ) {
        let m = triangles_with_degenerate(&[2900, 1500, 2048]);
        let t = topo(&m);
        for threads in [1, 2, 3] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            match pool.install(|| assemble(&m, &t)) {
                Err(super::OperatorError::DegenerateFace { face, .. }) => assert_eq!(face, 1500),
                other => panic!("{threads} threads: {other:?}"),
            }
        }
        let good = triangles_with_degenerate(&[]);
        assert!(assemble(&good, &topo(&good)).is_ok());
    }

    pub fn topo(m: &TriMesh) -> Topology {
        Topology::new(m).unwrap()
    }

    pub fn max_abs_row_sum(m: &SparseMatrix) -> f64 {
        let n = m.nrows();
        let mut rs = vec![0.0; n];
        for j in 0..n {
            for (&i, &v) in m.row_idx_of_col_raw(j).iter().zip(m.val_of_col(j)) {
                rs[i] += v;
            }
        }
        rs.iter().fold(0.0f64, |a, &b| a.max(b.abs()))
    }

    pub fn asymmetry(m: &SparseMatrix) -> f64 {
        let d = m.to_dense();
        let mut worst = 0.0f64;
        for i in 0..d.nrows() {
            for j in 0..d.ncols() {
                worst = worst.max((d[(i, j)] - d[(j, i)]).abs());
            }
        }
        worst
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::builtin;
    use faer::sparse::SparseColMat;

    #[test]
    fn first_non_finite_finds_the_first_across_chunks() {
        let mut x = vec![1.0f64; 100_000];
        assert_eq!(first_non_finite(&x), None);
        x[70_001] = f64::INFINITY;
        x[40_000] = f64::NAN;
        x[99_999] = f64::NEG_INFINITY;
        assert_eq!(first_non_finite(&x), Some(40_000));
        assert_eq!(first_non_finite(&x[40_001..]), Some(30_000));
        assert_eq!(first_non_finite(&[]), None);
    }

    #[test]
    fn check_finite_names_the_row_of_the_first_bad_entry() {
        let m = builtin::icosphere(3).unwrap();
        let t = test_util::topo(&m);
        let k = kirchhoff::kirchhoff(&t);
        assert!(check_finite(&k, None, "test").is_ok());
        let (symbolic, mut val) = k.into_parts();
        // Column 300's third entry, then a later one.
        let p = symbolic.col_ptr()[300] + 2;
        let row = symbolic.row_idx()[p];
        val[p] = f64::NAN;
        val[symbolic.col_ptr()[500]] = f64::INFINITY;
        let bad = SparseColMat::new(symbolic, val);
        match check_finite(&bad, None, "test") {
            Err(OperatorError::NonFinite { vertex, .. }) => assert_eq!(vertex as usize, row),
            other => panic!("{other:?}"),
        }
        // Flagged: the same scan, the same row.
        match check_finite_flagged(&bad, true, None, "test") {
            Err(OperatorError::NonFinite { vertex, .. }) => assert_eq!(vertex as usize, row),
            other => panic!("{other:?}"),
        }
        let mass = vec![1.0, 2.0, f64::NAN];
        let ok = kirchhoff::kirchhoff(&t);
        match check_finite(&ok, Some(&mass), "test") {
            Err(OperatorError::NonFinite { vertex, .. }) => assert_eq!(vertex, 2),
            other => panic!("{other:?}"),
        }
        // A false alarm (flagged, every entry finite): the scan finds nothing.
        assert!(check_finite_flagged(&ok, true, None, "test").is_ok());
        // Not flagged: the matrix is not read again, the mass still is.
        match check_finite_flagged(&ok, false, Some(&mass), "test") {
            Err(OperatorError::NonFinite { vertex, .. }) => assert_eq!(vertex, 2),
            other => panic!("{other:?}"),
        }
    }
}
