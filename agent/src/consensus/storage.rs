//! Stable storage for a robot's persistent Raft state (Figure 2: term, vote and log, plus the
//! commit index), so a restarted robot process cannot vote twice in one term.
//!
//! One file per robot, `raft-<id>.state`: an append-only sequence of records, each a whole
//! snapshot of [`Persistent`] framed as `[len: u32 LE][crc32: u32 LE][postcard bytes]`. A save
//! appends one record and `fsync`s before the caller lets any message that depends on it
//! leave (write-ahead). Loading keeps the last record whose length and checksum are whole, so a
//! write torn by a crash falls back to the state before it, and the torn tail is cut off
//! before the next append. When the file grows past [`COMPACT_BYTES`] it is replaced by one
//! record (written to a temporary file, synced, renamed, directory synced).
//!
//! [`encode_record`] and [`last_good`] are the pure halves, used by the in-process model and
//! the tests.

use std::fs::{File, OpenOptions};
use std::io::{Read, Write};
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::log::Log;
use super::messages::Entry;
use super::raft::Persistent;

/// A file larger than this is compacted to one record on the next save.
pub const COMPACT_BYTES: u64 = 256 * 1024;

/// What is stored: [`Persistent`] in a serde shape.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct Stored {
    term: u64,
    vote: Option<u32>,
    commit: u64,
    entries: Vec<Entry>,
}

/// `state` framed as one record.
pub fn encode_record(state: &Persistent) -> Vec<u8> {
    let stored = Stored {
        term: state.term,
        vote: state.vote,
        commit: state.commit,
        entries: state.log.entries().to_vec(),
    };
    let body = postcard::to_allocvec(&stored).expect("the persistent state always encodes");
    let mut out = Vec::with_capacity(body.len() + 8);
    out.extend_from_slice(&(body.len() as u32).to_le_bytes());
    out.extend_from_slice(&crc32fast::hash(&body).to_le_bytes());
    out.extend_from_slice(&body);
    out
}

/// The state of the last whole, checksummed record in `bytes`, and the length of the good
/// prefix (where a torn tail starts).
pub fn last_good(bytes: &[u8]) -> (Option<Persistent>, usize) {
    let mut at = 0;
    let mut state = None;
    while bytes.len() - at >= 8 {
        let len = u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap()) as usize;
        let crc = u32::from_le_bytes(bytes[at + 4..at + 8].try_into().unwrap());
        let Some(body) = bytes.get(at + 8..at + 8 + len) else {
            break;
        };
        if crc32fast::hash(body) != crc {
            break;
        }
        let Ok(s) = postcard::from_bytes::<Stored>(body) else {
            break;
        };
        state = Some(Persistent {
            term: s.term,
            vote: s.vote,
            commit: s.commit,
            log: Log::from_entries(s.entries),
        });
        at += 8 + len;
    }
    (state, at)
}

/// One robot's state file, open for appending.
#[derive(Debug)]
pub struct Store {
    path: PathBuf,
    file: File,
    len: u64,
    last: Option<Persistent>,
}

impl Store {
    /// Opens (creating `dir` and the file if need be) robot `id`'s store and returns it with
    /// the last good state in it; a torn tail is cut off.
    pub fn open(dir: &Path, id: u32) -> std::io::Result<(Store, Option<Persistent>)> {
        std::fs::create_dir_all(dir)?;
        let path = dir.join(format!("raft-{id}.state"));
        let mut file = OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(&path)?;
        let mut bytes = Vec::new();
        file.read_to_end(&mut bytes)?;
        let (state, good) = last_good(&bytes);
        if good < bytes.len() {
            file.set_len(good as u64)?;
            file.sync_data()?;
        }
        let store = Store {
            path,
            file,
            len: good as u64,
            last: state.clone(),
        };
        Ok((store, state))
    }

    /// Makes `state` durable if it differs from the last saved one: appends a record and
    /// syncs it (or compacts the file). Only after this returns may messages that depend on
    /// `state` be sent.
    pub fn save(&mut self, state: &Persistent) -> std::io::Result<()> {
        if self.last.as_ref() == Some(state) {
            return Ok(());
        }
        let record = encode_record(state);
        if self.len + record.len() as u64 > COMPACT_BYTES {
            self.compact(&record)?;
        } else {
            use std::io::Seek;
            self.file.seek(std::io::SeekFrom::Start(self.len))?;
            self.file.write_all(&record)?;
            self.file.sync_data()?;
            self.len += record.len() as u64;
        }
        self.last = Some(state.clone());
        Ok(())
    }

    /// Replaces the file by one record, atomically.
    fn compact(&mut self, record: &[u8]) -> std::io::Result<()> {
        let tmp = self.path.with_extension("state.tmp");
        let mut f = File::create(&tmp)?;
        f.write_all(record)?;
        f.sync_all()?;
        std::fs::rename(&tmp, &self.path)?;
        if let Some(dir) = self.path.parent() {
            File::open(dir)?.sync_all()?;
        }
        self.file = OpenOptions::new().read(true).write(true).open(&self.path)?;
        self.len = record.len() as u64;
        Ok(())
    }

    /// Where the file is.
    pub fn path(&self) -> &Path {
        &self.path
    }
}
