//! What a run is made from: the scenario config (schema, defaults written once, `--set`
//! overrides, bounds checks with errors that name the file, the key and the bounds), the start
//! layout, the seeded random streams every core draws from, and the bootstrap of a child
//! process. No wire format lives here (that is `swarmrt_protocol`), and the `[behaviour]`
//! parameters stay opaque: the behaviour that owns them checks them.
//!
//! ```
//! use swarmrt_scenario::Config;
//!
//! let cfg = Config::from_toml_str("doc.toml", r#"
//!     [scenario]
//!     name = "doc"
//!     ticks = 5
//!     [map]
//!     bounds = [0.0, 0.0, 10.0, 10.0]
//!     goal = { x = 8.0, y = 2.0, radius = 1.0 }
//!     [robots]
//!     count = 4
//! "#, &["radio.loss=0.2".to_string()]).unwrap();
//! assert_eq!(cfg.radio.loss, 0.2);
//! assert_eq!(cfg.start_positions(|_, _| true).unwrap().len(), 4);
//! let err = Config::from_toml_str("doc.toml", &cfg.to_toml(), &["radio.loss=2".into()]);
//! assert_eq!(err.unwrap_err().key, "radio.loss");
//! ```
#![warn(missing_docs)]

pub mod angle;
pub mod behaviour;
pub mod bounds;
pub mod config;
pub mod consensus;
pub mod error;
pub mod faults;
pub mod hull;
pub mod input;
pub mod layout;
pub mod limits;
pub mod overrides;
pub mod process;
pub mod program;
pub mod programs;
pub mod reference;
pub mod rng;
pub mod safe_fs;
pub mod validate;

pub use angle::wrap_angle;
pub use behaviour::BehaviourSection;
pub use config::*;
pub use error::{ConfigError, KeyError};
