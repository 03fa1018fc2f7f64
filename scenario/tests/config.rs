//! Config loading: defaults, `--set`, errors that name the file, the key and the bounds,
//! and the start layout.

use swarmrt_scenario::layout::nearest_grid_points;
use swarmrt_scenario::{Config, ConfigError, LossModel};

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
    Config::from_toml_str("t.toml", text, &ov)
}

#[test]
fn minimal_config_gets_defaults() {
    let c = load(MINIMAL, &[]).unwrap();
    assert_eq!(c.scenario.dt, 0.1);
    assert_eq!(c.radio.capacity, 4);
    assert_eq!(c.start_positions(|_, _| true).unwrap().len(), 4);
    assert_eq!(c.behaviour.kind, "goto");
}

#[test]
fn overrides_reach_nested_keys_and_round_trip() {
    let c = load(
        MINIMAL,
        &["radio.loss=0.3", "robots.count=9", "scenario.seed=7"],
    )
    .unwrap();
    assert_eq!(c.radio.loss, 0.3);
    assert_eq!(c.robots.count, 9);
    let again = load(&c.to_toml(), &[]).unwrap();
    assert_eq!(again, c);
}

#[test]
fn record_radio_is_off_by_default_set_by_override_and_resolved_only_when_on() {
    let off = load(MINIMAL, &[]).unwrap();
    assert!(!off.scenario.record_radio);
    // Off, the resolved config does not mention it: older run directories stay the same bytes.
    assert!(!off.to_toml().contains("record_radio"), "{}", off.to_toml());
    let on = load(MINIMAL, &["scenario.record_radio=true"]).unwrap();
    assert!(on.scenario.record_radio);
    assert!(
        on.to_toml().contains("record_radio = true"),
        "{}",
        on.to_toml()
    );
    assert_eq!(load(&on.to_toml(), &[]).unwrap(), on);
    let e = load(MINIMAL, &["scenario.record_radio=yes"]).unwrap_err();
    assert_eq!(e.key, "scenario.record_radio", "{e}");
}

#[test]
fn unknown_key_names_file_and_key() {
    let e = load(MINIMAL, &["radio.los=0.3"]).unwrap_err();
    assert_eq!(e.file, "t.toml");
    assert_eq!(e.key, "radio.los");
    assert!(e.message.contains("unknown field `los`"), "{e}");
}

#[test]
fn wrong_type_names_key() {
    let e = load(MINIMAL, &["robots.count=\"many\""]).unwrap_err();
    assert_eq!(e.key, "robots.count", "{e}");
}

#[test]
fn negative_count_is_refused() {
    let e = load(MINIMAL, &["robots.count=-3"]).unwrap_err();
    assert_eq!(e.key, "robots.count", "{e}");
}

#[test]
fn huge_coordinates_are_refused_not_overflowed() {
    let e = load(MINIMAL, &["map.bounds=[-5e18, 0.0, 5e18, 12.0]"]).unwrap_err();
    assert_eq!(e.key, "map.bounds[0]", "{e}");
    // Even called directly with absurd input, the grid search gives up instead of looping.
    assert_eq!(
        nearest_grid_points(3, (0.0, 0.0), 1e-9, [-1e6, -1e6, 1e6, 1e6], 0.1, |_, _| {
            true
        }),
        None
    );
}

#[test]
fn issue_5_obstacle_wider_than_f64_is_refused_not_built() {
    // Finite corners, infinite width: parry's BVH build panicked on it.
    let e = load(
        MINIMAL,
        &["map.rectangles=[{ x_min = -1e308, y_min = 1.0, x_max = 1e308, y_max = 2.0 }]"],
    )
    .unwrap_err();
    assert_eq!(e.key, "map.rectangles[0].x_min", "{e}");
    assert!(e.message.contains("[-1000000, 1000000]"), "{e}");
    let e = load(MINIMAL, &["map.circles=[{ x = 1e300, y = 1.0, r = 0.5 }]"]).unwrap_err();
    assert_eq!(e.key, "map.circles[0].x", "{e}");
    let e = load(
        MINIMAL,
        &["map.polygons=[{ points = [[0.0, 0.0], [1e308, 0.0], [0.0, 1.0]] }]"],
    )
    .unwrap_err();
    assert_eq!(e.key, "map.polygons[0].points[1][0]", "{e}");
}

#[test]
fn issue_5_control_characters_in_errors_are_escaped_to_keep_one_line() {
    // A newline in an override's key (or a quoted key in the file) reached the output.
    let e = load(MINIMAL, &["radio.lo\nss=1"]).unwrap_err();
    assert_eq!(e.key, "radio.lo\nss");
    assert_eq!(
        e.to_string().lines().next().unwrap(),
        e.to_string(),
        "one line"
    );
    assert!(e.to_string().contains("key `radio.lo\\nss`"), "{e}");
    let quoted = MINIMAL.replace("count = 4", "count = 4\n\"a\\u001b[2Jb\" = 1");
    let e = load(&quoted, &[]).unwrap_err();
    assert!(e.to_string().contains("key `robots.a\\u{1b}[2Jb`"), "{e}");
    // TOML's error echoes the offending line, NUL and all.
    let e = load("\u{0}[scenario]", &[]).unwrap_err();
    assert!(!e.to_string().chars().any(char::is_control), "{e}");
    assert!(e.to_string().contains("\\u{0}"), "{e}");
}

#[test]
fn issue_5_a_number_toml_cannot_hold_is_not_read_as_a_string() {
    // `swarm run --seed 18446744073709551615` (a valid u64) said "invalid type: string".
    for (ov, key) in [
        ("scenario.seed=18446744073709551615", "scenario.seed"),
        ("radio.loss=1e400", "radio.loss"),
        ("radio.loss=.5", "radio.loss"),
    ] {
        let e = load(MINIMAL, &[ov]).unwrap_err();
        assert_eq!((e.file.as_str(), e.key.as_str()), ("--set", key), "{e}");
        assert!(e.message.contains("9223372036854775807"), "{e}");
    }
    // Words still become strings, even those Rust reads as numbers.
    let c = load(MINIMAL, &["radio.loss_model=gilbert-elliott"]).unwrap();
    assert_eq!(c.radio.loss_model, LossModel::GilbertElliott);
    let c = load(MINIMAL, &["scenario.name=Infinity"]).unwrap();
    assert_eq!(c.scenario.name, "Infinity");
}

#[test]
fn issue_5_a_bad_fault_target_says_what_is_expected() {
    // Was "data did not match any variant of untagged enum FaultTarget".
    let e = load(MINIMAL, &["faults.kill=[{ tick = 1, robot = -1 }]"]).unwrap_err();
    assert_eq!(e.key, "faults.kill[0].robot", "{e}");
    assert!(e.message.contains("a robot id"), "{e}");
    assert!(e.message.contains("\"leader\""), "{e}");
}

#[test]
fn issue_5_huge_numbers_are_shown_short() {
    // A 309-digit number made the "one clear line" several hundred characters long.
    let e = load(MINIMAL, &["robots.max_speed=-1e308"]).unwrap_err();
    assert!(e.message.ends_with("got -1e308"), "{e}");
    let e = load(
        MINIMAL,
        &["robots.start={ x = 2.0, y = 2.0, spacing = 1e300 }"],
    )
    .unwrap_err();
    assert!(e.message.ends_with("got 1e300"), "{e}");
    let e = load(MINIMAL, &["radio.loss=1.5"]).unwrap_err();
    assert!(e.message.ends_with("got 1.5"), "{e}");
}

#[test]
fn loss_above_one_is_refused_with_bounds() {
    let e = load(MINIMAL, &["radio.loss=1.5"]).unwrap_err();
    assert_eq!(e.key, "radio.loss");
    assert!(e.message.contains("[0, 1]"), "{e}");
}

#[test]
fn grid_points_nearest_first_inside_bounds_and_clear() {
    let all = |_: f64, _: f64| true;
    let g = nearest_grid_points(5, (0.0, 0.0), 1.0, [-10.0, -10.0, 10.0, 10.0], 0.1, all).unwrap();
    assert_eq!(
        g,
        vec![(0.0, -1.0), (-1.0, 0.0), (1.0, 0.0), (0.0, 1.0)]
            .into_iter()
            .fold(vec![(0.0, 0.0)], |mut v, p| {
                v.push(p);
                v
            })
    );
    // Near a wall the layout grows away from it instead of leaving the map.
    let g = nearest_grid_points(9, (0.5, 0.5), 1.0, [0.0, 0.0, 10.0, 10.0], 0.2, all).unwrap();
    assert!(g.iter().all(|&(x, y)| x > 0.2 && y > 0.2), "{g:?}");
    // Points refused by `ok` are skipped.
    let g = nearest_grid_points(
        3,
        (0.0, 0.0),
        1.0,
        [-10.0, -10.0, 10.0, 10.0],
        0.1,
        |x, _| x >= 0.0,
    )
    .unwrap();
    assert!(g.iter().all(|&(x, _)| x >= 0.0), "{g:?}");
    // No room: None.
    assert_eq!(
        nearest_grid_points(200, (1.0, 1.0), 1.0, [0.0, 0.0, 5.0, 5.0], 0.1, all),
        None
    );
}

#[test]
fn too_many_robots_for_the_map_is_refused() {
    let c = load(MINIMAL, &["robots.count=400"]).unwrap();
    assert_eq!(c.start_positions(|_, _| true), None);
    let c = load(MINIMAL, &["robots.count=100"]).unwrap();
    assert_eq!(c.start_positions(|_, _| true).unwrap().len(), 100);
}
