//! The opt-in radio record (issue 30): `scenario.record_radio = true` makes the world write
//! `radio.csv`, one line per radio copy whose fate is decided, the same bytes in processes and
//! `--in-process`, counting exactly what `metrics.json`'s `radio` counts, and changing no other
//! record.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Duration;

use swarmrt_protocol::records::{RadioOutcome, RadioRow, parse_radio};
use swarmrt_tests::*;

const LIMIT: Duration = Duration::from_secs(180);

const RECORD: [&str; 2] = ["--set", "scenario.record_radio=true"];

/// A lossy, late radio: every copy that survives is delivered three ticks after sending.
const LOSSY_LATE: [&str; 4] = ["--set", "radio.loss=0.3", "--set", "radio.delay_ticks=2"];

/// A kill (copies in flight to it die as `receiver_down`), a partition of robots 0-3 from the
/// rest, and a blackout.
const FAULTS: [&str; 6] = [
    "--set",
    "faults.kill=[{tick=60,robot=4}]",
    "--set",
    "faults.partition=[{from=100,to=160,groups=[[0,1,2,3]]}]",
    "--set",
    "faults.blackout=[{from=200,to=220}]",
];

fn run(tmp: &Path, name: &str, args: &[&str]) -> PathBuf {
    let dir = tmp.join(name);
    let mut all = vec![
        "run",
        "configs/goto_simple.toml",
        "--ticks",
        "300",
        "--seed",
        "5",
        "--set",
        "scenario.stop_when_done=false",
        "--out",
        dir.to_str().unwrap(),
    ];
    all.extend_from_slice(args);
    assert_ok(&swarm(&all, LIMIT));
    dir
}

/// `radio.csv`'s rows, after checking that every line is a whole row.
fn radio_rows(dir: &Path) -> Vec<RadioRow> {
    let text = String::from_utf8(bytes(dir, "radio.csv")).unwrap();
    assert!(text.ends_with('\n'), "radio.csv ends with a whole line");
    let rows = parse_radio(&text).unwrap();
    assert_eq!(rows.len(), text.lines().count() - 1, "every line is a row");
    rows
}

/// Asserts the rows count exactly what the run's `radio` counters count, and returns the rows
/// per outcome.
fn assert_rows_match_counters(dir: &Path, rows: &[RadioRow]) -> BTreeMap<RadioOutcome, u64> {
    let m = metrics(dir);
    let radio = &m["radio"];
    let counter = |key: &str| radio[key].as_u64().unwrap_or_else(|| panic!("{key}: {m}"));
    let mut per = BTreeMap::new();
    for r in rows {
        *per.entry(r.outcome).or_insert(0u64) += 1;
    }
    assert_eq!(
        rows.len() as u64,
        counter("sent") - counter("in_flight"),
        "one line per decided copy: {radio}"
    );
    for o in RadioOutcome::ALL {
        assert_eq!(
            per.get(&o).copied().unwrap_or(0),
            counter(o.counter()),
            "{}: {radio}",
            o.as_str()
        );
    }
    assert_eq!(
        rows.iter()
            .filter(|r| r.outcome != RadioOutcome::Delivered)
            .count() as u64,
        counter("dropped")
    );
    // In the order decided: ticks never go back, nothing arrives before it was sent, and the
    // last line is no later than the last recorded tick.
    assert!(rows.windows(2).all(|w| w[0].tick <= w[1].tick));
    assert!(
        rows.iter()
            .all(|r| r.sent_tick <= r.tick && r.from != u32::MAX)
    );
    assert!(rows.last().is_none_or(|r| r.tick <= last_tick(dir)));
    per
}

/// Runs `args` with the radio record in both modes and once without it; asserts `radio.csv`
/// is the same bytes in both modes, matches the counters, and that the record changed no other
/// record. Returns the processes run's directory and its rows.
fn record_both_modes(tmp: &Path, args: &[&str]) -> (PathBuf, Vec<RadioRow>) {
    let mut recorded = RECORD.to_vec();
    recorded.extend_from_slice(args);
    let p = run(tmp, "processes", &recorded);
    recorded.push("--in-process");
    let q = run(tmp, "in-process", &recorded);
    let mut plain = args.to_vec();
    plain.push("--in-process");
    let base = run(tmp, "without-record", &plain);

    assert!(
        bytes(&p, "radio.csv") == bytes(&q, "radio.csv"),
        "radio.csv differs between modes"
    );
    assert!(!base.join("radio.csv").exists(), "radio.csv is opt-in");
    // The record perturbs nothing: the same trajectory, events and counters as without it.
    assert_same_records(&p, &q, "processes vs in-process, recording");
    assert_same_records(&p, &base, "recording vs not");
    assert_eq!(metrics(&p)["radio"], metrics(&base)["radio"]);
    assert_eq!(metrics(&q)["radio"], metrics(&base)["radio"]);

    let rows = radio_rows(&p);
    assert_rows_match_counters(&p, &rows);
    assert_rows_match_counters(&q, &radio_rows(&q));
    (p, rows)
}

#[test]
fn lossy_late_radio_is_recorded_identically_in_both_modes_and_matches_the_counters() {
    let tmp = tempfile::tempdir().unwrap();
    let (dir, rows) = record_both_modes(tmp.path(), &LOSSY_LATE);
    let per = assert_rows_match_counters(&dir, &rows);
    assert!(per[&RadioOutcome::Loss] > 0, "{per:?}");
    assert!(per[&RadioOutcome::Delivered] > 0, "{per:?}");
    for r in &rows {
        match r.outcome {
            // delay_ticks = 2: sent at t, in the observation of t + 3.
            RadioOutcome::Delivered => assert_eq!(r.tick, r.sent_tick + 3, "{r:?}"),
            // Loss is decided when routing, at the send tick.
            RadioOutcome::Loss => assert_eq!(r.tick, r.sent_tick, "{r:?}"),
            _ => {}
        }
        // goto broadcasts its beacons: each copy names its actual receiver.
        let to = r.to.expect("a broadcast copy names its receiver");
        assert!(to != r.from && to < 9, "{r:?}");
        assert!(r.bytes > 0, "{r:?}");
    }
}

#[test]
fn partitions_blackouts_and_deaths_are_recorded_with_their_reasons() {
    let tmp = tempfile::tempdir().unwrap();
    let mut args = LOSSY_LATE.to_vec();
    args.extend_from_slice(&FAULTS);
    let (dir, rows) = record_both_modes(tmp.path(), &args);
    let per = assert_rows_match_counters(&dir, &rows);
    assert!(per[&RadioOutcome::Partition] > 0, "{per:?}");
    let partition = |r: &&RadioRow| r.outcome == RadioOutcome::Partition;
    let side = |id: u32| id <= 3;
    // During the partition only copies across it are dropped for it; during the blackout all.
    assert!(
        rows.iter()
            .filter(partition)
            .all(|r| (100..160).contains(&r.tick) || (200..220).contains(&r.tick)),
        "partition drops only inside the windows"
    );
    assert!(
        rows.iter()
            .filter(partition)
            .filter(|r| (100..160).contains(&r.tick))
            .all(|r| side(r.from) != side(r.to.unwrap()))
    );
    assert!(rows.iter().filter(partition).any(|r| r.tick == 100));
    assert!(
        rows.iter()
            .filter(partition)
            .any(|r| (200..220).contains(&r.tick) && side(r.from) == side(r.to.unwrap()))
    );
    // Across the partition nothing sent inside the window gets through.
    assert!(!rows.iter().any(|r| r.outcome == RadioOutcome::Delivered
        && (100..160).contains(&r.sent_tick)
        && side(r.from) != side(r.to.unwrap())));
    // Robot 4 is dead from tick 60: copies still in flight to it die there, and it sends
    // nothing after.
    assert!(rows.iter().any(|r| r.outcome == RadioOutcome::ReceiverDown
        && r.to == Some(4)
        && (60..63).contains(&r.tick)));
    assert!(!rows.iter().any(|r| r.from == 4 && r.sent_tick >= 60));
}

#[test]
fn a_killed_world_leaves_whole_radio_lines_up_to_its_last_tick() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("run");
    let child = start_long_run(&dir, &RECORD);
    let children = children_of(child.id());
    let world = children
        .iter()
        .find(|(_, c)| c.contains("swarm-world"))
        .map(|(p, _)| *p)
        .unwrap();
    let run_id = run_id_of(&children);
    unsafe {
        libc::kill(world, libc::SIGKILL);
    }
    let out = wait_with_watchdog(child, LIMIT);
    assert_eq!(out.status.code(), Some(1));
    assert_eq!(metrics(&dir)["failed"], true);
    let rows = radio_rows(&dir);
    assert!(!rows.is_empty());
    let last = last_tick(&dir);
    assert!(
        rows.iter().all(|r| r.tick <= last),
        "trimmed to tick {last}"
    );
    assert_nothing_left(&children, &run_id);
}
