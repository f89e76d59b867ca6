//! Resampling a registered suspect onto the original's connectivity: for every
//! original vertex, the closest point of the suspect's surface
//! ([`crate::metric::bvh::Bvh`]), so the original's patch bases apply to it (Ohbuchi,
//! Mukaiyama, Takahashi CGF 2002 §4, "mesh resampling").
//!
//! An original vertex farther than `far` × the original's bounding-box diagonal from
//! the suspect's surface has no counterpart there (a cropped region, a hole): it is
//! marked **missing** and keeps its original position, so it adds nothing to the
//! residual instead of a large, meaningless offset to the crop border. This only
//! depends on the two meshes, never on the key, so the false-positive bound of
//! [`super::detect()`] still holds.

use crate::mesh::TriMesh;
use crate::metric::bvh::Bvh;
use rayon::prelude::*;
use serde::Serialize;

/// Errors of [`resample`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ResampleError {
    /// The suspect has no triangles to project onto.
    #[error("the suspect has no triangles to resample from")]
    NoTriangles,
    /// `far` is not positive.
    #[error("resampling parameter `far` = {0}: must be positive")]
    InvalidFar(f64),
}

/// Parameters of [`resample`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ResampleParams {
    /// Distance, relative to the original's diagonal, beyond which an original vertex
    /// counts as missing from the suspect.
    pub far: f64,
}

impl Default for ResampleParams {
    /// `far` = 0.01: ten times the largest benchmark noise (0.5 % of the mean distance
    /// to the centroid is below 0.1 % of the diagonal), far below a cropped part.
    fn default() -> Self {
        Self { far: 0.01 }
    }
}

/// What [`resample`] did.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ResampleReport {
    /// Original vertices with no suspect surface within `far` (kept in place).
    pub missing: usize,
    /// Mean distance of the others to the suspect surface, original units.
    pub mean_distance: f64,
    /// Largest such distance.
    pub max_distance: f64,
}

/// Resampled positions (one per original vertex), the `missing` flags and the report.
pub type Resampled = (Vec<[f64; 3]>, Vec<bool>, ResampleReport);

/// Positions for the original's vertices from the (registered) suspect's surface;
/// `missing[i]` is true where vertex i kept its original position.
pub fn resample(
    suspect: &TriMesh,
    original: &TriMesh,
    params: &ResampleParams,
) -> Result<Resampled, ResampleError> {
    if !(params.far > 0.0) {
        return Err(ResampleError::InvalidFar(params.far));
    }
    if suspect.faces.is_empty() {
        return Err(ResampleError::NoTriangles);
    }
    let bvh = Bvh::new(suspect);
    let far2 = (params.far * original.bbox_diagonal()).powi(2);
    let hits: Vec<([f64; 3], f64)> = original
        .positions
        .par_iter()
        .map(|p| bvh.closest(p))
        .collect();
    let mut out = Vec::with_capacity(hits.len());
    let mut missing = Vec::with_capacity(hits.len());
    let (mut sum, mut max, mut kept) = (0.0f64, 0.0f64, 0usize);
    for (p, (q, d2)) in original.positions.iter().zip(hits) {
        if d2 > far2 || !d2.is_finite() {
            out.push(*p);
            missing.push(true);
        } else {
            out.push(q);
            missing.push(false);
            sum += d2.sqrt();
            max = max.max(d2.sqrt());
            kept += 1;
        }
    }
    let report = ResampleReport {
        missing: missing.iter().filter(|&&m| m).count(),
        mean_distance: if kept > 0 { sum / kept as f64 } else { 0.0 },
        max_distance: max,
    };
    Ok((out, missing, report))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::builtin;

    #[test]
    fn resampling_a_finer_copy_returns_the_original_vertices() {
        let m = builtin::icosphere(2).unwrap();
        let fine = builtin::subdivide_midpoint(&m).unwrap();
        let (p, missing, r) = resample(&fine, &m, &ResampleParams::default()).unwrap();
        // Every original vertex is a vertex of the midpoint subdivision.
        assert_eq!(r.missing, 0);
        assert!(missing.iter().all(|&x| !x));
        for (a, b) in p.iter().zip(&m.positions) {
            for k in 0..3 {
                assert!((a[k] - b[k]).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn vertices_of_a_cropped_part_are_missing_and_stay() {
        let m = builtin::icosphere(3).unwrap();
        let keep: Vec<[u32; 3]> = m
            .faces
            .iter()
            .copied()
            .filter(|f| f.iter().all(|&v| m.positions[v as usize][2] < 0.5))
            .collect();
        let cropped = TriMesh::new(m.positions.clone(), keep);
        let (p, missing, r) = resample(&cropped, &m, &ResampleParams::default()).unwrap();
        let top = m.positions.iter().filter(|q| q[2] > 0.6).count();
        assert!(r.missing >= top && r.missing > 0, "{} {top}", r.missing);
        for i in 0..m.positions.len() {
            if missing[i] {
                assert_eq!(p[i], m.positions[i]);
            }
        }
        assert!(resample(&TriMesh::new(vec![], vec![]), &m, &Default::default()).is_err());
    }
}
