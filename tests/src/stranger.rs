//! Other local users, for the tests that attack a run the way someone else on the same host
//! would (docs/security.md, "Local users"). A user is a uid and gid with no account: the test
//! process (root, as CI runs the suite) starts a program as that user with util-linux's
//! `setpriv`, so nothing is added to `/etc/passwd` and nothing is left behind.

use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::Duration;

/// Another local user: a uid and gid that no account and no process of the test owns.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct User {
    /// Its uid (also its gid).
    pub uid: u32,
}

/// The attacker: the second local user the attack tests act as.
pub const STRANGER: User = User { uid: 47_123 };

/// A second, unprivileged victim, for promises that root would keep by its rights alone
/// (a victim that is not root cannot open what the kernel refuses it either).
pub const VICTIM: User = User { uid: 47_124 };

/// Panics with the reason when the tests cannot act as other users: they must run as root
/// (CI does, as the README says) and need util-linux's `setpriv`.
pub fn require_root() {
    // SAFETY: geteuid has no preconditions.
    let euid = unsafe { libc::geteuid() };
    assert_eq!(
        euid, 0,
        "the attack tests act as other local users and must run as root (uid {euid})"
    );
    assert!(
        crate::runs("setpriv", "--version"),
        "util-linux's setpriv is missing (apt-get install util-linux)"
    );
}

impl User {
    /// `program` to be run as this user: `setpriv` drops every privilege and supplementary
    /// group before it starts. Its HOME is a fresh path under /tmp that it may not own.
    pub fn command(&self, program: impl AsRef<std::ffi::OsStr>) -> Command {
        require_root();
        let mut cmd = Command::new("setpriv");
        cmd.arg(format!("--reuid={}", self.uid))
            .arg(format!("--regid={}", self.uid))
            .arg("--clear-groups")
            .arg("--inh-caps=-all")
            .arg("--")
            .arg(program)
            .env("HOME", "/tmp")
            .env_remove("XDG_RUNTIME_DIR")
            .stdin(Stdio::null());
        cmd
    }

    /// Runs `sh -c script` as this user within `limit`, its output captured.
    pub fn sh(&self, script: &str, limit: Duration) -> Output {
        let child = self
            .command("sh")
            .arg("-c")
            .arg(script)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("setpriv starts");
        crate::wait_with_watchdog(child, limit)
    }

    /// Makes `path` (a directory, created if missing) owned by this user with `mode`.
    pub fn own(&self, path: &Path, mode: u32) {
        use std::os::unix::fs::PermissionsExt;
        std::fs::create_dir_all(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        std::os::unix::fs::chown(path, Some(self.uid), Some(self.uid))
            .unwrap_or_else(|e| panic!("chown {}: {e}", path.display()));
        std::fs::set_permissions(path, std::fs::Permissions::from_mode(mode)).unwrap();
    }
}

/// A directory under /tmp that every user may enter (the victim's tests put their run
/// directories and binaries' outputs there), removed when dropped.
pub struct OpenScratch(pub std::path::PathBuf);

impl OpenScratch {
    /// A fresh `/tmp/swarmrt-<tag>-<pid>`, mode 0755, owned by root.
    pub fn new(tag: &str) -> OpenScratch {
        use std::os::unix::fs::PermissionsExt;
        let dir = std::env::temp_dir().join(format!("swarmrt-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o755)).unwrap();
        OpenScratch(dir)
    }
}

impl Drop for OpenScratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Shell-quotes `s` for [`User::sh`].
pub fn quote(s: &str) -> String {
    format!("'{}'", s.replace('\'', r"'\''"))
}

/// The `swarm` binary's path as a quoted shell word, for [`User::sh`] scripts.
pub fn swarm_word() -> String {
    quote(&crate::swarm_bin().display().to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_stranger_is_not_root_and_cannot_read_roots_private_files() {
        let s = OpenScratch::new("stranger-self-test");
        let secret = s.0.join("secret");
        std::fs::write(&secret, "x").unwrap();
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(&secret, std::fs::Permissions::from_mode(0o600)).unwrap();
        let out = STRANGER.sh(
            &format!("id -u; cat {}", quote(&secret.display().to_string())),
            Duration::from_secs(10),
        );
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert_eq!(stdout.lines().next(), Some("47123"), "{out:?}");
        assert!(!out.status.success(), "the stranger read root's 0600 file");
    }
}
