//! Writing where no other local user can redirect it. [`OutDir`] is a directory swarm writes
//! into (a run's `--out`, a sweep's, a tune's, an export's folder), checked once against
//! other users ([`check_path`]) and then used only through the handle opened at the check, so
//! a path swapped for a link afterwards changes nothing. Files are opened without following a
//! link planted at their name (`O_NOFOLLOW`): a link there is refused with an error naming
//! the path, and whatever it points to is left untouched.
//!
//! The path-based openers below check only the last component, for files outside an
//! [`OutDir`].
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

/// A directory swarm writes into (a run directory, a sweep's, a tune's, the folder of an
/// export), checked once and then used only through the handle opened at the check: every
/// file is opened, created, renamed and removed relative to that handle (`openat` and its
/// kin, never following a link at the name), so a path swapped after the check changes
/// nothing. The check ([`OutDir::create`], [`OutDir::open`]) refuses a directory another
/// user owns or that group or others may write, and one reached through a directory another
/// user could rename or replace an entry of ([`check_path`]).
#[derive(Debug)]
pub struct OutDir {
    dir: File,
    path: PathBuf,
    id: DirId,
}

/// Which directory an [`OutDir`] is: its device and inode. The orchestrator passes it to the
/// processes that write into the same directory (`--out-id`), which refuse any other.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DirId {
    /// `st_dev`.
    pub dev: u64,
    /// `st_ino`.
    pub ino: u64,
}

impl std::fmt::Display for DirId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}:{}", self.dev, self.ino)
    }
}

impl std::str::FromStr for DirId {
    type Err = String;
    fn from_str(s: &str) -> Result<DirId, String> {
        let (dev, ino) = s
            .split_once(':')
            .ok_or_else(|| format!("{s:?}: expected DEV:INO"))?;
        let num = |v: &str| {
            v.parse::<u64>()
                .map_err(|_| format!("{s:?}: expected DEV:INO"))
        };
        Ok(DirId {
            dev: num(dev)?,
            ino: num(ino)?,
        })
    }
}

/// A directory swarm will not write into: one line naming it and why (a user error, exit 2).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DirRefused(pub String);

impl std::fmt::Display for DirRefused {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for DirRefused {}

impl DirRefused {
    /// The refusal inside `e`, if `e` is one.
    pub fn of(e: &io::Error) -> Option<&DirRefused> {
        e.get_ref().and_then(|inner| inner.downcast_ref())
    }
}

fn refused(why: String) -> io::Error {
    io::Error::new(io::ErrorKind::PermissionDenied, DirRefused(why))
}

/// This process's effective uid.
fn euid() -> u32 {
    // SAFETY: geteuid has no preconditions.
    unsafe { libc::geteuid() }
}

/// Whether `meta`'s owner is trusted to hold swarm's directories: this user or root.
fn trusted_owner(meta: &std::fs::Metadata) -> bool {
    use std::os::unix::fs::MetadataExt;
    meta.uid() == euid() || meta.uid() == 0
}

/// Checks that no other user can redirect `path`: every directory on the way to it (links
/// resolved, each link checked as an entry of its directory) is owned by this user or root,
/// and a directory group or others may write is sticky (like /tmp), where only an entry's
/// owner may rename or remove it, and then the entry taken from it is this user's or root's.
/// The directory itself, when it exists, must be this user's and writable by nobody else.
/// Returns the path with its links resolved and whether it exists; a missing tail is fine
/// (swarm creates it, inside a directory that passed).
pub fn check_path(path: &Path) -> io::Result<(PathBuf, bool)> {
    use std::os::unix::fs::MetadataExt;
    let shown = path.display().to_string();
    let abs = if path.is_absolute() {
        path.to_path_buf()
    } else {
        std::env::current_dir()?.join(path)
    };
    let mut todo: Vec<std::ffi::OsString> = abs
        .components()
        .rev()
        .filter_map(|c| match c {
            std::path::Component::Normal(n) => Some(n.to_os_string()),
            std::path::Component::ParentDir => Some("..".into()),
            _ => None,
        })
        .collect();
    let mut at = PathBuf::from("/");
    let mut at_meta = std::fs::symlink_metadata(&at)?;
    let mut links = 0;
    while let Some(name) = todo.pop() {
        if name == ".." {
            at.pop();
            at_meta = std::fs::symlink_metadata(&at)?;
            continue;
        }
        let next = at.join(&name);
        let meta = match std::fs::symlink_metadata(&next) {
            Ok(m) => m,
            Err(e) if e.kind() == io::ErrorKind::NotFound => {
                at.push(&name);
                while let Some(rest) = todo.pop() {
                    at.push(rest);
                }
                return Ok((at, false));
            }
            Err(e) => return Err(io::Error::new(e.kind(), format!("{shown}: {e}"))),
        };
        // In a directory others may write, only a sticky bit keeps them from renaming our
        // entry, and only if the entry is ours (or root's).
        let mode = at_meta.mode();
        if mode & 0o022 != 0 && (mode & libc::S_ISVTX == 0 || !trusted_owner(&meta)) {
            let whose = if mode & libc::S_ISVTX == 0 {
                format!(
                    "{} may be written by group or others (mode {:04o}) and is not sticky",
                    at.display(),
                    mode & 0o7777
                )
            } else {
                format!(
                    "{} is owned by uid {} in the shared directory {}",
                    next.display(),
                    meta.uid(),
                    at.display()
                )
            };
            return Err(refused(format!(
                "refusing {shown}: another user could swap it for a link ({whose})"
            )));
        }
        if meta.file_type().is_symlink() {
            links += 1;
            if links > 40 {
                return Err(refused(format!(
                    "refusing {shown}: too many symbolic links"
                )));
            }
            let target = std::fs::read_link(&next)?;
            if target.is_absolute() {
                at = PathBuf::from("/");
                at_meta = std::fs::symlink_metadata(&at)?;
            }
            for c in target.components().rev() {
                match c {
                    std::path::Component::Normal(n) => todo.push(n.to_os_string()),
                    std::path::Component::ParentDir => todo.push("..".into()),
                    _ => {}
                }
            }
            continue;
        }
        if !meta.is_dir() {
            return Err(refused(format!(
                "refusing {shown}: {} is not a directory",
                next.display()
            )));
        }
        if !trusted_owner(&meta) {
            return Err(refused(format!(
                "refusing {shown}: {} is owned by uid {}, not by you (uid {}) or root, and its \
                 owner could swap what it holds",
                next.display(),
                meta.uid(),
                euid()
            )));
        }
        at = next;
        at_meta = meta;
    }
    check_own_dir(&shown, &at_meta)?;
    Ok((at, true))
}

/// The directory swarm writes into is this user's and no one else may write it.
fn check_own_dir(shown: &str, meta: &std::fs::Metadata) -> io::Result<()> {
    use std::os::unix::fs::MetadataExt;
    if meta.uid() != euid() {
        return Err(refused(format!(
            "refusing {shown}: it is owned by uid {}, not by you (uid {}); choose a directory \
             of your own",
            meta.uid(),
            euid()
        )));
    }
    let mode = meta.mode() & 0o7777;
    if mode & 0o022 != 0 {
        return Err(refused(format!(
            "refusing {shown}: group or others may write it (mode {mode:04o}); chmod go-w it \
             or choose another directory"
        )));
    }
    Ok(())
}

/// `mkdir` with mode 0755 whatever the umask leaves (a umask of 002 would make it group
/// writable, which [`check_path`] refuses), never through a link.
fn mkdir_private(parent: Option<&File>, path: &Path, name: &std::ffi::OsStr) -> io::Result<()> {
    use std::os::fd::AsRawFd;
    use std::os::unix::ffi::OsStrExt;
    let c = std::ffi::CString::new(name.as_bytes())
        .map_err(|_| io::Error::new(io::ErrorKind::InvalidInput, "NUL in a name"))?;
    match parent {
        // SAFETY: a valid descriptor and NUL-terminated name.
        Some(dir) => {
            if unsafe { libc::mkdirat(dir.as_raw_fd(), c.as_ptr(), 0o755) } != 0 {
                return Err(io::Error::last_os_error());
            }
            let fd = openat(
                dir,
                name,
                libc::O_RDONLY | libc::O_DIRECTORY | libc::O_NOFOLLOW,
                0,
            )?;
            fd.set_permissions(std::os::unix::fs::PermissionsExt::from_mode(0o755))
        }
        None => {
            std::fs::DirBuilder::new().mode(0o755).create(path)?;
            let fd = OpenOptions::new()
                .read(true)
                .custom_flags(libc::O_DIRECTORY | libc::O_NOFOLLOW)
                .open(path)?;
            fd.set_permissions(std::os::unix::fs::PermissionsExt::from_mode(0o755))
        }
    }
}

/// `openat(dir, name, flags | O_CLOEXEC, mode)` as a `File`.
fn openat(dir: &File, name: &std::ffi::OsStr, flags: i32, mode: u32) -> io::Result<File> {
    use std::os::fd::{AsRawFd, FromRawFd};
    use std::os::unix::ffi::OsStrExt;
    let c = std::ffi::CString::new(name.as_bytes())
        .map_err(|_| io::Error::new(io::ErrorKind::InvalidInput, "NUL in a name"))?;
    // SAFETY: a valid descriptor and NUL-terminated name; the returned descriptor is ours.
    let fd = unsafe {
        libc::openat(
            dir.as_raw_fd(),
            c.as_ptr(),
            flags | libc::O_CLOEXEC,
            mode as libc::c_uint,
        )
    };
    if fd < 0 {
        return Err(io::Error::last_os_error());
    }
    Ok(unsafe { File::from_raw_fd(fd) })
}

fn id_of(meta: &std::fs::Metadata) -> DirId {
    use std::os::unix::fs::MetadataExt;
    DirId {
        dev: meta.dev(),
        ino: meta.ino(),
    }
}

/// How a file is opened inside an [`OutDir`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Open {
    /// Write-only, created if missing, truncated.
    Create,
    /// Append, created if missing.
    Append,
    /// Read and write, created if missing, never truncated (a lock, a log).
    ReadWrite,
    /// Write an existing file (to cut it back with `set_len`).
    Existing,
    /// Read an existing regular file (never blocking on a FIFO).
    Read,
}

impl OutDir {
    /// Checks `path` ([`check_path`]), creates what of it is missing (mode 0755), and opens
    /// it. Used for a directory swarm is about to fill.
    pub fn create(path: &Path) -> io::Result<OutDir> {
        let (resolved, exists) = check_path(path)?;
        if !exists {
            // Each missing component is made by this process, inside a directory that
            // passed; a component that appears meanwhile is checked again.
            let mut at = PathBuf::from("/");
            for c in resolved.components().skip(1) {
                at.push(c);
                match mkdir_private(None, &at, c.as_os_str()) {
                    Ok(()) => {}
                    Err(e) if e.kind() == io::ErrorKind::AlreadyExists => {}
                    Err(e) => {
                        return Err(io::Error::new(
                            e.kind(),
                            format!("cannot create {}: {e}", at.display()),
                        ));
                    }
                }
            }
            check_path(&resolved)?;
        }
        OutDir::open_resolved(path, &resolved)
    }

    /// Checks an existing `path` ([`check_path`]) and opens it.
    pub fn open(path: &Path) -> io::Result<OutDir> {
        let (resolved, exists) = check_path(path)?;
        if !exists {
            return Err(io::Error::new(
                io::ErrorKind::NotFound,
                format!("{}: no such directory", path.display()),
            ));
        }
        OutDir::open_resolved(path, &resolved)
    }

    /// Opens `path` for a process the orchestrator started to write into the directory it
    /// checked: checked again, and refused unless it is the very directory `id` names.
    pub fn open_expected(path: &Path, id: DirId) -> io::Result<OutDir> {
        let dir = OutDir::open(path)?;
        if dir.id != id {
            return Err(refused(format!(
                "refusing {}: it is no longer the directory swarm checked ({} is now {}); \
                 something replaced it during the run",
                path.display(),
                id,
                dir.id
            )));
        }
        Ok(dir)
    }

    fn open_resolved(shown: &Path, resolved: &Path) -> io::Result<OutDir> {
        let dir = OpenOptions::new()
            .read(true)
            .custom_flags(libc::O_DIRECTORY | libc::O_NOFOLLOW)
            .open(resolved)
            .map_err(|e| io::Error::new(e.kind(), format!("{}: {e}", shown.display())))?;
        // The properties checked by path, checked again on the handle itself: what was
        // opened is what passed.
        let meta = dir.metadata()?;
        check_own_dir(&shown.display().to_string(), &meta)?;
        Ok(OutDir {
            id: id_of(&meta),
            dir,
            path: shown.to_path_buf(),
        })
    }

    /// The path the user gave, for messages.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// `path()/name`, for messages and for libraries that want a path to read.
    pub fn join(&self, name: impl AsRef<Path>) -> PathBuf {
        self.path.join(name)
    }

    /// Which directory this is.
    pub fn id(&self) -> DirId {
        self.id
    }

    fn name<'a>(&self, name: &'a str) -> io::Result<&'a std::ffi::OsStr> {
        if name.is_empty() || name.contains('/') || name == "." || name == ".." {
            return Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                format!("{name:?} is not a file name"),
            ));
        }
        Ok(std::ffi::OsStr::new(name))
    }

    /// Opens `name` inside the directory as `how` says, never following a link at the name
    /// (refused with [`SymlinkRefused`]) and never blocking on a FIFO.
    pub fn file(&self, name: &str, how: Open) -> io::Result<File> {
        let n = self.name(name)?;
        let flags = libc::O_NOFOLLOW
            | match how {
                Open::Create => libc::O_WRONLY | libc::O_CREAT | libc::O_TRUNC,
                Open::Append => libc::O_WRONLY | libc::O_CREAT | libc::O_APPEND,
                Open::ReadWrite => libc::O_RDWR | libc::O_CREAT,
                Open::Existing => libc::O_WRONLY | libc::O_NONBLOCK,
                Open::Read => libc::O_RDONLY | libc::O_NONBLOCK,
            };
        let file = match openat(&self.dir, n, flags, 0o644) {
            Ok(f) => f,
            Err(e) if e.raw_os_error() == Some(libc::ELOOP) && self.is_link(name) => {
                return Err(symlink_error(&self.join(name)));
            }
            Err(e) => return Err(e),
        };
        if !file.metadata()?.is_file() {
            return Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                format!("{} is not a regular file", self.join(name).display()),
            ));
        }
        if matches!(how, Open::Existing | Open::Read) {
            // Back to blocking reads and writes, as a regular file's always are.
            use std::os::fd::AsRawFd;
            // SAFETY: fcntl on a descriptor we own.
            unsafe {
                let fl = libc::fcntl(file.as_raw_fd(), libc::F_GETFL);
                libc::fcntl(file.as_raw_fd(), libc::F_SETFL, fl & !libc::O_NONBLOCK);
            }
        }
        Ok(file)
    }

    /// Whether `name` is a symbolic link in the directory.
    fn is_link(&self, name: &str) -> bool {
        self.stat(name).is_some_and(|m| m.is_symlink)
    }

    /// `name`'s type without following a link, if it exists.
    pub fn stat(&self, name: &str) -> Option<Entry> {
        use std::os::fd::AsRawFd;
        let n = self.name(name).ok()?;
        let c = std::ffi::CString::new(std::os::unix::ffi::OsStrExt::as_bytes(n)).ok()?;
        // SAFETY: zeroed stat is valid; fstatat only writes it.
        let mut st: libc::stat = unsafe { std::mem::zeroed() };
        let r = unsafe {
            libc::fstatat(
                self.dir.as_raw_fd(),
                c.as_ptr(),
                &mut st,
                libc::AT_SYMLINK_NOFOLLOW,
            )
        };
        (r == 0).then(|| Entry {
            name: name.to_string(),
            is_dir: st.st_mode & libc::S_IFMT == libc::S_IFDIR,
            is_symlink: st.st_mode & libc::S_IFMT == libc::S_IFLNK,
        })
    }

    /// Writes `bytes` into `name` (created or truncated).
    pub fn write(&self, name: &str, bytes: impl AsRef<[u8]>) -> io::Result<()> {
        self.file(name, Open::Create)?.write_all(bytes.as_ref())
    }

    /// Reads the regular file `name`.
    pub fn read(&self, name: &str) -> io::Result<Vec<u8>> {
        let mut out = Vec::new();
        io::Read::read_to_end(&mut self.file(name, Open::Read)?, &mut out)?;
        Ok(out)
    }

    /// Writes `bytes` to `name` atomically: into `<name>.tmp`, then renamed into place; a link
    /// at either name is refused. On an error the temporary file is removed.
    pub fn write_replace(&self, name: &str, bytes: impl AsRef<[u8]>) -> io::Result<()> {
        let tmp = format!("{name}.tmp");
        let written = self
            .write(&tmp, bytes)
            .and_then(|()| self.rename(&tmp, name));
        if let Err(e) = written {
            if !self.is_link(&tmp) {
                let _ = self.remove_file(&tmp);
            }
            return Err(e);
        }
        Ok(())
    }

    /// Renames `from` to `to` inside the directory; a link at `to` is refused.
    pub fn rename(&self, from: &str, to: &str) -> io::Result<()> {
        use std::os::fd::AsRawFd;
        use std::os::unix::ffi::OsStrExt;
        let (f, t) = (self.name(from)?, self.name(to)?);
        if self.is_link(to) {
            return Err(symlink_error(&self.join(to)));
        }
        let (f, t) = (
            std::ffi::CString::new(f.as_bytes())?,
            std::ffi::CString::new(t.as_bytes())?,
        );
        let fd = self.dir.as_raw_fd();
        // SAFETY: valid descriptor and NUL-terminated names.
        if unsafe { libc::renameat(fd, f.as_ptr(), fd, t.as_ptr()) } != 0 {
            return Err(io::Error::last_os_error());
        }
        Ok(())
    }

    /// Removes the file (or link) `name`; never what a link points to.
    pub fn remove_file(&self, name: &str) -> io::Result<()> {
        self.unlink(name, 0)
    }

    fn unlink(&self, name: &str, flags: i32) -> io::Result<()> {
        use std::os::fd::AsRawFd;
        let c = std::ffi::CString::new(std::os::unix::ffi::OsStrExt::as_bytes(self.name(name)?))?;
        // SAFETY: valid descriptor and NUL-terminated name.
        if unsafe { libc::unlinkat(self.dir.as_raw_fd(), c.as_ptr(), flags) } != 0 {
            return Err(io::Error::last_os_error());
        }
        Ok(())
    }

    /// Removes the subdirectory `name` and everything in it, through handles (a link inside
    /// is removed, never followed).
    pub fn remove_dir_all(&self, name: &str) -> io::Result<()> {
        let sub = self.subdir(name)?;
        for e in sub.entries()? {
            if e.is_dir {
                sub.remove_dir_all(&e.name)?;
            } else {
                sub.remove_file(&e.name)?;
            }
        }
        self.unlink(name, libc::AT_REMOVEDIR)
    }

    /// The subdirectory `name`, opened through this handle without following a link.
    pub fn subdir(&self, name: &str) -> io::Result<OutDir> {
        let n = self.name(name)?;
        let dir = match openat(
            &self.dir,
            n,
            libc::O_RDONLY | libc::O_DIRECTORY | libc::O_NOFOLLOW,
            0,
        ) {
            Ok(d) => d,
            // O_NOFOLLOW with O_DIRECTORY answers a link with ENOTDIR or ELOOP.
            Err(_) if self.is_link(name) => return Err(symlink_error(&self.join(name))),
            Err(e) => {
                return Err(io::Error::new(
                    e.kind(),
                    format!("{}: {e}", self.join(name).display()),
                ));
            }
        };
        let meta = dir.metadata()?;
        Ok(OutDir {
            id: id_of(&meta),
            dir,
            path: self.join(name),
        })
    }

    /// The subdirectory `name`, created (mode 0755) if missing.
    pub fn create_subdir(&self, name: &str) -> io::Result<OutDir> {
        match mkdir_private(Some(&self.dir), &self.join(name), self.name(name)?) {
            Ok(()) => {}
            Err(e) if e.kind() == io::ErrorKind::AlreadyExists => {}
            Err(e) => {
                return Err(io::Error::new(
                    e.kind(),
                    format!("cannot create {}: {e}", self.join(name).display()),
                ));
            }
        }
        self.subdir(name)
    }

    /// Creates a new subdirectory `base`, or `base-1`, `base-2`, ... if that exists: each
    /// name taken with one `mkdirat`, so two callers never get the same one.
    pub fn create_unused_subdir(&self, base: &str) -> io::Result<OutDir> {
        let mut name = base.to_string();
        let mut k = 1;
        loop {
            match mkdir_private(Some(&self.dir), &self.join(&name), self.name(&name)?) {
                Ok(()) => return self.subdir(&name),
                Err(e) if e.kind() == io::ErrorKind::AlreadyExists => {
                    name = format!("{base}-{k}");
                    k += 1;
                }
                Err(e) => {
                    return Err(io::Error::new(
                        e.kind(),
                        format!("cannot create {}: {e}", self.join(&name).display()),
                    ));
                }
            }
        }
    }

    /// The entries of the directory (without `.` and `..`), sorted by name, read through the
    /// handle (`fdopendir` on a duplicate of it), whatever the directory's path is now.
    pub fn entries(&self) -> io::Result<Vec<Entry>> {
        use std::os::fd::AsRawFd;
        // SAFETY: dup of a descriptor we own; fdopendir takes the duplicate, closedir frees
        // it; readdir's entries are read before the next call.
        let dup = unsafe { libc::fcntl(self.dir.as_raw_fd(), libc::F_DUPFD_CLOEXEC, 0) };
        if dup < 0 {
            return Err(io::Error::last_os_error());
        }
        let stream = unsafe { libc::fdopendir(dup) };
        if stream.is_null() {
            let e = io::Error::last_os_error();
            unsafe { libc::close(dup) };
            return Err(e);
        }
        // The duplicate shares the original's offset: start from the top.
        unsafe { libc::rewinddir(stream) };
        let mut out = Vec::new();
        loop {
            let ent = unsafe { libc::readdir(stream) };
            if ent.is_null() {
                break;
            }
            let name = unsafe { std::ffi::CStr::from_ptr((*ent).d_name.as_ptr()) };
            let name = name.to_string_lossy().into_owned();
            if name == "." || name == ".." {
                continue;
            }
            let kind = unsafe { (*ent).d_type };
            let (is_dir, is_symlink) = match kind {
                libc::DT_DIR => (true, false),
                libc::DT_LNK => (false, true),
                libc::DT_UNKNOWN => self
                    .stat(&name)
                    .map_or((false, false), |e| (e.is_dir, e.is_symlink)),
                _ => (false, false),
            };
            out.push(Entry {
                name,
                is_dir,
                is_symlink,
            });
        }
        unsafe { libc::closedir(stream) };
        out.sort_by(|a, b| a.name.cmp(&b.name));
        Ok(out)
    }

    /// A second handle on the same directory.
    pub fn try_clone(&self) -> io::Result<OutDir> {
        Ok(OutDir {
            dir: self.dir.try_clone()?,
            path: self.path.clone(),
            id: self.id,
        })
    }

    /// The open directory, e.g. to `flock` or `fsync` it.
    pub fn handle(&self) -> &File {
        &self.dir
    }
}

/// One entry of an [`OutDir`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Entry {
    /// Its name.
    pub name: String,
    /// A directory (not a link to one).
    pub is_dir: bool,
    /// A symbolic link.
    pub is_symlink: bool,
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

    fn chown(path: &Path, uid: u32) {
        std::os::unix::fs::chown(path, Some(uid), Some(uid)).unwrap();
    }

    fn chmod(path: &Path, mode: u32) {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(path, std::fs::Permissions::from_mode(mode)).unwrap();
    }

    fn refusal(r: io::Result<OutDir>) -> String {
        let e = r.expect_err("refused");
        assert!(DirRefused::of(&e).is_some(), "{e:?}");
        e.to_string()
    }

    #[test]
    fn a_directory_another_user_owns_or_may_write_is_refused() {
        let root = tempfile_lite::Dir::new();
        let theirs = root.path().join("theirs");
        std::fs::create_dir(&theirs).unwrap();
        chmod(&theirs, 0o777);
        if euid() == 0 {
            chown(&theirs, 47_123);
            let e = refusal(OutDir::open(&theirs));
            assert!(e.contains("is owned by uid 47123"), "{e}");
            // ...and a run directory inside it, which its owner could swap for a link.
            let e = refusal(OutDir::create(&theirs.join("run")));
            assert!(e.contains("theirs is owned by uid 47123"), "{e}");
        }
        let open = root.path().join("open");
        std::fs::create_dir(&open).unwrap();
        chmod(&open, 0o777);
        let e = refusal(OutDir::open(&open));
        assert!(
            e.contains("group or others may write it (mode 0777); chmod go-w it"),
            "{e}"
        );
        // A path through a writable directory that is not sticky: anyone could rename `run`.
        let e = refusal(OutDir::create(&open.join("run")));
        assert!(e.contains("is not sticky"), "{e}");
        // A sticky one, like /tmp, is fine for an entry of ours.
        let sticky = root.path().join("sticky");
        std::fs::create_dir(&sticky).unwrap();
        chmod(&sticky, 0o1777);
        let made = OutDir::create(&sticky.join("run").join("deeper")).unwrap();
        assert!(made.path().ends_with("run/deeper"));
        use std::os::unix::fs::PermissionsExt;
        let mode = std::fs::metadata(sticky.join("run"))
            .unwrap()
            .permissions()
            .mode();
        assert_eq!(mode & 0o777, 0o755);
        // A link to our own directory, in a directory of ours, is followed and checked.
        let link = root.path().join("link");
        symlink(sticky.join("run"), &link).unwrap();
        OutDir::open(&link).unwrap();
        // A file is no directory.
        let file = root.path().join("file");
        std::fs::write(&file, "x").unwrap();
        assert!(refusal(OutDir::open(&file)).contains("is not a directory"));
    }

    #[test]
    fn writes_go_where_the_check_was_made_whatever_replaces_the_path() {
        let root = tempfile_lite::Dir::new();
        let victim = root.path().join("victim");
        std::fs::create_dir(&victim).unwrap();
        std::fs::write(victim.join("config.toml"), "keep").unwrap();
        let run = root.path().join("run");
        let dir = OutDir::create(&run).unwrap();
        dir.write("a.txt", "1").unwrap();
        // The path is swapped for a link to the victim after the check...
        std::fs::rename(&run, root.path().join("run.old")).unwrap();
        symlink(&victim, &run).unwrap();
        // ...and every write still lands in the directory that was checked.
        dir.write("config.toml", "run").unwrap();
        dir.write_replace("metrics.json", "{}").unwrap();
        dir.file("trajectory.csv", Open::Append)
            .unwrap()
            .write_all(b"x\n")
            .unwrap();
        let sub = dir.create_subdir("storage").unwrap();
        sub.write("raft-0.state", "s").unwrap();
        assert_eq!(
            std::fs::read_to_string(victim.join("config.toml")).unwrap(),
            "keep"
        );
        assert_eq!(std::fs::read_dir(&victim).unwrap().count(), 1);
        let old = root.path().join("run.old");
        assert_eq!(
            std::fs::read_to_string(old.join("config.toml")).unwrap(),
            "run"
        );
        assert!(old.join("metrics.json").is_file() && old.join("storage/raft-0.state").is_file());
        let names: Vec<String> = dir.entries().unwrap().into_iter().map(|e| e.name).collect();
        assert_eq!(
            names,
            [
                "a.txt",
                "config.toml",
                "metrics.json",
                "storage",
                "trajectory.csv"
            ]
        );
        // A process opening the path again is refused: it is not the directory checked.
        let e = refusal(OutDir::open_expected(&run, dir.id()));
        assert!(
            e.contains("is no longer the directory swarm checked"),
            "{e}"
        );
        OutDir::open_expected(&old, dir.id()).unwrap();
        assert_eq!(dir.id().to_string().parse::<DirId>().unwrap(), dir.id());
    }

    #[test]
    fn links_fifos_and_subdirectories_are_handled_through_the_handle() {
        let root = tempfile_lite::Dir::new();
        let dir = OutDir::create(&root.path().join("run")).unwrap();
        let outside = root.path().join("outside");
        std::fs::create_dir(&outside).unwrap();
        std::fs::write(outside.join("keep"), "keep").unwrap();
        symlink(&outside, dir.join("storage")).unwrap();
        symlink(outside.join("keep"), dir.join("metrics.json")).unwrap();
        // A planted link is refused by every opener and by rename; never followed.
        let link = dir.join("metrics.json");
        for how in [
            Open::Create,
            Open::Append,
            Open::ReadWrite,
            Open::Existing,
            Open::Read,
        ] {
            assert_refused(dir.file("metrics.json", how).unwrap_err(), &link);
        }
        assert_refused(dir.write_replace("metrics.json", "x").unwrap_err(), &link);
        assert!(is_symlink_refusal(&dir.subdir("storage").unwrap_err()));
        // Removing the links removes the links only.
        dir.remove_file("metrics.json").unwrap();
        dir.remove_file("storage").unwrap();
        assert_eq!(
            std::fs::read_to_string(outside.join("keep")).unwrap(),
            "keep"
        );
        // A FIFO is not a file to read or append to, and opening it does not block.
        let fifo = std::ffi::CString::new(dir.join("trajectory.csv").to_str().unwrap()).unwrap();
        assert_eq!(unsafe { libc::mkfifo(fifo.as_ptr(), 0o644) }, 0);
        let e = dir.file("trajectory.csv", Open::Read).unwrap_err();
        assert!(e.to_string().ends_with("is not a regular file"), "{e}");
        assert!(dir.file("trajectory.csv", Open::Existing).is_err());
        // A tree with a link inside is removed without following it.
        let sub = dir.create_subdir("config").unwrap();
        sub.write("iceoryx2.toml", "x").unwrap();
        symlink(&outside, sub.join("out")).unwrap();
        dir.remove_dir_all("config").unwrap();
        assert!(dir.stat("config").is_none());
        assert!(outside.join("keep").is_file());
        // Names are single components.
        assert!(dir.write("../escape", "x").is_err());
        assert!(!root.path().join("escape").exists());
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
