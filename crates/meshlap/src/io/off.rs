//! Object File Format: an `OFF` header (also `COFF`, `NOFF`, `STOFF`, … variants),
//! the counts `nv nf ne` (on the header line or the next), `nv` vertex lines (the first
//! three numbers are the position; colours, normals or texture coordinates after them
//! are ignored) and `nf` polygon lines `k i_1 … i_k [colour]`, fan-triangulated.
//! Comments (`#` to the end of a line) and blank lines are allowed anywhere. Binary OFF
//! is not supported.

use super::text::{check_finite, fan, lines, parse_err, parse_num, tokens};
use super::{IoError, ReadInfo};
use crate::mesh::TriMesh;
use std::io::Write;

pub(crate) fn read(bytes: &[u8], file: &str, info: &mut ReadInfo) -> Result<TriMesh, IoError> {
    let header_err = |message: String| IoError::Header {
        file: file.to_string(),
        message,
    };
    let mut it = lines(bytes)
        .map(|(n, l)| (n, l.split(|&b| b == b'#').next().unwrap_or(l)))
        .filter(|(_, l)| tokens(l).next().is_some());
    let (hl, header) = it.next().ok_or_else(|| header_err("empty file".into()))?;
    let mut htoks = tokens(header);
    let magic = htoks.next().unwrap_or(b"");
    if !magic.ends_with(b"OFF") {
        return Err(header_err(format!(
            "expected OFF on line {hl}, found \"{}\"",
            super::text::show(magic)
        )));
    }
    let mut counts: Vec<&[u8]> = htoks.collect();
    if counts.first() == Some(&&b"BINARY"[..]) {
        return Err(IoError::Unsupported {
            file: file.to_string(),
            message: "binary OFF".into(),
        });
    }
    let mut cl = hl;
    if counts.is_empty() {
        let (n, l) = it
            .next()
            .ok_or_else(|| header_err("missing vertex and face counts".into()))?;
        counts = tokens(l).collect();
        cl = n;
    }
    if counts.len() < 2 {
        return Err(header_err(format!("line {cl}: expected `nv nf ne`")));
    }
    let nv = parse_num::<usize>(counts[0], file, cl, "a vertex count")?;
    let nf = parse_num::<usize>(counts[1], file, cl, "a face count")?;
    // Every vertex needs at least 6 bytes ("0 0 0\n"), every face 8: cap reservations.
    let cap = bytes.len() / 6;
    if nv > cap || nf > bytes.len() / 8 {
        return Err(header_err(format!(
            "{nv} vertices and {nf} faces cannot fit in {} bytes",
            bytes.len()
        )));
    }
    let mut positions = Vec::with_capacity(nv);
    let mut vertex_lines = Vec::with_capacity(nv);
    for k in 0..nv {
        let (ln, l) = it.next().ok_or_else(|| IoError::Truncated {
            file: file.to_string(),
            what: format!("vertex {k} of {nv}"),
        })?;
        let mut t = tokens(l);
        let mut p = [0.0; 3];
        for c in &mut p {
            let tok = t
                .next()
                .ok_or_else(|| parse_err(file, ln, l, "a vertex with three coordinates"))?;
            *c = parse_num::<f64>(tok, file, ln, "a vertex coordinate")?;
        }
        positions.push(p);
        vertex_lines.push(ln);
    }
    check_finite(&positions, file, |v| vertex_lines[v])?;
    let mut faces = Vec::with_capacity(nf);
    let mut poly = Vec::new();
    for k in 0..nf {
        let (ln, l) = it.next().ok_or_else(|| IoError::Truncated {
            file: file.to_string(),
            what: format!("face {k} of {nf}"),
        })?;
        let mut t = tokens(l);
        let first = t.next().unwrap_or(b"");
        let count = parse_num::<usize>(first, file, ln, "a polygon size")?;
        if count < 3 {
            return Err(parse_err(file, ln, first, "a polygon size of at least 3"));
        }
        poly.clear();
        for _ in 0..count {
            let tok = t.next().ok_or_else(|| {
                parse_err(file, ln, l, "a polygon with as many indices as its size")
            })?;
            let i = super::text::parse_num::<i64>(tok, file, ln, "a vertex index")?;
            if i < 0 || i as usize >= nv {
                return Err(IoError::IndexOutOfRange {
                    file: file.to_string(),
                    line: ln,
                    index: i,
                    vertices: nv,
                });
            }
            poly.push(i as u32);
        }
        if fan(&poly, &mut faces) {
            info.polygons_triangulated += 1;
        }
    }
    Ok(TriMesh::new(positions, faces))
}

pub(crate) fn write(w: &mut dyn Write, mesh: &TriMesh) -> std::io::Result<()> {
    writeln!(w, "OFF")?;
    writeln!(w, "{} {} 0", mesh.n_vertices(), mesh.n_faces())?;
    // `x y z` and 0-based `3 a b c` lines.
    super::encode::write_text_lines(w, mesh, b"", b"3 ", 0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(s: &str) -> Result<(TriMesh, ReadInfo), IoError> {
        crate::io::read_any(s.as_bytes(), crate::io::Format::Off, "t.off")
    }

    #[test]
    fn comments_colours_and_polygons() {
        let (m, info) = parse("# hi\nCOFF\n\n4 2 0 # counts\n0 0 0 255 0 0 255\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3 1 1 1\n3 0 1 2\n").unwrap();
        assert_eq!((m.n_vertices(), m.n_faces()), (4, 3));
        assert_eq!(info.polygons_triangulated, 1);
        let (m, _) = parse("OFF 3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n").unwrap();
        assert_eq!(m.n_faces(), 1);
    }

    #[test]
    fn errors() {
        assert!(matches!(parse("PLY\n"), Err(IoError::Header { .. })));
        assert!(matches!(
            parse("OFF\n3 1 0\n0 0 0\n1 0 0\n"),
            Err(IoError::Truncated { .. })
        ));
        assert!(matches!(
            parse("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 5\n"),
            Err(IoError::IndexOutOfRange {
                line: 6,
                index: 5,
                ..
            })
        ));
        assert!(matches!(
            parse("OFF\n1000000000000 1 0\n"),
            Err(IoError::Header { .. })
        ));
        assert!(matches!(
            parse("OFF\n3 1 0\n0 0 0\n1 inf 0\n0 1 0\n3 0 1 2\n"),
            Err(IoError::NonFinite {
                vertex: 1,
                line: 4,
                ..
            })
        ));
    }
}
