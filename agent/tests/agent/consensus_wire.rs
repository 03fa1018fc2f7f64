//! The consensus layer's wire: worst-case messages fit a frame, notes fit the report and
//! render as the checker expects.

use serde::Serialize;
use swarmrt_agent::consensus::{
    ConsensusMsg, ConsensusNote, Decision, Entry, Item, Role, SentCounts,
};
use swarmrt_agent::{Note, RadioMsg};
use swarmrt_protocol::{MAX_PAYLOAD, MAX_REPORT};

fn size<T: Serialize>(v: &T) -> usize {
    postcard::to_allocvec(v).unwrap().len()
}

#[test]
fn worst_case_messages_fit_a_frame() {
    let big = u64::MAX;
    let entry = Entry {
        term: big,
        item: Item::Decision {
            id: u16::MAX,
            decision: Decision::SetGoal { x: 1.0, y: 2.0 },
        },
    };
    // A heartbeat and an AppendEntries with one entry fit even with every number at its
    // largest encoding; the leader adds entries while the frame still fits.
    let append = RadioMsg::Consensus(ConsensusMsg::Append {
        term: big,
        prev_index: big,
        prev_term: big,
        commit: big,
        entries: vec![entry],
    });
    assert!(size(&append) <= MAX_PAYLOAD, "{}", size(&append));
    for m in [
        ConsensusMsg::PreVote {
            term: big,
            last_index: big,
            last_term: big,
        },
        ConsensusMsg::AppendResp {
            term: big,
            success: true,
            index: big,
        },
    ] {
        assert!(size(&RadioMsg::Consensus(m)) <= MAX_PAYLOAD);
    }
}

#[test]
fn notes_are_small_and_round_trip_through_json_and_postcard() {
    let n = Note::Consensus(ConsensusNote::State {
        term: 7,
        role: Role::Leader,
        vote: Some(3),
    });
    // In the record, a consensus note is tagged `consensus` (what the checker reads).
    assert_eq!(
        n.to_json(),
        r#"{"consensus":{"state":{"term":7,"role":"leader","vote":3}}}"#
    );
    assert!(n.claims_leadership());
    let bytes = postcard::to_allocvec(&n).unwrap();
    assert!(bytes.len() <= 6, "{}", bytes.len());
    assert_eq!(postcard::from_bytes::<Note>(&bytes).unwrap(), n);
    // The largest note a robot can emit still leaves room for several in one report.
    let worst = Note::Consensus(ConsensusNote::Sent(SentCounts {
        pre_vote: u32::MAX,
        pre_vote_resp: u32::MAX,
        vote: u32::MAX,
        vote_resp: u32::MAX,
        append: u32::MAX,
        append_resp: u32::MAX,
        quad_claim: u32::MAX,
        quad_leader: u32::MAX,
    }));
    assert!(size(&worst) * 4 < MAX_REPORT);
}

#[test]
fn leaders_claim_leadership_others_do_not() {
    let leader = ConsensusNote::State {
        term: 2,
        role: Role::Leader,
        vote: Some(1),
    };
    let candidate = ConsensusNote::State {
        term: 2,
        role: Role::Candidate,
        vote: Some(1),
    };
    assert!(leader.claims_leadership());
    assert!(!candidate.claims_leadership());
    let q = |leads| ConsensusNote::Quadrant {
        leader: 3,
        leads,
        score: 4,
    };
    assert!(q(true).claims_leadership());
    assert!(!q(false).claims_leadership());
    assert!(!ConsensusNote::Commit { index: 1 }.claims_leadership());
}

#[test]
fn digest_tells_entries_apart() {
    let a = Entry {
        term: 1,
        item: Item::Noop,
    };
    let b = Entry {
        term: 2,
        item: Item::Noop,
    };
    let c = Entry {
        term: 1,
        item: Item::Decision {
            id: 0,
            decision: Decision::SetSpeed { speed: 0.2 },
        },
    };
    assert_eq!(a.digest(), a.digest());
    assert_ne!(a.digest(), b.digest());
    assert_ne!(a.digest(), c.digest());
}
