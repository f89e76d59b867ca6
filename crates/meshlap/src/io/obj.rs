//! Wavefront OBJ: `v x y z [w] [r g b]` and `f` in every form (`i`, `i/t`, `i//n`,
//! `i/t/n`), with negative (relative) indices; polygons are fan-triangulated. Every
//! other statement (`vt`, `vn`, `o`, `g`, `s`, `usemtl`, `mtllib`, `l`, comments) is
//! ignored. Lines may end in CRLF.

use super::text::{check_finite, fan, lines, parse_err, parse_num, tokens};
use super::{IoError, ReadInfo};
use crate::mesh::TriMesh;
use std::io::Write;

pub(crate) fn read(bytes: &[u8], file: &str, info: &mut ReadInfo) -> Result<TriMesh, IoError> {
    let mut positions: Vec<[f64; 3]> = Vec::new();
    let mut vertex_lines: Vec<u32> = Vec::new();
    let mut faces: Vec<[u32; 3]> = Vec::new();
    let mut poly: Vec<u32> = Vec::with_capacity(8);
    for (ln, line) in lines(bytes) {
        let mut toks = tokens(line);
        let Some(head) = toks.next() else { continue };
        match head {
            b"v" => {
                let mut p = [0.0; 3];
                for c in &mut p {
                    let t = toks.next().ok_or_else(|| {
                        parse_err(file, ln, line, "a vertex with three coordinates")
                    })?;
                    *c = parse_num::<f64>(t, file, ln, "a vertex coordinate")?;
                }
                positions.push(p);
                vertex_lines.push(ln as u32);
            }
            b"f" => {
                poly.clear();
                let n = positions.len() as i64;
                for t in toks {
                    let idx_tok = t.split(|&b| b == b'/').next().unwrap_or(t);
                    let i = parse_num::<i64>(idx_tok, file, ln, "a face index")?;
                    let resolved = if i > 0 { i - 1 } else { n + i };
                    if i == 0 || resolved < 0 || resolved >= n {
                        return Err(IoError::IndexOutOfRange {
                            file: file.to_string(),
                            line: ln,
                            index: i,
                            vertices: positions.len(),
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
                    info.polygons_triangulated += 1;
                }
            }
            _ => {}
        }
    }
    check_finite(&positions, file, |v| vertex_lines[v] as usize)?;
    Ok(TriMesh::new(positions, faces))
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
