//! Opening the files swarm writes in a run directory without following a symbolic link
//! planted at their name (`O_NOFOLLOW`): a link there is refused with an error naming the
//! path, and whatever it points to is left untouched.
//!
//! Only the last component of a path is checked: a run directory given as `--out` may itself
//! be reached through a link, as the user chose; the files swarm creates inside it may not.
//! A file replaced by rename ([`write_replace_nofollow`]) is safe either way (`rename(2)`
//! replaces a link at the destination, never what it points to), and is refused too, so a
//! planted link is reported rather than silently dropped.

use std::fs::{File, OpenOptions};
use std::io::{self, Write};
use std::os::unix::fs::{DirBuilderExt, OpenOptionsExt};
use std::path::{Path, PathBuf};

/// A path swarm would write that is a symbolic link: refused, never followed. Its message is
/// `<path> is a symbolic link; refusing to follow it`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SymlinkRefused {
    /// The path that is a link.
    pub path: PathBuf,
}

impl std::fmt::Display for SymlinkRefused {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} is a symbolic link; refusing to follow it",
            self.path.display()
        )
    }
}

impl std::error::Error for SymlinkRefused {}

/// The `io::Error` for a refused link at `path`.
pub fn symlink_error(path: &Path) -> io::Error {
    io::Error::new(
        io::ErrorKind::InvalidInput,
        SymlinkRefused {
            path: path.to_path_buf(),
        },
    )
}

/// Whether `e` is a refused link ([`SymlinkRefused`]).
pub fn is_symlink_refusal(e: &io::Error) -> bool {
    e.get_ref()
        .is_some_and(|inner| inner.is::<SymlinkRefused>())
}

/// Opens `path` with `opts` plus `O_NOFOLLOW` (std adds `O_CLOEXEC` itself). A symbolic link
/// at `path` fails with [`SymlinkRefused`] (the kernel answers `ELOOP`, or `EEXIST` with
/// `create_new`); any other error is returned as it is.
pub fn open_nofollow(path: &Path, opts: &mut OpenOptions) -> io::Result<File> {
    match opts.custom_flags(libc::O_NOFOLLOW).open(path) {
        Ok(f) => Ok(f),
        Err(e)
            if matches!(e.raw_os_error(), Some(libc::ELOOP) | Some(libc::EEXIST))
                && std::fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_symlink()) =>
        {
            Err(symlink_error(path))
        }
        Err(e) => Err(e),
    }
}

/// `File::create` that refuses a link: write-only, created if missing, truncated.
pub fn create_nofollow(path: &Path) -> io::Result<File> {
    open_nofollow(
        path,
        OpenOptions::new().write(true).create(true).truncate(true),
    )
}

/// `std::fs::write` that refuses a link.
pub fn write_nofollow(path: &Path, bytes: impl AsRef<[u8]>) -> io::Result<()> {
    create_nofollow(path)?.write_all(bytes.as_ref())
}

/// Opens `path` for appending (created if missing) without following a link.
pub fn open_append_nofollow(path: &Path) -> io::Result<File> {
    open_nofollow(path, OpenOptions::new().append(true).create(true))
}

/// Opens `path` to read and write (created if missing, never truncated) without following a
/// link: a lock file, an append-only store.
pub fn open_rw_nofollow(path: &Path) -> io::Result<File> {
    open_nofollow(
        path,
        OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false),
    )
}

/// Opens an existing `path` for writing (not created, not truncated) without following a
/// link: to cut a file back with `set_len`.
pub fn open_existing_nofollow(path: &Path) -> io::Result<File> {
    open_nofollow(path, OpenOptions::new().write(true))
}

/// Fails with [`SymlinkRefused`] if `path` is a symbolic link; a missing path is fine.
pub fn refuse_symlink(path: &Path) -> io::Result<()> {
    match std::fs::symlink_metadata(path) {
        Ok(m) if m.file_type().is_symlink() => Err(symlink_error(path)),
        _ => Ok(()),
    }
}

/// Renames `from` to `to`, refusing a link at `to` (rename would replace the link, not write
/// through it; refusing says so instead of dropping it unannounced).
pub fn rename_nofollow(from: &Path, to: &Path) -> io::Result<()> {
    refuse_symlink(to)?;
    std::fs::rename(from, to)
}

/// Writes `bytes` to `path` atomically: into `<path>.tmp` (opened without following a link),
/// then renamed into place ([`rename_nofollow`]). On an error the temporary file is removed.
pub fn write_replace_nofollow(path: &Path, bytes: impl AsRef<[u8]>) -> io::Result<()> {
    let mut name = path.file_name().unwrap_or_default().to_os_string();
    name.push(".tmp");
    let tmp = path.with_file_name(name);
    let written = write_nofollow(&tmp, bytes).and_then(|()| rename_nofollow(&tmp, path));
    if let Err(e) = written {
        if !is_symlink_refusal(&e) || std::fs::symlink_metadata(&tmp).is_ok_and(|m| m.is_file()) {
            let _ = std::fs::remove_file(&tmp);
        }
        return Err(e);
    }
    Ok(())
}

/// A directory made for this process alone (mode 0700, a name no one else holds: `mkdir`
/// fails rather than reuse an existing name or link), for a library that writes a file by its
/// path: the file is written in here, then renamed into place. Removed on drop.
#[derive(Debug)]
pub struct PrivateDir {
    path: PathBuf,
}

impl PrivateDir {
    /// Creates `<parent>/.<stem>.<pid>.<n>.tmp`.
    pub fn new(parent: &Path, stem: &str) -> io::Result<PrivateDir> {
        static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
        loop {
            let n = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            let path = parent.join(format!(".{stem}.{}.{n}.tmp", std::process::id()));
            match std::fs::DirBuilder::new().mode(0o700).create(&path) {
                Ok(()) => return Ok(PrivateDir { path }),
                Err(e) if e.kind() == io::ErrorKind::AlreadyExists => continue,
                Err(e) => return Err(e),
            }
        }
    }

    /// The directory.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for PrivateDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.path);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::os::unix::fs::symlink;

    /// A directory with `victim` (outside it, holding "keep") and `dir/name -> victim`.
    fn planted(name: &str) -> (tempfile_lite::Dir, PathBuf, PathBuf) {
        let root = tempfile_lite::Dir::new();
        let victim = root.path().join("victim");
        std::fs::write(&victim, "keep").unwrap();
        let dir = root.path().join("run");
        std::fs::create_dir(&dir).unwrap();
        let link = dir.join(name);
        symlink(&victim, &link).unwrap();
        (root, victim, link)
    }

    fn assert_refused(e: io::Error, link: &Path) {
        assert!(is_symlink_refusal(&e), "{e:?}");
        assert_eq!(
            e.to_string(),
            format!(
                "{} is a symbolic link; refusing to follow it",
                link.display()
            )
        );
    }

    #[test]
    fn every_opener_refuses_a_planted_link_and_leaves_its_target_alone() {
        let (_root, victim, link) = planted("trajectory.csv");
        let before = std::fs::metadata(&victim).unwrap().modified().unwrap();
        assert_refused(create_nofollow(&link).unwrap_err(), &link);
        assert_refused(write_nofollow(&link, "x").unwrap_err(), &link);
        assert_refused(open_append_nofollow(&link).unwrap_err(), &link);
        assert_refused(open_rw_nofollow(&link).unwrap_err(), &link);
        assert_refused(open_existing_nofollow(&link).unwrap_err(), &link);
        assert_refused(refuse_symlink(&link).unwrap_err(), &link);
        assert_refused(write_replace_nofollow(&link, "x").unwrap_err(), &link);
        assert_refused(
            open_nofollow(&link, OpenOptions::new().write(true).create_new(true)).unwrap_err(),
            &link,
        );
        assert_eq!(std::fs::read_to_string(&victim).unwrap(), "keep");
        assert_eq!(
            std::fs::metadata(&victim).unwrap().modified().unwrap(),
            before
        );
        assert!(
            std::fs::symlink_metadata(&link).unwrap().is_symlink(),
            "the link stays"
        );
        assert!(
            !link.with_file_name("trajectory.csv.tmp").exists(),
            "no temporary file left"
        );
    }

    #[test]
    fn a_planted_temporary_link_is_refused_too() {
        let (_root, victim, tmp) = planted("metrics.json.tmp");
        let path = tmp.with_file_name("metrics.json");
        assert_refused(write_replace_nofollow(&path, "{}").unwrap_err(), &tmp);
        assert_eq!(std::fs::read_to_string(&victim).unwrap(), "keep");
        assert!(!path.exists());
        assert!(std::fs::symlink_metadata(&tmp).unwrap().is_symlink());
    }

    #[test]
    fn plain_files_are_written_as_std_would() {
        let root = tempfile_lite::Dir::new();
        let p = root.path().join("a.csv");
        write_nofollow(&p, "one\n").unwrap();
        open_append_nofollow(&p)
            .unwrap()
            .write_all(b"two\n")
            .unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "one\ntwo\n");
        create_nofollow(&p).unwrap().write_all(b"3\n").unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "3\n");
        open_existing_nofollow(&p).unwrap().set_len(1).unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "3");
        write_replace_nofollow(&p, "new").unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "new");
        assert!(!root.path().join("a.csv.tmp").exists());
        assert_eq!(
            open_existing_nofollow(&root.path().join("missing"))
                .unwrap_err()
                .kind(),
            io::ErrorKind::NotFound
        );
        let private = PrivateDir::new(root.path(), "plot").unwrap();
        let inner = private.path().to_path_buf();
        assert!(inner.is_dir());
        use std::os::unix::fs::PermissionsExt;
        assert_eq!(
            std::fs::metadata(&inner).unwrap().permissions().mode() & 0o777,
            0o700
        );
        let other = PrivateDir::new(root.path(), "plot").unwrap();
        assert_ne!(other.path(), inner);
        drop(private);
        assert!(!inner.exists(), "removed on drop");
    }

    /// A scratch directory removed on drop (this crate has no `tempfile`).
    mod tempfile_lite {
        use std::path::{Path, PathBuf};

        pub struct Dir(PathBuf);

        impl Dir {
            pub fn new() -> Dir {
                static N: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
                let n = N.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                let p = std::env::temp_dir()
                    .join(format!("swarmrt-safe-fs-{}-{n}", std::process::id()));
                let _ = std::fs::remove_dir_all(&p);
                std::fs::create_dir_all(&p).unwrap();
                Dir(p)
            }

            pub fn path(&self) -> &Path {
                &self.0
            }
        }

        impl Drop for Dir {
            fn drop(&mut self) {
                let _ = std::fs::remove_dir_all(&self.0);
            }
        }
    }
}
