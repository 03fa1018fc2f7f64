//! The envelopes' wire tags (issue 31): each variant's first byte is the tag its registry line
//! declares, and never moves; the Python and C constants are exactly what
//! `swarmrt_agent::wire` generates from the registry.
//! `SWARMRT_UPDATE_BINDINGS=1 cargo test -p swarmrt-agent --test agent wire_tags` rewrites them.

use std::path::PathBuf;

use swarmrt_agent::behaviours::chain::Link;
use swarmrt_agent::behaviours::flocking::FlockMsg;
use swarmrt_agent::behaviours::formation::{FormationMsg, FormationNote};
use swarmrt_agent::behaviours::goto::Beacon;
use swarmrt_agent::behaviours::grouping::GroupMsg;
use swarmrt_agent::behaviours::planner;
use swarmrt_agent::consensus::{ConsensusMsg, ConsensusNote};
use swarmrt_agent::wire::{self, WireTag};
use swarmrt_agent::{Note, RadioMsg};
use swarmrt_protocol::OPAQUE_TAG;

/// Robots in other languages hard-code these bytes: a tag that moves breaks them. Add a
/// behaviour's line here with its new tag; never change one.
const PINNED: &[(&str, u8)] = &[
    ("Goto", 0),
    ("Formation", 1),
    ("Flocking", 2),
    ("Grouping", 3),
    ("Planner", 4),
    ("Chain", 5),
    ("Consensus", 6),
];

#[test]
fn issue_31_tags_never_move() {
    assert_eq!(wire::tags(), PINNED);
    assert_eq!(wire::CONSENSUS_TAG, 6);
    assert!(wire::tags().iter().all(|t| t.1 != OPAQUE_TAG && t.1 < 0x80));
}

fn one_of_each() -> Vec<RadioMsg> {
    vec![
        RadioMsg::Goto(Beacon {
            x: 1.0,
            y: 2.0,
            theta: 3.0,
        }),
        RadioMsg::Formation(FormationMsg {
            x: 1.0,
            y: 2.0,
            theta: 3.0,
            v: 0.5,
            psi: 0.25,
            role: 2,
            obstacle: 1,
        }),
        RadioMsg::Flocking(FlockMsg::Byte(0xa5)),
        RadioMsg::Grouping(GroupMsg::Join {
            leader: 3,
            x: 1.5,
            y: -2.5,
        }),
        RadioMsg::Planner(planner::PlannerMsg::Beacon(planner::Beacon {
            pos: [1.0, 2.0, 3.0],
            plan: 7,
            hovering: true,
            arrived: false,
            detour: 0,
        })),
        RadioMsg::Chain(Link {
            x: 0.5,
            y: 0.25,
            master: Some([1.0, 2.0]),
            veto: 2,
        }),
        RadioMsg::Consensus(ConsensusMsg::PreVote {
            term: 1,
            last_index: 2,
            last_term: 3,
        }),
    ]
}

#[test]
fn every_radio_message_starts_with_its_pinned_tag_and_round_trips() {
    let msgs = one_of_each();
    assert_eq!(
        msgs.len(),
        WireTag::ALL.len(),
        "one message of each variant"
    );
    for (msg, (name, tag)) in msgs.iter().zip(PINNED) {
        assert_eq!(msg.tag().name(), *name);
        let bytes = postcard::to_allocvec(msg).unwrap();
        assert_eq!(bytes[0], *tag, "{name}");
        assert_eq!(RadioMsg::decode(&bytes).as_ref(), Some(msg), "{name}");
    }
}

#[test]
fn frames_encode_as_they_did_before_the_tags_were_explicit() {
    // The bytes the derived envelope wrote (variant index, then the message).
    let beacon = postcard::to_allocvec(&one_of_each()[0]).unwrap();
    let mut want = vec![0u8];
    for v in [1.0f64, 2.0, 3.0] {
        want.extend(v.to_le_bytes());
    }
    assert_eq!(beacon, want);
    let byte = postcard::to_allocvec(&RadioMsg::Flocking(FlockMsg::Byte(0xa5))).unwrap();
    assert_eq!(byte, [2, 1, 0xa5]);
    let pre_vote = postcard::to_allocvec(&one_of_each()[6]).unwrap();
    assert_eq!(pre_vote, [6, 0, 1, 2, 3]);
}

#[test]
fn unknown_tags_and_opaque_frames_do_not_decode() {
    assert_eq!(RadioMsg::decode(&[7, 0, 0, 0]), None);
    assert_eq!(RadioMsg::decode(&[OPAQUE_TAG, 6, 0, 1, 2, 3]), None);
}

#[test]
fn notes_start_with_their_pinned_tag_and_read_as_json_by_name() {
    let notes = [
        Note::Formation(FormationNote::Role { role: 2 }),
        Note::Consensus(ConsensusNote::Boot {
            term: 0,
            vote: None,
            last_index: 0,
            commit: 0,
        }),
    ];
    for n in &notes {
        let bytes = postcard::to_allocvec(n).unwrap();
        assert_eq!(bytes[0], n.tag() as u8);
        assert_eq!(postcard::from_bytes::<Note>(&bytes).unwrap(), *n);
        // Self-describing formats still name the variant.
        let json = serde_json::to_string(n).unwrap();
        assert!(
            json.starts_with(&format!("{{\"{}\":", n.tag().name())),
            "{json}"
        );
        assert_eq!(serde_json::from_str::<Note>(&json).unwrap(), *n);
    }
    assert_eq!(notes[0].tag(), WireTag::Formation);
    assert_eq!(notes[1].tag() as u8, 6);
    // A report is a postcard `Vec<Note>`: its length, then each note.
    let report = postcard::to_allocvec(&notes[..]).unwrap();
    assert_eq!(&report[..2], &[2, 1]);
}

fn check(rel: &str, want: String) {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join(rel);
    if std::env::var_os("SWARMRT_UPDATE_BINDINGS").is_some() {
        std::fs::write(&path, &want).unwrap();
        return;
    }
    let have = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert!(
        have == want,
        "{rel} is not what swarmrt_agent::wire generates from the registry; regenerate it: \
         SWARMRT_UPDATE_BINDINGS=1 cargo test -p swarmrt-agent --test agent wire_tags"
    );
}

#[test]
fn python_tags_are_generated_from_the_registry() {
    check("bindings/python/swarmrt/_tags.py", wire::python_module());
}

#[test]
fn c_tags_are_generated_from_the_registry() {
    check("bindings/c/include/swarmrt_tags.h", wire::c_header());
}
