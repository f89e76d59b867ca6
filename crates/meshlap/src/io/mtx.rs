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
        writeln!(
            w,
            "% written by meshlap (an operator's sign convention: F = D - W)"
        )?;
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

/// Column pointers a Matrix Market file may make the reader allocate beyond
/// [`COLUMNS_PER_BYTE`] per byte of the file (256 KiB of pointers).
const FREE_COLUMNS: usize = 1 << 15;

/// Column pointers (8 bytes each) allowed per byte of a Matrix Market file: the
/// readers' memory bound, 64 bytes per byte present (`tests/hostile_alloc.rs`).
const COLUMNS_PER_BYTE: usize = 8;

/// Reads a Matrix Market coordinate real (general or symmetric) file into an
/// `nrows × ncols` compressed-column matrix (a symmetric file's entries mirrored).
///
/// # Errors
/// [`IoError`] for a file that cannot be read, a malformed banner, size line or entry,
/// an index out of range, or too few entries. The matrix has one column pointer per
/// column whatever the entries, so a size line declaring more columns than
/// `8 · (file bytes) + 32,768` is [`IoError::Unsupported`] (such a file's columns are
/// almost all empty; without the limit a 60-byte file could commit gigabytes): the
/// reader's memory stays within a small multiple of the file, as every reader's does.
/// faer's error ([`IoError::Matrix`]) when the matrix cannot be allocated.
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
    let max_cols = bytes
        .len()
        .saturating_mul(COLUMNS_PER_BYTE)
        .saturating_add(FREE_COLUMNS);
    if nc > max_cols {
        return Err(IoError::Unsupported {
            file,
            message: format!(
                "{nc} columns in a {}-byte file (at most {max_cols}: the matrix stores one \
                 pointer per column, and columns beyond that are almost all empty)",
                bytes.len()
            ),
        });
    }
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

    /// Writes `text` to a scratch `.mtx` file and reads it back.
    fn read_text(text: &str) -> Result<SparseMatrix, IoError> {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("m.mtx");
        std::fs::write(&p, text).unwrap();
        read_matrix_market(&p)
    }

    #[test]
    fn columns_beyond_the_file_are_refused_before_allocating() {
        // A fuzz finding: 99,567,296 columns in a 117-byte file took 0.8 GB and ~1 s.
        for nc in ["99567296", "100000000000"] {
            let text =
                format!("%%MatrixMarket matrix coordinate real general\n3 {nc} 1\n1 1 2.0\n");
            match read_text(&text) {
                Err(IoError::Unsupported { message, .. }) => {
                    assert!(
                        message.starts_with(&format!("{nc} columns in a")),
                        "{message}"
                    )
                }
                other => panic!("{nc} columns: {other:?}"),
            }
        }
        // At the limit: 8 per byte of the file plus 32,768 columns, all empty but one.
        let head = "%%MatrixMarket matrix coordinate real general\n3 ";
        let tail = " 1\n1 1 2.0\n";
        let len = head.len() + tail.len() + 5;
        let at = len * COLUMNS_PER_BYTE + FREE_COLUMNS;
        assert_eq!(at.to_string().len(), 5);
        let m = read_text(&format!("{head}{at}{tail}")).unwrap();
        assert_eq!((m.nrows(), m.ncols(), m.compute_nnz()), (3, at, 1));
        assert!(matches!(
            read_text(&format!("{head}{}{tail}", at + 1)),
            Err(IoError::Unsupported { .. })
        ));
        // Rows cost nothing: a tall matrix of 10^12 rows reads.
        let m = read_text(
            "%%MatrixMarket matrix coordinate real general\n1000000000000 3 1\n7 2 1.5\n",
        )
        .unwrap();
        assert_eq!(m.nrows(), 1_000_000_000_000);
    }
}
