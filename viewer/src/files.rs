//! Opening a run directory's files to read them, safely for a directory someone else made: a
//! FIFO, a device or a symbolic link at a record's name is refused, never opened as a record
//! (a FIFO would block `open` for ever, a device could be read without end).

use std::fs::{File, OpenOptions};
use std::io::{self, Read};
use std::os::unix::fs::{FileTypeExt, OpenOptionsExt};
use std::path::Path;

/// A file of the run that is not a regular file; its message is one line naming it.
#[derive(Debug, thiserror::Error)]
#[error("{path} is {what}, not a regular file; refusing to read it")]
pub struct NotRegular {
    /// The path.
    pub path: String,
    /// What it is instead (`a FIFO`, `a symbolic link`, ...).
    pub what: &'static str,
}

fn refused(path: &Path, what: &'static str) -> io::Error {
    io::Error::new(
        io::ErrorKind::InvalidData,
        NotRegular {
            path: path.display().to_string(),
            what,
        },
    )
}

/// Opens `path` to read it: `O_NONBLOCK` (so a FIFO cannot block the open) and `O_NOFOLLOW`
/// (so a link is not followed), then `fstat` must say it is a regular file. `Ok(None)` when
/// it does not exist.
pub fn open_record(path: &Path) -> io::Result<Option<File>> {
    let opened = OpenOptions::new()
        .read(true)
        .custom_flags(libc::O_NONBLOCK | libc::O_NOFOLLOW)
        .open(path);
    let file = match opened {
        Ok(f) => f,
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(None),
        Err(e) if e.raw_os_error() == Some(libc::ELOOP) => {
            return Err(refused(path, "a symbolic link"));
        }
        Err(e) => return Err(e),
    };
    let kind = file.metadata()?.file_type();
    if kind.is_file() {
        return Ok(Some(file));
    }
    let what = if kind.is_fifo() {
        "a FIFO"
    } else if kind.is_char_device() {
        "a character device"
    } else if kind.is_block_device() {
        "a block device"
    } else if kind.is_socket() {
        "a socket"
    } else if kind.is_dir() {
        "a directory"
    } else {
        "not a file"
    };
    Err(refused(path, what))
}

/// The bytes of `path` if it is a regular file of at most `cap` bytes (`Ok(None)` when it is
/// missing); a longer one is an error, not read.
pub fn read_capped(path: &Path, cap: u64) -> io::Result<Option<Vec<u8>>> {
    let Some(file) = open_record(path)? else {
        return Ok(None);
    };
    let len = file.metadata()?.len();
    if len > cap {
        return Err(io::Error::new(
            io::ErrorKind::InvalidData,
            format!("{} is larger than {cap} bytes", path.display()),
        ));
    }
    let mut bytes = Vec::with_capacity(len as usize);
    file.take(cap).read_to_end(&mut bytes)?;
    Ok(Some(bytes))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_fifo_a_device_and_a_link_are_refused_without_blocking() {
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("trajectory.csv");
        let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
        // SAFETY: a valid NUL-terminated path.
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o644) }, 0);
        let e = open_record(&fifo).unwrap_err();
        assert!(
            e.to_string()
                .ends_with("is a FIFO, not a regular file; refusing to read it")
        );
        let link = dir.path().join("events.jsonl");
        std::os::unix::fs::symlink("/dev/zero", &link).unwrap();
        let e = open_record(&link).unwrap_err();
        assert!(e.to_string().contains("is a symbolic link"), "{e}");
        let e = open_record(Path::new("/dev/zero")).unwrap_err();
        assert!(e.to_string().contains("a character device"), "{e}");
        assert!(open_record(&dir.path().join("none")).unwrap().is_none());
        let file = dir.path().join("metrics.json");
        std::fs::write(&file, "{}").unwrap();
        assert_eq!(read_capped(&file, 2).unwrap().unwrap(), b"{}");
        assert!(read_capped(&file, 1).is_err());
    }
}
