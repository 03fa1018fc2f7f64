//! The page, embedded in the binary: plain HTML, CSS and JavaScript kept in `assets/`, so
//! building needs no JavaScript toolchain and a viewer never depends on where it was built.

/// `index.html`.
pub const INDEX: &str = include_str!("../assets/index.html");
/// `viewer.js`: the whole page logic (no framework).
pub const SCRIPT: &str = include_str!("../assets/viewer.js");
/// `viewer.css`.
pub const STYLE: &str = include_str!("../assets/viewer.css");
