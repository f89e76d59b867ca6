//! Bounding-volume hierarchy over a mesh's triangles for closest-point queries.
//!
//! Axis-aligned boxes, built top-down by splitting at the median centroid along the
//! longest axis (leaves of ≤ 4 triangles); a query descends nearer child first and
//! prunes boxes farther than the best distance so far. Point–triangle distance by
//! Ericson's Voronoi-region method (*Real-Time Collision Detection*, §5.1.5).
//! Hand-written: a few dozen lines, and the usual crates (parry, bvh) bring their own
//! geometry types and more dependencies than this needs.

use crate::mesh::TriMesh;
use crate::operator::geometry::cross;

#[derive(Clone, Copy, Debug)]
struct Node {
    lo: [f64; 3],
    hi: [f64; 3],
    /// Leaf: first triangle index in `order` and count; inner: left child, 0.
    start: u32,
    count: u32,
    right: u32,
}

/// A BVH over the triangles of a mesh.
#[derive(Debug)]
pub struct Bvh {
    tris: Vec<[[f64; 3]; 3]>,
    order: Vec<u32>,
    nodes: Vec<Node>,
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn add_s(a: [f64; 3], b: [f64; 3], s: f64) -> [f64; 3] {
    [a[0] + s * b[0], a[1] + s * b[1], a[2] + s * b[2]]
}

/// Closest point of segment `(a, b)` to `p` (`a` when the segment has zero length).
fn closest_on_segment(p: [f64; 3], a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    let ab = sub(b, a);
    let len2 = dot(ab, ab);
    if len2 <= 0.0 {
        return a;
    }
    add_s(a, ab, (dot(sub(p, a), ab) / len2).clamp(0.0, 1.0))
}

/// Closest point of triangle `(a, b, c)` to `p`. A triangle that is zero-area to
/// rounding (`‖ab × ac‖ ≤ ε·ℓ²`, ℓ its longest edge: collinear or coincident corners)
/// is treated as its three edges, so degenerate faces give finite distances.
pub fn closest_on_triangle(p: [f64; 3], a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> [f64; 3] {
    let ab = sub(b, a);
    let ac = sub(c, a);
    let n = cross(ab, ac);
    let longest2 = dot(ab, ab).max(dot(ac, ac)).max(dot(sub(c, b), sub(c, b)));
    if dot(n, n).sqrt() <= f64::EPSILON * longest2 {
        return [(a, b), (b, c), (c, a)]
            .map(|(u, v)| closest_on_segment(p, u, v))
            .into_iter()
            .min_by(|x, y| dot(sub(p, *x), sub(p, *x)).total_cmp(&dot(sub(p, *y), sub(p, *y))))
            .unwrap_or(a);
    }
    let ap = sub(p, a);
    let d1 = dot(ab, ap);
    let d2 = dot(ac, ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = sub(p, b);
    let d3 = dot(ab, bp);
    let d4 = dot(ac, bp);
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return add_s(a, ab, d1 / (d1 - d3));
    }
    let cp = sub(p, c);
    let d5 = dot(ab, cp);
    let d6 = dot(ac, cp);
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return add_s(a, ac, d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return add_s(b, sub(c, b), (d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = va + vb + vc;
    if denom.abs() < 1e-300 {
        // Unreachable for a proper triangle (checked above); keep the result finite.
        return a;
    }
    let v = vb / denom;
    let w = vc / denom;
    add_s(add_s(a, ab, v), ac, w)
}

impl Bvh {
    /// Builds the hierarchy over `m`'s triangles.
    pub fn new(m: &TriMesh) -> Self {
        let tris: Vec<[[f64; 3]; 3]> = m
            .faces
            .iter()
            .map(|f| f.map(|v| m.positions[v as usize]))
            .collect();
        let mut order: Vec<u32> = (0..tris.len() as u32).collect();
        let cent: Vec<[f64; 3]> = tris
            .iter()
            .map(|t| [0, 1, 2].map(|k| (t[0][k] + t[1][k] + t[2][k]) / 3.0))
            .collect();
        let mut nodes = Vec::with_capacity(2 * tris.len() / 4 + 1);
        // Iterative build: (node index, start, end).
        nodes.push(Node {
            lo: [0.0; 3],
            hi: [0.0; 3],
            start: 0,
            count: 0,
            right: 0,
        });
        let mut stack = vec![(0usize, 0usize, tris.len())];
        while let Some((ni, s, e)) = stack.pop() {
            let mut lo = [f64::INFINITY; 3];
            let mut hi = [f64::NEG_INFINITY; 3];
            for &t in &order[s..e] {
                for p in &tris[t as usize] {
                    for k in 0..3 {
                        lo[k] = lo[k].min(p[k]);
                        hi[k] = hi[k].max(p[k]);
                    }
                }
            }
            nodes[ni].lo = lo;
            nodes[ni].hi = hi;
            if e - s <= 4 {
                nodes[ni].start = s as u32;
                nodes[ni].count = (e - s) as u32;
                continue;
            }
            let axis = (0..3)
                .max_by(|&a, &b| (hi[a] - lo[a]).total_cmp(&(hi[b] - lo[b])))
                .unwrap_or(0);
            let mid = (s + e) / 2;
            order[s..e].select_nth_unstable_by(mid - s, |&x, &y| {
                cent[x as usize][axis].total_cmp(&cent[y as usize][axis])
            });
            let l = nodes.len();
            nodes.push(nodes[ni]);
            nodes.push(nodes[ni]);
            nodes[ni].start = l as u32;
            nodes[ni].count = 0;
            nodes[ni].right = l as u32 + 1;
            stack.push((l, s, mid));
            stack.push((l + 1, mid, e));
        }
        Bvh { tris, order, nodes }
    }

    fn box_dist2(n: &Node, p: &[f64; 3]) -> f64 {
        let mut d = 0.0;
        for k in 0..3 {
            let x = if p[k] < n.lo[k] {
                n.lo[k] - p[k]
            } else if p[k] > n.hi[k] {
                p[k] - n.hi[k]
            } else {
                0.0
            };
            d += x * x;
        }
        d
    }

    /// The closest point of the mesh to `p` and its squared distance (infinite for
    /// a mesh without triangles).
    pub fn closest(&self, p: &[f64; 3]) -> ([f64; 3], f64) {
        let (_, q, d) = self.closest_face(p);
        (q, d)
    }

    /// Like [`Bvh::closest`], also returning the index of the face (in the mesh's face
    /// order) the closest point lies on: `(face, point, squared distance)`; face 0 and
    /// an infinite distance for a mesh without triangles.
    pub fn closest_face(&self, p: &[f64; 3]) -> (usize, [f64; 3], f64) {
        let mut best = ([0.0; 3], f64::INFINITY);
        let mut face = 0;
        if self.tris.is_empty() {
            return (face, best.0, best.1);
        }
        let mut stack = vec![0u32];
        while let Some(ni) = stack.pop() {
            let n = &self.nodes[ni as usize];
            if Self::box_dist2(n, p) >= best.1 {
                continue;
            }
            if n.count > 0 {
                for &t in &self.order[n.start as usize..(n.start + n.count) as usize] {
                    let [a, b, c] = self.tris[t as usize];
                    let q = closest_on_triangle(*p, a, b, c);
                    let d = dot(sub(*p, q), sub(*p, q));
                    if d < best.1 {
                        best = (q, d);
                        face = t as usize;
                    }
                }
            } else {
                let (l, r) = (n.start, n.right);
                let dl = Self::box_dist2(&self.nodes[l as usize], p);
                let dr = Self::box_dist2(&self.nodes[r as usize], p);
                if dl < dr {
                    stack.push(r);
                    stack.push(l);
                } else {
                    stack.push(l);
                    stack.push(r);
                }
            }
        }
        (face, best.0, best.1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::builtin;
    use rand::{Rng, SeedableRng};

    #[test]
    fn agrees_with_brute_force_on_seeded_queries() {
        let m = builtin::torus(14, 9).unwrap();
        let bvh = Bvh::new(&m);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(17);
        for _ in 0..500 {
            let p = [0, 1, 2].map(|_| rng.gen_range(-3.0..3.0));
            let brute = m
                .faces
                .iter()
                .map(|f| {
                    let [a, b, c] = f.map(|v| m.positions[v as usize]);
                    let q = closest_on_triangle(p, a, b, c);
                    dot(sub(p, q), sub(p, q))
                })
                .fold(f64::INFINITY, f64::min);
            let (_, d) = bvh.closest(&p);
            assert!((d - brute).abs() <= 1e-12 * (1.0 + brute), "{d} vs {brute}");
        }
    }

    #[test]
    fn closest_point_regions() {
        let (a, b, c) = ([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]);
        assert_eq!(closest_on_triangle([-1.0, -1.0, 0.0], a, b, c), a);
        let q = closest_on_triangle([0.2, 0.2, 5.0], a, b, c);
        assert!((q[0] - 0.2).abs() < 1e-15 && (q[1] - 0.2).abs() < 1e-15 && q[2] == 0.0);
        assert_eq!(
            closest_on_triangle([0.5, -2.0, 1.0], a, b, c),
            [0.5, 0.0, 0.0]
        );
        let q = closest_on_triangle([1.0, 1.0, 0.0], a, b, c);
        assert!((q[0] - 0.5).abs() < 1e-15 && (q[1] - 0.5).abs() < 1e-15);
    }
}
