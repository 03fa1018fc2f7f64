//! Every iceoryx2 name a run uses, derived from its run id in this one place.
//!
//! Each run gets its own iceoryx2 root directory and shared-memory prefix, so runs never
//! collide and `swarm clean` can remove exactly the leftovers of a dead run.

use std::path::PathBuf;

/// The directory under which every run keeps its iceoryx2 files (one sub-directory per run).
///
/// On tmpfs, beside the shared memory: iceoryx2 creates and removes a handful of files per
/// node and port, and on the ext4 `/tmp` of the benchmark machine inode allocation among
/// recently deleted inodes made each robot's node take 50-700 ms to create under load; 500
/// robots took 7.6 s to start there and 0.8 s here (docs/benchmarks.md).
pub const IPC_BASE_DIR: &str = "/dev/shm/swarmrt-iceoryx2";
/// Where builds before the move to tmpfs kept run roots; `swarm clean` still looks there.
pub const LEGACY_IPC_BASE_DIR: &str = "/tmp/iceoryx2/swarmrt";
/// Directory where POSIX shared memory segments appear on Linux.
pub const SHM_DIR: &str = "/dev/shm";
/// Event id a robot uses on the command event after publishing a command.
pub const EVENT_COMMAND: usize = 1;
/// Event id the world's control thread uses to wake the world's main loop.
pub const EVENT_CONTROL: usize = 2;

/// The names belonging to one run.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RunServices {
    run_id: String,
}

impl RunServices {
    /// Names for `run_id` (lower-case hex; checked by [`valid_run_id`]).
    pub fn new(run_id: &str) -> Self {
        RunServices {
            run_id: run_id.to_string(),
        }
    }

    /// The run id.
    pub fn run_id(&self) -> &str {
        &self.run_id
    }

    /// World -> agents: one sample per tick holding every robot's observation.
    pub fn observations(&self) -> String {
        format!("swarmrt/{}/observations", self.run_id)
    }

    /// Agents -> world: one command sample per robot per tick.
    pub fn commands(&self) -> String {
        format!("swarmrt/{}/commands", self.run_id)
    }

    /// The iceoryx2 root directory of this run.
    pub fn ipc_root(&self) -> PathBuf {
        ipc_root_of(&self.run_id)
    }

    /// Prefix of every shared-memory segment and file this run creates.
    pub fn shm_prefix(&self) -> String {
        shm_prefix_of(&self.run_id)
    }

    /// Node name of robot `id`, so logs and `iox2 node list` show who is who.
    pub fn robot_node_name(&self, id: u32) -> String {
        format!("swarmrt-{}-robot-{id}", self.run_id)
    }

    /// Node name of the world process.
    pub fn world_node_name(&self) -> String {
        format!("swarmrt-{}-world", self.run_id)
    }
}

/// The iceoryx2 root directory of `run_id`.
pub fn ipc_root_of(run_id: &str) -> PathBuf {
    PathBuf::from(IPC_BASE_DIR).join(run_id)
}

/// The shared-memory prefix of `run_id`.
pub fn shm_prefix_of(run_id: &str) -> String {
    format!("swarmrt_{run_id}_")
}

/// Run ids are 1-32 lower-case hex digits; anything else is refused so paths stay safe.
pub fn valid_run_id(run_id: &str) -> bool {
    !run_id.is_empty()
        && run_id.len() <= 32
        && run_id
            .bytes()
            .all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_scoped_by_run_id() {
        let a = RunServices::new("00ab");
        let b = RunServices::new("00ac");
        assert_ne!(a.observations(), b.observations());
        assert!(a.commands().starts_with("swarmrt/00ab/"));
        assert!(a.ipc_root().ends_with("00ab"));
        assert!(valid_run_id("00ab"));
        assert!(!valid_run_id("../x"));
        assert!(!valid_run_id(""));
    }
}
