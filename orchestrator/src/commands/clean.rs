//! `swarm clean`: remove the iceoryx2 leftovers of runs whose orchestrator is gone.

use crate::error::SwarmResult;
use swarmrt_ipc::cleanup;

/// Removes dead runs' resources and says what it did.
pub fn clean() -> SwarmResult<()> {
    let (removed, alive) = cleanup::clean_dead_runs();
    for id in &removed {
        println!("removed run {id}");
    }
    println!(
        "{} dead run(s) cleaned, {} live run(s) left alone",
        removed.len(),
        alive.len()
    );
    Ok(())
}
