//! Golden `.mlz` files (`tests/data/mlz/`, see the README there): each decodes to the
//! mesh whose hash `decoded.sha256` records, bit for bit. This pins the format: the
//! decoder re-runs METIS, the probe hashing and the dense eigensolver, so a dependency
//! upgrade that changed the bases would otherwise break every existing file unnoticed.

use meshlap::TriMesh;
use sha2::{Digest, Sha256};

fn dir() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/mlz")
}

/// sha256 of the vertex bits (`f64` LE, x y z per vertex) followed by the faces (`u32`
/// LE, three per face).
fn mesh_hash(m: &TriMesh) -> String {
    let mut h = Sha256::new();
    for p in &m.positions {
        for x in p {
            h.update(x.to_le_bytes());
        }
    }
    for f in &m.faces {
        for v in f {
            h.update(v.to_le_bytes());
        }
    }
    h.finalize().iter().map(|b| format!("{b:02x}")).collect()
}

/// (file, vertices, faces, hash) of every golden file.
fn manifest() -> Vec<(String, usize, usize, String)> {
    let text = std::fs::read_to_string(dir().join("decoded.sha256")).unwrap();
    text.lines()
        .map(|l| {
            let w: Vec<&str> = l.split_whitespace().collect();
            assert_eq!(w.len(), 4, "manifest line {l:?}");
            (
                w[0].to_string(),
                w[1].parse().unwrap(),
                w[2].parse().unwrap(),
                w[3].to_string(),
            )
        })
        .collect()
}

#[test]
fn golden_files_decode_bit_for_bit() {
    let files = manifest();
    // Every geometry mode and both vertex orders are covered.
    assert!(files.len() >= 9);
    for (mode, order) in [
        ("spectral", false),
        ("spectral", true),
        ("spatial", false),
        ("spatial", true),
    ] {
        assert!(
            files
                .iter()
                .any(|(f, ..)| f.contains(mode) && f.ends_with("-po.mlz") == order),
            "no golden file for {mode}, preserved order {order}"
        );
    }
    let mut with_rejoin = 0;
    let mut per_version = [0usize; 10];
    for (file, n, nf, hash) in &files {
        let bytes = std::fs::read(dir().join(file)).unwrap();
        // Version 4 files never have a re-join section; the non-manifold ones (v5 on)
        // do. Version 6 on, files are named `v6-…`, `v7-…`, `v8-…`, `v9-…`.
        let version = u16::from_le_bytes([bytes[4], bytes[5]]);
        let prefix = format!("v{version}-");
        assert_eq!(
            version >= 6,
            file.starts_with(&prefix),
            "{file} (version {version})"
        );
        per_version[usize::from(version.min(9))] += 1;
        let secs = meshlap::codec::container::read(&bytes).unwrap();
        let rejoin = meshlap::codec::container::section(
            &secs,
            meshlap::codec::container::SectionKind::Rejoin,
        );
        let non_manifold = ["nm-", "suzanne-", "beetle-"]
            .iter()
            .any(|p| file.get(3..).is_some_and(|f| f.starts_with(p)) || file.starts_with(p));
        assert_eq!(
            rejoin.is_some(),
            version >= 5 && non_manifold,
            "{file} (version {version})"
        );
        with_rejoin += usize::from(rejoin.is_some());
        let m = meshlap::codec::decompress(&bytes).unwrap_or_else(|e| panic!("{file}: {e}"));
        assert_eq!((m.n_vertices(), m.n_faces()), (*n, *nf), "{file}");
        assert_eq!(&mesh_hash(&m), hash, "{file} decodes differently");
    }
    assert!(
        with_rejoin >= 3,
        "golden files of non-manifold meshes (version 5)"
    );
    // Every version still read has golden files (versions 6 on: spectral files whose
    // decoded bits are the same on every CPU; version 7 partitions by Lloyd cells and
    // predicts through the kept Cholesky factor; version 8 keeps the symmetric
    // operators' bases factored, one file per such operator; version 9 relaxes the
    // Lloyd cells two steps instead of five).
    assert!(
        per_version[4] >= 9
            && per_version[5] >= 4
            && per_version[6] >= 3
            && per_version[7] >= 4
            && per_version[8] >= 6
            && per_version[9] >= 5
    );
}

#[test]
fn a_changed_golden_file_is_noticed() {
    // The comparison above can fail: the lowest mantissa bit of the quantization
    // step, flipped under a recomputed checksum, moves the decoded coordinates in
    // their last bits only, and the hash notices. (`write` writes the current
    // version, so the file is one of the current version's.)
    use meshlap::codec::container::{read, section, write, SectionKind};
    let (file, .., hash) = manifest()
        .into_iter()
        .find(|(f, ..)| f == "v9-torus-spectral-sql-po.mlz")
        .unwrap();
    let bytes = std::fs::read(dir().join(&file)).unwrap();
    let secs = read(&bytes).unwrap();
    let mut geo = section(&secs, SectionKind::Geometry).unwrap().to_vec();
    // Mode byte, operator, patch size (u32), coefficient rule (u8 + f64), then the
    // step (f64 LE): its lowest byte is byte 15.
    geo[15] ^= 1;
    let forged: Vec<(SectionKind, &[u8])> = secs
        .iter()
        .map(|&(k, p)| {
            (
                k,
                if k == SectionKind::Geometry {
                    &geo[..]
                } else {
                    p
                },
            )
        })
        .collect();
    let forged = write(&forged).unwrap();
    let m = meshlap::codec::decompress(&forged).unwrap();
    assert_eq!(m.faces, meshlap::codec::decompress(&bytes).unwrap().faces);
    assert_ne!(mesh_hash(&m), hash);
}
