//! Where `swarm` finds the binaries it starts (`swarm-world`, `swarm-agent`, `swarm-host`,
//! `swarm-bench`): beside its own executable.

use std::path::PathBuf;

use anyhow::{Context, bail};

/// Finds `swarm-world` / `swarm-agent` beside the running executable.
pub fn sibling_binary(name: &str) -> anyhow::Result<PathBuf> {
    let exe = std::env::current_exe().context("cannot locate the swarm executable")?;
    let dir = exe.parent().context("executable has no directory")?;
    let p = dir.join(name);
    if p.exists() {
        return Ok(p);
    }
    // `cargo test` runs from target/<profile>/deps/.
    if let Some(up) = dir.parent() {
        let p = up.join(name);
        if p.exists() {
            return Ok(p);
        }
    }
    bail!(
        "cannot find {name} beside {}; build the whole workspace (cargo build --release)",
        exe.display()
    )
}
