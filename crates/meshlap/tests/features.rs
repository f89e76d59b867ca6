//! The picture layer is optional: plotters, png, the font and the glyph rasterizer are
//! optional dependencies pulled in only by the `pictures` feature (implied by
//! `experiments`); the CLI enables `experiments`. `cargo build -p meshlap
//! --no-default-features` then compiles none of them.

fn manifest(path: &str) -> String {
    std::fs::read_to_string(format!("{}/{path}", env!("CARGO_MANIFEST_DIR"))).unwrap()
}

fn line<'a>(toml: &'a str, key: &str) -> &'a str {
    toml.lines()
        .find(|l| l.starts_with(&format!("{key} =")))
        .unwrap_or_else(|| panic!("no `{key} =` line"))
}

#[test]
fn picture_dependencies_are_optional_and_behind_the_pictures_feature() {
    let toml = manifest("Cargo.toml");
    let pictures = line(&toml, "pictures");
    for dep in [
        "plotters",
        "plotters-backend",
        "ab_glyph",
        "epaint_default_fonts",
        "png",
    ] {
        assert!(line(&toml, dep).contains("optional = true"), "{dep}");
        assert!(pictures.contains(&format!("\"dep:{dep}\"")), "{pictures}");
    }
    assert!(line(&toml, "experiments").contains("\"pictures\""));
    assert!(line(&toml, "default").contains("\"experiments\""));
    let cli = manifest("../meshlap-cli/Cargo.toml");
    assert!(line(&cli, "meshlap").contains("\"experiments\""));
}

/// With the default features the picture modules are there.
#[cfg(feature = "experiments")]
#[test]
fn default_build_has_the_picture_layer() {
    let mesh = meshlap::mesh::builtin::icosahedron();
    let opts = meshlap::render::RenderOptions {
        width: 32,
        height: 32,
        ..Default::default()
    };
    assert_eq!(
        meshlap::render::render(&mesh, &opts).unwrap().rgb.len(),
        32 * 32 * 3
    );
    assert!(meshlap::experiment::claims::ClaimsOptions::quick().steps > 0);
}
