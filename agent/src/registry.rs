//! The behaviour registry's machinery. The list itself is one `behaviours!` call in
//! `behaviours/mod.rs`: adding a behaviour is a new folder there and one line in that call,
//! which declares the module, gives the behaviour its slot in the radio and note envelopes
//! ([`RadioMsg`], [`Note`]), makes its `kind` loadable from a config, and its metrics
//! computable from the records.
//!
//! The envelopes are postcard-encoded enums, one variant per behaviour (in line order), then
//! the consensus layer's, each written with the wire tag its line declares ([`crate::wire`]),
//! not its index: the world checks that a frame decodes as a [`RadioMsg`] and records each
//! [`Note`] as JSON, through [`VOCABULARY`].

use std::marker::PhantomData;

use serde::{Deserialize as _, Serialize};
use serde_json::Value;
use swarmrt_protocol::records::Records;
use swarmrt_protocol::{NoteJson, Observation, RecordedNote, Vocabulary};
use swarmrt_scenario::reference::Schema;
use swarmrt_scenario::{BehaviourSection, Config, ConfigError, KeyError};

use crate::behaviour::{Act, Behaviour, Params, Series};
pub use crate::behaviours::{BEHAVIOURS, Note, RadioMsg};
use crate::consensus::{ConsensusNote, Decision, Leadership};
use crate::inbox::Heard;
use crate::overlay::{Headline, LaneChange, Overlay, RoleDef, lane};
pub use crate::wire::WireTag;

/// Connects a behaviour to its variants of the envelopes (written by `behaviours!`); every
/// behaviour also has its viewer [`Overlay`].
pub trait Enveloped: Behaviour + Overlay {
    /// `msg` inside the radio envelope.
    fn wrap_msg(msg: Self::Msg) -> RadioMsg;
    /// The behaviour's own message, if `msg` is one.
    fn unwrap_msg(msg: RadioMsg) -> Option<Self::Msg>;
    /// `note` inside the note envelope.
    fn wrap_note(note: Self::Note) -> Note;
    /// The behaviour's own note, if `note` is one.
    fn note_of(note: &Note) -> Option<&Self::Note>;
}

/// One behaviour of the registry with its types erased.
pub trait Plugin: Sync {
    /// `behaviour.kind`.
    fn kind(&self) -> &'static str;
    /// Parses, defaults and validates the `[behaviour]` parameters; returns them resolved
    /// (every key present, in declaration order).
    fn resolve(&self, params: &toml::Table, cfg: &Config) -> Result<toml::Table, KeyError>;
    /// The behaviour configured for `cfg`: its `[behaviour]` parameters parsed once, for
    /// everything that needs them. `Err` (the key and why) when they do not parse.
    fn configure(&self, cfg: &Config) -> Result<Box<dyn Configured>, KeyError>;
    /// Every `[behaviour]` key with its default, as `behaviour.<key>`.
    fn keys(&self) -> Vec<String>;
    /// Its parameters for the config reference (`docs/config.md`): their table and schema.
    fn reference(&self) -> Schema;
    /// Names of the metrics it computes from the records.
    fn metric_names(&self) -> &'static [&'static str];
    /// The roles a viewer colours its robots by ([`crate::overlay`]); roles are indices.
    fn roles(&self) -> &'static [RoleDef];
    /// A recorded note, the `note` field of an `events.jsonl` line (a behaviour's note as
    /// itself, e.g. `{"veto":{...}}`; a consensus note as `{"consensus":{...}}`), decoded
    /// once into the typed envelope; `None` for anything this behaviour and the consensus
    /// layer never wrote.
    fn read_note(&self, note: &Value) -> Option<Note>;
    /// `note` as a headline of the event timeline: the behaviour's notable notes, and the
    /// consensus layer's (elections, quadrant leaders, [`crate::overlay::lane::headline`]).
    fn headline(&self, note: &Note) -> Option<Headline>;
    /// How `note` changes the reporter's consensus lane: the consensus layer's notes
    /// ([`crate::overlay::lane::lane_change`]) and the behaviour's own leader choice
    /// (grouping's `leader` note).
    fn lane(&self, note: &Note) -> Option<LaneChange>;
}

/// A behaviour configured for one run, its types erased: its parameters were parsed once,
/// when it was built ([`Plugin::configure`]).
pub trait Configured: Send + Sync {
    /// Robot `id`'s brain.
    fn brain(&self, id: u32) -> Box<dyn Brain>;
    /// Its metrics for a finished run.
    fn metrics(&self, run: &Records) -> Vec<(&'static str, Value)>;
    /// Its per-tick tables for a finished run.
    fn series(&self, run: &Records) -> Vec<Series>;
    /// Robot `id`'s role at the start of the run.
    fn initial_role(&self, id: u32) -> Option<u8>;
    /// Robot `id`'s role after it reported `note`; `None`: unchanged, and for consensus
    /// notes and notes that are not this behaviour's.
    fn role_after(&self, id: u32, note: &Note) -> Option<u8>;
}

/// A behaviour driven for one robot, its types erased: the agent hands it the tick's
/// decoded radio messages and committed decisions, it answers with a [`Decided`], from which
/// the agent composes the command.
pub trait Brain: Send {
    /// [`Behaviour::LISTENS`] of the behaviour inside.
    fn listens(&self) -> bool;

    /// One tick; messages of other kinds are ignored. `out` comes cleared.
    fn step(&mut self, tick: Tick<'_>, out: &mut Decided);

    /// A propagation round within the tick of `obs`: the behaviour starts from the tick's
    /// `motion` so far, may change it and send frames (all within the tick). `out` comes
    /// cleared.
    fn react(
        &mut self,
        obs: &Observation,
        heard: &mut Vec<Heard<RadioMsg>>,
        motion: Motion,
        out: &mut Decided,
    );
}

/// What a [`Brain`] is given for one tick.
pub struct Tick<'a> {
    /// This tick's observation.
    pub obs: &'a Observation,
    /// This tick's decoded radio messages (the brain takes its own kind).
    pub heard: &'a mut Vec<Heard<RadioMsg>>,
    /// Decisions committed and applied this tick.
    pub decisions: &'a [Decision],
    /// The election as this robot knows it (Raft scenarios).
    pub leadership: Option<Leadership>,
}

/// The motion fields of a command: what a behaviour decides and a reaction starts from.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Motion {
    /// Forward speed in m/s.
    pub v: f64,
    /// Turn rate in rad/s.
    pub omega: f64,
    /// Aerial robots: `[east, north, up]` in m/s.
    pub velocity: [f64; 3],
    /// Lidar on for the next observation.
    pub lidar_on: bool,
}

/// What a [`Brain`] decided, in the envelopes: the agent writes it into the command.
#[derive(Debug, Clone, Default)]
pub struct Decided {
    /// Wheel speeds (or velocity) and the lidar switch.
    pub motion: Motion,
    /// `(destination, message)` in sending order, those within the tick first.
    pub frames: Vec<(u32, RadioMsg)>,
    /// How many of `frames` travel within the tick.
    pub in_tick: usize,
    /// Its notes for the record.
    pub notes: Vec<Note>,
    /// Its proposals for the replicated log.
    pub proposals: Vec<Decision>,
}

impl Decided {
    /// Empties it for the next tick, keeping the buffers.
    pub fn clear(&mut self) {
        self.motion = Motion::default();
        self.frames.clear();
        self.in_tick = 0;
        self.notes.clear();
        self.proposals.clear();
    }
}

/// A behaviour as a registry entry (its types erased behind [`Plugin`]).
pub struct Entry<B>(pub PhantomData<fn() -> B>);

fn parse<B: Behaviour>(params: &toml::Table) -> Result<B::Params, KeyError> {
    serde_path_to_error::deserialize::<_, B::Params>(toml::Value::Table(params.clone())).map_err(
        |e| {
            let path = e.path().to_string();
            let key = if path.is_empty() || path == "." {
                "behaviour".to_string()
            } else {
                format!("behaviour.{}", path.trim_start_matches('.'))
            };
            (
                key,
                swarmrt_scenario::error::one_line(&e.inner().to_string()),
            )
        },
    )
}

/// `{ behaviour = params }` parsed with defaults filled in and written again (no bounds
/// checks), for the config reference.
fn round_trip<B: Behaviour>(t: &toml::Table) -> Result<toml::Table, KeyError> {
    let params = t
        .get("behaviour")
        .and_then(toml::Value::as_table)
        .cloned()
        .unwrap_or_default();
    let p = parse::<B>(&params)?;
    let p = toml::Table::try_from(&p).expect("parameters always serialize");
    Ok(toml::Table::from_iter([(
        "behaviour".to_string(),
        toml::Value::Table(p),
    )]))
}

impl<B: Enveloped> Plugin for Entry<B> {
    fn kind(&self) -> &'static str {
        B::KIND
    }

    fn resolve(&self, params: &toml::Table, cfg: &Config) -> Result<toml::Table, KeyError> {
        let p = parse::<B>(params)?;
        p.validate(cfg)?;
        Ok(toml::Table::try_from(&p).expect("parameters always serialize"))
    }

    fn configure(&self, cfg: &Config) -> Result<Box<dyn Configured>, KeyError> {
        Ok(Box::new(ConfiguredAs::<B> {
            params: parse::<B>(&cfg.behaviour.params)?,
            cfg: cfg.clone(),
        }))
    }

    fn keys(&self) -> Vec<String> {
        toml::Table::try_from(B::Params::default())
            .expect("parameters always serialize")
            .keys()
            .map(|k| format!("behaviour.{k}"))
            .collect()
    }

    fn reference(&self) -> Schema {
        let defaults =
            toml::Table::try_from(B::Params::default()).expect("parameters always serialize");
        Schema {
            keys: B::Params::KEYS,
            full: toml::Table::from_iter([("behaviour".to_string(), toml::Value::Table(defaults))]),
            round_trip: round_trip::<B>,
            // Only `behaviour` is read; the root is not this schema's.
            open: &[""],
        }
    }

    fn metric_names(&self) -> &'static [&'static str] {
        B::METRICS
    }

    fn roles(&self) -> &'static [RoleDef] {
        B::ROLES
    }

    fn read_note(&self, note: &Value) -> Option<Note> {
        match lane::from_json(note) {
            Some(c) => Some(Note::Consensus(c)),
            None => behaviour_note::<B>(note).map(B::wrap_note),
        }
    }

    fn headline(&self, note: &Note) -> Option<Headline> {
        match note {
            Note::Consensus(c) => lane::headline(c),
            other => B::headline(B::note_of(other)?),
        }
    }

    fn lane(&self, note: &Note) -> Option<LaneChange> {
        match note {
            Note::Consensus(c) => lane::lane_change(c),
            other => B::lane(B::note_of(other)?),
        }
    }
}

/// `B` configured for one run: the config and its parameters, parsed once.
struct ConfiguredAs<B: Behaviour> {
    cfg: Config,
    params: B::Params,
}

impl<B: Enveloped> Configured for ConfiguredAs<B> {
    fn brain(&self, id: u32) -> Box<dyn Brain> {
        Box::new(Driver::<B> {
            behaviour: B::new(&self.cfg, &self.params, id),
            inbox: Vec::new(),
            act: Act::default(),
        })
    }

    fn metrics(&self, run: &Records) -> Vec<(&'static str, Value)> {
        B::metrics(&self.cfg, &self.params, run)
    }

    fn series(&self, run: &Records) -> Vec<Series> {
        B::series(&self.cfg, &self.params, run)
    }

    fn initial_role(&self, id: u32) -> Option<u8> {
        B::initial_role(&self.cfg, &self.params, id)
    }

    fn role_after(&self, id: u32, note: &Note) -> Option<u8> {
        B::role_after(&self.params, id, B::note_of(note)?)
    }
}

/// A recorded note as `B`'s own note; `None` for a consensus note (`{"consensus":{...}}`,
/// which a lenient note type might otherwise accept) and for anything `B` never wrote.
fn behaviour_note<B: Behaviour>(note: &Value) -> Option<B::Note> {
    if note.get("consensus").is_some() {
        return None;
    }
    B::Note::deserialize(note).ok()
}

struct Driver<B: Behaviour> {
    behaviour: B,
    inbox: Vec<Heard<B::Msg>>,
    act: Act<B::Msg, B::Note>,
}

impl<B: Enveloped> Brain for Driver<B> {
    fn listens(&self) -> bool {
        B::LISTENS
    }

    fn step(&mut self, tick: Tick<'_>, out: &mut Decided) {
        for d in tick.decisions {
            self.behaviour.apply(d);
        }
        if let Some(l) = &tick.leadership {
            self.behaviour.lead(l);
        }
        self.take_inbox(tick.heard);
        self.act.reset();
        self.behaviour.step(tick.obs, &self.inbox, &mut self.act);
        out.proposals.extend_from_slice(self.act.proposals());
        self.hand_over(out);
    }

    fn react(
        &mut self,
        obs: &Observation,
        heard: &mut Vec<Heard<RadioMsg>>,
        motion: Motion,
        out: &mut Decided,
    ) {
        self.take_inbox(heard);
        self.act.reset();
        self.act.v = motion.v;
        self.act.omega = motion.omega;
        self.act.velocity = motion.velocity;
        self.act.lidar_on = motion.lidar_on;
        self.behaviour.react(obs, &self.inbox, &mut self.act);
        self.hand_over(out);
    }
}

impl<B: Enveloped> Driver<B> {
    /// Keeps the messages of this behaviour's kind from `heard` (all of it is taken).
    fn take_inbox(&mut self, heard: &mut Vec<Heard<RadioMsg>>) {
        self.inbox.clear();
        self.inbox.extend(heard.drain(..).filter_map(|h| {
            Some(Heard {
                src: h.src,
                sent_tick: h.sent_tick,
                msg: B::unwrap_msg(h.msg)?,
            })
        }));
    }

    /// Hands the act's motion, frames (those within the tick first) and notes over, in
    /// the envelopes.
    fn hand_over(&mut self, out: &mut Decided) {
        out.motion = Motion {
            v: self.act.v,
            omega: self.act.omega,
            velocity: self.act.velocity,
            lidar_on: self.act.lidar_on,
        };
        let (frames, in_tick, notes) = self.act.drain();
        out.in_tick = in_tick;
        out.frames
            .extend(frames.into_iter().map(|(dst, m)| (dst, B::wrap_msg(m))));
        out.notes.extend(notes.map(B::wrap_note));
    }
}

/// The behaviour named by `cfg.behaviour.kind`.
pub fn plugin(kind: &str) -> Option<&'static dyn Plugin> {
    BEHAVIOURS.iter().copied().find(|p| p.kind() == kind)
}

/// `behaviour.kind` of every registered behaviour, in registry order.
pub fn kinds() -> Vec<&'static str> {
    BEHAVIOURS.iter().map(|p| p.kind()).collect()
}

fn unknown_kind(kind: &str) -> KeyError {
    let names: Vec<String> = kinds().iter().map(|k| format!("`{k}`")).collect();
    (
        "behaviour.kind".to_string(),
        format!(
            "unknown behaviour `{kind}`, expected one of {}",
            names.join(", ")
        ),
    )
}

/// Resolves `[behaviour]` in place: its parameters parsed, defaulted and validated by the
/// behaviour that owns them, so `cfg.to_toml()` writes them all. `file` names the config in
/// the error.
pub fn resolve(cfg: &mut Config, file: &str) -> Result<(), ConfigError> {
    let section: &BehaviourSection = &cfg.behaviour;
    let resolved = plugin(&section.kind)
        .ok_or_else(|| unknown_kind(&section.kind))
        .and_then(|p| p.resolve(&section.params, cfg))
        .map_err(|(key, message)| ConfigError::new(file, key, message))?;
    cfg.behaviour.params = resolved;
    Ok(())
}

/// `B`'s parameters, typed, from a config whose `[behaviour]` is resolved ([`resolve`]);
/// `Err` at `behaviour.kind` when the config is another behaviour's.
pub fn params<B: Behaviour>(cfg: &Config) -> Result<B::Params, KeyError> {
    if cfg.behaviour.kind != B::KIND {
        return Err((
            "behaviour.kind".to_string(),
            format!("expected \"{}\", got \"{}\"", B::KIND, cfg.behaviour.kind),
        ));
    }
    parse::<B>(&cfg.behaviour.params)
}

/// Reads a config that is already resolved, such as the `config.toml` of a run directory:
/// [`Config::load`], then [`resolve`]. A user's scenario goes through
/// `swarmrt_harness::config::load_run_config`, which also builds the map and checks the
/// robot programs.
pub fn load(path: &std::path::Path, overrides: &[String]) -> Result<Config, ConfigError> {
    let mut cfg = Config::load(path, overrides)?;
    resolve(&mut cfg, &path.display().to_string())?;
    Ok(cfg)
}

/// [`load`] from text (named `file` in errors).
pub fn from_toml_str(file: &str, text: &str, overrides: &[String]) -> Result<Config, ConfigError> {
    let mut cfg = Config::from_toml_str(file, text, overrides)?;
    resolve(&mut cfg, file)?;
    Ok(cfg)
}

/// Robot `id`'s brain for this scenario; `Err` for a `[behaviour]` no behaviour accepts.
pub fn brain(cfg: &Config, id: u32) -> Result<Box<dyn Brain>, KeyError> {
    Ok(configure(cfg)?.brain(id))
}

/// The behaviour of `cfg` configured for it ([`Plugin::configure`]); `Err` for a
/// `[behaviour]` no behaviour accepts.
pub fn configure(cfg: &Config) -> Result<Box<dyn Configured>, KeyError> {
    plugin(&cfg.behaviour.kind)
        .ok_or_else(|| unknown_kind(&cfg.behaviour.kind))?
        .configure(cfg)
}

/// Every `[behaviour]` key of every behaviour (`behaviour.<key>`), sorted, without repeats.
pub fn param_keys() -> Vec<String> {
    let mut keys: Vec<String> = BEHAVIOURS.iter().flat_map(|p| p.keys()).collect();
    keys.sort();
    keys.dedup();
    keys
}

impl RadioMsg {
    /// Decodes a payload; `None` for bytes that are not a valid message (counted, not fatal).
    pub fn decode(bytes: &[u8]) -> Option<RadioMsg> {
        postcard::from_bytes(bytes).ok()
    }
}

/// How the consensus layer's notes look in the record: `{"consensus": {...}}`.
#[derive(Serialize)]
#[serde(rename_all = "snake_case")]
enum TaggedNote<'a> {
    Consensus(&'a ConsensusNote),
}

impl Note {
    /// True when the robot says it is the leader now (the target of a `"leader"` fault).
    pub fn claims_leadership(&self) -> bool {
        matches!(self, Note::Consensus(c) if c.claims_leadership())
    }

    /// The note for `events.jsonl`: a behaviour's note as itself, a consensus note tagged
    /// `consensus`.
    pub fn to_json(&self) -> String {
        let json = match self {
            Note::Consensus(c) => serde_json::to_string(&TaggedNote::Consensus(c)),
            other => other.behaviour_json(),
        };
        json.expect("notes always serialize")
    }
}

fn read_notes(report: &[u8]) -> Result<Vec<RecordedNote>, &'static str> {
    if report.is_empty() {
        return Ok(Vec::new());
    }
    let notes: Vec<Note> = postcard::from_bytes(report).map_err(|_| "malformed report")?;
    Ok(notes
        .iter()
        .map(|n| RecordedNote {
            json: NoteJson::new(n.to_json()).expect("a note renders as one JSON value"),
            claims_leadership: n.claims_leadership(),
        })
        .collect())
}

/// The robots' vocabulary as the world checks it.
pub const VOCABULARY: Vocabulary = Vocabulary {
    check_frame: |bytes| RadioMsg::decode(bytes).is_some(),
    read_notes,
};

/// Writes the envelopes, their wire tags ([`crate::wire`]), the [`Enveloped`] impls and the
/// list from one line per behaviour.
macro_rules! behaviours {
    ($($variant:ident = $tag:literal => $module:ident :: $ty:ident),+ $(,)?) => {
        $(pub mod $module;)+
        /// A message in a radio frame: one variant per behaviour, then the consensus layer's.
        /// Encoded with its [`WireTag`] first, then the message.
        #[derive(Debug, Clone, PartialEq)]
        pub enum RadioMsg {
            $(
                #[doc = concat!("A message of `", stringify!($module), "`.")]
                $variant(<$module::$ty as $crate::behaviour::Behaviour>::Msg),
            )+
            /// Election, replicated log and leader choice ([`crate::consensus`]).
            Consensus($crate::consensus::ConsensusMsg),
        }

        /// A note a robot reports: one variant per behaviour, then the consensus layer's.
        /// Encoded with its [`WireTag`] first, then the note.
        #[derive(Debug, Clone, PartialEq)]
        pub enum Note {
            $(
                #[doc = concat!("A note of `", stringify!($module), "`.")]
                $variant(<$module::$ty as $crate::behaviour::Behaviour>::Note),
            )+
            /// Consensus state changes and log events.
            Consensus($crate::consensus::ConsensusNote),
        }

        /// The wire tag of each variant of [`RadioMsg`] and [`Note`], as declared by its
        /// registry line: the first byte of its encoding, which adding a behaviour never
        /// moves. A tag declared twice does not compile (a discriminant assigned twice).
        #[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
        #[repr(u8)]
        pub enum WireTag {
            $(
                #[doc = concat!("`RadioMsg::", stringify!($variant), "`.")]
                $variant = $tag,
            )+
            /// `RadioMsg::Consensus` ([`crate::wire::CONSENSUS_TAG`]).
            Consensus = $crate::wire::CONSENSUS_TAG,
        }

        impl WireTag {
            /// Every tag, in registry order (the consensus layer's last).
            pub const ALL: &[WireTag] = &[$(WireTag::$variant,)+ WireTag::Consensus];
            /// The variant names, in the order of [`WireTag::ALL`].
            pub const NAMES: &[&str] = &[$(stringify!($variant),)+ "Consensus"];

            /// The variant's name (`"Goto"`, `"Consensus"`).
            pub const fn name(self) -> &'static str {
                match self {
                    $(WireTag::$variant => stringify!($variant),)+
                    WireTag::Consensus => "Consensus",
                }
            }
        }

        $crate::wire::envelope_serde!(RadioMsg; $($variant,)+ Consensus);
        $crate::wire::envelope_serde!(Note; $($variant,)+ Consensus);

        impl Note {
            pub(crate) fn behaviour_json(&self) -> serde_json::Result<String> {
                match self {
                    $(Note::$variant(n) => serde_json::to_string(n),)+
                    Note::Consensus(c) => serde_json::to_string(c),
                }
            }
        }

        $(
            impl $crate::registry::Enveloped for $module::$ty {
                fn wrap_msg(msg: Self::Msg) -> RadioMsg {
                    RadioMsg::$variant(msg)
                }
                fn unwrap_msg(msg: RadioMsg) -> Option<Self::Msg> {
                    match msg {
                        RadioMsg::$variant(m) => Some(m),
                        _ => None,
                    }
                }
                fn wrap_note(note: Self::Note) -> Note {
                    Note::$variant(note)
                }
                fn note_of(note: &Note) -> Option<&Self::Note> {
                    match note {
                        Note::$variant(n) => Some(n),
                        _ => None,
                    }
                }
            }
        )+

        /// Every behaviour, in registry order.
        pub static BEHAVIOURS: &[&dyn $crate::registry::Plugin] =
            &[$(&$crate::registry::Entry::<$module::$ty>(std::marker::PhantomData)),+];
    };
}
pub(crate) use behaviours;
