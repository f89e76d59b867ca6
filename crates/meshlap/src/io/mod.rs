//! Mesh readers and writers: OBJ, OFF, PLY (ASCII, binary little/big-endian, face
//! lists and triangle strips) and STL (ASCII and binary), plus Matrix Market and `.npy`
//! for matrices.
//!
//! Readers parse the whole file from one byte buffer without per-line allocation.
//! They never trust a count from a header for an allocation: reservations are capped by
//! what the remaining bytes can hold. Every error names the file, and for text formats
//! the line and the offending token. Polygons are fan-triangulated (and counted).
//!
//! Writers go through [`write_atomic`]: the data is written to a temporary file in the
//! target directory and renamed over the target only on success, so a failure never
//! leaves a partial file. The mesh and Matrix Market writers encode their records
//! (vertex and face lines, binary records, matrix entries) in parallel chunks, in
//! bounded memory, and write them in order (`encode`); text numbers are the shortest
//! decimals that read back to the same `f64`.

mod encode;
mod mtx;
mod npy;
mod obj;
mod off;
mod ply;
mod stl;
mod text;

pub use mtx::{read_matrix_market, write_matrix_market};
pub use npy::{read_npy, write_npy};

use crate::mesh::TriMesh;
use serde::Serialize;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::str::FromStr;

/// Errors of mesh and matrix reading and writing.
#[derive(Debug, thiserror::Error)]
pub enum IoError {
    /// The file could not be opened or read.
    #[error("cannot read {path}: {source}")]
    Open {
        /// The file.
        path: PathBuf,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
    /// The file could not be written.
    #[error("cannot write {path}: {source}")]
    Write {
        /// The file.
        path: PathBuf,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
    /// The extension names no supported format.
    #[error("{path}: unknown mesh format (extension must be .obj, .off, .ply or .stl, or pass --format)")]
    UnknownFormat {
        /// The file.
        path: PathBuf,
    },
    /// A format name that is not one of obj, off, ply, stl.
    #[error("unknown format `{0}` (expected obj, off, ply or stl)")]
    UnknownFormatName(String),
    /// A token could not be parsed.
    #[error("{file}:{line}: cannot parse \"{token}\" as {what}")]
    Parse {
        /// The file.
        file: String,
        /// 1-based line number.
        line: usize,
        /// The offending token (truncated to 40 characters).
        token: String,
        /// What was expected.
        what: &'static str,
    },
    /// A face refers to a vertex that does not exist.
    #[error("{file}:{line}: face index {index} is out of range ({vertices} vertices)")]
    IndexOutOfRange {
        /// The file.
        file: String,
        /// 1-based line number (0 for binary files).
        line: usize,
        /// The index as written in the file.
        index: i64,
        /// Number of vertices.
        vertices: usize,
    },
    /// A coordinate is NaN or infinite.
    #[error("{file}:{line}: vertex {vertex} has a NaN or infinite coordinate")]
    NonFinite {
        /// The file.
        file: String,
        /// 1-based line number (0 for binary files).
        line: usize,
        /// 0-based vertex index.
        vertex: usize,
    },
    /// Binary data ends early.
    #[error("{file}: truncated: the file ends while reading {what}")]
    Truncated {
        /// The file.
        file: String,
        /// What was being read.
        what: String,
    },
    /// A header is malformed or inconsistent with the data.
    #[error("{file}: bad header: {message}")]
    Header {
        /// The file.
        file: String,
        /// What is wrong.
        message: String,
    },
    /// The file is well-formed but uses something meshlap does not support.
    #[error("{file}: unsupported: {message}")]
    Unsupported {
        /// The file.
        file: String,
        /// What.
        message: String,
    },
    /// The file has no faces.
    #[error("{file}: the mesh has no faces")]
    Empty {
        /// The file.
        file: String,
    },
    /// A sparse matrix could not be built from the file's entries (index overflow or
    /// out of memory; faer's error kept).
    #[error("{file}: cannot build the matrix")]
    Matrix {
        /// The file.
        file: String,
        /// faer's error.
        #[source]
        source: faer::sparse::CreationError,
    },
    /// Per-vertex scalars or colours were given for a format that cannot store them
    /// (only PLY has vertex properties): nothing is written rather than dropping them
    /// silently. Fix: write a `.ply` file (or pass no scalars and colours).
    #[error("{path}: per-vertex scalars and colours need a PLY file, not {format}")]
    PropertiesNeedPly {
        /// The path that was to be written.
        path: PathBuf,
        /// The format it names.
        format: Format,
    },
    /// A mesh to write has a NaN or infinite coordinate (an upstream computation
    /// diverged), or for STL one beyond the `f32` range: nothing is written. Fix: the step that produced the mesh (a
    /// degenerate face, too large a smoothing step) — the vertex is named.
    #[error("{path}: refusing to write vertex {vertex}, which has a NaN or infinite coordinate (for STL: beyond the f32 range)")]
    NonFiniteOutput {
        /// The file that was not written.
        path: PathBuf,
        /// 0-based vertex index.
        vertex: usize,
    },
    /// Data to write is inconsistent (e.g. a per-vertex property of the wrong length).
    #[error("{0}")]
    InvalidData(String),
}

/// Mesh file formats.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Format {
    /// Wavefront OBJ.
    Obj,
    /// Object File Format.
    Off,
    /// Stanford PLY.
    Ply,
    /// Stereolithography.
    Stl,
}

impl Format {
    /// The format named by `path`'s extension (case-insensitive).
    pub fn from_path(path: &Path) -> Result<Format, IoError> {
        path.extension()
            .and_then(|e| e.to_str())
            .and_then(|e| e.parse().ok())
            .ok_or_else(|| IoError::UnknownFormat {
                path: path.to_path_buf(),
            })
    }
}

impl FromStr for Format {
    type Err = IoError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.to_ascii_lowercase().as_str() {
            "obj" => Ok(Format::Obj),
            "off" => Ok(Format::Off),
            "ply" => Ok(Format::Ply),
            "stl" => Ok(Format::Stl),
            _ => Err(IoError::UnknownFormatName(s.to_string())),
        }
    }
}

impl std::fmt::Display for Format {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Format::Obj => "obj",
            Format::Off => "off",
            Format::Ply => "ply",
            Format::Stl => "stl",
        })
    }
}

/// What a reader noticed while reading.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct ReadInfo {
    /// The format read.
    pub format: Format,
    /// Faces with more than three corners, fan-triangulated.
    pub polygons_triangulated: usize,
    /// Triangles produced from PLY triangle strips.
    pub triangles_from_strips: usize,
    /// Degenerate strip triangles (a repeated vertex) skipped.
    pub degenerate_strip_triangles_skipped: usize,
    /// STL corners merged into shared vertices by exact position.
    pub stl_vertices_welded: usize,
}

impl ReadInfo {
    fn new(format: Format) -> Self {
        ReadInfo {
            format,
            polygons_triangulated: 0,
            triangles_from_strips: 0,
            degenerate_strip_triangles_skipped: 0,
            stl_vertices_welded: 0,
        }
    }
}

/// A mesh as read, with the reader's report.
#[derive(Clone, Debug)]
pub struct LoadedMesh {
    /// The mesh (not yet cleaned).
    pub mesh: TriMesh,
    /// What the reader noticed.
    pub info: ReadInfo,
}

/// Reads the mesh at `path`; the format is `format` or inferred from the extension.
pub fn read_mesh(path: &Path, format: Option<Format>) -> Result<LoadedMesh, IoError> {
    let format = match format {
        Some(f) => f,
        None => Format::from_path(path)?,
    };
    let bytes = FileBytes::open(path).map_err(|source| IoError::Open {
        path: path.to_path_buf(),
        source,
    })?;
    read_named(bytes.as_slice(), format, &path.display().to_string())
}

/// A file's bytes: memory-mapped when the file is a regular, non-empty file (no copy,
/// pages populated ahead by the kernel), read into memory otherwise (pipes, empty
/// files). The readers only read the bytes; a file truncated or rewritten by another
/// process while it is mapped can give wrong values or a `SIGBUS`, as with every
/// memory-mapped reader (ripgrep's trade-off too): meshlap's readers are meant for
/// files at rest.
enum FileBytes {
    Mapped(memmap2::Mmap),
    Read(Vec<u8>),
}

impl FileBytes {
    /// Files below this size are read, not mapped (mapping costs more than it saves).
    const MAP_FROM: u64 = 1 << 20;

    fn open(path: &Path) -> std::io::Result<FileBytes> {
        let file = std::fs::File::open(path)?;
        let meta = file.metadata()?;
        if meta.is_file() && meta.len() >= Self::MAP_FROM {
            // SAFETY: the map is read-only and lives as long as the bytes borrowed
            // from it; see the type's documentation for concurrent modification.
            if let Ok(map) = unsafe { memmap2::MmapOptions::new().populate().map(&file) } {
                return Ok(FileBytes::Mapped(map));
            }
        }
        let mut bytes = Vec::new();
        std::io::Read::read_to_end(&mut &file, &mut bytes)?;
        Ok(FileBytes::Read(bytes))
    }

    fn as_slice(&self) -> &[u8] {
        match self {
            FileBytes::Mapped(m) => m,
            FileBytes::Read(v) => v,
        }
    }
}

/// Reads a mesh from memory.
pub fn read_mesh_from_bytes(bytes: &[u8], format: Format) -> Result<LoadedMesh, IoError> {
    read_named(bytes, format, "<memory>")
}

fn read_named(bytes: &[u8], format: Format, name: &str) -> Result<LoadedMesh, IoError> {
    crate::par::on_worker(|| read_named_here(bytes, format, name))
}

/// [`read_named`] on the calling thread.
fn read_named_here(bytes: &[u8], format: Format, name: &str) -> Result<LoadedMesh, IoError> {
    let (mesh, info) = read_any(bytes, format, name)?;
    if mesh.faces.is_empty() {
        return Err(IoError::Empty {
            file: name.to_string(),
        });
    }
    Ok(LoadedMesh { mesh, info })
}

/// Runs the reader of `format` (no check for an empty mesh).
fn read_any(bytes: &[u8], format: Format, name: &str) -> Result<(TriMesh, ReadInfo), IoError> {
    let mut info = ReadInfo::new(format);
    let mesh = match format {
        Format::Obj => obj::read(bytes, name, &mut info)?,
        Format::Off => off::read(bytes, name, &mut info)?,
        Format::Ply => ply::read(bytes, name, &mut info)?,
        Format::Stl => stl::read(bytes, name, &mut info)?,
    };
    Ok((mesh, info))
}

/// The readers' internal variants, for differential fuzzing (`fuzz/src/entry.rs`, whose
/// `obj_variants` and `ply_variants` targets check that every variant of a reader gives
/// the same mesh, report and error as its plain sequential reference) and for the
/// stable replay of its corpora. Not part of the API: these may change or go at any
/// time. Use [`read_mesh`] and [`read_mesh_from_bytes`].
#[doc(hidden)]
pub mod variants {
    use super::{obj, ply, Format, IoError, ReadInfo};
    use crate::mesh::TriMesh;

    /// OBJ `bytes` cut at line ends into chunks of at least `min_chunk` bytes (at most
    /// four per rayon thread) parsed in parallel, each line by the scanner with the
    /// token-based fallback (`scan: true`, what [`super::read_mesh`] does) or by the
    /// tokens alone. `min_chunk = usize::MAX, scan = false` is the sequential
    /// reference.
    pub fn obj(bytes: &[u8], min_chunk: usize, scan: bool) -> Result<(TriMesh, ReadInfo), IoError> {
        let mut info = ReadInfo::new(Format::Obj);
        obj::read_in_chunks(bytes, "<memory>", &mut info, min_chunk, scan).map(|m| (m, info))
    }

    /// PLY `bytes` with the binary fixed-record fast paths decoding parallel blocks of
    /// `Some(records)` records (at least 1), or (`None`) every binary element read
    /// record by record: the sequential reference. ASCII files read the same either
    /// way.
    pub fn ply(bytes: &[u8], records: Option<usize>) -> Result<(TriMesh, ReadInfo), IoError> {
        let mut info = ReadInfo::new(Format::Ply);
        ply::read_with(bytes, "<memory>", &mut info, records).map(|m| (m, info))
    }
}

/// Options of [`write_mesh`].
#[derive(Clone, Copy, Debug, Default)]
pub struct WriteOptions<'a> {
    /// Output format; `None` infers it from the extension.
    pub format: Option<Format>,
    /// A per-vertex scalar written as a PLY `double` property with this name (PLY only).
    pub vertex_scalar: Option<(&'a str, &'a [f64])>,
    /// Per-vertex colours written as PLY `uchar red/green/blue` (PLY only).
    pub vertex_colors: Option<&'a [[u8; 3]]>,
    /// Write PLY as ASCII instead of binary little-endian.
    pub ply_ascii: bool,
}

/// Writes `mesh` to `path` atomically. OBJ and PLY keep every `f64` exactly; OFF too;
/// STL stores `f32` (a documented loss) and no shared vertices. A NaN or infinite
/// coordinate is refused ([`IoError::NonFiniteOutput`], naming the vertex) before
/// anything is written.
pub fn write_mesh(path: &Path, mesh: &TriMesh, opts: &WriteOptions) -> Result<(), IoError> {
    let format = match opts.format {
        Some(f) => f,
        None => Format::from_path(path)?,
    };
    // STL stores f32: a finite f64 beyond f32's range would be written as infinity.
    let finite = |c: f64| match format {
        Format::Stl => (c as f32).is_finite(),
        _ => c.is_finite(),
    };
    if let Some(vertex) = mesh
        .positions
        .iter()
        .position(|p| !p.iter().all(|&c| finite(c)))
    {
        return Err(IoError::NonFiniteOutput {
            path: path.to_path_buf(),
            vertex,
        });
    }
    if format != Format::Ply && (opts.vertex_scalar.is_some() || opts.vertex_colors.is_some()) {
        return Err(IoError::PropertiesNeedPly {
            path: path.to_path_buf(),
            format,
        });
    }
    let n = mesh.n_vertices();
    if let Some((name, s)) = opts.vertex_scalar {
        if s.len() != n {
            return Err(IoError::InvalidData(format!(
                "vertex property `{name}` has {} values for {n} vertices",
                s.len()
            )));
        }
        if name.is_empty() || name.contains(char::is_whitespace) {
            return Err(IoError::InvalidData(format!(
                "invalid PLY property name `{name}`"
            )));
        }
    }
    if let Some(c) = opts.vertex_colors {
        if c.len() != n {
            return Err(IoError::InvalidData(format!(
                "{} vertex colours for {n} vertices",
                c.len()
            )));
        }
    }
    write_atomic(path, |w| match format {
        Format::Obj => obj::write(w, mesh),
        Format::Off => off::write(w, mesh),
        Format::Ply => ply::write(w, mesh, opts),
        Format::Stl => stl::write(w, mesh),
    })
}

/// Writes a file atomically: `f` writes into a temporary file in `path`'s directory,
/// which is renamed to `path` only when `f` and the flush succeed. On any error the
/// temporary file is removed and `path` is untouched.
pub fn write_atomic(
    path: &Path,
    f: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<(), IoError> {
    let err = |source| IoError::Write {
        path: path.to_path_buf(),
        source,
    };
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let tmp = tempfile::Builder::new()
        .prefix(".meshlap-")
        .suffix(".tmp")
        .tempfile_in(&dir)
        .map_err(err)?;
    {
        // Small writes (headers, the other writers' pieces) are gathered; the chunks of
        // the mesh and Matrix Market writers (`encode::write_records`, larger than the
        // buffer) go straight to the file, not copied through it first.
        let mut w = std::io::BufWriter::with_capacity(1 << 16, tmp.as_file());
        f(&mut w).map_err(err)?;
        w.flush().map_err(err)?;
    }
    // A temporary file is created private (0600); the result is an ordinary file.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(tmp.path(), std::fs::Permissions::from_mode(0o644))
            .map_err(err)?;
    }
    tmp.persist(path).map_err(|e| err(e.error))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::builtin;

    #[test]
    fn format_from_extension() {
        assert_eq!(
            Format::from_path(Path::new("a/B.OBJ")).unwrap(),
            Format::Obj
        );
        assert_eq!(Format::from_path(Path::new("x.ply")).unwrap(), Format::Ply);
        assert!(matches!(
            Format::from_path(Path::new("x.txt")),
            Err(IoError::UnknownFormat { .. })
        ));
        assert!(Format::from_path(Path::new("noext")).is_err());
    }

    #[test]
    fn atomic_write_leaves_nothing_on_failure() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("out.obj");
        let r = write_atomic(&target, |w| {
            w.write_all(b"partial")?;
            Err(std::io::Error::other("boom"))
        });
        assert!(r.is_err());
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
        // and an existing file is left untouched
        std::fs::write(&target, b"old").unwrap();
        let _ = write_atomic(&target, |_| Err(std::io::Error::other("boom")));
        assert_eq!(std::fs::read(&target).unwrap(), b"old");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn round_trip_every_format() {
        let m = builtin::torus(7, 5).unwrap();
        let dir = tempfile::tempdir().unwrap();
        for ext in ["obj", "off", "ply", "stl"] {
            let p = dir.path().join(format!("m.{ext}"));
            write_mesh(&p, &m, &WriteOptions::default()).unwrap();
            let back = read_mesh(&p, None).unwrap().mesh;
            if ext == "stl" {
                // STL has no shared vertices: compare corner positions face by face.
                assert_eq!(back.n_faces(), m.n_faces());
                assert_eq!(back.n_vertices(), m.n_vertices());
                for (fb, fm) in back.faces.iter().zip(&m.faces) {
                    for c in 0..3 {
                        let (a, b) = (back.positions[fb[c] as usize], m.positions[fm[c] as usize]);
                        for k in 0..3 {
                            assert_eq!(a[k], b[k] as f32 as f64);
                        }
                    }
                }
            } else {
                assert_eq!(back, m, "{ext}");
            }
        }
        let p = dir.path().join("a.ply");
        write_mesh(
            &p,
            &m,
            &WriteOptions {
                ply_ascii: true,
                ..Default::default()
            },
        )
        .unwrap();
        assert_eq!(read_mesh(&p, None).unwrap().mesh, m);
    }

    /// Meshes of several encoding chunks (`encode::CHUNK` records) with seeded
    /// coordinates over the whole finite range read back bit for bit from every
    /// format that stores f64 (STL: as f32), with the records in order across the
    /// chunks; PLY's per-vertex scalar and colours come out on the right lines.
    #[test]
    fn multi_chunk_meshes_round_trip_bit_for_bit() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(17);
        let n = 3 * encode::CHUNK + 5;
        let coordinate = |rng: &mut rand_chacha::ChaCha8Rng| loop {
            let x = match rng.gen_range(0..3) {
                0 => f64::from_bits(rng.gen::<u64>()),
                1 => rng.gen::<f64>() * 2.0 - 1.0,
                _ => (rng.gen_range(-1000..1000) as f64) / 8.0,
            };
            if x.is_finite() && (x as f32).is_finite() {
                return x;
            }
        };
        let positions: Vec<[f64; 3]> = (0..n)
            .map(|_| {
                [
                    coordinate(&mut rng),
                    coordinate(&mut rng),
                    coordinate(&mut rng),
                ]
            })
            .collect();
        let faces: Vec<[u32; 3]> = (0..2 * n)
            .map(|_| {
                let a = rng.gen_range(0..n as u32 - 2);
                [a, a + 1, a + 2]
            })
            .collect();
        let m = TriMesh::new(positions, faces);
        let dir = tempfile::tempdir().unwrap();
        let scalar: Vec<f64> = (0..n).map(|_| coordinate(&mut rng)).collect();
        let colors: Vec<[u8; 3]> = (0..n).map(|_| rng.gen()).collect();
        for (name, ascii) in [
            ("m.obj", false),
            ("m.off", false),
            ("m.ply", false),
            ("a.ply", true),
        ] {
            let p = dir.path().join(name);
            let with_props = name.ends_with("ply");
            let opts = WriteOptions {
                ply_ascii: ascii,
                vertex_scalar: with_props.then_some(("q", &scalar[..])),
                vertex_colors: with_props.then_some(&colors[..]),
                ..Default::default()
            };
            write_mesh(&p, &m, &opts).unwrap();
            let back = read_mesh(&p, None).unwrap().mesh;
            assert!(back == m, "{name}");
            if ascii {
                let text = std::fs::read_to_string(&p).unwrap();
                let body = &text[text.find("end_header\n").unwrap() + 11..];
                for (v, line) in body.lines().take(n).enumerate() {
                    let t: Vec<&str> = line.split(' ').collect();
                    assert_eq!(t[3].parse::<f64>().unwrap().to_bits(), scalar[v].to_bits());
                    let rgb: Vec<u8> = t[4..].iter().map(|x| x.parse().unwrap()).collect();
                    assert_eq!(rgb, colors[v]);
                }
            }
        }
        let p = dir.path().join("m.stl");
        write_mesh(&p, &m, &WriteOptions::default()).unwrap();
        let bytes = std::fs::read(&p).unwrap();
        assert_eq!(bytes.len(), 84 + 50 * m.n_faces());
        for (f, rec) in m.faces.iter().zip(bytes[84..].chunks_exact(50)) {
            for (c, &v) in f.iter().enumerate() {
                for k in 0..3 {
                    let at = 12 + 12 * c + 4 * k;
                    let x = f32::from_le_bytes(rec[at..at + 4].try_into().unwrap());
                    assert_eq!(x, m.positions[v as usize][k] as f32);
                }
            }
        }
    }
}
