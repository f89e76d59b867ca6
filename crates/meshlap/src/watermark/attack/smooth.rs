//! Umbrella Laplacian smoothing (the benchmark's "smoothing"): `X` iterations of
//! `x ← x + λ(Cx − x)`, where `(Cx)_i` is the average of vertex i's neighbours
//! (`C = D⁻¹W`, so `Cx − x = −D⁻¹Fx` with the Kirchhoff operator `F = D − W`,
//! positive semi-definite: each step multiplies the Tutte-Laplacian frequency γ by
//! `1 − λγ`). Boundary vertices are smoothed like the others; an isolated vertex stays.

use super::AttackError;
use crate::mesh::{topology::Topology, TriMesh, VertexId};

/// `mesh` after `iterations` steps of umbrella smoothing with step `lambda`
/// (connectivity and vertex order unchanged).
pub fn smooth(mesh: &TriMesh, iterations: usize, lambda: f64) -> Result<TriMesh, AttackError> {
    let topo = Topology::new(mesh)?;
    let mut x = mesh.positions.clone();
    let mut next = x.clone();
    for _ in 0..iterations {
        for i in 0..x.len() {
            let nb = topo.neighbors(VertexId(i as u32));
            if nb.is_empty() {
                next[i] = x[i];
                continue;
            }
            let mut c = [0.0; 3];
            for &j in nb {
                for k in 0..3 {
                    c[k] += x[j as usize][k];
                }
            }
            let inv = 1.0 / nb.len() as f64;
            next[i] = [0, 1, 2].map(|k| x[i][k] + lambda * (c[k] * inv - x[i][k]));
        }
        std::mem::swap(&mut x, &mut next);
    }
    Ok(TriMesh::new(x, mesh.faces.clone()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::builtin;

    /// Energy of the Kirchhoff Laplacian `Σ_edges ‖x_a − x_b‖²` (a high-frequency measure).
    fn dirichlet(m: &TriMesh) -> f64 {
        let t = Topology::new(m).unwrap();
        t.edges()
            .iter()
            .map(|&[a, b]| {
                let (p, q) = (m.positions[a as usize], m.positions[b as usize]);
                (0..3).map(|k| (p[k] - q[k]).powi(2)).sum::<f64>()
            })
            .sum()
    }

    #[test]
    fn damps_a_high_frequency_more_than_the_shape() {
        // A sphere with alternating ±ε bumps: the bumps are high frequency.
        let m = builtin::icosphere(3).unwrap();
        let mut bumpy = m.clone();
        for (i, p) in bumpy.positions.iter_mut().enumerate() {
            let s = if i % 2 == 0 { 1.02 } else { 0.98 };
            *p = p.map(|x| x * s);
        }
        let dev = |m: &TriMesh| -> f64 {
            // RMS deviation of the radius from its mean.
            let r: Vec<f64> = m
                .positions
                .iter()
                .map(|p| (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt())
                .collect();
            let mean = r.iter().sum::<f64>() / r.len() as f64;
            (r.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / r.len() as f64).sqrt()
        };
        let s = smooth(&bumpy, 10, 0.1).unwrap();
        assert!(
            dev(&s) < 0.5 * dev(&bumpy),
            "{} vs {}",
            dev(&s),
            dev(&bumpy)
        );
        assert!(dirichlet(&s) < dirichlet(&bumpy));
        // Monotone in the iteration count, identity at 0.
        assert!(dev(&smooth(&bumpy, 30, 0.1).unwrap()) < dev(&s));
        assert_eq!(smooth(&bumpy, 0, 0.1).unwrap(), bumpy);
        assert_eq!(s.faces, m.faces);
    }

    #[test]
    fn one_step_matches_the_kirchhoff_operator() {
        // x + λ(Cx − x) = x − λ D⁻¹ F x with F the assembled Kirchhoff operator.
        use crate::operator::{Operator, OperatorKind, OperatorOptions};
        let m = builtin::torus(9, 7).unwrap();
        let t = Topology::new(&m).unwrap();
        let f = Operator::assemble(OperatorKind::Kirchhoff, &m, &t, &OperatorOptions::default())
            .unwrap();
        let mut fx = vec![[0.0; 3]; m.n_vertices()];
        let mat = f.matrix.as_ref();
        for j in 0..mat.ncols() {
            for (&i, &w) in mat.row_idx_of_col_raw(j).iter().zip(mat.val_of_col(j)) {
                for k in 0..3 {
                    fx[i][k] += w * m.positions[j][k];
                }
            }
        }
        let s = smooth(&m, 1, 0.3).unwrap();
        for i in 0..m.n_vertices() {
            let d = t.degree(VertexId(i as u32)) as f64;
            for k in 0..3 {
                let want = m.positions[i][k] - 0.3 * fx[i][k] / d;
                assert!((s.positions[i][k] - want).abs() < 1e-12);
            }
        }
    }
}
