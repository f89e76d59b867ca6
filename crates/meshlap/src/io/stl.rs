//! STL, ASCII (`solid … facet normal … outer loop vertex x y z …`) and binary (80-byte
//! header, `u32` triangle count, 50 bytes per triangle). A file is binary when its size
//! is exactly `84 + 50·count` (a binary header may itself begin with "solid").
//! Corners with bitwise identical coordinates are welded into one vertex (in order of
//! first appearance) and the merges counted. A file that starts with "solid" but is not
//! pure ASCII is read as (possibly truncated) binary. The writer stores binary STL: `f32`
//! coordinates (a documented precision loss) and per-face normals.

use super::text::{lines, parse_err, parse_num, tokens};
use super::{IoError, ReadInfo};
use crate::mesh::TriMesh;
use std::collections::HashMap;
use std::io::Write;

struct Welder {
    index: HashMap<[u64; 3], u32>,
    positions: Vec<[f64; 3]>,
    corners: usize,
}

impl Welder {
    fn add(&mut self, p: [f64; 3]) -> u32 {
        self.corners += 1;
        let key = p.map(|c| if c == 0.0 { 0 } else { c.to_bits() });
        let next = self.positions.len() as u32;
        let positions = &mut self.positions;
        *self.index.entry(key).or_insert_with(|| {
            positions.push(p);
            next
        })
    }
}

pub(crate) fn read(bytes: &[u8], file: &str, info: &mut ReadInfo) -> Result<TriMesh, IoError> {
    let mut w = Welder {
        index: HashMap::new(),
        positions: Vec::new(),
        corners: 0,
    };
    let mut faces = Vec::new();
    let binary_size = |n: usize| n.checked_mul(50).and_then(|x| x.checked_add(84));
    let is_binary = bytes.len() >= 84 && {
        let n = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as usize;
        binary_size(n) == Some(bytes.len())
    };
    if is_binary {
        let n = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as usize;
        faces.reserve(n);
        for t in 0..n {
            let rec = &bytes[84 + 50 * t..84 + 50 * t + 50];
            let mut f = [0u32; 3];
            for (c, fc) in f.iter_mut().enumerate() {
                let mut p = [0.0f64; 3];
                for (k, pk) in p.iter_mut().enumerate() {
                    let o = 12 + 12 * c + 4 * k;
                    *pk = f32::from_le_bytes([rec[o], rec[o + 1], rec[o + 2], rec[o + 3]]) as f64;
                }
                if !p.iter().all(|x| x.is_finite()) {
                    return Err(IoError::NonFinite {
                        file: file.to_string(),
                        line: 0,
                        vertex: w.corners,
                    });
                }
                *fc = w.add(p);
            }
            faces.push(f);
        }
    } else if bytes.trim_ascii_start().starts_with(b"solid") && bytes.is_ascii() {
        let mut corner = Vec::with_capacity(3);
        for (ln, line) in lines(bytes) {
            let mut t = tokens(line);
            match t.next() {
                Some(b"vertex") => {
                    let mut p = [0.0; 3];
                    for c in &mut p {
                        let tok = t.next().ok_or_else(|| {
                            parse_err(file, ln, line, "a vertex with three coordinates")
                        })?;
                        *c = parse_num::<f64>(tok, file, ln, "a vertex coordinate")?;
                    }
                    if !p.iter().all(|x| x.is_finite()) {
                        return Err(IoError::NonFinite {
                            file: file.to_string(),
                            line: ln,
                            vertex: w.corners,
                        });
                    }
                    corner.push(w.add(p));
                }
                Some(b"endloop") => {
                    if corner.len() < 3 {
                        return Err(parse_err(file, ln, line, "a facet with three vertices"));
                    }
                    super::text::fan(&corner, &mut faces);
                    corner.clear();
                }
                _ => {}
            }
        }
        if !corner.is_empty() {
            return Err(IoError::Truncated {
                file: file.to_string(),
                what: "a facet (no endloop)".into(),
            });
        }
    } else if bytes.len() >= 84 {
        let n = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as usize;
        return Err(IoError::Truncated {
            file: file.to_string(),
            what: format!(
                "binary STL: header announces {n} triangles ({} bytes) but the file has {}",
                binary_size(n).map_or("too many".into(), |s| s.to_string()),
                bytes.len()
            ),
        });
    } else {
        return Err(IoError::Truncated {
            file: file.to_string(),
            what: "the 84-byte binary STL header (and the file does not start with `solid`)".into(),
        });
    }
    info.stl_vertices_welded = w.corners - w.positions.len();
    Ok(TriMesh::new(w.positions, faces))
}

pub(crate) fn write(out: &mut dyn Write, mesh: &TriMesh) -> std::io::Result<()> {
    let mut header = [0u8; 80];
    let tag = b"binary STL written by meshlap";
    header[..tag.len()].copy_from_slice(tag);
    out.write_all(&header)?;
    let n = u32::try_from(mesh.n_faces())
        .map_err(|_| std::io::Error::other("too many faces for STL"))?;
    out.write_all(&n.to_le_bytes())?;
    let (p, f) = (&mesh.positions, &mesh.faces);
    super::encode::write_records(out, f.len(), |r, out| {
        for face in &f[r] {
            let [a, b, c] = face.map(|v| p[v as usize]);
            let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
            let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
            let mut nrm = [
                u[1] * v[2] - u[2] * v[1],
                u[2] * v[0] - u[0] * v[2],
                u[0] * v[1] - u[1] * v[0],
            ];
            let l = (nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2]).sqrt();
            if l > 0.0 {
                nrm = nrm.map(|x| x / l);
            }
            for x in nrm.iter().chain(&a).chain(&b).chain(&c) {
                out.extend_from_slice(&(*x as f32).to_le_bytes());
            }
            out.extend_from_slice(&[0, 0]);
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(b: &[u8]) -> Result<(TriMesh, ReadInfo), IoError> {
        crate::io::read_any(b, crate::io::Format::Stl, "t.stl")
    }

    #[test]
    fn ascii_welds_shared_corners() {
        let src = b"solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nfacet normal 0 0 1\nouter loop\nvertex 1 0 0\nvertex 1 1 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid t\n";
        let (m, info) = parse(src).unwrap();
        assert_eq!((m.n_vertices(), m.n_faces()), (4, 2));
        assert_eq!(info.stl_vertices_welded, 2);
    }

    #[test]
    fn binary_starting_with_solid_and_truncation() {
        let m = crate::mesh::builtin::tetrahedron();
        let mut buf = Vec::new();
        write(&mut buf, &m).unwrap();
        buf[..5].copy_from_slice(b"solid");
        let (back, _) = parse(&buf).unwrap();
        assert_eq!((back.n_vertices(), back.n_faces()), (4, 4));
        assert!(matches!(
            parse(&buf[..buf.len() - 1]),
            Err(IoError::Truncated { .. })
        ));
        assert!(matches!(parse(b"junk"), Err(IoError::Truncated { .. })));
    }
}
