//! The `.mlz` container: a small, checksummed section file.
//!
//! ```text
//! magic      4 bytes  "MLZ\x1a"
//! version    u16 LE   (9: as 8, but the spectral coder's Lloyd patches take two
//!                     relaxation steps instead of five
//!                     (`partition::PartitionMethod::LLOYD_ITERATIONS_FAST`); 8 and
//!                     older are decoded as they were written;
//!                     8: as 7, but the spectral coder keeps the bases of the
//!                     symmetric operators (Kirchhoff, graph, SQL, SSTL) factored,
//!                     `X = Zᵀ(Qᵀx)`, `x̃ = Q(Z X̃)` (`spectral::FactoredEvd`: no
//!                     back-transformation, no canonicalisation; Tutte keeps the
//!                     explicit basis); 7 and older are decoded as they were written;
//!                     7: as 6, but the spectral coder's patches are Lloyd-relaxed
//!                     graph Voronoi cells (`partition::PartitionMethod::Lloyd`)
//!                     instead of METIS parts, and its predictor is solved through
//!                     the kept Cholesky factor (three right-hand sides); 6, 5 and 4
//!                     are decoded as they were written;
//!                     6: as 5, but the spectral coder's coefficient products and
//!                     inter-patch predictor use fixed-order arithmetic, so files
//!                     encode and decode to the same bits on every CPU (with or
//!                     without AVX2/FMA); 5 and 4 are decoded with faer's kernels,
//!                     as they were written;
//!                     5: the optional re-join section (kind 5) of meshes cut for
//!                     the connectivity coder, see `rejoin`; otherwise as 4, which is
//!                     still read;
//!                     4: patch partition and patch eigenbases changed (METIS with
//!                     one initial partitioning; see `geometry`); 3: a geometry-mode
//!                     byte opens the geometry section; 2 added inter-patch
//!                     prediction; versions before 4 are refused)
//! sections   u16 LE   count (≤ 16)
//! per section:
//!   kind     u8       1 header, 2 connectivity, 3 permutation, 4 geometry,
//!                     5 re-join (version 5 on)
//!   length   u32 LE   payload bytes
//!   crc32    u32 LE   of the kind byte and the payload (IEEE, `crc32fast`)
//!   payload  `length` bytes
//! ```
//!
//! Reading checks every length against the bytes that remain before slicing (so a
//! hostile length cannot cause an allocation or a panic), every checksum, and that no
//! bytes trail the last section. [`ByteReader`] gives bounded little-endian reads of
//! section payloads.

use super::CodecError;

/// File magic.
pub const MAGIC: [u8; 4] = *b"MLZ\x1a";
/// Current format version (what [`write()`] writes).
pub const VERSION: u16 = 9;
/// Oldest format version [`read`] accepts (its files decode as they always did).
pub const MIN_VERSION: u16 = 4;
const MAX_SECTIONS: u16 = 16;

/// Section kinds.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum SectionKind {
    /// Counts and coding parameters.
    Header = 1,
    /// Range-coded connectivity.
    Connectivity = 2,
    /// Input vertex order (optional).
    Permutation = 3,
    /// Range-coded geometry.
    Geometry = 4,
    /// Which vertices of the cut mesh are copies of which (optional; version 5 on).
    Rejoin = 5,
}

impl SectionKind {
    fn from_u8(v: u8) -> Result<Self, CodecError> {
        Ok(match v {
            1 => SectionKind::Header,
            2 => SectionKind::Connectivity,
            3 => SectionKind::Permutation,
            4 => SectionKind::Geometry,
            5 => SectionKind::Rejoin,
            _ => return Err(CodecError::Corrupt("unknown section kind")),
        })
    }
    /// Lower-case name (for messages).
    pub fn name(self) -> &'static str {
        match self {
            SectionKind::Header => "header",
            SectionKind::Connectivity => "connectivity",
            SectionKind::Permutation => "permutation",
            SectionKind::Geometry => "geometry",
            SectionKind::Rejoin => "re-join",
        }
    }
}

/// Serializes sections into a file image.
pub fn write(sections: &[(SectionKind, &[u8])]) -> Result<Vec<u8>, CodecError> {
    if sections.len() > MAX_SECTIONS as usize {
        return Err(CodecError::Internal("too many sections"));
    }
    let total: usize = sections.iter().map(|(_, p)| p.len() + 9).sum::<usize>() + 8;
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(&MAGIC);
    out.extend_from_slice(&VERSION.to_le_bytes());
    out.extend_from_slice(&(sections.len() as u16).to_le_bytes());
    for (kind, payload) in sections {
        let len =
            u32::try_from(payload.len()).map_err(|_| CodecError::SectionTooLarge(payload.len()))?;
        out.push(*kind as u8);
        out.extend_from_slice(&len.to_le_bytes());
        out.extend_from_slice(&checksum(*kind, payload).to_le_bytes());
        out.extend_from_slice(payload);
    }
    Ok(out)
}

/// Parses a file image into its sections (borrowing the payloads), verifying the
/// magic, version ([`MIN_VERSION`] to [`VERSION`]), lengths and checksums.
pub fn read(bytes: &[u8]) -> Result<Vec<(SectionKind, &[u8])>, CodecError> {
    let mut r = ByteReader::new(bytes, "file header");
    let magic = r.take(4)?;
    if magic != MAGIC {
        return Err(CodecError::BadMagic);
    }
    let version = r.u16()?;
    if !(MIN_VERSION..=VERSION).contains(&version) {
        return Err(CodecError::Version {
            found: version,
            oldest: MIN_VERSION,
            newest: VERSION,
        });
    }
    let count = r.u16()?;
    if count > MAX_SECTIONS {
        return Err(CodecError::Corrupt("too many sections"));
    }
    let mut out = Vec::with_capacity(count as usize);
    for _ in 0..count {
        r.what = "section table";
        let kind = SectionKind::from_u8(r.u8()?)?;
        if kind == SectionKind::Rejoin && version < 5 {
            return Err(CodecError::Corrupt("a re-join section in a version 4 file"));
        }
        let len = r.u32()? as usize;
        let crc = r.u32()?;
        r.what = kind.name();
        let payload = r.take(len)?;
        if checksum(kind, payload) != crc {
            return Err(CodecError::Checksum(kind.name()));
        }
        if out.iter().any(|(k, _)| *k == kind) {
            return Err(CodecError::Corrupt("duplicate section"));
        }
        out.push((kind, payload));
    }
    if r.remaining() != 0 {
        return Err(CodecError::Corrupt("bytes after the last section"));
    }
    Ok(out)
}

/// crc32 of the kind byte followed by the payload (so a flipped kind is caught too).
fn checksum(kind: SectionKind, payload: &[u8]) -> u32 {
    let mut h = crc32fast::Hasher::new();
    h.update(&[kind as u8]);
    h.update(payload);
    h.finalize()
}

/// Finds a section; a missing required section is corrupt.
pub fn section<'a>(sections: &[(SectionKind, &'a [u8])], kind: SectionKind) -> Option<&'a [u8]> {
    sections.iter().find(|(k, _)| *k == kind).map(|(_, p)| *p)
}

/// Bounded little-endian reader over a byte slice: every read checks the remaining
/// length and reports [`CodecError::Truncated`] naming what was being read.
#[derive(Debug)]
pub struct ByteReader<'a> {
    data: &'a [u8],
    pos: usize,
    /// What is being read (for error messages).
    pub what: &'static str,
}

impl<'a> ByteReader<'a> {
    /// A reader over `data`.
    pub fn new(data: &'a [u8], what: &'static str) -> Self {
        ByteReader { data, pos: 0, what }
    }
    /// Bytes not read yet.
    pub fn remaining(&self) -> usize {
        self.data.len() - self.pos
    }
    /// The next `n` bytes.
    pub fn take(&mut self, n: usize) -> Result<&'a [u8], CodecError> {
        if n > self.remaining() {
            return Err(CodecError::Truncated(self.what));
        }
        let s = &self.data[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }
    /// The rest of the data.
    pub fn rest(&mut self) -> &'a [u8] {
        let s = &self.data[self.pos..];
        self.pos = self.data.len();
        s
    }
    /// A byte.
    pub fn u8(&mut self) -> Result<u8, CodecError> {
        Ok(self.take(1)?[0])
    }
    /// A `u16`.
    pub fn u16(&mut self) -> Result<u16, CodecError> {
        let b = self.take(2)?;
        Ok(u16::from_le_bytes([b[0], b[1]]))
    }
    /// A `u32`.
    pub fn u32(&mut self) -> Result<u32, CodecError> {
        let b = self.take(4)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }
    /// A flag byte, 0 or 1; any other value is [`CodecError::Corrupt`] with `bad`.
    pub fn flag(&mut self, bad: &'static str) -> Result<bool, CodecError> {
        match self.u8()? {
            0 => Ok(false),
            1 => Ok(true),
            _ => Err(CodecError::Corrupt(bad)),
        }
    }
    /// An `f64`; an error if not finite.
    pub fn f64(&mut self) -> Result<f64, CodecError> {
        let b = self.take(8)?;
        let v = f64::from_le_bytes(b.try_into().expect("8 bytes"));
        if !v.is_finite() {
            return Err(CodecError::Corrupt("non-finite number"));
        }
        Ok(v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn round_trip_and_seeded_corruptions() {
        let a: Vec<u8> = (0..300u32).map(|i| (i * 7) as u8).collect();
        let b = vec![1u8, 2, 3];
        let img = write(&[(SectionKind::Header, &b), (SectionKind::Geometry, &a)]).unwrap();
        let secs = read(&img).unwrap();
        assert_eq!(section(&secs, SectionKind::Geometry), Some(&a[..]));
        assert_eq!(section(&secs, SectionKind::Header), Some(&b[..]));
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        for _ in 0..2000 {
            let mut d = img.clone();
            if rng.gen_bool(0.5) {
                d.truncate(rng.gen_range(0..d.len()));
            } else {
                for _ in 0..rng.gen_range(1..4) {
                    let i = rng.gen_range(0..d.len());
                    d[i] ^= 1 << rng.gen_range(0..8);
                }
            }
            // Every change is detected (crc32 catches ≤ 3 flipped bits in a payload).
            assert!(read(&d).is_err());
        }
        assert!(matches!(read(b"PK\x03\x04...."), Err(CodecError::BadMagic)));
        // Older versions are refused with a message that says what to do.
        let mut old = img.clone();
        old[4..6].copy_from_slice(&3u16.to_le_bytes());
        let e = read(&old).unwrap_err();
        assert!(matches!(e, CodecError::Version { found: 3, .. }));
        assert!(e.to_string().contains("reads versions 4 to 9"), "{e}");
        // Versions 4 and 5 are still read; version 4 without the section version 5
        // added.
        let mut v5 = img.clone();
        v5[4..6].copy_from_slice(&5u16.to_le_bytes());
        assert!(read(&v5).is_ok());
        let mut v4 = img.clone();
        v4[4..6].copy_from_slice(&4u16.to_le_bytes());
        assert!(read(&v4).is_ok());
        let rj = write(&[(SectionKind::Rejoin, &b)]).unwrap();
        assert!(read(&rj).is_ok());
        let mut rj4 = rj.clone();
        rj4[4..6].copy_from_slice(&4u16.to_le_bytes());
        assert!(matches!(read(&rj4), Err(CodecError::Corrupt(_))));
        let mut huge = img[..8].to_vec();
        huge.extend_from_slice(&[1, 0xFF, 0xFF, 0xFF, 0xFF, 0, 0, 0, 0]);
        assert!(matches!(read(&huge), Err(CodecError::Truncated(_))));
    }
}
