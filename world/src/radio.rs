//! The simulated radio medium: range, line of sight, loss, delay, jitter and capacity.
//!
//! The world calls [`RadioMedium::send`] with every robot's outbox after the robots have acted
//! at a tick, and [`RadioMedium::deliver`] before it builds the observations of a later tick.
//! With `delay_ticks = 0` and no jitter, a frame sent at tick `t` is in the inbox built by
//! `deliver(t + 1)`.
//!
//! # Accounting
//!
//! Every copy is accounted for: `sent == delivered + dropped + in_flight`, and `dropped` is the
//! sum of the `dropped_*` counters ([`RadioStats`]).
//!
//! - Robots with `can_talk == false` (down or dead) neither send nor receive: their outbox is
//!   ignored entirely and counts nowhere.
//! - Each frame a talking robot offers counts once in `frames`.
//! - Frames beyond `capacity` in one robot's outbox in one tick count `sent += 1` and
//!   `dropped_capacity += 1` each; they are not fanned out.
//! - A broadcast frame within capacity fans out to one copy per *other* talking robot whose
//!   Euclidean distance from the sender at send time is `<= range`; each copy counts `sent += 1`.
//!   Robots out of range are not addressees and count nowhere, so a broadcast nobody hears
//!   counts only in `frames`.
//! - A unicast frame within capacity is one copy (`sent += 1`). If `dst` is not talking it is
//!   `dropped_receiver_down`; else if `dst` is the sender itself, an unknown id or out of range
//!   it is `dropped_out_of_range`.
//! - Each remaining copy then goes, in this order, through line of sight (when enabled and the
//!   `blocked` callback says so: `dropped_line_of_sight`), the loss draw (`dropped_loss`) and the
//!   jitter draw, and goes in flight with `deliver_tick = tick + 1 + delay_ticks + jitter`. The
//!   world overwrites `src` with the sender id and `sent_tick` with `tick`; `dst` is kept (so a
//!   receiver can tell a broadcast from a unicast).
//! - At `deliver(tick)` every copy with `deliver_tick <= tick` leaves flight, per receiver in
//!   order of (`deliver_tick`, routing sequence): to a receiver that is not talking it is
//!   `dropped_receiver_down`; the first [`MAX_INBOX`] go into the inbox (`delivered`); the rest
//!   are `dropped_inbox_full` (never kept for a later tick).
//!
//! # Determinism
//!
//! The same config, seed and inputs give bit-identical inboxes and counters. Copies are routed
//! in a fixed order: senders by ascending id, frames in outbox order, broadcast receivers by
//! ascending id. All randomness comes from the single stream `rng::stream(seed, "radio", 0)`,
//! drawn per copy in routing order, and only by copies that reach the loss step (copies dropped
//! for capacity, range, receiver down or line of sight draw nothing):
//!
//! 1. loss: Bernoulli draws one `f64` `u` in `[0, 1)` and loses the copy iff `u < loss`.
//!    Gilbert-Elliott draws one `f64` for the state transition of the directed link
//!    (`src`, `dst`) (Good -> Bad iff `u < ge_p`, Bad -> Good iff `u < ge_r`; links start Good),
//!    then one `f64` `v` and loses the copy iff `v < ge_loss_good` / `ge_loss_bad` for the new
//!    state. This is netem's `loss gemodel p r 1-h 1-k`.
//! 2. jitter: a surviving copy draws one integer uniform in `0..=jitter_ticks`, only when
//!    `jitter_ticks > 0`.
//!
//! With Bernoulli `loss = 0` and no jitter the stream has no reader, so no draw is made.
//!
//! No hash map is used, and the link states are only looked up, never iterated.
//!
//! # Performance
//!
//! Broadcast receivers are found with the world's spatial grid ([`Grid`]) over the talking
//! robots, with cells of side `range`, rebuilt in place at each [`RadioMedium::send`] that has
//! a broadcast to route (receivers sorted by id afterwards), so a send costs about
//! O(N + copies · log) rather than O(N²). In-flight copies wait in one queue per receiver: a
//! FIFO without jitter (arrival order is then due order), a min-heap with it; copies that can
//! only find a full inbox wait as a count. Inboxes hold slots of one frame store, so every
//! copy of a broadcast is the same 152 bytes in memory once.
//!
//! # Recording
//!
//! With [`RadioMedium::set_recording`] on, every copy whose fate is decided also leaves a
//! [`RadioRow`] (the `radio.csv` line), in the order the medium decides them, for the shell to
//! take with [`RadioMedium::take_log`]. Copies then never wait as a count (each needs its own
//! sender and length at delivery); they meet the same fate in the same order, so counters,
//! inboxes and draws are those of a run without recording. Off (the default), the only cost is
//! one branch per decided copy.

use std::cmp::Ordering;
use std::collections::{BTreeSet, BinaryHeap, VecDeque};

use rand::Rng as _;
use swarmrt_protocol::records::{RadioOutcome, RadioRow};
use swarmrt_protocol::{BROADCAST, Frame, MAX_INBOX};
use swarmrt_scenario::{LossModel, RadioConfig};

use crate::grid::Grid;
use crate::rng::{self, Rng};

/// Counters of the medium. Invariant: `sent == delivered + dropped + in_flight`, and `dropped`
/// is the sum of the `dropped_*` fields.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct RadioStats {
    /// Frames offered by talking robots (outbox entries), before fan-out.
    pub frames: u64,
    /// Copies: one per addressee, plus one per frame refused for capacity.
    pub sent: u64,
    /// Copies put into an inbox.
    pub delivered: u64,
    /// Copies dropped for any reason (the sum of the `dropped_*` fields).
    pub dropped: u64,
    /// Copies lost by the loss model.
    pub dropped_loss: u64,
    /// Unicast copies whose receiver was out of range, unknown or the sender itself.
    pub dropped_out_of_range: u64,
    /// Frames beyond the per-robot, per-tick capacity.
    pub dropped_capacity: u64,
    /// Copies blocked by an obstacle between sender and receiver.
    pub dropped_line_of_sight: u64,
    /// Copies whose receiver was down or dead at send or delivery time.
    pub dropped_receiver_down: u64,
    /// Copies due when the receiver's inbox already held `MAX_INBOX` frames.
    pub dropped_inbox_full: u64,
    /// Copies between robots a scheduled partition or blackout kept apart.
    pub dropped_partition: u64,
    /// Copies routed but not yet due.
    pub in_flight: u64,
}

/// Why a copy was dropped; selects the counter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Reason {
    Loss,
    OutOfRange,
    Capacity,
    LineOfSight,
    ReceiverDown,
    InboxFull,
    Partition,
}

impl Reason {
    fn outcome(self) -> RadioOutcome {
        match self {
            Reason::Loss => RadioOutcome::Loss,
            Reason::OutOfRange => RadioOutcome::OutOfRange,
            Reason::Capacity => RadioOutcome::Capacity,
            Reason::LineOfSight => RadioOutcome::LineOfSight,
            Reason::ReceiverDown => RadioOutcome::ReceiverDown,
            Reason::InboxFull => RadioOutcome::InboxFull,
            Reason::Partition => RadioOutcome::Partition,
        }
    }
}

/// The row of one copy of `frame` (its `src` and `sent_tick` already the world's).
fn row(tick: u64, frame: &Frame, to: Option<u32>, outcome: RadioOutcome) -> RadioRow {
    RadioRow {
        tick,
        sent_tick: frame.sent_tick,
        from: frame.src,
        to,
        bytes: frame.len,
        outcome,
    }
}

/// Appends the row of one copy of `frame` to `log` when recording.
#[inline]
fn note(
    log: &mut Option<Vec<RadioRow>>,
    tick: u64,
    frame: &Frame,
    to: Option<u32>,
    outcome: RadioOutcome,
) {
    if let Some(log) = log {
        log.push(row(tick, frame, to, outcome));
    }
}

impl RadioStats {
    fn count_drop(&mut self, why: Reason) {
        self.count_drops(why, 1);
    }

    fn count_drops(&mut self, why: Reason, k: u64) {
        self.dropped += k;
        match why {
            Reason::Loss => self.dropped_loss += k,
            Reason::OutOfRange => self.dropped_out_of_range += k,
            Reason::Capacity => self.dropped_capacity += k,
            Reason::LineOfSight => self.dropped_line_of_sight += k,
            Reason::ReceiverDown => self.dropped_receiver_down += k,
            Reason::InboxFull => self.dropped_inbox_full += k,
            Reason::Partition => self.dropped_partition += k,
        }
    }
}

/// A copy in flight, ordered so that a `BinaryHeap` pops the smallest (`due`, `seq`) first.
/// The frame itself waits in [`RadioMedium::frames`] at `slot`, once for all copies of it
/// (every copy of a broadcast is the same bytes): heap operations move 24 bytes instead of a
/// whole frame, and delivery reads a few hot frames instead of one cold copy per receiver
/// (together a third of a 1,000-robot tick before).
struct Pending {
    due: u64,
    seq: u64,
    slot: u32,
    /// Copies routed after this one with the same `due` when the receiver already had a full
    /// inbox's worth due then: they will be dropped at delivery whatever happens (as
    /// `dropped_inbox_full`, or `dropped_receiver_down` if the receiver stops talking), so
    /// they wait here as a count instead of one entry each. A robot in a dense flock hears
    /// hundreds of broadcasts a tick and keeps 32.
    surplus: u32,
}

impl PartialEq for Pending {
    fn eq(&self, other: &Self) -> bool {
        (self.due, self.seq) == (other.due, other.seq)
    }
}

impl Eq for Pending {}

impl PartialOrd for Pending {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Pending {
    fn cmp(&self, other: &Self) -> Ordering {
        // Reversed: BinaryHeap is a max-heap and we want the earliest copy on top.
        (other.due, other.seq).cmp(&(self.due, self.seq))
    }
}

/// One receiver's copies in flight, popped in (`due`, `seq`) order.
///
/// Without jitter every copy routed at tick `t` is due at `t + 1 + delay_ticks`, so `due`
/// never decreases as `seq` grows and arrival order *is* (`due`, `seq`) order: a FIFO gives the
/// same pops as the heap at O(1) instead of O(log k) (the heap was most of the radio stage at
/// 1,000 robots). With jitter the heap sorts.
enum Queue {
    Fifo(VecDeque<Pending>),
    Heap(BinaryHeap<Pending>),
}

impl Queue {
    fn new(jitter: bool) -> Queue {
        if jitter {
            Queue::Heap(BinaryHeap::new())
        } else {
            Queue::Fifo(VecDeque::new())
        }
    }

    fn push(&mut self, p: Pending) {
        match self {
            Queue::Fifo(q) => {
                debug_assert!(q.back().is_none_or(|b| (b.due, b.seq) < (p.due, p.seq)));
                q.push_back(p)
            }
            Queue::Heap(q) => q.push(p),
        }
    }

    /// Counts one more copy due at `due` on the last entry, if the FIFO already holds
    /// [`MAX_INBOX`] copies due then (so this one cannot reach the inbox). Never with the heap,
    /// whose order is not arrival order.
    fn absorb(&mut self, due: u64) -> bool {
        let Queue::Fifo(q) = self else { return false };
        if q.len() < MAX_INBOX || q[q.len() - MAX_INBOX].due != due {
            return false;
        }
        match q.back_mut() {
            Some(last) => {
                last.surplus += 1;
                true
            }
            None => false,
        }
    }

    /// The earliest copy, if it is due at `tick`.
    fn pop_due(&mut self, tick: u64) -> Option<Pending> {
        match self {
            Queue::Fifo(q) => q
                .front()
                .is_some_and(|p| p.due <= tick)
                .then(|| q.pop_front())?,
            Queue::Heap(q) => q.peek().is_some_and(|p| p.due <= tick).then(|| q.pop())?,
        }
    }
}

/// Cell side of the receivers' grid: half the range, so a query visits about 5 x 5 cells
/// (rows of cells are contiguous, so more cells cost little and keep fewer candidates
/// outside the disc). Any positive side finds the same receivers (candidates are filtered by
/// exact distance).
fn grid_cell(range: f64) -> f64 {
    if range > 0.0 && range.is_finite() {
        range / 2.0
    } else {
        1.0
    }
}

/// Talking robots other than `src` within `range` of it, ascending id, into `out`. `grid`
/// holds the talking robots with finite positions; `marks` is scratch.
fn receivers_of(
    grid: &Grid,
    src: usize,
    positions: &[(f64, f64)],
    range: f64,
    out: &mut Vec<u32>,
    marks: &mut Vec<u64>,
) {
    out.clear();
    let p = positions[src];
    if range == f64::INFINITY {
        grid.each(|id| {
            if id != src && in_range(p, positions[id], range) {
                out.push(id as u32);
            }
        });
    } else {
        // Squared distances settle all but a hair-thin ring without a square root: below
        // `inside` the root is surely within range, above `outside` surely not (a correctly
        // rounded root moves by an ulp or so; the bounds leave 1e-9 relative), and in between
        // `in_range` decides as ever.
        let sq = range * range;
        let (inside, outside) = if range >= 1e-100 && sq.is_finite() {
            (sq * (1.0 - 1e-9), sq * (1.0 + 1e-9))
        } else {
            (f64::NEG_INFINITY, f64::INFINITY)
        };
        // A hair beyond the range, so that rounding in the cell arithmetic can never leave out
        // a robot `in_range` accepts: candidates are filtered by the exact distance anyway.
        let reach = range.max(0.0) * (1.0 + 1e-12) + 1e-9;
        grid.near_points(p, reach, |id, q| {
            let (dx, dy) = (p.0 - q.0, p.1 - q.1);
            let d_sq = dx * dx + dy * dy;
            if id != src && d_sq <= outside && (d_sq <= inside || in_range(p, q, range)) {
                out.push(id as u32);
            }
        });
    }
    // The grid reports by cell; routing goes by ascending id. Many receivers among few robots
    // (a dense flock: ~480 of 1,000) are put in order faster by marking them in a bitset
    // over all ids than by sorting; ids are distinct, so both give the same list.
    let words = positions.len().div_ceil(64);
    let sort_cost = out.len() * (usize::BITS - out.len().leading_zeros()) as usize;
    if sort_cost > 4 * words {
        marks.clear();
        marks.resize(words, 0);
        for &id in out.iter() {
            marks[id as usize / 64] |= 1u64 << (id % 64);
        }
        out.clear();
        for (w, &word) in marks.iter().enumerate() {
            let mut bits = word;
            while bits != 0 {
                out.push((w * 64) as u32 + bits.trailing_zeros());
                bits &= bits - 1;
            }
        }
    } else {
        out.sort_unstable();
    }
}

/// Drops one reference to the frame at `slot`; the last frees the slot.
fn release(frames: &mut [(Frame, u32)], free: &mut Vec<u32>, slot: u32) {
    let refs = &mut frames[slot as usize].1;
    *refs -= 1;
    if *refs == 0 {
        free.push(slot);
    }
}

fn in_range(a: (f64, f64), b: (f64, f64), range: f64) -> bool {
    let (dx, dy) = (a.0 - b.0, a.1 - b.1);
    (dx * dx + dy * dy).sqrt() <= range
}

/// The world's radio: routes robots' frames to inboxes so that robots never talk directly.
pub struct RadioMedium {
    cfg: RadioConfig,
    rng: Rng,
    robot_count: usize,
    /// In-flight copies per receiver.
    queues: Vec<Queue>,
    /// Frames of the in-flight copies, indexed by [`Pending::slot`], with how many copies
    /// in flight still refer to each.
    frames: Vec<(Frame, u32)>,
    /// Free slots of `frames`.
    free: Vec<u32>,
    /// Per receiver, the slots delivered by the last [`Self::deliver_due`] (each holds a
    /// reference to its frame until the next).
    inboxes: Vec<Vec<u32>>,
    /// Routing sequence of the next copy put in flight.
    seq: u64,
    /// Directed links (src, dst) currently in the Gilbert-Elliott Bad state; absent = Good.
    bad_links: BTreeSet<(u32, u32)>,
    /// The talking robots with finite positions, rebuilt per send that has a broadcast.
    grid: Grid,
    scratch: Vec<u32>,
    /// Scratch bitset over robot ids for [`receivers_of`].
    marks: Vec<u64>,
    stats: RadioStats,
    /// Radio group per robot while a partition or blackout is on; different groups are apart.
    groups: Option<Vec<u64>>,
    /// The rows of decided copies since the last [`Self::take_log`], while recording.
    log: Option<Vec<RadioRow>>,
}

impl RadioMedium {
    /// A medium for `robot_count` robots whose every random draw derives from `seed`.
    pub fn new(cfg: RadioConfig, seed: u64, robot_count: usize) -> Self {
        RadioMedium {
            cfg,
            rng: rng::stream(seed, "radio", 0),
            robot_count,
            queues: (0..robot_count)
                .map(|_| Queue::new(cfg.jitter_ticks > 0))
                .collect(),
            frames: Vec::new(),
            free: Vec::new(),
            inboxes: vec![Vec::new(); robot_count],
            seq: 0,
            bad_links: BTreeSet::new(),
            grid: Grid::default(),
            groups: None,
            scratch: Vec::new(),
            marks: Vec::new(),
            stats: RadioStats::default(),
            log: None,
        }
    }

    /// Switches recording on or off (off when built): while on, every decided copy leaves a
    /// [`RadioRow`] for [`Self::take_log`]. Switch it on before the first send for a row per
    /// copy (copies already waiting as a count get none). Switching off discards rows not yet
    /// taken.
    pub fn set_recording(&mut self, on: bool) {
        match (on, self.log.is_some()) {
            (true, false) => self.log = Some(Vec::new()),
            (false, true) => self.log = None,
            _ => {}
        }
    }

    /// The rows of the copies decided since the last call, in the order they were decided
    /// (empty when not recording).
    pub fn take_log(&mut self) -> Vec<RadioRow> {
        self.log.as_mut().map(std::mem::take).unwrap_or_default()
    }

    /// Routes the frames robots sent at `tick`, so that they arrive at a later [`Self::deliver`].
    ///
    /// `outboxes[i]`, `positions[i]` (true position at send time) and `can_talk[i]` describe
    /// robot `i`; `blocked(a, b)` is asked only when line of sight is enabled, and only for
    /// pairs within range whose receiver is talking.
    ///
    /// # Panics
    /// When a slice's length differs from the robot count given to [`Self::new`].
    pub fn send(
        &mut self,
        tick: u64,
        outboxes: &[&[Frame]],
        positions: &[(f64, f64)],
        can_talk: &[bool],
        blocked: &mut dyn FnMut(usize, usize) -> bool,
    ) {
        let n = self.robot_count;
        assert_eq!(outboxes.len(), n, "radio: one outbox per robot");
        assert_eq!(positions.len(), n, "radio: one position per robot");
        assert_eq!(can_talk.len(), n, "radio: one can_talk per robot");
        let capacity = self.cfg.capacity as usize;
        let range = self.cfg.range;

        let any_broadcast = (0..n).any(|i| {
            can_talk[i]
                && outboxes[i]
                    .iter()
                    .take(capacity)
                    .any(|f| f.dst == BROADCAST)
        });
        if any_broadcast {
            self.grid.rebuild(positions, grid_cell(range), |i| {
                can_talk[i] && positions[i].0.is_finite() && positions[i].1.is_finite()
            });
        }

        if let Some(threads) = self.send_threads() {
            self.send_parallel(tick, outboxes, positions, can_talk, threads);
            return;
        }

        let mut receivers = std::mem::take(&mut self.scratch);
        for src in 0..n {
            if !can_talk[src] {
                continue;
            }
            let mut receivers_known = false;
            for (k, frame) in outboxes[src].iter().enumerate() {
                self.stats.frames += 1;
                if k >= capacity {
                    self.stats.sent += 1;
                    self.stats.count_drop(Reason::Capacity);
                    if self.log.is_some() {
                        let copy = Frame {
                            src: src as u32,
                            sent_tick: tick,
                            ..*frame
                        };
                        let to = (frame.dst != BROADCAST).then_some(frame.dst);
                        note(&mut self.log, tick, &copy, to, RadioOutcome::Capacity);
                    }
                    continue;
                }
                let mut copy = *frame;
                copy.src = src as u32;
                copy.sent_tick = tick;
                // Stored on the first copy that goes in flight.
                let mut slot = None;
                if copy.dst == BROADCAST {
                    if !receivers_known {
                        receivers_of(
                            &self.grid,
                            src,
                            positions,
                            range,
                            &mut receivers,
                            &mut self.marks,
                        );
                        receivers_known = true;
                    }
                    for &dst in &receivers {
                        self.stats.sent += 1;
                        self.route(tick, src, dst as usize, &copy, &mut slot, blocked);
                    }
                } else {
                    self.stats.sent += 1;
                    let dst = copy.dst as usize;
                    if dst < n && !can_talk[dst] {
                        self.stats.count_drop(Reason::ReceiverDown);
                        let why = RadioOutcome::ReceiverDown;
                        note(&mut self.log, tick, &copy, Some(copy.dst), why);
                    } else if dst >= n
                        || dst == src
                        || !in_range(positions[src], positions[dst], range)
                    {
                        self.stats.count_drop(Reason::OutOfRange);
                        let why = RadioOutcome::OutOfRange;
                        note(&mut self.log, tick, &copy, Some(copy.dst), why);
                    } else {
                        self.route(tick, src, dst, &copy, &mut slot, blocked);
                    }
                }
            }
        }
        self.scratch = receivers;
    }

    /// Line of sight, loss and jitter for one copy already counted in `sent`.
    fn route(
        &mut self,
        tick: u64,
        src: usize,
        dst: usize,
        copy: &Frame,
        slot: &mut Option<u32>,
        blocked: &mut dyn FnMut(usize, usize) -> bool,
    ) {
        let dropped = if self
            .groups
            .as_ref()
            .is_some_and(|g| g.get(src) != g.get(dst))
        {
            Some(Reason::Partition)
        } else if self.cfg.line_of_sight && blocked(src, dst) {
            Some(Reason::LineOfSight)
        } else if self.lose(src as u32, dst as u32) {
            Some(Reason::Loss)
        } else {
            None
        };
        if let Some(why) = dropped {
            self.stats.count_drop(why);
            note(&mut self.log, tick, copy, Some(dst as u32), why.outcome());
            return;
        }
        let jitter = if self.cfg.jitter_ticks > 0 {
            self.rng.random_range(0..=self.cfg.jitter_ticks) as u64
        } else {
            0
        };
        let due = tick
            .saturating_add(1)
            .saturating_add(self.cfg.delay_ticks as u64)
            .saturating_add(jitter);
        self.stats.in_flight += 1;
        // While recording, each copy keeps its own entry: its row needs its sender and length.
        if self.log.is_none() && self.queues[dst].absorb(due) {
            return;
        }
        let slot = *slot.get_or_insert_with(|| match self.free.pop() {
            Some(free) => {
                self.frames[free as usize] = (*copy, 0);
                free
            }
            None => {
                self.frames.push((*copy, 0));
                (self.frames.len() - 1) as u32
            }
        });
        self.frames[slot as usize].1 += 1;
        self.queues[dst].push(Pending {
            due,
            seq: self.seq,
            slot,
            surplus: 0,
        });
        self.seq += 1;
    }

    /// Sets the radio groups for the following sends (`None`: everyone may hear everyone).
    pub fn set_groups(&mut self, groups: Option<Vec<u64>>) {
        self.groups = groups;
    }

    /// True while a scheduled partition or blackout keeps robots `a` and `b` apart.
    pub fn apart(&self, a: usize, b: usize) -> bool {
        self.groups.as_ref().is_some_and(|g| g.get(a) != g.get(b))
    }

    /// Draws the loss of one copy on the directed link `src -> dst`.
    fn lose(&mut self, src: u32, dst: u32) -> bool {
        match self.cfg.loss_model {
            // With no loss and no jitter nothing else reads the stream, so skipping the draw
            // (a ChaCha block every 8 copies) changes no outcome.
            LossModel::Bernoulli if self.cfg.loss <= 0.0 && self.cfg.jitter_ticks == 0 => false,
            LossModel::Bernoulli => self.rng.random::<f64>() < self.cfg.loss,
            LossModel::GilbertElliott => {
                let link = (src, dst);
                let was_bad = self.bad_links.contains(&link);
                let u: f64 = self.rng.random();
                let bad = if was_bad {
                    u >= self.cfg.ge_r
                } else {
                    u < self.cfg.ge_p
                };
                if bad != was_bad {
                    if bad {
                        self.bad_links.insert(link);
                    } else {
                        self.bad_links.remove(&link);
                    }
                }
                let p = if bad {
                    self.cfg.ge_loss_bad
                } else {
                    self.cfg.ge_loss_good
                };
                self.rng.random::<f64>() < p
            }
        }
    }

    /// Fills each robot's inbox with the copies due at `tick` (cleared first), so that the
    /// observations of `tick` carry them; read them with [`Self::inbox`].
    ///
    /// An inbox holds slots of the shared frame store, not copies: the ~200 distinct frames of
    /// a 1,000-robot tick stay hot in cache while the observations copy them out, instead of
    /// 32,000 cold 152-byte copies made here and copied again there. The frames stay until the
    /// next call.
    ///
    /// # Panics
    /// When `can_talk`'s length differs from the robot count given to [`Self::new`].
    pub fn deliver_due(&mut self, tick: u64, can_talk: &[bool]) {
        let n = self.robot_count;
        assert_eq!(can_talk.len(), n, "radio: one can_talk per robot");
        let (frames, free, stats, log) = (
            &mut self.frames,
            &mut self.free,
            &mut self.stats,
            &mut self.log,
        );
        for (r, (inbox, queue)) in self.inboxes.iter_mut().zip(&mut self.queues).enumerate() {
            for slot in inbox.drain(..) {
                release(frames, free, slot);
            }
            while let Some(p) = queue.pop_due(tick) {
                stats.in_flight -= 1;
                if let Some(log) = log.as_mut() {
                    let outcome = if !can_talk[r] {
                        RadioOutcome::ReceiverDown
                    } else if inbox.len() < MAX_INBOX {
                        RadioOutcome::Delivered
                    } else {
                        RadioOutcome::InboxFull
                    };
                    let frame = &frames[p.slot as usize].0;
                    log.push(row(tick, frame, Some(r as u32), outcome));
                }
                if !can_talk[r] {
                    release(frames, free, p.slot);
                    stats.count_drop(Reason::ReceiverDown);
                } else if inbox.len() < MAX_INBOX {
                    inbox.push(p.slot);
                    stats.delivered += 1;
                } else {
                    release(frames, free, p.slot);
                    stats.count_drop(Reason::InboxFull);
                }
                if p.surplus > 0 {
                    // Absorbed before recording was switched on (if ever): such copies have
                    // no rows; every copy routed while recording has its own entry.
                    stats.in_flight -= p.surplus as u64;
                    let why = if can_talk[r] {
                        debug_assert_eq!(inbox.len(), MAX_INBOX);
                        Reason::InboxFull
                    } else {
                        Reason::ReceiverDown
                    };
                    stats.count_drops(why, p.surplus as u64);
                }
            }
        }
    }

    /// Robot `r`'s inbox as filled by the last [`Self::deliver_due`], in delivery order.
    pub fn inbox(&self, r: usize) -> impl ExactSizeIterator<Item = &Frame> + '_ {
        self.inboxes[r]
            .iter()
            .map(|&slot| &self.frames[slot as usize].0)
    }

    /// [`Self::deliver_due`], then copies each robot's inbox into `inboxes[r]`.
    ///
    /// # Panics
    /// When a slice's length differs from the robot count given to [`Self::new`].
    pub fn deliver(&mut self, tick: u64, can_talk: &[bool], inboxes: &mut [Vec<Frame>]) {
        assert_eq!(
            inboxes.len(),
            self.robot_count,
            "radio: one inbox per robot"
        );
        self.deliver_due(tick, can_talk);
        for (r, inbox) in inboxes.iter_mut().enumerate() {
            inbox.clear();
            inbox.extend(self.inbox(r).copied());
        }
    }

    /// The counters so far, for the run summary and the accounting checks.
    pub fn stats(&self) -> RadioStats {
        self.stats
    }
}

mod parallel;
pub use parallel::PARALLEL_SEND_MIN;

#[cfg(test)]
mod tests;
