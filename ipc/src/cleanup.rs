//! Removing a run's iceoryx2 files and shared-memory segments, on every exit path, for
//! `swarm clean` and for `swarm-host` on a remote host. Every run lives under its own root
//! directory and shm prefix, so removal is exact: nothing of another run, or of other
//! iceoryx2 users, is touched.

use std::path::Path;
use swarmrt_protocol::services::{
    IPC_BASE_DIR, LEGACY_IPC_BASE_DIR, SHM_DIR, ipc_root_of, shm_prefix_of, valid_run_id,
};

/// File in a run's iceoryx2 root holding the orchestrator's pid.
pub const OWNER_FILE: &str = "swarmrt-owner.pid";

/// Start time of a process in clock ticks since boot (field 22 of `/proc/<pid>/stat`): with
/// the pid it names a process uniquely, so a recycled pid is not mistaken for the owner.
fn start_time(pid: i32) -> Option<u64> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    let (_, rest) = stat.rsplit_once(')')?;
    // After the command name come fields 3, 4, ...; field 22 is the 20th of those.
    rest.split_whitespace().nth(19)?.parse().ok()
}

/// Marks `run_id` as owned by this process, so `swarm clean` leaves it alone while it lives.
/// The root appears atomically (built aside, then renamed) with its owner file inside, so a
/// concurrent `swarm clean` never sees an unowned root of a live run.
pub fn claim(run_id: &str) -> std::io::Result<()> {
    let pid = std::process::id();
    let base = Path::new(IPC_BASE_DIR);
    std::fs::create_dir_all(base)?;
    let aside = base.join(format!(".claim-{run_id}-{pid}"));
    std::fs::create_dir(&aside)?;
    let owner = format!("{pid} {}", start_time(pid as i32).unwrap_or(0));
    std::fs::write(aside.join(OWNER_FILE), owner)?;
    std::fs::rename(&aside, ipc_root_of(run_id))
}

/// True when the owner recorded as "pid start-time" is still that very process.
fn owner_alive(owner: &str) -> bool {
    let mut it = owner.split_whitespace();
    let Some(pid) = it.next().and_then(|p| p.parse::<i32>().ok()) else {
        return false;
    };
    let recorded = it.next().and_then(|t| t.parse::<u64>().ok()).unwrap_or(0);
    match start_time(pid) {
        Some(now) => recorded == 0 || now == recorded,
        None => pid_alive(pid),
    }
}

/// Removes everything of `run_id`; returns how many files and directories were removed.
pub fn remove_run(run_id: &str) -> usize {
    let mut removed = 0;
    let root = ipc_root_of(run_id);
    if root.exists() {
        removed += count_entries(&root);
        if let Err(e) = std::fs::remove_dir_all(&root) {
            tracing::warn!("cannot remove {}: {e}", root.display());
        }
    }
    let prefix = shm_prefix_of(run_id);
    if let Ok(entries) = std::fs::read_dir(SHM_DIR) {
        for e in entries.flatten() {
            if e.file_name().to_string_lossy().starts_with(&prefix)
                && std::fs::remove_file(e.path()).is_ok()
            {
                removed += 1;
            }
        }
    }
    removed
}

fn count_entries(dir: &Path) -> usize {
    let mut n = 1;
    if let Ok(entries) = std::fs::read_dir(dir) {
        for e in entries.flatten() {
            let p = e.path();
            n += if p.is_dir() { count_entries(&p) } else { 1 };
        }
    }
    n
}

/// Files of `run_id` still present (in its root and in /dev/shm); empty after a clean exit.
pub fn leftovers(run_id: &str) -> Vec<String> {
    let mut found = Vec::new();
    let root = ipc_root_of(run_id);
    if root.exists() {
        found.push(root.display().to_string());
    }
    let prefix = shm_prefix_of(run_id);
    if let Ok(entries) = std::fs::read_dir(SHM_DIR) {
        for e in entries.flatten() {
            if e.file_name().to_string_lossy().starts_with(&prefix) {
                found.push(e.path().display().to_string());
            }
        }
    }
    found
}

fn pid_alive(pid: i32) -> bool {
    // Signal 0 checks existence; EPERM still means the process exists.
    pid > 0
        && (unsafe { libc::kill(pid, 0) } == 0
            || std::io::Error::last_os_error().raw_os_error() == Some(libc::EPERM))
}

/// `swarm clean`: removes every run whose owning orchestrator is no longer alive.
/// Returns (runs removed, runs left because their orchestrator still runs).
pub fn clean_dead_runs() -> (Vec<String>, Vec<String>) {
    let mut removed = Vec::new();
    let mut alive = Vec::new();
    let mut run_ids: Vec<String> = Vec::new();
    if let Ok(entries) = std::fs::read_dir(IPC_BASE_DIR) {
        for e in entries.flatten() {
            let name = e.file_name().to_string_lossy().to_string();
            if name.starts_with(".claim-") {
                // A claim whose orchestrator died before renaming it into place.
                let owner = std::fs::read_to_string(e.path().join(OWNER_FILE)).unwrap_or_default();
                if !owner_alive(&owner) {
                    let _ = std::fs::remove_dir_all(e.path());
                }
                continue;
            }
            run_ids.push(name);
        }
    }
    // Shared memory of a run whose root directory is already gone.
    if let Ok(entries) = std::fs::read_dir(SHM_DIR) {
        for e in entries.flatten() {
            let name = e.file_name().to_string_lossy().to_string();
            if let Some(rest) = name.strip_prefix("swarmrt_")
                && let Some((id, _)) = rest.split_once('_')
                && !run_ids.iter().any(|r| r == id)
            {
                run_ids.push(id.to_string());
            }
        }
    }
    // Roots left under the old base directory by earlier builds.
    if let Ok(entries) = std::fs::read_dir(LEGACY_IPC_BASE_DIR) {
        for e in entries.flatten() {
            let name = e.file_name().to_string_lossy().to_string();
            let owner = std::fs::read_to_string(e.path().join(OWNER_FILE)).unwrap_or_default();
            if (valid_run_id(&name) || name.starts_with(".claim-")) && !owner_alive(&owner) {
                let _ = std::fs::remove_dir_all(e.path());
                if valid_run_id(&name) && !run_ids.contains(&name) {
                    run_ids.push(name);
                }
            }
        }
    }
    run_ids.sort();
    run_ids.dedup();
    for id in run_ids {
        if !valid_run_id(&id) {
            continue;
        }
        let owner = std::fs::read_to_string(ipc_root_of(&id).join(OWNER_FILE)).ok();
        if owner.as_deref().is_some_and(owner_alive) {
            alive.push(id);
        } else {
            remove_run(&id);
            removed.push(id);
        }
    }
    (removed, alive)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn owner_is_alive_only_with_matching_start_time() {
        let me = std::process::id() as i32;
        let start = start_time(me).unwrap();
        assert!(owner_alive(&format!("{me} {start}")));
        assert!(
            !owner_alive(&format!("{me} {}", start + 1)),
            "a recycled pid is not the owner"
        );
        assert!(!owner_alive("garbage"));
    }
}
