//! The planner behaviour's wire: a route travels in parts that each fit one AppendEntries
//! frame and one report, and the parts rebuild the route exactly.

use crate::behaviours::planner::split;
use crate::consensus::raft::fits_frame;
use crate::consensus::{
    ConsensusMsg, ConsensusNote, Decision, Entry, Item, NOTE_BUDGET, Notes, ROUTE_PART_MOVES,
    RoutePart, UNSCHEDULED,
};
use swarmrt_planner::{Cell, Route};

/// A route of `n` moves zig-zagging east and up and down, from slot `start_slot`.
fn route(n: usize, start_slot: u32) -> Route {
    let mut cells = vec![Cell { i: 0, j: 3, k: 1 }];
    for s in 0..n {
        let c = *cells.last().unwrap();
        cells.push(Cell {
            i: c.i + 1,
            j: c.j,
            k: if s % 2 == 0 { c.k + 1 } else { c.k - 1 },
        });
    }
    Route {
        start_slot,
        cells,
        cost: 0.0,
        expansions: 0,
    }
}

#[test]
fn a_long_route_splits_into_parts_that_rebuild_it() {
    let r = route(70, 9);
    let parts = split(4097, 2, &r);
    assert_eq!(parts.len(), 3);
    let mut moves = Vec::new();
    for (k, p) in parts.iter().enumerate() {
        assert_eq!(
            (p.part as usize, p.parts, p.plan, p.vehicle),
            (k, 3, 4097, 2)
        );
        // Each part starts where and when the route is at its first move.
        let at = k * ROUTE_PART_MOVES;
        let c = r.cells[at];
        assert_eq!(p.start, [c.i, c.j, c.k]);
        assert_eq!(p.start_slot, 9 + at as u32);
        moves.extend_from_slice(&p.moves[..p.len as usize]);
    }
    let first = parts[0].start;
    let back = Route::from_moves(
        Cell {
            i: first[0],
            j: first[1],
            k: first[2],
        },
        parts[0].start_slot,
        &moves,
    )
    .unwrap();
    assert_eq!(back.cells, r.cells);
    assert_eq!(back.start_slot, r.start_slot);
    // A route that is only a start (the vehicle is at its goal) is one empty part.
    let parts = split(1, 0, &route(0, 3));
    assert_eq!((parts.len(), parts[0].len), (1, 0));
}

fn full_part() -> RoutePart {
    let r = route(ROUTE_PART_MOVES, u32::MAX / 4);
    let mut p = split(u32::MAX, u32::MAX - 1, &r)[0];
    p.start = [u16::MAX; 3];
    p
}

#[test]
fn a_full_part_fits_one_append_frame_even_at_huge_terms_and_indexes() {
    let entry = Entry {
        term: u64::MAX / 2,
        item: Item::Decision {
            id: UNSCHEDULED,
            decision: Decision::Route(full_part()),
        },
    };
    let m = ConsensusMsg::Append {
        term: u64::MAX / 2,
        prev_index: u64::MAX / 2,
        prev_term: u64::MAX / 2,
        commit: u64::MAX / 2,
        entries: vec![entry],
    };
    assert!(fits_frame(&m), "{m:?}");
    // Its digest covers the whole entry (two routes that differ in their last move differ).
    let mut other = full_part();
    other.moves[ROUTE_PART_MOVES - 1] ^= 1;
    let e2 = Entry {
        item: Item::Decision {
            id: UNSCHEDULED,
            decision: Decision::Route(other),
        },
        ..entry
    };
    assert_ne!(entry.digest(), e2.digest());
}

#[test]
fn proposing_a_full_part_leaves_room_in_the_report() {
    let note = ConsensusNote::Propose {
        index: u64::MAX / 2,
        term: u64::MAX / 2,
        id: UNSCHEDULED,
        decision: Decision::Route(full_part()),
    };
    let cost = Notes::cost(&note);
    let mut buf = [0u8; 256];
    let exact = postcard::to_slice(&note, &mut buf).unwrap().len() + 1;
    assert_eq!(cost, exact, "the cost is the exact encoded size");
    assert!(cost * 2 < NOTE_BUDGET, "{cost} of {NOTE_BUDGET}");
}
