//! A robot: fed one [`Observation`] per tick, answers one [`Command`]. The core ([`Agent`])
//! is pure: no I/O, no clock; its randomness comes from the run seed and the robot id. The
//! process shell (`shell`) only moves observations and commands through iceoryx2.
//!
//! Where things are: [`behaviours`] (one folder per behaviour, listed once in [`registry`]),
//! [`consensus`] (election, replicated log, quadrant leader choice), [`inbox`] (a decoded
//! radio message), [`agent`] (one robot's tick), [`overlay`] (what a viewer draws of each
//! behaviour: roles, headlines, consensus lanes), [`wire`] (the envelopes' fixed wire tags).
//!
//! ```
//! use swarmrt_agent::{Agent, registry};
//! use swarmrt_protocol::Observation;
//!
//! let cfg = registry::from_toml_str("doc.toml", r#"
//!     [scenario]
//!     name = "doc"
//!     ticks = 5
//!     [map]
//!     bounds = [0.0, 0.0, 10.0, 10.0]
//!     goal = { x = 8.0, y = 2.0, radius = 1.0 }
//!     [robots]
//!     count = 1
//! "#, &[]).unwrap();
//! assert_eq!(cfg.behaviour.params["speed"].as_float(), Some(0.5), "goto's default, resolved");
//! let mut agent = Agent::new(&cfg, 0);
//! let mut obs = Observation::empty(0, 0);
//! obs.x = 2.0;
//! obs.y = 2.0;
//! let step = agent.step(&obs);
//! assert!(step.persist().is_none(), "no `[consensus]`: nothing to make durable");
//! let cmd = step.without_storage();
//! assert!(cmd.v > 0.0, "the goal is straight ahead");
//! ```
#![warn(missing_docs)]

pub mod agent;
pub mod behaviour;
pub mod behaviours;
pub mod consensus;
pub mod inbox;
pub mod overlay;
pub mod registry;
pub mod wire;

pub use agent::{Agent, Step};
pub use registry::{Note, RadioMsg};
pub use swarmrt_protocol::{Command, Observation};
