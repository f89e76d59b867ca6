//! Matrix Market coordinate files (`%%MatrixMarket matrix coordinate real general`),
//! 1-based, every value in the shortest decimal form that reads back to the same `f64`,
//! so `scipy.io.mmread` and our reader recover the matrix exactly.

use super::text::{lines, parse_err, parse_num, tokens};
use super::{write_atomic, IoError};
use crate::SparseMatrix;
use faer::sparse::{SparseColMatRef, Triplet};
use std::path::Path;

/// Writes `m` atomically as a Matrix Market coordinate real general file.
pub fn write_matrix_market(path: &Path, m: SparseColMatRef<'_, usize, f64>) -> Result<(), IoError> {
    write_atomic(path, |w| {
        writeln!(w, "%%MatrixMarket matrix coordinate real general")?;
        writeln!(w, "% written by meshlap (sign convention F = D - W)")?;
        writeln!(w, "{} {} {}", m.nrows(), m.ncols(), m.compute_nnz())?;
        // One record per column: its entries' lines.
        super::encode::write_records(w, m.ncols(), |cols, out| {
            let mut t = super::encode::Text::new();
            for j in cols {
                for (&i, &v) in m.row_idx_of_col_raw(j).iter().zip(m.val_of_col(j)) {
                    t.int(out, i + 1);
                    out.push(b' ');
                    t.int(out, j + 1);
                    out.push(b' ');
                    t.float(out, v);
                    out.push(b'\n');
                }
            }
        })
    })
}

/// Reads a Matrix Market coordinate real (general or symmetric) file.
pub fn read_matrix_market(path: &Path) -> Result<SparseMatrix, IoError> {
    let file = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|source| IoError::Open {
        path: path.to_path_buf(),
        source,
    })?;
    let mut it = lines(&bytes);
    let (_, banner) = it
        .next()
        .ok_or_else(|| IoError::Empty { file: file.clone() })?;
    let banner = String::from_utf8_lossy(banner).to_ascii_lowercase();
    if !banner.starts_with("%%matrixmarket matrix coordinate real") {
        return Err(IoError::Header {
            file,
            message: "expected `%%MatrixMarket matrix coordinate real …`".into(),
        });
    }
    let symmetric = banner.contains("symmetric");
    let mut it = it.filter(|(_, l)| !l.starts_with(b"%") && tokens(l).next().is_some());
    let (ln, size) = it.next().ok_or_else(|| IoError::Truncated {
        file: file.clone(),
        what: "the size line".into(),
    })?;
    let t: Vec<&[u8]> = tokens(size).collect();
    if t.len() != 3 {
        return Err(parse_err(&file, ln, size, "`rows cols nnz`"));
    }
    let (nr, nc, nnz) = (
        parse_num::<usize>(t[0], &file, ln, "a row count")?,
        parse_num::<usize>(t[1], &file, ln, "a column count")?,
        parse_num::<usize>(t[2], &file, ln, "an entry count")?,
    );
    let mut trip = Vec::with_capacity(nnz.min(bytes.len() / 6));
    for _ in 0..nnz {
        let (ln, l) = it.next().ok_or_else(|| IoError::Truncated {
            file: file.clone(),
            what: "matrix entries".into(),
        })?;
        let t: Vec<&[u8]> = tokens(l).collect();
        if t.len() < 3 {
            return Err(parse_err(&file, ln, l, "`row col value`"));
        }
        let i = parse_num::<usize>(t[0], &file, ln, "a row index")?;
        let j = parse_num::<usize>(t[1], &file, ln, "a column index")?;
        if i == 0 || j == 0 || i > nr || j > nc {
            return Err(parse_err(&file, ln, l, "an in-range 1-based index pair"));
        }
        let v = parse_num::<f64>(t[2], &file, ln, "a value")?;
        trip.push(Triplet::new(i - 1, j - 1, v));
        if symmetric && i != j {
            trip.push(Triplet::new(j - 1, i - 1, v));
        }
    }
    SparseMatrix::try_new_from_triplets(nr, nc, &trip)
        .map_err(|source| IoError::Matrix { file, source })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{builtin, topology::Topology};

    #[test]
    fn round_trip_is_exact() {
        let m = builtin::cube(2).unwrap();
        let t = Topology::new(&m).unwrap();
        let s = crate::operator::sstl::sstl(&t).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("s.mtx");
        write_matrix_market(&p, s.as_ref()).unwrap();
        let back = read_matrix_market(&p).unwrap();
        assert_eq!(back.to_dense(), s.to_dense());
    }
}
