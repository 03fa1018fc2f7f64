//! The checker against hand-written note streams: every safety property caught, metrics
//! from leaders, deaths and re-elections.

use super::*;
use ConsensusNote as N;
use serde_json::json;

fn state(term: u64, role: Role, vote: Option<u32>) -> N {
    N::State { term, role, vote }
}

fn app(index: u64, term: u64, digest: u32) -> N {
    N::Append {
        index,
        term,
        digest,
    }
}

/// Feeds (tick, robot, note) triples, ending each tick; returns the violated properties.
fn run(stream: &[(u64, u32, N)]) -> Vec<&'static str> {
    let mut c = Checker::new();
    let mut last = None;
    for (t, r, n) in stream {
        if let Some(p) = last
            && *t > p
        {
            c.end_tick(p);
        }
        last = Some(*t);
        c.note(*t, *r, n);
    }
    if let Some(p) = last {
        c.end_tick(p);
    }
    c.violations().iter().map(|v| v.property).collect()
}

/// A healthy history: robot 0 leads term 1, replicates and commits two entries on 1 and 2.
fn healthy() -> Vec<(u64, u32, N)> {
    let mut s = vec![
        (1, 0, state(1, Role::Candidate, Some(0))),
        (1, 1, state(1, Role::Follower, Some(0))),
        (1, 2, state(1, Role::Follower, Some(0))),
        (2, 0, state(1, Role::Leader, Some(0))),
        (2, 0, app(1, 1, 0xa)),
        (2, 0, app(2, 1, 0xb)),
    ];
    for r in [1, 2] {
        s.push((3, r, app(1, 1, 0xa)));
        s.push((3, r, app(2, 1, 0xb)));
    }
    s.push((4, 0, N::Commit { index: 2 }));
    for r in [0, 1, 2] {
        if r != 0 {
            s.push((5, r, N::Commit { index: 2 }));
        }
        s.push((
            5,
            r,
            N::Apply {
                index: 1,
                term: 1,
                digest: 0xa,
            },
        ));
        s.push((
            5,
            r,
            N::Apply {
                index: 2,
                term: 1,
                digest: 0xb,
            },
        ));
    }
    s
}

#[test]
fn a_healthy_history_passes() {
    assert_eq!(run(&healthy()), Vec::<&str>::new());
}

#[test]
fn two_leaders_in_one_term_break_election_safety() {
    let s = vec![
        (1, 0, state(1, Role::Leader, Some(0))),
        (2, 1, state(1, Role::Leader, Some(1))),
    ];
    assert_eq!(run(&s), vec!["election_safety"]);
    // Leaders of different terms at once are fine (a stale leader in a minority).
    let s = vec![
        (1, 0, state(1, Role::Leader, Some(0))),
        (2, 1, state(2, Role::Leader, Some(1))),
    ];
    assert_eq!(run(&s), Vec::<&str>::new());
    // A leader that did not vote for itself is just as wrong.
    let s = vec![(1, 0, state(2, Role::Leader, Some(1)))];
    assert_eq!(run(&s), vec!["election_safety"]);
}

#[test]
fn same_index_and_term_with_different_prefixes_break_log_matching() {
    // Entry (2, term 2) is the same on both robots, but what precedes it is not.
    let s = vec![
        (1, 0, app(1, 1, 0xa)),
        (1, 0, app(2, 2, 0xc)),
        (1, 1, app(1, 3, 0xf)),
        (1, 1, app(2, 2, 0xc)),
    ];
    assert_eq!(run(&s), vec!["log_matching"]);
    // The same (index, term) with different contents, too.
    let s = vec![(1, 0, app(1, 1, 0xa)), (1, 1, app(1, 1, 0xb))];
    assert_eq!(run(&s), vec!["log_matching"]);
}

#[test]
fn a_leader_missing_a_committed_entry_breaks_leader_completeness() {
    let mut s = healthy();
    // Robot 3 never got the entries but leads term 2.
    s.push((6, 3, state(2, Role::Candidate, Some(3))));
    s.push((7, 3, state(2, Role::Leader, Some(3))));
    assert_eq!(run(&s), vec!["leader_completeness"]);
    // Truncating a committed entry is the same fault seen from a follower.
    let mut s = healthy();
    s.push((6, 1, N::Truncate { index: 2 }));
    assert_eq!(run(&s), vec!["leader_completeness"]);
}

/// Raft's Leader Completeness covers what was committed before a leader's term. A stale
/// leader of term 2 need not hold an entry of term 1 that the leader of term 3 commits later
/// (found by the fuzzer, seed 47941, once crashes could land inside a tick).
#[test]
fn a_stale_leader_need_not_hold_what_a_later_term_commits() {
    let s = vec![
        (1, 0, state(1, Role::Leader, Some(0))),
        (1, 0, app(1, 1, 0xa)),
        // Robot 1 leads term 2 with an empty log (entry 1 was on robot 0 only) ...
        (2, 1, state(2, Role::Candidate, Some(1))),
        (2, 2, state(2, Role::Follower, Some(1))),
        (3, 1, state(2, Role::Leader, Some(1))),
        (3, 1, app(1, 2, 0xb)),
        // ... and is cut off; robot 0 wins term 3 with robot 2's vote and commits its entry 1
        // of term 1 through its own entry of term 3.
        (4, 0, state(3, Role::Candidate, Some(0))),
        (4, 2, state(3, Role::Follower, Some(0))),
        (5, 0, state(3, Role::Leader, Some(0))),
        (5, 0, app(2, 3, 0xc)),
        (6, 2, app(1, 1, 0xa)),
        (6, 2, app(2, 3, 0xc)),
        (7, 0, N::Commit { index: 2 }),
    ];
    assert_eq!(run(&s), Vec::<&str>::new());
    // The same commit in term 1, before robot 1 led term 2: a completeness violation.
    let s = vec![
        (1, 0, state(1, Role::Leader, Some(0))),
        (1, 0, app(1, 1, 0xa)),
        (1, 2, app(1, 1, 0xa)),
        (2, 0, N::Commit { index: 1 }),
        (3, 1, state(2, Role::Candidate, Some(1))),
        (4, 1, state(2, Role::Leader, Some(1))),
    ];
    assert_eq!(run(&s), vec!["leader_completeness"]);
}

#[test]
fn different_entries_committed_or_applied_at_one_index_break_state_machine_safety() {
    // Robot 3 has its own entry 1 (another term) and commits it.
    let mut s = healthy();
    s.push((6, 3, app(1, 2, 0xe)));
    s.push((6, 3, N::Commit { index: 1 }));
    let v = run(&s);
    assert!(v.contains(&"state_machine_safety"), "{v:?}");
    // Applying beyond the commit index.
    let s = vec![
        (1, 0, app(1, 1, 0xa)),
        (
            1,
            0,
            N::Apply {
                index: 1,
                term: 1,
                digest: 0xa,
            },
        ),
    ];
    assert_eq!(run(&s), vec!["state_machine_safety"]);
}

#[test]
fn going_back_breaks_monotonicity() {
    let s = vec![
        (1, 0, state(3, Role::Follower, None)),
        (2, 0, state(2, Role::Follower, None)),
    ];
    assert_eq!(run(&s), vec!["monotonic_term"]);
    let s = vec![
        (1, 0, state(3, Role::Follower, Some(1))),
        (2, 0, state(3, Role::Follower, Some(2))),
    ];
    assert_eq!(run(&s), vec!["monotonic_vote"]);
    let mut s = healthy();
    s.push((6, 1, N::Commit { index: 1 }));
    assert_eq!(run(&s), vec!["monotonic_commit"]);
    let mut s = healthy();
    s.push((
        6,
        1,
        N::Apply {
            index: 1,
            term: 1,
            digest: 0xa,
        },
    ));
    assert_eq!(run(&s), vec!["apply_order"]);
}

#[test]
fn a_self_contradicting_record_is_reported() {
    let s = vec![(1, 0, app(3, 1, 0xa))];
    assert_eq!(run(&s), vec!["record"]);
}

#[test]
fn restarts_with_state_carry_on_and_amnesia_is_counted() {
    let mut c = Checker::new();
    for (t, r, n) in healthy() {
        c.note(t, r, &n);
    }
    c.died(6, 0);
    assert_eq!(c.current_leader(), None);
    // Robot 0 comes back with its state and re-applies: fine.
    c.note(
        20,
        0,
        &N::Boot {
            term: 1,
            vote: Some(0),
            last_index: 2,
            commit: 2,
        },
    );
    c.note(
        20,
        0,
        &N::Apply {
            index: 1,
            term: 1,
            digest: 0xa,
        },
    );
    c.end_tick(20);
    assert_eq!(c.violations(), &[]);
    assert_eq!(c.amnesia_restarts(), 0);
    // Robot 1 comes back with nothing: amnesia, not by itself a violation.
    c.note(
        21,
        1,
        &N::Boot {
            term: 0,
            vote: None,
            last_index: 0,
            commit: 0,
        },
    );
    assert_eq!(c.amnesia_restarts(), 1);
    assert_eq!(c.violations(), &[]);
}

#[test]
fn metrics_follow_leaders_deaths_and_reelections() {
    let mut lines = String::new();
    let push = |lines: &mut String, t: u64, r: u32, n: N| {
        lines.push_str(
            &serde_json::to_string(&json!({
                "event": "note", "tick": t, "robot": r, "note": {"consensus": n}
            }))
            .unwrap(),
        );
        lines.push('\n');
    };
    push(&mut lines, 10, 0, state(1, Role::Leader, Some(0)));
    push(&mut lines, 10, 0, app(1, 1, 0xa));
    push(&mut lines, 11, 0, N::Commit { index: 1 });
    push(
        &mut lines,
        11,
        0,
        N::Sent(SentCounts {
            append: 4,
            ..SentCounts::default()
        }),
    );
    lines.push_str(r#"{"event":"died","tick":50,"robot":0,"reason":"killed"}"#);
    lines.push('\n');
    push(&mut lines, 12, 1, app(1, 1, 0xa));
    push(&mut lines, 50, 1, state(2, Role::Candidate, Some(1)));
    push(&mut lines, 71, 1, state(2, Role::Leader, Some(1)));
    let ConsensusReport::Checked(m) = consensus_metrics(&lines) else {
        panic!("the notes read");
    };
    assert_eq!(m.first_leader_tick, Some(10));
    assert_eq!(m.leader_changes, 1);
    assert_eq!(m.reelection_ticks, [21]);
    assert_eq!(m.terms, 2);
    assert_eq!(m.committed, 1);
    assert_eq!(m.safety_violations, 0);
    assert_eq!(m.sent.get("append"), Some(&4));
    let unreadable = serde_json::to_value(consensus_metrics("not json\n")).unwrap();
    assert!(unreadable["error"].is_string(), "{unreadable}");
}
