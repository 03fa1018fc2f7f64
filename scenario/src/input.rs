//! Reading a file the user names as input (a config) without trusting what it is: opened
//! without blocking (a FIFO with no writer, a device), refused unless it is a regular file,
//! and never read past a bound (`/dev/zero`, a file that grows while it is read).

use std::fs::{File, OpenOptions};
use std::io::Read;
use std::os::unix::fs::{FileTypeExt, OpenOptionsExt};
use std::path::Path;

/// The text of the regular file at `path`, at most `max` bytes of UTF-8, or a one-line reason
/// (without the path: the caller names the file). The file is opened with `O_NONBLOCK`, so
/// opening a FIFO returns at once, and checked with `fstat` on that descriptor before a byte
/// is read; at most `max + 1` bytes are read, so a device or a growing file cannot fill memory.
pub fn read_bounded(path: &Path, max: u64) -> Result<String, String> {
    let file = OpenOptions::new()
        .read(true)
        .custom_flags(libc::O_NONBLOCK | libc::O_NOCTTY)
        .open(path)
        .map_err(|e| format!("cannot read: {e}"))?;
    let meta = file.metadata().map_err(|e| format!("cannot read: {e}"))?;
    if !meta.is_file() {
        return Err(format!(
            "cannot read: {}, not a regular file",
            kind(&meta.file_type())
        ));
    }
    if meta.len() > max {
        return Err(too_big(max, &format!("{} bytes", meta.len())));
    }
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    read_at_most(file, max + 1, &mut bytes)?;
    if bytes.len() as u64 > max {
        return Err(too_big(max, "it grew while it was read"));
    }
    String::from_utf8(bytes).map_err(|e| {
        format!(
            "not UTF-8 text (invalid byte at offset {})",
            e.utf8_error().valid_up_to()
        )
    })
}

/// `what` is too much for `max` bytes, in words.
pub fn too_big(max: u64, what: &str) -> String {
    format!("expected at most {max} bytes ({}), got {what}", human(max))
}

/// `n` bytes as `1 MiB`, `64 KiB` or `100 bytes`.
fn human(n: u64) -> String {
    match n {
        n if n >= 1 << 20 && n % (1 << 20) == 0 => format!("{} MiB", n >> 20),
        n if n >= 1 << 10 && n % (1 << 10) == 0 => format!("{} KiB", n >> 10),
        n => format!("{n} bytes"),
    }
}

/// Reads `file` until its end or `limit` bytes. A regular file opened `O_NONBLOCK` still
/// reads as usual; `WouldBlock` cannot happen on one, and is an error rather than a spin.
fn read_at_most(file: File, limit: u64, out: &mut Vec<u8>) -> Result<(), String> {
    file.take(limit)
        .read_to_end(out)
        .map(|_| ())
        .map_err(|e| format!("cannot read: {e}"))
}

/// What a non-regular file is, in words.
fn kind(t: &std::fs::FileType) -> &'static str {
    if t.is_dir() {
        "a directory"
    } else if t.is_fifo() {
        "a FIFO (named pipe)"
    } else if t.is_char_device() {
        "a character device"
    } else if t.is_block_device() {
        "a block device"
    } else if t.is_socket() {
        "a socket"
    } else {
        "not a file"
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmp(name: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("swarmrt-input-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn a_regular_file_within_the_bound_is_read_whole() {
        let dir = tmp("ok");
        let p = dir.join("c.toml");
        std::fs::write(&p, "a = 1\n").unwrap();
        assert_eq!(read_bounded(&p, 6).unwrap(), "a = 1\n");
        let e = read_bounded(&p, 5).unwrap_err();
        assert_eq!(e, "expected at most 5 bytes (5 bytes), got 6 bytes");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn devices_fifos_and_directories_are_refused_without_reading() {
        let e = read_bounded(Path::new("/dev/zero"), 1 << 20).unwrap_err();
        assert!(e.contains("character device"), "{e}");
        let dir = tmp("fifo");
        let fifo = dir.join("pipe.toml");
        let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
        // SAFETY: mkfifo on a NUL-terminated path.
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
        // No writer ever opens it: a blocking open would wait for ever.
        let e = read_bounded(&fifo, 1 << 20).unwrap_err();
        assert!(e.contains("FIFO"), "{e}");
        let e = read_bounded(&dir, 1 << 20).unwrap_err();
        assert!(e.contains("directory"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_file_that_is_not_utf8_is_refused_with_the_offset() {
        let dir = tmp("utf8");
        let p = dir.join("c.toml");
        std::fs::write(&p, b"ab\xffc").unwrap();
        assert!(read_bounded(&p, 100).unwrap_err().contains("offset 2"));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn sizes_read_as_people_write_them() {
        assert_eq!(human(1 << 20), "1 MiB");
        assert_eq!(human(64 << 10), "64 KiB");
        assert_eq!(human(100), "100 bytes");
    }
}
