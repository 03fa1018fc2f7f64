//! Propagation rounds inside one tick (`radio.rounds`): seed 003's Appendix A passes a
//! master's motion along the whole chain in one step by recursion; here the recursion runs
//! over the real radio, as rounds between the robots' answers and the world's step.
//!
//! After every robot answered the tick's observation, the first `in_tick` frames of each
//! accepted answer go out at once ([`World::start_rounds`]). Each [`World::next_round`]
//! routes the frames in flight to their receivers and names the robots woken with them; each
//! woken robot answers with a React command ([`World::react`]) whose motion replaces its
//! decision for the tick and whose frames travel in the next round. The tick ends when a
//! round delivers nothing, or when `radio.rounds` rounds were run (what is still in flight
//! is then dropped and counted as `capped`).
//!
//! A round frame meets the medium of the tick: range, line of sight and the partitions of
//! the tick, each robot's `capacity` per round, [`MAX_INBOX`] per receiver and round; no
//! delay (rounds need `delay_ticks = jitter_ticks = 0`). Its loss draws come from their own
//! stream (`"radio-rounds"`), so a config without rounds draws nothing new. Round frames
//! are counted in [`RoundStats`], apart from the tick's radio counters, and are not written
//! to `radio.csv`.

use rand::Rng as _;
use serde::{Deserialize, Serialize};
use swarmrt_protocol::{BROADCAST, Command, CommandKind, Frame, MAX_INBOX, RobotState, RoundInbox};

use super::{Event, World};
use crate::rng::{self, Rng};

/// What the propagation rounds did over the run (`metrics.json` `rounds`, present only with
/// `radio.rounds` > 0). Every round copy is accounted for: `sent == delivered + dropped +
/// capped`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct RoundStats {
    /// `radio.rounds`: the most rounds one tick may run.
    pub cap: u32,
    /// Rounds run over the run (each woke at least one robot).
    pub rounds: u64,
    /// Ticks that ran at least one round.
    pub ticks_with_rounds: u64,
    /// The most rounds one tick ran.
    pub max_in_a_tick: u32,
    /// Ticks whose rounds stopped at the cap with frames still in flight.
    pub capped_ticks: u64,
    /// Robot wake-ups: one per woken robot per round.
    pub wakeups: u64,
    /// Round frames offered by talking robots, before fan-out.
    pub frames: u64,
    /// Copies: one per addressee.
    pub sent: u64,
    /// Copies put into a round inbox.
    pub delivered: u64,
    /// Copies dropped by range, line of sight, partition, loss, capacity, a receiver that
    /// is not active, or a full round inbox.
    pub dropped: u64,
    /// Copies still in flight when the cap ended the tick's rounds.
    pub capped: u64,
    /// Reactions refused at the world boundary (also counted in `rejected`).
    pub rejected: u64,
}

/// The rounds' state inside the world.
pub(super) struct Rounds {
    cap: u32,
    rng: Rng,
    /// The round the tick is in: 0 until the first [`World::next_round`].
    round: u32,
    /// Frames sent and not yet routed, by sender (ascending, as routed).
    outgoing: Vec<(u32, Vec<Frame>)>,
    /// The robots woken in the current round, ascending.
    woken: Vec<u32>,
    stats: RoundStats,
}

impl Rounds {
    pub(super) fn new(cap: u32, seed: u64) -> Rounds {
        Rounds {
            cap,
            rng: rng::stream(seed, "radio-rounds", 0),
            round: 0,
            outgoing: Vec::new(),
            woken: Vec::new(),
            stats: RoundStats {
                cap,
                ..RoundStats::default()
            },
        }
    }

    pub(super) fn stats(&self) -> RoundStats {
        self.stats
    }
}

impl World {
    /// True when `radio.rounds` > 0: the shells run rounds between collecting a tick's
    /// answers and stepping.
    pub fn has_rounds(&self) -> bool {
        self.rounds.is_some()
    }

    /// How many frames of `cmd`'s outbox travel within the tick: `in_tick` of an Act (none
    /// without rounds), every frame of a React.
    pub(super) fn in_tick_frames(&self, cmd: &Command) -> usize {
        if self.rounds.is_none() {
            return 0;
        }
        let n = cmd.outbox().len();
        match CommandKind::from_u32(cmd.kind) {
            Some(CommandKind::React) => n,
            _ => (cmd.in_tick as usize).min(n),
        }
    }

    /// Starts the tick's rounds from its answers: the first `in_tick` frames of every active
    /// robot's valid Act go out (an invalid Act sends nothing; the step refuses it). A no-op
    /// without rounds.
    pub fn start_rounds(&mut self, commands: &[Option<Command>]) {
        let Some(rounds) = self.rounds.as_ref() else {
            return;
        };
        debug_assert_eq!(rounds.round, 0, "start_rounds once per tick");
        let mut outgoing = Vec::new();
        for (i, cmd) in commands.iter().enumerate() {
            let Some(cmd) = cmd else { continue };
            if self.robots[i].state != RobotState::Active || self.validate(i, cmd).is_err() {
                continue;
            }
            let k = self.in_tick_frames(cmd);
            if k > 0 {
                outgoing.push((i as u32, cmd.outbox()[..k].to_vec()));
            }
        }
        if let Some(r) = self.rounds.as_mut() {
            r.outgoing = outgoing;
        }
    }

    /// Routes the frames in flight and opens the next round: the inboxes of the robots woken
    /// in it, ascending by robot. Empty when nothing was delivered or the cap is reached: the
    /// tick's rounds are over (the world steps next, and the next tick starts at round 0).
    pub fn next_round(&mut self) -> Vec<RoundInbox> {
        let Some(mut rounds) = self.rounds.take() else {
            return Vec::new();
        };
        let outgoing = std::mem::take(&mut rounds.outgoing);
        let mut inboxes = Vec::new();
        if rounds.round >= rounds.cap {
            let copies: u64 = outgoing.iter().map(|(_, f)| f.len() as u64).sum();
            if copies > 0 {
                rounds.stats.capped_ticks += 1;
                rounds.stats.frames += copies;
                rounds.stats.sent += copies;
                rounds.stats.capped += copies;
            }
        } else if !outgoing.is_empty() {
            inboxes = self.route_round(&mut rounds, &outgoing);
        }
        if inboxes.is_empty() {
            rounds.round = 0;
            rounds.woken.clear();
        } else {
            rounds.round += 1;
            rounds.stats.rounds += 1;
            if rounds.round == 1 {
                rounds.stats.ticks_with_rounds += 1;
            }
            rounds.stats.max_in_a_tick = rounds.stats.max_in_a_tick.max(rounds.round);
            rounds.stats.wakeups += inboxes.len() as u64;
            rounds.woken = inboxes.iter().map(|b| b.robot).collect();
        }
        self.rounds = Some(rounds);
        inboxes
    }

    /// The round the tick is in (0 before its first round).
    pub fn round(&self) -> u32 {
        self.rounds.as_ref().map_or(0, |r| r.round)
    }

    /// Applies robot `robot`'s answer to the current round, in ascending robot order (as
    /// [`World::next_round`] named them): a valid React replaces the motion of the robot's
    /// decision in `commands` (its outbox and notes stay those of the tick) and sends its
    /// frames in the next round; its notes become events. `None` (no answer: it died or was
    /// given up) and a refused reaction change nothing.
    pub fn react(
        &mut self,
        robot: u32,
        answer: Option<&Command>,
        commands: &mut [Option<Command>],
    ) {
        let i = robot as usize;
        let woken = self
            .rounds
            .as_ref()
            .is_some_and(|r| r.woken.binary_search(&robot).is_ok());
        let Some(answer) = answer else { return };
        if !woken
            || self
                .robots
                .get(i)
                .is_none_or(|r| r.state != RobotState::Active)
        {
            return;
        }
        if let Err(reason) = self.validate_reaction(i, answer) {
            self.reject(robot, reason);
            if let Some(r) = self.rounds.as_mut() {
                r.stats.rejected += 1;
            }
            return;
        }
        if let Some(Some(cmd)) = commands.get_mut(i) {
            cmd.v = answer.v;
            cmd.omega = answer.omega;
            cmd.vx = answer.vx;
            cmd.vy = answer.vy;
            cmd.vz = answer.vz;
            cmd.lidar_on = answer.lidar_on;
        }
        let tick = self.tick;
        let report = answer.report().unwrap_or_default();
        for note in (self.vocabulary.read_notes)(report).unwrap_or_default() {
            self.events.push(Event::Note {
                tick,
                robot,
                note: note.json,
            });
        }
        let frames = answer.outbox().to_vec();
        if let Some(r) = self.rounds.as_mut()
            && !frames.is_empty()
        {
            r.outgoing.push((robot, frames));
        }
    }

    /// A reaction is checked as an Act is (limits, frames, notes), but must say React.
    fn validate_reaction(&self, robot: usize, cmd: &Command) -> Result<(), &'static str> {
        if CommandKind::from_u32(cmd.kind) != Some(CommandKind::React) {
            return Err("not a React command in a propagation round");
        }
        let as_act = Command {
            kind: CommandKind::Act as u32,
            ..*cmd
        };
        self.validate(robot, &as_act)
    }

    /// One round of routing: senders ascending, frames in outbox order, broadcast receivers
    /// ascending; loss drawn per copy that reaches the loss step.
    fn route_round(
        &mut self,
        rounds: &mut Rounds,
        outgoing: &[(u32, Vec<Frame>)],
    ) -> Vec<RoundInbox> {
        let n = self.robots.len();
        let cfg = self.cfg.radio;
        let tick = self.tick;
        let active = |r: usize| self.robots[r].state == RobotState::Active;
        let pos = |r: usize| (self.robots[r].x, self.robots[r].y);
        let mut boxes: Vec<Option<RoundInbox>> = vec![None; n];
        let mut sorted: Vec<&(u32, Vec<Frame>)> = outgoing.iter().collect();
        sorted.sort_by_key(|(src, _)| *src);
        let st = &mut rounds.stats;
        for (src, frames) in sorted {
            let s = *src as usize;
            if !active(s) {
                continue;
            }
            for (k, frame) in frames.iter().enumerate() {
                st.frames += 1;
                let receivers: Vec<usize> = if frame.dst == BROADCAST {
                    (0..n)
                        .filter(|&r| r != s && active(r) && within(pos(s), pos(r), cfg.range))
                        .collect()
                } else {
                    vec![frame.dst as usize]
                };
                for r in receivers {
                    st.sent += 1;
                    if r >= n {
                        st.dropped += 1;
                        continue;
                    }
                    let reaches = k < cfg.capacity as usize
                        && r != s
                        && active(r)
                        && within(pos(s), pos(r), cfg.range)
                        && !self.radio.apart(s, r)
                        && !(cfg.line_of_sight && self.map.blocks(pos(s), pos(r)))
                        && !lose(&mut rounds.rng, &cfg);
                    let inbox = boxes[r].get_or_insert_with(|| RoundInbox::empty(r as u32));
                    if !reaches || (inbox.inbox_len as usize) >= MAX_INBOX {
                        st.dropped += 1;
                        continue;
                    }
                    inbox.inbox[inbox.inbox_len as usize] = Frame {
                        src: *src,
                        sent_tick: tick,
                        ..*frame
                    };
                    inbox.inbox_len += 1;
                    st.delivered += 1;
                }
            }
        }
        boxes
            .into_iter()
            .flatten()
            .filter(|b| b.inbox_len > 0)
            .collect()
    }
}

fn within(a: (f64, f64), b: (f64, f64), range: f64) -> bool {
    let (dx, dy) = (a.0 - b.0, a.1 - b.1);
    (dx * dx + dy * dy).sqrt() <= range
}

/// A round copy's loss: Bernoulli at `radio.loss`, or, with Gilbert-Elliott, at the
/// model's long-run loss rate (its bursts are a property of a link over many ticks; a round
/// is a fraction of one).
fn lose(rng: &mut Rng, radio: &swarmrt_scenario::RadioConfig) -> bool {
    let p = match radio.loss_model {
        swarmrt_scenario::LossModel::Bernoulli => radio.loss,
        swarmrt_scenario::LossModel::GilbertElliott => {
            let bad = if radio.ge_p + radio.ge_r > 0.0 {
                radio.ge_p / (radio.ge_p + radio.ge_r)
            } else {
                0.0
            };
            (1.0 - bad) * radio.ge_loss_good + bad * radio.ge_loss_bad
        }
    };
    p > 0.0 && rng.random::<f64>() < p
}
