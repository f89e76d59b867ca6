//! Memory bounds of the readers and the `.mlz` decoder (issue 16, "Resources"),
//! measured in-process by a counting global allocator: hostile headers never make a
//! reader allocate more than a small multiple of the bytes present, and reading a
//! valid binary PLY peaks below 2.5× the in-memory mesh. (The CLI test
//! `reliability.rs` checks the same under an address-space limit.)
//!
//! One `#[test]` only: the allocator's counters are global to the process.

use meshlap::codec::container::{write, SectionKind};
use meshlap::io::{read_mesh_from_bytes, Format};
use meshlap::mesh::builtin;
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering::Relaxed};

struct Counting;

static CURRENT: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

// SAFETY: forwards to the system allocator; only counts.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let p = System.alloc(layout);
        if !p.is_null() {
            let now = CURRENT.fetch_add(layout.size(), Relaxed) + layout.size();
            PEAK.fetch_max(now, Relaxed);
        }
        p
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        System.dealloc(ptr, layout);
        CURRENT.fetch_sub(layout.size(), Relaxed);
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let p = System.realloc(ptr, layout, new_size);
        if !p.is_null() {
            if new_size >= layout.size() {
                let now =
                    CURRENT.fetch_add(new_size - layout.size(), Relaxed) + new_size - layout.size();
                PEAK.fetch_max(now, Relaxed);
            } else {
                CURRENT.fetch_sub(layout.size() - new_size, Relaxed);
            }
        }
        p
    }
}

#[global_allocator]
static ALLOC: Counting = Counting;

/// Peak bytes allocated above the level at the start, while running `f`.
fn peak_during<T>(f: impl FnOnce() -> T) -> (T, usize) {
    let base = CURRENT.load(Relaxed);
    PEAK.store(base, Relaxed);
    let r = f();
    (r, PEAK.load(Relaxed).saturating_sub(base))
}

fn hostile_inputs() -> Vec<(&'static str, Format, Vec<u8>)> {
    let mut v = Vec::new();
    let ply = |body: &str, tail: &[u8]| {
        let mut b = body.as_bytes().to_vec();
        b.extend_from_slice(tail);
        b
    };
    v.push((
        "PLY, 10^12 vertices",
        Format::Ply,
        ply(
            "ply\nformat binary_little_endian 1.0\nelement vertex 1000000000000\n\
             property float x\nproperty float y\nproperty float z\nend_header\n",
            &[0; 100],
        ),
    ));
    v.push((
        "PLY, 10^6 vertices in 1 KB",
        Format::Ply,
        ply(
            "ply\nformat ascii 1.0\nelement vertex 1000000\nproperty float x\n\
             property float y\nproperty float z\nend_header\n",
            &b"0 0 0\n".repeat(150),
        ),
    ));
    v.push((
        "PLY, a list of 2^32-1 indices",
        Format::Ply,
        ply(
            "ply\nformat binary_big_endian 1.0\nelement vertex 3\nproperty uchar x\n\
             property uchar y\nproperty uchar z\nelement face 1\n\
             property list uint int vertex_indices\nend_header\n",
            &[0, 0, 0, 1, 0, 0, 0, 1, 0, 255, 255, 255, 255, 0, 0, 0, 0],
        ),
    ));
    v.push((
        "PLY, 10^9 elements without properties",
        Format::Ply,
        ply(
            "ply\nformat ascii 1.0\nelement nothing 1000000000\nelement vertex 3\n\
             property float x\nproperty float y\nproperty float z\nelement face 1\n\
             property list uchar int vertex_indices\nend_header\n",
            b"0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
        ),
    ));
    v.push((
        "OFF, 10^8 vertices and faces",
        Format::Off,
        b"OFF\n100000000 100000000 0\n0 0 0\n".to_vec(),
    ));
    let mut stl = vec![0u8; 80];
    stl.extend_from_slice(&u32::MAX.to_le_bytes());
    stl.extend_from_slice(&[0; 150]);
    v.push(("STL, 2^32-1 triangles", Format::Stl, stl));
    v.push((
        "OBJ, a face of 10^4 corners",
        Format::Obj,
        ply("v 0 0 0\nv 1 0 0\nv 0 1 0\nf", &b" 1 2 3".repeat(3333)),
    ));
    v
}

#[test]
fn allocations_are_bounded_by_the_input() {
    // Warm up lazily initialised state (rayon's pool) outside the measurements.
    let warm = builtin::icosahedron();
    let _ = meshlap::mesh::topology::Topology::new(&warm);
    let _ = read_mesh_from_bytes(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", Format::Obj);
    for (name, format, bytes) in hostile_inputs() {
        let (r, peak) = peak_during(|| read_mesh_from_bytes(&bytes, format));
        let bound = 64 * bytes.len() + (256 << 10);
        assert!(
            peak <= bound,
            "{name}: peak {peak} bytes for {} input bytes ({r:?})",
            bytes.len()
        );
    }
    // The decoder: counts of 2^32 − 1 over tiny sections, valid checksums.
    let mut header = u32::MAX.to_le_bytes().repeat(2);
    header.extend_from_slice(&[0; 32]);
    for conn_len in [16usize, 4096] {
        let conn = vec![0xa5u8; conn_len];
        let mlz = write(&[
            (SectionKind::Header, &header),
            (SectionKind::Connectivity, &conn),
            (SectionKind::Geometry, &[0x11; 64]),
        ])
        .unwrap();
        let (r, peak) = peak_during(|| meshlap::codec::decompress(&mlz));
        assert!(r.is_err());
        assert!(peak <= 64 * mlz.len() + (256 << 10), "mlz: peak {peak}");
    }
    // Matrix Market (read from a path): 10^8 and 10^11 columns declared in a tiny file
    // (a fuzz finding: the column pointers were allocated, 0.8 GB for the first).
    let dir = tempfile::tempdir().unwrap();
    for nc in ["99567296", "100000000000"] {
        let p = dir.path().join("m.mtx");
        let text = format!("%%MatrixMarket matrix coordinate real general\n3 {nc} 1\n1 1 2.0\n");
        std::fs::write(&p, &text).unwrap();
        let (r, peak) = peak_during(|| meshlap::io::read_matrix_market(&p));
        assert!(r.is_err());
        assert!(
            peak <= 64 * text.len() + (256 << 10),
            "mtx, {nc} columns: peak {peak}"
        );
    }
    // A valid binary PLY: the peak while reading stays below 2.5× the mesh it returns
    // (24 bytes per vertex, 12 per face).
    let m = builtin::icosphere(6).unwrap();
    let p = dir.path().join("m.ply");
    meshlap::io::write_mesh(&p, &m, &Default::default()).unwrap();
    let bytes = std::fs::read(&p).unwrap();
    let (r, peak) = peak_during(|| read_mesh_from_bytes(&bytes, Format::Ply));
    assert_eq!(r.unwrap().mesh, m);
    let mesh_bytes = 24 * m.n_vertices() + 12 * m.n_faces();
    assert!(
        (peak as f64) < 2.5 * mesh_bytes as f64,
        "peak {peak} for a {mesh_bytes}-byte mesh"
    );
}
