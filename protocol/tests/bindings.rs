//! The committed C header and Python module are exactly what `layout` generates from the Rust
//! types: a struct changed in Rust without regenerating them fails here.
//! `SWARMRT_UPDATE_BINDINGS=1 cargo test -p swarmrt-protocol --test bindings` rewrites them.

use std::path::PathBuf;

use swarmrt_protocol::layout;

fn check(rel: &str, want: String) {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join(rel);
    if std::env::var_os("SWARMRT_UPDATE_BINDINGS").is_some() {
        std::fs::write(&path, &want).unwrap();
        return;
    }
    let have = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert!(
        have == want,
        "{rel} is not what swarmrt_protocol::layout generates from the Rust types; \
         regenerate it: SWARMRT_UPDATE_BINDINGS=1 cargo test -p swarmrt-protocol --test bindings"
    );
}

#[test]
fn c_header_is_generated_from_the_rust_types() {
    check("bindings/c/include/swarmrt_messages.h", layout::c_header());
}

#[test]
fn python_module_is_generated_from_the_rust_types() {
    check(
        "bindings/python/swarmrt/_messages.py",
        layout::python_module(),
    );
}
