//! One function per fuzz target: feed `data` to a meshlap reader or decoder through its
//! public entry point. Errors are expected and ignored; a panic, an abort, a timeout or
//! an allocation over the limit is a finding. A successful read must also satisfy the
//! reader's contract (asserted here): every face index in range, every coordinate
//! finite. The differential targets (`obj_variants`, `ply_variants`) read the same
//! bytes through a reader's internal variants (`meshlap::io::variants`: parallel
//! chunks, the line scanner, the binary fast paths) and assert that each gives
//! exactly what the sequential reference gives: the same bits, report and error;
//! `mlz_threads` does the same for the decoder on one thread and on two.
//!
//! Shared by the fuzz targets (`fuzz/fuzz_targets/*.rs`, nightly, libFuzzer) and the
//! stable replay test `crates/meshlap/tests/fuzz_replay.rs` (through `#[path]`), so
//! the corpora committed under `tests/data/fuzz/<target>/` replay through the same
//! code on stable.

use meshlap::codec::container::{self, SectionKind};
use meshlap::io::{read_mesh_from_bytes, variants, Format, IoError, ReadInfo};
use meshlap::TriMesh;

/// A fuzz target's entry point.
pub type Target = fn(&[u8]);

/// Every target, by name (the names of the `[[bin]]`s and of the corpus folders).
pub const TARGETS: [(&str, Target); 14] = [
    ("obj", obj),
    ("obj_variants", obj_variants),
    ("off", off),
    ("ply_ascii", ply_ascii),
    ("ply_binary", ply_binary),
    ("ply_variants", ply_variants),
    ("stl_ascii", stl_ascii),
    ("stl_binary", stl_binary),
    ("mlz", mlz),
    ("mlz_threads", mlz_threads),
    ("mtx", mtx),
    ("npy", npy),
    ("open", open),
    ("watermark_detect", watermark_detect),
];

/// The contract of a mesh that a reader or the decoder returned.
fn check_mesh(m: &TriMesh) {
    let n = m.positions.len();
    assert!(
        m.faces.iter().flatten().all(|&v| (v as usize) < n),
        "face index out of range"
    );
    assert!(
        m.positions.iter().flatten().all(|c| c.is_finite()),
        "non-finite coordinate"
    );
}

fn read(data: &[u8], format: Format) {
    if let Ok(loaded) = read_mesh_from_bytes(data, format) {
        check_mesh(&loaded.mesh);
        assert!(!loaded.mesh.faces.is_empty(), "a read mesh has faces");
    }
}

/// What a reader variant gave, in a form compared exactly: the mesh's coordinates as
/// bits (so `-0.0` and `0.0` differ), its faces, the report, or the error's message.
type Outcome = Result<(Vec<[u64; 3]>, Vec<[u32; 3]>, ReadInfo), String>;

fn outcome(r: Result<(TriMesh, ReadInfo), IoError>) -> Outcome {
    r.map(|(m, info)| (checked_bits(&m), m.faces, info))
        .map_err(|e| e.to_string())
}

/// The coordinates of a mesh that keeps the contract ([`check_mesh`]), as bits.
fn checked_bits(m: &TriMesh) -> Vec<[u64; 3]> {
    check_mesh(m);
    m.positions.iter().map(|p| p.map(f64::to_bits)).collect()
}

/// Wavefront OBJ, raw bytes.
pub fn obj(data: &[u8]) {
    read(data, Format::Obj);
}

/// Wavefront OBJ, differential. The first byte sets the smallest chunk, 1 to 64 bytes,
/// so that even small inputs are cut into several chunks parsed in parallel (the
/// reader's own threshold is 1 MiB, beyond any fuzz input); the rest is the file. The
/// scanner on one chunk (what `read_mesh` does with small files), the scanner on small
/// chunks and the tokens on small chunks must each give what the tokens give on one
/// chunk.
pub fn obj_variants(data: &[u8]) {
    let Some((&b, file)) = data.split_first() else {
        return;
    };
    let chunk = 1 + usize::from(b % 64);
    let reference = outcome(variants::obj(file, usize::MAX, false));
    for (min_chunk, scan) in [(usize::MAX, true), (chunk, true), (chunk, false)] {
        let got = outcome(variants::obj(file, min_chunk, scan));
        assert!(
            got == reference,
            "chunks of {min_chunk}, scan {scan}: {got:?}\nreference: {reference:?}"
        );
    }
}

/// OFF, raw bytes.
pub fn off(data: &[u8]) {
    read(data, Format::Off);
}

/// PLY, raw bytes (the seeds and dictionary are ASCII PLY).
pub fn ply_ascii(data: &[u8]) {
    read(data, Format::Ply);
}

/// Scalar type names of PLY, indexed by 3 bits of the mode byte.
const PLY_TYPES: [&str; 8] = [
    "char", "uchar", "short", "ushort", "int", "uint", "float", "double",
];

/// Binary PLY. The first byte picks a mode: even, the rest is the whole file; odd, a
/// well-formed binary header is generated from the mode byte (byte order, coordinate
/// type) and the next 5 bytes (list count and index types, `face` or `tristrips`,
/// vertex and face counts), and the rest is the body, so mutations reach the binary
/// decoding (including the fixed-size and strip fast paths) instead of dying in the
/// header.
pub fn ply_binary(data: &[u8]) {
    if let Some((_, file)) = ply_binary_file(data) {
        read(&file, Format::Ply);
    }
}

/// Binary PLY, differential: the file of [`ply_binary`]; the mode byte's top three bits
/// set the fast paths' parallel blocks, 1 to 8 records, so that block ends fall inside
/// small inputs (the reader's own blocks hold 16,384 records). The fast paths with
/// those blocks and with the reader's own must each give what the record-by-record
/// read gives.
pub fn ply_variants(data: &[u8]) {
    let Some((mode, file)) = ply_binary_file(data) else {
        return;
    };
    let records = 1 + usize::from(mode >> 5);
    let reference = outcome(variants::ply(&file, None));
    for blocks in [records, 1 << 14] {
        let got = outcome(variants::ply(&file, Some(blocks)));
        assert!(
            got == reference,
            "blocks of {blocks}: {got:?}\nreference: {reference:?}"
        );
    }
}

/// The mode byte and the PLY file of [`ply_binary`]'s input; `None` when it is empty.
fn ply_binary_file(data: &[u8]) -> Option<(u8, Vec<u8>)> {
    let (&mode, rest) = data.split_first()?;
    if mode & 1 == 0 || rest.len() < 5 {
        return Some((mode, rest.to_vec()));
    }
    let order = if mode & 2 == 0 {
        "binary_little_endian"
    } else {
        "binary_big_endian"
    };
    let coord = PLY_TYPES[usize::from((mode >> 2) & 7)];
    // The list count type must be an integer type.
    let count_ty = PLY_TYPES[usize::from(rest[0] & 7) % 6];
    let index_ty = PLY_TYPES[usize::from((rest[0] >> 3) & 7)];
    let extra = rest[0] & 0x40 != 0;
    let nv = u16::from_le_bytes([rest[1], rest[2]]);
    let nf = u16::from_le_bytes([rest[3], rest[4]]);
    let mut file = format!(
        "ply\nformat {order} 1.0\nelement vertex {nv}\nproperty {coord} x\n\
         property {coord} y\nproperty {coord} z\n"
    );
    if extra {
        file.push_str("property uchar red\n");
    }
    // Bit 7: the faces as triangle strips (one list per record, `-1` restarts).
    let element = if rest[0] & 0x80 != 0 {
        "tristrips"
    } else {
        "face"
    };
    file.push_str(&format!(
        "element {element} {nf}\nproperty list {count_ty} {index_ty} vertex_indices\n"
    ));
    if extra {
        file.push_str("property float quality\n");
    }
    file.push_str("end_header\n");
    let mut bytes = file.into_bytes();
    bytes.extend_from_slice(&rest[5..]);
    Some((mode, bytes))
}

/// Opening an in-memory mesh, differential: a face list decoded from the bytes goes
/// through the two ways of each step that issue 17's faster opening introduced, which
/// must agree exactly:
/// - `input::from_mesh` (cleaning all but the duplicate faces, the connectivity, the
///   duplicates found from its twins) against cleaning with every option and then
///   the connectivity: the same mesh, report and connectivity, or the same error;
/// - `clean::check_clean` (a counting sort of the faces, the Python package's check
///   of its `(V, F)` arguments) against the connectivity and
///   `clean::check_clean_given`: the same verdict and error;
/// - the connectivity with its steps for large meshes on
///   (`mesh::topology::variants::topology(…, 0)`) against the plain one.
///
/// Byte 0: its low three bits are the cleaning options, bit 3 lets an index reach one
/// past the last vertex (out of range). Byte 1: the vertex count, 1 to 64. Then each
/// three bytes a face, each index its byte modulo the count (or the count + 1).
pub fn open(data: &[u8]) {
    use meshlap::mesh::clean::{check_clean, check_clean_given, clean_owned, CleanOptions};
    use meshlap::mesh::topology::{variants as topology_variants, Topology};
    let [bits, count, body @ ..] = data else {
        return;
    };
    let n = 1 + usize::from(count % 64);
    let modulus = n as u32 + u32::from(bits & 8 != 0);
    let faces: Vec<[u32; 3]> = body
        .chunks_exact(3)
        .map(|c| [0, 1, 2].map(|k| u32::from(c[k]) % modulus))
        .collect();
    let positions = (0..n)
        .map(|i| [i as f64, (i * i % 7) as f64, (i % 3) as f64])
        .collect();
    let raw = TriMesh { positions, faces };
    // The lazily computed parts (outgoing half-edges, manifold flags) asked for, so
    // that the Debug forms compare everything.
    let settled = |t: &Topology| {
        let _ = t.non_manifold_vertices().count();
        format!("{t:?}")
    };
    let opts = CleanOptions {
        drop_degenerate_faces: bits & 1 != 0,
        drop_duplicate_faces: bits & 2 != 0,
        drop_unreferenced_vertices: bits & 4 != 0,
    };
    let report = |r: &meshlap::mesh::clean::CleanReport| {
        (
            r.dropped_degenerate_faces,
            r.dropped_duplicate_faces,
            r.dropped_unreferenced_vertices,
            r.vertex_map.clone(),
        )
    };
    let got = meshlap::input::from_mesh("fuzz", raw.clone(), None, &opts)
        .map(|i| (i.mesh.clone(), report(&i.clean), settled(&i.topology)))
        .map_err(|e| e.to_string());
    let want = clean_owned(raw.clone(), &opts)
        .map_err(meshlap::Error::from)
        .and_then(|(m, r)| {
            let t = Topology::new(&m)?;
            Ok((m, report(&r), settled(&t)))
        })
        .map_err(|e| e.to_string());
    assert!(
        got == want,
        "from_mesh: {got:?}\ncleaning, then the connectivity: {want:?}"
    );
    if let Ok((mesh, ..)) = &got {
        check_mesh(mesh);
    }
    let faces = &raw.faces;
    let sorted = check_clean(n, faces).map_err(|e| e.to_string());
    // One plain connectivity for both checks below.
    let built = Topology::from_faces(n, faces).map_err(|e| e.to_string());
    let given = built
        .as_ref()
        .map_err(String::clone)
        .and_then(|t| check_clean_given(t).map_err(|e| e.to_string()));
    assert!(
        sorted == given,
        "check_clean: {sorted:?}\ncheck_clean_given: {given:?}"
    );
    let plain = built.map(|t| settled(&t));
    let large = topology_variants::topology(n, faces, 0)
        .map(|t| settled(&t))
        .map_err(|e| e.to_string());
    assert!(
        plain == large,
        "the steps for large meshes: {large:?}\nplain: {plain:?}"
    );
}

/// ASCII STL, raw bytes (binary detection included: a file whose size matches its
/// triangle count is binary).
pub fn stl_ascii(data: &[u8]) {
    read(data, Format::Stl);
}

/// Binary STL. The first byte picks a mode: 0 (mod 3), the rest is the whole file;
/// 1, an 80-byte header and a triangle count matching the rest (truncated to whole
/// 50-byte records) are prepended, so the body is always decoded; 2, an 80-byte header
/// is prepended to the rest (whose first 4 bytes are then the count: usually a
/// mismatch, which exercises the fallbacks).
pub fn stl_binary(data: &[u8]) {
    let Some((&mode, rest)) = data.split_first() else {
        return;
    };
    match mode % 3 {
        0 => read(rest, Format::Stl),
        1 => {
            let count = rest.len() / 50;
            let mut bytes = vec![0u8; 80];
            bytes.extend_from_slice(&(count as u32).to_le_bytes());
            bytes.extend_from_slice(&rest[..count * 50]);
            read(&bytes, Format::Stl);
        }
        _ => {
            let mut bytes = vec![b' '; 80];
            bytes.extend_from_slice(rest);
            read(&bytes, Format::Stl);
        }
    }
}

/// The `.mlz` decoder, twice: on the raw bytes (container checks: magic, version,
/// lengths, checksums), then on the same sections re-sealed with valid checksums, so
/// mutations of the payloads reach the header, connectivity, geometry and
/// permutation decoders instead of failing the crc32.
pub fn mlz(data: &[u8]) {
    if let Ok(m) = meshlap::codec::decompress(data) {
        check_mesh(&m);
    }
    if let Some(resealed) = reseal(data) {
        if let Ok(m) = meshlap::codec::decompress(&resealed) {
            check_mesh(&m);
        }
    }
}

/// The `.mlz` decoder, differential: the input re-sealed as in [`mlz`] (or as it is,
/// when it holds no container header) decoded on one thread, which runs the
/// entropy decoder and the patches' synthesis one after the other, and on the global
/// pool, where they overlap on two threads and the synthesis fans out: the same mesh,
/// bit for bit, or the same error.
pub fn mlz_threads(data: &[u8]) {
    static ONE: std::sync::OnceLock<rayon::ThreadPool> = std::sync::OnceLock::new();
    let one = ONE.get_or_init(|| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .expect("a one-thread pool")
    });
    let bytes = reseal(data).unwrap_or_else(|| data.to_vec());
    let decode = || {
        meshlap::codec::decompress(&bytes)
            .map(|m| (checked_bits(&m), m.faces))
            .map_err(|e| e.to_string())
    };
    let sequential = one.install(decode);
    let threaded = decode();
    assert!(
        threaded == sequential,
        "threaded: {threaded:?}\none thread: {sequential:?}"
    );
}

/// Parses `data` with the container's layout (see `codec::container`) but ignores the
/// stored checksums, clamps lengths to the bytes present and maps unknown kinds into
/// 1..=4; writes the sections back with valid checksums. `None` when `data` does not
/// even hold the fixed file header.
pub fn reseal(data: &[u8]) -> Option<Vec<u8>> {
    if data.len() < 8 || data[..4] != container::MAGIC {
        return None;
    }
    let count = usize::from(u16::from_le_bytes([data[6], data[7]])).min(8);
    let mut pos = 8;
    let mut sections: Vec<(SectionKind, &[u8])> = Vec::new();
    for _ in 0..count {
        if pos + 9 > data.len() {
            break;
        }
        // Every byte names a kind (1–4 as written, 5 and 0 mod 5 the re-join section).
        let kind = match data[pos] % 5 {
            1 => SectionKind::Header,
            2 => SectionKind::Connectivity,
            3 => SectionKind::Permutation,
            4 => SectionKind::Geometry,
            _ => SectionKind::Rejoin,
        };
        let len = u32::from_le_bytes([data[pos + 1], data[pos + 2], data[pos + 3], data[pos + 4]])
            as usize;
        pos += 9;
        let len = len.min(data.len() - pos);
        sections.push((kind, &data[pos..pos + len]));
        pos += len;
    }
    // Keep the input's format version (every version from `container::MIN_VERSION`
    // to `container::VERSION` is read): the checksums cover the sections only.
    let mut out = container::write(&sections).ok()?;
    out[4..6].copy_from_slice(&data[4..6]);
    Some(out)
}

/// A per-process scratch file for the readers that take a path (Matrix Market and
/// `.npy`): the input is written there, then read back.
fn scratch(ext: &str, data: &[u8]) -> Option<std::path::PathBuf> {
    let p = std::env::temp_dir().join(format!(
        "meshlap-fuzz-{}-{:?}.{ext}",
        std::process::id(),
        std::thread::current().id()
    ));
    std::fs::write(&p, data).ok()?;
    Some(p)
}

/// The Matrix Market reader (through a scratch file: it reads a path). A matrix it
/// returns must have its entries in range.
pub fn mtx(data: &[u8]) {
    let Some(p) = scratch("mtx", data) else {
        return;
    };
    if let Ok(m) = meshlap::io::read_matrix_market(&p) {
        let (nr, nc) = (m.nrows(), m.ncols());
        for j in 0..nc {
            assert!(m.row_idx_of_col_raw(j).iter().all(|&i| i < nr));
        }
    }
    let _ = std::fs::remove_file(&p);
}

/// The `.npy` reader (through a scratch file: it reads a path).
pub fn npy(data: &[u8]) {
    let Some(p) = scratch("npy", data) else {
        return;
    };
    let _ = meshlap::io::read_npy(&p);
    let _ = std::fs::remove_file(&p);
}

/// The original of [`watermark_detect`]: builtin:icosphere:2 (162 vertices, small
/// enough that a detection with resampling stays far below the 1 s timeout).
fn detect_original() -> &'static TriMesh {
    static ORIGINAL: std::sync::OnceLock<TriMesh> = std::sync::OnceLock::new();
    ORIGINAL.get_or_init(|| meshlap::mesh::builtin::icosphere(2).expect("builtin mesh"))
}

/// The watermark detector's input path (`meshlap watermark detect SUSPECT --original
/// MESH`): `data` is read as a binary or ASCII PLY suspect and tested against a fixed
/// original (builtin:icosphere:2, key 7, 8 bits, the library's layout; the
/// original's bases are computed once per process). Registration, resampling onto the
/// original's connectivity, the patch transforms and the decision must return a typed
/// error or a report that keeps its contract: 8 correlations, bits only when found,
/// probabilities in [0, 1], finite correlations.
pub fn watermark_detect(data: &[u8]) {
    use meshlap::watermark::{DetectParams, Detector};
    static DETECTOR: std::sync::OnceLock<Option<Detector<'static>>> = std::sync::OnceLock::new();
    let Some(detector) =
        DETECTOR.get_or_init(|| Detector::new(detect_original(), &DetectParams::new(7, 8)).ok())
    else {
        panic!("the detector of the fixed original could not be built");
    };
    let Ok(loaded) = read_mesh_from_bytes(data, Format::Ply) else {
        return;
    };
    check_mesh(&loaded.mesh);
    if let Ok(r) = detector.detect(&loaded.mesh) {
        assert_eq!(r.correlations.len(), 8, "one correlation per bit");
        assert!(
            r.correlations.iter().all(|c| c.is_finite()),
            "finite correlations"
        );
        let p = r.false_positive_probability;
        assert!((0.0..=1.0).contains(&p), "false-positive probability {p}");
        assert_eq!(r.bits.is_some(), r.found, "bits exactly when found");
        if let Some(b) = &r.bits {
            assert_eq!(b.len(), 8);
        }
    }
}
