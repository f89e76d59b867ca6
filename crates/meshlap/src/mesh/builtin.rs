//! Deterministic generated meshes, addressed as `builtin:NAME[:ARGS]` wherever a mesh
//! path is accepted.
//!
//! | spec | mesh |
//! |---|---|
//! | `tetrahedron`, `octahedron`, `icosahedron` | the platonic solids (closed, regular) |
//! | `icosphere:N` | icosahedron subdivided N times (1:4 midpoint split), on the unit sphere: `10·4ᴺ + 2` vertices |
//! | `torus:U:V` | torus, U segments around the main circle, V around the tube (genus 1) |
//! | `grid:N` | open unit square, N×N quads each split along the same diagonal (interior valence 6, boundary) |
//! | `cube:N` | tessellated cube surface, N×N quads per side (closed; valences 3–6) |
//! | `step:N` | `grid:N` lifted to a step function `z = 0.5·[x ≥ ½]`: the paper's sharp-transition model |
//! | `nm-fin`, `nm-book`, `nm-bowtie`, `nm-fans`, `nm-flipped`, `nm-moebius`, `nm-mixed` | small non-manifold or inconsistently oriented meshes ([`super::nonmanifold`]) |
//!
//! All faces are oriented counter-clockwise seen from outside (closed meshes) or from
//! +z (height fields).

use super::{topology::Topology, MeshError, TriMesh};
use glam::DVec3;

/// Parses a `builtin:` spec (with or without the `builtin:` prefix) into a mesh.
pub fn from_spec(spec: &str) -> Result<TriMesh, MeshError> {
    let spec = spec.strip_prefix("builtin:").unwrap_or(spec);
    let mut parts = spec.split(':');
    let name = parts.next().unwrap_or("");
    let args: Vec<&str> = parts.collect();
    let arg = |i: usize, default: usize, max: usize| -> Result<usize, MeshError> {
        match args.get(i) {
            None => Ok(default),
            Some(s) => {
                let v: usize = s.parse().map_err(|_| {
                    MeshError::Builtin(format!("`{s}` is not a non-negative integer in `{spec}`"))
                })?;
                if v > max {
                    return Err(MeshError::Builtin(format!(
                        "{v} is too large in `{spec}` (at most {max})"
                    )));
                }
                Ok(v)
            }
        }
    };
    if let Some(kind) = super::nonmanifold::NonManifoldKind::from_name(name) {
        if !args.is_empty() {
            return Err(MeshError::Builtin(format!(
                "`{name}` takes no arguments, got `{spec}`"
            )));
        }
        return Ok(super::nonmanifold::non_manifold(kind));
    }
    let max_args = match name {
        "tetrahedron" | "octahedron" | "icosahedron" => 0,
        "icosphere" | "grid" | "cube" | "sphere48" | "step" => 1,
        "torus" => 2,
        _ => {
            return Err(MeshError::Builtin(format!(
                "unknown built-in mesh `{name}`; choose one of {}",
                NAMES.join(", ")
            )))
        }
    };
    if args.len() > max_args {
        return Err(MeshError::Builtin(format!(
            "`{name}` takes at most {max_args} argument(s), got `{spec}`"
        )));
    }
    match name {
        "tetrahedron" => Ok(tetrahedron()),
        "octahedron" => Ok(octahedron()),
        "icosahedron" => Ok(icosahedron()),
        "icosphere" => icosphere(arg(0, 3, 10)?),
        "torus" => torus(arg(0, 32, 20_000)?, arg(1, 16, 20_000)?),
        "grid" => grid(arg(0, 16, 10_000)?),
        "cube" => cube(arg(0, 8, 5_000)?),
        "sphere48" => sphere48(arg(0, 8, 5_000)?),
        "step" => step(arg(0, 16, 10_000)?),
        _ => unreachable!("name checked above"),
    }
}

/// The names accepted by [`from_spec`].
pub const NAMES: &[&str] = &[
    "tetrahedron",
    "octahedron",
    "icosahedron",
    "icosphere:N",
    "torus:U:V",
    "grid:N",
    "cube:N",
    "sphere48:N",
    "step:N",
    "nm-fin",
    "nm-book",
    "nm-bowtie",
    "nm-fans",
    "nm-flipped",
    "nm-moebius",
    "nm-mixed",
];

/// Flips every face whose normal points towards the origin (for star-shaped meshes
/// around the origin).
fn orient_outward(m: &mut TriMesh, center: [f64; 3]) {
    let center = DVec3::from(center);
    for f in &mut m.faces {
        let [a, b, c] = f.map(|v| DVec3::from(m.positions[v as usize]));
        let n = (b - a).cross(c - a);
        let centroid = (a + b + c) / 3.0 - center;
        if n.dot(centroid) < 0.0 {
            f.swap(1, 2);
        }
    }
}

/// Moves `p` onto the unit sphere (`p / |p|`, component-wise division).
fn onto_unit_sphere(p: &mut [f64; 3]) {
    let v = DVec3::from(*p);
    *p = (v / v.length()).to_array();
}

/// Regular tetrahedron (4 vertices, every degree 3).
pub fn tetrahedron() -> TriMesh {
    let mut m = TriMesh::new(
        vec![
            [1.0, 1.0, 1.0],
            [1.0, -1.0, -1.0],
            [-1.0, 1.0, -1.0],
            [-1.0, -1.0, 1.0],
        ],
        vec![[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]],
    );
    orient_outward(&mut m, [0.0; 3]);
    m
}

/// Regular octahedron (6 vertices, every degree 4).
pub fn octahedron() -> TriMesh {
    let p = vec![
        [1.0, 0.0, 0.0],
        [-1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, -1.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, 0.0, -1.0],
    ];
    let mut faces = Vec::new();
    for &x in &[0u32, 1] {
        for &y in &[2u32, 3] {
            for &z in &[4u32, 5] {
                faces.push([x, y, z]);
            }
        }
    }
    let mut m = TriMesh::new(p, faces);
    orient_outward(&mut m, [0.0; 3]);
    m
}

/// Regular icosahedron (12 vertices, every degree 5), on the unit sphere.
pub fn icosahedron() -> TriMesh {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let raw = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ];
    let norm = (1.0 + t * t).sqrt();
    let p = raw.iter().map(|v| v.map(|c| c / norm)).collect();
    let faces = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    let mut m = TriMesh::new(p, faces);
    orient_outward(&mut m, [0.0; 3]);
    m
}

/// One 1:4 midpoint subdivision step. New vertex of edge `e` is `n + e` (edge order
/// of [`Topology::edges`]), so the result is deterministic.
pub fn subdivide_midpoint(m: &TriMesh) -> Result<TriMesh, MeshError> {
    let topo = Topology::new(m)?;
    let n = m.n_vertices() as u32;
    let mut positions = m.positions.clone();
    positions.reserve(topo.n_edges());
    for &[a, b] in topo.edges() {
        let (pa, pb) = (m.positions[a as usize], m.positions[b as usize]);
        positions.push([
            0.5 * (pa[0] + pb[0]),
            0.5 * (pa[1] + pb[1]),
            0.5 * (pa[2] + pb[2]),
        ]);
    }
    let mut faces = Vec::with_capacity(4 * m.n_faces());
    for (f, t) in m.faces.iter().enumerate() {
        let h = 3 * f as u32;
        let mid = |c: u32| n + topo.half_edge_edge(h + c).0;
        let (m01, m12, m20) = (mid(0), mid(1), mid(2));
        faces.push([t[0], m01, m20]);
        faces.push([t[1], m12, m01]);
        faces.push([t[2], m20, m12]);
        faces.push([m01, m12, m20]);
    }
    Ok(TriMesh::new(positions, faces))
}

/// Icosahedron subdivided `level` times, vertices projected to the unit sphere
/// (`10·4ˡᵉᵛᵉˡ + 2` vertices; `level` ≤ 10).
pub fn icosphere(level: usize) -> Result<TriMesh, MeshError> {
    if level > 10 {
        return Err(MeshError::Builtin(format!(
            "icosphere level {level} is too large (at most 10)"
        )));
    }
    let mut m = icosahedron();
    for _ in 0..level {
        m = subdivide_midpoint(&m)?;
        m.positions.iter_mut().for_each(onto_unit_sphere);
    }
    Ok(m)
}

/// Torus with major radius 1 and minor radius 0.35: `u` segments around the main
/// circle and `v` around the tube (each at least 3); every vertex has degree 6.
pub fn torus(u: usize, v: usize) -> Result<TriMesh, MeshError> {
    if u < 3 || v < 3 {
        return Err(MeshError::Builtin(format!(
            "torus needs at least 3×3 segments, got {u}×{v}"
        )));
    }
    let (big, small) = (1.0, 0.35);
    let mut p = Vec::with_capacity(u * v);
    for i in 0..u {
        let a = 2.0 * std::f64::consts::PI * i as f64 / u as f64;
        for j in 0..v {
            let b = 2.0 * std::f64::consts::PI * j as f64 / v as f64;
            let r = big + small * b.cos();
            p.push([r * a.cos(), r * a.sin(), small * b.sin()]);
        }
    }
    let idx = |i: usize, j: usize| ((i % u) * v + (j % v)) as u32;
    let faces = split_quads(u, v, |i, j| {
        [idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1)]
    });
    Ok(TriMesh::new(p, faces))
}

/// The triangles `(a, b, c)` and `(a, c, d)` of every quad `[a, b, c, d]` (corners
/// counter-clockwise) of an `outer`×`inner` grid of quads, `quad(o, i)`, `o` outer.
fn split_quads(
    outer: usize,
    inner: usize,
    quad: impl Fn(usize, usize) -> [u32; 4],
) -> Vec<[u32; 3]> {
    let mut faces = Vec::with_capacity(2 * outer * inner);
    for o in 0..outer {
        for i in 0..inner {
            let [a, b, c, d] = quad(o, i);
            faces.push([a, b, c]);
            faces.push([a, c, d]);
        }
    }
    faces
}

fn grid_faces(n: usize) -> Vec<[u32; 3]> {
    let idx = |i: usize, j: usize| (j * (n + 1) + i) as u32;
    split_quads(n, n, |j, i| {
        [idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1)]
    })
}

/// Open unit square in the z = 0 plane, `n`×`n` quads each split along the same
/// diagonal: `(n+1)²` vertices, interior valence 6, one boundary loop.
pub fn grid(n: usize) -> Result<TriMesh, MeshError> {
    if n == 0 {
        return Err(MeshError::Builtin("grid needs at least 1 cell".into()));
    }
    let mut p = Vec::with_capacity((n + 1) * (n + 1));
    for j in 0..=n {
        for i in 0..=n {
            p.push([i as f64 / n as f64, j as f64 / n as f64, 0.0]);
        }
    }
    Ok(TriMesh::new(p, grid_faces(n)))
}

/// [`grid`] lifted to the step function `z = 0.5` for `x ≥ ½`, `z = 0` otherwise:
/// the "tessellation of a step function" of the paper's §4.9.
pub fn step(n: usize) -> Result<TriMesh, MeshError> {
    let mut m = grid(n)?;
    for p in &mut m.positions {
        p[2] = if p[0] >= 0.5 { 0.5 } else { 0.0 };
    }
    Ok(m)
}

/// Surface of the cube `[-1, 1]³`, each side tessellated by `n`×`n` quads split into
/// triangles; shared vertices along the cube's edges are welded. `6n² + 2` vertices.
pub fn cube(n: usize) -> Result<TriMesh, MeshError> {
    cube_lattice(n, false)
}

/// The "4-8" sphere of the paper's Fig. 4: the cube's n×n quad grids split along
/// alternating diagonals (checkerboard), so interior vertices have degree 4 and 8 in
/// turn, then pushed onto the unit sphere. `6n² + 2` vertices.
pub fn sphere48(n: usize) -> Result<TriMesh, MeshError> {
    let mut m = cube_lattice(n, true)?;
    m.positions.iter_mut().for_each(onto_unit_sphere);
    Ok(m)
}

/// The cube's surface lattice `[−1, 1]³`, each quad split along one diagonal, or along
/// alternating diagonals (4-8 connectivity).
fn cube_lattice(n: usize, alternate: bool) -> Result<TriMesh, MeshError> {
    if n == 0 {
        return Err(MeshError::Builtin(
            "cube needs at least 1 cell per side".into(),
        ));
    }
    let side = n + 1;
    // Vertex index by integer lattice coordinate; only surface points are used.
    let mut index = std::collections::HashMap::with_capacity(6 * side * side);
    let mut positions = Vec::new();
    let mut faces = Vec::with_capacity(12 * n * n);
    let mut vertex = |q: [usize; 3], positions: &mut Vec<[f64; 3]>| -> u32 {
        *index.entry(q).or_insert_with(|| {
            positions.push(q.map(|c| 2.0 * c as f64 / n as f64 - 1.0));
            (positions.len() - 1) as u32
        })
    };
    for axis in 0..3 {
        for &level in &[0, n] {
            let (a1, a2) = ((axis + 1) % 3, (axis + 2) % 3);
            for j in 0..n {
                for i in 0..n {
                    let mut corner = |di: usize, dj: usize| {
                        let mut q = [0usize; 3];
                        q[axis] = level;
                        q[a1] = i + di;
                        q[a2] = j + dj;
                        vertex(q, &mut positions)
                    };
                    let (a, b, c, d) = (corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1));
                    if alternate && (i + j + level) % 2 == 1 {
                        faces.push([a, b, d]);
                        faces.push([b, c, d]);
                    } else {
                        faces.push([a, b, c]);
                        faces.push([a, c, d]);
                    }
                }
            }
        }
    }
    let mut m = TriMesh::new(positions, faces);
    orient_outward(&mut m, [0.0; 3]);
    Ok(m)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn euler(m: &TriMesh) -> (usize, usize, usize, i64) {
        let t = Topology::new(m).unwrap();
        let (v, e, f) = (m.n_vertices(), t.n_edges(), m.n_faces());
        (v, e, f, v as i64 - e as i64 + f as i64)
    }

    #[test]
    fn sphere48_has_4_8_connectivity() {
        let m = sphere48(6).unwrap();
        assert_eq!(euler(&m), (6 * 36 + 2, 12 * 36 * 3 / 2, 12 * 36, 2));
        let t = Topology::new(&m).unwrap();
        assert!(t.is_manifold() && t.inconsistently_oriented_edges() == 0);
        let d = t.degrees();
        let count = |k: u32| d.iter().filter(|&&x| x == k).count();
        // every face interior vertex has degree 4 or 8, half and half
        assert!(
            count(4) + count(8) > 6 * 25 - 10,
            "{:?}",
            (count(4), count(8))
        );
        assert!(count(4).abs_diff(count(8)) < 20);
        assert!(m
            .positions
            .iter()
            .all(|p| (DVec3::from(*p).length_squared() - 1.0).abs() < 1e-12));
    }

    #[test]
    fn platonic_counts() {
        assert_eq!(euler(&tetrahedron()), (4, 6, 4, 2));
        assert_eq!(euler(&octahedron()), (6, 12, 8, 2));
        assert_eq!(euler(&icosahedron()), (12, 30, 20, 2));
    }

    #[test]
    fn generated_meshes_are_closed_and_oriented() {
        for spec in [
            "tetrahedron",
            "octahedron",
            "icosahedron",
            "icosphere:2",
            "torus:8:5",
            "cube:3",
        ] {
            let m = from_spec(spec).unwrap();
            let t = Topology::new(&m).unwrap();
            assert!(t.is_manifold(), "{spec}");
            assert_eq!(t.boundary_edges().count(), 0, "{spec}");
            assert_eq!(t.inconsistently_oriented_edges(), 0, "{spec}");
        }
    }

    #[test]
    fn icosphere_sizes_and_euler() {
        for l in 0..4 {
            let m = icosphere(l).unwrap();
            assert_eq!(m.n_vertices(), 10 * 4usize.pow(l as u32) + 2);
            assert_eq!(euler(&m).3, 2);
        }
    }

    #[test]
    fn torus_and_cube_euler() {
        assert_eq!(euler(&torus(10, 6).unwrap()).3, 0);
        let c = cube(4).unwrap();
        assert_eq!(c.n_vertices(), 6 * 16 + 2);
        assert_eq!(euler(&c).3, 2);
    }

    #[test]
    fn grid_and_step_have_one_boundary_loop() {
        for m in [grid(5).unwrap(), step(6).unwrap()] {
            let t = Topology::new(&m).unwrap();
            assert_eq!(t.boundary_loop_count(), 1);
            assert_eq!(euler(&m).3, 1);
            assert_eq!(t.inconsistently_oriented_edges(), 0);
        }
    }

    #[test]
    fn bad_specs_are_errors() {
        for s in [
            "builtin:nope",
            "builtin:grid:x",
            "builtin:grid:0",
            "builtin:torus:2:5",
            "builtin:icosphere:11",
            "builtin:grid:3:4",
            "builtin:tetrahedron:1",
        ] {
            assert!(from_spec(s).is_err(), "{s}");
        }
    }
}
