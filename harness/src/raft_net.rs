//! Raft cores alone in an in-memory network (after raft-rs's `harness/src/network.rs`):
//! messages take one tick, links can be cut, robots isolated; every note is kept.

use std::collections::BTreeSet;

use swarmrt_agent::consensus::raft::{Raft, RaftParams};
use swarmrt_agent::consensus::{ConsensusMsg, ConsensusNote, Role};
use swarmrt_agent::consensus::{NOTE_BUDGET, Notes, stream};
use swarmrt_protocol::BROADCAST;

/// Raft cores and the messages between them.
pub struct Net {
    /// The Raft cores, robot i at index i.
    pub nodes: Vec<Raft>,
    /// Messages to deliver at the next tick: (from, to, msg).
    pub wire: Vec<(u32, u32, ConsensusMsg)>,
    /// Directed links that lose everything.
    pub cut: BTreeSet<(u32, u32)>,
    /// Every note, per robot, in order.
    pub notes: Vec<Vec<ConsensusNote>>,
    /// Ticks stepped.
    pub tick: u64,
}

/// Raft parameters for `n` robots with short timeouts (10-20 ticks, heartbeat 2).
pub fn params(n: u32, pre_vote: bool) -> RaftParams {
    RaftParams {
        n,
        election_min: 10,
        election_max: 20,
        heartbeat: 2,
        pre_vote,
        check_quorum: true,
    }
}

impl Net {
    /// `n` fresh robots, every link up.
    pub fn new(n: u32, pre_vote: bool) -> Net {
        Net {
            nodes: (0..n)
                .map(|i| Raft::new(i, params(n, pre_vote), stream(7, "test", i as u64)))
                .collect(),
            wire: Vec::new(),
            cut: BTreeSet::new(),
            notes: vec![Vec::new(); n as usize],
            tick: 0,
        }
    }

    /// Cuts every link to and from robot `r`.
    pub fn isolate(&mut self, r: u32) {
        for o in 0..self.nodes.len() as u32 {
            if o != r {
                self.cut.insert((r, o));
                self.cut.insert((o, r));
            }
        }
    }

    /// One tick: deliver, step, tick, collect messages (4 frames each).
    pub fn step(&mut self) {
        let wire = std::mem::take(&mut self.wire);
        for (i, node) in self.nodes.iter_mut().enumerate() {
            let mut notes = Notes::new(NOTE_BUDGET);
            for (from, to, m) in &wire {
                if *to == i as u32 {
                    node.step(*from, m, &mut notes);
                }
            }
            node.tick(&mut notes);
            while node.next_apply(&mut notes).is_some() {}
            self.notes[i].extend(notes.take());
        }
        let n = self.nodes.len() as u32;
        for (i, node) in self.nodes.iter_mut().enumerate() {
            let from = i as u32;
            for (dst, m) in node.ready(4) {
                let targets: Vec<u32> = if dst == BROADCAST {
                    (0..n).filter(|&o| o != from).collect()
                } else {
                    vec![dst]
                };
                for to in targets {
                    if !self.cut.contains(&(from, to)) {
                        self.wire.push((from, to, m.clone()));
                    }
                }
            }
        }
        self.tick += 1;
    }

    /// `ticks` ticks.
    pub fn run(&mut self, ticks: u64) {
        for _ in 0..ticks {
            self.step();
        }
    }

    /// Every robot that believes it leads, with its term.
    pub fn leaders(&self) -> Vec<(u32, u64)> {
        self.nodes
            .iter()
            .enumerate()
            .filter(|(_, r)| r.role() == Role::Leader)
            .map(|(i, r)| (i as u32, r.term()))
            .collect()
    }

    /// Steps until exactly one robot leads; panics after `limit` ticks.
    pub fn run_until_leader(&mut self, limit: u64) -> u32 {
        for _ in 0..limit {
            self.step();
            if let [(l, _)] = self.leaders()[..] {
                return l;
            }
        }
        panic!(
            "no single leader within {limit} ticks: {:?}",
            self.leaders()
        );
    }
}
