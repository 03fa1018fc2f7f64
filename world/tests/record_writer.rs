//! The record writer thread writes the same bytes as the in-line recorder, in order, and
//! everything handed over is on disk once it is finished or dropped.

use swarmrt_protocol::{Command, Observation, Vocabulary};
use swarmrt_scenario::Config;
use swarmrt_world::records::{RecordWriter, Recorder};
use swarmrt_world::{Event, World};

fn config() -> Config {
    Config::from_toml_str(
        "writer.toml",
        r#"
            [scenario]
            name = "writer"
            ticks = 30
            [map]
            bounds = [0.0, 0.0, 10.0, 10.0]
            goal = { x = 3.5, y = 3.0, radius = 1.0 }
            [robots]
            count = 3
            start = { x = 2.0, y = 2.0, spacing = 1.0 }
        "#,
        &[],
    )
    .unwrap()
}

/// Runs 30 ticks with every robot driving and turning, recording through `record`.
fn run(mut record: impl FnMut(u64, &World, Vec<Event>)) {
    let cfg = config();
    let mut world = World::new(&cfg, Vocabulary::ANY).unwrap();
    let mut obs = vec![Observation::empty(0, 0); 3];
    let events = world.drain_events();
    record(world.tick(), &world, events);
    for t in 0..30u64 {
        world.observe(&mut obs);
        let commands: Vec<Option<Command>> = (0..3u32)
            .map(|r| {
                let mut c = Command::act(r, t);
                c.v = 0.5;
                c.omega = 0.3 * r as f64;
                Some(c)
            })
            .collect();
        world.step(&commands);
        let events = world.drain_events();
        record(world.tick(), &world, events);
    }
}

#[test]
fn the_writer_thread_writes_what_the_recorder_writes() {
    let inline = tempfile::tempdir().unwrap();
    let mut rec = Recorder::create(
        &swarmrt_scenario::safe_fs::OutDir::open(inline.path()).unwrap(),
        false,
    )
    .unwrap();
    run(|tick, w, events| rec.record(tick, w.robots(), &events).unwrap());

    let threaded = tempfile::tempdir().unwrap();
    let mut writer = RecordWriter::create(
        &swarmrt_scenario::safe_fs::OutDir::open(threaded.path()).unwrap(),
        false,
    )
    .unwrap();
    run(|tick, w, events| writer.record(tick, w.robots(), events).unwrap());
    writer.finish().unwrap();

    for file in ["trajectory.csv", "events.jsonl"] {
        let a = std::fs::read(inline.path().join(file)).unwrap();
        let b = std::fs::read(threaded.path().join(file)).unwrap();
        assert_eq!(a, b, "{file} differs");
    }
    let csv = std::fs::read_to_string(threaded.path().join("trajectory.csv")).unwrap();
    // Header, then 31 ticks of 3 robots.
    assert_eq!(csv.lines().count(), 1 + 31 * 3);
    assert!(csv.lines().last().unwrap().starts_with("30,2,"));
    let events = std::fs::read_to_string(threaded.path().join("events.jsonl")).unwrap();
    assert!(
        events.contains("reached"),
        "the goal next to the start is reached: {events}"
    );
}

#[test]
fn dropping_the_writer_still_writes_everything_handed_over() {
    let dir = tempfile::tempdir().unwrap();
    {
        let mut writer = RecordWriter::create(
            &swarmrt_scenario::safe_fs::OutDir::open(dir.path()).unwrap(),
            false,
        )
        .unwrap();
        run(|tick, w, events| writer.record(tick, w.robots(), events).unwrap());
        // No finish: an error return out of the world shell drops the writer.
    }
    let csv = std::fs::read_to_string(dir.path().join("trajectory.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 31 * 3);
}
