//! `meshlap._meshlap`: the Python extension module of meshlap (PyO3, stable ABI 3.9+).
//!
//! As thin as the command-line front end: each function converts its arguments, calls
//! one library function with the library's defaults, and converts the result. The
//! Python package `meshlap` (python/meshlap) wraps these functions: it checks shapes
//! and dtypes (naming the argument), converts array-likes, and builds
//! `scipy.sparse.csr_array` results and dicts. Every compute call releases the GIL
//! (`compute`) and runs on the pool set by `set_threads`.
//!
//! Sign convention: every operator is positive semi-definite, `F = D − W` (Zhang
//! 2004); libigl's `cotmatrix` is the negative.

use numpy::{PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use std::sync::atomic::AtomicU32;
use std::sync::{Arc, PoisonError, RwLock};

/// Every allocation of the extension (its buffers and the arrays it hands to numpy)
/// comes from mimalloc, which keeps freed memory for reuse for about a second
/// (`MIMALLOC_PURGE_DELAY`, in milliseconds, changes that) instead of returning it
/// to the kernel at once as glibc does with large blocks: repeated calls then reuse
/// their buffers instead of page-faulting them in again. The interpreter and other
/// extensions keep their own allocator.
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// Starts, once per process, the thread that once a second has every thread of the
/// compute pool ask mimalloc to return to the kernel the memory it freed more than the
/// purge delay ago (`mi_collect(false)` on each worker: nothing else is freed or
/// moved). mimalloc purges a thread's memory only when that thread allocates or frees;
/// the large buffers belong to the pool's workers, which sleep between calls, so
/// without this a large call's freed memory (hundreds of megabytes after a partial
/// eigensolve) would stay resident while the interpreter does other work, until the
/// next meshlap call. Called by [`compute`], so the thread starts with the first call
/// (a forked child, which inherits no thread, starts its own).
fn start_purger() {
    use std::sync::atomic::Ordering::Relaxed;
    static STARTED_IN: AtomicU32 = AtomicU32::new(0);
    let pid = std::process::id();
    if STARTED_IN.load(Relaxed) == pid || STARTED_IN.swap(pid, Relaxed) == pid {
        return;
    }
    // Without the thread (it could not be spawned), memory is still purged on the
    // next call, as mimalloc does by itself.
    let _ = std::thread::Builder::new()
        .name("meshlap-purge".into())
        .spawn(|| loop {
            std::thread::sleep(std::time::Duration::from_secs(1));
            // SAFETY: `mi_collect` may be called on any thread at any time; it
            // collects the calling thread's heap.
            let collect =
                |_: rayon::BroadcastContext<'_>| unsafe { libmimalloc_sys::mi_collect(false) };
            match current_pool() {
                Some(p) => p.broadcast(collect),
                None => rayon::broadcast(collect),
            };
        });
}

/// Adds each `#[pyfunction]` named to the module `m`: `add_functions!(m; f, g)`.
macro_rules! add_functions {
    ($m:expr; $($f:ident),+ $(,)?) => {{
        $( $m.add_function(pyo3::wrap_pyfunction!($f, $m)?)?; )+
        Ok(())
    }};
}
pub(crate) use add_functions;

mod mesh_fns;
mod spectral_fns;
mod watermark_fns;

/// The thread pool calls run on (`None`: rayon's global pool, all cores; `set_threads`
/// chooses) and the process it belongs to.
///
/// A process forked from one that has run a call (Python's `multiprocessing` with the
/// `fork` start method, the default on Linux before Python 3.14) inherits the pools
/// without their threads: a call there would wait forever for workers that do not
/// exist. So a call in a forked child first replaces the pool with one of its own, of
/// the same size ([`current_pool`]); the parent's is leaked, not dropped, as its
/// threads are not there to be told to stop. (A fork while another thread holds this
/// lock, which is only ever held to clone or replace the pool, would still leave the
/// child's copy locked; every `fork` of a multithreaded process carries that risk.)
struct Pool {
    pid: u32,
    pool: Option<Arc<rayon::ThreadPool>>,
}

static POOL: RwLock<Pool> = RwLock::new(Pool { pid: 0, pool: None });

/// The pool of this process (see [`Pool`]); in a forked child, a new one of the
/// parent's size, made on first use. A child that cannot start its threads panics
/// (PyO3 raises it as `PanicException`) rather than waiting forever.
fn current_pool() -> Option<Arc<rayon::ThreadPool>> {
    let pid = std::process::id();
    {
        let p = POOL.read().unwrap_or_else(PoisonError::into_inner);
        if p.pid == pid {
            return p.pool.clone();
        }
    }
    let mut p = POOL.write().unwrap_or_else(PoisonError::into_inner);
    if p.pid != pid {
        let threads = match &p.pool {
            Some(pool) => pool.current_num_threads(),
            None => rayon::current_num_threads(),
        };
        let own = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap_or_else(|e| panic!("cannot start {threads} threads in a forked process: {e}"));
        std::mem::forget(p.pool.replace(Arc::new(own)));
        p.pid = pid;
    }
    p.pool.clone()
}

/// Runs `f` without the GIL, on a worker of the pool chosen by `set_threads` (rayon's
/// global pool by default): its parallel passes are then shared out by work stealing
/// instead of being handed to the pool one by one from the calling thread.
pub(crate) fn compute<T: Send, F: FnOnce() -> T + Send>(py: Python<'_>, f: F) -> T {
    let pool = current_pool();
    start_purger();
    py.detach(move || match pool {
        Some(p) => p.install(f),
        None => meshlap::par::on_worker(f),
    })
}

/// The Python exception class (in `meshlap.errors`) of a library error.
fn class_of(e: &meshlap::Error) -> &'static str {
    use meshlap::Error as E;
    match e {
        E::Io(_) => "MeshIOError",
        E::Mesh(_) => "MeshError",
        E::Operator(_) => "OperatorError",
        E::Solve(_) | E::Filter(_) | E::Smoothing(_) => "SolveError",
        E::Repair(_) => "RepairError",
        E::Spectral(_) | E::Descriptor(_) | E::Patchwise(_) => "SpectralError",
        E::Watermark(_) | E::Attack(_) => "WatermarkError",
        E::Codec(_) => "CodecError",
        E::Metric(_) => "MetricError",
        E::Partition(_) => "PartitionError",
        E::Render(_) | E::Plot(_) => "RenderError",
        _ => "Error",
    }
}

/// A library error as the matching `meshlap.errors` exception (its message is the
/// library's).
pub(crate) fn raise(py: Python<'_>, e: impl Into<meshlap::Error>) -> PyErr {
    let e: meshlap::Error = e.into();
    raise_as(py, class_of(&e), e.to_string())
}

/// An exception of class `name` of `meshlap.errors` with message `msg`.
pub(crate) fn raise_as(py: Python<'_>, name: &str, msg: String) -> PyErr {
    let made = py
        .import("meshlap.errors")
        .and_then(|m| m.getattr(name))
        .and_then(|cls| cls.call1((msg.clone(),)));
    match made {
        Ok(exc) => PyErr::from_value(exc),
        Err(_) => pyo3::exceptions::PyValueError::new_err(msg),
    }
}

/// Shorthand: map a library result to a Python one.
pub(crate) trait OrRaise<T> {
    fn or_raise(self, py: Python<'_>) -> PyResult<T>;
}

impl<T, E: Into<meshlap::Error>> OrRaise<T> for Result<T, E> {
    fn or_raise(self, py: Python<'_>) -> PyResult<T> {
        self.map_err(|e| raise(py, e))
    }
}

/// A contiguous (rows, cols) view of a 2-D array, with the argument named in the
/// error (the Python layer has already converted dtype and layout).
pub(crate) fn slice2<'a, T: numpy::Element>(
    py: Python<'_>,
    a: &'a PyReadonlyArray2<'_, T>,
    name: &str,
    cols: Option<usize>,
) -> PyResult<(&'a [T], usize, usize)> {
    let (r, c) = (a.shape()[0], a.shape()[1]);
    if cols.is_some_and(|k| k != c) {
        return Err(raise_as(
            py,
            "MeshError",
            format!(
                "{name} must have shape (n, {}), got ({r}, {c})",
                cols.unwrap_or(0)
            ),
        ));
    }
    let s = a
        .as_slice()
        .map_err(|_| raise_as(py, "Error", format!("{name} must be C-contiguous")))?;
    Ok((s, r, c))
}

/// Face indices as the Python layer passes them: int64 (numpy's default integer) or
/// uint32, shape (m, 3), C-contiguous.
#[derive(FromPyObject)]
pub(crate) enum FaceArray<'py> {
    /// int64 indices (checked for negatives while converting).
    I64(PyReadonlyArray2<'py, i64>),
    /// uint32 indices.
    U32(PyReadonlyArray2<'py, u32>),
}

/// The names of a mesh's two arguments, for error messages: `("V", "F")`, or
/// `("Va", "Fa")` when a function takes two meshes.
pub(crate) type Names = (&'static str, &'static str);

/// `("V", "F")`.
pub(crate) const VF: Names = ("V", "F");

/// The mesh of `(V, F)`: V float64 (n, 3), F int64 or uint32 (m, 3), as given
/// (validated, not cleaned: NaN/inf coordinates, out-of-range indices, repeated
/// corners, duplicate faces and an empty mesh are errors), with its connectivity.
pub(crate) fn mesh_of(
    py: Python<'_>,
    v: &PyReadonlyArray2<'_, f64>,
    f: &FaceArray<'_>,
) -> PyResult<meshlap::input::Input> {
    mesh_named(py, v, f, VF)
}

/// [`mesh_of`] with the arguments' names for the messages: [`raw_named`], then
/// [`meshlap::input::from_mesh_as_given`], which builds the connectivity and refuses
/// what [`meshlap::mesh::clean::check_clean`] refuses (finding duplicates from the
/// connectivity instead of sorting the faces again).
pub(crate) fn mesh_named(
    py: Python<'_>,
    v: &PyReadonlyArray2<'_, f64>,
    f: &FaceArray<'_>,
    names: Names,
) -> PyResult<meshlap::input::Input> {
    let raw = raw_named(py, v, f, names)?;
    match compute(py, || meshlap::input::from_mesh_as_given("array", raw)) {
        Ok(input) => Ok(input),
        Err(meshlap::Error::Mesh(e)) => Err(unclean(py, e, names.1, |i| face_row(f, i))),
        Err(e) => Err(raise(py, e)),
    }
}

/// Row `i` of the face array, in any memory layout (in range: the library named it).
fn face_row(f: &FaceArray<'_>, i: usize) -> [i64; 3] {
    match f {
        FaceArray::I64(a) => [0, 1, 2].map(|c| a.as_array()[[i, c]]),
        FaceArray::U32(a) => [0, 1, 2].map(|c| i64::from(a.as_array()[[i, c]])),
    }
}

/// The error for a mesh that needs cleaning (a repeated corner, a duplicate face),
/// naming the face argument `fname` and its rows (`row(i)`); other mesh errors as
/// the library words them.
fn unclean(
    py: Python<'_>,
    e: meshlap::mesh::MeshError,
    fname: &str,
    row: impl Fn(usize) -> [i64; 3],
) -> PyErr {
    use meshlap::mesh::MeshError;
    let message = match e {
        MeshError::RepeatedCorner { face, .. } => format!(
            "{fname}[{face}] = {:?} repeats a vertex; clean the mesh first (meshlap.clean)",
            row(face)
        ),
        MeshError::DuplicateFace { face, first } => format!(
            "{fname}[{face}] = {:?} repeats face {fname}[{first}]; clean the mesh first (meshlap.clean)",
            row(face)
        ),
        e => return raise(py, e),
    };
    raise_as(py, "MeshError", message)
}

/// The mesh of `(V, F)` as given and refused if it needs cleaning: [`raw_named`], then
/// [`meshlap::mesh::clean::check_clean`] (the library's operators assume what
/// cleaning guarantees, and silently dropping a face would change the caller's
/// arrays); no connectivity.
pub(crate) fn checked_named(
    py: Python<'_>,
    v: &PyReadonlyArray2<'_, f64>,
    f: &FaceArray<'_>,
    names: Names,
) -> PyResult<meshlap::TriMesh> {
    let raw = raw_named(py, v, f, names)?;
    let checked = compute(py, || {
        meshlap::mesh::clean::check_clean(raw.n_vertices(), &raw.faces)
    });
    match checked {
        Ok(()) => Ok(raw),
        Err(e) => Err(unclean(py, e, names.1, |i| raw.faces[i].map(i64::from))),
    }
}

/// The mesh of `(V, F)` exactly as given, checked by [`meshlap::TriMesh::validate`]
/// (finite coordinates, indices in range, at least one face) with the arguments
/// named in the message; no connectivity.
pub(crate) fn raw_mesh(
    py: Python<'_>,
    v: &PyReadonlyArray2<'_, f64>,
    f: &FaceArray<'_>,
) -> PyResult<meshlap::TriMesh> {
    raw_named(py, v, f, VF)
}

/// Face indices as borrowed from numpy, before conversion.
#[derive(Clone, Copy)]
enum FaceSlice<'a> {
    I64(&'a [i64]),
    U32(&'a [u32]),
}

/// Why [`raw_named`]'s conversion refused a face: its index, its corners, and whether
/// one is negative (else one is out of range).
type BadFace = (usize, [i64; 3], bool);

fn raw_named(
    py: Python<'_>,
    v: &PyReadonlyArray2<'_, f64>,
    f: &FaceArray<'_>,
    (vname, fname): Names,
) -> PyResult<meshlap::TriMesh> {
    let (vs, n, _) = slice2(py, v, vname, Some(3))?;
    let fs = match f {
        FaceArray::U32(a) => FaceSlice::U32(slice2(py, a, fname, Some(3))?.0),
        FaceArray::I64(a) => FaceSlice::I64(slice2(py, a, fname, Some(3))?.0),
    };
    // Copies and checks without the GIL, in parallel (the library's validation names
    // the first offender, as a sequential scan would; so does the index check here).
    let made = compute(py, || -> Result<meshlap::TriMesh, BadFace> {
        let positions: Vec<[f64; 3]> = vs.as_chunks::<3>().0.to_vec();
        let faces: Vec<[u32; 3]> = match fs {
            FaceSlice::U32(fs) => fs.as_chunks::<3>().0.to_vec(),
            FaceSlice::I64(fs) => {
                use rayon::prelude::*;
                let fs = fs.as_chunks::<3>().0;
                let bad = |t: &[i64; 3]| t.iter().any(|&x| x < 0 || x > i64::from(u32::MAX));
                // The first bad chunk, then the first bad face in it (rayon's
                // per-item `position_first` is several times slower).
                const CHUNK: usize = 1 << 12;
                if let Some(c) = fs.par_chunks(CHUNK).position_first(|c| c.iter().any(bad)) {
                    let i = c * CHUNK + fs[c * CHUNK..].iter().position(bad).unwrap_or(0);
                    let t = fs[i];
                    return Err((i, t, t.iter().any(|&x| x < 0)));
                }
                fs.par_iter()
                    .with_min_len(1 << 14)
                    .map(|t| t.map(|x| x as u32))
                    .collect()
            }
        };
        Ok(meshlap::TriMesh::new(positions, faces))
    });
    let bad_face = |i: usize, t: [i64; 3], what: &str| {
        raise_as(
            py,
            "MeshError",
            format!("{fname}[{i}] = [{}, {}, {}] {what}", t[0], t[1], t[2]),
        )
    };
    let out_of_range = format!("refers to a vertex >= {n}, but {vname} has {n} vertices");
    let mesh = match made {
        Ok(mesh) => mesh,
        Err((i, t, true)) => return Err(bad_face(i, t, "has a negative vertex index")),
        Err((i, t, false)) => return Err(bad_face(i, t, &out_of_range)),
    };
    match compute(py, || mesh.validate()) {
        Ok(()) => Ok(mesh),
        Err(meshlap::mesh::MeshError::Empty) => Err(raise_as(
            py,
            "MeshError",
            format!("{fname} is empty (shape (0, 3)): the mesh has no faces"),
        )),
        Err(meshlap::mesh::MeshError::NonFinite { vertex }) => Err(raise_as(
            py,
            "MeshError",
            format!("{vname} has a NaN or infinite coordinate at vertex {vertex}"),
        )),
        Err(meshlap::mesh::MeshError::IndexOutOfRange { face, .. }) => Err(bad_face(
            face,
            mesh.faces[face].map(i64::from),
            &out_of_range,
        )),
        Err(e) => Err(raise(py, e)),
    }
}

/// A mesh as numpy arrays: V float64 (n, 3), F int64 (m, 3).
pub(crate) type MeshOut<'py> = (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray2<i64>>);

/// `(V, F)` numpy arrays of a mesh: float64 (n, 3) and int64 (m, 3). The positions
/// move into the array without a copy; the indices are widened in parallel.
pub(crate) fn mesh_arrays<'py>(py: Python<'py>, m: meshlap::TriMesh) -> PyResult<MeshOut<'py>> {
    use rayon::prelude::*;
    let (n, nf) = (m.n_vertices(), m.n_faces());
    let v: Vec<f64> = m.positions.into_flattened();
    let f: Vec<i64> = compute(py, || {
        m.faces
            .as_flattened()
            .par_iter()
            .with_min_len(1 << 15)
            .map(|&i| i64::from(i))
            .collect()
    });
    Ok((
        PyArray1::from_vec(py, v).reshape([n, 3])?,
        PyArray1::from_vec(py, f).reshape([nf, 3])?,
    ))
}

/// A faer matrix as a float64 numpy array of the same shape.
pub(crate) fn mat_out<'py>(
    py: Python<'py>,
    m: faer::MatRef<'_, f64>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let (r, c) = (m.nrows(), m.ncols());
    let mut flat = Vec::with_capacity(r * c);
    for i in 0..r {
        flat.extend((0..c).map(|j| m[(i, j)]));
    }
    PyArray1::from_vec(py, flat).reshape([r, c])
}

/// A sparse matrix as `(indptr, indices, data, shape)` of its compressed rows (the
/// Python layer wraps them in a `scipy.sparse.csr_array` without a conversion).
pub(crate) type CsrParts<'py> = (
    Bound<'py, PyArray1<i64>>,
    Bound<'py, PyArray1<i64>>,
    Bound<'py, PyArray1<f64>>,
    (usize, usize),
);

pub(crate) fn csr_out<'py>(py: Python<'py>, op: meshlap::operator::Operator) -> CsrParts<'py> {
    // The library's compressed rows (the CSC arrays moved for a symmetric operator, a
    // parallel transpose otherwise), handed to numpy without a copy.
    let c = compute(py, || op.into_csr());
    (
        PyArray1::from_vec(py, indices_as_i64(c.row_ptr)),
        PyArray1::from_vec(py, indices_as_i64(c.col)),
        PyArray1::from_vec(py, c.val),
        (c.nrows, c.ncols),
    )
}

/// A vector of indices as numpy's int64, reusing its allocation.
fn indices_as_i64(v: Vec<usize>) -> Vec<i64> {
    // Same size and alignment on the 64-bit targets PyO3's wheels are built for (a
    // compile error elsewhere), and every index of an allocation is below
    // isize::MAX, so each value keeps its meaning; the standard library reuses the
    // allocation for a map between types of one layout.
    const _: () = assert!(std::mem::size_of::<usize>() == std::mem::size_of::<i64>());
    v.into_iter().map(|i| i as i64).collect()
}

/// A report as JSON text (the Python layer parses it into a dict).
pub(crate) fn json<T: serde::Serialize>(py: Python<'_>, value: &T) -> PyResult<String> {
    serde_json::to_string(value)
        .map_err(|e| raise_as(py, "Error", format!("cannot serialise: {e}")))
}

/// Use `n` threads (n ≥ 1) for every later call; `0` goes back to all cores.
#[pyfunction]
fn set_threads(py: Python<'_>, n: usize) -> PyResult<()> {
    let pool = if n == 0 {
        None
    } else {
        Some(Arc::new(
            rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .map_err(|e| raise_as(py, "Error", format!("cannot start {n} threads: {e}")))?,
        ))
    };
    let pid = std::process::id();
    let mut p = POOL.write().unwrap_or_else(PoisonError::into_inner);
    let old = std::mem::replace(&mut p.pool, pool);
    if p.pid != pid {
        // A forked child: the parent's pool has no threads here (see `Pool`).
        std::mem::forget(old);
        p.pid = pid;
    }
    Ok(())
}

/// The number of threads calls run on.
#[pyfunction]
fn get_threads() -> usize {
    match current_pool() {
        Some(p) => p.current_num_threads(),
        None => rayon::current_num_threads(),
    }
}

/// `meshlap::keep_freed_memory`: keep freed memory in glibc's heaps (process-wide:
/// numpy's arrays and other extensions; the extension's own allocations come from
/// mimalloc, [`GLOBAL`]); whether glibc took the setting.
#[pyfunction]
fn keep_freed_memory() -> bool {
    meshlap::keep_freed_memory()
}

#[pymodule]
fn _meshlap(m: &Bound<'_, PyModule>) -> PyResult<()> {
    POOL.write().unwrap_or_else(PoisonError::into_inner).pid = std::process::id();
    m.add_function(wrap_pyfunction!(set_threads, m)?)?;
    m.add_function(wrap_pyfunction!(get_threads, m)?)?;
    m.add_function(wrap_pyfunction!(keep_freed_memory, m)?)?;
    // The library's defaults that the Python signatures repeat (asserted equal in
    // python/tests/test_mesh.py).
    m.add(
        "DEFAULT_SMOOTH_OPERATOR",
        meshlap::filter::FilterSettings::DEFAULT_OPERATOR.name(),
    )?;
    mesh_fns::register(m)?;
    spectral_fns::register(m)?;
    watermark_fns::register(m)?;
    Ok(())
}
