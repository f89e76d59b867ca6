//! NumPy `.npy` (format 1.0) for dense `f64` matrices: `write_npy` stores an n×k
//! float64 array in Fortran order (faer's column-major layout, no copy);
//! `read_npy` reads float64 arrays in either order (1-D arrays as n×1).

use super::{write_atomic, IoError};
use faer::{Mat, MatRef};
use std::path::Path;

/// Writes `data` as an n×k little-endian float64 `.npy` (Fortran order), atomically.
pub fn write_npy(path: &Path, data: MatRef<'_, f64>) -> Result<(), IoError> {
    write_atomic(path, |w| {
        let dict = format!(
            "{{'descr': '<f8', 'fortran_order': True, 'shape': ({}, {}), }}",
            data.nrows(),
            data.ncols()
        );
        // magic (6) + version (2) + header length (2) + dict + padding + '\n' ≡ 0 mod 64
        let unpadded = 10 + dict.len() + 1;
        let pad = (64 - unpadded % 64) % 64;
        let header = format!("{dict}{}\n", " ".repeat(pad));
        w.write_all(b"\x93NUMPY\x01\x00")?;
        w.write_all(&(header.len() as u16).to_le_bytes())?;
        w.write_all(header.as_bytes())?;
        for j in 0..data.ncols() {
            for i in 0..data.nrows() {
                w.write_all(&data[(i, j)].to_le_bytes())?;
            }
        }
        Ok(())
    })
}

/// Reads a little-endian float64 `.npy` array (1-D or 2-D, C or Fortran order).
pub fn read_npy(path: &Path) -> Result<Mat<f64>, IoError> {
    let file = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|source| IoError::Open {
        path: path.to_path_buf(),
        source,
    })?;
    let bad = |m: &str| IoError::Header {
        file: file.clone(),
        message: m.to_string(),
    };
    if bytes.len() < 10 || &bytes[..6] != b"\x93NUMPY" {
        return Err(bad("not an .npy file"));
    }
    let (hlen, start): (usize, usize) = match bytes[6] {
        1 => (u16::from_le_bytes([bytes[8], bytes[9]]) as usize, 10),
        2 | 3 if bytes.len() >= 12 => (
            u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize,
            12,
        ),
        _ => return Err(bad("unsupported .npy version")),
    };
    let header = bytes
        .get(start..start.saturating_add(hlen))
        .ok_or_else(|| bad("header runs past the end"))?;
    let header = String::from_utf8_lossy(header);
    if !header.contains("'descr': '<f8'") {
        return Err(IoError::Unsupported {
            file: file.clone(),
            message: "only little-endian float64 arrays are supported".into(),
        });
    }
    let fortran = header.contains("'fortran_order': True");
    let shape_txt = header
        .split("'shape': (")
        .nth(1)
        .and_then(|s| s.split(')').next())
        .ok_or_else(|| bad("no shape"))?;
    let dims: Vec<usize> = shape_txt
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| s.parse().map_err(|_| bad("bad shape")))
        .collect::<Result<_, _>>()?;
    let (n, k) = match dims.as_slice() {
        [n] => (*n, 1),
        [n, k] => (*n, *k),
        _ => return Err(bad("only 1-D and 2-D arrays are supported")),
    };
    let data = &bytes[start + hlen..];
    let count = n.checked_mul(k).ok_or_else(|| bad("shape overflows"))?;
    if data.len() < count.saturating_mul(8) {
        return Err(IoError::Truncated {
            file,
            what: format!("{count} float64 values"),
        });
    }
    let at = |p: usize| {
        let b = &data[8 * p..8 * p + 8];
        f64::from_le_bytes([b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]])
    };
    Ok(Mat::from_fn(n, k, |i, j| {
        if fortran {
            at(j * n + i)
        } else {
            at(i * k + j)
        }
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip() {
        let m = Mat::from_fn(5, 3, |i, j| (i * 3 + j) as f64 * 0.1 - 0.7);
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("m.npy");
        write_npy(&p, m.as_ref()).unwrap();
        let bytes = std::fs::read(&p).unwrap();
        assert_eq!((bytes.len() - 15 * 8) % 64, 0);
        assert_eq!(read_npy(&p).unwrap(), m);
    }
}
