//! Resources, interruption and determinism of the `meshlap` binary (issue 16; see
//! RELIABILITY.md):
//!
//! - hostile headers (a PLY announcing 10¹² vertices, an OFF, a binary STL and an
//!   `.mlz` announcing more than their bytes hold) fail with the one-line error while
//!   the process runs under an address-space limit (`RLIMIT_AS`) far below what the
//!   announced counts would need, and a real mesh still loads under the same limit;
//! - a `convert` killed with SIGKILL in the middle of writing leaves nothing at the
//!   output path (and an existing file there untouched);
//! - `.mlz` bytes and decoded meshes are identical for 1, 2 and 3 threads.

mod common;
use common::*;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Address-space limit of the child in the memory tests: the binary, its thread
/// stacks and malloc arenas fit; any allocation sized by a hostile count does not.
#[cfg(target_os = "linux")]
const ADDRESS_SPACE: u64 = 384 << 20;

/// Runs the binary with one worker thread under [`ADDRESS_SPACE`].
#[cfg(target_os = "linux")]
fn meshlap_limited(args: &[&str]) -> Output {
    use std::os::unix::process::CommandExt;
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_meshlap"));
    cmd.arg("--threads").arg("1").args(args);
    // SAFETY: only async-signal-safe calls (setrlimit) between fork and exec.
    unsafe {
        cmd.pre_exec(|| {
            let lim = libc::rlimit {
                rlim_cur: ADDRESS_SPACE,
                rlim_max: ADDRESS_SPACE,
            };
            if libc::setrlimit(libc::RLIMIT_AS, &lim) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        });
    }
    cmd.output().expect("run meshlap")
}

/// Hostile files: (name, bytes). Each announces far more than its bytes can hold.
fn hostile_files() -> Vec<(&'static str, Vec<u8>)> {
    let ply = b"ply\nformat binary_little_endian 1.0\nelement vertex 1000000000000\n\
property float x\nproperty float y\nproperty float z\nelement face 1000000000000\n\
property list uchar int vertex_indices\nend_header\n"
        .iter()
        .copied()
        .chain([0u8; 64])
        .collect();
    let ply_list = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\n\
property float x\nproperty float y\nproperty float z\nelement face 1\n\
property list uint int vertex_indices\nend_header\n"
        .iter()
        .copied()
        .chain([0u8; 36])
        .chain(u32::MAX.to_le_bytes())
        .chain([0u8; 16])
        .collect();
    let off = b"OFF\n100000000 100000000 0\n0 0 0\n".to_vec();
    // A binary STL whose count says 2^32 − 1 triangles (the size does not match, so
    // it is read as truncated binary or refused).
    let mut stl = vec![0u8; 80];
    stl.extend_from_slice(&u32::MAX.to_le_bytes());
    stl.extend_from_slice(&[0u8; 100]);
    vec![
        ("huge.ply", ply),
        ("huge_list.ply", ply_list),
        ("huge.off", off),
        ("huge.stl", stl),
    ]
}

/// An `.mlz` whose header announces 2^32 − 1 vertices and faces over a tiny
/// connectivity section, with valid checksums (so only the count checks stand
/// between the header and the allocations).
fn hostile_mlz() -> Vec<u8> {
    use meshlap::codec::container::{write, SectionKind};
    let mut header = Vec::new();
    header.extend_from_slice(&u32::MAX.to_le_bytes());
    header.extend_from_slice(&u32::MAX.to_le_bytes());
    header.extend_from_slice(&[0u8; 32]);
    write(&[
        (SectionKind::Header, &header),
        (SectionKind::Connectivity, &[0xff; 64]),
        (SectionKind::Geometry, &[0x11; 64]),
    ])
    .unwrap()
}

#[cfg(target_os = "linux")]
#[test]
fn hostile_headers_fail_cleanly_under_an_address_space_limit() {
    // The control: a real mesh loads (and is analysed) under the same limit, so the
    // limit is not what makes the hostile files fail.
    let ok = meshlap_limited(&["info", &data("cow.obj")]);
    assert!(ok.status.success(), "{ok:?}");
    let dir = tempfile::tempdir().unwrap();
    for (name, bytes) in hostile_files() {
        let p = dir.path().join(name);
        std::fs::write(&p, &bytes).unwrap();
        let out = meshlap_limited(&["info", p.to_str().unwrap()]);
        // Exit 1 with one line: not an abort on a failed allocation (SIGABRT) nor a
        // kill.
        assert_one_line_error(&out, name);
    }
    let mlz = dir.path().join("huge.mlz");
    std::fs::write(&mlz, hostile_mlz()).unwrap();
    let target = dir.path().join("out.obj");
    let out = meshlap_limited(&[
        "decompress",
        mlz.to_str().unwrap(),
        "-o",
        target.to_str().unwrap(),
    ]);
    assert_one_line_error(&out, "");
    assert!(!target.exists());
}

/// Entries of `dir` (names).
fn entries(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect()
}

/// Starts `meshlap convert builtin:icosphere:8 OUT` (1.3 million faces, ~80 MB of
/// OBJ), waits until the temporary file has data, kills the process with SIGKILL.
/// Returns the temporary file's name.
fn kill_convert_mid_write(dir: &Path, out: &Path) -> String {
    let mut child = Command::new(env!("CARGO_BIN_EXE_meshlap"))
        .args(["convert", "builtin:icosphere:8", out.to_str().unwrap()])
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let start = std::time::Instant::now();
    loop {
        let tmp = entries(dir)
            .into_iter()
            .find(|n| n.starts_with(".meshlap-"));
        if let Some(tmp) = tmp {
            if std::fs::metadata(dir.join(&tmp)).is_ok_and(|m| m.len() > 0) {
                child.kill().unwrap(); // SIGKILL
                child.wait().unwrap();
                return tmp;
            }
        }
        if let Some(status) = child.try_wait().unwrap() {
            panic!("convert ended ({status}) before it could be killed mid-write");
        }
        assert!(
            start.elapsed().as_secs() < 600,
            "no temporary file appeared"
        );
        std::thread::sleep(std::time::Duration::from_millis(1));
    }
}

#[test]
fn a_killed_write_leaves_nothing_at_the_output_path() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("big.obj");
    let tmp = kill_convert_mid_write(dir.path(), &out);
    assert!(!out.exists(), "a partial file is at the output path");
    // What a SIGKILL leaves is the hidden temporary file, never the output name.
    assert!(
        tmp.starts_with(".meshlap-") && tmp.ends_with(".tmp"),
        "{tmp}"
    );
    // An existing output is left untouched.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("big.obj");
    std::fs::write(&out, b"previous content").unwrap();
    kill_convert_mid_write(dir.path(), &out);
    assert_eq!(std::fs::read(&out).unwrap(), b"previous content");
}

/// Runs `meshlap --threads t ARGS`, asserting success.
fn with_threads(t: usize, args: &[&str]) -> Output {
    let t = t.to_string();
    let mut all = vec!["--threads", t.as_str()];
    all.extend_from_slice(args);
    let out = meshlap(&all);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

#[test]
fn mlz_bytes_and_decoded_meshes_do_not_depend_on_threads() {
    let dir = tempfile::tempdir().unwrap();
    let cases: [(&str, &[&str]); 3] = [
        (
            "spectral",
            &[
                "builtin:icosphere:3",
                "--mode",
                "spectral",
                "--patch-size",
                "120",
            ],
        ),
        ("spatial", &["builtin:torus:24:16", "--mode", "spatial"]),
        (
            "auto",
            &[
                "builtin:torus:30:20",
                "--patch-size",
                "150",
                "--preserve-order",
            ],
        ),
    ];
    for (name, args) in cases {
        let mut files: Vec<(Vec<u8>, Vec<u8>)> = Vec::new();
        for t in 1..=3 {
            let mlz: PathBuf = dir.path().join(format!("{name}-{t}.mlz"));
            let ply = dir.path().join(format!("{name}-{t}.ply"));
            let mut a = vec!["compress"];
            a.extend_from_slice(args);
            a.extend_from_slice(&["-o", mlz.to_str().unwrap()]);
            with_threads(t, &a);
            // Decode each file with a different thread count than it was coded with.
            let d = (t % 3) + 1;
            with_threads(
                d,
                &[
                    "decompress",
                    mlz.to_str().unwrap(),
                    "-o",
                    ply.to_str().unwrap(),
                ],
            );
            files.push((std::fs::read(&mlz).unwrap(), std::fs::read(&ply).unwrap()));
        }
        for (t, f) in files.iter().enumerate().skip(1) {
            assert!(
                f.0 == files[0].0,
                "{name}: .mlz bytes differ for {} threads",
                t + 1
            );
            assert!(
                f.1 == files[0].1,
                "{name}: decoded mesh differs for {} threads",
                t + 1
            );
        }
    }
}
