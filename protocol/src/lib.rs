//! The bytes swarmrt processes exchange, and nothing else: the shared-memory messages
//! (`Observation`, `Command`), the framing of radio payloads and notes inside them, the
//! orchestrator <-> world control lines, iceoryx2 service names and the port-opening and hello
//! helpers every process uses. Dependency-light (no TOML, no log subscriber), so a robot in
//! another language or a bridge to another host can follow it; `docs/architecture.md` lists
//! the byte layout.
//!
//! A tick in lock-step mode, seen from this crate:
//!
//! ```
//! use swarmrt_protocol::{BROADCAST, Command, Observation, PROTOCOL_VERSION};
//!
//! // The world fills one Observation per robot ...
//! let obs = Observation::empty(3, 0);
//! assert_eq!(obs.version, PROTOCOL_VERSION);
//! // ... the robot answers with a Command carrying velocities and radio frames, whose
//! // payloads are postcard-encoded messages of the robots' own vocabulary.
//! let mut cmd = Command::act(3, obs.tick);
//! cmd.v = 0.5;
//! cmd.push_frame(BROADCAST, &(1.0f64, 2.0f64)).unwrap();
//! assert_eq!(cmd.outbox().len(), 1);
//! ```
#![warn(missing_docs)]

pub mod control;
pub mod layout;
pub mod messages;
pub mod records;
pub mod services;
pub mod vocabulary;

pub use messages::*;
pub use vocabulary::{NoteJson, RecordedNote, Vocabulary};
