//! Seeded in-process harnesses for the consensus cores (`swarm fuzz ...`).
//!
//! [`Sim`] drives real [`Agent`]s (behaviour + consensus, exactly as in a run) through the
//! world's real [`RadioMedium`], so messages see the same range, loss, delay, jitter and
//! capacity rules as in `swarm run`. Robots stand still at fixed positions (movement does not
//! matter to consensus). Partitions are the medium's own radio groups (as a `[faults]`
//! partition in a run: copies count as `dropped_partition`); the harness adds what a run's
//! world does not offer: crashes at any tick (the robot stops talking, its notes stop, the
//! checker hears of its death) and restarts with the persistent Raft state the robot had
//! (term, vote, log, commit: Raft's stable storage; volatile state and the behaviour start
//! afresh). A crash can also land inside a tick ([`CrashPoint`]): after the robot made its new
//! state durable but before its messages and notes left, or while that write was torn (the
//! storage then holds the state before the tick).

pub mod consensus;
pub mod election;
pub mod quadrant;

use swarmrt_agent::Agent;
use swarmrt_agent::Note;
use swarmrt_agent::consensus::Role;
use swarmrt_agent::consensus::raft::Persistent;
use swarmrt_protocol::{Frame, Neighbour, NoteJson, Observation, RobotState};
use swarmrt_scenario::Config;
use swarmrt_world::Event;
use swarmrt_world::radio::RadioMedium;

use crate::consensus_check::Checker;

/// A minimal scenario the harnesses adjust (robot count, radio, consensus).
pub fn base_config() -> Config {
    Config::from_toml_str(
        "fuzz.toml",
        r#"
[scenario]
name = "fuzz"
ticks = 100000000
[map]
bounds = [-1000.0, -1000.0, 1000.0, 1000.0]
goal = { x = 500.0, y = 500.0, radius = 1.0 }
[robots]
count = 3
[radio]
range = 1000.0
[consensus]
"#,
        &[],
    )
    .expect("the built-in fuzz config is valid")
}

/// `n` positions on a square grid of `spacing` metres around the origin.
pub fn grid(n: usize, spacing: f64) -> Vec<(f64, f64)> {
    let side = (n as f64).sqrt().ceil() as usize;
    (0..n)
        .map(|i| ((i % side) as f64 * spacing, (i / side) as f64 * spacing))
        .collect()
}

/// One `events.jsonl` line, exactly as the world writes it.
fn event_line(e: &Event) -> String {
    serde_json::to_string(e).expect("events always serialize")
}

/// Where in a robot's tick a crash lands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CrashPoint {
    /// Between ticks: everything it decided was stored and sent.
    BetweenTicks,
    /// After its new state was written to stable storage, before its command (messages and
    /// notes) left: the storage is ahead of what anyone heard.
    AfterWrite,
    /// While writing: the last record is torn, so the storage holds the state from before
    /// this tick, and nothing of this tick left.
    TornWrite,
}

/// Robots, medium and checker of one in-process consensus run.
pub struct Sim {
    cfg: Config,
    agents: Vec<Option<Agent>>,
    saved: Vec<Option<Persistent>>,
    /// Robots to crash inside their next step, and where.
    crash_in_step: Vec<Option<CrashPoint>>,
    /// Armed by [`Sim::crash_on_winning`]: crash the next robot (but this one) that wins an
    /// election, inside the step it won in, after its write.
    crash_on_winning: Option<Option<u32>>,
    /// The robot that crash took, until [`Sim::take_crashed_on_winning`].
    crashed_on_winning: Option<u32>,
    incarnation: Vec<u32>,
    medium: RadioMedium,
    positions: Vec<(f64, f64)>,
    headings: Vec<f64>,
    neighbours: Vec<Vec<Neighbour>>,
    inboxes: Vec<Vec<Frame>>,
    checker: Checker,
    tick: u64,
    record: Option<Vec<String>>,
    /// (messages left for lack of note room, messages beyond the frame budget) of crashed
    /// incarnations.
    lost_counts: (u64, u64),
}

impl Sim {
    /// Robots of `cfg` at `positions` (one per robot), all alive at tick 0.
    pub fn new(cfg: &Config, positions: Vec<(f64, f64)>) -> Sim {
        let n = cfg.robots.count as usize;
        assert_eq!(positions.len(), n, "one position per robot");
        let mut radio = cfg.radio;
        // No obstacles here: nothing blocks a line of sight.
        radio.line_of_sight = false;
        Sim {
            agents: (0..n as u32).map(|i| Some(Agent::new(cfg, i))).collect(),
            saved: vec![None; n],
            crash_in_step: vec![None; n],
            crash_on_winning: None,
            crashed_on_winning: None,
            incarnation: vec![0; n],
            medium: RadioMedium::new(radio, cfg.scenario.seed, n),
            positions,
            headings: vec![0.0; n],
            neighbours: vec![Vec::new(); n],
            inboxes: vec![Vec::new(); n],
            checker: Checker::new(),
            tick: 0,
            record: None,
            lost_counts: (0, 0),
            cfg: cfg.clone(),
        }
    }

    /// Keeps every note and death as an `events.jsonl` line (see [`Sim::recorded`]).
    pub fn record(&mut self) {
        self.record = Some(Vec::new());
    }

    /// The recorded `events.jsonl` text.
    pub fn recorded(&self) -> String {
        self.record
            .as_ref()
            .map(|l| l.iter().map(|s| format!("{s}\n")).collect())
            .unwrap_or_default()
    }

    /// Sets headings (radians) and what each robot's range-and-bearing sensor sees.
    pub fn set_senses(&mut self, headings: Vec<f64>, neighbours: Vec<Vec<Neighbour>>) {
        self.headings = headings;
        self.neighbours = neighbours;
    }

    /// The current tick.
    pub fn tick(&self) -> u64 {
        self.tick
    }

    /// The checker fed with every note so far.
    pub fn checker(&self) -> &Checker {
        &self.checker
    }

    /// Robot `r`'s agent, unless crashed.
    pub fn agent(&self, r: u32) -> Option<&Agent> {
        self.agents.get(r as usize)?.as_ref()
    }

    /// Whether robot `r` is alive.
    pub fn alive(&self, r: u32) -> bool {
        self.agent(r).is_some()
    }

    /// The live robot that believes it leads with the highest term.
    pub fn leader(&self) -> Option<u32> {
        self.agents
            .iter()
            .enumerate()
            .filter_map(|(i, a)| {
                let r = a.as_ref()?.consensus()?.raft()?;
                (r.role() == Role::Leader).then_some((r.term(), i as u32))
            })
            .max()
            .map(|(_, i)| i)
    }

    /// Crashes robot `r` between ticks, keeping its persistent state for a restart.
    pub fn crash(&mut self, r: u32) {
        // A crash due inside the next step is overtaken by this one.
        self.crash_in_step[r as usize] = None;
        let Some(a) = self.agents[r as usize].take() else {
            return;
        };
        let (l, u) = counts(&a);
        self.lost_counts.0 += l;
        self.lost_counts.1 += u;
        self.saved[r as usize] = a.consensus().and_then(|c| c.persistent());
        self.checker.died(self.tick, r);
        if let Some(rec) = &mut self.record {
            rec.push(event_line(&Event::Died {
                tick: self.tick,
                robot: r,
                reason: "fuzz crash".to_string(),
            }));
        }
    }

    /// Crashes robot `r` at `point`: [`CrashPoint::BetweenTicks`] now, the others inside its
    /// next step.
    pub fn crash_at(&mut self, r: u32, point: CrashPoint) {
        match point {
            CrashPoint::BetweenTicks => self.crash(r),
            _ if self.alive(r) => self.crash_in_step[r as usize] = Some(point),
            _ => {}
        }
    }

    /// Arms a crash of the next robot other than `except` that wins an election: it dies in
    /// the step it won, after its new state (term, vote, no-op) was written and before
    /// anything of that step left ([`CrashPoint::AfterWrite`]). Nobody hears of its leadership;
    /// its no-op is on it alone (Figure 8's leader of term 3). `None` disarms.
    pub fn crash_on_winning(&mut self, armed: Option<Option<u32>>) {
        self.crash_on_winning = armed;
    }

    /// The robot the armed crash took, once (see [`Sim::crash_on_winning`]).
    pub fn take_crashed_on_winning(&mut self) -> Option<u32> {
        self.crashed_on_winning.take()
    }

    /// Restarts crashed robot `r` from its saved persistent state.
    pub fn restart(&mut self, r: u32) {
        if self.agents[r as usize].is_some() {
            // A crash still due inside this tick and a restart at the same boundary: it
            // never went down.
            self.crash_in_step[r as usize] = None;
            return;
        }
        self.incarnation[r as usize] += 1;
        let inc = self.incarnation[r as usize];
        self.agents[r as usize] = Some(match self.saved[r as usize].take() {
            Some(s) => Agent::restore(&self.cfg, r, s, inc),
            None => Agent::new(&self.cfg, r),
        });
    }

    /// One tick: every live robot observes and acts, its notes go to the checker, the medium
    /// routes its frames (robots in different `groups` cannot hear each other; `None`: no
    /// partition) and delivers.
    pub fn step(&mut self, groups: Option<Vec<u64>>) {
        let n = self.agents.len();
        let tick = self.tick;
        let mut outboxes: Vec<Vec<Frame>> = vec![Vec::new(); n];
        let mut crashed_in_step = Vec::new();
        for (i, (slot, outbox)) in self.agents.iter_mut().zip(&mut outboxes).enumerate() {
            let Some(agent) = slot.as_mut() else {
                continue;
            };
            let mut obs = Observation::empty(i as u32, tick);
            obs.state = RobotState::Active as u8;
            (obs.x, obs.y) = self.positions[i];
            obs.theta = self.headings[i];
            let nb = &self.neighbours[i];
            for (slot, nbr) in nb.iter().take(obs.neighbours.len()).enumerate() {
                obs.neighbours[slot] = *nbr;
            }
            obs.neighbours_len = nb.len().min(obs.neighbours.len()) as u16;
            let inbox = &self.inboxes[i];
            for (slot, f) in inbox.iter().take(obs.inbox.len()).enumerate() {
                obs.inbox[slot] = *f;
            }
            obs.inbox_len = inbox.len().min(obs.inbox.len()) as u16;
            let before = agent.consensus().and_then(|c| c.persistent());
            let leading = |a: &Agent| {
                a.consensus()
                    .and_then(|c| c.raft())
                    .is_some_and(|r| r.role() == Role::Leader)
            };
            let led = leading(agent);
            // The fuzzer models stable storage with whole states (`before`, `crash`).
            let cmd = agent.step(&obs).without_storage();
            if let Some(except) = self.crash_on_winning
                && except != Some(i as u32)
                && !led
                && leading(agent)
            {
                self.crash_on_winning = None;
                self.crashed_on_winning = Some(i as u32);
                self.crash_in_step[i] = Some(CrashPoint::AfterWrite);
            }
            if let Some(point) = self.crash_in_step[i].take() {
                // The process dies before its command leaves: no frame, no note.
                crashed_in_step.push((i as u32, point, before));
                continue;
            }
            *outbox = cmd.outbox().to_vec();
            for note in cmd.notes::<Note>().unwrap_or_default() {
                if let Some(rec) = &mut self.record {
                    rec.push(event_line(&Event::Note {
                        tick,
                        robot: i as u32,
                        note: NoteJson::new(note.to_json()).expect("a note is one JSON value"),
                    }));
                }
                if let Note::Consensus(c) = note {
                    self.checker.note(tick, i as u32, &c);
                }
            }
        }
        for (r, point, before) in crashed_in_step {
            self.crash(r);
            if point == CrashPoint::TornWrite {
                self.saved[r as usize] = before;
            }
        }
        let can_talk: Vec<bool> = self.agents.iter().map(Option::is_some).collect();
        let slices: Vec<&[Frame]> = outboxes.iter().map(|o| o.as_slice()).collect();
        self.medium.set_groups(groups);
        self.medium
            .send(tick, &slices, &self.positions, &can_talk, &mut |_, _| false);
        self.checker.end_tick(tick);
        self.tick += 1;
        self.medium.deliver(self.tick, &can_talk, &mut self.inboxes);
    }

    /// Messages the Raft cores left unprocessed because their notes would not have fit the
    /// tick's report, and messages they dropped because the tick's frames were used up.
    pub fn budget_counters(&self) -> (u64, u64) {
        self.agents
            .iter()
            .flatten()
            .map(counts)
            .fold(self.lost_counts, |acc, c| (acc.0 + c.0, acc.1 + c.1))
    }

    /// Radio counters so far.
    pub fn radio(&self) -> swarmrt_world::radio::RadioStats {
        self.medium.stats()
    }
}

fn counts(a: &Agent) -> (u64, u64) {
    a.consensus()
        .and_then(|c| c.raft())
        .map_or((0, 0), |r| (r.left_for_notes(), r.unsent()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_partition_keeps_the_minority_from_leading_and_a_crash_silences_a_robot() {
        let mut cfg = base_config();
        cfg.robots.count = 5;
        let mut sim = Sim::new(&cfg, grid(5, 0.7));
        // Robots 0 and 1 are cut off from 2, 3 and 4 for the whole run.
        let apart = || Some(vec![1, 1, 0, 0, 0]);
        while sim.checker().current_leader().is_none() {
            assert!(sim.tick() < 1000, "a leader in the majority");
            sim.step(apart());
        }
        let (leader, _) = sim.checker().current_leader().unwrap();
        assert!(leader >= 2, "leader {leader} is in the majority");
        assert!(sim.radio().dropped_partition > 0);
        sim.crash(leader);
        assert!(!sim.alive(leader));
        let before = sim.radio().frames;
        let t = sim.tick();
        while sim.tick() < t + 300 {
            sim.step(apart());
        }
        // Two live robots on the majority side and two in the minority: no side has the
        // three votes of a majority of five, so nobody leads.
        assert_eq!(sim.leader(), None);
        assert_eq!(sim.checker().current_leader(), None);
        assert!(sim.radio().frames > before, "the others still talk");
        assert!(sim.checker().violations().is_empty());
    }
}
