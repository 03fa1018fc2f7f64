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
    assert_eq!(rec.events_of("reached").count(), 1);
}
