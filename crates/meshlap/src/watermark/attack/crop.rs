//! Cropping (the benchmark's "cropping"): the vertices are ordered by their coordinate
//! along the principal axis (the eigenvector of the largest eigenvalue of the vertex
//! covariance), and the `⌈X/100 · n⌉` largest (or, for an odd seed, smallest) are
//! removed: one side of the model is cut off. A face is kept only when all its
//! vertices are; vertices no kept face references are dropped too. The order of the
//! remaining vertices is the input's.

use super::AttackError;
use crate::filter::preserve::centroid;
use crate::mesh::TriMesh;
use crate::metric::sym3::sym3_eigen;

/// The unit principal axis of `points` (largest-variance direction), with its largest
/// component made positive so the result does not depend on the eigensolver's sign.
pub fn principal_axis(points: &[[f64; 3]]) -> [f64; 3] {
    let c = centroid(points);
    let mut cov = [[0.0; 3]; 3];
    for p in points {
        let d = [0, 1, 2].map(|k| p[k] - c[k]);
        for i in 0..3 {
            for j in 0..3 {
                cov[i][j] += d[i] * d[j];
            }
        }
    }
    let (_, v) = sym3_eigen(cov);
    let a = v[0];
    let big = (0..3)
        .max_by(|&i, &j| a[i].abs().total_cmp(&a[j].abs()))
        .unwrap_or(0);
    if a[big] < 0.0 {
        a.map(|x| -x)
    } else {
        a
    }
}

/// `mesh` with `percent` % of its vertices cut off one side (module documentation).
pub fn crop(mesh: &TriMesh, percent: f64, seed: u64) -> Result<TriMesh, AttackError> {
    let n = mesh.n_vertices();
    let remove = ((percent / 100.0 * n as f64).ceil() as usize).min(n);
    let axis = principal_axis(&mesh.positions);
    let side = if seed.is_multiple_of(2) { 1.0 } else { -1.0 };
    let key = |i: usize| side * (0..3).map(|k| mesh.positions[i][k] * axis[k]).sum::<f64>();
    let mut order: Vec<usize> = (0..n).collect();
    // Largest projection first; ties broken by index for determinism.
    order.sort_by(|&a, &b| key(b).total_cmp(&key(a)).then(a.cmp(&b)));
    let mut keep = vec![true; n];
    for &i in &order[..remove] {
        keep[i] = false;
    }
    let faces: Vec<[u32; 3]> = mesh
        .faces
        .iter()
        .filter(|f| f.iter().all(|&v| keep[v as usize]))
        .copied()
        .collect();
    if faces.is_empty() {
        return Err(AttackError::CropEmpty { percent });
    }
    let mut used = vec![false; n];
    for f in &faces {
        for &v in f {
            used[v as usize] = true;
        }
    }
    let mut new_index = vec![u32::MAX; n];
    let mut positions = Vec::new();
    for i in 0..n {
        if used[i] {
            new_index[i] = positions.len() as u32;
            positions.push(mesh.positions[i]);
        }
    }
    let faces = faces
        .into_iter()
        .map(|f| f.map(|v| new_index[v as usize]))
        .collect();
    Ok(TriMesh::new(positions, faces))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::builtin;

    #[test]
    fn removes_at_least_the_fraction_from_one_side() {
        // An elongated torus: the principal axis is x.
        let mut m = builtin::torus(40, 8).unwrap();
        for p in &mut m.positions {
            p[0] *= 3.0;
        }
        let axis = principal_axis(&m.positions);
        assert!(axis[0] > 0.999, "{axis:?}");
        for pct in [10.0, 30.0, 50.0] {
            let c = crop(&m, pct, 0).unwrap();
            let removed = m.n_vertices() - c.n_vertices();
            let want = (pct / 100.0 * m.n_vertices() as f64).ceil() as usize;
            assert!(
                removed >= want && removed <= want + m.n_vertices() / 50,
                "{pct}: {removed} vs {want}"
            );
            // Every kept vertex lies below the `want` largest x.
            let mut xs: Vec<f64> = m.positions.iter().map(|p| p[0]).collect();
            xs.sort_by(|a, b| b.total_cmp(a));
            let cut = xs[want - 1];
            assert!(c.positions.iter().all(|p| p[0] <= cut));
            c.validate().unwrap();
            // Every vertex of the result is referenced.
            let mut used = vec![false; c.n_vertices()];
            c.faces
                .iter()
                .flatten()
                .for_each(|&v| used[v as usize] = true);
            assert!(used.iter().all(|&u| u));
        }
        // The other side for an odd seed; deterministic.
        let a = crop(&m, 30.0, 1).unwrap();
        let min_x = |m: &TriMesh| {
            m.positions
                .iter()
                .map(|p| p[0])
                .fold(f64::INFINITY, f64::min)
        };
        assert!(min_x(&a) > min_x(&m) + 1.0);
        assert_eq!(crop(&m, 30.0, 1).unwrap(), a);
        assert_eq!(crop(&m, 0.0, 0).unwrap(), m);
        assert!(matches!(
            crop(&m, 99.0, 0),
            Ok(_) | Err(AttackError::CropEmpty { .. })
        ));
    }
}
