//! Each behaviour's metrics read its notes typed: notes written as a robot's report is
//! recorded (`Note::to_json` inside a `note` event) read back through the metric path, a
//! consensus note among them is left to the consensus checker, and a note whose fields this
//! build does not know (a renamed field) is left out rather than read as a default.

use serde_json::{Value, json};
use swarmrt_agent::behaviours::chain::{ChainNote, VetoWhy};
use swarmrt_agent::behaviours::formation::FormationNote;
use swarmrt_agent::behaviours::grouping::GroupNote;
use swarmrt_agent::behaviours::planner::{HoverWhy, PlanNote};
use swarmrt_agent::consensus::{ConsensusNote, RecordedNote, Role};
use swarmrt_agent::registry::{self, Note};
use swarmrt_protocol::NoteJson;
use swarmrt_protocol::records::{Event, Records};
use swarmrt_scenario::Config;

const HEADER: &str = "tick,id,x,y,theta,v,omega,lidar,state\n";

/// One `events.jsonl` line as the world writes a note.
fn line(tick: u64, robot: u32, note: &Note) -> String {
    let e: Event<NoteJson> = Event::Note {
        tick,
        robot,
        note: NoteJson::new(note.to_json()).unwrap(),
    };
    serde_json::to_string(&e).unwrap()
}

/// A note in the form of a build whose note type had other fields.
fn foreign(tick: u64, robot: u32, note: &str) -> String {
    format!(r#"{{"event":"note","tick":{tick},"robot":{robot},"note":{note}}}"#)
}

/// A consensus note, which every behaviour's records may hold.
fn consensus(tick: u64, robot: u32) -> String {
    let state = ConsensusNote::State {
        term: 1,
        role: Role::Leader,
        vote: Some(robot),
    };
    line(tick, robot, &Note::Consensus(state))
}

fn records(lines: &[String]) -> Records {
    Records::parse(HEADER, &lines.join("\n")).unwrap()
}

fn config(name: &str, text: &str) -> Config {
    registry::from_toml_str(name, text, &[]).unwrap()
}

fn metric(cfg: &Config, rec: &Records, key: &str) -> Value {
    let m = registry::configure(cfg).unwrap().metrics(rec);
    m.into_iter().find(|(k, _)| *k == key).unwrap().1
}

#[test]
fn recorded_notes_decode_as_consensus_or_the_behaviours_own() {
    let flip = Note::Formation(FormationNote::EpsilonFlip).to_json();
    let flip: Value = serde_json::from_str(&flip).unwrap();
    assert_eq!(flip, json!("epsilon_flip"), "a behaviour's note as itself");
    assert_eq!(
        RecordedNote::<FormationNote>::from_json(&flip).unwrap(),
        RecordedNote::Behaviour(FormationNote::EpsilonFlip)
    );
    let commit = ConsensusNote::Commit { index: 4 };
    let tagged: Value = serde_json::from_str(&Note::Consensus(commit.clone()).to_json()).unwrap();
    assert_eq!(tagged, json!({"consensus": {"commit": {"index": 4}}}));
    assert_eq!(
        RecordedNote::<FormationNote>::from_json(&tagged).unwrap(),
        RecordedNote::Consensus(commit)
    );
    assert!(RecordedNote::<FormationNote>::from_json(&json!({"consensus": {"nope": 1}})).is_err());
    assert!(RecordedNote::<FormationNote>::from_json(&json!({"turn": {"direction": 1}})).is_err());
}

#[test]
fn chain_metrics_read_veto_and_replan_notes() {
    let cfg = config(
        "chain_stationary.toml",
        include_str!("../../../configs/chain_stationary.toml"),
    );
    let veto = |master, depth, why| Note::Chain(ChainNote::Veto { master, depth, why });
    let rec = records(&[
        line(10, 7, &veto(6, 1, VetoWhy::Stationary)),
        consensus(11, 3),
        line(12, 8, &veto(7, 2, VetoWhy::Passed)),
        foreign(13, 9, r#"{"veto":{"master":8,"hops":3,"why":"passed"}}"#),
        line(
            14,
            9,
            &Note::Chain(ChainNote::Replan {
                depth: 3,
                turn_deg: 90.0,
            }),
        ),
        line(20, 2, &veto(1, 1, VetoWhy::Trapped)),
    ]);
    let m = metric(&cfg, &rec, "chain");
    assert_eq!(m["vetoes"], 2, "{m}");
    assert_eq!(m["veto_depth"], 3, "{m}");
    assert_eq!(m["replans"], 1, "{m}");
    let series = registry::configure(&cfg).unwrap().series(&rec);
    let vetoes = series.iter().find(|s| s.name == "chain_vetoes").unwrap();
    let rows: Vec<[f64; 3]> = vetoes.rows.iter().map(|r| [r[2], r[3], r[4]]).collect();
    // (robot, depth, event): the re-plan belongs to the first veto, the second opens another.
    assert_eq!(
        rows,
        [
            [7.0, 1.0, 1.0],
            [8.0, 2.0, 1.0],
            [9.0, 3.0, 1.0],
            [2.0, 1.0, 2.0]
        ]
    );
}

#[test]
fn formation_counts_epsilon_flip_notes() {
    let cfg = config(
        "formation_simple.toml",
        include_str!("../../../configs/formation_simple.toml"),
    );
    let note = |n| Note::Formation(n);
    let rec = records(&[
        line(1, 0, &note(FormationNote::Role { role: 2 })),
        line(2, 0, &note(FormationNote::EpsilonFlip)),
        line(2, 1, &note(FormationNote::Turn { dir: -1 })),
        foreign(3, 1, r#""epsilon_flop""#),
        consensus(3, 2),
        line(4, 3, &note(FormationNote::EpsilonFlip)),
    ]);
    assert_eq!(metric(&cfg, &rec, "epsilon_flips"), 2);
}

#[test]
fn grouping_metrics_read_leader_formed_goal_and_classifier_notes() {
    let cfg = config(
        "grouping_s1.toml",
        include_str!("../../../configs/grouping_s1.toml"),
    );
    let dt = cfg.scenario.dt;
    let leader = |leader, leads, changes| {
        Note::Grouping(GroupNote::Leader {
            leader,
            leads,
            score: 2,
            changes,
        })
    };
    let mut lines = vec![
        line(5, 0, &leader(0, true, 1)),
        line(5, 1, &leader(0, false, 2)),
        line(5, 2, &leader(0, false, 0)),
        line(6, 0, &Note::Grouping(GroupNote::Formed { n: 3 })),
        line(9, 0, &Note::Grouping(GroupNote::Formed { n: 3 })),
        line(
            10,
            1,
            &Note::Grouping(GroupNote::Classified {
                correct: 3,
                wrong: 1,
            }),
        ),
        consensus(11, 4),
        foreign(
            12,
            3,
            r#"{"leader":{"leader":0,"leads":true,"score":1,"rounds":4}}"#,
        ),
        line(18, 0, &Note::Grouping(GroupNote::GoalTold)),
        line(20, 0, &Note::Grouping(GroupNote::GoalSeen)),
    ];
    lines.push(r#"{"event":"reached","tick":30,"robot":1}"#.to_string());
    lines.push(r#"{"event":"collision","tick":31,"robot":2,"other":1}"#.to_string());
    let g = metric(&cfg, &records(&lines), "grouping");
    assert_eq!(g["groups"], 1, "{g}");
    assert_eq!(g["leaders"], 1, "{g}");
    assert_eq!(g["tie_rounds"], 3, "{g}");
    assert_eq!(g["precision"], 0.75, "{g}");
    assert_eq!(g["collisions"], 1, "{g}");
    let group = &g["per_group"][0];
    assert_eq!(group["leader"], 0, "{g}");
    assert_eq!(group["robots"], 3, "{g}");
    assert_eq!(group["found_goal"], "told", "{g}");
    assert_eq!(group["explore_time"], json!(12.0 * dt), "{g}");
    assert_eq!(group["collisions"], 2, "{g}");
    assert_eq!(g["per_robot"][1]["t_nav"], json!(24.0 * dt), "{g}");
    assert_eq!(g["per_robot"][3]["leader"], Value::Null, "{g}");
}

#[test]
fn planner_metrics_read_plan_notes_with_costs_as_recorded() {
    let cfg = config(
        "planner_uav3.toml",
        include_str!("../../../configs/planner_uav3.toml"),
    );
    let planned = |plan, vehicle, cost, expansions| {
        Note::Planner(PlanNote::Planned {
            plan,
            vehicle,
            start_slot: 2,
            moves: 10,
            cost,
            expansions,
        })
    };
    let rec = records(&[
        line(1, 0, &planned(0, 0, 12.1, 50)),
        line(1, 0, &planned(0, 1, 0.1, 70)),
        line(
            1,
            0,
            &Note::Planner(PlanNote::NoRoute {
                plan: 0,
                vehicle: 2,
            }),
        ),
        consensus(2, 0),
        line(3, 1, &Note::Planner(PlanNote::Flying { plan: 0 })),
        line(
            9,
            1,
            &Note::Planner(PlanNote::Hover {
                plan: 0,
                why: HoverWhy::Lost,
            }),
        ),
        foreign(
            9,
            0,
            r#"{"planned":{"plan":1,"vehicle":0,"start":9,"moves":4,"cost":3.0,"expansions":9}}"#,
        ),
        line(10, 0, &planned(1, 0, 4.5, 9)),
        line(12, 0, &Note::Planner(PlanNote::Arrived)),
    ]);
    let p = metric(&cfg, &rec, "planner");
    assert_eq!(p["plans"], 2, "{p}");
    assert_eq!(p["replans"], 1, "{p}");
    assert_eq!(p["no_route"], 1, "{p}");
    assert_eq!(p["hovers"], 1, "{p}");
    // The costs as the record holds them (12.1 and 0.1), not the f32s widened.
    assert_eq!(p["route_cost"], json!(12.1 + 0.1), "{p}");
    assert_eq!(p["expansions"], json!(120.0), "{p}");
    assert_eq!(
        p["routes"][1],
        json!({"plan": 0, "vehicle": 1, "start_slot": 2, "moves": 10, "cost": 0.1, "expansions": 70}),
        "{p}"
    );
    assert_eq!(p["routes"].as_array().unwrap().len(), 3, "{p}");
}
