//! End-to-end tests of `meshlap watermark embed` and `meshlap watermark detect`.

mod common;
use common::*;
use std::process::Output;

const MSG: &str = "0123456789abcdef";

fn tmp(name: &str) -> String {
    let dir = std::env::temp_dir().join(format!("meshlap-wm-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name).display().to_string()
}

/// `meshlap watermark embed MESH -o OUT --key KEY --message MESSAGE EXTRA…`.
fn embed(mesh: &str, out: &str, key: &str, message: &str, extra: &[&str]) -> Output {
    let mut a = vec![
        "watermark",
        "embed",
        mesh,
        "-o",
        out,
        "--key",
        key,
        "--message",
        message,
    ];
    a.extend_from_slice(extra);
    meshlap(&a)
}

/// `meshlap watermark detect SUSPECT --original ORIGINAL --key KEY EXTRA…`.
fn detect(suspect: &str, original: &str, key: &str, extra: &[&str]) -> Output {
    let mut a = vec![
        "watermark",
        "detect",
        suspect,
        "--original",
        original,
        "--key",
        key,
    ];
    a.extend_from_slice(extra);
    meshlap(&a)
}

#[test]
fn embed_then_detect_recovers_the_message_with_the_documented_keys() {
    let cow = data("cow.obj");
    let out = tmp("cow-marked.obj");
    let e = json(&embed(&cow, &out, "0x2a", MSG, &["--json"]));
    for key in [
        "bits",
        "patches",
        "coefficients_per_bit",
        "mrms",
        "max_displacement",
        "msdm2",
        "seconds",
    ] {
        assert!(e.get(key).is_some(), "embed JSON lacks {key}");
    }
    assert_eq!(e["bits"], 64);
    assert!(e["mrms"].as_f64().unwrap() <= 1.5e-4);
    let d = json(&detect(&out, &cow, "42", &["--expect", MSG, "--json"]));
    for key in [
        "message",
        "bits",
        "correlations",
        "false_positive_probability",
        "registration",
        "resampled",
        "bit_errors",
        "ber",
        "seconds",
    ] {
        assert!(d.get(key).is_some(), "detect JSON lacks {key}");
    }
    for key in ["scale", "rotation_degrees", "translation", "rms_residual"] {
        assert!(
            d["registration"].get(key).is_some(),
            "registration lacks {key}"
        );
    }
    assert_eq!(d["message"], MSG);
    assert_eq!(d["bit_errors"], 0);
    assert_eq!(d["bits"].as_array().unwrap().len(), 64);
    assert_eq!(d["resampled"], false);
    assert!(d["false_positive_probability"].as_f64().unwrap() <= 1e-6);
    // A wrong key: no message, a probability above the threshold.
    let w = json(&detect(&out, &cow, "43", &["--json"]));
    assert!(w["message"].is_null());
    assert!(w["false_positive_probability"].as_f64().unwrap() > 1e-6);
    let text = detect(&out, &cow, "43", &[]);
    assert!(String::from_utf8_lossy(&text.stdout).contains("no watermark found"));
    // Every weighting finds the mark; an unknown one is a usage error.
    for w in ["auto", "patch", "patch-axis"] {
        let d = json(&detect(
            &out,
            &cow,
            "42",
            &["--expect", MSG, "--weighting", w, "--json"],
        ));
        assert_eq!(d["bit_errors"], 0, "{w}");
    }
    assert_eq!(
        detect(&out, &cow, "42", &["--weighting", "axis"])
            .status
            .code(),
        Some(2)
    );
    // --no-msdm2: the metric is skipped.
    let e = json(&embed(&cow, &out, "0x2a", MSG, &["--no-msdm2", "--json"]));
    assert!(e["msdm2"].is_null());
}

#[test]
fn bad_input_gives_one_line_errors() {
    let out = tmp("bad.obj");
    assert_one_line_error(
        &embed("builtin:icosphere:3", &out, "1", "12xz", &[]),
        "non-hex",
    );
    assert_one_line_error(
        &embed("builtin:tetrahedron", &out, "1", MSG, &[]),
        "coefficient slots",
    );
    assert_one_line_error(
        &detect("builtin:torus:30:15", "builtin:icosphere:3", "1", &[]),
        "does not match",
    );
    assert_eq!(
        embed("builtin:icosphere:3", &out, "x", MSG, &[])
            .status
            .code(),
        Some(2)
    );
    assert_eq!(
        embed(
            "builtin:icosphere:3",
            &out,
            "1",
            MSG,
            &["--operator", "cotan"]
        )
        .status
        .code(),
        Some(2)
    );
}
