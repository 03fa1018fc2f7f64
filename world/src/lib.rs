//! The world: owns the truth of a run (DESIGN sections 2-5).
//!
//! The core ([`World`]) is a deterministic state machine with no I/O dependency: no iceoryx2,
//! no Zenoh, no clap. Its process shell (`swarm-world`) is `swarmrt_runtime::world`, which only
//! moves its observations and commands through iceoryx2.
//!
//! [`World::step`] (`world/mod.rs`) calls one stage per sibling file: `commands.rs`,
//! `route.rs` (radio), `kinematics.rs`, `contacts.rs`, `sensing.rs` ([`World::observe`], goal
//! check) and `faults.rs`; `stage_times.rs` times them when the shell asks. [`lockstep`] is the
//! one tick every shell drives: faults, answers, propagation rounds, step.
//!
//! ```
//! use swarmrt_protocol::{Command, Observation, Vocabulary};
//! use swarmrt_scenario::Config;
//! use swarmrt_world::World;
//!
//! let cfg = Config::from_toml_str("doc.toml", r#"
//!     [scenario]
//!     name = "doc"
//!     ticks = 5
//!     [map]
//!     bounds = [0.0, 0.0, 10.0, 10.0]
//!     goal = { x = 8.0, y = 8.0, radius = 1.0 }
//!     [robots]
//!     count = 2
//! "#, &[]).unwrap();
//! let mut world = World::new(&cfg, Vocabulary::ANY).unwrap();
//! let mut obs = vec![Observation::empty(0, 0); 2];
//! while !world.finished() {
//!     world.observe(&mut obs);
//!     let cmds: Vec<_> = obs.iter().map(|o| {
//!         let mut c = Command::act(o.robot, o.tick);
//!         c.v = 0.5;
//!         Some(c)
//!     }).collect();
//!     world.step(&cmds);
//! }
//! assert_eq!(world.tick(), 5);
//! assert!(world.robots()[0].x > 1.6);
//! ```
#![warn(missing_docs)]

pub mod grid;
pub mod lockstep;
pub mod map;
pub mod radio;
pub mod records;
pub mod rng;
pub mod world;

pub use world::{
    Event, ProcessSignal, Robot, RoundStats, Stage, StageTimes, Stalled, World, WorldMetrics,
};
