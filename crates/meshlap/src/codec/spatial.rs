//! Spatial (predictive) geometry coding: closed-loop DPCM over the connectivity
//! coder's traversal order with multi-parallelogram prediction, encoder-selected
//! predictors and rate–distortion optimized rounding (geometry mode 1 of the `.mlz`
//! geometry section).
//!
//! Vertices are coded in the decoded vertex order (the order in which the
//! cut-border machine meets them), so when vertex `v` is coded every vertex `< v` is
//! already decoded. Its candidate predictions come from the decoded positions `x̃`:
//!
//! * every **parallelogram** `x̃_a + x̃_b − x̃_c` for a face `(a, b, v)` whose edge
//!   `(a, b)` has, on its other side, a face `(b, a, c)` with `a, b, c < v`
//!   (Touma–Gotsman), in half-edge order;
//! * candidate 0 is their mean (Draco's multi-parallelogram); with selection on
//!   (default) candidates 1..=3 are the first three single parallelograms, and the
//!   encoder signals which one it used (an adaptive 2-bit symbol per vertex with at
//!   least two parallelograms, context: the candidate count) — Draco's "constrained
//!   multi-parallelogram" makes the same kind of choice;
//! * without a parallelogram, the mean of the decoded neighbours; without one, the
//!   previous vertex (the first vertex of a connected component).
//!
//! The residual `r = (x_v − x̂_v)/Δ` (global step `Δ`, as for the spectral coder) is
//! quantized per coordinate **inside the loop**: `x̃_v = x̂_v + q·Δ`, so later
//! predictions use exactly what the decoder will have, and no error accumulates. The
//! prediction is not rounded to a grid (a lattice coder like Draco's predicts integer
//! positions from integer positions and adds the rounding of the prediction to every
//! residual): that costs more bits for the same error (BENCHMARKS.md, Compression).
//!
//! **Rate–distortion optimized rounding.** `q` is `round(r)` or the next integer
//! towards zero, whichever has the lower `(r − q)² + μ·bits(q)`, where `bits` is the
//! current cost of `q` in its adaptive model ([`super::entropy::IntModel::cost`]) and
//! `μ` (`lambda`, in step² per bit) is an encoder-side parameter; `μ = 0` is plain
//! rounding (vertex RMS `≈ Δ/2`). The predictor choice minimizes the same
//! Lagrangian summed over the three coordinates plus `μ·bits(choice)`.
//!
//! **Contexts.** Each coordinate's integer is coded with an adaptive
//! [`super::entropy::IntModel`] chosen by the coordinate, the parallelogram count
//! (0, 1, 2, ≥ 3), the activity of the decoded neighbours (whether their mean
//! `Σ_k |q_k|` reaches 2) and whether an earlier coordinate of the same vertex was
//! non-zero: 3·4·2·2 = 48 models. Fewer contexts learn faster, which matters on
//! meshes of tens of thousands of vertices: more activity buckets, no activity
//! context, or one set of models for the three coordinates all did worse
//! (BENCHMARKS.md, Compression).
//!
//! The decoder repeats the same floating-point operations in the same order (both
//! sides walk the vertices with the same `Walk`), so it reproduces the encoder's
//! reconstruction bit for bit; no eigenbasis is needed, which makes decoding cheap.
//!
//! The stream: the step `Δ` (`f64` LE), the selection flag (`u8`), then the
//! range-coded payload.

use super::container::ByteReader;
use super::entropy::{BitTree, IntModel, RangeDecoder, RangeEncoder};
use super::quantize::checked;
use super::{CodecError, ParameterError};
use crate::mesh::topology::{Topology, INVALID};
use crate::mesh::VertexId;
use glam::DVec3;

/// Candidate predictions per vertex at most (the mean and three single parallelograms).
const MAX_CANDIDATES: usize = 4;
/// Activity buckets of the contexts.
const ACTIVITY: usize = 2;

/// Parameters of the spatial coder.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct SpatialParams {
    /// Let the encoder choose, per vertex, between the mean of the parallelograms and
    /// single parallelograms (signalled in the stream).
    pub select: bool,
    /// Rate–distortion multiplier `μ ≥ 0` (step² per bit) of the rounding and the
    /// predictor choice; 0: plain rounding. Encoder-side only.
    pub lambda: f64,
}

/// Largest rate–distortion multiplier.
pub const MAX_LAMBDA: f64 = 10.0;

impl SpatialParams {
    /// Checks the multiplier's range, `[0, MAX_LAMBDA]`.
    pub fn validate(&self) -> Result<(), ParameterError> {
        if !(self.lambda >= 0.0 && self.lambda <= MAX_LAMBDA) {
            return Err(ParameterError::RdoLambda {
                got: self.lambda,
                max: MAX_LAMBDA,
            });
        }
        Ok(())
    }
}

impl Default for SpatialParams {
    fn default() -> Self {
        SpatialParams {
            select: true,
            lambda: 0.12,
        }
    }
}

/// The parallelograms of every vertex (connectivity only): `(a, b, c)` predicts
/// `x_a + x_b − x_c`, all three decoded before the vertex.
pub struct Plan {
    off: Vec<u32>,
    paras: Vec<[u32; 3]>,
}

impl Plan {
    /// Parallelograms of the decoded connectivity `topo` (vertex order = coding order).
    pub fn new(topo: &Topology) -> Self {
        let n = topo.n_vertices();
        let nh = 3 * topo.n_faces() as u32;
        let mut found: Vec<(u32, [u32; 3])> = Vec::new();
        for h in 0..nh {
            let t = topo.twin(h);
            if t == INVALID {
                continue;
            }
            let v = topo.opposite_vertex(h);
            let (a, b, c) = (topo.from(h), topo.to(h), topo.opposite_vertex(t));
            if a < v && b < v && c < v {
                found.push((v, [a, b, c]));
            }
        }
        // Stable: half-edge order within a vertex.
        found.sort_by_key(|&(v, _)| v);
        let mut off = vec![0u32; n + 1];
        for &(v, _) in &found {
            off[v as usize + 1] += 1;
        }
        for i in 0..n {
            off[i + 1] += off[i];
        }
        Plan {
            off,
            paras: found.into_iter().map(|(_, p)| p).collect(),
        }
    }

    fn paras(&self, v: usize) -> &[[u32; 3]] {
        &self.paras[self.off[v] as usize..self.off[v + 1] as usize]
    }

    /// Candidate predictions of `v` from the decoded positions `rec` (only entries
    /// `< v` are read): returns the count and the parallelogram count.
    fn candidates(
        &self,
        topo: &Topology,
        v: usize,
        rec: &[DVec3],
        select: bool,
        out: &mut [DVec3; MAX_CANDIDATES],
    ) -> (usize, usize) {
        let ps = self.paras(v);
        if !ps.is_empty() {
            let mut s = DVec3::ZERO;
            for (i, &[a, b, c]) in ps.iter().enumerate() {
                let p = rec[a as usize] + rec[b as usize] - rec[c as usize];
                s += p;
                if select && i + 1 < MAX_CANDIDATES {
                    out[i + 1] = p;
                }
            }
            out[0] = s * (1.0 / ps.len() as f64);
            let nc = if select && ps.len() >= 2 {
                (ps.len() + 1).min(MAX_CANDIDATES)
            } else {
                1
            };
            return (nc, ps.len());
        }
        let mut s = DVec3::ZERO;
        let mut c = 0usize;
        for &w in topo.neighbors(VertexId(v as u32)) {
            if w as usize >= v {
                break;
            }
            s += rec[w as usize];
            c += 1;
        }
        out[0] = if c > 0 {
            s * (1.0 / c as f64)
        } else if v > 0 {
            rec[v - 1]
        } else {
            DVec3::ZERO
        };
        (1, 0)
    }
}

/// Activity bucket of `v`: 1 when the mean `Σ_k |q_k|` of its decoded neighbours is
/// at least 2 (or it has none), else 0.
fn activity(topo: &Topology, v: usize, q: &[[i32; 3]]) -> usize {
    let mut s = 0u64;
    let mut c = 0u64;
    for &w in topo.neighbors(VertexId(v as u32)) {
        if w as usize >= v {
            break;
        }
        let t = q[w as usize];
        s += (t[0].unsigned_abs() + t[1].unsigned_abs() + t[2].unsigned_abs()) as u64;
        c += 1;
    }
    (c == 0 || s >= 2 * c) as usize
}

/// Model index of coordinate `k` given the parallelogram count, the activity bucket
/// and the vertex's earlier coordinates.
fn context(k: usize, npara: usize, act: usize, earlier: &[i64]) -> usize {
    let nz = earlier.iter().any(|&x| x != 0) as usize;
    ((k * 4 + npara.min(3)) * ACTIVITY + act) * 2 + nz
}

/// `(q, (r − q)² + μ·bits(q))` of the better of `round(r)` and the next integer
/// towards zero.
fn rdo_round(r: f64, m: &IntModel, mu: f64) -> Result<(i64, f64), CodecError> {
    let q0 = checked(r.round())?;
    let j = |q: i64| (r - q as f64).powi(2) + mu * m.cost(q) as f64;
    let j0 = if mu > 0.0 {
        j(q0)
    } else {
        (r - q0 as f64).powi(2)
    };
    if mu > 0.0 && q0 != 0 {
        let q1 = q0 - q0.signum();
        let j1 = j(q1);
        if j1 < j0 {
            return Ok((q1, j1));
        }
    }
    Ok((q0, j0))
}

/// What a vertex is coded with: its candidate count (`nc`, a choice symbol is coded
/// when above 1), parallelogram count and activity bucket.
#[derive(Clone, Copy)]
struct Site {
    v: usize,
    nc: usize,
    np: usize,
    act: usize,
}

/// The state encoder and decoder share while walking the vertices in coding order:
/// the adaptive models, the decoded positions, the quantized residuals (for the
/// activity contexts) and the current vertex's candidates.
struct Walk<'a> {
    topo: &'a Topology,
    plan: &'a Plan,
    select: bool,
    step: f64,
    coord: Vec<IntModel>,
    choice: Vec<BitTree>,
    rec: Vec<DVec3>,
    qs: Vec<[i32; 3]>,
    cand: [DVec3; MAX_CANDIDATES],
}

impl<'a> Walk<'a> {
    fn new(topo: &'a Topology, plan: &'a Plan, select: bool, step: f64) -> Self {
        let n = topo.n_vertices();
        Walk {
            topo,
            plan,
            select,
            step,
            coord: (0..3 * 4 * ACTIVITY * 2)
                .map(|_| IntModel::default())
                .collect(),
            choice: (0..MAX_CANDIDATES - 1).map(|_| BitTree::new(2)).collect(),
            rec: vec![DVec3::ZERO; n],
            qs: vec![[0i32; 3]; n],
            cand: [DVec3::ZERO; MAX_CANDIDATES],
        }
    }

    /// Computes the candidates of vertex `v` and its contexts.
    fn site(&mut self, v: usize) -> Site {
        let (nc, np) = self
            .plan
            .candidates(self.topo, v, &self.rec, self.select, &mut self.cand);
        let act = activity(self.topo, v, &self.qs);
        Site { v, nc, np, act }
    }

    /// The model of the predictor choice (with several candidates).
    fn choice_model(&mut self, site: Site) -> Option<&mut BitTree> {
        (site.nc > 1).then(|| &mut self.choice[site.nc - 2])
    }

    /// The model of coordinate `k`, given the vertex's earlier coordinates.
    fn coord_model(&mut self, site: Site, k: usize, earlier: &[i64]) -> &mut IntModel {
        &mut self.coord[context(k, site.np, site.act, earlier)]
    }

    /// Records the vertex as decoded: candidate `ci` plus `q·Δ`.
    fn place(&mut self, site: Site, ci: usize, q: [i64; 3]) {
        let r = DVec3::new(q[0] as f64, q[1] as f64, q[2] as f64);
        self.rec[site.v] = self.cand[ci] + r * self.step;
        self.qs[site.v] = q.map(|x| x as i32);
    }

    /// The decoded positions (n×3).
    fn finish(self) -> Vec<[f64; 3]> {
        self.rec.iter().map(|p| p.to_array()).collect()
    }
}

/// Encodes `positions` (decoded vertex order) with step `step`: the stream — the
/// step (`f64` LE), the selection flag (`u8`) and the range-coded payload — and the
/// positions the decoder will produce.
pub fn encode(
    topo: &Topology,
    plan: &Plan,
    positions: &[[f64; 3]],
    step: f64,
    params: &SpatialParams,
) -> Result<(Vec<u8>, Vec<[f64; 3]>), CodecError> {
    params.validate()?;
    let inv = 1.0 / step;
    let mu = params.lambda;
    let mut out = Vec::with_capacity(9);
    out.extend_from_slice(&step.to_le_bytes());
    out.push(params.select as u8);
    let mut enc = RangeEncoder::new();
    let mut w = Walk::new(topo, plan, params.select, step);
    for (v, &x) in positions.iter().enumerate().take(topo.n_vertices()) {
        let site = w.site(v);
        let x = DVec3::from(x);
        // The candidate and rounding of the lowest Lagrangian (squared error in
        // steps² + μ·bits).
        let mut best = (f64::INFINITY, 0usize, [0i64; 3]);
        for ci in 0..site.nc {
            let mut j = match w.choice_model(site) {
                Some(m) => mu * m.cost(ci as u32) as f64,
                None => 0.0,
            };
            let r = (x - w.cand[ci]) * inv;
            let mut q = [0i64; 3];
            for k in 0..3 {
                let (qk, jk) = rdo_round(r[k], w.coord_model(site, k, &q[..k]), mu)?;
                q[k] = qk;
                j += jk;
            }
            if j < best.0 {
                best = (j, ci, q);
            }
        }
        let (_, ci, q) = best;
        if let Some(m) = w.choice_model(site) {
            m.encode(&mut enc, ci as u32);
        }
        for k in 0..3 {
            w.coord_model(site, k, &q[..k]).encode(&mut enc, q[k]);
        }
        w.place(site, ci, q);
    }
    out.extend_from_slice(&enc.finish());
    Ok((out, w.finish()))
}

/// Decodes a stream written by [`encode`] for the connectivity `topo`: the positions
/// (n×3) in the decoded vertex order.
pub fn decode(topo: &Topology, data: &[u8]) -> Result<Vec<[f64; 3]>, CodecError> {
    let mut r = ByteReader::new(data, "geometry header");
    let step = r.f64()?;
    if step <= 0.0 {
        return Err(CodecError::Corrupt("non-positive quantization step"));
    }
    let select = r.flag("bad predictor-selection flag")?;
    let plan = Plan::new(topo);
    let mut dec = RangeDecoder::new(r.rest());
    let mut w = Walk::new(topo, &plan, select, step);
    for v in 0..topo.n_vertices() {
        let site = w.site(v);
        let ci = match w.choice_model(site) {
            Some(m) => m.decode(&mut dec) as usize,
            None => 0,
        };
        if ci >= site.nc {
            return Err(CodecError::Corrupt("predictor choice out of range"));
        }
        let mut q = [0i64; 3];
        for k in 0..3 {
            q[k] = w.coord_model(site, k, &q[..k]).decode(&mut dec)?;
            if q[k].unsigned_abs() >= 1 << 31 {
                return Err(CodecError::Corrupt("residual out of range"));
            }
        }
        w.place(site, ci, q);
        if v % 1024 == 0 && dec.exhausted() {
            return Err(CodecError::Truncated("geometry stream"));
        }
    }
    dec.finish()?;
    let rec = w.finish();
    if rec.iter().flatten().any(|x| !x.is_finite()) {
        return Err(CodecError::Corrupt("non-finite decoded coordinate"));
    }
    Ok(rec)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::codec::tests::{corrupt, rms};
    use crate::mesh::builtin;

    fn mesh(spec: &str) -> (Vec<[f64; 3]>, Topology) {
        let m = builtin::from_spec(spec).unwrap();
        let t = Topology::new(&m).unwrap();
        (m.positions, t)
    }

    #[test]
    fn parallelograms_use_only_earlier_vertices_and_are_exact_on_a_grid() {
        let (p, t) = mesh("builtin:grid:9");
        let plan = Plan::new(&t);
        let mut with = 0;
        for v in 0..t.n_vertices() {
            for &[a, b, c] in plan.paras(v) {
                assert!(a < v as u32 && b < v as u32 && c < v as u32);
                // A planar regular grid: every parallelogram is exact.
                for k in 0..3 {
                    let e = p[a as usize][k] + p[b as usize][k] - p[c as usize][k];
                    assert!((e - p[v][k]).abs() < 1e-9, "vertex {v}");
                }
                with += 1;
            }
        }
        assert!(with > t.n_vertices() / 2, "{with} parallelograms");
    }

    #[test]
    fn round_trip_is_exact_and_error_is_half_a_step() {
        for spec in [
            "builtin:icosphere:3",
            "builtin:cube:8",
            "builtin:torus:12:8",
        ] {
            let (p, t) = mesh(spec);
            let plan = Plan::new(&t);
            for params in [
                SpatialParams {
                    select: false,
                    lambda: 0.0,
                },
                SpatialParams::default(),
            ] {
                let step = 1e-3;
                let (data, rec) = encode(&t, &plan, &p, step, &params).unwrap();
                let dec = decode(&t, &data).unwrap();
                assert_eq!(dec, rec, "{spec} {params:?}");
                let e = rms(&rec, &p);
                // Uniform rounding: RMS ≈ Δ/2 (3 coordinates of Δ²/12); RD rounding
                // trades a little more.
                assert!(e < 0.75 * step, "{spec}: {e}");
                // (The cube's faces are planar grids: its parallelograms are exact.)
                if params.lambda == 0.0 && spec != "builtin:cube:8" {
                    assert!(
                        (0.35 * step..0.6 * step).contains(&e),
                        "{spec}: {e} vs step {step}"
                    );
                }
            }
        }
    }

    #[test]
    fn rd_rounding_and_selection_lower_the_rate() {
        let (p, t) = mesh("builtin:torus:60:40");
        // Irregular noise so the choice matters.
        let p: Vec<[f64; 3]> = p
            .iter()
            .enumerate()
            .map(|(i, x)| {
                let h = (i as f64 * 12.9898).sin() * 43758.5453;
                let d = (h - h.floor() - 0.5) * 0.004;
                [x[0] + d, x[1] - d, x[2] + 0.5 * d]
            })
            .collect();
        let plan = Plan::new(&t);
        let step = 2e-3;
        let size = |select, lambda| {
            let (data, rec) =
                encode(&t, &plan, &p, step, &SpatialParams { select, lambda }).unwrap();
            (data.len(), rms(&rec, &p))
        };
        let (plain, e_plain) = size(false, 0.0);
        let (_, e_sel) = size(true, 0.0);
        let n = p.len() as f64;
        // Lagrangian D/Δ² + μ·R per vertex (D: squared error summed over coordinates).
        let lagrangian =
            |bytes: usize, e: f64, mu: f64| (e / step).powi(2) + mu * bytes as f64 * 8.0 / n;
        // Selection without a rate term lowers the error; RD rounding lowers the
        // rate for some more error (not necessarily the Lagrangian: a coarser
        // reconstruction also feeds later predictions).
        assert!(e_sel < e_plain, "{e_sel} vs {e_plain}");
        for mu in [0.05, 0.12] {
            let (rdo, e_rdo) = size(false, mu);
            assert!(rdo < plain, "μ = {mu}: {rdo} vs {plain} bytes");
            assert!(e_rdo < 1.35 * e_plain, "μ = {mu}: {e_rdo} vs {e_plain}");
        }
        // With a rate term the choice pays for itself.
        let (sel, e_sel) = size(true, 0.12);
        let (nosel, e_nosel) = size(false, 0.12);
        assert!(
            lagrangian(sel, e_sel, 0.12) < lagrangian(nosel, e_nosel, 0.12),
            "{sel} B {e_sel} vs {nosel} B {e_nosel}"
        );
    }

    #[test]
    fn corrupt_payload_never_panics() {
        use rand::SeedableRng;
        let (p, t) = mesh("builtin:icosphere:2");
        let plan = Plan::new(&t);
        let (data, _) = encode(&t, &plan, &p, 0.01, &SpatialParams::default()).unwrap();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4);
        for _ in 0..200 {
            let _ = decode(&t, &corrupt(&data, &mut rng));
        }
        // A truncated stream is an error, not a wrong mesh.
        assert!(decode(&t, &data[..data.len() / 3]).is_err());
    }
}
