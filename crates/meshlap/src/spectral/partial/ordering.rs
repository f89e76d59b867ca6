//! METIS nested-dissection ordering for the LDLᵀ of large `K − σM`.

use crate::SparseMatrix;

/// From this dimension on, the LDLᵀ uses METIS' nested-dissection ordering instead
/// of AMD: on large meshes it gives markedly smaller factors and faster solves for
/// the cost of the ordering; on meshes of a few ten thousand vertices the ordering
/// costs about as much as it saves (figures in BENCHMARKS.md, "partial spectra").
pub(super) const NESTED_DISSECTION_FROM: usize = 50_000;

/// METIS nested-dissection fill-reducing ordering (`METIS_NodeND`) of the pattern
/// of a symmetric matrix, as (forward, inverse) permutations; `None` if METIS fails
/// (the caller falls back to AMD). The `metis` crate wraps only METIS' partitioners,
/// so the call goes through its `metis-sys` bindings.
pub(super) fn nested_dissection(a: &SparseMatrix) -> Option<(Vec<usize>, Vec<usize>)> {
    let n = a.nrows();
    let mut xadj: Vec<metis_sys::idx_t> = Vec::with_capacity(n + 1);
    let mut adjncy: Vec<metis_sys::idx_t> = Vec::with_capacity(a.compute_nnz());
    xadj.push(0);
    for j in 0..n {
        for &i in a.row_idx_of_col_raw(j) {
            if i != j {
                adjncy.push(metis_sys::idx_t::try_from(i).ok()?);
            }
        }
        xadj.push(metis_sys::idx_t::try_from(adjncy.len()).ok()?);
    }
    let mut nv = metis_sys::idx_t::try_from(n).ok()?;
    let mut options = [0 as metis_sys::idx_t; metis_sys::METIS_NOPTIONS as usize];
    let mut perm = vec![0 as metis_sys::idx_t; n];
    let mut iperm = vec![0 as metis_sys::idx_t; n];
    // SAFETY: `options` has METIS_NOPTIONS entries; the graph arrays are a valid CSR
    // of `nv` vertices (symmetric pattern, no self loops) and `perm`/`iperm` hold `nv`
    // entries each, as METIS_NodeND requires. METIS keeps no pointer after returning.
    let rc = unsafe {
        metis_sys::METIS_SetDefaultOptions(options.as_mut_ptr());
        metis_sys::METIS_NodeND(
            &mut nv,
            xadj.as_mut_ptr(),
            adjncy.as_mut_ptr(),
            std::ptr::null_mut(),
            options.as_mut_ptr(),
            perm.as_mut_ptr(),
            iperm.as_mut_ptr(),
        )
    };
    if rc != metis_sys::rstatus_et_METIS_OK {
        return None;
    }
    // METIS: perm[new] = old (faer's forward array), iperm[old] = new.
    let fwd: Vec<usize> = perm.iter().map(|&x| x as usize).collect();
    let inv: Vec<usize> = iperm.iter().map(|&x| x as usize).collect();
    let mut seen = vec![false; n];
    for &f in &fwd {
        if f >= n || std::mem::replace(&mut seen[f], true) {
            return None;
        }
    }
    Some((fwd, inv))
}
