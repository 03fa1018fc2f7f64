//! The viewer overlay of each behaviour (`behaviours/<name>/overlay.rs`) and of the consensus
//! layer (`overlay/lane.rs`), through the registry's type-erased [`Plugin`] and with every
//! note rendered exactly as the world records it (postcard report -> `VOCABULARY` -> JSON).

use std::path::Path;

use serde_json::Value;
use swarmrt_agent::Note;
use swarmrt_agent::behaviours::chain::{ChainNote, VetoWhy};
use swarmrt_agent::behaviours::formation::FormationNote;
use swarmrt_agent::behaviours::grouping::GroupNote;
use swarmrt_agent::behaviours::planner::{HoverWhy, PlanNote};
use swarmrt_agent::consensus::{ConsensusNote, Role};
use swarmrt_agent::overlay::lane::{self, lane_change};
use swarmrt_agent::overlay::{Headline, LaneChange};
use swarmrt_agent::registry::{self, BEHAVIOURS, Plugin, VOCABULARY};
use swarmrt_scenario::Config;

/// `note` as its `note` field in `events.jsonl`: encoded into a report as a robot sends it,
/// decoded and rendered by the world's vocabulary.
fn recorded(note: Note) -> Value {
    let report = postcard::to_allocvec(&vec![note]).unwrap();
    let notes = (VOCABULARY.read_notes)(&report).unwrap();
    assert_eq!(notes.len(), 1);
    serde_json::from_str(notes[0].json.get()).unwrap()
}

fn config(name: &str, overrides: &[&str]) -> Config {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../configs")
        .join(name);
    let ov: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    registry::load(&path, &ov).unwrap()
}

fn plugin(cfg: &Config) -> &'static dyn Plugin {
    registry::plugin(&cfg.behaviour.kind).unwrap()
}

/// The role's name, for readable assertions.
fn role_name(p: &dyn Plugin, role: Option<u8>) -> Option<&'static str> {
    role.map(|r| p.roles()[r as usize].name)
}

fn kind(h: Option<Headline>) -> Option<&'static str> {
    h.map(|h| h.kind)
}

/// Robot `id`'s role at the start, with `cfg`'s parameters.
fn initial_role(p: &dyn Plugin, cfg: &Config, id: u32) -> Option<u8> {
    p.configure(cfg).ok()?.initial_role(id)
}

/// Robot `id`'s role after the recorded `note`, decoded once as a viewer reads it.
fn role_after(p: &dyn Plugin, cfg: &Config, id: u32, note: &Value) -> Option<u8> {
    p.configure(cfg).ok()?.role_after(id, &p.read_note(note)?)
}

/// The recorded `note` as a headline.
fn headline(p: &dyn Plugin, note: &Value) -> Option<Headline> {
    p.headline(&p.read_note(note)?)
}

/// The lane change of the recorded `note`.
fn lane_of(p: &dyn Plugin, note: &Value) -> Option<LaneChange> {
    p.lane(&p.read_note(note)?)
}

#[test]
fn notes_are_recorded_as_the_behaviours_own_json_and_consensus_notes_tagged() {
    let veto = ChainNote::Veto {
        master: 5,
        depth: 1,
        why: VetoWhy::Stationary,
    };
    assert_eq!(
        recorded(Note::Chain(veto)),
        serde_json::json!({"veto": {"master": 5, "depth": 1, "why": "stationary"}})
    );
    assert_eq!(
        recorded(Note::Formation(FormationNote::EpsilonFlip)),
        serde_json::json!("epsilon_flip")
    );
    let state = ConsensusNote::State {
        term: 3,
        role: Role::Leader,
        vote: Some(2),
    };
    assert_eq!(
        recorded(Note::Consensus(state)),
        serde_json::json!({"consensus": {"state": {"term": 3, "role": "leader", "vote": 2}}})
    );
}

#[test]
fn every_role_has_a_name_and_a_distinct_css_colour() {
    for p in BEHAVIOURS {
        let roles = p.roles();
        for (k, r) in roles.iter().enumerate() {
            assert!(!r.name.is_empty(), "{}", p.kind());
            let hex = r.colour.strip_prefix('#').unwrap_or("");
            assert!(
                hex.len() == 6 && hex.chars().all(|c| c.is_ascii_hexdigit()),
                "{}: {}",
                p.kind(),
                r.colour
            );
            assert!(
                roles[..k]
                    .iter()
                    .all(|o| o.colour != r.colour && o.name != r.name),
                "{}: {} repeats",
                p.kind(),
                r.name
            );
        }
    }
}

#[test]
fn chain_roles_follow_the_structure_and_vetoes() {
    let cfg = config("chain_stationary.toml", &[]);
    let p = plugin(&cfg);
    let initial = |id| role_name(p, initial_role(p, &cfg, id));
    // Robot 0 is the head (the initiator by default), 6 is stationary, 11 ends the chain.
    assert_eq!(initial(0), Some("initiator"));
    assert_eq!(initial(1), Some("master"));
    assert_eq!(initial(6), Some("stationary"));
    assert_eq!(initial(11), Some("end slave"));
    // A middle initiator has two sub-chains: both ends are end slaves, its neighbours masters.
    let mid = config("chain_stationary.toml", &["behaviour.initiator=5"]);
    assert_eq!(role_name(p, initial_role(p, &mid, 5)), Some("initiator"));
    assert_eq!(role_name(p, initial_role(p, &mid, 4)), Some("master"));
    assert_eq!(role_name(p, initial_role(p, &mid, 0)), Some("end slave"));
    assert_eq!(role_name(p, initial_role(p, &mid, 11)), Some("end slave"));

    let veto = recorded(Note::Chain(ChainNote::Veto {
        master: 5,
        depth: 1,
        why: VetoWhy::Stationary,
    }));
    assert_eq!(role_name(p, role_after(p, &cfg, 6, &veto)), Some("vetoing"));
    let h = headline(p, &veto).unwrap();
    assert_eq!(h.kind, "veto");
    assert_eq!(h.others, vec![5], "the master it vetoes");
    assert!(
        h.text.contains("master 5") && h.text.contains("stationary"),
        "{}",
        h.text
    );

    let replan = recorded(Note::Chain(ChainNote::Replan {
        depth: 6,
        turn_deg: -45.0,
    }));
    assert_eq!(
        role_name(p, role_after(p, &cfg, 0, &replan)),
        Some("initiator")
    );
    let h = headline(p, &replan).unwrap();
    assert_eq!(h.kind, "replan");
    assert!(
        h.text.contains("6 robot") && h.text.contains("right"),
        "{}",
        h.text
    );
    // Not a chain note: no role, no headline.
    let other = recorded(Note::Formation(FormationNote::EpsilonFlip));
    assert_eq!(role_after(p, &cfg, 0, &other), None);
    assert_eq!(headline(p, &other), None);
}

#[test]
fn formation_roles_are_the_observers_and_turns_are_headlines() {
    let cfg = config("formation_deadlock.toml", &[]);
    let p = plugin(&cfg);
    assert_eq!(role_name(p, initial_role(p, &cfg, 3)), Some("lidar off"));
    let role = |r| {
        role_after(
            p,
            &cfg,
            0,
            &recorded(Note::Formation(FormationNote::Role { role: r })),
        )
    };
    assert_eq!(role_name(p, role(1)), Some("front observer (leads)"));
    assert_eq!(role_name(p, role(2)), Some("left observer"));
    assert_eq!(role_name(p, role(3)), Some("right observer"));
    assert_eq!(role_name(p, role(0)), Some("lidar off"));
    assert_eq!(
        role_name(p, role(9)),
        Some("lidar off"),
        "unknown reads as none"
    );

    let flip = recorded(Note::Formation(FormationNote::EpsilonFlip));
    assert_eq!(role_after(p, &cfg, 0, &flip), None);
    assert_eq!(kind(headline(p, &flip)), Some("epsilon_flip"));
    let turn = headline(
        p,
        &recorded(Note::Formation(FormationNote::Turn { dir: 1 })),
    )
    .unwrap();
    assert_eq!(
        (turn.kind, turn.text.as_str()),
        ("turn", "turns the swarm left")
    );
    assert_eq!(
        headline(
            p,
            &recorded(Note::Formation(FormationNote::Role { role: 1 }))
        ),
        None
    );
}

#[test]
fn flocks_are_the_start_groups() {
    let cfg = config("flocking_crossing.toml", &[]);
    let p = plugin(&cfg);
    let groups = cfg.start_group_count();
    assert!(groups >= 2, "a config with two flocks");
    let last = cfg.robots.count - 1;
    assert_eq!(role_name(p, initial_role(p, &cfg, 0)), Some("flock 0"));
    let want = format!("flock {}", groups - 1);
    assert_eq!(
        role_name(p, initial_role(p, &cfg, last)),
        Some(want.as_str())
    );
    for id in 0..cfg.robots.count {
        assert_eq!(
            initial_role(p, &cfg, id),
            Some(cfg.start_group(id) as u8),
            "robot {id}"
        );
    }
    // Explicit group sizes move the boundary.
    let sized = config(
        "flocking_crossing.toml",
        &[&format!(
            "robots.start.group_sizes=[1, {}]",
            cfg.robots.count - 1
        )],
    );
    assert_eq!(role_name(p, initial_role(p, &sized, 0)), Some("flock 0"));
    assert_eq!(role_name(p, initial_role(p, &sized, 1)), Some("flock 1"));
}

#[test]
fn grouping_roles_lanes_and_headlines() {
    let cfg = config("grouping_s1.toml", &[]);
    let p = plugin(&cfg);
    assert_eq!(role_name(p, initial_role(p, &cfg, 2)), Some("alone"));
    let g = |n| recorded(Note::Grouping(n));
    let after = |n| role_name(p, role_after(p, &cfg, 2, &g(n)));
    assert_eq!(after(GroupNote::Clustered), Some("clustered"));
    let leads = GroupNote::Leader {
        leader: 2,
        leads: true,
        score: 4,
        changes: 0,
    };
    let follows = GroupNote::Leader {
        leader: 7,
        leads: false,
        score: 1,
        changes: 1,
    };
    assert_eq!(after(leads.clone()), Some("leader"));
    assert_eq!(after(follows.clone()), Some("member"));
    assert_eq!(after(GroupNote::GoalSeen), Some("leader, goal known"));
    assert_eq!(after(GroupNote::GoalTold), Some("leader, goal known"));
    assert_eq!(after(GroupNote::Arrived), Some("arrived"));
    assert_eq!(after(GroupNote::Formed { n: 5 }), None);

    // The group is the leader followed, the same lane as a consensus quadrant note's.
    let lane_follows = lane_of(p, &g(follows.clone())).unwrap();
    assert_eq!(lane_follows.leader, Some(7));
    assert_eq!(lane_follows.role, Some("follower"));
    let quad = recorded(Note::Consensus(ConsensusNote::Quadrant {
        leader: 7,
        leads: false,
        score: 1,
    }));
    assert_eq!(lane_of(p, &quad), Some(lane_follows));
    assert_eq!(lane_of(p, &g(leads.clone())).unwrap().role, Some("leader"));

    assert_eq!(kind(headline(p, &g(leads))), Some("leader"));
    assert_eq!(headline(p, &g(follows)), None);
    assert_eq!(
        kind(headline(p, &g(GroupNote::GoalSeen))),
        Some("goal_seen")
    );
    assert_eq!(
        kind(headline(p, &g(GroupNote::GoalTold))),
        Some("goal_told")
    );
    assert_eq!(kind(headline(p, &g(GroupNote::Arrived))), Some("arrived"));
    assert_eq!(headline(p, &g(GroupNote::Clustered)), None);
}

#[test]
fn planner_vehicles_hover_fly_and_arrive() {
    let cfg = config("planner_uav3.toml", &[]);
    let p = plugin(&cfg);
    assert_eq!(role_name(p, initial_role(p, &cfg, 1)), Some("hovering"));
    let n = |n| recorded(Note::Planner(n));
    let after = |id, note| role_name(p, role_after(p, &cfg, id, &n(note)));
    let plan = 2 << 12 | 1; // plan 1 of term 2
    assert_eq!(after(1, PlanNote::Flying { plan }), Some("in flight"));
    let hover = PlanNote::Hover {
        plan,
        why: HoverWhy::Lost,
    };
    assert_eq!(after(1, hover), Some("hovering"));
    assert_eq!(after(1, PlanNote::Arrived), Some("arrived"));
    let no_route = PlanNote::NoRoute { plan, vehicle: 2 };
    assert_eq!(
        after(0, no_route),
        None,
        "the leader's note about vehicle 2"
    );
    assert_eq!(
        after(2, no_route),
        Some("no route"),
        "the leader is vehicle 2"
    );

    let h = headline(p, &n(no_route)).unwrap();
    assert_eq!((h.kind, h.others.clone()), ("no_route", vec![2]));
    assert!(h.text.contains("plan 1 of term 2"), "{}", h.text);
    let planned = PlanNote::Planned {
        plan,
        vehicle: 1,
        start_slot: 3,
        moves: 12,
        cost: 14.5,
        expansions: 99,
    };
    assert_eq!(after(0, planned), None);
    let h = headline(p, &n(planned)).unwrap();
    assert_eq!((h.kind, h.others.clone()), ("replan", vec![1]));
    let h = headline(p, &n(hover)).unwrap();
    assert_eq!(h.kind, "hover");
    assert!(h.text.contains("silent"), "{}", h.text);
    assert_eq!(kind(headline(p, &n(PlanNote::Arrived))), Some("arrived"));
    assert_eq!(headline(p, &n(PlanNote::Flying { plan })), None);
}

#[test]
fn goto_has_no_overlay() {
    let cfg = config("goto_simple.toml", &[]);
    let p = plugin(&cfg);
    assert!(p.roles().is_empty());
    assert_eq!(initial_role(p, &cfg, 0), None);
}

#[test]
fn consensus_state_boot_and_commit_change_the_lane() {
    let leader = ConsensusNote::State {
        term: 3,
        role: Role::Leader,
        vote: Some(1),
    };
    let want = LaneChange {
        role: Some("leader"),
        term: Some(3),
        ..LaneChange::default()
    };
    assert_eq!(lane_change(&leader), Some(want));
    // The same from the recorded JSON, directly and through any behaviour's plugin.
    let json = recorded(Note::Consensus(leader.clone()));
    assert_eq!(lane::from_json(&json), Some(leader));
    let cfg = config("raft_election.toml", &[]);
    for &p in BEHAVIOURS {
        assert_eq!(lane_of(p, &json), Some(want), "{}", p.kind());
        let h = headline(p, &json).unwrap();
        assert_eq!((h.kind, h.text.as_str()), ("elected", "leader of term 3"));
        assert_eq!(
            role_after(p, &cfg, 0, &json),
            None,
            "not a behaviour's note"
        );
    }
    let pre = ConsensusNote::State {
        term: 4,
        role: Role::PreCandidate,
        vote: None,
    };
    assert_eq!(lane_change(&pre).unwrap().role, Some("pre_candidate"));
    assert_eq!(lane::headline(&pre), None);
    let boot = ConsensusNote::Boot {
        term: 7,
        vote: Some(2),
        last_index: 9,
        commit: 5,
    };
    assert_eq!(
        lane_change(&boot),
        Some(LaneChange {
            role: Some("follower"),
            term: Some(7),
            commit: Some(5),
            leader: None,
        })
    );
    let commit = recorded(Note::Consensus(ConsensusNote::Commit { index: 12 }));
    assert_eq!(
        lane::from_json(&commit).as_ref().and_then(lane_change),
        Some(LaneChange {
            commit: Some(12),
            ..LaneChange::default()
        })
    );
    let apply = ConsensusNote::Apply {
        index: 1,
        term: 1,
        digest: 0,
    };
    assert_eq!(lane_change(&apply), None);
    // A quadrant leader declaring itself leads its own group.
    let quad = ConsensusNote::Quadrant {
        leader: 4,
        leads: true,
        score: 3,
    };
    assert_eq!(
        lane_change(&quad),
        Some(LaneChange {
            role: Some("leader"),
            leader: Some(4),
            ..LaneChange::default()
        })
    );
    assert_eq!(lane::headline(&quad).map(|h| h.kind), Some("leader"));
    // A behaviour's note is not a consensus note.
    assert_eq!(lane::from_json(&serde_json::json!("epsilon_flip")), None);
}

/// Replays the note events of a real `events.jsonl` (the head of `swarm run <config>
/// --in-process`, kept in `tests/data/`) as a viewer would: each robot from its initial
/// role, changed by its own notes. Returns the role changes `(tick, robot, role name)` and
/// the headlines `(tick, robot, kind, others)`.
#[allow(clippy::type_complexity)]
fn replay(
    config_name: &str,
    events: &str,
) -> (
    Vec<(u64, u32, &'static str)>,
    Vec<(u64, u32, &'static str, Vec<u32>)>,
) {
    let cfg = config(config_name, &[]);
    let p = plugin(&cfg);
    let configured = p.configure(&cfg).unwrap();
    let mut roles: Vec<Option<u8>> = (0..cfg.robots.count)
        .map(|id| configured.initial_role(id))
        .collect();
    let (mut changes, mut headlines) = (Vec::new(), Vec::new());
    for line in events.lines() {
        let e: Value = serde_json::from_str(line).unwrap();
        if e["event"] != "note" {
            continue;
        }
        let (tick, robot) = (
            e["tick"].as_u64().unwrap(),
            e["robot"].as_u64().unwrap() as u32,
        );
        // Decoded once, as a viewer reads it.
        let Some(note) = p.read_note(&e["note"]) else {
            continue;
        };
        if let Some(r) = configured.role_after(robot, &note)
            && roles[robot as usize] != Some(r)
        {
            roles[robot as usize] = Some(r);
            changes.push((tick, robot, p.roles()[r as usize].name));
        }
        if let Some(h) = p.headline(&note) {
            headlines.push((tick, robot, h.kind, h.others));
        }
    }
    (changes, headlines)
}

#[test]
fn a_recorded_chain_run_shows_the_veto_travelling_back_and_the_head_replanning() {
    let events = include_str!("../data/chain_stationary.events.jsonl");
    let (changes, headlines) = replay("chain_stationary.toml", events);
    // Robot 6 (stationary) objects first, then 5 .. 1 pass the veto on towards the head.
    let vetoing: Vec<u32> = changes
        .iter()
        .filter(|c| c.2 == "vetoing")
        .map(|c| c.1)
        .take(6)
        .collect();
    assert_eq!(vetoing, vec![6, 5, 4, 3, 2, 1], "{changes:?}");
    let first = &headlines[0];
    assert_eq!((first.1, first.2, first.3.clone()), (6, "veto", vec![5]));
    assert!(
        headlines.iter().any(|h| h.1 == 0 && h.2 == "replan"),
        "{headlines:?}"
    );
}

#[test]
fn a_recorded_formation_run_picks_observers_and_flips() {
    let events = include_str!("../data/formation_deadlock.events.jsonl");
    let (changes, headlines) = replay("formation_deadlock.toml", events);
    assert!(
        changes.iter().any(|c| c.2 == "front observer (leads)"),
        "{changes:?}"
    );
    assert!(
        changes.iter().any(|c| c.2 == "left observer"),
        "{changes:?}"
    );
    assert!(headlines.iter().any(|h| h.2 == "turn"), "{headlines:?}");
    assert!(
        headlines.iter().any(|h| h.2 == "epsilon_flip"),
        "{headlines:?}"
    );
}
