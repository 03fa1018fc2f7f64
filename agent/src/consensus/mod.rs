//! Consensus among the robots: a Raft-style election and replicated log of swarm decisions
//! ([`raft`]), or the quadrant leader choice of seed 001 ([`quadrant`]).
//!
//! The cores are pure state machines (no I/O, no clock, randomness seeded from the run seed
//! and robot id). [`Consensus`] is the thin layer the [`crate::Agent`] calls once per tick:
//! it feeds the tick's radio messages and the passage of time to the core, proposes the
//! scheduled decisions, hands back the decisions to act on, and returns what the core has to
//! say ([`Ready`]: its frames and notes, which the agent puts into the command) and what of
//! its state must be durable first ([`Consensus::take_persist`]). It knows nothing of the
//! behaviours' envelopes: the arrows run from the agent to here, never back.
//!
//! Scheduled proposals are not forwarded: every robot has the schedule (it is in the config),
//! so the robot that is leader at the proposal's tick, or the first one after it, proposes
//! it; a decision already in the leader's log (put there by an earlier leader) is not
//! proposed again.
//!
//! The Raft core alone, for a group of one (which elects itself):
//!
//! ```
//! use swarmrt_agent::consensus::raft::{Proposed, Raft, RaftParams};
//! use swarmrt_agent::consensus::{NOTE_BUDGET, Notes, stream};
//! use swarmrt_agent::consensus::{ConsensusNote, Decision, Role};
//!
//! let p = RaftParams { n: 1, election_min: 5, election_max: 10, heartbeat: 2,
//!                      pre_vote: true, check_quorum: true };
//! let mut raft = Raft::new(0, p, stream(42, "raft", 0));
//! let mut notes = Notes::new(NOTE_BUDGET);
//! while raft.role() != Role::Leader {
//!     raft.tick(&mut notes); // time enters as ticks; messages would enter through step()
//! }
//! let d = Decision::SetGoal { x: 3.0, y: 4.0 };
//! assert_eq!(raft.propose(0, d, &mut notes), Proposed::Appended);
//! while raft.next_apply(&mut notes).is_some() {} // the no-op, then the decision
//! assert_eq!(raft.applied(), 2);
//! // Every change was reported, for the run record and the checker.
//! assert!(notes.as_slice().iter().any(|n| matches!(n, ConsensusNote::Apply { index: 2, .. })));
//! ```

pub mod log;
pub mod messages;
pub mod notes;
pub mod persist;
pub mod quadrant;
pub mod raft;
pub mod storage;

use rand::Rng as _;
use swarmrt_protocol::{MAX_REPORT, Observation};
use swarmrt_scenario::Config;
use swarmrt_scenario::consensus::{Algorithm, ConsensusConfig};

use crate::inbox::Heard;
pub use messages::{ConsensusMsg, Decision, Entry, Item, ROUTE_PART_MOVES, RoutePart, UNSCHEDULED};
pub use notes::{ConsensusNote, RecordedNote, Role, SentCounts, behaviour_notes};
use persist::{Persist, Persistent};
use quadrant::Quadrant;
use raft::{Raft, RaftParams};

/// What a behaviour knows of the election (Raft only).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Leadership {
    /// This robot's current term.
    pub term: u64,
    /// The leader of that term, when this robot knows it.
    pub leader: Option<u32>,
    /// Whether this robot is that leader (and may propose).
    pub is_leader: bool,
    /// How many of the behaviour's proposals of the previous tick were appended to the log
    /// (the first ones, in order; the behaviour proposes the others again).
    pub appended: usize,
}

/// Every random draw of the cores comes from the run's shared seeded streams.
pub use swarmrt_scenario::rng::{Rng, stream};

/// Report bytes kept free for the behaviour's own notes.
pub const BEHAVIOUR_NOTE_RESERVE: usize = 32;
/// Report bytes consensus notes may use per tick: the report minus the behaviour's share
/// and the two bytes of the note list's length prefix.
pub const NOTE_BUDGET: usize = MAX_REPORT - BEHAVIOUR_NOTE_RESERVE - 2;

/// One tick's consensus notes with their encoded size, so they always fit the report.
#[derive(Debug, Clone, Default)]
pub struct Notes {
    notes: Vec<ConsensusNote>,
    used: usize,
    reserved: usize,
    cap: usize,
}

impl Notes {
    /// An empty list that may hold `cap` encoded bytes.
    pub fn new(cap: usize) -> Notes {
        Notes {
            cap,
            ..Notes::default()
        }
    }

    /// Encoded size of `n` as one element of the report's `Vec<Note>` (one byte for the
    /// `Note::Consensus` tag).
    pub fn cost(n: &ConsensusNote) -> usize {
        let mut buf = [0u8; 200];
        1 + postcard::to_slice(n, &mut buf).map_or(200, |b| b.len())
    }

    /// Bytes still free (minus reservations).
    pub fn room(&self) -> usize {
        self.cap.saturating_sub(self.used + self.reserved)
    }

    /// Keeps `bytes` free for a later step of this tick.
    pub fn reserve(&mut self, bytes: usize) {
        self.reserved += bytes;
    }

    /// Returns a reservation.
    pub fn release(&mut self, bytes: usize) {
        self.reserved = self.reserved.saturating_sub(bytes);
    }

    /// Adds a note (callers check [`Notes::room`] before changing state).
    pub fn push(&mut self, n: ConsensusNote) {
        self.used += Self::cost(&n);
        self.notes.push(n);
    }

    /// The notes so far.
    pub fn as_slice(&self) -> &[ConsensusNote] {
        &self.notes
    }

    /// Takes the notes, leaving the list empty.
    pub fn take(&mut self) -> Vec<ConsensusNote> {
        self.used = 0;
        self.reserved = 0;
        std::mem::take(&mut self.notes)
    }
}

/// What the consensus layer has to say at the end of a tick: its frames, to send after the
/// behaviour's, and its notes, to report after the behaviour's.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Ready {
    /// `(destination, message)`, at most the frames the behaviour left free.
    pub frames: Vec<(u32, ConsensusMsg)>,
    /// This tick's notes, within [`NOTE_BUDGET`].
    pub notes: Vec<ConsensusNote>,
}

enum Core {
    Raft(Box<Raft>),
    Quadrant(Quadrant),
}

/// A robot's consensus layer.
pub struct Consensus {
    core: Core,
    schedule: Vec<(u64, Decision)>,
    /// Scheduled decisions applied by this robot (so far since its last start).
    applied_ids: Vec<bool>,
    notes: Notes,
    boot: Option<ConsensusNote>,
    sent: SentCounts,
    sent_noted: SentCounts,
    stats_every: u64,
    capacity: usize,
    /// Whether the robot keeps its Raft state in stable storage ([`stores_state`]).
    durable: bool,
    tick: u64,
    /// The behaviour's proposals appended last tick ([`Leadership::appended`]).
    appended: usize,
}

/// Upper bound of a [`ConsensusNote::Sent`] note.
fn sent_note_bound() -> usize {
    Notes::cost(&ConsensusNote::Sent(SentCounts {
        pre_vote: u32::MAX,
        pre_vote_resp: u32::MAX,
        vote: u32::MAX,
        vote_resp: u32::MAX,
        append: u32::MAX,
        append_resp: u32::MAX,
        quad_claim: u32::MAX,
        quad_leader: u32::MAX,
    }))
}

/// True when robots of this scenario keep their persistent Raft state in stable storage
/// (`consensus.storage`, Raft only: the quadrant choice has no state worth keeping).
pub fn stores_state(cfg: &Config) -> bool {
    cfg.consensus
        .as_ref()
        .is_some_and(|c| c.storage && c.algorithm == Algorithm::Raft)
}

impl Consensus {
    /// Robot `id`'s consensus layer, or `None` when the scenario has no `[consensus]`.
    pub fn new(cfg: &Config, id: u32) -> Option<Consensus> {
        Self::build(cfg, id, None, 0)
    }

    /// Robot `id` in a fresh process after `incarnation` restarts, with no persistent state.
    pub fn fresh(cfg: &Config, id: u32, incarnation: u32) -> Option<Consensus> {
        Self::build(cfg, id, None, incarnation)
    }

    /// Robot `id` restarting after a crash with the persistent state it had (`incarnation`
    /// counts its restarts and keys a fresh random stream for its timeouts).
    pub fn restore(
        cfg: &Config,
        id: u32,
        state: Persistent,
        incarnation: u32,
    ) -> Option<Consensus> {
        Self::build(cfg, id, Some(state), incarnation)
    }

    fn build(
        cfg: &Config,
        id: u32,
        state: Option<Persistent>,
        incarnation: u32,
    ) -> Option<Consensus> {
        let c: &ConsensusConfig = cfg.consensus.as_ref()?;
        let seed = cfg.scenario.seed;
        let stream_id = id as u64 | (incarnation as u64) << 32;
        let core = match c.algorithm {
            Algorithm::Raft => {
                let p = RaftParams {
                    n: cfg.robots.count,
                    election_min: c.election_timeout_min,
                    election_max: c.election_timeout_max,
                    heartbeat: c.heartbeat_ticks,
                    pre_vote: c.pre_vote,
                    check_quorum: c.check_quorum,
                };
                let rng = stream(seed, "raft", stream_id);
                Core::Raft(Box::new(match state {
                    Some(s) => Raft::restore(id, p, s, rng),
                    None => Raft::new(id, p, rng),
                }))
            }
            Algorithm::Quadrant => {
                let draw = stream(seed, "quadrant", id as u64).random::<u32>();
                Core::Quadrant(Quadrant::new(
                    id,
                    c.quadrant.claim_period,
                    c.quadrant.decide_tick,
                    draw,
                ))
            }
        };
        let boot = match &core {
            Core::Raft(r) => Some(r.boot_note()),
            Core::Quadrant(_) => None,
        };
        Some(Consensus {
            core,
            schedule: c
                .propose
                .iter()
                .map(|p| (p.tick, Decision::from(p)))
                .collect(),
            applied_ids: vec![false; c.propose.len()],
            notes: Notes::new(NOTE_BUDGET),
            boot,
            sent: SentCounts::default(),
            sent_noted: SentCounts::default(),
            stats_every: c.stats_every.max(1) as u64,
            capacity: cfg.radio.capacity as usize,
            durable: stores_state(cfg),
            tick: 0,
            appended: 0,
        })
    }

    /// The Raft core, when this robot runs Raft.
    pub fn raft(&self) -> Option<&Raft> {
        match &self.core {
            Core::Raft(r) => Some(r),
            Core::Quadrant(_) => None,
        }
    }

    /// The quadrant core, when this robot runs the quadrant leader choice.
    pub fn quadrant(&self) -> Option<&Quadrant> {
        match &self.core {
            Core::Quadrant(q) => Some(q),
            Core::Raft(_) => None,
        }
    }

    /// What must survive a crash (Raft only), whole: a clone of the log, for checks and
    /// tests (a tick hands over only what changed, [`Consensus::take_persist`]).
    pub fn persistent(&self) -> Option<Persistent> {
        self.raft().map(|r| r.persistent())
    }

    /// What changed of the persistent Raft state since the last call, when the robot keeps
    /// it in stable storage: durable before this tick's command leaves. `None` otherwise.
    pub fn take_persist(&mut self) -> Option<Persist> {
        match &mut self.core {
            Core::Raft(r) if self.durable => r.take_persist(),
            _ => None,
        }
    }

    /// Messages sent so far, per kind.
    pub fn sent(&self) -> SentCounts {
        self.sent
    }

    /// Feeds this tick's messages and the passage of time; returns the committed decisions
    /// to act on now, in log order.
    pub fn step(&mut self, obs: &Observation, inbox: &[Heard<ConsensusMsg>]) -> Vec<Decision> {
        self.tick = obs.tick;
        self.notes = Notes::new(NOTE_BUDGET);
        if let Some(b) = self.boot.take() {
            self.notes.push(b);
        }
        let stats_due = obs.tick.is_multiple_of(self.stats_every);
        let stats_bound = if stats_due { sent_note_bound() } else { 0 };
        self.notes.reserve(stats_bound);
        let mut out = Vec::new();
        match &mut self.core {
            Core::Raft(r) => {
                // Time's notes are reserved first so a busy inbox cannot starve the timers.
                let tick_bound = r.tick_bound();
                self.notes.reserve(tick_bound);
                for d in inbox {
                    r.step(d.src, &d.msg, &mut self.notes);
                }
                self.notes.release(tick_bound);
                r.tick(&mut self.notes);
                for (k, &(at, decision)) in self.schedule.iter().enumerate() {
                    if at <= obs.tick && !self.applied_ids[k] {
                        let id = k as u16;
                        if r.propose(id, decision, &mut self.notes) == raft::Proposed::NoRoom {
                            break;
                        }
                    }
                }
                while let Some(e) = r.next_apply(&mut self.notes) {
                    if let Item::Decision { id, decision } = e.item {
                        if let Some(done) = self.applied_ids.get_mut(id as usize) {
                            *done = true;
                        }
                        out.push(decision);
                    }
                }
            }
            Core::Quadrant(q) => {
                q.observe(obs.neighbours());
                for d in inbox {
                    q.step(d.src, &d.msg);
                }
                q.tick(obs.tick, &mut self.notes);
            }
        }
        self.notes.release(stats_bound);
        out
    }

    /// Who leads, as this robot knows it now (Raft only).
    pub fn leadership(&self) -> Option<Leadership> {
        let r = self.raft()?;
        Some(Leadership {
            term: r.term(),
            leader: r.leader(),
            is_leader: r.role() == Role::Leader,
            appended: self.appended,
        })
    }

    /// As leader, appends the decisions the behaviour proposed this tick, in order, as far as
    /// this tick's note budget allows; returns how many were appended (the behaviour proposes
    /// the rest again). Not leader: 0.
    pub fn propose(&mut self, decisions: &[Decision]) -> usize {
        self.appended = 0;
        let Core::Raft(r) = &mut self.core else {
            return 0;
        };
        // The statistics note `ready` may add must still fit.
        let stats = sent_note_bound();
        self.notes.reserve(stats);
        let mut done = 0;
        for &d in decisions {
            if r.propose(UNSCHEDULED, d, &mut self.notes) != raft::Proposed::Appended {
                break;
            }
            done += 1;
        }
        self.notes.release(stats);
        self.appended = done;
        done
    }

    /// What the core has to say this tick: its messages for the frames the behaviour left
    /// free (`used` of `radio.capacity` are taken; every message fits a frame, so all of them
    /// are sent and counted), and its notes, with the statistics note when it is due.
    pub fn ready(&mut self, used: usize) -> Ready {
        let budget = self.capacity.saturating_sub(used);
        let frames = match &mut self.core {
            Core::Raft(r) => r.ready(budget),
            Core::Quadrant(q) => q.ready(budget),
        };
        for (_, m) in &frames {
            self.sent.count(m);
        }
        if self.tick.is_multiple_of(self.stats_every) && self.sent != self.sent_noted {
            self.sent_noted = self.sent;
            self.notes.push(ConsensusNote::Sent(self.sent));
        }
        Ready {
            frames,
            notes: self.notes.take(),
        }
    }
}
