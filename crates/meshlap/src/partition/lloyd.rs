//! Parts by Lloyd relaxation of graph Voronoi cells: the first step of
//! [`PartitionMethod::Lloyd`](super::PartitionMethod::Lloyd).
//!
//! k-means on the vertex graph with hop distances (Lloyd's algorithm with the
//! Chebyshev centre in place of the centroid, which a graph does not have):
//! 1. **Seeds.** Each connected component of `c` vertices gets
//!    `max(1, round(c·k/n))` seeds, spread evenly over its vertices in index order
//!    (the `i`-th of `s` seeds is its vertex number `⌊(2i + 1)·c / 2s⌋`).
//! 2. **Cells.** A multi-source breadth-first search from the seeds, level by level:
//!    every vertex first reached at level `d + 1` joins the cell that most of its
//!    neighbours at level `d` belong to (ties: the lowest cell index). The decision
//!    reads only earlier levels, so it does not depend on the order in which a level
//!    is visited. A cell of [`CAP_PERCENT`] % of the mean size `n / seeds` takes no
//!    more vertices while a neighbouring cell can: a vertex whose earlier neighbours
//!    are all in full cells waits for the next level, and when a level assigns
//!    nothing the cap is lifted for the rest. Each cell is connected (every vertex
//!    joins through a neighbour of its own cell).
//! 3. **Centres.** Every cell's new seed is its vertex farthest from the cell's
//!    border (hops, counted inside the cell from the vertices with a neighbour in
//!    another cell; ties: the lowest vertex index). A cell without a border (a whole
//!    component) keeps its seed.
//! 4. Steps 2 and 3 repeat `iterations` times; the cells of the last seeds are the
//!    parts.
//!
//! Integer arithmetic only, and no random numbers: the parts depend on the
//! connectivity and its vertex numbering alone, the same on every CPU and thread
//! count, which is what lets a decoder recompute them ([`crate::codec`], format 7).
//! Written by hand because no crate offers a deterministic graph k-means; METIS
//! (the other method) keeps its random generator in process-global state and runs
//! on one thread. Cost: `O(iterations · (n + edges))`; each wide level's search and
//! decisions run in parallel, and so does each level of step 3's search (a level is
//! a set, and a decision reads earlier levels only, so the result does not depend on
//! the thread count or on the order in which a level is listed).

use rayon::prelude::*;
use std::sync::atomic::{AtomicU32, Ordering::Relaxed};

/// A cell stops growing at this percentage of the mean cell size `n / seeds` while
/// a neighbouring cell can take the vertex.
const CAP_PERCENT: usize = 125;

/// A vertex not yet reached by the search.
const NONE: u32 = u32::MAX;
/// A vertex reached at the level being decided.
const PENDING: u32 = u32::MAX - 1;

/// Parts of the graph with adjacency `adj[off[v]..off[v + 1]]` (symmetric, no self
/// loops) from about `k` seeds after `iterations` Lloyd steps; returns each vertex's
/// part (`0..parts`; every part non-empty and connected) and the number of parts.
pub(super) fn lloyd_parts(
    off: &[u32],
    adj: &[u32],
    k: usize,
    iterations: usize,
) -> (Vec<u32>, usize) {
    let n = off.len().saturating_sub(1);
    if n == 0 {
        return (Vec::new(), 0);
    }
    let nbrs = Graph { off, adj };
    let mut seeds = initial_seeds(n, &nbrs, k.max(1));
    let mut scratch = Scratch::new(n);
    let mut lab = vec![NONE; n];
    let cap = (n * CAP_PERCENT).div_ceil(100 * seeds.len());
    grow(&nbrs, &seeds, &mut lab, &mut scratch, cap);
    for _ in 0..iterations {
        centres(&nbrs, &lab, &mut seeds, &mut scratch);
        grow(&nbrs, &seeds, &mut lab, &mut scratch, cap);
    }
    (lab, seeds.len())
}

/// The adjacency: the neighbours of `v` are `adj[off[v]..off[v + 1]]`.
struct Graph<'a> {
    off: &'a [u32],
    adj: &'a [u32],
}

impl Graph<'_> {
    fn of(&self, v: u32) -> &[u32] {
        &self.adj[self.off[v as usize] as usize..self.off[v as usize + 1] as usize]
    }
}

/// Work arrays kept from pass to pass.
struct Scratch {
    front: Vec<u32>,
    next: Vec<u32>,
    decided: Vec<[u32; 2]>,
    dist: Vec<u32>,
}

impl Scratch {
    fn new(n: usize) -> Self {
        Self {
            front: Vec::new(),
            next: Vec::new(),
            decided: Vec::new(),
            dist: vec![0; n],
        }
    }
}

/// Step 1: seeds spread over each component's vertices in index order, ascending.
/// Components are numbered in the order of their lowest vertex and found by a
/// concurrent union-find over the edges ([`component_labels`], in parallel over the
/// vertices; the numbering does not depend on the order).
///
/// [`component_labels`]: crate::mesh::component_labels::component_labels
fn initial_seeds(n: usize, nbrs: &Graph<'_>, k: usize) -> Vec<u32> {
    // Component numbers by lowest vertex, and each component's size.
    let (comp, count) = crate::mesh::component_labels::component_labels(n, |sink| {
        (0..n as u32)
            .into_par_iter()
            .with_min_len(1 << 11)
            .for_each(|v| {
                for &w in nbrs.of(v) {
                    if w > v {
                        sink(v, w);
                    }
                }
            });
    });
    let mut sizes = vec![0usize; count];
    for &c in &comp {
        sizes[c as usize] += 1;
    }
    // Each component's vertices ascending, packed one component after the other.
    let mut start: Vec<usize> = Vec::with_capacity(sizes.len() + 1);
    start.push(0);
    for &c in &sizes {
        start.push(start[start.len() - 1] + c);
    }
    let mut fill = start.clone();
    let mut members = vec![0u32; n];
    for v in 0..n {
        let c = comp[v] as usize;
        members[fill[c]] = v as u32;
        fill[c] += 1;
    }
    let mut seeds = Vec::with_capacity(k + sizes.len());
    for (c, &len) in sizes.iter().enumerate() {
        let m = &members[start[c]..start[c] + len];
        let s = ((len * k + n / 2) / n).clamp(1, len);
        seeds.extend((0..s).map(|i| m[(2 * i + 1) * len / (2 * s)]));
    }
    seeds.sort_unstable();
    seeds
}

/// Step 2: the cells of `seeds` (cell `i` grows from `seeds[i]`) into `lab`; a cell
/// of `cap` vertices takes no more while another can.
fn grow(nbrs: &Graph<'_>, seeds: &[u32], lab: &mut [u32], s: &mut Scratch, cap: usize) {
    lab.fill(NONE);
    s.front.clear();
    let k = seeds.len();
    let mut size = vec![0usize; k];
    // `open[l]`: cell `l` may take vertices (below the cap, or the cap lifted); one
    // more entry, closed, for the labels NONE and PENDING (`decide` clamps to it).
    let mut open = vec![1u8; k + 1];
    open[k] = 0;
    for (i, &v) in seeds.iter().enumerate() {
        lab[v as usize] = i as u32;
        size[i] = 1;
        open[i] = u8::from(size[i] < cap);
        s.front.push(v);
    }
    let mut deferred: Vec<u32> = Vec::new();
    let mut relax = false;
    loop {
        // The next level: the front's unreached neighbours, claimed (marked PENDING),
        // then decided together with the deferred vertices (every assigned
        // neighbour's cell was full). A vertex first reached now has all its
        // assigned neighbours in the front (one assigned earlier would have reached
        // it earlier), and a deferred one counts every assigned neighbour: either
        // way it joins the open cell most of its assigned neighbours belong to. Each
        // decision reads the labels of earlier levels only (this level's vertices
        // are PENDING, which it skips), so the decisions do not depend on their
        // order and run in parallel.
        claim(nbrs, &s.front, lab, PENDING, |_, _| true, &mut s.next);
        s.next.extend_from_slice(&deferred);
        decide_all(nbrs, &s.next, lab, &open, &mut s.decided);
        deferred.clear();
        if s.decided.is_empty() {
            break;
        }
        let mut progressed = false;
        s.front.clear();
        for &[w, l] in &s.decided {
            if l == NONE {
                deferred.push(w);
            } else if lab[w as usize] == PENDING {
                // (A vertex claimed twice by a parallel search is listed twice, with
                // the same decision: the second copy finds it assigned.)
                lab[w as usize] = l;
                size[l as usize] += 1;
                if !relax && size[l as usize] >= cap {
                    open[l as usize] = 0;
                }
                s.front.push(w);
                progressed = true;
            }
        }
        if !progressed {
            relax = true;
            open[..k].fill(1);
        }
    }
}

/// The [`decide`] of every vertex of `ws` (`[w, cell]` into `decided`, in the order
/// of `ws`), in parallel for a long list. Each decision chases three dependent loads
/// (`w`'s offsets, its neighbours, their labels) that are mostly cache misses on a
/// large graph, so each run of decisions prefetches them ahead, a load at a time
/// ([`prefetch_ahead`]): hints only, which change no result.
fn decide_all(nbrs: &Graph<'_>, ws: &[u32], lab: &[u32], open: &[u8], decided: &mut Vec<[u32; 2]>) {
    decided.clear();
    let run = |ws: &[u32], out: &mut Vec<[u32; 2]>| {
        for (i, &w) in ws.iter().enumerate() {
            prefetch_ahead(nbrs, ws, i, lab);
            out.push([w, decide(nbrs.of(w), |u| lab[u as usize], open)]);
        }
    };
    if ws.len() < PAR_LEVEL {
        run(ws, decided);
        return;
    }
    let parts: Vec<Vec<[u32; 2]>> = ws
        .par_chunks(PAR_LEVEL / 4)
        .map(|part| {
            let mut out = Vec::with_capacity(part.len());
            run(part, &mut out);
            out
        })
        .collect();
    for p in &parts {
        decided.extend_from_slice(p);
    }
}

/// For the `i`-th vertex of `list`, which a loop is about to visit: prefetches the
/// offsets of the vertex [`AHEAD`]` · 2` places on, the neighbours of the one
/// [`AHEAD`] on, and the `per_vertex` entries of the neighbours of the one
/// [`AHEAD`]` / 2` on (by then their addresses are in cache).
#[inline(always)]
fn prefetch_ahead<T>(nbrs: &Graph<'_>, list: &[u32], i: usize, per_vertex: &[T]) {
    if let Some(&x) = list.get(i + 2 * AHEAD) {
        crate::mem::prefetch(&nbrs.off[x as usize]);
    }
    if let Some(&x) = list.get(i + AHEAD) {
        let (a, b) = (
            nbrs.off[x as usize] as usize,
            nbrs.off[x as usize + 1] as usize,
        );
        if a < b {
            crate::mem::prefetch(&nbrs.adj[a]);
            crate::mem::prefetch(&nbrs.adj[b - 1]);
        }
    }
    if let Some(&x) = list.get(i + AHEAD / 2) {
        for &u in nbrs.of(x) {
            crate::mem::prefetch(&per_vertex[u as usize]);
        }
    }
}

/// How far ahead in a list of vertices [`prefetch_ahead`] looks.
const AHEAD: usize = 16;

/// One level of a breadth-first search: the neighbours `w` of the vertices `v` of
/// `front` with `marks[w]` still [`NONE`] and `admit(v, w)` into `next`, marked
/// `mark`. A wide front is searched in parallel: the set is the same, the order may
/// not be, and nothing downstream depends on the order. A vertex is claimed by a
/// plain (relaxed) load and store rather than an atomic exchange, whose full fence
/// would stall the loads behind it: two threads reaching one vertex at the same
/// moment both list it, so `next` may hold a vertex twice (rarely), and callers
/// treat a repeat as a no-op.
fn claim(
    nbrs: &Graph<'_>,
    front: &[u32],
    marks: &mut [u32],
    mark: u32,
    admit: impl Fn(u32, u32) -> bool + Sync,
    next: &mut Vec<u32>,
) {
    next.clear();
    if front.len() < PAR_LEVEL {
        for (i, &v) in front.iter().enumerate() {
            prefetch_ahead(nbrs, front, i, marks);
            for &w in nbrs.of(v) {
                if marks[w as usize] == NONE && admit(v, w) {
                    marks[w as usize] = mark;
                    next.push(w);
                }
            }
        }
        return;
    }
    let marks = atomic(marks);
    let found: Vec<Vec<u32>> = front
        .par_chunks(PAR_LEVEL / 4)
        .map(|part| {
            let mut out = Vec::with_capacity(part.len() * 2);
            for (i, &v) in part.iter().enumerate() {
                prefetch_ahead(nbrs, part, i, marks);
                for &w in nbrs.of(v) {
                    let x = &marks[w as usize];
                    if x.load(Relaxed) == NONE && admit(v, w) {
                        x.store(mark, Relaxed);
                        out.push(w);
                    }
                }
            }
            out
        })
        .collect();
    for f in &found {
        next.extend_from_slice(f);
    }
}

/// `x` seen as atomics, for the claims of a parallel search.
fn atomic(x: &mut [u32]) -> &[AtomicU32] {
    // SAFETY: `AtomicU32` has the size, alignment and bit validity of `u32`, and the
    // exclusive borrow keeps every non-atomic access out while the view lives.
    unsafe { &*(x as *mut [u32] as *const [AtomicU32]) }
}

/// Levels of at least this many vertices are decided in parallel (under Miri 32, so
/// that the small meshes it can interpret still reach the parallel search and its
/// atomic claims; RELIABILITY.md).
const PAR_LEVEL: usize = if cfg!(miri) { 32 } else { 4096 };

/// The decision for a vertex with neighbours `nb`: the most frequent label among
/// those of open cells (`open[l] != 0`; ties: the lowest), `NONE` for none. The
/// neighbours' labels are gathered without a branch per neighbour (a label is
/// written, and kept when its cell is open).
#[inline]
fn decide(nb: &[u32], lab: impl Fn(u32) -> u32, open: &[u8]) -> u32 {
    let closed = (open.len() - 1) as u32;
    let keep = |l: u32| open[l.min(closed) as usize] != 0;
    let mut buf = [0u32; 32];
    if nb.len() > buf.len() {
        let mut all: Vec<u32> = nb.iter().map(|&u| lab(u)).filter(|&l| keep(l)).collect();
        return majority(&mut all);
    }
    let mut len = 0usize;
    for &u in nb {
        let l = lab(u);
        // len ≤ the neighbours seen so far < 32.
        buf[len & 31] = l;
        len += usize::from(keep(l));
    }
    majority(&mut buf[..len])
}

/// The most frequent label of `all` (ties: the lowest), `NONE` for none.
fn majority(all: &mut [u32]) -> u32 {
    let Some(&first) = all.first() else {
        return NONE;
    };
    // Most vertices see one cell only.
    if all.iter().all(|&l| l == first) {
        return first;
    }
    all.sort_unstable();
    let (mut best, mut best_count, mut run) = (NONE, 0usize, 0usize);
    for i in 0..all.len() {
        run = if i > 0 && all[i - 1] == all[i] {
            run + 1
        } else {
            1
        };
        if run > best_count {
            (best, best_count) = (all[i], run);
        }
    }
    best
}

/// Step 3: every cell's vertex farthest from its border becomes its seed.
fn centres(nbrs: &Graph<'_>, lab: &[u32], seeds: &mut [u32], s: &mut Scratch) {
    let n = lab.len();
    let dist = &mut s.dist;
    // Border vertices (a neighbour in another cell) at distance 0, in parallel; the
    // distances do not depend on the order of the search's levels.
    dist.par_iter_mut().enumerate().for_each(|(v, d)| {
        let l = lab[v];
        *d = if nbrs.of(v as u32).iter().any(|&w| lab[w as usize] != l) {
            0
        } else {
            NONE
        };
    });
    s.front.clear();
    s.front
        .extend((0..n as u32).filter(|&v| dist[v as usize] == 0));
    let mut d = 0;
    while !s.front.is_empty() {
        // Inward from the borders, within each cell.
        claim(
            nbrs,
            &s.front,
            dist,
            d + 1,
            |v, w| lab[v as usize] == lab[w as usize],
            &mut s.next,
        );
        std::mem::swap(&mut s.front, &mut s.next);
        d += 1;
    }
    // Deepest vertex per cell, ties to the lowest index: per block of vertices in
    // ascending order (only a strictly deeper one replaces the best), then the
    // blocks in order, on the same rule.
    let dist = &*dist;
    let deepest = |range: std::ops::Range<usize>| {
        let mut best: Vec<u32> = vec![NONE; seeds.len()];
        for v in range {
            let (l, dv) = (lab[v] as usize, dist[v]);
            if dv != NONE && (best[l] == NONE || dv > dist[best[l] as usize]) {
                best[l] = v as u32;
            }
        }
        best
    };
    // A few blocks per thread: each keeps a best vertex per cell.
    let block = PAR_BLOCK.max(n.div_ceil(4 * rayon::current_num_threads().max(1)));
    let blocks: Vec<_> = (0..n)
        .step_by(block)
        .map(|a| a..(a + block).min(n))
        .collect();
    let per_block: Vec<Vec<u32>> = blocks.into_par_iter().map(deepest).collect();
    let mut best: Vec<u32> = vec![NONE; seeds.len()];
    for block in per_block {
        for (b, c) in best.iter_mut().zip(block) {
            if c != NONE && (*b == NONE || dist[c as usize] > dist[*b as usize]) {
                *b = c;
            }
        }
    }
    for (seed, b) in seeds.iter_mut().zip(best) {
        if b != NONE {
            *seed = b;
        }
    }
}

/// The smallest block of vertices of the parallel search for each cell's deepest
/// vertex.
const PAR_BLOCK: usize = 1 << 15;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::topology::Topology;

    fn parts_of(topo: &Topology, k: usize, it: usize) -> (Vec<u32>, usize) {
        lloyd_parts(topo.adjacency_offsets(), topo.adjacency(), k, it)
    }

    /// Every part is non-empty and connected, one per seed, from a single seed up
    /// to 64 (two components: `partition`'s tests).
    #[test]
    fn parts_are_connected_and_cover_every_component() {
        let ico = crate::mesh::builtin::icosphere(3).unwrap();
        let t = Topology::new(&ico).unwrap();
        for (k, it) in [(1, 0), (7, 0), (20, 3), (64, 5)] {
            let (lab, parts) = parts_of(&t, k, it);
            assert_eq!(parts, k);
            check_connected(&t, &lab, parts);
        }
    }

    /// Levels wide enough to be decided in parallel give the same parts on pools of
    /// 1 and 3 threads. (Under Miri, with its lower [`PAR_LEVEL`], icosphere 3 and 4
    /// parts: the fronts around the seeds and the cells' borders are wider than 32.)
    #[test]
    fn same_parts_on_any_thread_count() {
        let (level, k) = if cfg!(miri) { (3, 4) } else { (6, 1000) };
        let ico = crate::mesh::builtin::icosphere(level).unwrap();
        let t = Topology::new(&ico).unwrap();
        let run = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| parts_of(&t, k, 2))
        };
        let (a, parts) = run(1);
        assert_eq!(run(3).0, a);
        check_connected(&t, &a, parts);
    }

    /// Step 2 as the module docs state it, one vertex at a time: each vertex is
    /// decided the moment it is first reached (before the rest of its level is
    /// claimed), a deferred one again at every later level.
    fn grow_one_at_a_time(nbrs: &Graph<'_>, seeds: &[u32], n: usize, cap: usize) -> Vec<u32> {
        let k = seeds.len();
        let mut lab = vec![NONE; n];
        let (mut size, mut open) = (vec![0usize; k], vec![1u8; k + 1]);
        open[k] = 0;
        let mut front: Vec<u32> = seeds.to_vec();
        for (i, &v) in seeds.iter().enumerate() {
            lab[v as usize] = i as u32;
            size[i] = 1;
            open[i] = u8::from(size[i] < cap);
        }
        let (mut deferred, mut relax) = (Vec::new(), false);
        loop {
            let mut decided = Vec::new();
            for &v in &front {
                for &w in nbrs.of(v) {
                    if lab[w as usize] == NONE {
                        lab[w as usize] = PENDING;
                        decided.push([w, decide(nbrs.of(w), |u| lab[u as usize], &open)]);
                    }
                }
            }
            for &w in &deferred {
                decided.push([w, decide(nbrs.of(w), |u| lab[u as usize], &open)]);
            }
            deferred.clear();
            if decided.is_empty() {
                return lab;
            }
            front.clear();
            for &[w, l] in &decided {
                if l == NONE {
                    deferred.push(w);
                } else {
                    lab[w as usize] = l;
                    size[l as usize] += 1;
                    if !relax && size[l as usize] >= cap {
                        open[l as usize] = 0;
                    }
                    front.push(w);
                }
            }
            if front.is_empty() {
                relax = true;
                open[..k].fill(1);
            }
        }
    }

    /// The search that claims a whole level before deciding it (in parallel, with
    /// prefetching) gives the cells of the one-at-a-time search, on closed and
    /// boundary meshes, with caps that defer many vertices, on 1 and 3 threads.
    #[test]
    fn cells_match_the_one_at_a_time_search() {
        let meshes = [
            // 40,962 vertices: levels wide enough for the parallel search.
            crate::mesh::builtin::icosphere(6).unwrap(),
            crate::mesh::builtin::torus(120, 40).unwrap(),
            crate::mesh::builtin::grid(90).unwrap(),
        ];
        for mesh in &meshes {
            let t = Topology::new(mesh).unwrap();
            let nbrs = Graph {
                off: t.adjacency_offsets(),
                adj: t.adjacency(),
            };
            let n = t.n_vertices();
            for k in [3, 40, 1500] {
                let seeds = initial_seeds(n, &nbrs, k);
                for cap in [
                    n.div_ceil(seeds.len()),
                    (n * CAP_PERCENT).div_ceil(100 * seeds.len()),
                ] {
                    let want = grow_one_at_a_time(&nbrs, &seeds, n, cap);
                    for threads in [1, 3] {
                        let got = rayon::ThreadPoolBuilder::new()
                            .num_threads(threads)
                            .build()
                            .unwrap()
                            .install(|| {
                                let mut lab = vec![NONE; n];
                                grow(&nbrs, &seeds, &mut lab, &mut Scratch::new(n), cap);
                                lab
                            });
                        assert_eq!(
                            got, want,
                            "n = {n}, k = {k}, cap = {cap}, {threads} threads"
                        );
                    }
                }
            }
        }
    }

    /// The seeds from the union-find's components are those of a depth-first search
    /// numbering components by their lowest vertex (the method before it), on random
    /// graphs of many components, isolated vertices included.
    #[test]
    fn seeds_match_a_depth_first_component_search() {
        fn by_search(n: usize, nbrs: &Graph<'_>, k: usize) -> Vec<u32> {
            let mut comp = vec![NONE; n];
            let mut members: Vec<Vec<u32>> = Vec::new();
            for s in 0..n as u32 {
                if comp[s as usize] != NONE {
                    continue;
                }
                let c = members.len() as u32;
                comp[s as usize] = c;
                let mut stack = vec![s];
                while let Some(v) = stack.pop() {
                    for &w in nbrs.of(v) {
                        if comp[w as usize] == NONE {
                            comp[w as usize] = c;
                            stack.push(w);
                        }
                    }
                }
                members.push(Vec::new());
            }
            for v in 0..n as u32 {
                members[comp[v as usize] as usize].push(v);
            }
            let mut seeds = Vec::new();
            for m in &members {
                let c = m.len();
                let s = ((c * k + n / 2) / n).clamp(1, c);
                seeds.extend((0..s).map(|i| m[(2 * i + 1) * c / (2 * s)]));
            }
            seeds.sort_unstable();
            seeds
        }
        let mut rng = crate::rng::SplitMix64::new(17);
        for round in 0..200 {
            let n = 1 + (rng.next_u64() % 300) as usize;
            let edges = (rng.next_u64() % (2 * n as u64)) as usize;
            let mut adj: Vec<Vec<u32>> = vec![Vec::new(); n];
            for _ in 0..edges {
                let a = (rng.next_u64() % n as u64) as u32;
                let b = (rng.next_u64() % n as u64) as u32;
                if a != b && !adj[a as usize].contains(&b) {
                    adj[a as usize].push(b);
                    adj[b as usize].push(a);
                }
            }
            let mut off = vec![0u32];
            let mut flat = Vec::new();
            for a in &adj {
                flat.extend_from_slice(a);
                off.push(flat.len() as u32);
            }
            let g = Graph {
                off: &off,
                adj: &flat,
            };
            for k in [1, 3, n / 4 + 1, n] {
                assert_eq!(
                    initial_seeds(n, &g, k),
                    by_search(n, &g, k),
                    "round {round}, k {k}"
                );
            }
        }
    }

    /// A decision is the most frequent label of the open cells among the neighbours
    /// (ties: the lowest), NONE for none: against a direct count, for degrees up to
    /// and past the 32 gathered without a branch.
    #[test]
    fn decide_is_the_open_majority() {
        let mut rng = crate::rng::SplitMix64::new(5);
        let k = 7u32;
        for round in 0..2000 {
            let deg = (rng.next_u64() % 48) as usize;
            let lab: Vec<u32> = (0..deg)
                .map(|_| match rng.next_u64() % 10 {
                    0 => NONE,
                    1 => PENDING,
                    _ => (rng.next_u64() % u64::from(k)) as u32,
                })
                .collect();
            let mut open: Vec<u8> = (0..k)
                .map(|_| u8::from(!rng.next_u64().is_multiple_of(4)))
                .collect();
            open.push(0);
            let nb: Vec<u32> = (0..deg as u32).collect();
            let mut count = vec![0usize; k as usize];
            for &l in &lab {
                if l < k && open[l as usize] != 0 {
                    count[l as usize] += 1;
                }
            }
            let best = (0..k).max_by_key(|&l| (count[l as usize], std::cmp::Reverse(l)));
            let want = match best {
                Some(l) if count[l as usize] > 0 => l,
                _ => NONE,
            };
            assert_eq!(
                decide(&nb, |u| lab[u as usize], &open),
                want,
                "round {round}"
            );
        }
    }

    fn check_connected(t: &Topology, lab: &[u32], parts: usize) {
        let n = lab.len();
        let mut seen = vec![false; n];
        let mut count = vec![0usize; parts];
        for v in 0..n {
            count[lab[v] as usize] += 1;
        }
        assert!(count.iter().all(|&c| c > 0), "empty part");
        let mut comps = vec![0usize; parts];
        for s in 0..n {
            if seen[s] {
                continue;
            }
            comps[lab[s] as usize] += 1;
            let mut stack = vec![s as u32];
            seen[s] = true;
            while let Some(v) = stack.pop() {
                for &w in t.neighbors(crate::mesh::VertexId(v)) {
                    if !seen[w as usize] && lab[w as usize] == lab[v as usize] {
                        seen[w as usize] = true;
                        stack.push(w);
                    }
                }
            }
        }
        assert!(comps.iter().all(|&c| c == 1), "a part is not connected");
    }
}
