//! The run's iceoryx2 "global management segment", made private before any node opens it.
//!
//! iceoryx2 0.10 keeps one segment per root and prefix, `/dev/shm/<prefix>node.0_10_0.global_mgmt`
//! (a node counter for unique ids), and creates it with mode 0666: its
//! `GlobalManagementSegment::open_or_create` asks for global access. Any local user could then
//! truncate it, and every node creation after that waits for ever: iceoryx2's open retries a
//! zero-size mapping without looking at its timeout (`posix_shared_memory.rs`, the
//! `MappingSizeIsZero` arm of `open_impl`). So the first process of a run ([`ensure`], from
//! `cleanup::claim` and [`crate::node`]) creates the segment itself through iceoryx2-cal's own
//! builder, with global access off (0600); every later iceoryx2 process of the run, a Python
//! robot's included, opens that one, and [`ensure`] refuses a segment another user could have
//! planted or changed, in one line, before iceoryx2 could wait on it.
//!
//! Upstream, two changes would make this module unnecessary: `open_or_create` without
//! `enable_global_access(true)` (or a config switch for it), and the timeout checked in the
//! zero-size arm of `open_impl`.

use std::io::Write;
use std::os::unix::fs::{MetadataExt, OpenOptionsExt, PermissionsExt};
use std::path::PathBuf;
use std::time::{Duration, Instant};

use iceoryx2::config::Config;
use iceoryx2_bb_elementary::package_version::PackageVersion;
use iceoryx2_cal::hash::Hash;
use iceoryx2_cal::hash::sha1::Sha1;
use swarmrt_protocol::services::{SHM_DIR, euid};

/// The type iceoryx2 stores in the segment: its name is hashed into the segment's file name
/// (`DynamicStorageConfiguration::path_for_with_type`), so ours must be the same.
const STATE_TYPE: &str = "iceoryx2::node::global_management_segment::State";

/// The segment's bytes as iceoryx2-cal lays them out (`posix_shared_memory.rs`: a `repr(C)`
/// `Data { version: AtomicU64, data: State }`, `State { node_counter: AtomicU32 }`, padded).
const SIZE: usize = 16;

/// A management segment swarm will not let iceoryx2 open: another user's, open to others, or
/// left empty. Its message is one line naming the file and the reason.
#[derive(Debug, Clone, thiserror::Error)]
#[error(
    "refusing the run's shared-memory segment {path}: {why}; another local user may have \
     planted or changed it (remove the run with `swarm clean` and start it again)"
)]
pub struct SegmentRefused {
    /// The segment's file under /dev/shm.
    pub path: PathBuf,
    /// Why it is not trusted.
    pub why: String,
}

/// The segment's file: POSIX shared memory lives flat in /dev/shm, named (as
/// `GlobalManagementSegment::dynamic_storage_config` and `path_for_with_type` name it)
/// `<prefix><sha1 of the type, base64url>_node.<major>_<minor>_<patch><global_mgmt_suffix>`.
pub fn path(cfg: &Config) -> PathBuf {
    let ver = PackageVersion::get();
    let hash = Sha1::new(STATE_TYPE.as_bytes()).value();
    let name = format!(
        "{}{}_node.{}_{}_{}{}",
        cfg.global.prefix,
        hash.as_base64url(),
        ver.major(),
        ver.minor(),
        ver.patch(),
        cfg.global.node.global_mgmt_suffix,
    );
    PathBuf::from(SHM_DIR).join(name)
}

/// Makes sure the run's management segment exists, is this user's and is private (mode with
/// no group or other bits), creating it so if it is missing. Bounded: an empty segment of
/// this user (one of the run's processes between creating and sizing it) is waited for up to
/// the config's `creation_timeout`, then refused.
pub fn ensure(cfg: &Config) -> Result<(), SegmentRefused> {
    let path = path(cfg);
    let refuse = |why: String| SegmentRefused {
        path: path.clone(),
        why,
    };
    match create(&path) {
        Ok(()) => {}
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {}
        Err(e) => return Err(refuse(format!("cannot create it ({e})"))),
    }
    let started = Instant::now();
    loop {
        match check(&path) {
            Ok(()) => return Ok(()),
            Err(Check::Refused(why)) => return Err(refuse(why)),
            Err(Check::Empty) if started.elapsed() < cfg.global.creation_timeout => {
                // One of this run's own processes is between creating and sizing it (no one
                // else can write a 0600 file of ours): a start-up race of microseconds.
                std::thread::sleep(Duration::from_millis(1));
            }
            Err(Check::Empty) => {
                return Err(refuse(format!(
                    "it is still empty after {:?}",
                    cfg.global.creation_timeout
                )));
            }
        }
    }
}

/// Creates the segment as iceoryx2-cal creates a storage, but private: exclusively, mode
/// 0200 (write-only: an opener waits while it cannot read it) while the version is written,
/// then 0600. The run's cleanup removes it with every file of the prefix.
fn create(path: &std::path::Path) -> std::io::Result<()> {
    let mut file = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .create_new(true)
        .mode(0o200)
        .custom_flags(libc::O_NOFOLLOW)
        .open(path)?;
    let mut bytes = [0u8; SIZE];
    bytes[..8].copy_from_slice(&PackageVersion::get().to_u64().to_ne_bytes());
    file.write_all(&bytes)?;
    file.set_permissions(std::fs::Permissions::from_mode(0o600))
}

enum Check {
    /// Not to be opened: the reason.
    Refused(String),
    /// This user's private segment, not sized yet.
    Empty,
}

/// Checks the segment's file without following a link and without blocking.
fn check(path: &std::path::Path) -> Result<(), Check> {
    let file = std::fs::OpenOptions::new()
        .read(true)
        .custom_flags(libc::O_NOFOLLOW | libc::O_NONBLOCK)
        .open(path)
        .map_err(|e| Check::Refused(format!("cannot open it ({e})")))?;
    let meta = file
        .metadata()
        .map_err(|e| Check::Refused(format!("cannot stat it ({e})")))?;
    let me = euid();
    if !meta.file_type().is_file() {
        return Err(Check::Refused("it is not a regular file".to_string()));
    }
    if meta.uid() != me {
        return Err(Check::Refused(format!(
            "it is owned by uid {}, not by you (uid {me})",
            meta.uid()
        )));
    }
    let mode = meta.mode() & 0o7777;
    if mode & 0o077 != 0 {
        return Err(Check::Refused(format!(
            "group or others may open it (mode {mode:04o})"
        )));
    }
    if meta.len() < SIZE as u64 {
        return Err(Check::Empty);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use swarmrt_protocol::services::RunServices;

    /// A run id of this test process alone, its shared memory removed when dropped.
    struct TestRun(RunServices);

    impl TestRun {
        fn new(tag: u8) -> TestRun {
            let id = format!("ee{:08x}{tag:02x}", std::process::id());
            let run = RunServices::new(&id);
            crate::cleanup::remove_run(&id);
            TestRun(run)
        }
    }

    impl Drop for TestRun {
        fn drop(&mut self) {
            crate::cleanup::remove_run(self.0.run_id());
        }
    }

    #[test]
    fn the_segment_is_made_private_and_iceoryx2_opens_ours() {
        let run = TestRun::new(1);
        let cfg = crate::ipc_config(&run.0).unwrap();
        // The name is the one iceoryx2 gives it: a node of another run without `ensure`
        // makes its own (mode 0666), named as `path` names it.
        let bare = TestRun::new(3);
        let bare_cfg = crate::ipc_config(&bare.0).unwrap();
        let _n = iceoryx2::prelude::NodeBuilder::new()
            .config(&bare_cfg)
            .create::<crate::Svc>()
            .unwrap();
        let theirs = std::fs::metadata(path(&bare_cfg)).expect("iceoryx2's own segment");
        assert_eq!(theirs.mode() & 0o777, 0o666, "iceoryx2 0.10 makes it 0666");
        assert_eq!(theirs.len(), SIZE as u64);

        ensure(&cfg).unwrap();
        let p = path(&cfg);
        let before = std::fs::metadata(&p).unwrap();
        assert_eq!(before.mode() & 0o777, 0o600, "{}", p.display());
        assert!(
            p.file_name()
                .unwrap()
                .to_string_lossy()
                .ends_with("node.0_10_0.global_mgmt"),
            "{}",
            p.display()
        );
        // Nodes of the run open it, and leave it as it was: same file, still 0600.
        let _a = crate::node(&run.0, "a").unwrap();
        let _b = crate::node(&run.0, "b").unwrap();
        let after = std::fs::metadata(&p).unwrap();
        assert_eq!(after.ino(), before.ino());
        assert_eq!(after.mode() & 0o777, 0o600);
        // Two nodes counted in our segment (after the 8-byte version word).
        let bytes = std::fs::read(&p).unwrap();
        let counter = u32::from_ne_bytes(bytes[8..12].try_into().unwrap());
        assert_eq!(counter, 2);
    }

    #[test]
    fn a_segment_others_may_open_or_an_empty_one_is_refused_in_bounded_time() {
        let run = TestRun::new(2);
        let mut cfg = crate::ipc_config(&run.0).unwrap();
        cfg.global.creation_timeout = Duration::from_millis(200);
        let p = path(&cfg);
        // As iceoryx2 0.10 makes it: mode 0666.
        std::fs::write(&p, [0u8; 16]).unwrap();
        std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o666)).unwrap();
        let e = ensure(&cfg).unwrap_err().to_string();
        assert_eq!(
            e,
            format!(
                "refusing the run's shared-memory segment {}: group or others may open it \
                 (mode 0666); another local user may have planted or changed it (remove the \
                 run with `swarm clean` and start it again)",
                p.display()
            )
        );
        // A node of the run makes that check before iceoryx2 opens the segment.
        let Err(by_node) = crate::node(&run.0, "late") else {
            panic!("a node was made over a segment others may open");
        };
        assert_eq!(by_node.to_string(), e);
        // Truncated to nothing (what another user did to the 0666 one): refused after the
        // timeout (200 ms here, a run's 10 s) instead of the wait for ever inside iceoryx2.
        // Through a whole run: `local_users::another_user_cannot_truncate_a_runs_segments...`.
        std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o600)).unwrap();
        std::fs::File::create(&p).unwrap();
        let e = ensure(&cfg).unwrap_err().to_string();
        assert!(e.contains("it is still empty after"), "{e}");
        // A link planted at its name is refused, not followed.
        std::fs::remove_file(&p).unwrap();
        std::os::unix::fs::symlink("/etc/hostname", &p).unwrap();
        let e = ensure(&cfg).unwrap_err().to_string();
        assert!(e.contains("cannot open it"), "{e}");
    }
}
