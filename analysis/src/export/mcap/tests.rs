//! The exporter read back with the `mcap` crate: channels, schemas, counts, poses, events,
//! torn input, determinism, and every message checked against Foxglove's JSON Schema.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde_json::Value;

use super::*;

/// A config of the repository, resolved as a run directory holds it.
fn config_of(name: &str) -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join("configs")
        .join(name);
    Config::load(&path, &[]).unwrap().to_toml()
}

/// A run directory holding `config`, `trajectory` and `events`.
fn run_dir(config: &str, trajectory: &str, events: &str) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("config.toml"), config).unwrap();
    std::fs::write(dir.path().join("trajectory.csv"), trajectory).unwrap();
    std::fs::write(dir.path().join("events.jsonl"), events).unwrap();
    dir
}

/// Ground rows of 3 robots for ticks `0..ticks`: robot `i` at `(i + 0.1 t, 2 - 0.05 t)` with
/// heading `0.3 i - 0.1 t`; robot 2 down from tick 3.
fn ground_trajectory(ticks: u64) -> String {
    let mut s = String::from(swarmrt_protocol::records::TRAJECTORY_HEADER);
    for t in 0..ticks {
        for i in 0..3u32 {
            let state = if i == 2 && t >= 3 { "down" } else { "active" };
            let (x, y, th) = pose_of(i, t);
            s += &format!("{t},{i},{x:.6},{y:.6},{th:.6},0.2,0.1,1,{state}\n");
        }
    }
    s
}

fn pose_of(i: u32, t: u64) -> (f64, f64, f64) {
    (
        f64::from(i) + 0.1 * t as f64,
        2.0 - 0.05 * t as f64,
        0.3 * f64::from(i) - 0.1 * t as f64,
    )
}

const EVENTS: &str = "{\"event\":\"fault\",\"tick\":1,\"fault\":\"freeze\",\"robot\":1,\"random\":true}\n\
{\"event\":\"note\",\"tick\":1,\"robot\":0,\"note\":{\"role\":\"leader\"}}\n\
{\"event\":\"collision\",\"tick\":3,\"robot\":2,\"other\":1}\n\
{\"event\":\"rejected\",\"tick\":3,\"robot\":0,\"reason\":\"speed out of range\"}\n\
{\"event\":\"reached\",\"tick\":4,\"robot\":0}\n\
{\"event\":\"died\",\"tick\":4,\"robot\":1,\"reason\":\"process exited: signal 9\"}\n";

/// Everything read back from an MCAP file.
struct ReadBack {
    /// topic -> (schema name, schema encoding, message encoding)
    channels: BTreeMap<String, (String, String, String)>,
    /// topic -> messages (log time, decoded JSON), in file order.
    messages: BTreeMap<String, Vec<(u64, Value)>>,
    /// Schema data by schema name.
    schemas: BTreeMap<String, Value>,
    stats_messages: u64,
    attachments: usize,
}

fn read_back(path: &Path) -> ReadBack {
    let bytes = std::fs::read(path).unwrap();
    let summary = ::mcap::Summary::read(&bytes).unwrap().expect("a summary");
    let mut channels = BTreeMap::new();
    let mut schemas = BTreeMap::new();
    for ch in summary.channels.values() {
        let schema = ch.schema.as_ref().expect("every channel has a schema");
        channels.insert(
            ch.topic.clone(),
            (
                schema.name.clone(),
                schema.encoding.clone(),
                ch.message_encoding.clone(),
            ),
        );
        schemas.insert(
            schema.name.clone(),
            serde_json::from_slice(&schema.data).unwrap(),
        );
    }
    let mut messages: BTreeMap<String, Vec<(u64, Value)>> = BTreeMap::new();
    for m in ::mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        let v: Value = serde_json::from_slice(&m.data).unwrap();
        messages
            .entry(m.channel.topic.clone())
            .or_default()
            .push((m.log_time, v));
    }
    ReadBack {
        channels,
        messages,
        schemas,
        stats_messages: summary.stats.unwrap().message_count,
        attachments: summary.attachment_indexes.len(),
    }
}

fn export(dir: &Path) -> (PathBuf, Summary) {
    let out = dir.join("run.mcap");
    let summary = write_mcap(dir, &out).unwrap();
    (out, summary)
}

/// Checks `v` against a JSON Schema of the kind Foxglove publishes (objects with `required`,
/// arrays, numbers, integers, booleans, strings, `oneOf` constants); also refuses fields the
/// schema does not have. `Err` names the path of the first mismatch.
fn conforms(schema: &Value, v: &Value, at: &str) -> Result<(), String> {
    if let Some(options) = schema.get("oneOf").and_then(Value::as_array) {
        return if options.iter().any(|o| o["const"] == *v) {
            Ok(())
        } else {
            Err(format!("{at}: {v} is none of the constants"))
        };
    }
    let ok = match schema["type"].as_str() {
        Some("object") => {
            let obj = v.as_object().ok_or(format!("{at}: not an object"))?;
            let props = schema["properties"].as_object().unwrap();
            for req in schema["required"].as_array().into_iter().flatten() {
                let key = req.as_str().unwrap();
                if !obj.contains_key(key) {
                    return Err(format!("{at}: `{key}` missing"));
                }
            }
            for (k, item) in obj {
                let sub = props
                    .get(k)
                    .ok_or(format!("{at}: `{k}` not in the schema"))?;
                conforms(sub, item, &format!("{at}.{k}"))?;
            }
            true
        }
        Some("array") => {
            let items = v.as_array().ok_or(format!("{at}: not an array"))?;
            for (i, item) in items.iter().enumerate() {
                conforms(&schema["items"], item, &format!("{at}[{i}]"))?;
            }
            true
        }
        Some("number") => v.as_f64().is_some_and(f64::is_finite),
        Some("integer") => {
            v.as_u64().is_some()
                && schema["minimum"]
                    .as_u64()
                    .is_none_or(|m| v.as_u64() >= Some(m))
                && schema["maximum"]
                    .as_u64()
                    .is_none_or(|m| v.as_u64() <= Some(m))
        }
        Some("boolean") => v.is_boolean(),
        Some("string") => v.is_string(),
        other => return Err(format!("{at}: schema type {other:?} not handled")),
    };
    if ok {
        Ok(())
    } else {
        Err(format!("{at}: {v} is not a {}", schema["type"]))
    }
}

/// Every message of `rb` conforms to its channel's schema.
fn assert_all_conform(rb: &ReadBack) {
    for (topic, msgs) in &rb.messages {
        let schema = &rb.schemas[&rb.channels[topic].0];
        for (i, (_, m)) in msgs.iter().enumerate() {
            conforms(schema, m, topic).unwrap_or_else(|e| panic!("{topic} message {i}: {e}"));
        }
    }
}

/// The yaw of a `foxglove.Quaternion` about +z.
fn yaw(q: &Value) -> f64 {
    2.0 * q["z"].as_f64().unwrap().atan2(q["w"].as_f64().unwrap())
}

#[test]
fn a_run_reads_back_with_its_channels_counts_poses_and_events() {
    let cfg = config_of("formation_complex.toml");
    let dir = run_dir(&cfg, &ground_trajectory(5), EVENTS);
    let (out, summary) = export(dir.path());
    let dt_ns = (Config::from_toml_str("c", &cfg, &[]).unwrap().scenario.dt * 1e9).round() as u64;

    let rb = read_back(&out);
    let want: BTreeMap<String, (String, String, String)> = [
        (MAP_TOPIC, "foxglove.SceneUpdate"),
        (ROBOTS_TOPIC, "foxglove.SceneUpdate"),
        (TF_TOPIC, "foxglove.FrameTransforms"),
        (EVENTS_TOPIC, "foxglove.Log"),
    ]
    .into_iter()
    .map(|(t, s)| (t.into(), (s.into(), "jsonschema".into(), "json".into())))
    .collect();
    assert_eq!(rb.channels, want);
    let counts: BTreeMap<&str, usize> = rb
        .messages
        .iter()
        .map(|(t, m)| (t.as_str(), m.len()))
        .collect();
    let expected = BTreeMap::from([
        (MAP_TOPIC, 1),
        (ROBOTS_TOPIC, 5),
        (TF_TOPIC, 5),
        (EVENTS_TOPIC, 6),
    ]);
    assert_eq!(counts, expected);
    assert_eq!(rb.stats_messages, 17);
    assert_eq!(rb.attachments, 1, "config.toml attached");
    let reported: BTreeMap<&str, usize> = summary
        .channels
        .iter()
        .map(|c| (c.topic.as_str(), c.messages as usize))
        .collect();
    assert_eq!(reported, expected);
    assert_eq!((summary.ticks, summary.robots), (5, 3));
    assert!(summary.warnings.is_empty(), "{:?}", summary.warnings);

    // Robot 1 at tick 3, from /tf and from its scene entity.
    let (t, tf) = &rb.messages[TF_TOPIC][3];
    assert_eq!(*t, 3 * dt_ns);
    let tr = tf["transforms"]
        .as_array()
        .unwrap()
        .iter()
        .find(|t| t["child_frame_id"] == "robot_1")
        .unwrap();
    assert_eq!(tr["parent_frame_id"], WORLD_FRAME);
    let (x, y, th) = pose_of(1, 3);
    assert!((tr["translation"]["x"].as_f64().unwrap() - x).abs() < 1e-6);
    assert!((tr["translation"]["y"].as_f64().unwrap() - y).abs() < 1e-6);
    assert!((yaw(&tr["rotation"]) - th).abs() < 1e-6);
    assert_eq!(
        tr["timestamp"]["sec"].as_u64().unwrap() * 1_000_000_000
            + tr["timestamp"]["nsec"].as_u64().unwrap(),
        3 * dt_ns
    );
    let (_, scene) = &rb.messages[ROBOTS_TOPIC][3];
    let ents = scene["entities"].as_array().unwrap();
    assert_eq!(ents.len(), 3);
    let body = &ents[1]["cylinders"][0];
    assert!((body["pose"]["position"]["x"].as_f64().unwrap() - x).abs() < 1e-6);
    // Down robots are another colour than active ones.
    assert_eq!(ents[2]["metadata"][0]["value"], "down");
    assert_ne!(
        ents[2]["cylinders"][0]["color"],
        ents[0]["cylinders"][0]["color"]
    );

    // The map: bounds, every obstacle, the goal.
    let map = &rb.messages[MAP_TOPIC][0].1;
    let ids: Vec<&str> = map["entities"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e["id"].as_str().unwrap())
        .collect();
    let c = Config::from_toml_str("c", &cfg, &[]).unwrap();
    assert!(!c.map.polygons.is_empty());
    assert_eq!(
        ids.len(),
        1 + c.map.circles.len() + c.map.rectangles.len() + c.map.polygons.len() + c.goals().len()
    );
    assert!(ids.contains(&"bounds") && ids.contains(&"polygon_0") && ids.contains(&"goal_0"));

    // Events: time, level, robot.
    let logs = &rb.messages[EVENTS_TOPIC];
    let collision = logs
        .iter()
        .find(|(_, l)| l["message"].as_str().unwrap().starts_with("collision"))
        .unwrap();
    assert_eq!(collision.0, 3 * dt_ns);
    assert_eq!(collision.1["level"], LOG_WARNING);
    assert_eq!(collision.1["name"], "robot_2");
    assert!(collision.1["message"].as_str().unwrap().contains("robot 1"));
    let level_of = |prefix: &str| {
        logs.iter()
            .find(|(_, l)| l["message"].as_str().unwrap().starts_with(prefix))
            .unwrap_or_else(|| panic!("no {prefix} log"))
            .1["level"]
            .as_u64()
            .unwrap()
    };
    assert_eq!(level_of("died"), 3);
    assert_eq!(level_of("rejected"), 3);
    assert_eq!(level_of("reached"), 2);
    assert_eq!(level_of("fault"), 2);
    assert_eq!(level_of("note"), 1);
    // Log times never go back.
    assert!(logs.windows(2).all(|w| w[0].0 <= w[1].0));

    assert_all_conform(&rb);
}

#[test]
fn an_aerial_run_conforms_and_places_robots_at_their_height() {
    let cfg = config_of("planner_uav3.toml");
    let mut traj = String::from(swarmrt_protocol::records::TRAJECTORY_HEADER_AERIAL);
    for t in 0..3 {
        for i in 0..2 {
            traj += &format!("{t},{i},1.0,{i}.5,{}.25,0.5,0.1,0.0,0.0,1,active\n", t + 1);
        }
    }
    let dir = run_dir(&cfg, &traj, "");
    let (out, _) = export(dir.path());
    let rb = read_back(&out);
    assert_all_conform(&rb);
    let tf = &rb.messages[TF_TOPIC][2].1["transforms"][1];
    assert_eq!(tf["translation"]["z"], 3.25);
    let map = &rb.messages[MAP_TOPIC][0].1["entities"];
    // Floor, ceiling and the verticals; each goal a sphere at its height.
    assert_eq!(map[0]["lines"].as_array().unwrap().len(), 3);
    let goal = map
        .as_array()
        .unwrap()
        .iter()
        .find(|e| e["id"] == "goal_0")
        .unwrap();
    assert_eq!(goal["spheres"].as_array().unwrap().len(), 1);
}

#[test]
fn the_same_run_gives_the_same_bytes() {
    let dir = run_dir(
        &config_of("formation_complex.toml"),
        &ground_trajectory(4),
        EVENTS,
    );
    let a = dir.path().join("a.mcap");
    let b = dir.path().join("b.mcap");
    write_mcap(dir.path(), &a).unwrap();
    write_mcap(dir.path(), &b).unwrap();
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
    assert!(!dir.path().join("a.mcap.partial").exists());
}

#[test]
fn a_torn_run_is_exported_up_to_its_last_whole_tick() {
    // Tick 4 has two of three rows, the second cut short; an event line is cut too.
    let mut traj = ground_trajectory(4);
    traj += "4,0,0.4,1.8,0,0.2,0.1,1,active\n4,1,1.4,1.";
    let events = format!("{EVENTS}{{\"event\":\"reached\",\"ti");
    let dir = run_dir(&config_of("formation_complex.toml"), &traj, &events);
    let (out, summary) = export(dir.path());
    assert_eq!(summary.ticks, 4);
    let text = summary.warnings.join("\n");
    assert!(text.contains("up to tick 3"), "{text}");
    assert!(text.contains("events.jsonl: 1 line"), "{text}");
    // Events after tick 3 (the reached and died of tick 4) are left out.
    assert!(text.contains("2 event(s) after tick 3"), "{text}");
    let rb = read_back(&out);
    assert_eq!(rb.messages[TF_TOPIC].len(), 4);
    assert_eq!(rb.messages[EVENTS_TOPIC].len(), 4);

    // A file that ends in a newline after a short last tick is torn too.
    let traj = ground_trajectory(3) + "3,0,0.3,1.85,0,0.2,0.1,1,active\n";
    let dir = run_dir(&config_of("formation_complex.toml"), &traj, EVENTS);
    let (_, summary) = export(dir.path());
    assert_eq!(summary.ticks, 3);
    assert_eq!(summary.warnings.len(), 2, "{:?}", summary.warnings);
}

#[test]
fn a_directory_that_is_not_a_run_is_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.mcap");
    let bad = |dir: &Path| {
        let e = write_mcap(dir, &out).unwrap_err();
        let msg = e
            .downcast_ref::<BadInput>()
            .unwrap_or_else(|| panic!("not BadInput: {e:#}"))
            .to_string();
        assert!(!msg.contains('\n'), "{msg}");
        msg
    };
    assert!(bad(dir.path()).contains("config.toml"));
    assert!(bad(&dir.path().join("nope")).contains("no such"));
    std::fs::write(dir.path().join("config.toml"), "x").unwrap();
    assert!(bad(dir.path()).contains("trajectory.csv"));
    std::fs::write(dir.path().join("trajectory.csv"), "a,b\n").unwrap();
    bad(dir.path());
    std::fs::write(
        dir.path().join("config.toml"),
        config_of("formation_complex.toml"),
    )
    .unwrap();
    assert!(bad(dir.path()).contains("`tick`"));
    assert!(!out.exists());
}

#[test]
fn the_schema_check_refuses_missing_extra_and_mistyped_fields() {
    let schema: Value = serde_json::from_str(LOG_SCHEMA).unwrap();
    let good = log_message(
        &EventLine {
            line: 1,
            tick: 2,
            event: Logged::of(serde_json::json!({"event": "reached", "tick": 2, "robot": 4})),
        },
        7,
    );
    conforms(&schema, &good, "log").unwrap();
    let mut missing = good.clone();
    missing.as_object_mut().unwrap().remove("file");
    assert!(conforms(&schema, &missing, "log").is_err());
    let mut extra = good.clone();
    extra["robot"] = 4.into();
    assert!(conforms(&schema, &extra, "log").is_err());
    let mut level = good.clone();
    level["level"] = 9.into();
    assert!(conforms(&schema, &level, "log").is_err());
    let mut nsec = good;
    nsec["timestamp"]["nsec"] = "7".into();
    assert!(conforms(&schema, &nsec, "log").is_err());
}
