//! The world core: a deterministic state machine. `observe` fills every robot's
//! [`Observation`] for the current tick, `step` takes every robot's [`Command`] and advances
//! one tick. No I/O, no clock; every random draw comes from the run seed.

use rand::Rng as _;
use rand_distr::{Distribution, Normal};
use serde::Serialize;
use std::collections::BTreeSet;
use std::f64::consts::PI;
use swarmrt_protocol::config::Config;
use swarmrt_protocol::faults::FaultTarget;
use swarmrt_protocol::{
    BROADCAST, Command, CommandKind, Frame, MAX_INBOX, MAX_LIDAR_RAYS, MAX_NEIGHBOURS, MAX_OUTBOX,
    MAX_PAYLOAD, Neighbour, Note, Observation, PROTOCOL_VERSION, RadioMsg, RobotState,
};

use crate::grid::Grid;
use crate::map::{Map, MapError};
use crate::radio::{RadioMedium, RadioStats};
use crate::rng::{self, Rng};

/// The truth about one robot.
#[derive(Debug, Clone, PartialEq)]
pub struct Robot {
    /// Robot id (index).
    pub id: u32,
    /// True x position, metres.
    pub x: f64,
    /// True y position, metres.
    pub y: f64,
    /// True heading, radians in (-pi, pi].
    pub theta: f64,
    /// Forward speed applied in the last step.
    pub v: f64,
    /// Turn rate applied in the last step.
    pub omega: f64,
    /// Whether the lidar is on for the current observation.
    pub lidar_on: bool,
    /// Lifecycle state.
    pub state: RobotState,
    /// First tick at which the robot was inside the goal radius.
    pub reached_tick: Option<u64>,
}

/// Something worth a line in `events.jsonl`.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "event", rename_all = "snake_case")]
pub enum Event {
    /// A robot hit an obstacle, a wall or another robot and went down.
    Collision {
        /// Tick of the step in which it happened.
        tick: u64,
        /// The robot that went down.
        robot: u32,
        /// The other robot, when it was a robot.
        #[serde(skip_serializing_if = "Option::is_none")]
        other: Option<u32>,
    },
    /// A robot entered the goal radius for the first time.
    Reached {
        /// Tick at which it was first inside.
        tick: u64,
        /// The robot.
        robot: u32,
    },
    /// A robot's process is gone; it stays where it is as an obstacle.
    Died {
        /// Tick from which it counts as dead.
        tick: u64,
        /// The robot.
        robot: u32,
        /// Why (e.g. "process exited: signal 9").
        reason: String,
    },
    /// A scheduled fault took effect or ended.
    Fault {
        /// Tick from which it holds.
        tick: u64,
        /// `kill`, `freeze`, `thaw`, `restart`, `rejoin`, `partition_start`, `partition_end`,
        /// `blackout_start`, `blackout_end`, or `kill_skipped` / `freeze_skipped` /
        /// `restart_skipped` when the target was dead, already out, or a `"leader"` target
        /// had no leader.
        fault: String,
        /// The robot, for a process fault.
        #[serde(skip_serializing_if = "Option::is_none")]
        robot: Option<u32>,
        /// True for a fault drawn from `faults.kill_rate` / `faults.freeze_rate`.
        #[serde(skip_serializing_if = "std::ops::Not::not")]
        random: bool,
    },
    /// A robot's note about its own decisions (role, turn, consensus state).
    Note {
        /// Tick of the command that carried it.
        tick: u64,
        /// The robot.
        robot: u32,
        /// What it said.
        note: Note,
    },
    /// A robot sent a command the world refused (logged once per robot and reason).
    Rejected {
        /// Tick of the refused command.
        tick: u64,
        /// The robot.
        robot: u32,
        /// What was wrong.
        reason: String,
    },
}

/// Scalar outcome of a run so far.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct WorldMetrics {
    /// Ticks stepped.
    pub ticks: u64,
    /// Robots that reached the goal.
    pub reached_target: u32,
    /// Collision events.
    pub collisions: u32,
    /// Robots knocked down.
    pub down: u32,
    /// Robots whose process died.
    pub dead: u32,
    /// Robot-ticks with the lidar on (the energy metric).
    pub lidar_on_ticks: u64,
    /// Commands refused at the world boundary.
    pub rejected: u64,
    /// Faults that took effect (kills, freezes, restarts, partitions and blackouts begun).
    pub faults_injected: u64,
    /// Robot processes restarted by the schedule.
    pub restarts: u64,
    /// Robot-ticks spent frozen.
    pub frozen_ticks: u64,
    /// Radio counters.
    pub radio: RadioStats,
}

/// The world of one run.
pub struct World {
    cfg: Config,
    map: Map,
    robots: Vec<Robot>,
    radio: RadioMedium,
    tick: u64,
    sensor_rng: Vec<Rng>,
    inboxes: Vec<Vec<Frame>>,
    events: Vec<Event>,
    rejected_once: BTreeSet<(u32, &'static str)>,
    metrics: WorldMetrics,
    /// The robot that last reported itself leader (the target of a `"leader"` fault).
    leader: Option<u32>,
    /// Process faults the shell must still carry out with real signals.
    signals: Vec<ProcessSignal>,
    /// Per robot, the freeze or restart it is in.
    outages: Vec<Option<Outage>>,
    /// Per robot, how many times the schedule restarted its process.
    incarnations: Vec<u32>,
    /// Draws of `faults.kill_rate` and `faults.freeze_rate`.
    fault_rng: Rng,
}

/// What the process shell must do to a robot's process at this tick boundary. The world core
/// has already applied it to its own state, so the run replays whatever the signal's timing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ProcessSignal {
    /// SIGKILL it: it is dead from this tick.
    Kill(u32),
    /// SIGSTOP it: it is frozen from this tick.
    Freeze(u32),
    /// SIGCONT it: it answers this tick's observation again.
    Thaw(u32),
    /// SIGKILL it and start a fresh process for the robot, its `incarnation`-th.
    Restart {
        /// The robot.
        robot: u32,
        /// 1 for the first restart, 2 for the second, ...
        incarnation: u32,
    },
    /// The fresh process must have said hello before this tick is published.
    Rejoin(u32),
}

/// A freeze or a restart in progress.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Outage {
    /// First tick it answers again.
    until: u64,
    /// State to return to (a robot knocked down before stays down).
    resume: RobotState,
}

/// Wraps an angle into (-pi, pi].
pub fn wrap_angle(a: f64) -> f64 {
    let mut a = a % (2.0 * PI);
    if a <= -PI {
        a += 2.0 * PI;
    } else if a > PI {
        a -= 2.0 * PI;
    }
    a
}

impl World {
    /// Builds the world at tick 0 with every robot at its start position.
    pub fn new(cfg: &Config) -> Result<World, MapError> {
        let map = Map::build(&cfg.map)?;
        let seed = cfg.scenario.seed;
        let heading = wrap_angle(cfg.start_heading());
        let radius = cfg.robots.radius;
        let starts = cfg
            .start_positions(|x, y| map.clearance((x, y)) >= radius * 1.5)
            .ok_or_else(|| MapError {
                key: "robots.start".to_string(),
                message: format!(
                    "expected room for {} robots {} m apart near ({}, {}), inside map.bounds and clear of obstacles; \
                     the map has less (lower robots.count or robots.start.spacing, or move robots.start)",
                    cfg.robots.count, cfg.robots.start.spacing, cfg.robots.start.x, cfg.robots.start.y
                ),
            })?;
        let robots: Vec<Robot> = starts
            .into_iter()
            .enumerate()
            .map(|(i, (x, y))| Robot {
                id: i as u32,
                x,
                y,
                theta: heading,
                v: 0.0,
                omega: 0.0,
                lidar_on: true,
                state: RobotState::Active,
                reached_tick: None,
            })
            .collect();
        let n = robots.len();
        let mut world = World {
            cfg: cfg.clone(),
            map,
            radio: RadioMedium::new(cfg.radio, seed, n),
            tick: 0,
            sensor_rng: (0..n)
                .map(|i| rng::stream(seed, "sensor", i as u64))
                .collect(),
            inboxes: vec![Vec::new(); n],
            events: Vec::new(),
            rejected_once: BTreeSet::new(),
            metrics: WorldMetrics::default(),
            leader: None,
            signals: Vec::new(),
            outages: vec![None; n],
            incarnations: vec![0; n],
            fault_rng: rng::stream(seed, "faults", 0),
            robots,
        };
        world.check_goal();
        world.apply_faults();
        Ok(world)
    }

    /// The current tick (the one `observe` describes).
    pub fn tick(&self) -> u64 {
        self.tick
    }

    /// Every robot's true state.
    pub fn robots(&self) -> &[Robot] {
        &self.robots
    }

    /// The map, for queries such as line of sight.
    pub fn map(&self) -> &Map {
        &self.map
    }

    /// The config the world was built from.
    pub fn config(&self) -> &Config {
        &self.cfg
    }

    /// Metrics so far.
    pub fn metrics(&self) -> WorldMetrics {
        let mut m = self.metrics.clone();
        m.radio = self.radio.stats();
        m
    }

    /// Takes the events produced since the last call, in the order they happened.
    pub fn drain_events(&mut self) -> Vec<Event> {
        std::mem::take(&mut self.events)
    }

    /// True when the run should end: the tick budget is spent, or (with
    /// `scenario.stop_when_done`) every robot reached the goal or is down or dead.
    pub fn finished(&self) -> bool {
        self.tick >= self.cfg.scenario.ticks
            || (self.cfg.scenario.stop_when_done
                && self
                    .robots
                    .iter()
                    .all(|r| r.reached_tick.is_some() || r.state != RobotState::Active))
    }

    /// Marks a robot whose process is gone as dead from the current tick; it stays as an
    /// obstacle. Idempotent.
    pub fn mark_dead(&mut self, robot: u32, reason: &str) {
        let Some(r) = self.robots.get_mut(robot as usize) else {
            return;
        };
        if r.state == RobotState::Dead {
            return;
        }
        r.state = RobotState::Dead;
        self.outages[robot as usize] = None;
        r.v = 0.0;
        r.omega = 0.0;
        r.lidar_on = false;
        self.metrics.dead += 1;
        self.events.push(Event::Died {
            tick: self.tick,
            robot,
            reason: reason.to_string(),
        });
    }

    /// Fills `out[i]` with robot i's observation of the current tick. Draws sensor noise, so
    /// call it exactly once per tick.
    ///
    /// From [`PARALLEL_OBSERVE_MIN`] robots on, the robots are split into contiguous ranges
    /// observed on scoped threads (at most [`OBSERVE_THREADS`]): each observation reads only
    /// shared state and its own robot's noise stream, so the result is the same bytes. In
    /// process mode the robots sleep while the world observes, so the other cores are free
    /// (a scoped thread costs ~50 us here; at 100 robots two threads take 226 us, one 290 us).
    pub fn observe(&mut self, out: &mut [Observation]) {
        let threads = if self.robots.len() >= PARALLEL_OBSERVE_MIN {
            std::thread::available_parallelism()
                .map(|p| p.get())
                .unwrap_or(1)
                .min(OBSERVE_THREADS)
        } else {
            1
        };
        self.observe_on(out, threads);
    }

    /// [`World::observe`] on exactly `threads` threads (at least one): the same bytes for
    /// any count.
    pub fn observe_on(&mut self, out: &mut [Observation], threads: usize) {
        let n = self.robots.len();
        assert_eq!(out.len(), n, "one observation slot per robot");
        let positions: Vec<(f64, f64)> = self.robots.iter().map(|r| (r.x, r.y)).collect();
        let lidar = self.cfg.robots.lidar;
        let rb_range = self.cfg.robots.range_bearing.range;
        let radius = self.cfg.robots.radius;
        // One neighbour query per robot serves the lidar (bodies within range + radius) and
        // range-and-bearing. Cells about a third of that reach keep the candidates close to
        // the disc (results do not depend on the cell size: candidates are filtered by
        // distance and sorted).
        let reach = (lidar.range + radius).max(rb_range);
        let grid = Grid::build(&positions, (reach / 3.0).max(4.0 * radius));
        let ctx = ObserveCtx {
            robots: &self.robots,
            map: &self.map,
            grid: &grid,
            inboxes: &self.inboxes,
            tick: self.tick,
            lidar,
            rb_range,
            radius,
            reach,
            noise: self.cfg.robots.noise,
            goal: self.cfg.map.goal,
            goal_sensor: self.cfg.robots.goal_sensor,
        };
        let rngs = &mut self.sensor_rng[..];
        if threads <= 1 || n < 2 {
            ctx.observe_range(0, out, rngs);
        } else {
            let chunk = n.div_ceil(threads);
            std::thread::scope(|s| {
                let mut parts = out
                    .chunks_mut(chunk)
                    .zip(rngs.chunks_mut(chunk))
                    .enumerate();
                let first = parts.next();
                for (k, (outs, rngs)) in parts {
                    let ctx = &ctx;
                    s.spawn(move || ctx.observe_range(k * chunk, outs, rngs));
                }
                if let Some((_, (outs, rngs))) = first {
                    ctx.observe_range(0, outs, rngs);
                }
            });
        }
        for r in &self.robots {
            if r.state == RobotState::Active && r.lidar_on {
                self.metrics.lidar_on_ticks += 1;
            }
        }
    }

    /// Checks a command against the protocol and the robot's limits; `Err` names the problem.
    pub fn validate(&self, robot: usize, cmd: &Command) -> Result<(), &'static str> {
        let lim = &self.cfg.robots;
        if cmd.version != PROTOCOL_VERSION {
            return Err("wrong protocol version");
        }
        if cmd.robot as usize != robot {
            return Err("robot id does not match its slot");
        }
        if CommandKind::from_u32(cmd.kind) != Some(CommandKind::Act) {
            return Err("not an Act command");
        }
        if cmd.tick != self.tick {
            return Err("command for another tick");
        }
        if !cmd.v.is_finite() || !cmd.omega.is_finite() {
            return Err("non-finite speed");
        }
        let eps = 1e-9;
        if cmd.v.abs() > lim.max_speed * (1.0 + eps) + eps
            || cmd.omega.abs() > lim.max_turn_rate * (1.0 + eps) + eps
        {
            return Err("speed out of range");
        }
        if cmd.outbox_len as usize > MAX_OUTBOX {
            return Err("outbox length out of range");
        }
        cmd.notes()?;
        for f in cmd.outbox() {
            if f.len as usize > MAX_PAYLOAD {
                return Err("oversized radio frame");
            }
            if f.dst != BROADCAST && f.dst as usize >= self.robots.len() {
                return Err("radio frame to an unknown robot");
            }
            // The world routes bytes, but bytes no robot could read are refused at the
            // boundary rather than delivered as noise.
            if RadioMsg::decode(f.bytes()).is_none() {
                return Err("malformed radio frame");
            }
        }
        Ok(())
    }

    /// Advances one tick. `commands[i]` is robot i's answer to this tick's observation, or
    /// `None` if it sent none (dead, or a shell that gave up waiting). Invalid commands are
    /// refused, counted and treated as "stop, send nothing".
    pub fn step(&mut self, commands: &[Option<Command>]) {
        let n = self.robots.len();
        assert_eq!(commands.len(), n, "one command slot per robot");
        let tick = self.tick;
        let dt = self.cfg.scenario.dt;
        let radius = self.cfg.robots.radius;

        // 1. Accept or refuse each command.
        let mut accepted: Vec<Option<&Command>> = vec![None; n];
        for i in 0..n {
            if self.robots[i].state != RobotState::Active {
                continue;
            }
            if let Some(cmd) = &commands[i] {
                match self.validate(i, cmd) {
                    Ok(()) => {
                        accepted[i] = Some(cmd);
                        // validate() decoded it once already; this cannot fail.
                        for note in cmd.notes().unwrap_or_default() {
                            if note.claims_leadership() {
                                self.leader = Some(i as u32);
                            }
                            self.events.push(Event::Note {
                                tick,
                                robot: i as u32,
                                note,
                            });
                        }
                    }
                    Err(reason) => self.reject(i as u32, reason),
                }
            }
        }

        // 2. Radio: route what robots sent at this tick, from where they were when sending.
        let positions: Vec<(f64, f64)> = self.robots.iter().map(|r| (r.x, r.y)).collect();
        let can_talk: Vec<bool> = self
            .robots
            .iter()
            .map(|r| r.state == RobotState::Active)
            .collect();
        let outboxes: Vec<&[Frame]> = accepted
            .iter()
            .map(|c| c.map(|c| c.outbox()).unwrap_or(&[]))
            .collect();
        let map = &self.map;
        let mut blocked = |a: usize, b: usize| map.blocks(positions[a], positions[b]);
        self.radio
            .send(tick, &outboxes, &positions, &can_talk, &mut blocked);

        // 3. Kinematics (unicycle, heading first then position) with swept obstacle checks.
        for (i, accepted) in accepted.iter().enumerate() {
            let r = &mut self.robots[i];
            if r.state != RobotState::Active {
                r.v = 0.0;
                r.omega = 0.0;
                continue;
            }
            let (v, omega, lidar) = match accepted {
                Some(c) => (c.v, c.omega, c.lidar_on != 0),
                None => (0.0, 0.0, r.lidar_on),
            };
            r.v = v;
            r.omega = omega;
            r.lidar_on = lidar;
            r.theta = wrap_angle(r.theta + omega * dt);
            let (dx, dy) = (v * dt * r.theta.cos(), v * dt * r.theta.sin());
            let dist = (dx * dx + dy * dy).sqrt();
            let sub = ((dist / (radius * 0.5)).ceil() as usize).max(1);
            let (x0, y0) = (r.x, r.y);
            for s in 1..=sub {
                let f = s as f64 / sub as f64;
                r.x = x0 + dx * f;
                r.y = y0 + dy * f;
                if self.map.clearance((r.x, r.y)) < radius {
                    r.state = RobotState::Down;
                    break;
                }
            }
            if r.state == RobotState::Down {
                self.metrics.collisions += 1;
                self.metrics.down += 1;
                self.events.push(Event::Collision {
                    tick,
                    robot: i as u32,
                    other: None,
                });
            }
        }

        // 4. Robot-robot contacts: both go down (a down or dead robot is an obstacle).
        let positions: Vec<(f64, f64)> = self.robots.iter().map(|r| (r.x, r.y)).collect();
        let grid = Grid::build(&positions, 2.0 * radius);
        let mut pairs: Vec<(usize, usize)> = Vec::new();
        for i in 0..n {
            if self.robots[i].state != RobotState::Active {
                continue;
            }
            grid.near(positions[i], 2.0 * radius, |j| {
                if j != i {
                    let d = ((positions[j].0 - positions[i].0).powi(2)
                        + (positions[j].1 - positions[i].1).powi(2))
                    .sqrt();
                    if d < 2.0 * radius {
                        pairs.push((i.min(j), i.max(j)));
                    }
                }
            });
        }
        pairs.sort_unstable();
        pairs.dedup();
        for (a, b) in pairs {
            for (me, other) in [(a, b), (b, a)] {
                if self.robots[me].state == RobotState::Active {
                    self.robots[me].state = RobotState::Down;
                    self.metrics.collisions += 1;
                    self.metrics.down += 1;
                    self.events.push(Event::Collision {
                        tick,
                        robot: me as u32,
                        other: Some(other as u32),
                    });
                }
            }
        }

        // 5. Advance time, deliver what is due, note arrivals.
        self.tick += 1;
        self.metrics.ticks = self.tick;
        let can_talk: Vec<bool> = self
            .robots
            .iter()
            .map(|r| r.state == RobotState::Active)
            .collect();
        self.radio.deliver(self.tick, &can_talk, &mut self.inboxes);
        self.check_goal();
        self.apply_faults();
    }

    /// Process faults applied since the last call, in order: the process shell carries them
    /// out with real signals (via the orchestrator); in-process runs restart agents on them.
    pub fn take_signals(&mut self) -> Vec<ProcessSignal> {
        std::mem::take(&mut self.signals)
    }

    fn fault_event(&mut self, fault: &str, robot: Option<u32>, random: bool) {
        self.events.push(Event::Fault {
            tick: self.tick,
            fault: fault.into(),
            robot,
            random,
        });
    }

    fn target(&self, t: &FaultTarget) -> Option<u32> {
        match t {
            FaultTarget::Id(id) => Some(*id),
            FaultTarget::Named(_) => self.leader,
        }
    }

    /// True when the robot's process runs and answers (not dead, frozen or restarting).
    fn running(&self, robot: u32) -> bool {
        self.robots
            .get(robot as usize)
            .is_some_and(|r| r.state.expects_command())
    }

    fn kill(&mut self, robot: u32, random: bool) {
        self.metrics.faults_injected += 1;
        self.fault_event("kill", Some(robot), random);
        self.mark_dead(robot, "fault: kill");
        self.signals.push(ProcessSignal::Kill(robot));
    }

    fn freeze(&mut self, robot: u32, until: u64, random: bool) {
        self.metrics.faults_injected += 1;
        self.fault_event("freeze", Some(robot), random);
        let r = &mut self.robots[robot as usize];
        self.outages[robot as usize] = Some(Outage {
            until,
            resume: r.state,
        });
        r.state = RobotState::Frozen;
        r.v = 0.0;
        r.omega = 0.0;
        self.signals.push(ProcessSignal::Freeze(robot));
    }

    /// Applies the faults scheduled at the current tick boundary: first outages that end,
    /// then kills, restarts, freezes, random faults and radio windows.
    fn apply_faults(&mut self) {
        let tick = self.tick;
        let faults = std::mem::take(&mut self.cfg.faults);
        for robot in 0..self.robots.len() as u32 {
            let Some(o) = self.outages[robot as usize].filter(|o| o.until == tick) else {
                continue;
            };
            self.outages[robot as usize] = None;
            let r = &mut self.robots[robot as usize];
            let was = r.state;
            r.state = o.resume;
            if was == RobotState::Frozen {
                self.fault_event("thaw", Some(robot), false);
                self.signals.push(ProcessSignal::Thaw(robot));
            } else {
                self.fault_event("rejoin", Some(robot), false);
                self.signals.push(ProcessSignal::Rejoin(robot));
            }
        }
        for k in faults.kill.iter().filter(|k| k.tick == tick) {
            let target = self.target(&k.robot);
            // A frozen or restarting process can be killed too.
            match target.filter(|&r| {
                self.robots
                    .get(r as usize)
                    .is_some_and(|r| r.state != RobotState::Dead)
            }) {
                Some(robot) => self.kill(robot, false),
                None => self.fault_event("kill_skipped", target, false),
            }
        }
        for k in faults.restart.iter().filter(|k| k.tick == tick) {
            let target = self.target(&k.robot);
            match target.filter(|&r| {
                self.robots
                    .get(r as usize)
                    .is_some_and(|r| r.state != RobotState::Dead)
            }) {
                Some(robot) => {
                    self.metrics.faults_injected += 1;
                    self.metrics.restarts += 1;
                    self.fault_event("restart", Some(robot), false);
                    let i = robot as usize;
                    self.incarnations[i] += 1;
                    let r = &mut self.robots[i];
                    // Restarting a frozen robot ends the freeze: the stopped process is killed.
                    let resume = match (self.outages[i], r.state) {
                        (Some(o), _) => o.resume,
                        (None, s) => s,
                    };
                    self.outages[i] = Some(Outage {
                        until: tick + k.down_ticks,
                        resume,
                    });
                    r.state = RobotState::Restarting;
                    r.v = 0.0;
                    r.omega = 0.0;
                    r.lidar_on = false;
                    if self.leader == Some(robot) {
                        self.leader = None;
                    }
                    self.signals.push(ProcessSignal::Restart {
                        robot,
                        incarnation: self.incarnations[i],
                    });
                }
                None => self.fault_event("restart_skipped", target, false),
            }
        }
        for f in faults.freeze.iter().filter(|f| f.from == tick) {
            let target = self.target(&f.robot);
            match target.filter(|&r| self.running(r)) {
                Some(robot) => self.freeze(robot, f.to, false),
                None => self.fault_event("freeze_skipped", target, false),
            }
        }
        if faults.kill_rate > 0.0 || faults.freeze_rate > 0.0 {
            // Two draws per robot every tick, whatever its state, so one robot's fate never
            // shifts another's draws.
            for robot in 0..self.robots.len() as u32 {
                let kill = self.fault_rng.random::<f64>() < faults.kill_rate;
                let freeze = self.fault_rng.random::<f64>() < faults.freeze_rate;
                if !self.running(robot) {
                    continue;
                }
                if kill {
                    self.kill(robot, true);
                } else if freeze {
                    self.freeze(robot, tick + faults.freeze_ticks, true);
                }
            }
        }
        let windows = faults
            .partition
            .iter()
            .map(|p| ("partition", p.from, p.to))
            .chain(faults.blackout.iter().map(|b| ("blackout", b.from, b.to)));
        for (kind, from, to) in windows {
            for (at, phase) in [(from, "start"), (to, "end")] {
                if at == tick {
                    if phase == "start" {
                        self.metrics.faults_injected += 1;
                    }
                    self.fault_event(&format!("{kind}_{phase}"), None, false);
                }
            }
        }
        self.metrics.frozen_ticks += self
            .robots
            .iter()
            .filter(|r| r.state == RobotState::Frozen)
            .count() as u64;
        self.radio
            .set_groups(faults.radio_groups(tick, self.robots.len()));
        self.cfg.faults = faults;
    }

    fn check_goal(&mut self) {
        let g = self.cfg.map.goal;
        for r in &mut self.robots {
            if r.reached_tick.is_none()
                && r.state == RobotState::Active
                && (r.x - g.x).powi(2) + (r.y - g.y).powi(2) <= g.radius * g.radius
            {
                r.reached_tick = Some(self.tick);
                self.metrics.reached_target += 1;
                self.events.push(Event::Reached {
                    tick: self.tick,
                    robot: r.id,
                });
            }
        }
    }

    /// Counts a refused command; the first refusal per robot and reason becomes an event.
    pub fn reject(&mut self, robot: u32, reason: &'static str) {
        self.metrics.rejected += 1;
        if (robot as usize) < self.robots.len() && self.rejected_once.insert((robot, reason)) {
            tracing::warn!(robot, reason, tick = self.tick, "command rejected");
            self.events.push(Event::Rejected {
                tick: self.tick,
                robot,
                reason: reason.to_string(),
            });
        }
    }
}

/// Gaussian noise with standard deviation `sd`; draws nothing when `sd` is zero so a
/// noiseless run consumes no randomness.
fn gauss(rng: &mut Rng, sd: f64) -> f64 {
    if sd > 0.0 {
        Normal::new(0.0, sd).map(|d| d.sample(rng)).unwrap_or(0.0)
    } else {
        0.0
    }
}

/// Robots from which [`World::observe`] splits the robots over threads (below, a thread costs
/// more than it saves).
pub const PARALLEL_OBSERVE_MIN: usize = 64;
/// Most threads [`World::observe`] uses.
pub const OBSERVE_THREADS: usize = 4;

/// What one observation reads: shared by every robot of a tick.
struct ObserveCtx<'a> {
    robots: &'a [Robot],
    map: &'a Map,
    grid: &'a Grid,
    inboxes: &'a [Vec<Frame>],
    tick: u64,
    lidar: swarmrt_protocol::config::LidarConfig,
    rb_range: f64,
    radius: f64,
    reach: f64,
    noise: swarmrt_protocol::config::NoiseConfig,
    goal: swarmrt_protocol::config::Goal,
    goal_sensor: swarmrt_protocol::config::GoalSensorConfig,
}

impl ObserveCtx<'_> {
    /// Observes robots `first..first + out.len()`; `rngs` are their noise streams.
    fn observe_range(&self, first: usize, out: &mut [Observation], rngs: &mut [Rng]) {
        // Other robots within `reach`: (centre distance, id), nearest first.
        let mut near: Vec<(f64, u32)> = Vec::new();
        for (k, (o, rng)) in out.iter_mut().zip(rngs).enumerate() {
            self.observe_one(first + k, o, rng, &mut near);
        }
    }

    fn observe_one(
        &self,
        i: usize,
        o: &mut Observation,
        rng: &mut Rng,
        near: &mut Vec<(f64, u32)>,
    ) {
        let (lidar, rb_range, radius, reach) = (self.lidar, self.rb_range, self.radius, self.reach);
        let (noise, goal, goal_sensor) = (self.noise, self.goal, self.goal_sensor);
        let r = &self.robots[i];
        *o = Observation::empty(i as u32, self.tick);
        o.state = r.state as u8;
        o.reached = r.reached_tick.is_some() as u8;
        o.x = r.x + gauss(rng, noise.pose);
        o.y = r.y + gauss(rng, noise.pose);
        o.theta = wrap_angle(r.theta + gauss(rng, noise.heading));
        if r.state != RobotState::Active {
            return;
        }
        near.clear();
        self.grid.near((r.x, r.y), reach, |j| {
            if j != i {
                let q = &self.robots[j];
                let d = ((q.x - r.x).powi(2) + (q.y - r.y).powi(2)).sqrt();
                if d <= reach {
                    near.push((d, j as u32));
                }
            }
        });
        near.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        if r.lidar_on {
            let rays = (lidar.rays as usize).min(MAX_LIDAR_RAYS);
            // Other robots' bodies (in any state) are obstacles too. A ray stops looking once
            // a body's nearest point lies beyond its best hit.
            for k in 0..rays {
                let angle = r.theta + lidar.ray_angle(k);
                let dir = (angle.cos(), angle.sin());
                let mut d = self
                    .map
                    .cast((r.x, r.y), angle, lidar.range)
                    .unwrap_or(lidar.range);
                for &(dc, j) in near.iter() {
                    // Any hit on this body is at least dc - radius away (exact to far below
                    // the margin), so neither it nor a farther body can lower d; d is a
                    // minimum, so the order of the bodies does not change it.
                    if dc - radius > d + LIDAR_SKIP_MARGIN {
                        break;
                    }
                    let q = &self.robots[j as usize];
                    if let Some(t) = ray_circle((r.x, r.y), dir, (q.x, q.y), radius) {
                        d = d.min(t);
                    }
                }
                let d = (d + gauss(rng, noise.lidar)).clamp(0.0, lidar.range);
                o.lidar[k] = d;
            }
            o.lidar_len = rays as u16;
        }
        // Range-and-bearing: other robots with their emitter on, nearest first.
        let mut seen = 0;
        for &(d, j) in near.iter() {
            if seen == MAX_NEIGHBOURS || d > rb_range {
                break;
            }
            let q = &self.robots[j as usize];
            if q.state != RobotState::Active {
                continue;
            }
            o.neighbours[seen] = Neighbour {
                id: j,
                range: d,
                bearing: wrap_angle((q.y - r.y).atan2(q.x - r.x) - r.theta),
            };
            seen += 1;
        }
        o.neighbours_len = seen as u16;
        let gd = ((goal.x - r.x).powi(2) + (goal.y - r.y).powi(2)).sqrt();
        let gb = wrap_angle((goal.y - r.y).atan2(goal.x - r.x) - r.theta);
        if gd <= goal_sensor.range && gb.abs() <= goal_sensor.fov_deg.to_radians() / 2.0 {
            o.goal_visible = 1;
            o.goal_range = gd;
            o.goal_bearing = gb;
        }
        let inbox = &self.inboxes[i];
        for (slot, f) in inbox.iter().take(MAX_INBOX).enumerate() {
            o.inbox[slot] = *f;
        }
        o.inbox_len = inbox.len().min(MAX_INBOX) as u16;
    }
}

/// Metres a robot body's nearest point must lie beyond a ray's best hit before the ray stops
/// testing bodies (rounding in `ray_circle` is ~1e-15 m at these distances).
const LIDAR_SKIP_MARGIN: f64 = 1e-9;

/// Distance along the ray from `o` in unit direction `dir` (cos, sin of its angle) to the
/// circle (`c`, `r`), if it hits ahead.
fn ray_circle(o: (f64, f64), dir: (f64, f64), c: (f64, f64), r: f64) -> Option<f64> {
    let (dx, dy) = dir;
    let (fx, fy) = (o.0 - c.0, o.1 - c.1);
    let b = fx * dx + fy * dy;
    let cc = fx * fx + fy * fy - r * r;
    let disc = b * b - cc;
    if disc < 0.0 {
        return None;
    }
    let s = disc.sqrt();
    let t = -b - s;
    if t >= 0.0 {
        Some(t)
    } else if -b + s >= 0.0 {
        Some(0.0)
    } else {
        None
    }
}
