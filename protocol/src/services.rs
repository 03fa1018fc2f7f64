//! Every iceoryx2 name a run uses, derived from its run id in this one place.
//!
//! Each run gets its own iceoryx2 root directory and shared-memory prefix, so runs never
//! collide and `swarm clean` can remove exactly the leftovers of a dead run.

use std::path::PathBuf;

/// The directory under which this user's runs keep their iceoryx2 files (one sub-directory
/// per run): the value of [`SHM_BASE_ENV`] when it is set; else `$XDG_RUNTIME_DIR/swarmrt`
/// when the login session gives this user a private tmpfs there ([`xdg_base`]), which no
/// other user can create first; else `/dev/shm/swarmrt-<euid>`.
///
/// Private to its user (mode 0700, checked by `swarmrt_ipc::cleanup::claim` before every
/// run), so no other user can list, read or replace a run's files. On tmpfs, beside the
/// shared memory: iceoryx2 creates and removes a handful of files per node and port, and on
/// the ext4 `/tmp` of the benchmark machine inode allocation among recently deleted inodes
/// made each robot's node take 50-700 ms to create under load; 500 robots took 7.6 s to
/// start there and 0.8 s here (docs/benchmarks.md).
pub fn ipc_base_dir() -> PathBuf {
    match std::env::var_os(SHM_BASE_ENV) {
        Some(base) if !base.is_empty() => PathBuf::from(base),
        _ => xdg_base().unwrap_or_else(default_shm_base),
    }
}

/// `/dev/shm/swarmrt-<euid>`: the base without [`SHM_BASE_ENV`] or a usable
/// `$XDG_RUNTIME_DIR`. Another user may create it first in the world-writable /dev/shm;
/// `claim` then refuses it and says what to do.
pub fn default_shm_base() -> PathBuf {
    PathBuf::from(format!("{SHM_DIR}/swarmrt-{}", euid()))
}

/// `$XDG_RUNTIME_DIR/swarmrt` when `XDG_RUNTIME_DIR` is an absolute path to a directory of
/// this user with no access for group or others, on a tmpfs (iceoryx2's files are created
/// and removed by the hundred), and short enough for iceoryx2's socket paths (the base may
/// be at most 27 bytes). Anything else is passed over for `/dev/shm`, silently: the
/// variable is the login manager's, not a choice the user made for swarm.
pub fn xdg_base() -> Option<PathBuf> {
    use std::os::unix::fs::MetadataExt;
    let dir = PathBuf::from(std::env::var_os("XDG_RUNTIME_DIR")?);
    let base = dir.join("swarmrt");
    if !dir.is_absolute() || base.as_os_str().len() > 27 {
        return None;
    }
    let meta = std::fs::symlink_metadata(&dir).ok()?;
    if !meta.is_dir() || meta.uid() != euid() || meta.mode() & 0o077 != 0 || !on_tmpfs(&dir) {
        return None;
    }
    Some(base)
}

/// True when `dir` lies on a tmpfs.
fn on_tmpfs(dir: &std::path::Path) -> bool {
    use std::os::unix::ffi::OsStrExt;
    let Ok(c) = std::ffi::CString::new(dir.as_os_str().as_bytes()) else {
        return false;
    };
    // SAFETY: `c` is a valid NUL-terminated path; statfs only writes the struct we pass.
    let mut fs: libc::statfs = unsafe { std::mem::zeroed() };
    unsafe { libc::statfs(c.as_ptr(), &mut fs) == 0 && fs.f_type == libc::TMPFS_MAGIC }
}

/// Environment variable that, when set, replaces [`ipc_base_dir`]'s `/dev/shm/swarmrt-<euid>`
/// (an absolute path of at most 27 bytes, so iceoryx2's socket paths under it fit, best on a
/// tmpfs): for tests, and for users who want another tmpfs. It is checked as the default
/// base is. The processes of a run inherit it; robots get their run's root itself
/// (`SWARMRT_IPC_ROOT`, `SWARMRT_IPC_CONFIG`). `swarm clean` sweeps the base of its own
/// environment: run it with the same value.
pub const SHM_BASE_ENV: &str = "SWARMRT_SHM_BASE";

/// The effective user id of this process.
pub fn euid() -> u32 {
    // SAFETY: geteuid has no preconditions and cannot fail.
    unsafe { libc::geteuid() }
}

/// Where earlier builds kept run roots; `swarm clean` still sweeps them (only the entries
/// this user owns): the base every user shared in `/dev/shm` before each user had their own,
/// and the one in `/tmp` before the move to tmpfs.
pub const LEGACY_IPC_BASE_DIRS: [&str; 2] = ["/dev/shm/swarmrt-iceoryx2", "/tmp/iceoryx2/swarmrt"];
/// Directory where POSIX shared memory segments appear on Linux.
pub const SHM_DIR: &str = "/dev/shm";
/// Event id a robot uses on the command event after publishing a command.
pub const EVENT_COMMAND: usize = 1;
/// Event id the world's control thread uses to wake the world's main loop.
pub const EVENT_CONTROL: usize = 2;
/// Robot ids per command service. iceoryx2 walks every publisher of a service for each
/// sample it hands out, so draining N robots' answers from one service costs the world
/// O(N^2) a tick (a third of its CPU at 1,000 robots); groups of 32 make it O(32 N).
pub const COMMAND_GROUP: u32 = 32;

/// The command service group robot `id` publishes in.
pub fn command_group_of(id: u32) -> u32 {
    id / COMMAND_GROUP
}

/// What a robot program finds in its environment, beside the arguments `swarm-agent` gets
/// (`--run-id --robot --incarnation --config --storage [--slot-offset]`), so a controller in
/// any language can join without parsing them (docs/robot-interface.md).
pub mod env {
    /// The run id (lower-case hex).
    pub const RUN_ID: &str = "SWARMRT_RUN_ID";
    /// This robot's id.
    pub const ROBOT: &str = "SWARMRT_ROBOT";
    /// Scheduled restarts of this robot before this process (0 for its first process).
    pub const INCARNATION: &str = "SWARMRT_INCARNATION";
    /// The run's resolved config (TOML), every key present.
    pub const CONFIG: &str = "SWARMRT_CONFIG";
    /// A directory for state that must survive a scheduled restart.
    pub const STORAGE: &str = "SWARMRT_STORAGE";
    /// Index of this robot's slot in the observation sample is `robot - SLOT_OFFSET`.
    pub const SLOT_OFFSET: &str = "SWARMRT_SLOT_OFFSET";
    /// The run's iceoryx2 root directory.
    pub const IPC_ROOT: &str = "SWARMRT_IPC_ROOT";
    /// The run's iceoryx2 shared-memory prefix.
    pub const IPC_PREFIX: &str = "SWARMRT_IPC_PREFIX";
    /// An `iceoryx2.toml` holding the run's root, prefix and settings (load it as the node's
    /// config).
    pub const IPC_CONFIG: &str = "SWARMRT_IPC_CONFIG";
    /// Name of the observation service (and of the event service beside it).
    pub const OBSERVATIONS: &str = "SWARMRT_OBSERVATIONS";
    /// Name of this robot's command service (its group's: robot ids `32 k .. 32 k + 31`).
    pub const COMMANDS: &str = "SWARMRT_COMMANDS";
    /// Name of the event service a robot wakes the world on (one for the whole run).
    pub const COMMANDS_EVENT: &str = "SWARMRT_COMMANDS_EVENT";
    /// The node name this robot should use (so `iox2 node list` shows who is who).
    pub const NODE_NAME: &str = "SWARMRT_NODE_NAME";
}

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

    /// Agents -> world wake-up: the event service every robot notifies (and the world's
    /// control thread). The commands themselves travel in [`RunServices::command_group`].
    pub fn commands(&self) -> String {
        format!("swarmrt/{}/commands", self.run_id)
    }

    /// Agents -> world: one command sample per robot per tick, robots of ids
    /// `COMMAND_GROUP * group ..` publishing in the same service.
    pub fn command_group(&self, group: u32) -> String {
        format!("swarmrt/{}/commands/{group}", self.run_id)
    }

    /// The command service robot `id` publishes in.
    pub fn robot_commands(&self, id: u32) -> String {
        self.command_group(command_group_of(id))
    }

    /// World -> woken robots: one sample per propagation round (`radio.rounds`).
    pub fn rounds(&self) -> String {
        format!("swarmrt/{}/rounds", self.run_id)
    }

    /// World -> robot `id`: its own wake-up, with `radio.rounds` (the tick's and the rounds
    /// it is woken in), so a round wakes only the robots it has frames for.
    pub fn robot_wake(&self, id: u32) -> String {
        format!("swarmrt/{}/wake/{id}", self.run_id)
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

    /// The environment of robot `id`'s program (see [`env`]); `ipc_config` is the path of
    /// the run's `iceoryx2.toml` on the robot's host.
    pub fn robot_env(
        &self,
        id: u32,
        incarnation: u32,
        config: &std::path::Path,
        storage: &std::path::Path,
        slot_offset: u32,
        ipc_config: &std::path::Path,
    ) -> Vec<(&'static str, std::ffi::OsString)> {
        vec![
            (env::RUN_ID, self.run_id.clone().into()),
            (env::ROBOT, id.to_string().into()),
            (env::INCARNATION, incarnation.to_string().into()),
            (env::CONFIG, config.as_os_str().to_owned()),
            (env::STORAGE, storage.as_os_str().to_owned()),
            (env::SLOT_OFFSET, slot_offset.to_string().into()),
            (env::IPC_ROOT, self.ipc_root().into_os_string()),
            (env::IPC_PREFIX, self.shm_prefix().into()),
            (env::IPC_CONFIG, ipc_config.as_os_str().to_owned()),
            (env::OBSERVATIONS, self.observations().into()),
            (env::COMMANDS, self.robot_commands(id).into()),
            (env::COMMANDS_EVENT, self.commands().into()),
            (env::NODE_NAME, self.robot_node_name(id).into()),
        ]
    }

    /// Node name of the world process.
    pub fn world_node_name(&self) -> String {
        format!("swarmrt-{}-world", self.run_id)
    }
}

/// The iceoryx2 root directory of `run_id`.
pub fn ipc_root_of(run_id: &str) -> PathBuf {
    ipc_base_dir().join(run_id)
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
        assert_eq!(a.robot_commands(31), a.command_group(0));
        assert_eq!(a.robot_commands(32), "swarmrt/00ab/commands/1");
        assert_ne!(a.command_group(0), a.commands());
        assert!(a.ipc_root().ends_with("00ab"));
        assert!(valid_run_id("00ab"));
        assert!(!valid_run_id("../x"));
        assert!(!valid_run_id(""));
    }

    #[test]
    fn the_base_is_per_user() {
        if std::env::var_os(SHM_BASE_ENV).is_none() && xdg_base().is_none() {
            let base = ipc_base_dir();
            assert_eq!(base, PathBuf::from(format!("/dev/shm/swarmrt-{}", euid())));
            assert_eq!(ipc_root_of("00ab"), base.join("00ab"));
        }
        assert_eq!(
            default_shm_base(),
            PathBuf::from(format!("/dev/shm/swarmrt-{}", euid()))
        );
    }
}
