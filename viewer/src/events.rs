//! `events.jsonl` read as it grows into what the page shows: the timeline's markers, each
//! robot's notes, its role over time (from its behaviour's overlay) and the consensus lanes.
//!
//! Events are read through the typed record schema (`records::Event`); a line that does not
//! parse is counted, never guessed at.

use std::path::Path;

use serde::Serialize;
use serde_json::Value;
use swarmrt_protocol::records::{Event, FaultKind};

use crate::overlay::{LaneChange, Overlay};
use crate::tail::Tail;

/// One mark on the timeline.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Marker {
    /// Tick it happened at.
    pub tick: u64,
    /// What kind of thing (`collision`, `reached`, `died`, `fault`, `rejected`, or a
    /// behaviour's or the consensus's headline kind such as `veto` or `leader`).
    pub kind: String,
    /// The robots involved, the one that reported it first.
    pub robots: Vec<u32>,
    /// One line for a person.
    pub text: String,
}

/// A change on a robot's consensus lane.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LanePoint {
    /// Tick of the note.
    pub tick: u64,
    /// The robot.
    pub robot: u32,
    /// Its role from here on, when the note says.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub role: Option<String>,
    /// Its term from here on, when the note says.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub term: Option<u64>,
    /// Its commit index from here on, when the note says.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub commit: Option<u64>,
}

/// Everything read from `events.jsonl` so far.
pub struct EventsModel {
    tail: Tail,
    overlay: Box<dyn Overlay>,
    /// The timeline, in record order (ticks ascending).
    pub markers: Vec<Marker>,
    /// Per robot: `(tick, note as JSON)` in record order.
    notes: Vec<Vec<(u64, String)>>,
    /// Per robot: `(from tick, role)`; the first entry is the start role.
    roles: Vec<Vec<(u64, u8)>>,
    /// The consensus lanes, in record order.
    pub lanes: Vec<LanePoint>,
    /// Lines that were not an event.
    pub bad_lines: u64,
    /// The reporter of the last marker when it is a behaviour's headline (others of its kind
    /// and tick join it).
    merged_from: Option<u32>,
}

impl EventsModel {
    /// A model of `path` for `robots` robots coloured by `overlay`; nothing is read until
    /// [`Self::refresh`].
    pub fn new(path: &Path, robots: usize, overlay: Box<dyn Overlay>) -> EventsModel {
        let roles = (0..robots as u32)
            .map(|id| match overlay.initial_role(id) {
                Some(r) => vec![(0, r)],
                None => Vec::new(),
            })
            .collect();
        EventsModel {
            tail: Tail::new(path),
            overlay,
            markers: Vec::new(),
            notes: vec![Vec::new(); robots],
            roles,
            lanes: Vec::new(),
            bad_lines: 0,
            merged_from: None,
        }
    }

    /// Lines longer than [`crate::tail::MAX_LINE`], skipped.
    pub fn long_lines(&self) -> u64 {
        self.tail.long_lines()
    }

    /// The behaviour's overlay.
    pub fn overlay(&self) -> &dyn Overlay {
        self.overlay.as_ref()
    }

    /// Reads the whole lines appended since the last call.
    pub fn refresh(&mut self) -> std::io::Result<()> {
        let mut tail = std::mem::take(&mut self.tail);
        let read = tail.read_new(
            |line, _, _| match serde_json::from_slice::<Event<Value>>(line) {
                Ok(e) => self.add(e, line),
                Err(_) => self.bad_lines += 1,
            },
        );
        self.tail = tail;
        read?;
        Ok(())
    }

    fn mark(&mut self, tick: u64, kind: &str, robots: Vec<u32>, text: String) {
        self.merged_from = None;
        self.markers.push(Marker {
            tick,
            kind: kind.to_string(),
            robots,
            text,
        });
    }

    fn add(&mut self, e: Event<Value>, line: &[u8]) {
        match e {
            Event::Collision { tick, robot, other } => {
                let mut robots = vec![robot];
                let text = match other {
                    Some(o) => {
                        robots.push(o);
                        format!("robot {robot} collided with robot {o}")
                    }
                    None => format!("robot {robot} hit an obstacle"),
                };
                self.mark(tick, "collision", robots, text);
            }
            Event::Reached { tick, robot } => self.mark(
                tick,
                "reached",
                vec![robot],
                format!("robot {robot} reached the goal"),
            ),
            Event::Died {
                tick,
                robot,
                reason,
            } => self.mark(
                tick,
                "died",
                vec![robot],
                format!("robot {robot} died: {reason}"),
            ),
            Event::Fault {
                tick,
                fault,
                robot,
                random,
            } => {
                let what = serde_json::to_value(fault)
                    .ok()
                    .and_then(|v| v.as_str().map(str::to_string))
                    .unwrap_or_default()
                    .replace('_', " ");
                let robots: Vec<u32> = robot.into_iter().collect();
                let text = match robot {
                    Some(r) => {
                        format!("{what}: robot {r}{}", if random { " (random)" } else { "" })
                    }
                    None => what,
                };
                let kind = match fault {
                    FaultKind::PartitionStart
                    | FaultKind::PartitionEnd
                    | FaultKind::BlackoutStart
                    | FaultKind::BlackoutEnd => "radio",
                    _ => "fault",
                };
                self.mark(tick, kind, robots, text);
            }
            Event::Rejected {
                tick,
                robot,
                reason,
            } => self.mark(
                tick,
                "rejected",
                vec![robot],
                format!("robot {robot}'s command refused: {reason}"),
            ),
            Event::Note { tick, robot, note } => {
                if let Some(list) = self.notes.get_mut(robot as usize) {
                    let text = serde_json::to_string(&note)
                        .unwrap_or_else(|_| String::from_utf8_lossy(line).into_owned());
                    list.push((tick, text));
                }
                let meaning = self.overlay.read(robot, &note);
                if let Some(role) = meaning.role
                    && let Some(list) = self.roles.get_mut(robot as usize)
                {
                    list.push((tick, role));
                }
                if let Some(h) = meaning.headline {
                    self.headline(tick, robot, h);
                }
                if let Some(LaneChange {
                    role, term, commit, ..
                }) = meaning.lane
                {
                    self.lanes.push(LanePoint {
                        tick,
                        robot,
                        role: role.map(str::to_string),
                        term,
                        commit,
                    });
                }
            }
        }
    }

    /// A behaviour's headline; the same kind from several robots in one tick (a formation
    /// turning together) is one marker naming them all.
    fn headline(&mut self, tick: u64, robot: u32, h: crate::overlay::Headline) {
        if let Some(last) = self.markers.last_mut()
            && last.tick == tick
            && last.kind == h.kind
            && self.merged_from.is_some()
        {
            let first = self.merged_from.expect("checked");
            for r in std::iter::once(robot).chain(h.others) {
                if !last.robots.contains(&r) {
                    last.robots.push(r);
                }
            }
            last.text = format!(
                "{} robots: {} (robot {first} and others)",
                last.robots.len(),
                h.kind.replace('_', " ")
            );
            return;
        }
        let mut robots = vec![robot];
        robots.extend(h.others.iter().copied().filter(|&o| o != robot));
        let text = format!("robot {robot}: {}", h.text);
        self.mark(tick, h.kind, robots, text);
        self.merged_from = Some(robot);
    }

    /// Robot `id`'s role at `tick` ([`crate::trajectory::NO_ROLE`] without one).
    pub fn role_at(&self, id: u32, tick: u64) -> u8 {
        let Some(list) = self.roles.get(id as usize) else {
            return crate::trajectory::NO_ROLE;
        };
        let k = list.partition_point(|&(t, _)| t <= tick);
        if k == 0 {
            crate::trajectory::NO_ROLE
        } else {
            list[k - 1].1
        }
    }

    /// Robot `id`'s last `n` notes at or before `tick`, oldest first.
    pub fn notes_before(&self, id: u32, tick: u64, n: usize) -> Vec<(u64, Value)> {
        let Some(list) = self.notes.get(id as usize) else {
            return Vec::new();
        };
        let k = list.partition_point(|&(t, _)| t <= tick);
        list[k.saturating_sub(n)..k]
            .iter()
            .map(|(t, s)| (*t, serde_json::from_str(s).unwrap_or(Value::Null)))
            .collect()
    }

    /// True when any robot has a consensus lane.
    pub fn has_lanes(&self) -> bool {
        !self.lanes.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::overlay::{Headline, Meaning, RoleDef};

    struct Test;
    impl Overlay for Test {
        fn roles(&self) -> &'static [RoleDef] {
            &[RoleDef {
                name: "a",
                colour: "#000",
            }]
        }
        fn initial_role(&self, id: u32) -> Option<u8> {
            (id == 1).then_some(0)
        }
        fn read(&self, _id: u32, note: &Value) -> Meaning {
            Meaning {
                role: note.get("become").and_then(|v| v.as_u64()).map(|v| v as u8),
                headline: note.get("veto").map(|m| Headline {
                    kind: "veto",
                    text: "veto".into(),
                    others: vec![m.as_u64().unwrap() as u32],
                }),
                lane: note.get("term").map(|t| LaneChange {
                    role: Some("leader"),
                    term: t.as_u64(),
                    ..LaneChange::default()
                }),
            }
        }
    }

    #[test]
    fn markers_roles_notes_and_lanes_from_typed_events() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("events.jsonl");
        std::fs::write(
            &path,
            concat!(
                "{\"event\":\"collision\",\"tick\":3,\"robot\":0,\"other\":1}\n",
                "{\"event\":\"note\",\"tick\":4,\"robot\":0,\"note\":{\"become\":0}}\n",
                "not json\n",
                "{\"event\":\"note\",\"tick\":5,\"robot\":1,\"note\":{\"veto\":0,\"term\":2}}\n",
                "{\"event\":\"note\",\"tick\":5,\"robot\":0,\"note\":{\"veto\":1}}\n",
                "{\"event\":\"fault\",\"tick\":6,\"fault\":\"partition_start\"}\n",
                "{\"event\":\"reached\",\"tick\":7,\"rob"
            ),
        )
        .unwrap();
        let mut m = EventsModel::new(&path, 2, Box::new(Test));
        m.refresh().unwrap();
        assert_eq!(m.bad_lines, 1);
        let kinds: Vec<&str> = m.markers.iter().map(|k| k.kind.as_str()).collect();
        assert_eq!(kinds, ["collision", "veto", "radio"], "the torn line waits");
        assert_eq!(m.markers[0].robots, [0, 1]);
        assert_eq!(
            m.markers[1].robots,
            [1, 0],
            "robot 0's veto in the same tick joins"
        );
        assert!(
            m.markers[1].text.starts_with("2 robots: veto"),
            "{}",
            m.markers[1].text
        );
        assert_eq!(m.role_at(0, 3), crate::trajectory::NO_ROLE);
        assert_eq!(m.role_at(0, 4), 0);
        assert_eq!(m.role_at(1, 0), 0);
        assert_eq!(m.notes_before(1, 100, 5).len(), 1);
        assert_eq!(m.lanes[0].term, Some(2));
    }
}
