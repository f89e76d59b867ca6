//! Wavefront OBJ: `v x y z [w] [r g b]` and `f` in every form (`i`, `i/t`, `i//n`,
//! `i/t/n`), with negative (relative) indices; polygons are fan-triangulated. Every
//! other statement (`vt`, `vn`, `o`, `g`, `s`, `usemtl`, `mtllib`, `l`, comments) is
//! ignored. Lines may end in CRLF.

use super::text::{fan, parse_err, parse_f64, tokens};
use super::{IoError, ReadInfo};
use crate::mesh::TriMesh;
use rayon::prelude::*;
use std::io::Write;

/// Bytes per chunk below which a file is read on one thread.
const CHUNK_BYTES: usize = 1 << 20;

/// Reads an OBJ file held in `bytes`.
///
/// The file is cut at line ends into chunks that are parsed in parallel (rayon). A
/// first pass counts each chunk's lines and `v` statements, so the second knows the
/// global line number and the number of vertices defined before every line: a face
/// index refers to a vertex defined above it (relative indices count back from the
/// last one), exactly as in a sequential read. Errors are those of the first failing
/// line in file order. Coordinates are parsed with `fast-float2` (correctly rounded,
/// like `str::parse`, which still handles the rare tokens it declines, such as `nan`).
pub(crate) fn read(bytes: &[u8], file: &str, info: &mut ReadInfo) -> Result<TriMesh, IoError> {
    read_in_chunks(bytes, file, info, CHUNK_BYTES)
}

/// [`read`] with chunks of at least `min_chunk` bytes (tests cut small files finely).
fn read_in_chunks(
    bytes: &[u8],
    file: &str,
    info: &mut ReadInfo,
    min_chunk: usize,
) -> Result<TriMesh, IoError> {
    let chunks = split_lines(bytes, rayon::current_num_threads() * 4, min_chunk);
    let counts: Vec<(usize, usize)> = chunks.par_iter().map(|c| count_lines(c)).collect();
    let mut first_line = Vec::with_capacity(chunks.len());
    let mut first_vertex = Vec::with_capacity(chunks.len());
    let (mut lines, mut verts) = (1usize, 0usize);
    for &(l, v) in &counts {
        first_line.push(lines);
        first_vertex.push(verts);
        lines += l;
        verts += v;
    }
    let mut positions = vec![[0.0f64; 3]; verts];
    let mut slots: Vec<&mut [[f64; 3]]> = Vec::with_capacity(chunks.len());
    let mut rest = positions.as_mut_slice();
    for &(_, v) in &counts {
        let (head, tail) = rest.split_at_mut(v);
        slots.push(head);
        rest = tail;
    }
    let parsed: Vec<Result<Chunk, IoError>> = chunks
        .par_iter()
        .zip(slots)
        .enumerate()
        .map(|(k, (text, out))| parse_chunk(text, file, first_line[k], first_vertex[k], out))
        .collect();
    let mut faces = Vec::new();
    for chunk in parsed {
        let chunk = chunk?;
        if faces.is_empty() {
            faces = chunk.faces;
        } else {
            faces.extend_from_slice(&chunk.faces);
        }
        info.polygons_triangulated += chunk.polygons;
    }
    Ok(TriMesh::new(positions, faces))
}

/// What one chunk of lines produced.
struct Chunk {
    faces: Vec<[u32; 3]>,
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

/// Lines of a chunk (each ended by `\n`, or by the chunk's end), without `\r\n`'s `\r`.
fn chunk_lines(text: &[u8]) -> impl Iterator<Item = &[u8]> {
    let body = text.strip_suffix(b"\n").unwrap_or(text);
    let mut start = 0;
    let ends = memchr::memchr_iter(b'\n', body).chain(std::iter::once(body.len()));
    ends.map(move |end| {
        let line = &body[start..end];
        start = end + 1;
        line.strip_suffix(b"\r").unwrap_or(line)
    })
}

/// `(lines, vertex statements)` of a chunk. A chunk that ends without a newline (the
/// file's last) still has its last line counted, as the sequential reader does.
fn count_lines(text: &[u8]) -> (usize, usize) {
    let body = text.strip_suffix(b"\n").unwrap_or(text);
    let mut lines = 1;
    let mut verts = usize::from(is_vertex_line(body));
    for p in memchr::memchr_iter(b'\n', body) {
        lines += 1;
        verts += usize::from(is_vertex_line(&body[p + 1..]));
    }
    (lines, verts)
}

/// Whether the line starting at `rest[0]` is a `v` statement (its first token is `v`).
fn is_vertex_line(rest: &[u8]) -> bool {
    let t = match rest.first() {
        Some(b'v') => rest,
        Some(b) if b.is_ascii_whitespace() && *b != b'\n' => {
            let end = memchr::memchr(b'\n', rest).unwrap_or(rest.len());
            rest[..end].trim_ascii_start()
        }
        _ => return false,
    };
    t.first() == Some(&b'v') && t.get(1).is_none_or(|b| b.is_ascii_whitespace())
}

/// Parses one chunk whose first line is `first_line` and before which `first_vertex`
/// vertices were defined, writing its vertices into `out` (sized by [`count_lines`]).
fn parse_chunk(
    text: &[u8],
    file: &str,
    first_line: usize,
    first_vertex: usize,
    out: &mut [[f64; 3]],
) -> Result<Chunk, IoError> {
    let mut faces = Vec::with_capacity(text.len() / 24);
    let mut polygons = 0;
    let mut poly: Vec<u32> = Vec::with_capacity(8);
    let mut n = first_vertex;
    let mut local = 0usize;
    for (k, line) in chunk_lines(text).enumerate() {
        let ln = first_line + k;
        let mut toks = tokens(line);
        let Some(head) = toks.next() else { continue };
        match head {
            b"v" => {
                let p = &mut out[local];
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
                        vertex: n,
                    });
                }
                local += 1;
                n += 1;
            }
            b"f" => {
                poly.clear();
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
                    poly.push(resolved as u32);
                }
                if poly.len() < 3 {
                    return Err(parse_err(
                        file,
                        ln,
                        line,
                        "a face with at least three vertices",
                    ));
                }
                if fan(&poly, &mut faces) {
                    polygons += 1;
                }
            }
            _ => {}
        }
    }
    Ok(Chunk { faces, polygons })
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
    // `{:?}` prints the shortest representation that reads back to the same f64.
    for p in &mesh.positions {
        writeln!(w, "v {:?} {:?} {:?}", p[0], p[1], p[2])?;
    }
    for f in &mesh.faces {
        writeln!(w, "f {} {} {}", f[0] + 1, f[1] + 1, f[2] + 1)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(s: &str) -> Result<(TriMesh, ReadInfo), IoError> {
        crate::io::read_any(s.as_bytes(), crate::io::Format::Obj, "t.obj")
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
        for chunk in 1..=40 {
            let mut info = ReadInfo::new(crate::io::Format::Obj);
            let m = read_in_chunks(src.as_bytes(), "t.obj", &mut info, chunk).unwrap();
            assert_eq!(m, whole.0, "chunk {chunk}");
            assert_eq!(info, whole.1, "chunk {chunk}");
        }
        // The first failing line in file order is reported, whatever the cut.
        let bad = format!("{src}v 1 2 x\nf 1 2 99\n");
        for chunk in [1, 5, 40, usize::MAX] {
            let mut info = ReadInfo::new(crate::io::Format::Obj);
            let e = read_in_chunks(bad.as_bytes(), "t.obj", &mut info, chunk).unwrap_err();
            assert!(
                matches!(e, IoError::Parse { ref token, .. } if token == "x"),
                "{e}"
            );
        }
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
