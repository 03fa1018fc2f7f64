//! Stable storage of the persistent Raft state: what survives a restart, a torn last record
//! and a corrupted one.

use swarmrt_agent::consensus::log::Log;
use swarmrt_agent::consensus::raft::Persistent;
use swarmrt_agent::consensus::storage::{COMPACT_BYTES, Store, encode_record, last_good};
use swarmrt_agent::consensus::{Decision, Entry, Item};

fn state(term: u64, vote: Option<u32>, entries: u64) -> Persistent {
    let log = Log::from_entries(
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
    );
    Persistent {
        term,
        vote,
        commit: entries / 2,
        log,
    }
}

#[test]
fn the_last_whole_record_wins_and_a_torn_tail_falls_back_to_the_one_before() {
    let a = state(3, Some(1), 4);
    let b = state(4, Some(2), 5);
    let mut bytes = encode_record(&a);
    let first = bytes.len();
    bytes.extend(encode_record(&b));
    assert_eq!(last_good(&bytes), (Some(b.clone()), bytes.len()));
    // Every cut inside the second record leaves the first.
    for cut in first..bytes.len() {
        assert_eq!(
            last_good(&bytes[..cut]),
            (Some(a.clone()), first),
            "cut at {cut}"
        );
    }
    // A flipped bit in the second record's body fails its checksum.
    let mut bad = bytes.clone();
    *bad.last_mut().unwrap() ^= 1;
    assert_eq!(last_good(&bad), (Some(a.clone()), first));
    // Nothing whole: nothing stored.
    assert_eq!(last_good(&bytes[..first - 1]), (None, 0));
    assert_eq!(last_good(&[]), (None, 0));
}

#[test]
fn a_store_survives_its_process_and_cuts_a_torn_tail_before_appending() {
    let dir = tempfile::tempdir().unwrap();
    let (mut store, restored) = Store::open(dir.path(), 7).unwrap();
    assert_eq!(restored, None, "a new store is empty");
    let a = state(2, Some(7), 3);
    store.save(&a).unwrap();
    let len = std::fs::metadata(store.path()).unwrap().len();
    store.save(&a).unwrap();
    assert_eq!(
        std::fs::metadata(store.path()).unwrap().len(),
        len,
        "an unchanged state is not written again"
    );
    drop(store);
    let (store, restored) = Store::open(dir.path(), 7).unwrap();
    assert_eq!(restored.as_ref(), Some(&a));
    // A crash in the middle of the next write leaves half a record.
    let b = state(3, None, 4);
    let path = store.path().to_path_buf();
    let mut torn = std::fs::read(&path).unwrap();
    torn.extend_from_slice(&encode_record(&b)[..10]);
    std::fs::write(&path, &torn).unwrap();
    drop(store);
    let (mut store, restored) = Store::open(dir.path(), 7).unwrap();
    assert_eq!(restored.as_ref(), Some(&a), "the torn record is ignored");
    assert_eq!(std::fs::metadata(&path).unwrap().len(), len, "and cut off");
    store.save(&b).unwrap();
    drop(store);
    assert_eq!(Store::open(dir.path(), 7).unwrap().1, Some(b));
}

#[test]
fn a_growing_file_is_compacted_to_its_latest_state() {
    let dir = tempfile::tempdir().unwrap();
    let (mut store, _) = Store::open(dir.path(), 0).unwrap();
    let mut last = state(0, None, 0);
    for term in 1..2000 {
        last = state(term, Some(0), 40);
        store.save(&last).unwrap();
    }
    let len = std::fs::metadata(store.path()).unwrap().len();
    assert!(len <= COMPACT_BYTES, "{len} bytes");
    drop(store);
    assert_eq!(Store::open(dir.path(), 0).unwrap().1, Some(last));
}
