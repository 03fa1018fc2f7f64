//! The run-record schema: event lines as the world writes them read back typed, and
//! `trajectory.csv` read by column name.

use serde_json::Value;
use swarmrt_protocol::NoteJson;
use swarmrt_protocol::records::{Columns, Event, FaultKind, Records};

#[test]
fn event_lines_round_trip_and_keep_their_bytes() {
    let lines = [
        r#"{"event":"collision","tick":3,"robot":1}"#,
        r#"{"event":"collision","tick":3,"robot":1,"other":2}"#,
        r#"{"event":"fault","tick":60,"fault":"kill","robot":4}"#,
        r#"{"event":"fault","tick":61,"fault":"freeze","robot":2,"random":true}"#,
        r#"{"event":"fault","tick":70,"fault":"partition_start"}"#,
        r#"{"event":"note","tick":5,"robot":0,"note":{"role":{"role":2}}}"#,
        r#"{"event":"note","tick":5,"robot":0,"note":"epsilon_flip"}"#,
        r#"{"event":"died","tick":9,"robot":3,"reason":"process exited: signal 9"}"#,
        r#"{"event":"rejected","tick":2,"robot":1,"reason":"non-finite speed"}"#,
        r#"{"event":"reached","tick":400,"robot":7}"#,
    ];
    for line in lines {
        let read: Event<Value> = serde_json::from_str(line).unwrap();
        assert_eq!(
            serde_json::to_string(&read).unwrap(),
            line,
            "read back as written"
        );
    }
    let kill: Event<Value> = serde_json::from_str(lines[2]).unwrap();
    assert!(matches!(
        kill,
        Event::Fault {
            fault: FaultKind::Kill,
            robot: Some(4),
            random: false,
            ..
        }
    ));
    // What the world writes: the note's JSON verbatim, key order and all.
    let written: Event<NoteJson> = Event::Note {
        tick: 5,
        robot: 0,
        note: NoteJson::new(r#"{"consensus":{"state":{"term":7,"vote":3}}}"#.into()).unwrap(),
    };
    assert_eq!(
        serde_json::to_string(&written).unwrap(),
        r#"{"event":"note","tick":5,"robot":0,"note":{"consensus":{"state":{"term":7,"vote":3}}}}"#
    );
    let bad = r#"{"event":"fault","tick":1,"fault":"explode"}"#;
    assert!(serde_json::from_str::<Event<Value>>(bad).is_err());
}

#[test]
fn trajectory_columns_are_found_by_name() {
    let cols = Columns::from_header("state,tick,id,lidar,x,y,theta,v,omega").unwrap();
    let row = cols.parse("active,4,2,1,1.5,2.5,0.1,0.5,0.0").unwrap();
    assert_eq!((row.tick, row.id, row.x, row.y), (4, 2, 1.5, 2.5));
    assert!(row.lidar && row.active);
    assert!(
        cols.parse("active,4,2").is_none(),
        "a cut line is not a row"
    );
    assert!(Columns::from_header("tick,id,x").is_err());
    let rec = Records::parse(
        "tick,id,x,y,theta,v,omega,lidar,state\n0,0,1.0,1.0,0.0,0.0,0.0,1,active\n\
         0,1,2.0,1.0,0.0,0.0,0.0,0,down\n1,0,1.1,1.0,0.0,0.5,0.0,1,active\n1,1,2.0",
        "{\"event\":\"reached\",\"tick\":1,\"robot\":0}\nnot json\n",
    )
    .unwrap();
    assert_eq!(rec.ticks.len(), 2);
    assert_eq!(rec.ticks[1].len(), 1, "the cut last line is skipped");
    assert!(!rec.ticks[0][1].active);
    assert_eq!(rec.reached().collect::<Vec<_>>(), [(1, 0)]);
}

/// A note type as a behaviour declares one: recorded as itself, read back as itself.
#[derive(Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
enum TestNote {
    Turn { dir: i8 },
    Flip,
}

#[test]
fn events_read_back_typed_and_notes_decode_as_their_type() {
    let events = [
        r#"{"event":"collision","tick":3,"robot":1,"other":2}"#,
        r#"{"event":"note","tick":4,"robot":1,"note":{"turn":{"dir":-1}}}"#,
        r#"{"event":"note","tick":4,"robot":2,"note":{"consensus":{"truncate":{"index":3}}}}"#,
        r#"{"event":"from_the_future","tick":5}"#,
        r#"{"event":"note","tick":5,"robot":0,"note":"flip"}"#,
        r#"{"event":"note","tick":6,"robot":0,"note":{"turn":{"direction":1}}}"#,
        r#"{"event":"reached","tick":7,"robot":2}"#,
        r#"{"event":"collision","tick":8,"robot":0}"#,
        r#"{"event":"reached","tick":9,"rob"#,
    ]
    .join("\n");
    let rec = Records::parse("tick,id,x,y,theta,v,omega,lidar,state\n", &events).unwrap();
    assert_eq!(rec.events.len(), 7, "unknown and cut lines are skipped");
    assert_eq!(rec.events[4].tick(), 6);
    assert_eq!(rec.reached().collect::<Vec<_>>(), [(7, 2)]);
    assert_eq!(
        rec.collisions().collect::<Vec<_>>(),
        [(3, 1, Some(2)), (8, 0, None)]
    );
    assert_eq!(rec.notes().count(), 4);
    assert_eq!(
        rec.notes_as::<TestNote>().collect::<Vec<_>>(),
        [(4, 1, TestNote::Turn { dir: -1 }), (5, 0, TestNote::Flip)]
    );
    // A renamed field is an error, not a note read as a default.
    let failed: Vec<(u64, u32)> = rec
        .try_notes_as::<TestNote>()
        .filter(|(_, _, n)| n.is_err())
        .map(|(t, r, _)| (t, r))
        .collect();
    assert_eq!(failed, [(4, 2), (6, 0)]);
}
