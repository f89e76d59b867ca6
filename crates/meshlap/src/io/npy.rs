//! NumPy `.npy` arrays for dense matrices, through the `npyz` crate (the maintained
//! reader/writer of the format; meshlap keeps only the shape rules and the checks).
//!
//! - [`write_npy`] stores an n×k matrix as a little-endian float64 array in Fortran
//!   order (faer's column-major layout), so `numpy.load` gives an (n, k) `float64`
//!   array.
//! - [`read_npy`] reads 1-D arrays (as n×1) and 2-D arrays in C or Fortran order, of
//!   any real numeric dtype (`f8`, `f4`, signed and unsigned integers of 1–8 bytes,
//!   `bool`, either byte order), converted to `f64`. The data length the header
//!   announces is checked against the bytes present before anything is allocated.

use super::{write_atomic, IoError};
use faer::{Mat, MatRef};
use npyz::{DType, NpyFile, Order, TypeChar, WriterBuilder};
use std::path::Path;

/// Writes `data` (n×k) as a little-endian float64 `.npy` array of shape (n, k) in
/// Fortran order, atomically (a temporary file renamed over `path`).
pub fn write_npy(path: &Path, data: MatRef<'_, f64>) -> Result<(), IoError> {
    write_atomic(path, |w| {
        let mut out = npyz::WriteOptions::new()
            .default_dtype()
            .shape(&[data.nrows() as u64, data.ncols() as u64])
            .order(Order::Fortran)
            .writer(w)
            .begin_nd()?;
        for j in 0..data.ncols() {
            for i in 0..data.nrows() {
                out.push(&data[(i, j)])?;
            }
        }
        out.finish()
    })
}

/// Reads a 1-D (as n×1) or 2-D `.npy` array of a real numeric dtype as an `f64`
/// matrix. Errors: [`IoError::Open`] (the file), [`IoError::Header`] (not an `.npy`
/// file, or a shape of another rank), [`IoError::Unsupported`] (a dtype that is not a
/// real number: complex, strings, records, dates), [`IoError::Truncated`] (fewer data
/// bytes than the shape announces).
pub fn read_npy(path: &Path) -> Result<Mat<f64>, IoError> {
    let file = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|source| IoError::Open {
        path: path.to_path_buf(),
        source,
    })?;
    let header_error = |message: String| IoError::Header {
        file: file.clone(),
        message,
    };
    // npyz allocates the header length the file announces (up to 4 GiB in versions 2
    // and 3) before reading it: check it against the bytes present first (found by
    // the `npy` fuzz target).
    if bytes.starts_with(b"\x93NUMPY") && bytes.len() >= 12 {
        let header_end = data_offset(&bytes);
        if header_end > bytes.len() as u64 {
            return Err(IoError::Truncated {
                file,
                what: format!("a header of {header_end} bytes"),
            });
        }
        // npyz parses the header's dict literal with backtracking that takes time
        // exponential in the depth of nested `{`/`[` (21 levels: hours; found by the
        // `npy` fuzz target). A NumPy header nests at most a few levels (dict, a
        // structured dtype's list and tuples, the shape tuple).
        let start = if bytes[6] == 1 { 10 } else { 12 };
        let depth = nesting_depth(&bytes[start..header_end as usize]);
        if depth > MAX_HEADER_NESTING {
            return Err(header_error(format!(
                "brackets nested {depth} deep in the header (an array header nests at most \
                 {MAX_HEADER_NESTING})"
            )));
        }
    }
    let npy = NpyFile::new(&bytes[..]).map_err(|e| header_error(e.to_string()))?;
    let (n, k) = match *npy.shape() {
        [n] => (n, 1),
        [n, k] => (n, k),
        _ => {
            return Err(header_error(format!(
                "shape {:?}: only 1-D and 2-D arrays are supported",
                npy.shape()
            )))
        }
    };
    let unsupported = || IoError::Unsupported {
        file: file.clone(),
        message: format!(
            "dtype `{}`: only real numbers (float, int, uint, bool) are supported",
            npy.dtype().descr()
        ),
    };
    let ty = match npy.dtype() {
        DType::Plain(ty) => ty,
        _ => return Err(unsupported()),
    };
    let size = ty.num_bytes().ok_or_else(unsupported)? as u64;
    let count = n
        .checked_mul(k)
        .and_then(|c| usize::try_from(c).ok())
        .ok_or_else(|| header_error(format!("shape ({n}, {k}) overflows")))?;
    let data_len = (bytes.len() as u64).saturating_sub(data_offset(&bytes));
    if (count as u64).saturating_mul(size) > data_len {
        return Err(IoError::Truncated {
            file,
            what: format!("{count} values of dtype `{}`", npy.dtype().descr()),
        });
    }
    let order = npy.order();
    let truncated = |_: std::io::Error| IoError::Truncated {
        file: file.clone(),
        what: format!("{count} values"),
    };
    let values: Vec<f64> = match (ty.type_char(), size) {
        (TypeChar::Float, 8) => npy.into_vec::<f64>().map_err(truncated)?,
        (TypeChar::Float, 4) => widen(npy.into_vec::<f32>(), truncated)?,
        (TypeChar::Int, 8) => widen(npy.into_vec::<i64>(), truncated)?,
        (TypeChar::Int, 4) => widen(npy.into_vec::<i32>(), truncated)?,
        (TypeChar::Int, 2) => widen(npy.into_vec::<i16>(), truncated)?,
        (TypeChar::Int, 1) => widen(npy.into_vec::<i8>(), truncated)?,
        (TypeChar::Uint, 8) => widen(npy.into_vec::<u64>(), truncated)?,
        (TypeChar::Uint, 4) => widen(npy.into_vec::<u32>(), truncated)?,
        (TypeChar::Uint, 2) => widen(npy.into_vec::<u16>(), truncated)?,
        (TypeChar::Uint, 1) => widen(npy.into_vec::<u8>(), truncated)?,
        (TypeChar::Bool, 1) => widen(npy.into_vec::<bool>(), truncated)?,
        _ => return Err(unsupported()),
    };
    let (n, k) = (n as usize, k as usize);
    Ok(Mat::from_fn(n, k, |i, j| match order {
        Order::Fortran => values[j * n + i],
        Order::C => values[i * k + j],
    }))
}

/// Byte offset of the array data: magic (6) + version (2) + header length (2 bytes for
/// version 1, 4 for versions 2 and 3) + the header text. Only called on at least 12
/// bytes that start with the magic, so the fields exist.
/// Deepest nesting of brackets a header may have: `{'descr': [('f', '<f8', (3,))],
/// 'shape': (2,)}` nests 4 deep.
const MAX_HEADER_NESTING: usize = 6;

/// The deepest nesting of `{`, `[` and `(` in `header` (quotes ignored: a bracket in a
/// field name counts too, which only refuses structured dtypes, unsupported anyway).
fn nesting_depth(header: &[u8]) -> usize {
    let (mut depth, mut deepest) = (0usize, 0usize);
    for &b in header {
        match b {
            b'{' | b'[' | b'(' => {
                depth += 1;
                deepest = deepest.max(depth);
            }
            b'}' | b']' | b')' => depth = depth.saturating_sub(1),
            _ => {}
        }
    }
    deepest
}

fn data_offset(bytes: &[u8]) -> u64 {
    match bytes.get(6) {
        Some(1) => 10 + u16::from_le_bytes([bytes[8], bytes[9]]) as u64,
        _ => 12 + u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as u64,
    }
}

/// Converts a vector of numbers read by `npyz` to `f64`.
fn widen<T: ToF64>(
    values: std::io::Result<Vec<T>>,
    err: impl Fn(std::io::Error) -> IoError,
) -> Result<Vec<f64>, IoError> {
    Ok(values.map_err(err)?.into_iter().map(T::to_f64).collect())
}

/// Lossless (up to f64 rounding of 64-bit integers) conversion to `f64`.
trait ToF64 {
    fn to_f64(self) -> f64;
}

macro_rules! to_f64 {
    ($($t:ty),*) => {$(
        impl ToF64 for $t {
            fn to_f64(self) -> f64 {
                self as f64
            }
        }
    )*};
}
to_f64!(f32, i64, i32, i16, i8, u64, u32, u16, u8);

impl ToF64 for bool {
    fn to_f64(self) -> f64 {
        f64::from(u8::from(self))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A version-1 `.npy` file written by hand (the format's reference layout), so the
    /// reader is checked against bytes numpy would write, not only against our writer.
    fn handmade(descr: &str, fortran: bool, shape: &str, data: &[u8]) -> Vec<u8> {
        let dict = format!(
            "{{'descr': '{descr}', 'fortran_order': {}, 'shape': {shape}, }}",
            if fortran { "True" } else { "False" }
        );
        let unpadded = 10 + dict.len() + 1;
        let pad = (64 - unpadded % 64) % 64;
        let header = format!("{dict}{}\n", " ".repeat(pad));
        let mut out = b"\x93NUMPY\x01\x00".to_vec();
        out.extend_from_slice(&(header.len() as u16).to_le_bytes());
        out.extend_from_slice(header.as_bytes());
        out.extend_from_slice(data);
        out
    }

    fn read_bytes(bytes: &[u8]) -> Result<Mat<f64>, IoError> {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.npy");
        std::fs::write(&p, bytes).unwrap();
        read_npy(&p)
    }

    #[test]
    fn round_trip_and_numpy_layout() {
        let m = Mat::from_fn(5, 3, |i, j| (i * 3 + j) as f64 * 0.1 - 0.7);
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("m.npy");
        write_npy(&p, m.as_ref()).unwrap();
        let bytes = std::fs::read(&p).unwrap();
        // Header padded to a multiple of 64 bytes, then 15 float64 values, column-major.
        assert_eq!((bytes.len() - 15 * 8) % 64, 0);
        let text = String::from_utf8_lossy(&bytes[10..bytes.len() - 120]);
        assert!(text.contains("'descr': '<f8'"), "{text}");
        assert!(text.contains("'fortran_order': True"), "{text}");
        assert!(text.contains("'shape': (5, 3"), "{text}");
        let first = f64::from_le_bytes(bytes[bytes.len() - 120..][..8].try_into().unwrap());
        let second = f64::from_le_bytes(bytes[bytes.len() - 112..][..8].try_into().unwrap());
        assert_eq!((first, second), (m[(0, 0)], m[(1, 0)]));
        assert_eq!(read_npy(&p).unwrap(), m);
    }

    #[test]
    fn reads_c_order_other_dtypes_and_1d() {
        let c: Vec<u8> = [1.5f32, 2.0, -3.0, 4.0, 5.0, 6.25]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        let m = read_bytes(&handmade("<f4", false, "(2, 3)", &c)).unwrap();
        assert_eq!((m.nrows(), m.ncols()), (2, 3));
        assert_eq!((m[(0, 1)], m[(1, 0)], m[(1, 2)]), (2.0, 4.0, 6.25));
        let ints: Vec<u8> = [7i32, -8, 9].iter().flat_map(|v| v.to_le_bytes()).collect();
        let v = read_bytes(&handmade("<i4", false, "(3,)", &ints)).unwrap();
        assert_eq!((v.nrows(), v.ncols()), (3, 1));
        assert_eq!((v[(0, 0)], v[(1, 0)], v[(2, 0)]), (7.0, -8.0, 9.0));
        let big: Vec<u8> = [1.0f64, -2.0]
            .iter()
            .flat_map(|v| v.to_be_bytes())
            .collect();
        let b = read_bytes(&handmade(">f8", false, "(2,)", &big)).unwrap();
        assert_eq!((b[(0, 0)], b[(1, 0)]), (1.0, -2.0));
    }

    #[test]
    fn bad_files_are_typed_errors() {
        assert!(matches!(
            read_bytes(b"not numpy at all"),
            Err(IoError::Header { .. })
        ));
        // The shape announces far more data than present: refused before allocating.
        let huge = handmade("<f8", false, "(4000000000, 4000000000)", &[0; 16]);
        assert!(matches!(read_bytes(&huge), Err(IoError::Truncated { .. })));
        let short = handmade("<f8", false, "(3,)", &[0; 16]);
        assert!(matches!(read_bytes(&short), Err(IoError::Truncated { .. })));
        let complex = handmade("<c16", false, "(1,)", &[0; 16]);
        assert!(matches!(
            read_bytes(&complex),
            Err(IoError::Unsupported { .. })
        ));
        // A version-2 header announcing 1.6 GB in a 24-byte file: refused before
        // anything is allocated (the fuzz target's out-of-memory finding).
        let mut hostile = b"\x93NUMPY\x02\x00".to_vec();
        hostile.extend_from_slice(&1_694_498_932u32.to_le_bytes());
        hostile.extend_from_slice(b"{'descr': '|u1'");
        assert!(matches!(
            read_bytes(&hostile),
            Err(IoError::Truncated { .. })
        ));
        // Brackets nested deeper than any array header: refused at once instead of
        // npyz's exponential backtracking (the fuzz target's timeout finding, whose
        // input is in tests/data/fuzz/npy/).
        let nested = handmade(
            "<f8",
            false,
            &format!("{}3,{}", "[".repeat(21), "]".repeat(21)),
            &[0; 8],
        );
        let t = std::time::Instant::now();
        assert!(matches!(read_bytes(&nested), Err(IoError::Header { .. })));
        assert!(t.elapsed().as_secs_f64() < 0.5);
        let ok = handmade("<f8", false, "(1,)", &[0; 8]);
        assert_eq!(nesting_depth(&ok[10..]), 2);
        let rank3 = handmade("<f8", false, "(1, 1, 1)", &[0; 8]);
        assert!(matches!(read_bytes(&rank3), Err(IoError::Header { .. })));
        assert!(matches!(
            read_npy(Path::new("/nonexistent/x.npy")),
            Err(IoError::Open { .. })
        ));
    }
}
