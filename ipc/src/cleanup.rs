//! Removing a run's iceoryx2 files and shared-memory segments, on every exit path, for
//! `swarm clean` and for `swarm-host` on a remote host. Every run lives under its own root
//! directory and shm prefix, so removal is exact: nothing of another run, or of other
//! iceoryx2 users, is touched.

use std::io;
use std::os::unix::fs::{DirBuilderExt, MetadataExt, OpenOptionsExt, PermissionsExt};
use std::path::Path;
use swarmrt_protocol::services::{
    LEGACY_IPC_BASE_DIRS, SHM_BASE_ENV, SHM_DIR, euid, ipc_base_dir, ipc_root_of, shm_prefix_of,
    valid_run_id,
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

/// A shared-memory base swarm will not use (a link, another user's, writable by others, too
/// long): the user's to fix, in one line. Carried inside the `io::Error` of [`claim`].
#[derive(Debug, Clone)]
pub struct BaseRefused(pub String);

impl std::fmt::Display for BaseRefused {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for BaseRefused {}

impl BaseRefused {
    /// The refusal inside `e`, if `e` is one.
    pub fn of(e: &io::Error) -> Option<&BaseRefused> {
        e.get_ref().and_then(|inner| inner.downcast_ref())
    }
}

/// Marks `run_id` as owned by this process, so `swarm clean` leaves it alone while it lives,
/// and makes the run's iceoryx2 management segment private before any node opens it
/// ([`crate::mgmt_segment`]).
/// The root appears atomically (built aside, then renamed) with its owner file inside, so a
/// concurrent `swarm clean` never sees an unowned root of a live run.
///
/// The base the root lives in ([`ipc_base_dir`]) is created private (mode 0700) and checked
/// before use ([`check_base`]): a base that is a symbolic link, belongs to another user, or
/// that group or others may write is refused with one line saying which and why; this
/// user's own base that others may only read or enter is first made 0700
/// (`tighten_own_base`).
pub fn claim(run_id: &str) -> io::Result<()> {
    let pid = std::process::id();
    let base = ipc_base_dir();
    check_base_len(&base, run_id)?;
    make_private_base(&base)?;
    let aside = base.join(format!(".claim-{run_id}-{pid}"));
    std::fs::create_dir(&aside)?;
    let owner = format!("{pid} {}", start_time(pid as i32).unwrap_or(0));
    std::fs::write(aside.join(OWNER_FILE), owner)?;
    std::fs::rename(&aside, ipc_root_of(run_id))?;
    // Before any node of the run exists, so every node opens this private one.
    let run = swarmrt_protocol::services::RunServices::new(run_id);
    let cfg = crate::ipc_config(&run).map_err(io::Error::other)?;
    crate::mgmt_segment::ensure(&cfg)
        .map_err(|e| io::Error::new(io::ErrorKind::PermissionDenied, BaseRefused(e.to_string())))
}

/// The longest base whose runs' iceoryx2 sockets still fit `sun_path` (108 bytes with its
/// NUL): a listener's socket is `<base>/<run>/swarmrt_<run>_<id>.event`, `<id>` a u128 in
/// decimal (up to 39 digits). 27 bytes for the 12-digit run ids of `swarm run`:
/// `/dev/shm/swarmrt-<euid>` always fits.
fn max_base_len(run_id: &str) -> usize {
    let below = 1 + run_id.len() + "/swarmrt_".len() + run_id.len() + 1 + 39 + ".event".len();
    107usize.saturating_sub(below)
}

/// Refuses a base (set by SWARMRT_SHM_BASE) too long for iceoryx2's socket paths, which
/// would fail later as an opaque `ListenerCreateError::ResourceCreationFailed`.
fn check_base_len(base: &Path, run_id: &str) -> io::Result<()> {
    let (len, max) = (base.as_os_str().len(), max_base_len(run_id));
    if len > max {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            BaseRefused(format!(
                "refusing the shared-memory root {}: {len} bytes long, longer than the {max} \
                 iceoryx2's socket paths leave room for; choose a shorter path",
                base.display()
            )),
        ));
    }
    Ok(())
}

/// Creates `base` with mode 0700 unless it exists, then checks it ([`check_base`]).
fn make_private_base(base: &Path) -> io::Result<()> {
    let create = || std::fs::DirBuilder::new().mode(0o700).create(base);
    let mut made = create();
    if made
        .as_ref()
        .is_err_and(|e| e.kind() == io::ErrorKind::NotFound)
        && let Some(parent) = base.parent()
    {
        // A base set by SWARMRT_SHM_BASE whose parent does not exist yet.
        made = std::fs::create_dir_all(parent).and_then(|()| create());
    }
    match made {
        Ok(()) => {
            // The umask may have taken bits 0700 asked for; set them on the very directory
            // just made (never following a link).
            let dir = std::fs::OpenOptions::new()
                .read(true)
                .custom_flags(libc::O_DIRECTORY | libc::O_NOFOLLOW)
                .open(base)?;
            dir.set_permissions(std::fs::Permissions::from_mode(0o700))?;
        }
        Err(e) if e.kind() == io::ErrorKind::AlreadyExists => tighten_own_base(base),
        // The base is the user's choice (SWARMRT_SHM_BASE) or their /dev/shm: a base that
        // cannot be made is theirs to fix, one line and exit 2.
        Err(e) => {
            return Err(io::Error::new(
                e.kind(),
                BaseRefused(format!(
                    "cannot create the shared-memory root {}: {e}",
                    base.display()
                )),
            ));
        }
    }
    check_base(base)
}

/// Sets mode 0700 on an existing `base` that is this user's own directory (not a link) and
/// that group or others may read or enter but not write: iceoryx2 makes the directories of
/// a root it does not find with mode 0750 (a program that opens a run's node without
/// [`claim`], such as a test, makes the base so), and nobody else could have put anything
/// in it. A base others may write stays as it is, for [`check_base`] to refuse.
fn tighten_own_base(base: &Path) {
    let Ok(dir) = std::fs::OpenOptions::new()
        .read(true)
        .custom_flags(libc::O_DIRECTORY | libc::O_NOFOLLOW)
        .open(base)
    else {
        return;
    };
    let Ok(meta) = dir.metadata() else {
        return;
    };
    let mode = meta.mode() & 0o7777;
    if meta.uid() == euid() && mode & 0o077 != 0 && mode & 0o022 == 0 {
        match dir.set_permissions(std::fs::Permissions::from_mode(0o700)) {
            Ok(()) => tracing::debug!("{}: mode {mode:04o} made 0700", base.display()),
            Err(e) => tracing::debug!("{}: cannot make it 0700: {e}", base.display()),
        }
    }
}

/// Checks that `base` is fit to hold this user's runs: a real directory (not a symbolic
/// link), owned by this process's effective user, with no permission for group or others
/// (mode `& 0o077 == 0`). Any group or other bit is refused, not only write: [`claim`]
/// creates it 0700 (and tightens this user's own base that others may only read), and a
/// base others can list shows them every run. The error's message is one line naming the
/// path and the reason.
pub fn check_base(base: &Path) -> io::Result<()> {
    check_base_for(base, euid())
}

fn check_base_for(base: &Path, euid: u32) -> io::Result<()> {
    let refuse = |kind: io::ErrorKind, why: String| {
        Err(io::Error::new(
            kind,
            BaseRefused(format!(
                "refusing the shared-memory root {}: {why}",
                base.display()
            )),
        ))
    };
    let meta = std::fs::symlink_metadata(base)?;
    let kind = meta.file_type();
    if kind.is_symlink() {
        return refuse(
            io::ErrorKind::Other,
            "is a symbolic link; remove it".to_string(),
        );
    }
    if !kind.is_dir() {
        return refuse(
            io::ErrorKind::Other,
            "is not a directory; remove it".to_string(),
        );
    }
    if meta.uid() != euid {
        return refuse(
            io::ErrorKind::PermissionDenied,
            format!(
                "owned by uid {}, not by you (uid {euid}): another user made it first, and \
                 only they or root can remove it; set {SHM_BASE_ENV} to a directory of your \
                 own on a tmpfs (at most 27 bytes, e.g. {SHM_BASE_ENV}=/dev/shm/swarmrt-{euid}-own) \
                 or ask root to remove it",
                meta.uid()
            ),
        );
    }
    let mode = meta.mode() & 0o7777;
    if mode & 0o077 != 0 {
        return refuse(
            io::ErrorKind::PermissionDenied,
            format!("group or others may access it (mode {mode:04o}); chmod 700 it"),
        );
    }
    Ok(())
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
    let base = ipc_base_dir();
    match check_base(&base) {
        Ok(()) => {
            for e in std::fs::read_dir(&base).into_iter().flatten().flatten() {
                let name = e.file_name().to_string_lossy().to_string();
                if name.starts_with(".claim-") {
                    // A claim whose orchestrator died before renaming it into place.
                    let owner =
                        std::fs::read_to_string(e.path().join(OWNER_FILE)).unwrap_or_default();
                    if !owner_alive(&owner) {
                        let _ = std::fs::remove_dir_all(e.path());
                    }
                    continue;
                }
                run_ids.push(name);
            }
        }
        Err(e) if e.kind() == io::ErrorKind::NotFound => {}
        // Not this user's private base: nothing in it is trusted, or removed.
        Err(e) => tracing::warn!("{e}"),
    }
    let me = euid();
    // Shared memory of a run whose root directory is already gone: only this user's
    // segments (another user's live run has its root in a base this user cannot see).
    if let Ok(entries) = std::fs::read_dir(SHM_DIR) {
        for e in entries.flatten() {
            let name = e.file_name().to_string_lossy().to_string();
            if let Some(rest) = name.strip_prefix("swarmrt_")
                && let Some((id, _)) = rest.split_once('_')
                && !run_ids.iter().any(|r| r == id)
                && e.metadata().is_ok_and(|m| m.uid() == me)
            {
                run_ids.push(id.to_string());
            }
        }
    }
    // Roots left under the old base directories by earlier builds: only this user's.
    for legacy in LEGACY_IPC_BASE_DIRS {
        let Ok(entries) = std::fs::read_dir(legacy) else {
            continue;
        };
        for e in entries.flatten() {
            let name = e.file_name().to_string_lossy().to_string();
            if !e.metadata().is_ok_and(|m| m.uid() == me) {
                continue;
            }
            let owner = std::fs::read_to_string(e.path().join(OWNER_FILE)).unwrap_or_default();
            if (valid_run_id(&name) || name.starts_with(".claim-")) && !owner_alive(&owner) {
                let _ = std::fs::remove_dir_all(e.path());
                if valid_run_id(&name) && !run_ids.contains(&name) {
                    run_ids.push(name);
                }
            }
        }
        // The old base itself once empty, if it is this user's (nothing else is removed).
        if std::fs::symlink_metadata(legacy).is_ok_and(|m| m.is_dir() && m.uid() == me) {
            let _ = std::fs::remove_dir(legacy);
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
    use std::path::PathBuf;

    /// A fresh directory under the temp dir, removed when dropped.
    struct Scratch(PathBuf);

    impl Scratch {
        fn new(tag: &str) -> Scratch {
            let dir = std::env::temp_dir()
                .join(format!("swarmrt-cleanup-test-{tag}-{}", std::process::id()));
            let _ = std::fs::remove_dir_all(&dir);
            std::fs::create_dir_all(&dir).unwrap();
            Scratch(dir)
        }
    }

    impl Drop for Scratch {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }

    fn dir_with_mode(at: &Path, mode: u32) -> PathBuf {
        let dir = at.join(format!("base-{mode:o}"));
        std::fs::create_dir(&dir).unwrap();
        std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(mode)).unwrap();
        dir
    }

    fn refusal(base: &Path, uid: u32) -> String {
        check_base_for(base, uid)
            .expect_err("the base is refused")
            .to_string()
    }

    #[test]
    fn every_default_base_fits_iceoryx2s_socket_paths() {
        let run_id = "0123456789ab";
        assert_eq!(max_base_len(run_id), 27);
        check_base_len(Path::new("/dev/shm/swarmrt-4294967295"), run_id).unwrap();
        let long = Path::new("/dev/shm/swarmrt-a-rather-long-base");
        let e = check_base_len(long, run_id).unwrap_err().to_string();
        assert_eq!(
            e,
            "refusing the shared-memory root /dev/shm/swarmrt-a-rather-long-base: 35 bytes \
             long, longer than the 27 iceoryx2's socket paths leave room for; choose a \
             shorter path"
        );
    }

    #[test]
    fn a_private_base_of_this_user_is_accepted() {
        let s = Scratch::new("private");
        let base = dir_with_mode(&s.0, 0o700);
        check_base(&base).unwrap();
        // Less than 0700 for the owner is still private.
        check_base(&dir_with_mode(&s.0, 0o500)).unwrap();
    }

    #[test]
    fn any_group_or_other_permission_is_refused() {
        let s = Scratch::new("modes");
        for mode in [0o755, 0o750, 0o770, 0o701, 0o707, 0o1777] {
            let base = dir_with_mode(&s.0, mode);
            let e = check_base(&base).expect_err("refused");
            assert_eq!(e.kind(), io::ErrorKind::PermissionDenied);
            assert_eq!(
                e.to_string(),
                format!(
                    "refusing the shared-memory root {}: group or others may access it \
                     (mode {mode:04o}); chmod 700 it",
                    base.display()
                )
            );
        }
    }

    #[test]
    fn a_base_of_another_user_is_refused() {
        let s = Scratch::new("owner");
        let base = dir_with_mode(&s.0, 0o700);
        let me = euid();
        let other = me.wrapping_add(1);
        assert_eq!(
            refusal(&base, other),
            format!(
                "refusing the shared-memory root {}: owned by uid {me}, not by you \
                 (uid {other}): another user made it first, and only they or root can \
                 remove it; set SWARMRT_SHM_BASE to a directory of your own on a tmpfs (at \
                 most 27 bytes, e.g. SWARMRT_SHM_BASE=/dev/shm/swarmrt-{other}-own) or ask \
                 root to remove it",
                base.display()
            )
        );
    }

    #[test]
    fn a_symbolic_link_or_a_file_is_refused() {
        let s = Scratch::new("links");
        let target = dir_with_mode(&s.0, 0o700);
        let link = s.0.join("link");
        std::os::unix::fs::symlink(&target, &link).unwrap();
        assert_eq!(
            refusal(&link, euid()),
            format!(
                "refusing the shared-memory root {}: is a symbolic link; remove it",
                link.display()
            )
        );
        let file = s.0.join("file");
        std::fs::write(&file, "").unwrap();
        assert!(refusal(&file, euid()).ends_with(": is not a directory; remove it"));
        // make_private_base does not follow the link or chmod its target either.
        std::fs::set_permissions(&target, std::fs::Permissions::from_mode(0o755)).unwrap();
        assert!(make_private_base(&link).is_err());
        let mode = std::fs::metadata(&target).unwrap().mode() & 0o777;
        assert_eq!(mode, 0o755);
    }

    #[test]
    fn a_missing_base_is_made_private_and_a_writable_one_refused() {
        let s = Scratch::new("make");
        let base = s.0.join("parent").join("base");
        make_private_base(&base).unwrap();
        let meta = std::fs::symlink_metadata(&base).unwrap();
        assert!(meta.is_dir());
        assert_eq!(meta.mode() & 0o777, 0o700);
        assert_eq!(meta.uid(), euid());
        make_private_base(&base).unwrap();
        // An existing base others may write is refused, not silently tightened...
        for mode in [0o777, 0o770, 0o702] {
            let open = dir_with_mode(&s.0, mode);
            let e = make_private_base(&open).unwrap_err().to_string();
            assert!(
                e.contains(&format!("(mode {mode:04o}); chmod 700 it")),
                "{e}"
            );
            assert_eq!(std::fs::metadata(&open).unwrap().mode() & 0o777, mode);
        }
        // ...while this user's own base others may only read (as iceoryx2 makes one it does
        // not find, 0750) is made private.
        for mode in [0o750, 0o755, 0o705] {
            let readable = dir_with_mode(&s.0, mode);
            make_private_base(&readable).unwrap();
            assert_eq!(std::fs::metadata(&readable).unwrap().mode() & 0o777, 0o700);
        }
    }

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
