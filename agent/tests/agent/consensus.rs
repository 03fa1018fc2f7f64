//! The consensus layer inside the agent: robots act only on applied decisions, notes and
//! frames stay within their budgets, a knocked-down robot decides nothing.

use swarmrt_agent::Agent;
use swarmrt_agent::consensus::persist::Persistent;
use swarmrt_agent::consensus::{ConsensusMsg, ConsensusNote, Item, Role};
use swarmrt_agent::{Note, RadioMsg};
use swarmrt_protocol::{BROADCAST, MAX_REPORT, Neighbour, Observation, RobotState};
use swarmrt_scenario::Config;

fn config(extra: &str) -> Config {
    Config::from_toml_str(
        "c.toml",
        &format!(
            r#"
[scenario]
name = "c"
ticks = 1000
[map]
bounds = [0.0, 0.0, 20.0, 20.0]
goal = {{ x = 18.0, y = 2.0, radius = 1.0 }}
[robots]
count = 1
lidar = {{ rays = 5, fov_deg = 180.0, range = 3.0 }}
[behaviour]
kind = "goto"
beacon_period = 0
{extra}
"#
        ),
        &[],
    )
    .unwrap()
}

fn obs(tick: u64) -> Observation {
    let mut o = Observation::empty(0, tick);
    o.x = 2.0;
    o.y = 2.0;
    o.lidar_len = 5;
    o.lidar[..5].fill(3.0);
    o
}

fn consensus_notes(cmd: &swarmrt_protocol::Command) -> Vec<ConsensusNote> {
    cmd.notes()
        .unwrap()
        .into_iter()
        .filter_map(|n| match n {
            Note::Consensus(c) => Some(c),
            _ => None,
        })
        .collect()
}

#[test]
fn a_lone_robot_turns_to_the_new_goal_only_once_the_decision_is_applied() {
    let cfg = config(
        r#"
[consensus]
[[consensus.propose]]
tick = 100
goal = [2.0, 18.0]
"#,
    );
    let mut a = Agent::new(&cfg, 0);
    let first = a.step(&obs(0)).without_storage();
    assert!(
        matches!(
            consensus_notes(&first)[0],
            ConsensusNote::Boot { term: 0, .. }
        ),
        "the first note reports the starting state"
    );
    let mut applied_at = None;
    for t in 1..200 {
        let cmd = a.step(&obs(t)).without_storage();
        let notes = consensus_notes(&cmd);
        if notes
            .iter()
            .any(|n| matches!(n, ConsensusNote::Apply { index: 2, .. }))
        {
            applied_at = Some(t);
        }
        let heading_to_new_goal = cmd.omega > 0.0; // (2, 18) is to the left of heading 0
        match applied_at {
            None => assert!(
                cmd.omega.abs() < 1e-9,
                "tick {t}: still straight to (18, 2): {cmd:?}"
            ),
            Some(_) => assert!(heading_to_new_goal, "tick {t}: turns left: {cmd:?}"),
        }
        assert!(cmd.outbox().is_empty(), "a group of one sends nothing");
    }
    // Leader of its group of one, it proposed at tick 100 and applied right away.
    assert_eq!(applied_at, Some(100));
    let r = a.consensus().unwrap().raft().unwrap();
    assert_eq!((r.role(), r.commit(), r.applied()), (Role::Leader, 2, 2));
}

#[test]
fn frames_and_notes_stay_within_capacity_and_report() {
    // Five agents wired directly (every frame delivered next tick): a busy election.
    let cfg = Config::from_toml_str(
        "c.toml",
        r#"
[scenario]
name = "c"
ticks = 1000
[map]
bounds = [0.0, 0.0, 20.0, 20.0]
goal = { x = 18.0, y = 2.0, radius = 1.0 }
[robots]
count = 5
[radio]
capacity = 2
[behaviour]
kind = "goto"
beacon_period = 3
[consensus]
election_timeout_min = 6
election_timeout_max = 9
heartbeat_ticks = 1
stats_every = 1
[[consensus.propose]]
tick = 40
speed = 0.3
[[consensus.propose]]
tick = 41
goal = [5.0, 5.0]
"#,
        &[],
    )
    .unwrap();
    let mut agents: Vec<Agent> = (0..5).map(|i| Agent::new(&cfg, i)).collect();
    let mut wire: Vec<swarmrt_protocol::Frame> = Vec::new();
    let mut leaders = 0;
    for t in 0..150 {
        let mut next = Vec::new();
        for (i, a) in agents.iter_mut().enumerate() {
            let mut o = Observation::empty(i as u32, t);
            let mine = wire
                .iter()
                .filter(|f| f.src != i as u32 && (f.dst == BROADCAST || f.dst == i as u32));
            for (k, f) in mine.take(32).enumerate() {
                o.inbox[k] = *f;
                o.inbox_len = k as u16 + 1;
            }
            let cmd = a.step(&o).without_storage();
            assert!(cmd.outbox().len() <= 2, "radio.capacity");
            assert!(cmd.report_len as usize <= MAX_REPORT);
            for f in cmd.outbox() {
                let mut f = *f;
                f.src = i as u32;
                f.sent_tick = t;
                assert!(RadioMsg::decode(f.bytes()).is_some());
                next.push(f);
            }
        }
        wire = next;
        leaders = agents
            .iter()
            .filter(|a| a.consensus().unwrap().raft().unwrap().role() == Role::Leader)
            .count();
    }
    assert_eq!(leaders, 1);
    for a in &agents {
        let raft = a.consensus().unwrap().raft().unwrap();
        for id in [0, 1] {
            let at = (1..=raft.log().last_index())
                .find(|&i| {
                    matches!(raft.log().get(i).unwrap().item,
                        Item::Decision { id: k, .. } if k == id)
                })
                .expect("decision in the log");
            assert!(raft.applied() >= at, "decision {id} applied");
        }
    }
}

#[test]
fn unicast_frames_for_another_robot_are_ignored() {
    // A vote granted to robot 2 must not count for robot 0, even if it reaches robot 0.
    let cfg = Config::from_toml_str(
        "c.toml",
        r#"
[scenario]
name = "c"
ticks = 100
[map]
bounds = [0.0, 0.0, 20.0, 20.0]
goal = { x = 18.0, y = 2.0, radius = 1.0 }
[robots]
count = 3
[behaviour]
kind = "goto"
beacon_period = 0
[consensus]
election_timeout_min = 6
election_timeout_max = 7
heartbeat_ticks = 1
pre_vote = false
"#,
        &[],
    )
    .unwrap();
    let mut a = Agent::new(&cfg, 0);
    let mut t = 0;
    while a.consensus().unwrap().raft().unwrap().role() != Role::Candidate {
        a.step(&Observation::empty(0, t)).without_storage();
        t += 1;
    }
    let term = a.consensus().unwrap().raft().unwrap().term();
    let mut o = Observation::empty(0, t);
    for (k, src) in [1u32, 2].into_iter().enumerate() {
        let mut c = swarmrt_protocol::Command::act(src, t);
        c.push_frame(
            2, // addressed to robot 2, not to us
            &RadioMsg::Consensus(ConsensusMsg::VoteResp {
                term,
                granted: true,
            }),
        )
        .unwrap();
        o.inbox[k] = c.outbox()[0];
        o.inbox[k].src = src;
    }
    o.inbox_len = 2;
    a.step(&o).without_storage();
    assert_eq!(
        a.consensus().unwrap().raft().unwrap().role(),
        Role::Candidate
    );
}

#[test]
fn a_knocked_down_robot_runs_no_consensus() {
    let cfg = config("[consensus]\n");
    let mut a = Agent::new(&cfg, 0);
    let mut o = obs(0);
    o.state = RobotState::Down as u8;
    for t in 0..100 {
        o.tick = t;
        let cmd = a.step(&o).without_storage();
        assert_eq!(cmd.report_len, 0, "the world would not record its notes");
        assert!(cmd.outbox().is_empty());
    }
    assert_eq!(a.consensus().unwrap().raft().unwrap().term(), 0);
}

#[test]
fn a_quadrant_robot_claims_then_declares_itself_when_it_sees_the_most() {
    let cfg = config(
        r#"
[consensus]
algorithm = "quadrant"
[consensus.quadrant]
claim_period = 1
decide_tick = 5
"#,
    );
    let mut a = Agent::new(&cfg, 0);
    let mut o = obs(0);
    // Three robots ahead-left, in one quadrant: score 3; nobody else claims anything.
    for (k, id) in [1, 2, 3].into_iter().enumerate() {
        o.neighbours[k] = Neighbour {
            id,
            range: 1.0,
            bearing: 0.3 + 0.1 * k as f64,
        };
    }
    o.neighbours_len = 3;
    // Every tick (claim_period 1) it broadcasts the best claim it knows: its own, as nobody
    // else claims anything, before and after deciding.
    let mut claims = 0;
    for t in 0..10 {
        o.tick = t;
        let cmd = a.step(&o).without_storage();
        for f in cmd.outbox() {
            if let Some(RadioMsg::Consensus(ConsensusMsg::QuadLeader { score, leader, .. })) =
                RadioMsg::decode(f.bytes())
            {
                assert_eq!((score, leader), (3, 0), "tick {t}");
                claims += 1;
            }
        }
    }
    assert_eq!(claims, 10, "one claim per tick");
    let q = a.consensus().unwrap().quadrant().unwrap();
    assert_eq!((q.score(), q.leader()), (3, Some(0)));
}

#[test]
fn the_changes_a_robot_hands_over_rebuild_its_whole_state_and_a_restored_one_starts_clean() {
    let cfg = config(
        r#"
[consensus]
[[consensus.propose]]
tick = 50
goal = [2.0, 18.0]
"#,
    );
    let mut a = Agent::new(&cfg, 0);
    let mut stored = Persistent::default();
    let mut handed = 0;
    for t in 0..120 {
        let step = a.step(&obs(t));
        let change = step.persist().cloned();
        if t == 0 {
            // A new robot's state was never written: its first step hands it over.
            assert!(change.is_some_and(|c| c.hard.is_some()));
        }
        let _ = step.persist_then(|c| {
            stored.apply(&c);
            handed += 1;
            Ok::<(), ()>(())
        });
        assert_eq!(
            Some(&stored),
            a.consensus().unwrap().persistent().as_ref(),
            "tick {t}"
        );
    }
    assert!(
        handed > 2 && handed < 120,
        "only ticks that change the state hand over: {handed}"
    );
    assert_eq!(stored.log.last_index(), 2, "the no-op and the decision");
    let mut b = Agent::restore(&cfg, 0, stored.clone(), 1);
    assert!(
        b.step(&obs(0)).persist().is_none(),
        "nothing changed since the store"
    );
}
