//! What the world needs to know about the robots' own messages without knowing any
//! behaviour: whether a radio payload is one some robot can read, and how a robot's notes
//! look in the run record. The robots' side (`swarmrt_agent::registry::VOCABULARY`) supplies
//! both; the world calls them at its boundary and otherwise routes and records bytes.

use serde::{Deserialize, Serialize};
use serde_json::value::RawValue;

/// A note as one JSON value, written verbatim into the `note` field of a `note` event.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(transparent)]
pub struct NoteJson(Box<RawValue>);

impl NoteJson {
    /// `json` if it is one JSON value.
    pub fn new(json: String) -> Result<NoteJson, serde_json::Error> {
        RawValue::from_string(json).map(NoteJson)
    }

    /// The JSON text.
    pub fn get(&self) -> &str {
        self.0.get()
    }
}

impl PartialEq for NoteJson {
    fn eq(&self, other: &Self) -> bool {
        self.get() == other.get()
    }
}

/// A note a robot reported, ready for `events.jsonl`.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordedNote {
    /// The note as one JSON value.
    pub json: NoteJson,
    /// True when the robot says it is the leader now (the target of a `"leader"` fault).
    pub claims_leadership: bool,
}

/// The robots' message checks, as plain functions so the world needs no generic parameter.
#[derive(Debug, Clone, Copy)]
pub struct Vocabulary {
    /// True when a radio payload decodes as a message some robot can read; frames that do not
    /// are refused at the world's boundary rather than delivered as noise.
    pub check_frame: fn(&[u8]) -> bool,
    /// Decodes a command's report (the notes) for the record; `Err` names what was wrong.
    pub read_notes: fn(&[u8]) -> Result<Vec<RecordedNote>, &'static str>,
}

impl Vocabulary {
    /// For worlds driven without robots (the world's own tests and benchmarks): any payload is
    /// accepted and a non-empty report is refused.
    pub const ANY: Vocabulary = Vocabulary {
        check_frame: |_| true,
        read_notes: |report| {
            if report.is_empty() {
                Ok(Vec::new())
            } else {
                Err("malformed report")
            }
        },
    };
}
