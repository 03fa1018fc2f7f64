//! The world core: a deterministic state machine. `observe` fills every robot's
//! [`Observation`](swarmrt_protocol::Observation) for the current tick, `step` takes every
//! robot's [`Command`] and advances one tick. No I/O, no clock (unless the shell switches on
//! [`StageTimes`]); every random draw comes from the run seed.
//!
//! [`World::step`] is a short sequence of stages over the world's state, each in a sibling
//! file (like rapier's `physics_pipeline/`):
//!
//! 1. `commands.rs`: accept or refuse each command; its notes become events.
//! 2. `route.rs`: route the frames sent at this tick through the [`RadioMedium`].
//! 3. `kinematics.rs`: integrate the unicycles, with swept obstacle checks.
//! 4. `contacts.rs`: robot-robot contacts knock both robots down.
//! 5. The tick advances; `route.rs` delivers the frames now due and `sensing.rs` checks who
//!    reached the goal.
//! 6. `faults.rs`: the faults of the new tick boundary.
//!
//! Before `step`, with `radio.rounds`, the shells run the tick's propagation rounds
//! (`rounds.rs`): frames sent within the tick wake their receivers, whose reactions replace
//! their motion for the tick.
//!
//! `sensing.rs` also builds the observations ([`World::observe`]); `stage_times.rs` adds up
//! the wall-clock time of each stage when the shell asks for it.

use serde::{Deserialize, Serialize};
use std::collections::BTreeSet;
use swarmrt_protocol::records;
use swarmrt_protocol::{Command, NoteJson, RobotState, Vocabulary};
use swarmrt_scenario::Config;
pub use swarmrt_scenario::wrap_angle;

use crate::map::{Map, MapError};
use crate::radio::{RadioMedium, RadioStats};
use crate::rng::{self, Rng};

mod commands;
mod contacts;
mod faults;
mod kinematics;
mod rounds;
mod route;
mod sensing;
mod stage_times;
mod stall;

use faults::Outage;
pub use faults::ProcessSignal;
pub use rounds::RoundStats;
use rounds::Rounds;
pub use sensing::{OBSERVE_CHUNK, OBSERVE_THREADS, PARALLEL_OBSERVE_MIN, worker_threads};
pub use stage_times::{Stage, StageTimes};
use stall::StallWatch;
pub use stall::Stalled;

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
    /// True height, metres (0 for ground robots).
    pub z: f64,
    /// Forward speed applied in the last step (an aerial robot's horizontal speed).
    pub v: f64,
    /// Vertical speed applied in the last step (aerial robots).
    pub vz: f64,
    /// Turn rate applied in the last step.
    pub omega: f64,
    /// Whether the lidar is on for the current observation.
    pub lidar_on: bool,
    /// Lifecycle state.
    pub state: RobotState,
    /// First tick at which the robot was inside the goal radius.
    pub reached_tick: Option<u64>,
}

/// Something worth a line in `events.jsonl`, with notes as the robots' vocabulary renders
/// them (the schema is [`swarmrt_protocol::records::Event`]).
pub type Event = records::Event<NoteJson>;

/// Scalar outcome of a run so far (read back from a world process's report, too).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
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
    /// Why the run ended early with robots short of their goal (`scenario.stall_ticks`);
    /// absent otherwise.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stalled: Option<Stalled>,
    /// What the in-tick propagation rounds did (`radio.rounds` > 0 only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rounds: Option<RoundStats>,
}

/// The world of one run.
pub struct World {
    cfg: Config,
    /// What the robots may say: checks radio payloads, renders notes for the record.
    vocabulary: Vocabulary,
    map: Map,
    robots: Vec<Robot>,
    radio: RadioMedium,
    tick: u64,
    sensor_rng: Vec<Rng>,
    /// Per robot, draws of `robots.noise.wheel_slip` (none when it is zero).
    slip_rng: Vec<Rng>,
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
    /// Wall-clock time per stage, while the shell has timing on.
    stage_times: StageTimes,
    /// Where each robot last moved, for `scenario.stall_ticks`.
    stall: StallWatch,
    /// In-tick propagation rounds (`radio.rounds` > 0).
    rounds: Option<Rounds>,
}

impl World {
    /// Builds the world at tick 0 with every robot at its start position. `vocabulary` is
    /// the robots' (`swarmrt_agent::registry::VOCABULARY`), or [`Vocabulary::ANY`] for a world
    /// driven without robots.
    pub fn new(cfg: &Config, vocabulary: Vocabulary) -> Result<World, MapError> {
        let map = Map::build(&cfg.map)?;
        let seed = cfg.scenario.seed;
        let radius = cfg.robots.radius;
        let starts = cfg
            .start_poses(|x, y| map.clearance((x, y)) >= radius * 1.5)
            .ok_or_else(|| MapError {
                key: "robots.start".to_string(),
                message: format!(
                    "expected room for {} robots {} m apart near {}, inside map.bounds and clear of obstacles; \
                     the map has less (lower robots.count or robots.start.spacing, or move robots.start)",
                    cfg.robots.count,
                    cfg.robots.start.spacing,
                    start_centres(cfg)
                ),
            })?;
        let robots: Vec<Robot> = starts
            .into_iter()
            .enumerate()
            .map(|(i, (x, y, theta))| Robot {
                id: i as u32,
                x,
                y,
                theta,
                z: cfg.start_z(i as u32),
                v: 0.0,
                vz: 0.0,
                omega: 0.0,
                lidar_on: true,
                state: RobotState::Active,
                reached_tick: None,
            })
            .collect();
        let n = robots.len();
        let mut world = World {
            cfg: cfg.clone(),
            vocabulary,
            map,
            radio: RadioMedium::new(cfg.radio, seed, n),
            tick: 0,
            sensor_rng: (0..n)
                .map(|i| rng::stream(seed, "sensor", i as u64))
                .collect(),
            slip_rng: (0..n)
                .map(|i| rng::stream(seed, "wheel_slip", i as u64))
                .collect(),
            events: Vec::new(),
            rejected_once: BTreeSet::new(),
            metrics: WorldMetrics::default(),
            leader: None,
            signals: Vec::new(),
            outages: vec![None; n],
            incarnations: vec![0; n],
            fault_rng: rng::stream(seed, "faults", 0),
            stage_times: StageTimes::default(),
            stall: StallWatch::default(),
            rounds: (cfg.radio.rounds > 0).then(|| Rounds::new(cfg.radio.rounds, seed)),
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
        m.rounds = self.rounds.as_ref().map(Rounds::stats);
        m
    }

    /// Takes the events produced since the last call, in the order they happened.
    pub fn drain_events(&mut self) -> Vec<Event> {
        std::mem::take(&mut self.events)
    }

    /// True when the run should end: the tick budget is spent, or (with
    /// `scenario.stop_when_done`) every robot reached the goal or is down or dead, or the run
    /// stalled ([`WorldMetrics::stalled`]).
    pub fn finished(&self) -> bool {
        self.tick >= self.cfg.scenario.ticks
            || self.metrics.stalled.is_some()
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

    /// Advances one tick. `commands[i]` is robot i's answer to this tick's observation, or
    /// `None` if it sent none (dead, or a shell that gave up waiting). Invalid commands are
    /// refused, counted and treated as "stop, send nothing".
    pub fn step(&mut self, commands: &[Option<Command>]) {
        assert_eq!(
            commands.len(),
            self.robots.len(),
            "one command slot per robot"
        );
        let accepted = self.timed(Stage::Commands, |w| w.accept_commands(commands));
        self.timed(Stage::Radio, |w| w.route_radio(&accepted));
        self.timed(Stage::Kinematics, |w| w.integrate(&accepted));
        self.timed(Stage::Contacts, |w| w.robot_contacts());
        self.tick += 1;
        self.metrics.ticks = self.tick;
        self.timed(Stage::Radio, |w| w.deliver_radio());
        self.timed(Stage::Sensing, |w| w.check_goal());
        self.timed(Stage::Faults, |w| w.apply_faults());
        self.check_stall();
    }

    /// Switches the radio record on or off (off when the world is built; the shells switch it
    /// on before the first step when `scenario.record_radio` is set): while on, the medium
    /// keeps a [`RadioRow`](swarmrt_protocol::records::RadioRow) per decided copy for
    /// [`World::take_radio_rows`]. Nothing else a run does changes.
    pub fn set_radio_recording(&mut self, on: bool) {
        self.radio.set_recording(on);
    }

    /// The `radio.csv` rows of the copies decided since the last call, in the order the medium
    /// decided them (empty while the radio record is off).
    pub fn take_radio_rows(&mut self) -> Vec<records::RadioRow> {
        self.radio.take_log()
    }

    /// Switches the per-stage timers on or off (off when the world is built: the core reads
    /// no clock unless the shell asks). Switching keeps the times so far.
    pub fn set_stage_timing(&mut self, on: bool) {
        self.stage_times.set_enabled(on);
    }

    /// Wall-clock time spent in each stage since timing was switched on or last taken.
    pub fn stage_times(&self) -> StageTimes {
        self.stage_times
    }

    /// [`World::stage_times`], then starts counting from zero again (timing stays as it was).
    pub fn take_stage_times(&mut self) -> StageTimes {
        let times = self.stage_times;
        self.stage_times.clear();
        times
    }

    /// Runs one stage, adding its wall-clock time to `stage` when timing is on.
    fn timed<R>(&mut self, stage: Stage, f: impl FnOnce(&mut Self) -> R) -> R {
        let start = self.stage_times.start();
        let out = f(self);
        self.stage_times.stop(stage, start);
        out
    }
}

/// The start grid centres for an error message: `(x, y)` or each group's.
fn start_centres(cfg: &Config) -> String {
    let s = &cfg.robots.start;
    if s.groups.is_empty() {
        format!("({}, {})", s.x.unwrap_or(0.0), s.y.unwrap_or(0.0))
    } else {
        s.groups
            .iter()
            .map(|g| format!("({}, {})", g.x, g.y))
            .collect::<Vec<_>>()
            .join(", ")
    }
}
