//! The Raft core on its own in [`swarmrt_harness::raft_net::Net`]: election, commit,
//! pre-vote, step-down, vote rules, note budget, restart with persistent state.

use swarmrt_agent::consensus::raft::{Persistent, Proposed, Raft};
use swarmrt_agent::consensus::{ConsensusMsg, ConsensusNote, Decision, Entry, Item, Role};
use swarmrt_agent::consensus::{NOTE_BUDGET, Notes, stream};

use swarmrt_harness::raft_net::{Net, params};

#[test]
fn three_robots_elect_one_leader_and_commit_its_noop_everywhere() {
    let mut net = Net::new(3, true);
    let l = net.run_until_leader(200);
    net.run(10);
    assert_eq!(net.leaders(), vec![(l, net.nodes[l as usize].term())]);
    for r in &net.nodes {
        assert_eq!(r.leader(), Some(l));
        assert_eq!(r.commit(), 1, "the leader's no-op is committed");
        assert_eq!(r.applied(), 1);
        assert_eq!(r.log().get(1).unwrap().item, Item::Noop);
    }
}

#[test]
fn a_proposal_is_committed_and_applied_by_all_and_never_proposed_twice() {
    let mut net = Net::new(5, true);
    let l = net.run_until_leader(300) as usize;
    let d = Decision::SetGoal { x: 3.0, y: 4.0 };
    let mut notes = Notes::new(NOTE_BUDGET);
    assert_eq!(net.nodes[l].propose(0, d, &mut notes), Proposed::Appended);
    assert_eq!(
        net.nodes[l].propose(0, d, &mut notes),
        Proposed::AlreadyInLog
    );
    let other = (l + 1) % 5;
    assert_eq!(
        net.nodes[other].propose(1, d, &mut notes),
        Proposed::NotLeader
    );
    net.run(10);
    for r in &net.nodes {
        assert_eq!(r.commit(), 2);
        assert_eq!(
            r.log().get(2).unwrap().item,
            Item::Decision { id: 0, decision: d }
        );
    }
}

#[test]
fn pre_vote_keeps_a_returning_robot_from_deposing_the_leader() {
    // With pre-vote the isolated robot never raises its term, so when it hears the leader
    // again it simply follows. Without pre-vote (the control) it comes back with a higher
    // term and the leader is deposed: the assertion below is what pre-vote buys.
    for pre_vote in [true, false] {
        let mut net = Net::new(5, pre_vote);
        let l = net.run_until_leader(300);
        let term = net.nodes[l as usize].term();
        let drifter = (l + 1) % 5;
        net.isolate(drifter);
        net.run(200);
        net.cut.clear();
        net.run(60);
        let still = net.leaders() == vec![(l, term)];
        if pre_vote {
            assert!(still, "leader kept: {:?}", net.leaders());
            assert_eq!(net.nodes[drifter as usize].term(), term);
            assert_eq!(net.nodes[drifter as usize].leader(), Some(l));
        } else {
            assert!(!still, "without pre-vote the drifter deposes the leader");
            assert!(net.nodes[l as usize].term() > term);
        }
    }
}

#[test]
fn a_partitioned_minority_leader_steps_down_and_its_entries_are_replaced() {
    let mut net = Net::new(5, true);
    let l = net.run_until_leader(300);
    // Cut the leader and one follower off from the other three.
    let minority = [l, (l + 1) % 5];
    for &a in &minority {
        for b in 0..5 {
            if !minority.contains(&b) {
                net.cut.insert((a, b));
                net.cut.insert((b, a));
            }
        }
    }
    let mut notes = Notes::new(NOTE_BUDGET);
    let stale = Decision::SetSpeed { speed: 0.1 };
    assert_eq!(
        net.nodes[l as usize].propose(0, stale, &mut notes),
        Proposed::Appended
    );
    net.run(150);
    // The majority elected a new leader; the old one stepped down (check-quorum).
    let leaders = net.leaders();
    assert_eq!(leaders.len(), 1, "{leaders:?}");
    let new = leaders[0].0;
    assert!(!minority.contains(&new));
    let fresh = Decision::SetSpeed { speed: 0.3 };
    assert_eq!(
        net.nodes[new as usize].propose(1, fresh, &mut notes),
        Proposed::Appended
    );
    net.run(20);
    net.cut.clear();
    net.run(60);
    // The old leader's uncommitted entry was truncated: every log holds the new decision,
    // none the stale one, and every robot committed the same prefix.
    for r in &net.nodes {
        assert!(r.log().has_decision(1), "robot follows the new leader");
        assert!(!r.log().has_decision(0));
        assert_eq!(r.commit(), net.nodes[new as usize].commit());
    }
    let old = &net.notes[l as usize];
    assert!(
        old.iter()
            .any(|n| matches!(n, ConsensusNote::Truncate { .. })),
        "the old leader reported the truncation"
    );
}

#[test]
fn votes_need_an_up_to_date_log_and_are_refused_inside_the_lease() {
    let p = params(3, true);
    let mut r = Raft::new(0, p, stream(1, "t", 0));
    let mut notes = Notes::new(NOTE_BUDGET);
    // Robot 1 leads term 1 and gives robot 0 two entries.
    let e = Entry {
        term: 1,
        item: Item::Noop,
    };
    r.step(
        1,
        &ConsensusMsg::Append {
            term: 1,
            prev_index: 0,
            prev_term: 0,
            commit: 0,
            entries: vec![e, e],
        },
        &mut notes,
    );
    assert_eq!(r.log().last_index(), 2);
    // Inside the lease a higher-term vote request is ignored: no answer, no term change.
    r.step(
        2,
        &ConsensusMsg::Vote {
            term: 5,
            last_index: 9,
            last_term: 4,
        },
        &mut notes,
    );
    assert_eq!(r.term(), 1);
    assert!(r.ready(4).iter().all(|(to, _)| *to == 1), "only the ack");
    // After the lease, a candidate with a shorter log is refused, a current one granted.
    let mut quiet = Notes::new(NOTE_BUDGET);
    for _ in 0..p.election_min {
        r.tick(&mut quiet);
    }
    let mut r2 = r.clone();
    r.step(
        2,
        &ConsensusMsg::Vote {
            term: 5,
            last_index: 1,
            last_term: 1,
        },
        &mut notes,
    );
    assert_eq!(r.term(), 5);
    assert_eq!(r.vote(), None);
    assert!(r.ready(4).contains(&(
        2,
        ConsensusMsg::VoteResp {
            term: 5,
            granted: false
        }
    )));
    r2.step(
        2,
        &ConsensusMsg::Vote {
            term: 5,
            last_index: 2,
            last_term: 1,
        },
        &mut notes,
    );
    assert_eq!(r2.vote(), Some(2));
}

#[test]
fn a_message_whose_notes_do_not_fit_is_left_unprocessed() {
    let mut r = Raft::new(0, params(3, true), stream(1, "t", 0));
    let e = Entry {
        term: 1,
        item: Item::Noop,
    };
    let msg = ConsensusMsg::Append {
        term: 1,
        prev_index: 0,
        prev_term: 0,
        commit: 0,
        entries: vec![e; 4],
    };
    let mut tight = Notes::new(20);
    assert!(!r.step(1, &msg, &mut tight));
    assert_eq!((r.term(), r.log().last_index()), (0, 0), "state untouched");
    assert_eq!(r.left_for_notes(), 1);
    let mut roomy = Notes::new(NOTE_BUDGET);
    assert!(r.step(1, &msg, &mut roomy));
    assert_eq!(r.log().last_index(), 4);
}

#[test]
fn a_restarted_robot_keeps_term_vote_and_log_and_reapplies() {
    let mut net = Net::new(3, true);
    net.run_until_leader(300);
    net.run(10);
    let before: Persistent = net.nodes[0].persistent();
    let mut again = Raft::restore(
        0,
        params(3, true),
        before.clone(),
        stream(7, "test", 1 << 32),
    );
    assert_eq!(
        again.boot_note(),
        ConsensusNote::Boot {
            term: before.term,
            vote: before.vote,
            last_index: before.log.last_index(),
            commit: before.commit
        }
    );
    assert_eq!(again.role(), Role::Follower);
    let mut notes = Notes::new(NOTE_BUDGET);
    let mut reapplied = 0;
    while again.next_apply(&mut notes).is_some() {
        reapplied += 1;
    }
    assert_eq!(reapplied, before.commit);
}

/// Fuzz seeds 778, 786, 10212, 10751, 12286, 12782 and 12841 with the burst shape: a follower
/// whose log ends in a run of entries of an old term stayed behind its leader forever. A leader
/// starts every `next_index` past its own log; the follower's first refusal brings its
/// `next_index` down to the follower's log end. The broadcast from there spans several
/// frames, and the follower refuses each: the first on the conflict (hint `prev_index - 1`),
/// the others because they start past its log (hint: its last index). Merged into the one
/// answer a tick sends, the last refusal, the highest hint, won, so `next_index` never went
/// below the follower's log end and the conflict was never resolved.
#[test]
fn a_follower_with_a_long_conflicting_log_catches_up() {
    let mut net = Net::new(3, true);
    let a = net.run_until_leader(300);
    net.run(10);
    let (b, c) = ((a + 1) % 3, (a + 2) % 3);
    // Leader `a`, cut off alone, appends ten decisions nobody else gets.
    net.isolate(a);
    for id in 0..10 {
        let d = Decision::SetSpeed {
            speed: f64::from(id),
        };
        assert_eq!(
            net.nodes[a as usize].propose(id, d, &mut Notes::new(NOTE_BUDGET)),
            Proposed::Appended
        );
    }
    // `b` and `c` elect a leader of a later term, which commits more than one frame holds.
    let mut l = None;
    for _ in 0..300 {
        net.step();
        l = net.leaders().into_iter().map(|(r, _)| r).find(|&r| r != a);
        if l.is_some() {
            break;
        }
    }
    let l = l.expect("the majority elects a leader");
    for id in 100..130 {
        let d = Decision::SetGoal {
            x: f64::from(id),
            y: 0.0,
        };
        assert_eq!(
            net.nodes[l as usize].propose(id, d, &mut Notes::new(NOTE_BUDGET)),
            Proposed::Appended
        );
    }
    net.run(100);
    let long = net.nodes[l as usize].log().last_index();
    assert_eq!(net.nodes[b as usize].commit(), long);
    assert_eq!(net.nodes[c as usize].commit(), long);
    // Now `l` goes and `a` comes back: the other one leads with the long log, and needs `a`
    // for its majority.
    net.cut.clear();
    net.isolate(l);
    net.run(400);
    let other = if l == b { c } else { b };
    let leader = &net.nodes[other as usize];
    assert_eq!(leader.role(), Role::Leader);
    let r = &net.nodes[a as usize];
    assert_eq!(
        (r.log().last_index(), r.commit(), r.applied()),
        (leader.log().last_index(), leader.commit(), leader.commit()),
        "the old leader catches up with the new one"
    );
    assert!(leader.commit() > long, "the new leader commits its no-op");
    for id in 0..10 {
        assert!(!r.log().has_decision(id), "its own entries were replaced");
    }
}
