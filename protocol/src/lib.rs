//! The contracts shared by every swarmrt process: shared-memory messages, radio payloads,
//! iceoryx2 service names and the scenario config.
//!
//! A tick in lock-step mode, seen from this crate:
//!
//! ```
//! use swarmrt_protocol::{Command, Observation, RadioMsg, PROTOCOL_VERSION};
//!
//! // The world fills one Observation per robot ...
//! let mut obs = Observation::empty(3, 0);
//! assert_eq!(obs.version, PROTOCOL_VERSION);
//! // ... the robot answers with a Command carrying velocities and radio frames.
//! let mut cmd = Command::act(3, 0);
//! cmd.v = 0.5;
//! cmd.push_frame(swarmrt_protocol::BROADCAST, &RadioMsg::Beacon { x: 1.0, y: 2.0, theta: 0.0 })
//!     .unwrap();
//! assert_eq!(cmd.outbox().len(), 1);
//! # obs.tick = 1;
//! ```
#![warn(missing_docs)]

pub mod child;
pub mod config;
pub mod consensus;
pub mod control;
pub mod faults;
pub mod ipc;
pub mod logging;
pub mod messages;
pub mod radio_msg;
pub mod report;
pub mod rng;
pub mod services;

pub use messages::*;
pub use radio_msg::RadioMsg;
pub use report::{MAX_REPORT, Note};
