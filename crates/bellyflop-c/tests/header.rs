//! The committed header is what cbindgen generates from the crate today:
//! a change to the API that is not regenerated fails here (and in CI).
//! Regenerate with `BLESS=1 cargo test -p bellyflop-c --test header`.

use std::path::Path;

fn generated() -> String {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let config = cbindgen::Config::from_file(dir.join("cbindgen.toml")).expect("cbindgen.toml");
    let bindings = cbindgen::Builder::new()
        .with_config(config)
        .with_src(dir.join("src/lib.rs"))
        .generate()
        .expect("cbindgen generates the header");
    let mut out = Vec::new();
    bindings.write(&mut out);
    String::from_utf8(out).expect("the header is UTF-8")
}

#[test]
fn committed_header_is_current() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("include/bellyflop.h");
    let fresh = generated();
    if std::env::var_os("BLESS").is_some() {
        std::fs::write(&path, &fresh).expect("write the header");
    }
    let committed = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        committed == fresh,
        "{} differs from a fresh cbindgen generation: regenerate it with `BLESS=1 cargo test -p bellyflop-c --test header` and commit it",
        path.display()
    );
}
