//! Stable storage for a robot's persistent Raft state (Figure 2: term, vote and log, plus the
//! commit index), so a restarted robot process cannot vote twice in one term.
//!
//! One file per robot, `raft-<id>.state`: an append-only sequence of records, each a whole
//! snapshot of [`Persistent`] framed as `[len: u32 LE][crc32: u32 LE][postcard bytes]`. A save
//! appends one record and `fsync`s before the caller lets any message that depends on it
//! leave (write-ahead). A robot's tick hands over only what changed ([`Persist`]); the store
//! keeps the last state to apply it to, so a record is still the whole state. A new file is made durable with its directory (`fsync` of the
//! directory too).
//!
//! Loading ([`scan`]) tells a torn tail from corruption. Only the last record can be torn by a
//! crash (a save appends to the end): a bad record that reaches the end of the file (cut
//! short, or whole in length with a failed checksum), or a tail of zeros, is a torn write;
//! the state before it is kept and the tail is cut off before the next append. A bad record
//! with more data after it (or one whose length runs past the end while a whole record
//! follows, a corrupted length) is corruption: [`Store::open`] refuses it ([`CorruptStore`]) rather than silently drop the
//! records after it, which may hold votes the robot gave. When the file grows past
//! [`COMPACT_BYTES`] it is replaced by one record (written to a temporary file, synced,
//! renamed, directory synced).
//!
//! Files are opened without following a symbolic link planted at their name
//! (`swarmrt_scenario::safe_fs`).
//!
//! [`encode_record`], [`scan`] and [`last_good`] are the pure halves, used by the tests.

use std::fs::File;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use swarmrt_scenario::safe_fs::{Open, OutDir};

use super::log::Log;
use super::messages::Entry;
use super::persist::{HardState, Persist, Persistent};

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

/// [`Stored`] as it is written, borrowing the log in two pieces (a kept prefix and a new
/// tail) so that no log is copied to write it: the same bytes as `Stored`.
#[derive(Serialize)]
struct StoredRef<'a> {
    term: u64,
    vote: Option<u32>,
    commit: u64,
    entries: Pieces<'a>,
}

/// Two slices written as one sequence.
struct Pieces<'a>(&'a [Entry], &'a [Entry]);

impl Serialize for Pieces<'_> {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_seq(self.0.iter().chain(self.1))
    }
}

/// `state` framed as one record.
pub fn encode_record(state: &Persistent) -> Vec<u8> {
    encode(state.hard_state(), state.log.entries(), &[])
}

/// The state `hard` with the log `kept ++ tail`, framed as one record.
fn encode(hard: HardState, kept: &[Entry], tail: &[Entry]) -> Vec<u8> {
    let stored = StoredRef {
        term: hard.term,
        vote: hard.vote,
        commit: hard.commit,
        entries: Pieces(kept, tail),
    };
    let body = postcard::to_allocvec(&stored).expect("the persistent state always encodes");
    let mut out = Vec::with_capacity(body.len() + 8);
    out.extend_from_slice(&(body.len() as u32).to_le_bytes());
    out.extend_from_slice(&crc32fast::hash(&body).to_le_bytes());
    out.extend_from_slice(&body);
    out
}

/// The state of the last whole, checksummed record in `bytes`, and the length of the good
/// prefix (where the first bad record starts), whether that record is a torn tail or
/// corruption ([`scan`] tells them apart).
pub fn last_good(bytes: &[u8]) -> (Option<Persistent>, usize) {
    let (state, good, _) = walk(bytes);
    (state, good)
}

/// What is wrong with a record that is not a torn tail.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Damage {
    /// The body's CRC-32 is not the one in the header.
    Checksum,
    /// The checksum holds but the body is not a stored state.
    Undecodable,
    /// The length in the header runs past the end of the file, yet a whole record follows.
    Length(u32),
}

impl std::fmt::Display for Damage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Damage::Checksum => write!(f, "checksum mismatch"),
            Damage::Undecodable => write!(f, "the record does not decode"),
            Damage::Length(len) => write!(
                f,
                "its length ({len} bytes) runs past the end of the file, yet a whole record follows"
            ),
        }
    }
}

/// Where a store's bytes are corrupt: the record (counted from 1) and the byte offset of its
/// header, and what is wrong with it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Corruption {
    /// The bad record, counted from 1.
    pub record: usize,
    /// The offset of its header in the file.
    pub offset: usize,
    /// What is wrong with it.
    pub damage: Damage,
}

/// The state of the last record in `bytes` and the length of the good prefix (where a torn
/// tail starts, to be cut off), or where the bytes are corrupt: a bad record that is not the
/// last thing in the file (see the module documentation).
pub fn scan(bytes: &[u8]) -> Result<(Option<Persistent>, usize), Corruption> {
    match walk(bytes) {
        (state, good, None) => Ok((state, good)),
        (_, _, Some(c)) => Err(c),
    }
}

/// A header at `at` and its body, when the body lies within `bytes`.
fn framed(bytes: &[u8], at: usize) -> Option<(u32, u32, Option<&[u8]>)> {
    let head = bytes.get(at..at.checked_add(8)?)?;
    let len = u32::from_le_bytes(head[..4].try_into().unwrap());
    let crc = u32::from_le_bytes(head[4..].try_into().unwrap());
    let body = (at + 8)
        .checked_add(len as usize)
        .and_then(|end| bytes.get(at + 8..end));
    Some((len, crc, body))
}

/// A whole, checksummed, decodable record's state.
fn decoded(crc: u32, body: &[u8]) -> Result<Stored, Damage> {
    if crc32fast::hash(body) != crc {
        return Err(Damage::Checksum);
    }
    postcard::from_bytes::<Stored>(body).map_err(|_| Damage::Undecodable)
}

/// Whether a whole, checksummed, decodable record starts anywhere in `bytes` from `from` on.
fn whole_record_from(bytes: &[u8], from: usize) -> bool {
    (from..bytes.len().saturating_sub(7)).any(
        |p| matches!(framed(bytes, p), Some((_, crc, Some(body))) if decoded(crc, body).is_ok()),
    )
}

/// The last good state, the good prefix's length and, if the first bad record is not a torn
/// tail, where and why.
fn walk(bytes: &[u8]) -> (Option<Persistent>, usize, Option<Corruption>) {
    let mut at = 0;
    let mut state = None;
    let mut record = 0;
    // Fewer than 8 bytes left: a torn header (or nothing).
    while let Some((len, crc, body)) = framed(bytes, at) {
        record += 1;
        let damage = match body.map(|b| decoded(crc, b)) {
            Some(Ok(s)) => {
                state = Some(Persistent {
                    term: s.term,
                    vote: s.vote,
                    commit: s.commit,
                    log: Log::from_entries(s.entries),
                });
                at += 8 + len as usize;
                continue;
            }
            Some(Err(d)) => d,
            None => Damage::Length(len),
        };
        let end = at + 8 + len as usize;
        // A bad record that reaches the end of the file is a torn write, unless a whole
        // record starts after its header (then its length, not its tail, is what broke). So
        // is a tail of zeros: a file whose size grew in a crash before its data was written.
        let torn = (end >= bytes.len() && !whole_record_from(bytes, at + 8))
            || bytes[at..].iter().all(|&b| b == 0);
        let corrupt = (!torn).then_some(Corruption {
            record,
            offset: at,
            damage,
        });
        return (state, at, corrupt);
    }
    (state, at, None)
}

/// A robot's store that holds corruption rather than a torn tail: the robot refuses to start
/// (its message says so, naming the file, the record and the byte).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CorruptStore {
    /// The robot.
    pub robot: u32,
    /// Its storage file.
    pub path: PathBuf,
    /// Where and what.
    pub at: Corruption,
}

impl std::fmt::Display for CorruptStore {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "robot {}'s Raft storage {} is corrupt at record {} (byte {}): {}; refusing to \
             start (delete the file to start the robot with no state)",
            self.robot,
            self.path.display(),
            self.at.record,
            self.at.offset,
            self.at.damage
        )
    }
}

impl std::error::Error for CorruptStore {}

/// Why [`Store::open`] failed.
#[derive(Debug)]
pub enum StoreError {
    /// Reading, creating or cutting the file failed (a link planted at its name is refused
    /// this way too).
    Io {
        /// The file.
        path: PathBuf,
        /// The error.
        error: std::io::Error,
    },
    /// The file holds corruption, not just a torn tail.
    Corrupt(CorruptStore),
}

impl std::fmt::Display for StoreError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            StoreError::Io { path, error } => write!(f, "{}: {error}", path.display()),
            StoreError::Corrupt(c) => c.fmt(f),
        }
    }
}

impl std::error::Error for StoreError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            StoreError::Io { error, .. } => Some(error),
            StoreError::Corrupt(_) => None,
        }
    }
}

/// One robot's state file, open for appending, in a directory held open (checked once as a
/// run directory is, `safe_fs::OutDir`): compaction renames through that handle, so a path
/// swapped later changes nothing.
#[derive(Debug)]
pub struct Store {
    dir: OutDir,
    name: String,
    path: PathBuf,
    file: File,
    len: u64,
    last: Option<Persistent>,
}

impl Store {
    /// Opens (creating `dir` and the file if need be, the new file made durable with its
    /// directory) robot `id`'s store and returns it with the last good state in it; a torn
    /// tail is cut off. Corruption is refused ([`StoreError::Corrupt`]), and so is a
    /// symbolic link at the file's name.
    pub fn open(dir: &Path, id: u32) -> Result<(Store, Option<Persistent>), StoreError> {
        let name = format!("raft-{id}.state");
        let path = dir.join(&name);
        let io = |error| StoreError::Io {
            path: path.clone(),
            error,
        };
        let out = OutDir::create(dir).map_err(io)?;
        let created = out.stat(&name).is_none();
        let mut file = out.file(&name, Open::ReadWrite).map_err(io)?;
        if created {
            out.handle().sync_all().map_err(io)?;
        }
        let mut bytes = Vec::new();
        file.read_to_end(&mut bytes).map_err(io)?;
        let (state, good) = scan(&bytes).map_err(|at| {
            StoreError::Corrupt(CorruptStore {
                robot: id,
                path: path.clone(),
                at,
            })
        })?;
        if good < bytes.len() {
            file.set_len(good as u64).map_err(io)?;
            file.sync_data().map_err(io)?;
        }
        let store = Store {
            dir: out,
            name,
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
        self.write(&encode_record(state))?;
        self.last = Some(state.clone());
        Ok(())
    }

    /// Makes the last saved state with `change` applied durable (the first change of a new
    /// store applies to the empty state): appends it as one record and syncs it. Only after
    /// this returns may messages that depend on it be sent. The log is not copied: the
    /// record is written from the kept prefix and the change's tail.
    pub fn persist(&mut self, change: &Persist) -> std::io::Result<()> {
        let last = self.last.get_or_insert_with(Persistent::default);
        let hard = change.hard.unwrap_or(last.hard_state());
        let record = match &change.log {
            Some(tail) => {
                let keep = usize::try_from(tail.first.saturating_sub(1)).unwrap_or(usize::MAX);
                let entries = last.log.entries();
                encode(hard, &entries[..keep.min(entries.len())], &tail.entries)
            }
            None => encode(hard, last.log.entries(), &[]),
        };
        self.write(&record)?;
        if let Some(last) = &mut self.last {
            last.apply(change);
        }
        Ok(())
    }

    /// Appends `record` and syncs it, or compacts the file to it when it would grow too big.
    fn write(&mut self, record: &[u8]) -> std::io::Result<()> {
        if self.len + record.len() as u64 > COMPACT_BYTES {
            self.compact(record)
        } else {
            use std::io::Seek;
            self.file.seek(std::io::SeekFrom::Start(self.len))?;
            self.file.write_all(record)?;
            self.file.sync_data()?;
            self.len += record.len() as u64;
            Ok(())
        }
    }

    /// Replaces the file by one record, atomically.
    fn compact(&mut self, record: &[u8]) -> std::io::Result<()> {
        let tmp = format!("{}.tmp", self.name);
        let mut f = self.dir.file(&tmp, Open::Create)?;
        f.write_all(record)?;
        f.sync_all()?;
        self.dir.rename(&tmp, &self.name)?;
        self.dir.handle().sync_all()?;
        self.file = self.dir.file(&self.name, Open::ReadWrite)?;
        self.len = record.len() as u64;
        Ok(())
    }

    /// Where the file is.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::consensus::{Decision, Item};

    fn state(term: u64, entries: u64) -> Persistent {
        Persistent {
            term,
            vote: Some(term as u32 % 3),
            commit: entries / 2,
            log: Log::from_entries(
                (0..entries)
                    .map(|i| Entry {
                        term: 1 + i / 2,
                        item: if i % 2 == 0 {
                            Item::Noop
                        } else {
                            Item::Decision {
                                id: i as u16,
                                decision: Decision::SetGoal {
                                    x: i as f64,
                                    y: 2.0,
                                },
                            }
                        },
                    })
                    .collect(),
            ),
        }
    }

    /// Three records (terms 1, 2, 3) in robot 3's file in a fresh directory; returns the
    /// directory, the file, the states and each record's offset.
    fn three_records() -> (tempfile::TempDir, PathBuf, Vec<Persistent>, Vec<usize>) {
        let dir = tempfile::tempdir().unwrap();
        let states: Vec<Persistent> = (1..=3).map(|t| state(t, t + 2)).collect();
        let (mut store, restored) = Store::open(dir.path(), 3).unwrap();
        assert_eq!(restored, None);
        let mut offsets = Vec::new();
        for s in &states {
            offsets.push(std::fs::metadata(store.path()).unwrap().len() as usize);
            store.save(s).unwrap();
        }
        let path = store.path().to_path_buf();
        (dir, path, states, offsets)
    }

    fn flip(path: &Path, at: usize) {
        let mut bytes = std::fs::read(path).unwrap();
        bytes[at] ^= 0x40;
        std::fs::write(path, bytes).unwrap();
    }

    #[test]
    fn a_flipped_byte_in_a_middle_record_is_corruption_naming_record_and_byte() {
        let (dir, path, _, offsets) = three_records();
        flip(&path, offsets[1] + 8 + 2);
        let before = std::fs::read(&path).unwrap();
        let e = Store::open(dir.path(), 3).unwrap_err();
        assert_eq!(
            e.to_string(),
            format!(
                "robot 3's Raft storage {} is corrupt at record 2 (byte {}): checksum \
                 mismatch; refusing to start (delete the file to start the robot with no state)",
                path.display(),
                offsets[1]
            )
        );
        assert!(matches!(
            e,
            StoreError::Corrupt(CorruptStore {
                robot: 3,
                at: Corruption {
                    record: 2,
                    damage: Damage::Checksum,
                    ..
                },
                ..
            })
        ));
        assert_eq!(std::fs::read(&path).unwrap(), before, "nothing is cut");
        // The first record too; then a length in a header that no longer fits.
        let (dir, path, _, _) = three_records();
        flip(&path, 8);
        assert!(matches!(
            Store::open(dir.path(), 3).unwrap_err(),
            StoreError::Corrupt(CorruptStore {
                at: Corruption {
                    record: 1,
                    offset: 0,
                    damage: Damage::Checksum
                },
                ..
            })
        ));
        let (_dir, path, _, offsets) = three_records();
        let mut bytes = std::fs::read(&path).unwrap();
        bytes[offsets[1] + 3] = 0x7f; // record 2's length, now past the end of the file
        let c = scan(&bytes).unwrap_err();
        assert_eq!((c.record, c.offset), (2, offsets[1]));
        assert!(matches!(c.damage, Damage::Length(_)), "{c:?}");
        assert!(
            c.damage
                .to_string()
                .contains("runs past the end of the file"),
            "{}",
            c.damage
        );
    }

    #[test]
    fn a_torn_last_record_falls_back_to_the_previous_state_and_is_cut() {
        let (dir, path, states, offsets) = three_records();
        let whole = std::fs::read(&path).unwrap();
        for cut in [offsets[2] + 1, offsets[2] + 8, whole.len() - 1] {
            std::fs::write(&path, &whole[..cut]).unwrap();
            let (store, restored) = Store::open(dir.path(), 3).unwrap();
            assert_eq!(restored.as_ref(), Some(&states[1]), "cut at {cut}");
            assert_eq!(
                std::fs::metadata(&path).unwrap().len() as usize,
                offsets[2],
                "the torn tail is cut off"
            );
            drop(store);
        }
    }

    #[test]
    fn a_flipped_byte_in_the_last_record_with_nothing_after_is_a_torn_tail() {
        let (dir, path, states, offsets) = three_records();
        let len = std::fs::metadata(&path).unwrap().len() as usize;
        flip(&path, len - 1);
        let (mut store, restored) = Store::open(dir.path(), 3).unwrap();
        assert_eq!(restored.as_ref(), Some(&states[1]));
        assert_eq!(std::fs::metadata(&path).unwrap().len() as usize, offsets[2]);
        // And the next save appends after the good prefix.
        store.save(&states[2]).unwrap();
        drop(store);
        assert_eq!(
            Store::open(dir.path(), 3).unwrap().1,
            Some(states[2].clone())
        );
        // Zeros where the last record should be (the size grew, the data never came).
        let mut bytes = std::fs::read(&path).unwrap();
        bytes.extend([0u8; 40]);
        assert_eq!(scan(&bytes).unwrap(), (Some(states[2].clone()), len));
    }

    #[test]
    fn a_link_at_the_files_name_is_refused_not_followed() {
        let dir = tempfile::tempdir().unwrap();
        let victim = dir.path().join("victim");
        std::fs::write(&victim, "keep").unwrap();
        let storage = dir.path().join("storage");
        std::fs::create_dir(&storage).unwrap();
        let link = storage.join("raft-0.state");
        std::os::unix::fs::symlink(&victim, &link).unwrap();
        let e = Store::open(&storage, 0).unwrap_err().to_string();
        assert!(
            e.ends_with(&format!(
                "{} is a symbolic link; refusing to follow it",
                link.display()
            )),
            "{e}"
        );
        assert_eq!(std::fs::read_to_string(&victim).unwrap(), "keep");
    }

    #[test]
    fn a_store_fed_changes_writes_the_bytes_of_one_fed_whole_states() {
        let dir = tempfile::tempdir().unwrap();
        let (mut whole, _) = Store::open(&dir.path().join("whole"), 1).unwrap();
        let (mut changes, _) = Store::open(&dir.path().join("changes"), 1).unwrap();
        let s1 = state(1, 4);
        // A new leader's entry replaces the fourth; then only the commit index moves.
        let mut s2 = state(2, 3);
        let replaced = Entry {
            term: 2,
            item: Item::Noop,
        };
        s2.log.push(replaced);
        let s3 = Persistent {
            commit: 3,
            ..s2.clone()
        };
        let c2 = Persist {
            hard: Some(s2.hard_state()),
            log: Some(super::super::persist::LogSuffix {
                first: 4,
                entries: vec![replaced],
            }),
        };
        let c3 = Persist {
            hard: Some(s3.hard_state()),
            log: None,
        };
        for (s, c) in [(&s1, &Persist::whole(&s1)), (&s2, &c2), (&s3, &c3)] {
            whole.save(s).unwrap();
            changes.persist(c).unwrap();
        }
        let bytes = |s: &Store| std::fs::read(s.path()).unwrap();
        assert_eq!(bytes(&changes), bytes(&whole));
        let reopened = Store::open(&dir.path().join("changes"), 1).unwrap().1;
        assert_eq!(reopened, Some(s3));
    }
}
