//! What a behaviour is: a deterministic state machine fed the tick's observation and the
//! messages of its own kind, answering with wheel speeds, the lidar switch, radio messages and
//! notes. No I/O, no clock; randomness only from streams seeded by the run seed.
//!
//! A behaviour owns everything about itself in its folder under `behaviours/`: its parameters
//! (the `[behaviour]` keys, with their defaults and bounds), its radio message, its notes, its
//! core and the metrics computed from its records. `registry.rs` lists it once. What a viewer
//! draws of it (roles, headlines) is its [`crate::overlay::Overlay`] impl, in its folder's
//! `overlay.rs`.

use std::fmt::Debug;

use serde::Serialize;
use serde::de::DeserializeOwned;
use serde_json::Value;
use swarmrt_protocol::Observation;
use swarmrt_protocol::records::Records;
use swarmrt_scenario::reference::Key;
use swarmrt_scenario::{Config, KeyError};

use crate::consensus::{Decision, Leadership};
use crate::inbox::Heard;

/// A behaviour's `[behaviour]` parameters: a serde struct with `#[serde(default,
/// deny_unknown_fields)]` and one `impl Default`, checked against the whole config.
pub trait Params:
    Serialize + DeserializeOwned + Default + Debug + Clone + PartialEq + Send + Sync + 'static
{
    /// One row per `[behaviour]` key (`behaviour.<field>`): bounds, unit and meaning, for
    /// `docs/config.md` and for [`Params::validate`], which reads its constant bounds from it.
    const KEYS: &'static [Key];

    /// Checks every value against its bounds; the key is `behaviour.<field>`.
    fn validate(&self, cfg: &Config) -> Result<(), KeyError>;
}

/// What a behaviour decided this tick. Starts stopped, silent, lidar off.
#[derive(Debug, Clone, PartialEq)]
pub struct Act<M, N> {
    /// Forward speed in m/s.
    pub v: f64,
    /// Turn rate in rad/s.
    pub omega: f64,
    /// Lidar on for the next observation.
    pub lidar_on: bool,
    /// Aerial robots: the velocity `[east, north, up]` in m/s in the world frame (`v` and
    /// `omega` are for ground robots).
    pub velocity: [f64; 3],
    frames: Vec<(u32, M)>,
    /// Frames that travel within the tick (`radio.rounds`), sent before `frames`.
    in_tick: Vec<(u32, M)>,
    notes: Vec<N>,
    proposals: Vec<Decision>,
}

impl<M, N> Default for Act<M, N> {
    fn default() -> Self {
        Act {
            v: 0.0,
            omega: 0.0,
            lidar_on: false,
            velocity: [0.0; 3],
            frames: Vec::new(),
            in_tick: Vec::new(),
            notes: Vec::new(),
            proposals: Vec::new(),
        }
    }
}

impl<M, N> Act<M, N> {
    /// Sends `msg` to robot `dst` (or [`swarmrt_protocol::BROADCAST`]). Frames beyond the
    /// outbox are dropped, as the radio would.
    pub fn send(&mut self, dst: u32, msg: M) {
        self.frames.push((dst, msg));
    }

    /// With `radio.rounds` > 0, sends `msg` to `dst` within this tick: the receiver is woken
    /// to [`Behaviour::react`] before the world steps. Without rounds it is an ordinary frame
    /// (arriving with the next observation). In a reaction every frame travels within the
    /// tick, so there [`Act::send`] does the same.
    pub fn send_in_tick(&mut self, dst: u32, msg: M) {
        self.in_tick.push((dst, msg));
    }

    /// Reports `note` in the run record (`events.jsonl`).
    pub fn note(&mut self, note: N) {
        self.notes.push(note);
    }

    /// As Raft leader, proposes `decision` for the replicated log. Proposals beyond this
    /// tick's note budget, or made by a robot that is not leader, are dropped: the behaviour
    /// learns which ones were appended from the decisions applied later.
    pub fn propose(&mut self, decision: Decision) {
        self.proposals.push(decision);
    }

    /// Clears it for the next tick, keeping the buffers.
    pub fn reset(&mut self) {
        self.v = 0.0;
        self.omega = 0.0;
        self.lidar_on = false;
        self.velocity = [0.0; 3];
        self.frames.clear();
        self.in_tick.clear();
        self.notes.clear();
        self.proposals.clear();
    }

    /// The decisions proposed this tick.
    pub fn proposals(&self) -> &[Decision] {
        &self.proposals
    }

    /// The messages to send, in order (those within the tick first), how many of them
    /// travel within the tick, and the notes.
    pub fn drain(&mut self) -> (Vec<(u32, M)>, usize, std::vec::Drain<'_, N>) {
        let in_tick = self.in_tick.len();
        let mut frames = std::mem::take(&mut self.in_tick);
        frames.append(&mut self.frames);
        (frames, in_tick, self.notes.drain(..))
    }
}

/// A robot behaviour.
pub trait Behaviour: Send + Sized + 'static {
    /// The name in `behaviour.kind`.
    const KIND: &'static str;
    /// Its `[behaviour]` parameters.
    type Params: Params;
    /// What it says over the radio (postcard-encoded into frames).
    type Msg: Serialize + DeserializeOwned + Debug + Clone + PartialEq + Send + Sync + 'static;
    /// What it reports about itself (rendered as JSON in `events.jsonl`).
    type Note: Serialize + DeserializeOwned + Debug + Clone + PartialEq + Send + Sync + 'static;
    /// Names of the metrics [`Behaviour::metrics`] computes.
    const METRICS: &'static [&'static str] = &[];
    /// False when `step` and `react` never read their inbox: the agent then does not decode
    /// the frames it would throw away (a tenth of a goto robot's turn in a crowd that
    /// beacons), so frames that do not decode are not counted either.
    const LISTENS: bool = true;

    /// Robot `id`'s behaviour for this scenario.
    fn new(cfg: &Config, params: &Self::Params, id: u32) -> Self;

    /// This tick's decision. `inbox` holds this tick's messages of this behaviour's kind.
    fn step(
        &mut self,
        obs: &Observation,
        inbox: &[Heard<Self::Msg>],
        act: &mut Act<Self::Msg, Self::Note>,
    );

    /// A propagation round within this tick (`radio.rounds` > 0): `round` holds the frames
    /// of this behaviour's kind that reached it in the round (sent with
    /// [`Act::send_in_tick`] or from another reaction). `act` starts as this tick's decision
    /// so far (its motion, no frames): change the motion, and send frames to pass the change
    /// on within the tick. The default reacts to nothing.
    fn react(
        &mut self,
        _obs: &Observation,
        _round: &[Heard<Self::Msg>],
        _act: &mut Act<Self::Msg, Self::Note>,
    ) {
    }

    /// Acts on a swarm decision the consensus layer committed and applied. Called before
    /// `step` in the tick it was applied; behaviours that have no use for it ignore it.
    fn apply(&mut self, _decision: &Decision) {}

    /// What this robot knows of the election this tick (Raft scenarios only), before `step`.
    fn lead(&mut self, _leadership: &Leadership) {}

    /// Its own metrics, computed after the run from the records alone (so both modes give
    /// the same numbers): `(name, value)` for each name in [`Behaviour::METRICS`].
    fn metrics(
        _cfg: &Config,
        _params: &Self::Params,
        _run: &Records,
    ) -> Vec<(&'static str, Value)> {
        Vec::new()
    }

    /// Its per-tick tables, computed after the run from the records alone: each is written
    /// as `<name>.csv` in the run directory and drawn as its plots.
    fn series(_cfg: &Config, _params: &Self::Params, _run: &Records) -> Vec<Series> {
        Vec::new()
    }
}

/// A per-tick table a behaviour derives from the records (`<name>.csv` in the run
/// directory), with the line plots to draw from it.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// File stem of the CSV.
    pub name: &'static str,
    /// Column names, the CSV header.
    pub columns: Vec<&'static str>,
    /// One row per line of the CSV, `columns.len()` values each.
    pub rows: Vec<Vec<f64>>,
    /// Plots drawn from the table.
    pub plots: Vec<SeriesPlot>,
}

/// A line plot of some columns of a [`Series`] against another.
#[derive(Debug, Clone, PartialEq)]
pub struct SeriesPlot {
    /// File stem (`<file>.svg` and `<file>.png`).
    pub file: &'static str,
    /// Caption.
    pub title: String,
    /// The x column.
    pub x: &'static str,
    /// One line per column named here ...
    pub lines: Vec<&'static str>,
    /// ... and per distinct value of this column (e.g. one line per flock).
    pub group_by: Option<&'static str>,
    /// Label of the y axis.
    pub y_label: &'static str,
}

/// The empty note type, for behaviours that report nothing.
#[derive(Debug, Clone, PartialEq, Serialize, serde::Deserialize)]
pub enum NoNote {}
