//! Helpers for the integration tests: the pinned set of real meshes.
#![allow(dead_code)]

use meshlap::input::{open, Input, OpenOptions};

/// Small meshes copied into the repository's `tests/data`.
pub fn data(name: &str) -> String {
    format!("{}/../../tests/data/{name}", env!("CARGO_MANIFEST_DIR"))
}

/// Large meshes read from `shared/data/meshes` beside the repository.
pub fn shared(name: &str) -> String {
    format!(
        "{}/../../../shared/data/meshes/{name}",
        env!("CARGO_MANIFEST_DIR")
    )
}

pub fn load(path: &str) -> Input {
    open(path, &OpenOptions::default()).unwrap_or_else(|e| panic!("{path}: {e}"))
}

/// Closed manifold meshes.
pub const CLOSED: &[&str] = &["cow.obj", "spot.obj", "fandisk.obj"];
/// Manifold meshes with boundary.
pub const WITH_BOUNDARY: &[&str] = &["teapot.obj", "woody.obj"];
/// Meshes with non-manifold edges.
pub const NON_MANIFOLD: &[&str] = &["beetle.obj", "suzanne.obj"];

/// Manifold versions of every small test mesh (non-manifold ones split).
pub fn manifold_meshes() -> Vec<(String, meshlap::TriMesh, meshlap::mesh::topology::Topology)> {
    let mut out = Vec::new();
    for name in CLOSED.iter().chain(WITH_BOUNDARY).chain(NON_MANIFOLD) {
        let input = load(&data(name));
        let mesh = if input.topology.is_manifold() {
            input.mesh
        } else {
            meshlap::mesh::clean::split_non_manifold(&input.mesh)
                .unwrap()
                .0
        };
        let topo = meshlap::mesh::topology::Topology::new(&mesh).unwrap();
        out.push((name.to_string(), mesh, topo));
    }
    out
}
