//! A learning environment's world: the one lock-step tick ([`lockstep::begin`] and
//! [`lockstep::finish`]) with a policy answering between its halves, from outside the call.
//! A policy's robots are one more kind of robot ([`PolicyRobots`]): they observe what a
//! robot process observes ([`features`]) and answer what it would send ([`action`]), so the
//! same policy deployed as one process per robot writes the same records.

pub mod action;
pub mod features;

use swarmrt_protocol::{Command, Observation, RobotState, RoundInbox};
use swarmrt_scenario::Config;
use swarmrt_scenario::safe_fs::OutDir;
use swarmrt_world::lockstep::{self, Robots};
use swarmrt_world::map::MapError;
use swarmrt_world::records::Recorder;
use swarmrt_world::{Event, ProcessSignal, World};

pub use action::{Action, ActionError};
pub use features::{Features, Layout};

/// Reward for entering the goal radius, once (the built-in reward).
pub const REACHED_BONUS: f64 = 1.0;
/// Reward for a collision that takes the robot down (the built-in reward).
pub const COLLISION_PENALTY: f64 = -1.0;

/// The robots of an environment: they observe; their answers come from outside.
struct PolicyRobots {
    obs: Vec<Observation>,
}

impl Robots for PolicyRobots {
    type Error = std::convert::Infallible;

    /// A restarted robot's policy keeps no state the world knows of: nothing to carry out.
    fn carry_out(&mut self, _: &mut World, _: Vec<ProcessSignal>) -> Result<(), Self::Error> {
        Ok(())
    }

    /// Observes every robot; the answers are the policy's, filled in by [`Env::step`].
    fn answer(
        &mut self,
        world: &mut World,
        commands: &mut Vec<Option<Command>>,
    ) -> Result<(), Self::Error> {
        world.observe_on(&mut self.obs, 1);
        commands.clear();
        commands.resize(self.obs.len(), None);
        Ok(())
    }

    /// A policy answers once a tick: it does not react within a propagation round.
    fn react(
        &mut self,
        _: &mut World,
        _: &[RoundInbox],
        _: &mut [Option<Command>],
    ) -> Result<(), Self::Error> {
        Ok(())
    }
}

/// What one step did, per robot.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Outcome {
    /// The built-in reward: progress towards the robot's goal (m, by the world's truth),
    /// [`REACHED_BONUS`] on entering it, [`COLLISION_PENALTY`] on going down.
    pub rewards: Vec<f64>,
    /// Robots whose episode ended: down (a collision) or dead (a fault).
    pub terminated: Vec<bool>,
    /// True when the run ended (its ticks, or `scenario.stop_when_done`).
    pub truncated: bool,
    /// The world's events of the step, in order.
    pub events: Vec<Event>,
}

/// Why an environment could not be made or stepped.
#[derive(Debug, thiserror::Error)]
pub enum EnvError {
    /// The config's map does not build (the key and why).
    #[error("key `{}`: {}", .0.key, .0.message)]
    Map(MapError),
    /// An action was refused; nothing moved.
    #[error(transparent)]
    Action(#[from] ActionError),
    /// The records could not be written.
    #[error("cannot write the records: {0}")]
    Records(#[from] std::io::Error),
}

/// A world whose robots a policy drives, one tick per [`Env::step`].
pub struct Env {
    world: World,
    robots: PolicyRobots,
    commands: Vec<Option<Command>>,
    layout: Layout,
    recorder: Option<Recorder>,
    /// Each robot's distance to its goal at the last observation (the built-in reward).
    distance: Vec<f64>,
}

impl Env {
    /// `cfg`'s world at tick 0, observed; with `record`, its `trajectory.csv` and
    /// `events.jsonl` (and `radio.csv` when the config records it) written there as
    /// `swarm run` writes them.
    pub fn new(cfg: &Config, layout: Layout, record: Option<&OutDir>) -> Result<Env, EnvError> {
        let mut world =
            World::new(cfg, swarmrt_agent::registry::VOCABULARY).map_err(EnvError::Map)?;
        let n = cfg.robots.count as usize;
        let recorder = match record {
            Some(dir) => {
                world.set_radio_recording(cfg.scenario.record_radio);
                let mut r = Recorder::for_run(dir, cfg)?;
                let events = world.drain_events();
                r.record(world.tick(), world.robots(), &events)?;
                Some(r)
            }
            None => None,
        };
        let mut env = Env {
            world,
            robots: PolicyRobots {
                obs: vec![Observation::empty(0, 0); n],
            },
            commands: Vec::with_capacity(n),
            layout,
            recorder,
            distance: vec![0.0; n],
        };
        env.distance = env.distances();
        env.begin();
        Ok(env)
    }

    /// The world.
    pub fn world(&self) -> &World {
        &self.world
    }

    /// The layout of [`Env::features`].
    pub fn layout(&self) -> &Layout {
        &self.layout
    }

    /// Every robot's observation of the current tick.
    pub fn observations(&self) -> &[Observation] {
        &self.robots.obs
    }

    /// True for the robots that answer this tick (active or down: the world ignores a down
    /// robot's command, but a robot process still sends one).
    pub fn expects_action(&self, robot: usize) -> bool {
        RobotState::from_u8(self.robots.obs[robot].state).is_some_and(RobotState::expects_command)
    }

    /// Robot slots `at..` of `out` get every robot's view of the current tick.
    pub fn features_into(&self, out: &mut Features, at: usize) {
        let max = self.world.config().robots.lidar.range;
        for (i, o) in self.robots.obs.iter().enumerate() {
            out.fill(&self.layout, at + i, o, max);
        }
    }

    /// Checks every action first (nothing moves when one is refused), then applies the ones
    /// of the robots that answer this tick, steps the world, records the tick and observes the
    /// next one.
    pub fn step(&mut self, actions: &[Action]) -> Result<Outcome, EnvError> {
        let n = self.robots.obs.len();
        assert_eq!(actions.len(), n, "one action per robot");
        let cfg = self.world.config();
        for (r, a) in actions.iter().enumerate() {
            if self.expects_action(r) {
                a.check(cfg, r as u32, self.layout.payload)?;
            }
        }
        let tick = self.world.tick();
        for (r, a) in actions.iter().enumerate() {
            if self.expects_action(r) {
                self.commands[r] = Some(a.command(r as u32, tick));
            }
        }
        let Ok(_) = lockstep::finish(&mut self.world, &mut self.robots, &mut self.commands);
        let events = self.world.drain_events();
        if let Some(r) = &mut self.recorder {
            let radio = self.world.take_radio_rows();
            r.record_tick(self.world.tick(), self.world.robots(), &events, &radio)?;
        }
        let now = self.distances();
        let mut rewards: Vec<f64> = (self.distance.iter().zip(&now))
            .map(|(before, after)| before - after)
            .collect();
        self.distance = now;
        for e in &events {
            match e {
                Event::Reached { robot, .. } => rewards[*robot as usize] += REACHED_BONUS,
                Event::Collision { robot, .. } => rewards[*robot as usize] += COLLISION_PENALTY,
                _ => {}
            }
        }
        let terminated = (self.world.robots().iter())
            .map(|r| matches!(r.state, RobotState::Down | RobotState::Dead))
            .collect();
        let truncated = self.world.finished();
        if !truncated {
            self.begin();
        }
        Ok(Outcome {
            rewards,
            terminated,
            truncated,
            events,
        })
    }

    /// The first half of the tick: faults, then every robot's observation.
    fn begin(&mut self) {
        let Ok(_) = lockstep::begin(&mut self.world, &mut self.robots, &mut self.commands);
    }

    fn distances(&self) -> Vec<f64> {
        let cfg = self.world.config();
        (self.world.robots().iter())
            .map(|r| {
                let g = cfg.goal_of(r.id);
                (r.x - g.x).hypot(r.y - g.y)
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cfg(extra: &str) -> Config {
        let text = format!(
            "[scenario]\nname = \"env\"\nticks = 30\nseed = 4\n[map]\nbounds = [0.0, 0.0, 10.0, 10.0]\ngoal = {{ x = 8.0, y = 5.0, radius = 0.5 }}\n[robots]\ncount = 3\n{extra}"
        );
        swarmrt_agent::registry::from_toml_str("env.toml", &text, &[]).unwrap()
    }

    fn layout(cfg: &Config) -> Layout {
        Layout::new(cfg, 4, 2, 8).unwrap()
    }

    fn rollout(cfg: &Config) -> (Vec<Features>, Vec<Vec<f64>>) {
        let mut env = Env::new(cfg, layout(cfg), None).unwrap();
        let (mut seen, mut rewards) = (vec![], vec![]);
        loop {
            let mut f = Features::zeroed(env.layout(), 3);
            env.features_into(&mut f, 0);
            seen.push(f);
            let actions: Vec<Action> = (0..3)
                .map(|r| Action {
                    v: 0.2,
                    omega: 0.1 * r as f64,
                    say: vec![r as u8; r],
                })
                .collect();
            let out = env.step(&actions).unwrap();
            rewards.push(out.rewards);
            if out.truncated {
                return (seen, rewards);
            }
        }
    }

    #[test]
    fn the_same_seed_gives_the_same_views_and_rewards_and_the_run_ends_at_its_ticks() {
        let cfg = cfg("[radio]\nloss = 0.3\n");
        let (a, ra) = rollout(&cfg);
        let (b, rb) = rollout(&cfg);
        assert_eq!(a.len(), 30);
        assert_eq!(a, b);
        assert_eq!(ra, rb);
        assert!(
            ra.iter().flatten().any(|&r| r > 0.0),
            "robots moved towards the goal"
        );
    }

    #[test]
    fn a_policys_frames_cross_the_radio_to_the_others() {
        let cfg = cfg("");
        let (seen, _) = rollout(&cfg);
        let last = seen.last().unwrap();
        // Robot 0 hears robot 2's two bytes and robot 1's one (robot 0 says nothing).
        let heard: Vec<(i32, i32)> = (0..2)
            .filter(|&j| last.inbox_mask[j] == 1)
            .map(|j| (last.inbox_meta[j * 2], last.inbox_meta[j * 2 + 1]))
            .collect();
        assert_eq!(heard, vec![(1, 1), (2, 2)]);
    }

    #[test]
    fn an_action_past_a_limit_is_refused_with_the_robot_and_the_bound_and_nothing_moves() {
        let cfg = cfg("");
        let mut env = Env::new(&cfg, layout(&cfg), None).unwrap();
        let mut actions = vec![Action::default(); 3];
        actions[2].v = 9.0;
        let EnvError::Action(e) = env.step(&actions).unwrap_err() else {
            panic!("an action error")
        };
        assert_eq!(e.robot, 2);
        assert!(e.to_string().contains("v = 9 is out of range [-"), "{e}");
        actions[2].v = f64::NAN;
        assert!(
            env.step(&actions)
                .unwrap_err()
                .to_string()
                .contains("not a finite")
        );
        actions[2] = Action {
            say: vec![0; 9],
            ..Action::default()
        };
        assert!(
            env.step(&actions)
                .unwrap_err()
                .to_string()
                .contains("at most 8")
        );
        assert_eq!(env.world().tick(), 0, "refused steps step nothing");
    }
}
