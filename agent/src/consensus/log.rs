//! The replicated log: entries at indexes 1, 2, ...; index 0 is the empty prefix (term 0).

use super::messages::{Entry, Item};

/// A robot's copy of the log.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Log {
    entries: Vec<Entry>,
}

impl Log {
    /// An empty log.
    pub fn new() -> Log {
        Log::default()
    }

    /// A log holding `entries` at indexes 1, 2, ...
    pub fn from_entries(entries: Vec<Entry>) -> Log {
        Log { entries }
    }

    /// Every entry, index 1 first.
    pub fn entries(&self) -> &[Entry] {
        &self.entries
    }

    /// Index of the last entry (0 when empty).
    pub fn last_index(&self) -> u64 {
        self.entries.len() as u64
    }

    /// Term of the last entry (0 when empty).
    pub fn last_term(&self) -> u64 {
        self.entries.last().map_or(0, |e| e.term)
    }

    /// Term of the entry at `index`: `Some(0)` for index 0, `None` past the end.
    pub fn term(&self, index: u64) -> Option<u64> {
        if index == 0 {
            Some(0)
        } else {
            self.get(index).map(|e| e.term)
        }
    }

    /// The entry at `index` (1-based).
    pub fn get(&self, index: u64) -> Option<&Entry> {
        let i = usize::try_from(index).ok()?.checked_sub(1)?;
        self.entries.get(i)
    }

    /// Appends one entry at `last_index() + 1`.
    pub fn push(&mut self, e: Entry) {
        self.entries.push(e);
    }

    /// Removes every entry from `index` on.
    pub fn truncate_from(&mut self, index: u64) {
        let keep = usize::try_from(index.saturating_sub(1)).unwrap_or(usize::MAX);
        self.entries.truncate(keep);
    }

    /// Entries from `index` on (empty past the end).
    pub fn from(&self, index: u64) -> &[Entry] {
        let i = usize::try_from(index.max(1) - 1).unwrap_or(usize::MAX);
        self.entries.get(i..).unwrap_or(&[])
    }

    /// Whether scheduled decision `id` is anywhere in the log (committed or not).
    pub fn has_decision(&self, id: u16) -> bool {
        self.entries
            .iter()
            .any(|e| matches!(e.item, Item::Decision { id: k, .. } if k == id))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn e(term: u64) -> Entry {
        Entry {
            term,
            item: Item::Noop,
        }
    }

    #[test]
    fn one_based_indexes_and_truncation() {
        let mut log = Log::new();
        assert_eq!(
            (log.last_index(), log.last_term(), log.term(0)),
            (0, 0, Some(0))
        );
        for t in [1, 1, 2] {
            log.push(e(t));
        }
        assert_eq!(log.term(3), Some(2));
        assert_eq!(log.term(4), None);
        assert_eq!(log.from(2).len(), 2);
        assert_eq!(log.from(9).len(), 0);
        log.truncate_from(2);
        assert_eq!(log.last_index(), 1);
        assert_eq!(log.get(u64::MAX), None);
    }
}
