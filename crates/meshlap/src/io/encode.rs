//! The writers' records (vertex and face lines, binary vertex and face records),
//! encoded in parallel and in bounded memory.
//!
//! [`write_records`] cuts a file's `count` records into chunks of [`CHUNK`], encodes a
//! batch of chunks (two per thread) into byte buffers on the rayon pool, writes the
//! buffers in order while the next batch is encoded, and reuses them: the bytes
//! written are those of a sequential loop over the records, and the memory held is
//! two batches' buffers, never the whole file.
//!
//! Text numbers: [`Text`] prints a `f64` with `zmij` (the shortest decimal that reads
//! back to the same `f64`, as std's `{:?}` does; large and small magnitudes in
//! exponent form such as `1e+16`, `5e-324`) and an integer with `itoa`. Both crates
//! are dtolnay's, already in the tree through `serde_json`, and faster per value than
//! std's `write!` with `{:?}` through a `dyn Write`, which the writers used before
//! (BENCHMARKS.md, "Writers").

use crate::mesh::TriMesh;
use rayon::prelude::*;
use std::io::Write;
use std::ops::Range;

/// Records per chunk: about 0.2–0.6 MB of text for vertex lines.
pub(crate) const CHUNK: usize = 8192;

/// Writes records `0..count` to `w`: `encode(range, out)` appends the bytes of the
/// records in `range` to `out`, for chunks of [`CHUNK`] records encoded in parallel,
/// a batch of two chunks per thread at a time. The calling thread writes a batch
/// while the pool encodes the next one (`rayon::in_place_scope`, so `w` need not be
/// `Send`); the batches are written in order.
///
/// # Errors
/// The first error of `w` (the batch being encoded is finished first, then dropped).
pub(crate) fn write_records(
    w: &mut dyn Write,
    count: usize,
    encode: impl Fn(Range<usize>, &mut Vec<u8>) + Sync,
) -> std::io::Result<()> {
    let chunks = count.div_ceil(CHUNK);
    let batch = (2 * rayon::current_num_threads()).clamp(1, chunks.max(1));
    let fill = |bufs: &mut [Vec<u8>], first: usize| {
        bufs.par_iter_mut().enumerate().for_each(|(k, out)| {
            out.clear();
            let c = first + k;
            encode(c * CHUNK..((c + 1) * CHUNK).min(count), out);
        });
    };
    let (mut cur, mut next) = (vec![Vec::new(); batch], vec![Vec::new(); batch]);
    let mut m = batch.min(chunks);
    fill(&mut cur[..m], 0);
    let mut first = 0;
    while m > 0 {
        let after = first + m;
        let m_next = batch.min(chunks - after);
        let mut written = Ok(());
        rayon::in_place_scope(|s| {
            let bufs = &mut next[..m_next];
            if m_next > 0 {
                s.spawn(|_| fill(bufs, after));
            }
            for out in &cur[..m] {
                written = w.write_all(out);
                if written.is_err() {
                    break;
                }
            }
        });
        written?;
        std::mem::swap(&mut cur, &mut next);
        (first, m) = (after, m_next);
    }
    Ok(())
}

/// Writes `mesh` as text lines: per vertex `vertex_prefix` and its coordinates, then
/// per face `face_prefix` and its corner indices plus `index_base` (OBJ: `v `, `f `,
/// 1; OFF: no prefix, `3 `, 0), each chunk of lines encoded in parallel
/// ([`write_records`]).
///
/// # Errors
/// The first error of `w`.
pub(crate) fn write_text_lines(
    w: &mut dyn Write,
    mesh: &TriMesh,
    vertex_prefix: &[u8],
    face_prefix: &[u8],
    index_base: u64,
) -> std::io::Result<()> {
    let (p, f) = (&mesh.positions, &mesh.faces);
    write_records(w, p.len(), |r, out| {
        let mut t = Text::new();
        for v in &p[r] {
            t.floats_line(out, vertex_prefix, v);
        }
    })?;
    write_records(w, f.len(), |r, out| {
        let mut t = Text::new();
        for &face in &f[r] {
            t.face_line(out, face_prefix, face, index_base);
        }
    })
}

/// Appends `s` (at most 32 bytes: a formatted number) to `out` with two fixed-size
/// copies that overlap, instead of a call to `memcpy` for every number (BENCHMARKS.md,
/// "Writers").
#[inline(always)]
fn push_short(out: &mut Vec<u8>, s: &[u8]) {
    /// Copies `s[..K]` and `s[n − K..]` (n = `s.len()`, K ≤ n ≤ 2K) to `dst`.
    ///
    /// # Safety
    /// `dst` is valid for n bytes and does not overlap `s`.
    #[inline(always)]
    unsafe fn copy<const K: usize>(s: &[u8], dst: *mut u8) {
        let n = s.len();
        // SAFETY: K ≤ n, so both ranges lie in `s` and, by the caller, in `dst`.
        unsafe {
            std::ptr::copy_nonoverlapping(s.as_ptr(), dst, K);
            std::ptr::copy_nonoverlapping(s.as_ptr().add(n - K), dst.add(n - K), K);
        }
    }
    let n = s.len();
    assert!(n <= 32, "push_short: {n} bytes");
    out.reserve(n);
    let len = out.len();
    // SAFETY: the reserve makes room for n bytes after `len`; every one of them is
    // written below (the two copies of each arm cover 0..n), then the length grows.
    unsafe {
        let dst = out.as_mut_ptr().add(len);
        match n {
            16.. => copy::<16>(s, dst),
            8.. => copy::<8>(s, dst),
            4.. => copy::<4>(s, dst),
            2.. => copy::<2>(s, dst),
            1 => *dst = s[0],
            0 => {}
        }
        out.set_len(len + n);
    }
}

/// Number formatting for the text writers (see the module documentation).
pub(crate) struct Text {
    float: zmij::Buffer,
    int: itoa::Buffer,
}

impl Text {
    pub(crate) fn new() -> Self {
        Self {
            float: zmij::Buffer::new(),
            int: itoa::Buffer::new(),
        }
    }

    /// Appends `x`: the shortest decimal that reads back to `x` (`NaN`, `inf`,
    /// `-inf` for the non-finite).
    #[inline]
    pub(crate) fn float(&mut self, out: &mut Vec<u8>, x: f64) {
        push_short(out, self.float.format(x).as_bytes());
    }

    /// Appends the decimal digits of `v`.
    #[inline]
    pub(crate) fn int(&mut self, out: &mut Vec<u8>, v: impl itoa::Integer) {
        push_short(out, self.int.format(v).as_bytes());
    }

    /// Appends the values separated by single spaces.
    #[inline]
    pub(crate) fn floats(&mut self, out: &mut Vec<u8>, xs: &[f64]) {
        for (k, &x) in xs.iter().enumerate() {
            if k > 0 {
                out.push(b' ');
            }
            self.float(out, x);
        }
    }

    /// Appends `prefix`, the values separated by single spaces, and a newline.
    #[inline]
    pub(crate) fn floats_line(&mut self, out: &mut Vec<u8>, prefix: &[u8], xs: &[f64]) {
        out.extend_from_slice(prefix);
        self.floats(out, xs);
        out.push(b'\n');
    }

    /// Appends `prefix`, the three indices each plus `base`, separated by single
    /// spaces, and a newline (a face line).
    #[inline]
    pub(crate) fn face_line(&mut self, out: &mut Vec<u8>, prefix: &[u8], f: [u32; 3], base: u64) {
        out.extend_from_slice(prefix);
        for (k, &i) in f.iter().enumerate() {
            if k > 0 {
                out.push(b' ');
            }
            self.int(out, u64::from(i) + base);
        }
        out.push(b'\n');
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// The chunked, parallel writer gives the bytes of the sequential loop, at every
    /// count around the chunk and batch boundaries and on pools of 1–3 threads.
    #[test]
    fn records_come_out_in_order_at_every_boundary() {
        let encode = |r: Range<usize>, out: &mut Vec<u8>| {
            let mut t = Text::new();
            for i in r {
                t.int(out, i);
                out.push(if i % 5 == 0 { b'\n' } else { b' ' });
            }
        };
        for threads in 1..=3 {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            for count in [0, 1, CHUNK - 1, CHUNK, CHUNK + 1, 7 * CHUNK + 3, 13 * CHUNK] {
                let mut want = Vec::new();
                encode(0..count, &mut want);
                let mut got = Vec::new();
                pool.install(|| write_records(&mut got, count, encode))
                    .unwrap();
                assert!(got == want, "{threads} threads, {count} records");
            }
        }
    }

    /// Every length from 0 to 32 bytes is appended whole, after any prefix.
    #[test]
    fn short_copies_append_every_length() {
        let src: Vec<u8> = (0..32u8).map(|b| b'a' + b % 26).collect();
        for n in 0..=32 {
            let mut out = b"xy".to_vec();
            push_short(&mut out, &src[..n]);
            assert_eq!(&out[..2], b"xy");
            assert_eq!(&out[2..], &src[..n], "{n} bytes");
        }
    }

    /// A writer error stops the writing and is returned.
    #[test]
    fn the_first_write_error_is_returned() {
        struct Full(usize);
        impl Write for Full {
            fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
                if self.0 < b.len() {
                    return Err(std::io::Error::other("disk full"));
                }
                self.0 -= b.len();
                Ok(b.len())
            }
            fn flush(&mut self) -> std::io::Result<()> {
                Ok(())
            }
        }
        let encode = |r: Range<usize>, out: &mut Vec<u8>| out.resize(out.len() + r.len(), b'x');
        let mut w = Full(CHUNK + 10);
        let e = write_records(&mut w, 5 * CHUNK, encode).unwrap_err();
        assert_eq!(e.to_string(), "disk full");
    }

    /// Every printed float reads back to the same bits: seeded values over the whole
    /// exponent range, the subnormals, the extremes and the signed zeros; the
    /// non-finite print as std prints them.
    #[test]
    fn floats_read_back_exactly() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(41);
        let mut values = vec![
            0.0,
            -0.0,
            1.0,
            0.1,
            1e-5,
            1e16,
            f64::MAX,
            f64::MIN,
            f64::MIN_POSITIVE,
            5e-324,
            -2.5e-310,
        ];
        values.extend(
            (0..20_000)
                .map(|_| f64::from_bits(rng.gen::<u64>()))
                .filter(|x| x.is_finite()),
        );
        values.extend((0..20_000).map(|_| rng.gen::<f64>() * 2.0 - 1.0));
        let mut t = Text::new();
        for x in values {
            let mut out = Vec::new();
            t.float(&mut out, x);
            let s = std::str::from_utf8(&out).unwrap();
            let back: f64 = s.parse().unwrap();
            assert_eq!(back.to_bits(), x.to_bits(), "{x:?} printed as {s}");
            let fast = fast_float2::parse::<f64, _>(s).unwrap();
            assert_eq!(fast.to_bits(), x.to_bits(), "{x:?} printed as {s}");
        }
        for x in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            let mut out = Vec::new();
            t.float(&mut out, x);
            assert_eq!(std::str::from_utf8(&out).unwrap(), format!("{x:?}"));
        }
        let mut out = Vec::new();
        t.floats_line(&mut out, b"v ", &[1.0, -0.5, 1e16]);
        t.face_line(&mut out, b"f ", [0, 9, u32::MAX], 1);
        assert_eq!(out, b"v 1.0 -0.5 1e+16\nf 1 10 4294967296\n");
    }
}
