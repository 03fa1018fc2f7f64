//! A Raft core (Ongaro & Ousterhout, "In Search of an Understandable Consensus Algorithm",
//! 2014; section numbers below refer to it, "thesis" to Ongaro's 2014 dissertation).
//!
//! Shaped like tikv/raft-rs's `RawNode`: the core never sends, sleeps or reads a clock. Time
//! enters as [`Raft::tick`], messages as [`Raft::step`], and the caller takes the messages to
//! send with [`Raft::ready`] and what changed of the persistent state with
//! [`Raft::take_persist`], which it makes durable before those messages leave. Its one
//! random draw (the election timeout) comes from an RNG the caller seeded from the run seed.
//!
//! Adapted to a lossy broadcast radio with a few frames per tick:
//! - the leader broadcasts AppendEntries (every follower whose log matches at `prev_index`
//!   takes them; the others refuse with a hint and are caught up by the next broadcast,
//!   which starts at the lowest `next_index` of the recently heard followers);
//! - candidates repeat their (pre-)vote requests every heartbeat period, since a lost request
//!   is never answered ("if RPCs fail, they are retried", section 5.1);
//! - pre-vote (thesis 9.6), the leader lease on votes (thesis 4.2.3) and check-quorum
//!   (thesis 6.2), so a robot that drifts out of range and back cannot depose a leader;
//! - every state change is reported as a [`ConsensusNote`] within a byte budget per tick; a
//!   message whose notes would not fit is left unprocessed, exactly as if the radio had lost
//!   it, which Raft tolerates.

use super::{ConsensusMsg, ConsensusNote, Decision, Entry, Item, Role, UNSCHEDULED};
use rand::Rng as _;
use swarmrt_protocol::{BROADCAST, MAX_PAYLOAD};

use super::log::Log;
pub use super::persist::{HardState, LogSuffix, Persist, Persistent};
use super::{Notes, Rng};

/// Known bugs the fuzzer must catch (issue 18). Compiled only with the `mutants` feature, and
/// even then inert: a mutant is active only on the thread that selected it with
/// [`set_mutant`], which only `swarm fuzz consensus --mutant` and the harness tests call.
#[cfg(feature = "mutants")]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mutant {
    /// Grant every vote request (no one-vote-per-term).
    VoteForAnyone,
    /// Grant (pre-)votes without the up-to-date check (section 5.4.1).
    NoUpToDateCheck,
    /// A follower keeps a conflicting entry instead of truncating (Figure 2, step 3).
    KeepConflictingEntries,
    /// Commit entries of earlier terms by counting replicas (Figure 8).
    CommitEarlierTerm,
    /// A restart restores everything but the vote.
    ForgetVoteOnRestart,
    /// Accept AppendEntries from a stale term.
    AcceptStaleAppend,
    /// A leader adopts a higher term but keeps leading.
    NoStepDown,
    /// Apply entries before they are committed.
    ApplyBeforeCommit,
}

#[cfg(feature = "mutants")]
impl Mutant {
    /// Every mutant, with its command-line name.
    pub const ALL: [(&'static str, Mutant); 8] = [
        ("vote-for-anyone", Mutant::VoteForAnyone),
        ("no-up-to-date-check", Mutant::NoUpToDateCheck),
        ("keep-conflicting-entries", Mutant::KeepConflictingEntries),
        ("commit-earlier-term", Mutant::CommitEarlierTerm),
        ("forget-vote-on-restart", Mutant::ForgetVoteOnRestart),
        ("accept-stale-append", Mutant::AcceptStaleAppend),
        ("no-step-down", Mutant::NoStepDown),
        ("apply-before-commit", Mutant::ApplyBeforeCommit),
    ];

    /// The mutant called `name`.
    pub fn parse(name: &str) -> Option<Mutant> {
        Mutant::ALL
            .iter()
            .find(|(n, _)| *n == name)
            .map(|&(_, m)| m)
    }
}

#[cfg(feature = "mutants")]
thread_local! {
    static MUTANT: std::cell::Cell<Option<Mutant>> = const { std::cell::Cell::new(None) };
}

/// Selects the mutant of every core on this thread (`None`: the real core).
#[cfg(feature = "mutants")]
pub fn set_mutant(m: Option<Mutant>) {
    MUTANT.with(|c| c.set(m));
}

/// The mutant selection of the calling thread, to carry onto the worker threads a caller
/// splits robots over (the selection is per thread so that tests can run side by side).
/// Without the `mutants` feature it carries nothing.
#[derive(Debug, Clone, Copy)]
pub struct MutantScope {
    #[cfg(feature = "mutants")]
    mutant: Option<Mutant>,
}

impl MutantScope {
    /// This thread's selection.
    pub fn current() -> MutantScope {
        MutantScope {
            #[cfg(feature = "mutants")]
            mutant: MUTANT.with(|c| c.get()),
        }
    }

    /// Makes it this thread's selection.
    pub fn enter(self) {
        #[cfg(feature = "mutants")]
        set_mutant(self.mutant);
    }
}

#[cfg(feature = "mutants")]
macro_rules! mutant {
    ($m:ident) => {
        MUTANT.with(|c| c.get()) == Some(Mutant::$m)
    };
}

#[cfg(not(feature = "mutants"))]
macro_rules! mutant {
    ($m:ident) => {
        false
    };
}

/// Timing and membership.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RaftParams {
    /// Group size: robots `0..n` are the members; a majority is `n / 2 + 1`.
    pub n: u32,
    /// Election timeout lower bound in ticks (also the lease).
    pub election_min: u32,
    /// Election timeout upper bound in ticks (exclusive); check-quorum period.
    pub election_max: u32,
    /// Ticks between heartbeats and between repeated requests.
    pub heartbeat: u32,
    /// Run the pre-vote phase before a real election.
    pub pre_vote: bool,
    /// Leaders step down without a majority's responses for `election_max` ticks.
    pub check_quorum: bool,
}

/// Result of [`Raft::propose`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Proposed {
    /// Appended to the leader's log.
    Appended,
    /// The decision is in the log already (proposed by this or an earlier leader).
    AlreadyInLog,
    /// Only a leader proposes; the proposal waits.
    NotLeader,
    /// This tick's note budget is spent; try again next tick.
    NoRoom,
}

#[derive(Debug, Clone, Copy, Default)]
struct Progress {
    /// Next index to send (section 5.3).
    next: u64,
    /// Highest index known to match.
    matched: u64,
    /// Tick of the last response.
    heard: u64,
    /// Responded since the last check-quorum.
    recent: bool,
}

/// One robot's Raft state machine.
#[derive(Debug, Clone)]
pub struct Raft {
    id: u32,
    p: RaftParams,
    term: u64,
    vote: Option<u32>,
    log: Log,
    commit: u64,
    applied: u64,
    role: Role,
    leader: Option<u32>,
    election_elapsed: u32,
    timeout: u32,
    /// Ticks since the last heartbeat (leader) or request (candidates).
    since_send: u32,
    quorum_elapsed: u32,
    /// Pre-vote or vote answers of the current campaign, per robot.
    votes: Vec<Option<bool>>,
    progress: Vec<Progress>,
    /// Highest index broadcast so far in this term.
    sent_until: u64,
    /// A follower refused: resend from the lowest `next` without waiting for the heartbeat.
    probe: bool,
    now: u64,
    rng: Rng,
    msgs: Vec<(u32, ConsensusMsg)>,
    noted: (u64, Role, Option<u32>),
    left_for_notes: u64,
    unsent: u64,
    /// The hard state as last handed over by [`Raft::take_persist`]; `None` until the first
    /// hand-over of a new core, whose state was never written.
    stable: Option<HardState>,
    /// The lowest log index changed since the last hand-over.
    unstable_from: Option<u64>,
}

impl Raft {
    /// A fresh member `id` with an empty log.
    pub fn new(id: u32, p: RaftParams, rng: Rng) -> Raft {
        let mut r = Raft::restore(id, p, Persistent::default(), rng);
        r.stable = None;
        r
    }

    /// A member restarting from its persistent state: a follower that re-applies its
    /// committed entries from index 1 (the state machine is volatile, section 5 / Figure 2).
    pub fn restore(id: u32, p: RaftParams, s: Persistent, rng: Rng) -> Raft {
        let n = p.n.max(1) as usize;
        let stable = Some(s.hard_state());
        let commit = s.commit.min(s.log.last_index());
        let mut r = Raft {
            id,
            p,
            term: s.term,
            vote: if mutant!(ForgetVoteOnRestart) {
                None
            } else {
                s.vote
            },
            log: s.log,
            commit,
            applied: 0,
            role: Role::Follower,
            leader: None,
            election_elapsed: 0,
            timeout: p.election_min,
            since_send: 0,
            quorum_elapsed: 0,
            votes: vec![None; n],
            progress: vec![Progress::default(); n],
            sent_until: 0,
            probe: false,
            now: 0,
            rng,
            msgs: Vec::new(),
            noted: (s.term, Role::Follower, s.vote),
            left_for_notes: 0,
            unsent: 0,
            stable,
            unstable_from: None,
        };
        r.reset_timeout();
        r
    }

    /// The note reporting the state this core started from.
    pub fn boot_note(&self) -> ConsensusNote {
        ConsensusNote::Boot {
            term: self.term,
            vote: self.vote,
            last_index: self.log.last_index(),
            commit: self.commit,
        }
    }

    /// What must survive a crash, whole (a clone of the log: for checks and tests; a step
    /// hands over only what changed, [`Raft::take_persist`]).
    pub fn persistent(&self) -> Persistent {
        Persistent {
            term: self.term,
            vote: self.vote,
            commit: self.commit,
            log: self.log.clone(),
        }
    }

    /// The hard state now.
    pub fn hard_state(&self) -> HardState {
        HardState {
            term: self.term,
            vote: self.vote,
            commit: self.commit,
        }
    }

    /// What changed in the persistent state since the last call (a new core's first call
    /// hands over its hard state): to be made durable before any message sent since then
    /// leaves. `None` when nothing changed.
    pub fn take_persist(&mut self) -> Option<Persist> {
        let now = self.hard_state();
        let hard = (self.stable != Some(now)).then_some(now);
        let log = self.unstable_from.take().map(|first| LogSuffix {
            first,
            entries: self.log.from(first).to_vec(),
        });
        if hard.is_none() && log.is_none() {
            return None;
        }
        self.stable = Some(now);
        Some(Persist { hard, log })
    }

    /// Appends `e` to the log, remembering the change for [`Raft::take_persist`].
    fn log_push(&mut self, e: Entry) {
        self.log.push(e);
        self.touched(self.log.last_index());
    }

    /// Truncates the log from `index` on, remembering the change.
    fn log_truncate(&mut self, index: u64) {
        self.log.truncate_from(index);
        self.touched(index);
    }

    fn touched(&mut self, index: u64) {
        self.unstable_from = Some(self.unstable_from.map_or(index, |f| f.min(index)));
    }

    /// Current term.
    pub fn term(&self) -> u64 {
        self.term
    }

    /// Current role.
    pub fn role(&self) -> Role {
        self.role
    }

    /// The leader this robot follows (itself when leader), if known.
    pub fn leader(&self) -> Option<u32> {
        self.leader
    }

    /// Vote in the current term.
    pub fn vote(&self) -> Option<u32> {
        self.vote
    }

    /// Commit index.
    pub fn commit(&self) -> u64 {
        self.commit
    }

    /// Last applied index.
    pub fn applied(&self) -> u64 {
        self.applied
    }

    /// The log.
    pub fn log(&self) -> &Log {
        &self.log
    }

    /// Messages left unprocessed because their notes would not have fit this tick's report.
    pub fn left_for_notes(&self) -> u64 {
        self.left_for_notes
    }

    /// Messages dropped because the tick's frame budget was spent.
    pub fn unsent(&self) -> u64 {
        self.unsent
    }

    fn quorum(&self) -> usize {
        self.p.n as usize / 2 + 1
    }

    fn reset_timeout(&mut self) {
        let (lo, hi) = (
            self.p.election_min,
            self.p.election_max.max(self.p.election_min + 1),
        );
        self.timeout = self.rng.random_range(lo..hi);
    }

    /// Within the lease: the leader itself, or a follower that heard its leader less than
    /// `election_min` ticks ago. Such a robot ignores (pre-)vote requests of higher terms
    /// (thesis 4.2.3), so a returning robot cannot disrupt a working leader.
    fn in_lease(&self) -> bool {
        match self.role {
            Role::Leader => true,
            Role::Follower => self.leader.is_some() && self.election_elapsed < self.p.election_min,
            _ => false,
        }
    }

    /// Candidate's log at least as up-to-date as ours (section 5.4.1).
    fn up_to_date(&self, last_index: u64, last_term: u64) -> bool {
        mutant!(NoUpToDateCheck)
            || (last_term, last_index) >= (self.log.last_term(), self.log.last_index())
    }

    fn send(&mut self, to: u32, m: ConsensusMsg) {
        self.msgs.push((to, m));
    }

    fn note_state(&mut self, notes: &mut Notes) {
        let now = (self.term, self.role, self.vote);
        if now != self.noted {
            self.noted = now;
            notes.push(ConsensusNote::State {
                term: self.term,
                role: self.role,
                vote: self.vote,
            });
        }
    }

    fn state_cost(term: u64) -> usize {
        Notes::cost(&ConsensusNote::State {
            term,
            role: Role::PreCandidate,
            vote: Some(u32::MAX),
        })
    }

    /// Upper bound of the note bytes one [`Raft::tick`] may produce.
    pub fn tick_bound(&self) -> usize {
        let t = self.term.saturating_add(1);
        let i = self.log.last_index() + 1;
        Self::state_cost(t)
            + Notes::cost(&ConsensusNote::Append {
                index: i,
                term: t,
                digest: u32::MAX,
            })
            + Notes::cost(&ConsensusNote::Commit { index: i })
    }

    /// Upper bound of the note bytes stepping `msg` may produce.
    fn step_bound(&self, msg: &ConsensusMsg) -> usize {
        let t = self.term.max(msg_term(msg)).saturating_add(1);
        let state = Self::state_cost(t);
        match msg {
            ConsensusMsg::Append {
                prev_index,
                commit,
                entries,
                ..
            } => {
                let first = prev_index.saturating_add(1);
                let mut b = state
                    + Notes::cost(&ConsensusNote::Truncate { index: first })
                    + Notes::cost(&ConsensusNote::Commit { index: *commit });
                for (k, e) in entries.iter().enumerate() {
                    b += Notes::cost(&ConsensusNote::Append {
                        index: first.saturating_add(k as u64),
                        term: e.term,
                        digest: u32::MAX,
                    });
                }
                b
            }
            ConsensusMsg::PreVoteResp { .. } | ConsensusMsg::VoteResp { .. } => {
                // Winning appends the leader's no-op (and commits it in a group of one).
                let i = self.log.last_index() + 1;
                state
                    + Notes::cost(&ConsensusNote::Append {
                        index: i,
                        term: t,
                        digest: u32::MAX,
                    })
                    + Notes::cost(&ConsensusNote::Commit { index: i })
            }
            ConsensusMsg::AppendResp { .. } => {
                state
                    + Notes::cost(&ConsensusNote::Commit {
                        index: self.log.last_index(),
                    })
            }
            _ => state,
        }
    }

    fn become_follower(&mut self, term: u64, leader: Option<u32>) {
        if term > self.term {
            self.term = term;
            self.vote = None;
        }
        self.role = Role::Follower;
        self.leader = leader;
        self.election_elapsed = 0;
        self.reset_timeout();
        self.votes.fill(None);
    }

    /// Election timeout: ask for pre-votes first (thesis 9.6), or campaign at once.
    fn campaign_pre(&mut self, notes: &mut Notes) {
        if !self.p.pre_vote {
            self.campaign(notes);
            return;
        }
        self.role = Role::PreCandidate;
        self.leader = None;
        self.votes.fill(None);
        self.votes[self.id as usize] = Some(true);
        self.election_elapsed = 0;
        self.reset_timeout();
        self.since_send = 0;
        if self.quorum() <= 1 {
            self.campaign(notes);
        } else {
            self.send_request();
        }
    }

    /// Section 5.2: increment the term, vote for itself, request votes.
    fn campaign(&mut self, notes: &mut Notes) {
        self.term = self.term.saturating_add(1);
        self.vote = Some(self.id);
        self.role = Role::Candidate;
        self.leader = None;
        self.votes.fill(None);
        self.votes[self.id as usize] = Some(true);
        self.election_elapsed = 0;
        self.reset_timeout();
        self.since_send = 0;
        if self.quorum() <= 1 {
            self.become_leader(notes);
        } else {
            self.send_request();
        }
    }

    fn send_request(&mut self) {
        let (last_index, last_term) = (self.log.last_index(), self.log.last_term());
        let m = match self.role {
            Role::PreCandidate => ConsensusMsg::PreVote {
                term: self.term.saturating_add(1),
                last_index,
                last_term,
            },
            Role::Candidate => ConsensusMsg::Vote {
                term: self.term,
                last_index,
                last_term,
            },
            _ => return,
        };
        self.send(BROADCAST, m);
    }

    fn become_leader(&mut self, notes: &mut Notes) {
        self.role = Role::Leader;
        self.leader = Some(self.id);
        let next = self.log.last_index() + 1;
        let now = self.now;
        for p in &mut self.progress {
            *p = Progress {
                next,
                matched: 0,
                heard: now,
                recent: true,
            };
        }
        self.quorum_elapsed = 0;
        self.sent_until = self.log.last_index();
        // Heartbeat at once: followers learn the new leader and get its no-op.
        self.since_send = self.p.heartbeat;
        self.probe = false;
        // Section 8 / 5.4.2: a leader commits entries of earlier terms only through an
        // entry of its own term, so it appends a no-op right away.
        self.append_own(Item::Noop, notes);
    }

    fn append_own(&mut self, item: Item, notes: &mut Notes) -> u64 {
        let e = Entry {
            term: self.term,
            item,
        };
        self.log_push(e);
        let index = self.log.last_index();
        self.progress[self.id as usize].matched = index;
        notes.push(ConsensusNote::Append {
            index,
            term: e.term,
            digest: e.digest(),
        });
        self.maybe_commit(notes);
        index
    }

    /// Section 5.3/5.4.2: commit the highest index a majority holds, if it is of this term.
    fn maybe_commit(&mut self, notes: &mut Notes) {
        let mut m: Vec<u64> = self.progress.iter().map(|p| p.matched).collect();
        m[self.id as usize] = self.log.last_index();
        m.sort_unstable_by(|a, b| b.cmp(a));
        let n = m[self.quorum() - 1];
        if n > self.commit && (self.log.term(n) == Some(self.term) || mutant!(CommitEarlierTerm)) {
            self.commit = n;
            notes.push(ConsensusNote::Commit { index: n });
        }
    }

    /// One tick of logical time.
    pub fn tick(&mut self, notes: &mut Notes) {
        self.now += 1;
        self.since_send = self.since_send.saturating_add(1);
        if self.role == Role::Leader {
            if self.p.check_quorum {
                self.quorum_elapsed += 1;
                if self.quorum_elapsed >= self.p.election_max {
                    self.quorum_elapsed = 0;
                    let me = self.id as usize;
                    let active = self
                        .progress
                        .iter()
                        .enumerate()
                        .filter(|&(i, p)| i == me || p.recent)
                        .count();
                    for p in &mut self.progress {
                        p.recent = false;
                    }
                    if active < self.quorum() {
                        // Thesis 6.2: a leader cut off from a majority steps down.
                        let term = self.term;
                        self.become_follower(term, None);
                    }
                }
            }
        } else {
            self.election_elapsed = self.election_elapsed.saturating_add(1);
            if matches!(self.role, Role::PreCandidate | Role::Candidate)
                && self.since_send >= self.p.heartbeat
            {
                self.since_send = 0;
                self.send_request();
            }
            if self.election_elapsed >= self.timeout {
                self.campaign_pre(notes);
            }
        }
        self.note_state(notes);
    }

    /// Handles one message from robot `from`. Returns false when it was left unprocessed
    /// because the notes it could cause do not fit this tick's report (as if lost).
    pub fn step(&mut self, from: u32, msg: &ConsensusMsg, notes: &mut Notes) -> bool {
        if from >= self.p.n || from == self.id {
            return true;
        }
        if matches!(
            msg,
            ConsensusMsg::QuadClaim { .. } | ConsensusMsg::QuadLeader { .. }
        ) {
            return true;
        }
        if notes.room() < self.step_bound(msg) {
            self.left_for_notes += 1;
            return false;
        }
        self.step_inner(from, msg, notes);
        self.note_state(notes);
        true
    }

    fn step_inner(&mut self, from: u32, msg: &ConsensusMsg, notes: &mut Notes) {
        let mterm = msg_term(msg);
        if mterm > self.term && self.role == Role::Leader && mutant!(NoStepDown) {
            self.term = mterm;
            self.vote = None;
        } else if mterm > self.term {
            match msg {
                ConsensusMsg::PreVote { .. } | ConsensusMsg::Vote { .. } if self.in_lease() => {
                    return;
                }
                // Never change the term for a pre-vote request (thesis 9.6); a granted
                // pre-vote answer echoes the term we would campaign in.
                ConsensusMsg::PreVote { .. } => {}
                ConsensusMsg::PreVoteResp { granted: true, .. } => {}
                ConsensusMsg::Append { .. } => self.become_follower(mterm, Some(from)),
                _ => self.become_follower(mterm, None),
            }
        } else if mterm < self.term
            && !(mutant!(AcceptStaleAppend) && matches!(msg, ConsensusMsg::Append { .. }))
        {
            // Stale sender: tell it our term so it steps down (section 5.1).
            let t = self.term;
            match msg {
                ConsensusMsg::Append { .. } => {
                    let index = self.log.last_index();
                    self.send(
                        from,
                        ConsensusMsg::AppendResp {
                            term: t,
                            success: false,
                            index,
                        },
                    );
                }
                ConsensusMsg::PreVote { .. } => self.send(
                    from,
                    ConsensusMsg::PreVoteResp {
                        term: t,
                        granted: false,
                    },
                ),
                ConsensusMsg::Vote { .. } => self.send(
                    from,
                    ConsensusMsg::VoteResp {
                        term: t,
                        granted: false,
                    },
                ),
                _ => {}
            }
            return;
        }
        match msg {
            &ConsensusMsg::PreVote {
                term,
                last_index,
                last_term,
            } => {
                let grant = term > self.term && self.up_to_date(last_index, last_term);
                let t = if grant { term } else { self.term };
                self.send(
                    from,
                    ConsensusMsg::PreVoteResp {
                        term: t,
                        granted: grant,
                    },
                );
            }
            &ConsensusMsg::Vote {
                last_index,
                last_term,
                ..
            } => {
                let can_vote = self.vote == Some(from)
                    || (self.vote.is_none() && self.leader.is_none())
                    || mutant!(VoteForAnyone);
                let grant = can_vote && self.up_to_date(last_index, last_term);
                if grant {
                    self.vote = Some(from);
                    self.election_elapsed = 0;
                }
                let t = self.term;
                self.send(
                    from,
                    ConsensusMsg::VoteResp {
                        term: t,
                        granted: grant,
                    },
                );
            }
            &ConsensusMsg::PreVoteResp { term, granted } => {
                if self.role == Role::PreCandidate {
                    if granted && term == self.term.saturating_add(1) {
                        self.votes[from as usize] = Some(true);
                    } else if !granted {
                        self.votes[from as usize] = Some(false);
                    }
                    match self.tally() {
                        Some(true) => self.campaign(notes),
                        Some(false) => {
                            let t = self.term;
                            self.become_follower(t, None);
                        }
                        None => {}
                    }
                }
            }
            &ConsensusMsg::VoteResp { granted, .. } => {
                if self.role == Role::Candidate {
                    self.votes[from as usize] = Some(granted);
                    match self.tally() {
                        Some(true) => self.become_leader(notes),
                        Some(false) => {
                            let t = self.term;
                            self.become_follower(t, None);
                        }
                        None => {}
                    }
                }
            }
            ConsensusMsg::Append {
                prev_index,
                prev_term,
                commit,
                entries,
                ..
            } => {
                if self.role == Role::Leader {
                    // Two leaders in one term cannot happen (section 5.2); ignore rather
                    // than follow. The checker reports it from the notes if it ever does.
                    return;
                }
                if self.role != Role::Follower || self.leader != Some(from) {
                    let t = self.term;
                    self.become_follower(t, Some(from));
                } else {
                    self.election_elapsed = 0;
                }
                self.handle_append(from, *prev_index, *prev_term, *commit, entries, notes);
            }
            &ConsensusMsg::AppendResp { success, index, .. } => {
                if self.role != Role::Leader {
                    return;
                }
                let last = self.log.last_index();
                let now = self.now;
                let pr = &mut self.progress[from as usize];
                pr.heard = now;
                pr.recent = true;
                if success {
                    pr.matched = pr.matched.max(index.min(last));
                    pr.next = pr.next.max(pr.matched + 1);
                    self.maybe_commit(notes);
                } else {
                    pr.next = pr.next.min(index.saturating_add(1)).max(pr.matched + 1);
                    self.probe = true;
                }
            }
            ConsensusMsg::QuadClaim { .. } | ConsensusMsg::QuadLeader { .. } => {}
        }
    }

    /// `Some(true)` once a majority granted, `Some(false)` once a majority refused.
    fn tally(&self) -> Option<bool> {
        let yes = self.votes.iter().filter(|v| **v == Some(true)).count();
        let no = self.votes.iter().filter(|v| **v == Some(false)).count();
        if yes >= self.quorum() {
            Some(true)
        } else if no >= self.quorum() {
            Some(false)
        } else {
            None
        }
    }

    /// AppendEntries receiver implementation (Figure 2, steps 2-5).
    fn handle_append(
        &mut self,
        from: u32,
        prev_index: u64,
        prev_term: u64,
        commit: u64,
        entries: &[Entry],
        notes: &mut Notes,
    ) {
        let term = self.term;
        let last = self.log.last_index();
        if prev_index > last {
            self.send(
                from,
                ConsensusMsg::AppendResp {
                    term,
                    success: false,
                    index: last,
                },
            );
            return;
        }
        if self.log.term(prev_index) != Some(prev_term) {
            self.send(
                from,
                ConsensusMsg::AppendResp {
                    term,
                    success: false,
                    index: prev_index.saturating_sub(1),
                },
            );
            return;
        }
        for (k, e) in entries.iter().enumerate() {
            let index = prev_index + 1 + k as u64;
            match self.log.term(index) {
                Some(t) if t == e.term => continue,
                Some(_) if mutant!(KeepConflictingEntries) => continue,
                Some(_) => {
                    // Step 3: a conflicting entry and all that follow it go.
                    self.log_truncate(index);
                    notes.push(ConsensusNote::Truncate { index });
                }
                None => {}
            }
            self.log_push(*e);
            notes.push(ConsensusNote::Append {
                index,
                term: e.term,
                digest: e.digest(),
            });
        }
        // Step 5: only the prefix this message vouched for may be committed.
        let matched = prev_index + entries.len() as u64;
        let c = commit.min(matched);
        if c > self.commit {
            self.commit = c;
            notes.push(ConsensusNote::Commit { index: c });
        }
        self.send(
            from,
            ConsensusMsg::AppendResp {
                term,
                success: true,
                index: matched,
            },
        );
    }

    /// As leader, appends scheduled decision `id` unless it is in the log already (a
    /// decision with id [`UNSCHEDULED`] is always appended: its proposer keeps track).
    pub fn propose(&mut self, id: u16, decision: Decision, notes: &mut Notes) -> Proposed {
        if self.role != Role::Leader {
            return Proposed::NotLeader;
        }
        if id != UNSCHEDULED && self.log.has_decision(id) {
            return Proposed::AlreadyInLog;
        }
        let index = self.log.last_index() + 1;
        let cost = Notes::cost(&ConsensusNote::Propose {
            index,
            term: self.term,
            id,
            decision,
        }) + Notes::cost(&ConsensusNote::Append {
            index,
            term: self.term,
            digest: u32::MAX,
        }) + Notes::cost(&ConsensusNote::Commit { index });
        if notes.room() < cost {
            return Proposed::NoRoom;
        }
        notes.push(ConsensusNote::Propose {
            index,
            term: self.term,
            id,
            decision,
        });
        self.append_own(Item::Decision { id, decision }, notes);
        Proposed::Appended
    }

    /// The next committed entry to act on, if any and if its note fits.
    pub fn next_apply(&mut self, notes: &mut Notes) -> Option<Entry> {
        let upto = if mutant!(ApplyBeforeCommit) {
            self.log.last_index()
        } else {
            self.commit
        };
        if self.applied >= upto {
            return None;
        }
        let index = self.applied + 1;
        let e = *self.log.get(index)?;
        let note = ConsensusNote::Apply {
            index,
            term: e.term,
            digest: e.digest(),
        };
        if notes.room() < Notes::cost(&note) {
            return None;
        }
        notes.push(note);
        self.applied = index;
        Some(e)
    }

    /// The messages to send this tick, at most `budget` frames: answers first, then the
    /// leader's AppendEntries broadcasts. What does not fit is dropped (as a lost frame).
    pub fn ready(&mut self, budget: usize) -> Vec<(u32, ConsensusMsg)> {
        let mut out = coalesce(std::mem::take(&mut self.msgs));
        if out.len() > budget {
            self.unsent += (out.len() - budget) as u64;
            out.truncate(budget);
        }
        if self.role != Role::Leader || out.len() >= budget || self.p.n <= 1 {
            return out;
        }
        let last = self.log.last_index();
        let start = if self.since_send >= self.p.heartbeat || self.probe {
            self.lowest_next()
        } else if last > self.sent_until {
            self.sent_until + 1
        } else {
            return out;
        };
        let mut prev = start.clamp(1, last + 1) - 1;
        loop {
            let entries = self.frame_entries(prev);
            let n = entries.len() as u64;
            out.push((
                BROADCAST,
                ConsensusMsg::Append {
                    term: self.term,
                    prev_index: prev,
                    prev_term: self.log.term(prev).unwrap_or(0),
                    commit: self.commit,
                    entries,
                },
            ));
            prev += n;
            if n == 0 || prev >= last || out.len() >= budget {
                break;
            }
        }
        self.sent_until = self.sent_until.max(prev);
        self.since_send = 0;
        self.probe = false;
        out
    }

    /// Lowest `next` among followers heard within two election timeouts (a dead robot must
    /// not pin every broadcast to its old position), else just past the log.
    fn lowest_next(&self) -> u64 {
        let horizon = 2 * self.p.election_max as u64;
        let me = self.id as usize;
        self.progress
            .iter()
            .enumerate()
            .filter(|&(i, p)| i != me && self.now.saturating_sub(p.heard) <= horizon)
            .map(|(_, p)| p.next)
            .min()
            .unwrap_or(self.log.last_index() + 1)
    }

    /// As many entries after `prev` as fit one frame with the AppendEntries header.
    fn frame_entries(&self, prev: u64) -> Vec<Entry> {
        let mut entries: Vec<Entry> = Vec::new();
        for e in self.log.from(prev + 1).iter().take(16) {
            entries.push(*e);
            let m = ConsensusMsg::Append {
                term: self.term,
                prev_index: prev,
                prev_term: self.log.term(prev).unwrap_or(0),
                commit: self.commit,
                entries: entries.clone(),
            };
            if !fits_frame(&m) {
                entries.pop();
                break;
            }
        }
        entries
    }
}

/// Drops superseded campaign requests, and merges the answers to several AppendEntries of one
/// leader and term within a tick into one:
/// the highest success index (each success vouches for a prefix of the same leader's log, and
/// a leader never contradicts its own entries within its term), or, without a success, the
/// refusal with the lowest hint. Frames are scarce; one answer says all the others would.
///
/// Lowest, not last: a broadcast from a follower's `next_index` spans several frames, and a
/// follower whose log conflicts refuses the first with `prev_index - 1` but every later one,
/// which starts past its log, with its last index. Keeping the last refusal told the leader
/// "retry past my log" every tick, so its `next_index` for that follower never came down to
/// the conflict and the follower never caught up (fuzz seeds 778, 786, 10212, ... with the
/// burst shape; `harness/tests/raft.rs`,
/// `a_follower_with_a_long_conflicting_log_catches_up`). A lower hint only costs resending.
fn coalesce(msgs: Vec<(u32, ConsensusMsg)>) -> Vec<(u32, ConsensusMsg)> {
    let mut out: Vec<(u32, ConsensusMsg)> = Vec::with_capacity(msgs.len());
    for (to, m) in msgs {
        if let ConsensusMsg::AppendResp {
            term,
            success,
            index,
        } = m
        {
            let earlier = out.iter_mut().find(|(t, o)| {
                *t == to && matches!(o, ConsensusMsg::AppendResp { term: ot, .. } if *ot == term)
            });
            if let Some((
                _,
                ConsensusMsg::AppendResp {
                    success: s0,
                    index: i0,
                    ..
                },
            )) = earlier
            {
                match (*s0, success) {
                    (true, true) => *i0 = (*i0).max(index),
                    (true, false) => {}
                    (false, true) => (*s0, *i0) = (true, index),
                    (false, false) => *i0 = (*i0).min(index),
                }
                continue;
            }
        }
        if matches!(m, ConsensusMsg::PreVote { .. } | ConsensusMsg::Vote { .. }) {
            // Only the latest campaign request matters (a repeat and a new campaign can
            // fall in the same tick).
            out.retain(|(_, o)| {
                !matches!(o, ConsensusMsg::PreVote { .. } | ConsensusMsg::Vote { .. })
            });
        }
        out.push((to, m));
    }
    out
}

/// Whether `m` fits one radio frame inside [`crate::RadioMsg::Consensus`] (whose
/// variant tag takes one byte).
pub fn fits_frame(m: &ConsensusMsg) -> bool {
    let mut buf = [0u8; MAX_PAYLOAD - 1];
    postcard::to_slice(m, &mut buf).is_ok()
}

fn msg_term(m: &ConsensusMsg) -> u64 {
    match m {
        ConsensusMsg::PreVote { term, .. }
        | ConsensusMsg::PreVoteResp { term, .. }
        | ConsensusMsg::Vote { term, .. }
        | ConsensusMsg::VoteResp { term, .. }
        | ConsensusMsg::Append { term, .. }
        | ConsensusMsg::AppendResp { term, .. } => *term,
        ConsensusMsg::QuadClaim { .. } | ConsensusMsg::QuadLeader { .. } => 0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn resp(term: u64, success: bool, index: u64) -> ConsensusMsg {
        ConsensusMsg::AppendResp {
            term,
            success,
            index,
        }
    }

    #[test]
    fn answers_to_one_leader_merge_and_stale_requests_go() {
        let req = |term| ConsensusMsg::PreVote {
            term,
            last_index: 0,
            last_term: 0,
        };
        let merged = coalesce(vec![
            (1, resp(3, true, 4)),
            (BROADCAST, req(4)),
            (1, resp(3, false, 2)),
            (1, resp(3, true, 7)),
            (2, resp(3, true, 1)),
            (1, resp(4, false, 0)),
            (BROADCAST, req(5)),
        ]);
        assert_eq!(
            merged,
            vec![
                (1, resp(3, true, 7)),
                (2, resp(3, true, 1)),
                (1, resp(4, false, 0)),
                (BROADCAST, req(5)),
            ]
        );
        // Refusals keep the lowest hint, whatever their order.
        assert_eq!(
            coalesce(vec![(1, resp(3, false, 9)), (1, resp(3, false, 10))]),
            vec![(1, resp(3, false, 9))]
        );
        assert_eq!(
            coalesce(vec![(1, resp(3, false, 10)), (1, resp(3, false, 9))]),
            vec![(1, resp(3, false, 9))]
        );
        // A refusal followed by a success becomes the success.
        assert_eq!(
            coalesce(vec![(1, resp(3, false, 2)), (1, resp(3, true, 5))]),
            vec![(1, resp(3, true, 5))]
        );
    }
}
