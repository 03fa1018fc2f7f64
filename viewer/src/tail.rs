//! Reading a record as it grows: the whole lines appended since the last look, in blocks, so
//! a live run costs one read of its new bytes and a large finished run is never held in
//! memory at once.

use std::fs::File;
use std::io::{Read, Seek, SeekFrom};
use std::path::Path;

/// Bytes read at a time.
const BLOCK: usize = 8 << 20;

/// Calls `line(text, offset, next)` for every whole line of `path` from byte `from` on
/// (`offset` where it starts, `next` where the following one does) and returns the byte after
/// the last whole line. A missing file has no lines; a line still being written waits.
pub fn lines_from(
    path: &Path,
    from: u64,
    mut line: impl FnMut(&[u8], u64, u64),
) -> std::io::Result<u64> {
    let mut file = match File::open(path) {
        Ok(f) => f,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(from),
        Err(e) => return Err(e),
    };
    let len = file.metadata()?.len();
    if len <= from {
        return Ok(from);
    }
    file.seek(SeekFrom::Start(from))?;
    let mut reader = file.take(len - from);
    let mut done = from;
    let mut buf: Vec<u8> = Vec::with_capacity(BLOCK.min((len - from) as usize));
    loop {
        let had = buf.len();
        buf.resize(had + BLOCK, 0);
        let n = reader.read(&mut buf[had..])?;
        buf.truncate(had + n);
        if n == 0 {
            return Ok(done);
        }
        let mut at = 0usize;
        while let Some(nl) = buf[at..].iter().position(|&b| b == b'\n') {
            let offset = done + at as u64;
            line(&buf[at..at + nl], offset, offset + nl as u64 + 1);
            at += nl + 1;
        }
        done += at as u64;
        buf.drain(..at);
    }
}

/// Bytes `start..end` of `path`.
pub fn read_range(path: &Path, start: u64, end: u64) -> std::io::Result<Vec<u8>> {
    let mut file = File::open(path)?;
    file.seek(SeekFrom::Start(start))?;
    let mut buf = vec![0u8; end.saturating_sub(start) as usize];
    file.read_exact(&mut buf)?;
    Ok(buf)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn whole_lines_with_their_offsets_and_a_waiting_tail() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("f");
        std::fs::write(&path, "ab\ncde\nf").unwrap();
        let mut seen = Vec::new();
        let end = lines_from(&path, 0, |l, o, n| seen.push((l.to_vec(), o, n))).unwrap();
        assert_eq!(end, 7);
        assert_eq!(seen, [(b"ab".to_vec(), 0, 3), (b"cde".to_vec(), 3, 7)]);
        assert_eq!(read_range(&path, 3, 6).unwrap(), b"cde");
        assert_eq!(
            lines_from(&dir.path().join("none"), 5, |_, _, _| {}).unwrap(),
            5
        );
    }
}
