//! `libswarmrt`: what a robot controller written in C links to join a swarmrt run
//! (`swarm run cfg.toml --set 'robots.program=["/path/to/robot"]'`). The header is
//! `bindings/c/include/swarmrt.h`; the message structs it includes
//! (`swarmrt_messages.h`) are generated from the Rust types.
//!
//! The iceoryx2 side is the Rust robot's own code (`swarmrt_ipc`: the run's node
//! config, [`RobotPorts`](swarmrt_ipc::RobotPorts), hello) and its loop rules
//! ([`robot`]); the decisions are the C program's. A C robot is:
//!
//! ```c
//! swarmrt_robot_t *r = swarmrt_robot_open(err, sizeof err);   /* env, node, ports, hello */
//! while ((rc = swarmrt_robot_next(r, &obs)) == 1) {           /* 1 = answer this tick   */
//!     swarmrt_robot_act(&obs, &cmd);                          /* stopped, silent        */
//!     cmd.v = 0.3;
//!     swarmrt_robot_send(r, &cmd);
//! }
//! swarmrt_robot_close(r);
//! return swarmrt_exit_code(rc);                               /* 0 shutdown, 143 SIGTERM */
//! ```
//!
//! Map of the crate: [`robot`] (environment, node, ports, the wait loop), [`config`] (the
//! resolved config by dotted keys), [`frames`] (opaque frames and the go-to beacon without
//! postcard), [`ffi`] (the `extern "C"` functions: null checks, no panic crosses into C).
//! The same calls from Rust:
//!
//! ```
//! use swarmrt::config::Config;
//! use swarmrt::frames::{goto_beacon, push_goto_beacon};
//! use swarmrt_protocol::{BROADCAST, Command};
//!
//! let cfg = Config::parse("[map]\nbounds = [0.0, 0.0, 12.0, 12.0]\n").unwrap();
//! assert_eq!(cfg.f64("map.bounds[2]"), Ok(Some(12.0)));
//! assert_eq!(cfg.f64("map.goal.x"), Ok(None));
//!
//! let mut cmd = Command::act(3, 10);
//! push_goto_beacon(&mut cmd, BROADCAST, 1.0, 2.0, 0.5).unwrap();
//! assert_eq!(goto_beacon(&cmd.outbox[0]), Some((1.0, 2.0, 0.5)));
//! ```
#![warn(missing_docs)]

pub mod config;
pub mod error;
pub mod ffi;
pub mod frames;
pub mod robot;

pub use error::Error;
