//! The behaviour registry: `[behaviour]` resolved by the behaviour that owns it, errors that
//! name the key, notes rendered for the record as they always were.

use swarmrt_agent::behaviours::formation::FormationNote;
use swarmrt_agent::behaviours::goto::Beacon;
use swarmrt_agent::registry::{self, VOCABULARY};
use swarmrt_agent::{Note, RadioMsg};
use swarmrt_scenario::{Config, ConfigError};

const MINIMAL: &str = r#"
[scenario]
name = "t"
ticks = 10
[map]
bounds = [0.0, 0.0, 10.0, 10.0]
goal = { x = 8.0, y = 8.0, radius = 1.0 }
[robots]
count = 4
"#;

fn load(text: &str, ov: &[&str]) -> Result<Config, ConfigError> {
    let ov: Vec<String> = ov.iter().map(|s| s.to_string()).collect();
    registry::from_toml_str("t.toml", text, &ov)
}

#[test]
fn a_bad_behaviour_field_is_named_with_its_key() {
    let e = load(
        MINIMAL,
        &["behaviour.kind=\"formation\"", "behaviour.turn_deg=\"x\""],
    )
    .unwrap_err();
    assert_eq!(e.key, "behaviour.turn_deg", "{e}");
    let e = load(
        MINIMAL,
        &["behaviour.kind=\"formation\"", "behaviour.turn_dg=1"],
    )
    .unwrap_err();
    assert_eq!(e.key, "behaviour.turn_dg", "{e}");
    let e = load(
        MINIMAL,
        &["behaviour.kind=\"formation\"", "behaviour.speed=50"],
    )
    .unwrap_err();
    assert_eq!(e.key, "behaviour.speed", "{e}");
}

#[test]
fn an_unknown_kind_names_the_key_and_the_known_kinds() {
    let e = load(MINIMAL, &["behaviour.kind=\"flock\""]).unwrap_err();
    assert_eq!(e.key, "behaviour.kind", "{e}");
    assert!(
        e.message.contains("`goto`") && e.message.contains("`formation`"),
        "{e}"
    );
    let e = load(MINIMAL, &["behaviour.kind=3"]).unwrap_err();
    assert_eq!(e.key, "behaviour.kind", "{e}");
    let e = load(MINIMAL, &["behaviour={ speed = 1.0 }"]).unwrap_err();
    assert_eq!(e.key, "behaviour", "{e}");
    assert!(e.message.contains("kind"), "{e}");
}

#[test]
fn defaults_are_filled_in_declaration_order_and_round_trip() {
    let c = load(MINIMAL, &[]).unwrap();
    assert_eq!(c.behaviour.kind, "goto");
    let keys: Vec<&str> = c.behaviour.params.keys().map(String::as_str).collect();
    assert_eq!(
        keys,
        ["speed", "avoid_distance", "beacon_period", "slot_spacing"]
    );
    let toml = c.to_toml();
    assert!(
        toml.contains("[behaviour]\nkind = \"goto\"\nspeed = 0.5\navoid_distance = 0.9"),
        "{toml}"
    );
    assert_eq!(registry::from_toml_str("t.toml", &toml, &[]).unwrap(), c);
    let f = load(
        MINIMAL,
        &["behaviour.kind=\"formation\"", "behaviour.turn_deg=10"],
    )
    .unwrap();
    assert_eq!(f.behaviour.params["turn_deg"].as_float(), Some(10.0));
    assert_eq!(f.behaviour.params["epsilon_clear"].as_float(), Some(0.01));
}

#[test]
fn every_behaviour_is_listed_with_its_keys() {
    assert_eq!(
        registry::kinds(),
        [
            "goto",
            "formation",
            "flocking",
            "grouping",
            "planner",
            "chain"
        ]
    );
    let keys = registry::param_keys();
    for k in [
        "behaviour.beacon_period",
        "behaviour.turn_deg",
        "behaviour.verdict_ticks",
        "behaviour.migration_deg",
        "behaviour.cluster_distance",
        "behaviour.lead_time",
        "behaviour.rod_max",
        "behaviour.stationary",
    ] {
        assert!(keys.iter().any(|x| x == k), "{k} in {keys:?}");
    }
}

#[test]
fn notes_render_as_the_record_always_had_them() {
    let cases = [
        (
            Note::Formation(FormationNote::Role { role: 2 }),
            r#"{"role":{"role":2}}"#,
        ),
        (
            Note::Formation(FormationNote::Turn { dir: -1 }),
            r#"{"turn":{"dir":-1}}"#,
        ),
        (
            Note::Formation(FormationNote::EpsilonFlip),
            r#""epsilon_flip""#,
        ),
    ];
    for (note, json) in &cases {
        assert_eq!(note.to_json(), *json);
    }
    let notes: Vec<Note> = cases.iter().map(|(n, _)| n.clone()).collect();
    let report = postcard::to_allocvec(&notes).unwrap();
    let recorded = (VOCABULARY.read_notes)(&report).unwrap();
    let shown: Vec<&str> = recorded.iter().map(|r| r.json.get()).collect();
    assert_eq!(shown, cases.iter().map(|c| c.1).collect::<Vec<_>>());
    assert!((VOCABULARY.read_notes)(&[0xff, 0xff, 0xff, 0xff]).is_err());
    assert_eq!((VOCABULARY.read_notes)(&[]).unwrap(), vec![]);
}

#[test]
fn frames_are_checked_against_every_behaviour_and_consensus() {
    let beacon = RadioMsg::Goto(Beacon {
        x: 1.0,
        y: 2.0,
        theta: 0.0,
    });
    assert!((VOCABULARY.check_frame)(
        &postcard::to_allocvec(&beacon).unwrap()
    ));
    assert!(!(VOCABULARY.check_frame)(&[0xff, 0xff, 0xff]));
    assert!(!(VOCABULARY.check_frame)(&[200, 1, 2]));
}
