//! Reading a record as it grows: the whole lines appended since the last look, in blocks, so
//! a live run costs one read of its new bytes and a large finished run is never held in
//! memory at once.
//!
//! Every byte is read once: a line still being written is kept (at most [`MAX_LINE`] of it)
//! and completed by the next look, never read again. A line longer than [`MAX_LINE`] is no
//! line a run writes: it is skipped and counted, and its bytes are dropped as they are read,
//! so a hostile file (a gigabyte without a newline) costs one pass and a bounded buffer.

use std::fs::File;
use std::io;
use std::os::unix::fs::FileExt;
use std::path::{Path, PathBuf};

use crate::files::open_record;

/// The longest line a record may have, in bytes (the longest a run writes is a note of a few
/// hundred bytes); a longer line is skipped and counted.
pub const MAX_LINE: usize = 64 << 10;
/// Bytes read at a time.
const BLOCK: usize = 1 << 20;

/// Cuts bytes into lines, holding at most [`MAX_LINE`] bytes of an unterminated one.
#[derive(Debug, Default)]
struct Splitter {
    /// The unterminated line so far, and the offset of its first byte.
    partial: Vec<u8>,
    partial_at: u64,
    /// The unterminated line is longer than [`MAX_LINE`]: drop bytes until its newline.
    skipping: bool,
    /// Lines longer than [`MAX_LINE`] met so far (counted when they pass the cap).
    long_lines: u64,
}

impl Splitter {
    /// Feeds `bytes`, which start at offset `base`; calls `line(text, offset, next)` for each
    /// line they complete.
    fn feed(&mut self, bytes: &[u8], base: u64, line: &mut impl FnMut(&[u8], u64, u64)) {
        let mut at = 0usize;
        while let Some(k) = bytes[at..].iter().position(|&b| b == b'\n') {
            let nl = at + k;
            let next = base + nl as u64 + 1;
            let piece = &bytes[at..nl];
            if self.skipping {
                self.skipping = false;
            } else if self.partial.is_empty() {
                if piece.len() > MAX_LINE {
                    self.long_lines += 1;
                } else {
                    line(piece, base + at as u64, next);
                }
            } else if self.partial.len() + piece.len() > MAX_LINE {
                self.long_lines += 1;
                self.partial.clear();
            } else {
                self.partial.extend_from_slice(piece);
                line(&self.partial, self.partial_at, next);
                self.partial.clear();
            }
            at = nl + 1;
        }
        let rest = &bytes[at..];
        if rest.is_empty() || self.skipping {
            return;
        }
        if self.partial.is_empty() {
            self.partial_at = base + at as u64;
        }
        if self.partial.len() + rest.len() > MAX_LINE {
            self.long_lines += 1;
            self.skipping = true;
            self.partial = Vec::new();
        } else {
            self.partial.extend_from_slice(rest);
        }
    }
}

/// Reads `file` from `from` up to `to`, a block at a time, into `split`; returns where it
/// stopped (before `to` if the file is shorter now).
fn read_into(
    file: &File,
    from: u64,
    to: u64,
    split: &mut Splitter,
    line: &mut impl FnMut(&[u8], u64, u64),
) -> io::Result<u64> {
    let mut block = vec![0u8; BLOCK.min(to.saturating_sub(from) as usize)];
    let mut at = from;
    while at < to {
        let want = ((to - at) as usize).min(block.len());
        let n = match file.read_at(&mut block[..want], at) {
            Ok(0) => break,
            Ok(n) => n,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(e),
        };
        split.feed(&block[..n], at, line);
        at += n as u64;
    }
    Ok(at)
}

/// One record followed as it grows.
#[derive(Debug, Default)]
pub struct Tail {
    path: PathBuf,
    /// The next byte to read.
    read_to: u64,
    split: Splitter,
}

impl Tail {
    /// A tail of `path`; nothing is read until [`Tail::read_new`].
    pub fn new(path: &Path) -> Tail {
        Tail {
            path: path.to_path_buf(),
            ..Tail::default()
        }
    }

    /// The record's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Calls `line(text, offset, next)` for every whole line appended since the last call
    /// (`offset` where it starts, `next` where the following one does). A missing file has
    /// no lines; a line still being written waits for its newline.
    pub fn read_new(&mut self, mut line: impl FnMut(&[u8], u64, u64)) -> io::Result<()> {
        let Some(file) = open_record(&self.path)? else {
            return Ok(());
        };
        let len = file.metadata()?.len();
        if len > self.read_to {
            self.read_to = read_into(&file, self.read_to, len, &mut self.split, &mut line)?;
        }
        Ok(())
    }

    /// Lines longer than [`MAX_LINE`] skipped so far.
    pub fn long_lines(&self) -> u64 {
        self.split.long_lines
    }

    /// Whether bytes were read past the last whole line (a torn line, or one being written).
    pub fn pending(&self) -> bool {
        self.split.skipping || !self.split.partial.is_empty()
    }
}

/// Calls `line(text)` for each line in bytes `start..end` of `path` (a range of whole lines a
/// [`Tail`] found; a trailing `\r` is dropped), reading a block at a time.
pub fn lines_in(path: &Path, start: u64, end: u64, mut line: impl FnMut(&[u8])) -> io::Result<()> {
    let file = open_record(path)?.ok_or_else(|| {
        io::Error::new(
            io::ErrorKind::NotFound,
            format!("{} is gone", path.display()),
        )
    })?;
    let mut split = Splitter::default();
    read_into(&file, start, end, &mut split, &mut |l: &[u8], _, _| {
        line(l.strip_suffix(b"\r").unwrap_or(l))
    })?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    fn lines(tail: &mut Tail) -> Vec<(Vec<u8>, u64, u64)> {
        let mut seen = Vec::new();
        tail.read_new(|l, o, n| seen.push((l.to_vec(), o, n)))
            .unwrap();
        seen
    }

    #[test]
    fn whole_lines_with_their_offsets_and_a_waiting_tail() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("f");
        std::fs::write(&path, "ab\ncde\nf").unwrap();
        let mut tail = Tail::new(&path);
        assert_eq!(
            lines(&mut tail),
            [(b"ab".to_vec(), 0, 3), (b"cde".to_vec(), 3, 7)]
        );
        assert!(tail.pending());
        let mut f = std::fs::OpenOptions::new()
            .append(true)
            .open(&path)
            .unwrap();
        f.write_all(b"gh\ni").unwrap();
        assert_eq!(lines(&mut tail), [(b"fgh".to_vec(), 7, 11)]);
        let mut got = Vec::new();
        lines_in(&path, 3, 11, |l| got.push(l.to_vec())).unwrap();
        assert_eq!(got, [b"cde".to_vec(), b"fgh".to_vec()]);
        let mut none = Tail::new(&dir.path().join("none"));
        assert!(lines(&mut none).is_empty());
    }

    #[test]
    fn a_line_longer_than_the_cap_is_skipped_counted_and_never_held_or_reread() {
        let mut s = Splitter::default();
        let mut seen = Vec::new();
        let mut push = |l: &[u8], o: u64, _n: u64| seen.push((l.len(), o));
        s.feed(b"ok\n", 0, &mut push);
        let big = vec![b'x'; MAX_LINE];
        s.feed(&big, 3, &mut push);
        assert_eq!(s.partial.len(), MAX_LINE, "exactly the cap is still a line");
        s.feed(b"y", 3 + MAX_LINE as u64, &mut push);
        assert!(
            s.skipping && s.partial.capacity() == 0,
            "the long line is dropped"
        );
        assert_eq!(s.long_lines, 1);
        for k in 0..4u64 {
            s.feed(&big, 4 + MAX_LINE as u64 * (k + 1), &mut push);
        }
        assert_eq!(s.long_lines, 1, "counted once");
        s.feed(b"zz\nnext\n", 100, &mut push);
        let whole_at_cap = vec![b'w'; MAX_LINE + 1];
        s.feed(&whole_at_cap, 200, &mut push);
        s.feed(b"\n", 200 + MAX_LINE as u64 + 1, &mut push);
        assert_eq!(s.long_lines, 2);
        let mut in_one_block = vec![b'v'; MAX_LINE + 1];
        in_one_block.extend_from_slice(b"\nlast\n");
        s.feed(&in_one_block, 300, &mut push);
        assert_eq!(s.long_lines, 3);
        assert_eq!(seen, [(2, 0), (4, 103), (4, 300 + MAX_LINE as u64 + 2)]);
    }
}
