//! Wavefront OBJ: `v x y z [w] [r g b]` and `f` in every form (`i`, `i/t`, `i//n`,
//! `i/t/n`), with negative (relative) indices; polygons are fan-triangulated. Every
//! other statement (`vt`, `vn`, `o`, `g`, `s`, `usemtl`, `mtllib`, `l`, comments) is
//! ignored. Lines may end in CRLF.

use super::text::{parse_err, parse_f64, tokens};
use super::{IoError, ReadInfo};
use crate::mesh::TriMesh;
use rayon::prelude::*;
use std::io::Write;

/// Bytes per chunk below which a file is read on one thread.
const CHUNK_BYTES: usize = 1 << 20;

/// Reads an OBJ file held in `bytes`.
///
/// The file is cut at line ends into chunks that are parsed in parallel (rayon). A
/// first pass counts each chunk's lines, `v` statements and `f` statements, so the
/// second knows the global line number and the number of vertices defined before
/// every line: a face index refers to a vertex defined above it (relative indices
/// count back from the last one), exactly as in a sequential read. Vertices are
/// written straight into the output array, and so are faces while each `f` statement
/// gives one triangle (polygons spill the rest of their chunk into a separate list,
/// and the chunks are then concatenated). Errors are those of the first failing line
/// in file order.
///
/// Each line is first parsed by a hand-written scanner that handles the common forms
/// (`v x y z …`, `f i j k …` with `/`-suffixed indices) without splitting the line
/// into tokens; any line it does not fully accept (a token it cannot parse, an index
/// out of range, a non-finite coordinate, too few corners) is parsed again by the
/// token-based reader, which decides, so both give the same results and errors.
/// Coordinates are parsed with `fast-float2` (correctly rounded like `str::parse`,
/// several times faster, and able to parse a number at the start of a longer buffer,
/// which the scanner needs; `lexical-core` would do too but brings a larger API for
/// formats OBJ does not have); `str::parse` still handles the rare tokens it declines.
pub(crate) fn read(bytes: &[u8], file: &str, info: &mut ReadInfo) -> Result<TriMesh, IoError> {
    read_in_chunks(bytes, file, info, CHUNK_BYTES, true)
}

/// [`read`] with chunks of at least `min_chunk` bytes (tests and the differential fuzz
/// target cut small files finely); `scan: false` parses every line with the
/// token-based reader alone.
pub(super) fn read_in_chunks(
    bytes: &[u8],
    file: &str,
    info: &mut ReadInfo,
    min_chunk: usize,
    scan: bool,
) -> Result<TriMesh, IoError> {
    let chunks = split_lines(bytes, rayon::current_num_threads() * 4, min_chunk);
    let counts: Vec<Counts> = chunks.par_iter().map(|c| count_lines(c)).collect();
    let mut starts = Vec::with_capacity(chunks.len());
    let mut total = Counts::default();
    for c in &counts {
        starts.push(total);
        total.lines += c.lines;
        total.verts += c.verts;
        total.faces += c.faces;
    }
    let mut positions = crate::mem::zeroed_vec([0.0f64; 3], total.verts);
    let mut faces = crate::mem::zeroed_vec([0u32; 3], total.faces);
    let mut slots = Vec::with_capacity(chunks.len());
    let (mut pos_rest, mut face_rest) = (positions.as_mut_slice(), faces.as_mut_slice());
    for c in &counts {
        let (p, pr) = pos_rest.split_at_mut(c.verts);
        let (f, fr) = face_rest.split_at_mut(c.faces);
        slots.push((p, f));
        (pos_rest, face_rest) = (pr, fr);
    }
    let parsed: Vec<Result<Chunk, IoError>> = chunks
        .par_iter()
        .zip(slots)
        .zip(starts)
        .map(|((text, (pos, faces)), start)| {
            let mut c = ChunkParser {
                file,
                line: start.lines + 1,
                n: start.verts,
                local: 0,
                positions: pos,
                faces,
                written: 0,
                spill: Vec::new(),
                polygons: 0,
                poly: Vec::with_capacity(8),
            };
            c.parse(text, scan)?;
            Ok(Chunk {
                written: c.written,
                spill: c.spill,
                polygons: c.polygons,
            })
        })
        .collect();
    let mut done = Vec::with_capacity(parsed.len());
    for chunk in parsed {
        let chunk = chunk?;
        info.polygons_triangulated += chunk.polygons;
        done.push(chunk);
    }
    // Every `f` statement gave one triangle in its chunk's slot unless polygons spilt.
    let exact = done
        .iter()
        .zip(&counts)
        .all(|(d, c)| d.written == c.faces && d.spill.is_empty());
    if !exact {
        let mut all = Vec::with_capacity(done.iter().map(|d| d.written + d.spill.len()).sum());
        let mut rest = faces.as_slice();
        for (d, c) in done.iter().zip(&counts) {
            let (slot, r) = rest.split_at(c.faces);
            all.extend_from_slice(&slot[..d.written]);
            all.extend_from_slice(&d.spill);
            rest = r;
        }
        faces = all;
    }
    Ok(TriMesh::new(positions, faces))
}

/// Lines, `v` statements and `f` statements of a chunk (or before it).
#[derive(Copy, Clone, Default)]
struct Counts {
    lines: usize,
    verts: usize,
    faces: usize,
}

/// What one chunk of lines produced besides its slots.
struct Chunk {
    /// Triangles written into the chunk's face slot.
    written: usize,
    /// Triangles that did not fit there, in order after them.
    spill: Vec<[u32; 3]>,
    polygons: usize,
}

/// Cuts `bytes` into at most `parts` pieces of at least `min_chunk` bytes that end just
/// after a `\n` (the last piece ends where the file does).
fn split_lines(bytes: &[u8], parts: usize, min_chunk: usize) -> Vec<&[u8]> {
    let target = (bytes.len() / parts.max(1)).max(min_chunk.max(1));
    let mut out = Vec::new();
    let mut rest = bytes;
    while rest.len() > target {
        match memchr::memchr(b'\n', &rest[target..]) {
            Some(p) => {
                let (head, tail) = rest.split_at(target + p + 1);
                out.push(head);
                rest = tail;
            }
            None => break,
        }
    }
    out.push(rest);
    out
}

/// Whitespace inside a line: what `u8::is_ascii_whitespace` accepts but `\n`.
#[inline(always)]
fn is_blank(b: u8) -> bool {
    matches!(b, b' ' | b'\t' | b'\r' | b'\x0c')
}

/// Whether `b` (the byte after a token, `None` at the end) ends the token.
#[inline(always)]
fn ends_token(b: Option<&u8>) -> bool {
    b.is_none_or(|&b| b == b'\n' || is_blank(b))
}

/// [`Counts`] of a chunk. A chunk that ends without a newline (the file's last) still
/// has its last line counted, as the sequential reader does.
fn count_lines(text: &[u8]) -> Counts {
    let body = text.strip_suffix(b"\n").unwrap_or(text);
    let mut c = Counts::default();
    let starts = std::iter::once(0).chain(memchr::memchr_iter(b'\n', body).map(|p| p + 1));
    for start in starts {
        c.lines += 1;
        match statement(&body[start..]) {
            Some(b'v') => c.verts += 1,
            Some(b'f') => c.faces += 1,
            _ => {}
        }
    }
    c
}

/// The one-letter statement (`v` or `f`) of the line starting at `rest[0]`: its first
/// token, if that is `v` or `f`.
#[inline(always)]
fn statement(rest: &[u8]) -> Option<u8> {
    let t = match rest.first() {
        Some(b'v' | b'f') => rest,
        Some(&b) if is_blank(b) => {
            let end = memchr::memchr(b'\n', rest).unwrap_or(rest.len());
            rest[..end].trim_ascii_start()
        }
        _ => return None,
    };
    match t.first() {
        Some(&s @ (b'v' | b'f')) if ends_token(t.get(1)) => Some(s),
        _ => None,
    }
}

/// The state of one chunk's parse: its place in the file and its output slots.
struct ChunkParser<'a> {
    file: &'a str,
    /// 1-based number of the line being parsed.
    line: usize,
    /// Vertices defined before the line (in the whole file).
    n: usize,
    /// Vertices of this chunk written so far.
    local: usize,
    positions: &'a mut [[f64; 3]],
    faces: &'a mut [[u32; 3]],
    written: usize,
    spill: Vec<[u32; 3]>,
    polygons: usize,
    poly: Vec<u32>,
}

impl ChunkParser<'_> {
    /// Parses every line of `text` (ended by `\n`, or by the chunk's end); with
    /// `scan`, each line goes through [`Self::scan_line`] first.
    fn parse(&mut self, text: &[u8], scan: bool) -> Result<(), IoError> {
        let mut pos = 0;
        loop {
            let next = if scan {
                self.scan_line(text, pos)
            } else {
                None
            };
            let next = match next {
                Some(next) => next,
                None => {
                    let end = memchr::memchr(b'\n', &text[pos..]).map_or(text.len(), |e| pos + e);
                    let line = &text[pos..end];
                    self.token_line(line.strip_suffix(b"\r").unwrap_or(line))?;
                    end + 1
                }
            };
            // `next` is one past the line's `\n`, or past the end for the last line.
            if next >= text.len() {
                return Ok(());
            }
            pos = next;
            self.line += 1;
        }
    }

    /// Adds a triangle after the previous ones: into the slot while it has room.
    #[inline(always)]
    fn push(&mut self, t: [u32; 3]) {
        match self.faces.get_mut(self.written) {
            Some(slot) => {
                *slot = t;
                self.written += 1;
            }
            None => self.spill.push(t),
        }
    }

    /// Fan-triangulates `self.poly` (at least three corners) into the output.
    fn fan(&mut self) {
        let poly = std::mem::take(&mut self.poly);
        for k in 1..poly.len().saturating_sub(1) {
            self.push([poly[0], poly[k], poly[k + 1]]);
        }
        self.polygons += usize::from(poly.len() > 3);
        self.poly = poly;
    }

    /// The scanner: parses the line starting at `text[start]` if it is well-formed and
    /// returns where the next line starts; `None` (having changed nothing that
    /// [`Self::token_line`] does not set again) for anything else.
    #[inline]
    fn scan_line(&mut self, text: &[u8], start: usize) -> Option<usize> {
        let blank_to = |mut p: usize| {
            while p < text.len() && is_blank(text[p]) {
                p += 1;
            }
            p
        };
        let line_end = |p: usize| match text.get(p) {
            None => Some(text.len()),
            Some(b'\n') => Some(p + 1),
            _ => None,
        };
        let mut p = blank_to(start);
        let head = text.get(p).copied();
        if !matches!(head, Some(b'v' | b'f')) || !ends_token(text.get(p + 1)) {
            // An empty line, a comment or a statement meshlap ignores.
            return Some(memchr::memchr(b'\n', &text[p..]).map_or(text.len(), |e| p + e + 1));
        }
        p += 1;
        if head == Some(b'v') {
            let mut v = [0.0f64; 3];
            for c in &mut v {
                p = blank_to(p);
                let (x, len) = fast_float2::parse_partial::<f64, _>(&text[p..]).ok()?;
                p += len;
                if !ends_token(text.get(p)) {
                    return None;
                }
                *c = x;
            }
            if !v.iter().all(|c| c.is_finite()) {
                return None;
            }
            *self.positions.get_mut(self.local)? = v;
            self.local += 1;
            self.n += 1;
            // Further tokens (w, colour) are ignored.
            p = blank_to(p);
            return line_end(p).or_else(|| {
                Some(memchr::memchr(b'\n', &text[p..]).map_or(text.len(), |e| p + e + 1))
            });
        }
        self.poly.clear();
        let n = self.n as i64;
        loop {
            p = blank_to(p);
            if let Some(next) = line_end(p) {
                if self.poly.len() < 3 {
                    return None;
                }
                self.fan();
                return Some(next);
            }
            let (i, len) = scan_index(&text[p..])?;
            p += len;
            if text.get(p) == Some(&b'/') {
                // `i/t`, `i//n`, `i/t/n`: the rest of the token is not read.
                while !ends_token(text.get(p)) {
                    p += 1;
                }
            } else if !ends_token(text.get(p)) {
                return None;
            }
            let resolved = if i > 0 { i - 1 } else { n + i };
            if i == 0 || resolved < 0 || resolved >= n {
                return None;
            }
            self.poly.push(resolved as u32);
        }
    }

    /// The token-based reader of one line (without its line end): decides every line
    /// the scanner declines, and names the error.
    fn token_line(&mut self, line: &[u8]) -> Result<(), IoError> {
        let (file, ln) = (self.file, self.line);
        let mut toks = tokens(line);
        let Some(head) = toks.next() else {
            return Ok(());
        };
        match head {
            b"v" => {
                let p = &mut self.positions[self.local];
                for c in p.iter_mut() {
                    let t = toks.next().ok_or_else(|| {
                        parse_err(file, ln, line, "a vertex with three coordinates")
                    })?;
                    *c = parse_f64(t)
                        .ok_or_else(|| parse_err(file, ln, t, "a vertex coordinate"))?;
                }
                if !p.iter().all(|c| c.is_finite()) {
                    return Err(IoError::NonFinite {
                        file: file.to_string(),
                        line: ln,
                        vertex: self.n,
                    });
                }
                self.local += 1;
                self.n += 1;
            }
            b"f" => {
                let n = self.n;
                self.poly.clear();
                for t in toks {
                    let idx_tok = match memchr::memchr(b'/', t) {
                        Some(slash) => &t[..slash],
                        None => t,
                    };
                    let i = parse_i64(idx_tok)
                        .ok_or_else(|| parse_err(file, ln, idx_tok, "a face index"))?;
                    let resolved = if i > 0 { i - 1 } else { n as i64 + i };
                    if i == 0 || resolved < 0 || resolved >= n as i64 {
                        return Err(IoError::IndexOutOfRange {
                            file: file.to_string(),
                            line: ln,
                            index: i,
                            vertices: n,
                        });
                    }
                    self.poly.push(resolved as u32);
                }
                if self.poly.len() < 3 {
                    return Err(parse_err(
                        file,
                        ln,
                        line,
                        "a face with at least three vertices",
                    ));
                }
                self.fan();
            }
            _ => {}
        }
        Ok(())
    }
}

/// A face index at the start of `s`: an optional sign and 1 to 18 decimal digits
/// (never overflowing), with the bytes it spans; `None` otherwise (the token-based
/// reader then decides).
#[inline(always)]
fn scan_index(s: &[u8]) -> Option<(i64, usize)> {
    let (neg, start) = match s.first()? {
        b'-' => (true, 1),
        b'+' => (false, 1),
        _ => (false, 0),
    };
    let mut v: i64 = 0;
    let mut p = start;
    while let Some(&d) = s.get(p) {
        if !d.is_ascii_digit() {
            break;
        }
        if p - start == 18 {
            return None;
        }
        v = v * 10 + (d - b'0') as i64;
        p += 1;
    }
    if p == start {
        return None;
    }
    Some((if neg { -v } else { v }, p))
}

/// A decimal integer token with an optional sign (what `str::parse::<i64>` accepts).
fn parse_i64(tok: &[u8]) -> Option<i64> {
    let (neg, digits) = match tok.first()? {
        b'-' => (true, &tok[1..]),
        b'+' => (false, &tok[1..]),
        _ => (false, tok),
    };
    if digits.is_empty() || digits.len() > 18 {
        return std::str::from_utf8(tok).ok()?.parse().ok();
    }
    let mut v: i64 = 0;
    for &d in digits {
        if !d.is_ascii_digit() {
            return None;
        }
        v = v * 10 + (d - b'0') as i64;
    }
    Some(if neg { -v } else { v })
}

pub(crate) fn write(w: &mut dyn Write, mesh: &TriMesh) -> std::io::Result<()> {
    writeln!(
        w,
        "# meshlap: {} vertices, {} faces",
        mesh.n_vertices(),
        mesh.n_faces()
    )?;
    // `v x y z` and 1-based `f a b c` lines.
    super::encode::write_text_lines(w, mesh, b"v ", b"f ", 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(s: &str) -> Result<(TriMesh, ReadInfo), IoError> {
        crate::io::read_any(s.as_bytes(), crate::io::Format::Obj, "t.obj")
    }

    /// `src` read with chunks of at least `chunk` bytes, with or without the scanner:
    /// the mesh and report, or the error's message.
    fn read_with(src: &[u8], chunk: usize, scan: bool) -> Result<(TriMesh, ReadInfo), String> {
        let mut info = ReadInfo::new(crate::io::Format::Obj);
        read_in_chunks(src, "t.obj", &mut info, chunk, scan)
            .map(|m| (m, info))
            .map_err(|e| e.to_string())
    }

    /// The token-based reader on one chunk (the sequential reader as it was) is the
    /// reference: every cut, with and without the scanner, must give the same.
    fn assert_same_everywhere(src: &[u8], chunks: impl IntoIterator<Item = usize>) {
        let reference = read_with(src, usize::MAX, false);
        for chunk in chunks {
            for scan in [true, false] {
                assert_eq!(
                    read_with(src, chunk, scan),
                    reference,
                    "chunk {chunk}, scan {scan}, file {:?}",
                    String::from_utf8_lossy(src)
                );
            }
        }
    }

    #[test]
    fn chunked_reads_equal_the_one_chunk_read() {
        // Relative indices reaching back across chunk ends, CRLF, blank and comment
        // lines, polygons; cut into chunks of 1..=40 bytes.
        let mut src = String::from("# start\r\n");
        for k in 0..30 {
            src += &format!("v {k} {}.5 -{k}e-1\r\n\n", k * 2);
            if k >= 3 {
                src += "f -1 -2 -3\n";
            }
            if k % 7 == 6 {
                src += &format!("f {} {} {} {}\n# c\n", k - 2, k - 1, k, k + 1);
            }
        }
        let whole = parse(&src).unwrap();
        assert_eq!(read_with(src.as_bytes(), usize::MAX, false), Ok(whole));
        assert_same_everywhere(src.as_bytes(), 1..=40);
        // Without the last newline, and with CRLF everywhere.
        assert_same_everywhere(src.trim_end().as_bytes(), 1..=40);
        let crlf = src.replace("\r\n", "\n").replace('\n', "\r\n");
        assert_same_everywhere(crlf.as_bytes(), 1..=40);
        assert_same_everywhere(crlf.trim_end().as_bytes(), 1..=40);
        // The first failing line in file order is reported, whatever the cut.
        let bad = format!("{src}v 1 2 x\nf 1 2 99\n");
        for chunk in [1, 5, 40, usize::MAX] {
            let mut info = ReadInfo::new(crate::io::Format::Obj);
            let e = read_in_chunks(bad.as_bytes(), "t.obj", &mut info, chunk, true).unwrap_err();
            assert!(
                matches!(e, IoError::Parse { ref token, .. } if token == "x"),
                "{e}"
            );
        }
    }

    #[test]
    fn errors_from_a_later_chunk_name_their_line() {
        // 100 vertices on lines 1..=100, then triangles; the bad line is far from the
        // first chunk at every cut.
        let mut src = String::new();
        for k in 0..100 {
            src += &format!("v {k} 0 {}\n", k % 3);
        }
        for k in 1..=98 {
            src += &format!("f {k} {} {}\n", k + 1, k + 2);
        }
        let good = read_with(src.as_bytes(), usize::MAX, false).unwrap();
        assert_eq!(good.0.n_faces(), 98);
        let with_line = |line: &str| format!("{src}# x\n{line}\nf 1 2 3\n");
        let cases = [
            (
                "f 1 2 101",
                "t.obj:200: face index 101 is out of range (100 vertices)",
            ),
            (
                "f 1 -101 2",
                "t.obj:200: face index -101 is out of range (100 vertices)",
            ),
            ("f 1 2 3x", "t.obj:200: cannot parse \"3x\" as a face index"),
            (
                "f 1 2",
                "t.obj:200: cannot parse \"f 1 2\" as a face with at least three vertices",
            ),
            (
                "v 1 2 zz",
                "t.obj:200: cannot parse \"zz\" as a vertex coordinate",
            ),
            (
                "v 1 inf 2",
                "t.obj:200: vertex 100 has a NaN or infinite coordinate",
            ),
        ];
        for (line, message) in cases {
            let src = with_line(line);
            for chunk in [1, 16, 100, 1000, usize::MAX] {
                for scan in [true, false] {
                    assert_eq!(
                        read_with(src.as_bytes(), chunk, scan).unwrap_err(),
                        message,
                        "chunk {chunk}, scan {scan}"
                    );
                }
            }
        }
    }

    #[test]
    fn scanner_agrees_with_the_token_reader_line_by_line() {
        let lines = [
            "v 1 2 3",
            "v 1 2 3 1",
            "v  1\t2\x0c3\r",
            "v 1 2",
            "v 1 2 x",
            "v 1e 2 3",
            "v 1.5e3 -2E-2 +3",
            "v .5 5. 3",
            "v inf 0 0",
            "v nan 0 0",
            "v -infinity 0 0",
            "v 1 2 3x",
            "v 1,5 2 3",
            "v 0x10 1 2",
            "v 1 2 3\x0b",
            "v 1 2 \x0b3",
            "v\t1 2 3",
            "  v 1 2 3",
            "\rv 1 2 3",
            "v 1 2 3\r\r",
            "v 1 2 3 \r",
            "vt 1 2",
            "vn 1 2 3",
            "v",
            "v 1e400 0 0",
            "v 1e-400 0 0",
            "v 0.30000000000000004441 1 2",
            "v 1.00000000000000000000000000000001 2 3",
            "v - 1 2",
            "v +-1 2 3",
            "f 1 2 3",
            "f 1/1 2/2 3/3",
            "f 1//1 2//2 3//3",
            "f 1/2/3 2/x/ 3/",
            "f -1 -2 -3",
            "f +1 +2 +3",
            "f 1 2",
            "f 1 2 3 4 5",
            "f 0 1 2",
            "f 1 2 4",
            "f -4 1 2",
            "f 1x 2 3",
            "f /1 2 3",
            "f 1 2 3 #c",
            "f 01 002 3",
            "f 123456789012345678 1 2",
            "f 1234567890123456789 1 2",
            "f 99999999999999999999 1 2",
            "f -0 1 2",
            "f - 1 2",
            "f\t1\t2\t3",
            "f",
            "ff 1 2 3",
            "# v 1 2 3",
            "g f 1 2 3",
            "f 1 2 3\r",
            "\x0cf 1 2 3",
            "f 1 2 3\x0b",
            "f 1 2 3 ",
            "s 1",
            "v 1 2 3 # x",
            "f 1\r2 3",
        ];
        let prefix = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
        for line in lines {
            for end in ["", "\n", "\r\n", "\nf 1 2 3\n"] {
                let src = format!("{prefix}{line}{end}");
                assert_same_everywhere(src.as_bytes(), [1, 3, 17, 40, usize::MAX]);
            }
        }
    }

    #[test]
    fn scanner_agrees_with_the_token_reader_on_random_files() {
        use rand::{Rng, SeedableRng};
        let words = [
            "v",
            "f",
            "vt",
            "#",
            "1",
            "2",
            "3",
            "-1",
            "-2",
            "+3",
            "0",
            "7",
            "1/1",
            "2//3",
            "-1/2/3",
            "0.5",
            "-1e-3",
            "nan",
            "x",
            "",
            " ",
            "\t",
            "\r",
            "1.",
            ".5",
            "9e99",
            "1e999",
            "12345678901234567890",
            "/",
        ];
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(17);
        for _ in 0..400 {
            let mut src = String::new();
            for _ in 0..rng.gen_range(1..30) {
                let head = ["v", "v", "f", "f", "vt", "#", "", " v", "g"][rng.gen_range(0..9)];
                src += head;
                for _ in 0..rng.gen_range(0..6) {
                    src += [" ", " ", "\t", "  "][rng.gen_range(0..4)];
                    src += words[rng.gen_range(0..words.len())];
                }
                src += ["\n", "\n", "\r\n", "\n\n"][rng.gen_range(0..4)];
            }
            if rng.gen_bool(0.3) {
                src.pop();
            }
            assert_same_everywhere(src.as_bytes(), [1, 9, usize::MAX]);
        }
    }

    #[test]
    fn scanner_agrees_with_the_token_reader_on_the_fuzz_corpus() {
        let dir =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/fuzz/obj");
        let mut n = 0;
        for entry in std::fs::read_dir(dir).unwrap() {
            let src = std::fs::read(entry.unwrap().path()).unwrap();
            assert_same_everywhere(&src, [1, 7, 64, usize::MAX]);
            n += 1;
        }
        assert!(n >= 3);
    }

    #[test]
    fn every_face_form_and_relative_indices() {
        let src = "# c\nv 0 0 0\nv 1 0 0\nv 1 1 0\r\nv 0 1 0 1.0 0.5 0.5 0.5\nvt 0 0\nvn 0 0 1\n\
                   f 1 2 3\nf 1/1 3/1 4/1\nf 1//1 2//1 4//1\nf -4/1/1 -2/1/1 -1/1/1\nf 1 2 3 4\n";
        let (m, info) = parse(src).unwrap();
        assert_eq!(m.n_vertices(), 4);
        assert_eq!(m.faces[3], [0, 2, 3]);
        assert_eq!(m.n_faces(), 6);
        assert_eq!(info.polygons_triangulated, 1);
    }

    #[test]
    fn errors_name_line_and_token() {
        let e = parse("v 0 0 0\nv 1 0 x1\n").unwrap_err().to_string();
        assert_eq!(e, "t.obj:2: cannot parse \"x1\" as a vertex coordinate");
        assert!(matches!(
            parse("v 0 0 0\nf 1 2 3\n"),
            Err(IoError::IndexOutOfRange {
                line: 2,
                index: 2,
                ..
            })
        ));
        assert!(matches!(
            parse("v 0 0 0\nf 0 1 1\n"),
            Err(IoError::IndexOutOfRange { index: 0, .. })
        ));
        assert!(matches!(
            parse("v 0 0 0\nf -2 1 1\n"),
            Err(IoError::IndexOutOfRange { index: -2, .. })
        ));
        assert!(matches!(
            parse("v 0 0 nan\nv 1 1 1\n"),
            Err(IoError::NonFinite {
                line: 1,
                vertex: 0,
                ..
            })
        ));
        assert!(matches!(
            parse("v 0 0\n"),
            Err(IoError::Parse { line: 1, .. })
        ));
    }
}
