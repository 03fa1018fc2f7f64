//! The `[consensus]` section: defaults, round trip, and errors that name the key and bounds.

use swarmrt_scenario::{Config, ConfigError};

const BASE: &str = r#"
[scenario]
name = "t"
ticks = 10
[map]
bounds = [0.0, 0.0, 10.0, 10.0]
goal = { x = 8.0, y = 8.0, radius = 1.0 }
[robots]
count = 4
[consensus]
election_timeout_min = 20
[[consensus.propose]]
tick = 5
goal = [2.0, 3.0]
[[consensus.propose]]
tick = 9
speed = 0.2
"#;

fn load(ov: &[&str]) -> Result<Config, ConfigError> {
    let ov: Vec<String> = ov.iter().map(|s| s.to_string()).collect();
    Config::from_toml_str("t.toml", BASE, &ov)
}

#[test]
fn consensus_section_loads_round_trips_and_is_optional() {
    let c = load(&[]).unwrap();
    let cc = c.consensus.as_ref().unwrap();
    assert_eq!(cc.election_timeout_max, 40);
    assert_eq!(cc.propose[0].goal, Some([2.0, 3.0]));
    assert_eq!(cc.propose[1].speed, Some(0.2));
    assert_eq!(
        Config::from_toml_str("t.toml", &c.to_toml(), &[]).unwrap(),
        c
    );
    let without = BASE.split("[consensus]").next().unwrap();
    let c = Config::from_toml_str("t.toml", without, &[]).unwrap();
    assert_eq!(c.consensus, None);
    assert!(!c.to_toml().contains("consensus"));
}

#[test]
fn consensus_errors_name_the_key_and_the_bounds() {
    let cases: &[(&[&str], &str, &str)] = &[
        (
            &["consensus.electon_timeout_min=3"],
            "consensus.electon_timeout_min",
            "unknown field",
        ),
        (
            &["consensus.election_timeout_max=20"],
            "consensus.election_timeout_max",
            "above consensus.election_timeout_min = 20",
        ),
        (
            &["consensus.heartbeat_ticks=20"],
            "consensus.heartbeat_ticks",
            "[1, 19]",
        ),
        (
            &["consensus.heartbeat_ticks=0"],
            "consensus.heartbeat_ticks",
            "[1, 19]",
        ),
        (
            &["radio.delay_ticks=9"],
            "consensus.election_timeout_min",
            "round trip",
        ),
        (
            &["consensus.algorithm=\"paxos\""],
            "consensus.algorithm",
            "unknown variant",
        ),
        (
            &["consensus.stats_every=0"],
            "consensus.stats_every",
            "[1, 1000000]",
        ),
        (
            &["consensus.quadrant.claim_period=0"],
            "consensus.quadrant.claim_period",
            "[1, 100000]",
        ),
    ];
    for (ov, key, msg) in cases {
        let e = load(ov).unwrap_err();
        assert_eq!(e.key, *key, "{ov:?}: {e}");
        assert!(e.to_string().contains(msg), "{ov:?}: {e}");
    }
    let both = BASE.replace("goal = [2.0, 3.0]", "goal = [2.0, 3.0]\nspeed = 0.1");
    let e = Config::from_toml_str("t.toml", &both, &[]).unwrap_err();
    assert_eq!(e.key, "consensus.propose[0]", "{e}");
    let outside = BASE.replace("goal = [2.0, 3.0]", "goal = [20.0, 3.0]");
    let e = Config::from_toml_str("t.toml", &outside, &[]).unwrap_err();
    assert_eq!(e.key, "consensus.propose[0].goal[0]", "{e}");
    let fast = BASE.replace("speed = 0.2", "speed = 5.0");
    let e = Config::from_toml_str("t.toml", &fast, &[]).unwrap_err();
    assert_eq!(e.key, "consensus.propose[1].speed", "{e}");
}
