//! Strategies for config fuzzing: the real configs in `configs/`, random mutations of their
//! text, random `--set key=value` overrides and random TOML-ish text.
//!
//! Shared by `agent/tests/config_fuzz.rs` (in-process, many cases) and
//! `tests/tests/e2e/config_fuzz.rs` (through the `swarm` binary), which includes it with `#[path]`.
//! The `[behaviour]` keys and kinds come from the behaviour registry, so a new behaviour is
//! fuzzed without editing this file.
//! Every draw comes from proptest's runner, which the tests seed with a fixed seed.

#![allow(dead_code)]

use proptest::prelude::*;
use proptest::sample::Index;
use proptest::test_runner::{Config as ProptestConfig, RngSeed};

/// The runner config of a fuzz property: `cases` cases from a fixed seed, no failure files.
/// `PROPTEST_CASES` and `PROPTEST_RNG_SEED` still override both, to explore further by hand.
pub fn runner(cases: u32) -> ProptestConfig {
    let base = ProptestConfig::default();
    ProptestConfig {
        cases: if std::env::var_os("PROPTEST_CASES").is_some() {
            base.cases
        } else {
            cases
        },
        rng_seed: match base.rng_seed {
            RngSeed::Random => RngSeed::Fixed(0x5eed_c0f1),
            fixed => fixed,
        },
        failure_persistence: None,
        ..base
    }
}

/// `(file name, text)` of every config in the workspace's `configs/`, sorted by name.
pub fn real_configs() -> Vec<(String, String)> {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs");
    let mut out: Vec<(String, String)> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .map(|p| {
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            (name, std::fs::read_to_string(&p).unwrap())
        })
        .collect();
    out.sort();
    assert!(!out.is_empty(), "no configs in {}", dir.display());
    out
}

/// Every key path a config has outside `[behaviour]` (the leaves and the tables).
const SCENARIO_KEYS: &[&str] = &[
    "scenario",
    "scenario.name",
    "scenario.seed",
    "scenario.ticks",
    "scenario.dt",
    "scenario.stop_when_done",
    "scenario.deadline_ms",
    "map",
    "map.bounds",
    "map.goal",
    "map.goal.x",
    "map.goal.y",
    "map.goal.radius",
    "map.circles",
    "map.rectangles",
    "map.polygons",
    "robots",
    "robots.count",
    "robots.radius",
    "robots.max_speed",
    "robots.max_turn_rate",
    "robots.start",
    "robots.start.x",
    "robots.start.y",
    "robots.start.spacing",
    "robots.start.heading_deg",
    "robots.start.groups",
    "robots.start.jitter",
    "robots.start.heading_jitter_deg",
    "robots.lidar",
    "robots.lidar.rays",
    "robots.lidar.fov_deg",
    "robots.lidar.range",
    "robots.lidar.angles_deg",
    "robots.range_bearing.range",
    "robots.goal_sensor.range",
    "robots.goal_sensor.fov_deg",
    "robots.noise.pose",
    "robots.noise.heading",
    "robots.noise.lidar",
    "robots.noise.wheel_slip",
    "radio",
    "radio.range",
    "radio.loss",
    "radio.loss_model",
    "radio.ge_p",
    "radio.ge_r",
    "radio.ge_loss_good",
    "radio.ge_loss_bad",
    "radio.delay_ticks",
    "radio.jitter_ticks",
    "radio.capacity",
    "radio.line_of_sight",
    "behaviour",
    "behaviour.kind",
    "faults",
    "faults.kill",
    "faults.freeze",
    "faults.restart",
    "faults.kill_rate",
    "faults.freeze_rate",
    "faults.freeze_ticks",
    "faults.partition",
    "faults.blackout",
    "scenario.unresponsive_ms",
    "consensus",
    "consensus.algorithm",
    "consensus.election_timeout_min",
    "consensus.election_timeout_max",
    "consensus.heartbeat_ticks",
    "consensus.pre_vote",
    "consensus.check_quorum",
    "consensus.stats_every",
    "consensus.propose",
    "consensus.quadrant",
    "consensus.quadrant.claim_period",
    "consensus.quadrant.decide_tick",
    "consensus.storage",
];

/// Values that sit on type and range edges, as TOML text.
const EDGE_VALUES: &[&str] = &[
    "18446744073709551615",
    "9223372036854775807",
    "9223372036854775808",
    "-9223372036854775808",
    "4294967295",
    "4294967296",
    "1e300",
    "-1e300",
    "1e-300",
    "1.7976931348623157e308",
    "-1.7976931348623157e308",
    "5e-324",
    "nan",
    "+nan",
    "-nan",
    "inf",
    "+inf",
    "-inf",
    "[]",
    "[[]]",
    "{}",
    "{ a = 1 }",
    "{ x = 1.0, y = 1.0, radius = 0.5 }",
    "[1, \"a\"]",
    "[0.0, 0.0]",
    "[0.0, 0.0, 1.0, 1.0]",
    "[-1e300, 0.0, 1e300, 1.0]",
    "[[0, 1], [2]]",
    "[[0, 0]]",
    "true",
    "false",
    "0",
    "-0",
    "0.0",
    "-0.0",
    "1",
    "2",
    "-1",
    "0x10",
    "0o7",
    "0b1",
    "1_000",
    "1979-05-27T07:32:00Z",
    "07:32:00",
    "'lit'",
    "\"\"",
    "\"leader\"",
    "\"raft\"",
    "\"quadrant\"",
    "\"gilbert-elliott\"",
    "\"bernoulli\"",
    "\"\\u0000\"",
    "\"a\\nb\"",
    "[{ tick = 1, robot = 0 }]",
    "[{ tick = 1, robot = \"leader\" }]",
    "[{ tick = 1, robot = -1 }]",
    "[{ tick = 1, robot = 100000 }]",
    "[{ from = 2, to = 1 }]",
    "[{ from = 0, to = 5 }]",
    "[{ from = 0, to = 5, groups = [[0], [1]] }]",
    "[{ from = 0, to = 5, groups = [[0], [0]] }]",
    "[{ tick = 3, speed = 0.1 }]",
    "[{ tick = 3, goal = [1.0, 1.0] }]",
    "[{ tick = 3 }]",
    "[{ x = 1.0, y = 1.0, r = 0.5 }]",
    "[{ x = 1e300, y = 1.0, r = 0.5 }]",
    "[{ x_min = 1.0, y_min = 1.0, x_max = 2.0, y_max = 2.0 }]",
    "[{ x_min = -1e308, y_min = 1.0, x_max = 1e308, y_max = 2.0 }]",
    "[{ points = [[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]] }]",
    "[{ points = [[0.0, 0.0], [1e308, 0.0], [0.0, 1e308]] }]",
    "[{ points = [[1.0, 1.0], [1.0, 1.0], [1.0, 1.0]] }]",
];

/// A float as TOML writes it (`nan`, `inf`, otherwise with a `.` or an exponent).
fn toml_float(v: f64) -> String {
    if v.is_nan() {
        "nan".to_string()
    } else if v.is_infinite() {
        if v > 0.0 { "inf" } else { "-inf" }.to_string()
    } else {
        format!("{v:?}")
    }
}

/// A random TOML value: edge cases, integers, floats, strings, arrays and tables.
/// [`EDGE_VALUES`] and every behaviour's name, quoted.
fn edge_values() -> Vec<String> {
    let mut values: Vec<String> = EDGE_VALUES.iter().map(|v| v.to_string()).collect();
    values.extend(
        swarmrt_agent::registry::kinds()
            .iter()
            .map(|k| format!("\"{k}\"")),
    );
    values
}

pub fn value() -> BoxedStrategy<String> {
    prop_oneof![
        4 => prop::sample::select(edge_values()),
        2 => (-5i64..50).prop_map(|v| v.to_string()),
        1 => any::<i64>().prop_map(|v| v.to_string()),
        2 => (-20.0f64..50.0).prop_map(toml_float),
        1 => any::<f64>().prop_map(toml_float),
        1 => "[a-z_ -]{0,8}".prop_map(|s| format!("\"{s}\"")),
        1 => prop::collection::vec((-3.0f64..30.0).prop_map(toml_float), 0..6)
            .prop_map(|v| format!("[{}]", v.join(", "))),
        1 => prop::collection::vec((0u32..12).prop_map(|v| v.to_string()), 0..4)
            .prop_map(|v| format!("[[{}]]", v.join(", "))),
    ]
    .boxed()
}

/// A value that often passes validation: a small integer or float.
pub fn plausible() -> BoxedStrategy<String> {
    prop_oneof![
        (0i64..20).prop_map(|v| v.to_string()),
        (0.0f64..1.0).prop_map(toml_float),
        (0.0f64..20.0).prop_map(toml_float),
    ]
    .boxed()
}

/// Half [`value`], half [`plausible`].
pub fn some_value() -> BoxedStrategy<String> {
    prop_oneof![value(), plausible()].boxed()
}

/// A key: a real key path most of the time, otherwise made up or malformed.
pub fn key() -> BoxedStrategy<String> {
    prop_oneof![
        6 => prop::sample::select(keys()),
        1 => "[a-z_]{1,8}(\\.[a-z_]{1,8}){0,2}",
        1 => prop::sample::select(&[
            "", ".", "..", "radio..loss", ".radio", "radio.", "radio.loss.x",
            "scenario.name.z", " radio.loss ", "a b", "radio.lo\nss", "radio.\u{301}loss",
            "robots.count.0", "map.bounds.x", "consensus.propose.tick", "faults.kill.robot",
            "\u{1F916}", "radio.loss=", "behaviour.kind.x",
        ][..])
        .prop_map(String::from),
    ]
    .boxed()
}

/// Every key path a config has: the scenario's and every behaviour's parameters.
pub fn keys() -> Vec<String> {
    let mut keys: Vec<String> = SCENARIO_KEYS.iter().map(|k| k.to_string()).collect();
    keys.extend(swarmrt_agent::registry::param_keys());
    keys
}

/// A number for geometry: huge, tiny, non-finite, or ordinary.
fn coordinate() -> BoxedStrategy<f64> {
    prop_oneof![
        2 => prop::sample::select(&[
            1e308, -1e308, f64::MAX, f64::MIN, 1e300, -1e300, 1e-300, 5e-324, 0.0, -0.0, 1e6,
            -1e6, 1e6 + 0.5, f64::NAN, f64::INFINITY, f64::NEG_INFINITY,
        ][..]),
        1 => -20.0f64..50.0,
    ]
    .boxed()
}

/// `(min, max)` of two coordinates, so a shape is often the right way round.
fn span() -> BoxedStrategy<(String, String)> {
    (coordinate(), coordinate())
        .prop_map(|(a, b)| {
            let (lo, hi) = if b < a { (b, a) } else { (a, b) };
            (toml_float(lo), toml_float(hi))
        })
        .boxed()
}

/// `--set` of a whole piece of geometry (bounds, goal, start, obstacles) with numbers from
/// [`coordinate`], so that several numbers of one shape are extreme at once.
pub fn geometry_override() -> BoxedStrategy<String> {
    let c = || coordinate().prop_map(toml_float);
    prop_oneof![
        (span(), span())
            .prop_map(|((x0, x1), (y0, y1))| { format!("map.bounds=[{x0}, {y0}, {x1}, {y1}]") }),
        (c(), c(), c())
            .prop_map(|(x, y, r)| { format!("map.goal={{ x = {x}, y = {y}, radius = {r} }}") }),
        (c(), c(), c()).prop_map(|(x, y, s)| {
            format!("robots.start={{ x = {x}, y = {y}, spacing = {s} }}")
        }),
        (c(), c(), c())
            .prop_map(|(x, y, r)| { format!("map.circles=[{{ x = {x}, y = {y}, r = {r} }}]") }),
        (span(), span()).prop_map(|((a, x), (b, y))| {
            format!("map.rectangles=[{{ x_min = {a}, y_min = {b}, x_max = {x}, y_max = {y} }}]")
        }),
        prop::collection::vec((c(), c()), 0..5).prop_map(|p| {
            let p: Vec<String> = p.iter().map(|(x, y)| format!("[{x}, {y}]")).collect();
            format!("map.polygons=[{{ points = [{}] }}]", p.join(", "))
        }),
    ]
    .boxed()
}

/// One `--set` argument: usually `key=value`, sometimes a malformed one.
pub fn override_arg() -> BoxedStrategy<String> {
    prop_oneof![
        8 => (key(), some_value()).prop_map(|(k, v)| format!("{k}={v}")),
        2 => geometry_override(),
        1 => (key(), "\\PC{0,12}").prop_map(|(k, v)| format!("{k}={v}")),
        1 => "\\PC{0,16}",
    ]
    .boxed()
}

/// One text mutation.
#[derive(Debug, Clone)]
pub enum Mutation {
    /// Remove one line.
    DeleteLine(Index),
    /// Repeat one line right after itself.
    DuplicateLine(Index),
    /// Exchange two lines.
    SwapLines(Index, Index),
    /// Replace everything after the `=` of a `key = value` line.
    ReplaceLineValue(Index, String),
    /// Replace one number literal (also inside arrays and inline tables).
    ReplaceNumber(Index, String),
    /// Insert a character into a key name.
    RenameInsert(Index, Index, char),
    /// Delete a character of a key name.
    RenameDelete(Index, Index),
    /// Cut the text at a (char boundary at or before a) random byte.
    Truncate(Index),
    /// Insert random text at a random char boundary.
    Insert(Index, String),
    /// Append a table (often one already present, or an array of tables of faults or
    /// proposals).
    Append(String),
}

/// A random mutation.
pub fn mutation() -> BoxedStrategy<Mutation> {
    let ix = any::<Index>;
    let key_char = prop_oneof![
        4 => prop::char::range('a', 'z'),
        1 => prop::sample::select(&['_', '-', '.', ' ', '"', '\u{e9}', '0'][..]),
        1 => any::<char>(),
    ];
    let junk = prop_oneof![
        2 => prop::sample::select(&[
            "\n", "\"", "'", "[", "]", "[[", "]]", "=", "\u{0}", "\u{feff}", "\r\n", "\r",
            "'''", "\"\"\"", "\u{e9}", "\u{1F916}", "\t", "#", ",", "{", "}", ".", "\\",
            "\n[scenario]\n", "\nx = 1\n",
        ][..])
        .prop_map(String::from),
        1 => "\\PC{1,6}",
        1 => prop::collection::vec(any::<u8>(), 1..6)
            .prop_map(|b| String::from_utf8_lossy(&b).into_owned()),
    ];
    prop_oneof![
        2 => ix().prop_map(Mutation::DeleteLine),
        1 => ix().prop_map(Mutation::DuplicateLine),
        1 => (ix(), ix()).prop_map(|(a, b)| Mutation::SwapLines(a, b)),
        4 => (ix(), some_value()).prop_map(|(i, v)| Mutation::ReplaceLineValue(i, v)),
        4 => (ix(), some_value()).prop_map(|(i, v)| Mutation::ReplaceNumber(i, v)),
        1 => (ix(), ix(), key_char).prop_map(|(k, p, c)| Mutation::RenameInsert(k, p, c)),
        1 => (ix(), ix()).prop_map(|(k, p)| Mutation::RenameDelete(k, p)),
        1 => ix().prop_map(Mutation::Truncate),
        1 => (ix(), junk).prop_map(|(i, s)| Mutation::Insert(i, s)),
        2 => table().prop_map(Mutation::Append),
    ]
    .boxed()
}

/// A small number most of the time (so ids, ticks and windows often pass), else any value.
fn smallish() -> BoxedStrategy<String> {
    prop_oneof![3 => (0i64..12).prop_map(|v| v.to_string()), 1 => value()].boxed()
}

/// A table to append.
fn table() -> BoxedStrategy<String> {
    prop_oneof![
        (smallish(), smallish())
            .prop_map(|(t, r)| format!("[[faults.kill]]\ntick = {t}\nrobot = {r}")),
        (smallish(), smallish(), value()).prop_map(|(f, t, g)| {
            format!("[[faults.partition]]\nfrom = {f}\nto = {t}\ngroups = {g}")
        }),
        (smallish(), smallish())
            .prop_map(|(f, t)| format!("[[faults.blackout]]\nfrom = {f}\nto = {t}")),
        (smallish(), smallish(), smallish()).prop_map(|(r, f, t)| {
            format!("[[faults.freeze]]\nrobot = {r}\nfrom = {f}\nto = {t}")
        }),
        (smallish(), smallish(), smallish()).prop_map(|(t, r, d)| {
            format!("[[faults.restart]]\ntick = {t}\nrobot = {r}\ndown_ticks = {d}")
        }),
        (smallish(), value())
            .prop_map(|(t, g)| format!("[[consensus.propose]]\ntick = {t}\ngoal = {g}")),
        (smallish(), value())
            .prop_map(|(t, s)| format!("[[consensus.propose]]\ntick = {t}\nspeed = {s}")),
        (key(), value()).prop_map(|(k, v)| match k.rsplit_once('.') {
            Some((table, leaf)) => format!("[{table}]\n{leaf} = {v}"),
            None => format!("{k} = {v}"),
        }),
        (value(), value(), value())
            .prop_map(|(x, y, r)| { format!("[[map.circles]]\nx = {x}\ny = {y}\nr = {r}") }),
    ]
    .boxed()
}

/// Byte offsets of `text`'s char boundaries (including its end).
fn boundaries(text: &str) -> Vec<usize> {
    text.char_indices()
        .map(|(i, _)| i)
        .chain(std::iter::once(text.len()))
        .collect()
}

/// `(start, end)` byte spans of the number literals (a run of `[0-9A-Za-z_.+-]` that starts
/// with a digit, `+` or `-`, right after a space, `=`, `[`, `,` or `{`).
fn number_spans(text: &str) -> Vec<(usize, usize)> {
    let b = text.as_bytes();
    let tok = |c: u8| c.is_ascii_alphanumeric() || b"_.+-".contains(&c);
    let mut spans = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let after_sep = i == 0 || b" =[,{".contains(&b[i - 1]);
        if after_sep && (b[i].is_ascii_digit() || b[i] == b'-' || b[i] == b'+') {
            let mut j = i;
            while j < b.len() && tok(b[j]) {
                j += 1;
            }
            spans.push((i, j));
            i = j;
        } else {
            i += 1;
        }
    }
    spans
}

/// `(start, end)` byte spans of key names: identifiers followed (after spaces) by `=`, `.`
/// or `]`.
fn key_spans(text: &str) -> Vec<(usize, usize)> {
    let b = text.as_bytes();
    let ident = |c: u8| c.is_ascii_alphanumeric() || c == b'_';
    let mut spans = Vec::new();
    let mut i = 0;
    while i < b.len() {
        if ident(b[i]) && (i == 0 || !ident(b[i - 1])) {
            let mut j = i;
            while j < b.len() && ident(b[j]) {
                j += 1;
            }
            let mut k = j;
            while k < b.len() && b[k] == b' ' {
                k += 1;
            }
            if k < b.len() && b"=.]".contains(&b[k]) && b.get(k + 1) != Some(&b'=') {
                spans.push((i, j));
            }
            i = j;
        } else {
            i += 1;
        }
    }
    spans
}

/// Applies one mutation (a no-op when the text has nothing it applies to).
pub fn apply(text: &str, m: &Mutation) -> String {
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let join = |lines: Vec<String>| lines.join("\n") + "\n";
    match m {
        Mutation::DeleteLine(i) if !lines.is_empty() => {
            lines.remove(i.index(lines.len()));
            join(lines)
        }
        Mutation::DuplicateLine(i) if !lines.is_empty() => {
            let k = i.index(lines.len());
            lines.insert(k, lines[k].clone());
            join(lines)
        }
        Mutation::SwapLines(a, b) if !lines.is_empty() => {
            let n = lines.len();
            lines.swap(a.index(n), b.index(n));
            join(lines)
        }
        Mutation::ReplaceLineValue(i, v) => {
            let candidates: Vec<usize> = (0..lines.len())
                .filter(|&k| {
                    let t = lines[k].trim_start();
                    t.contains('=') && !t.starts_with('#') && !t.starts_with('[')
                })
                .collect();
            if candidates.is_empty() {
                return text.to_string();
            }
            let k = candidates[i.index(candidates.len())];
            let eq = lines[k].find('=').unwrap();
            lines[k] = format!("{}= {v}", &lines[k][..eq]);
            join(lines)
        }
        Mutation::ReplaceNumber(i, v) => {
            let spans = number_spans(text);
            if spans.is_empty() {
                return text.to_string();
            }
            let (s, e) = spans[i.index(spans.len())];
            format!("{}{v}{}", &text[..s], &text[e..])
        }
        Mutation::RenameInsert(k, p, c) => {
            let spans = key_spans(text);
            if spans.is_empty() {
                return text.to_string();
            }
            let (s, e) = spans[k.index(spans.len())];
            let at = s + p.index(e - s + 1);
            format!("{}{c}{}", &text[..at], &text[at..])
        }
        Mutation::RenameDelete(k, p) => {
            let spans = key_spans(text);
            if spans.is_empty() {
                return text.to_string();
            }
            let (s, e) = spans[k.index(spans.len())];
            let at = s + p.index(e - s);
            format!("{}{}", &text[..at], &text[at + 1..])
        }
        Mutation::Truncate(i) => {
            let b = boundaries(text);
            text[..b[i.index(b.len())]].to_string()
        }
        Mutation::Insert(i, s) => {
            let b = boundaries(text);
            let at = b[i.index(b.len())];
            format!("{}{s}{}", &text[..at], &text[at..])
        }
        Mutation::Append(t) => format!("{text}\n{t}\n"),
        _ => text.to_string(),
    }
}

/// A real config (its name and text) with 1 to 4 mutations applied; the mutations come along
/// so a failure shows them.
pub fn mutated_config() -> impl Strategy<Value = (String, String, Vec<Mutation>)> {
    let configs = real_configs();
    (
        prop::sample::select(configs),
        prop::collection::vec(mutation(), 1..5),
    )
        .prop_map(|((name, text), ms)| {
            let out = ms.iter().fold(text, |t, m| apply(&t, m));
            (name, out, ms)
        })
}

/// A real config with 1 to 3 of its numbers replaced by plausible or extreme ones: many
/// still load, so they reach the world and a run.
pub fn renumbered_config() -> impl Strategy<Value = (String, String, Vec<Mutation>)> {
    let number = prop_oneof![plausible(), coordinate().prop_map(toml_float)];
    (
        prop::sample::select(real_configs()),
        prop::collection::vec(
            (any::<Index>(), number).prop_map(|(i, v)| Mutation::ReplaceNumber(i, v)),
            1..4,
        ),
    )
        .prop_map(|((name, text), ms)| {
            let out = ms.iter().fold(text, |t, m| apply(&t, m));
            (name, out, ms)
        })
}

/// Random TOML-ish text: table headers, keys, `=`, values, brackets and junk.
pub fn random_text() -> BoxedStrategy<String> {
    let token = prop_oneof![
        3 => key(),
        3 => value(),
        2 => prop::sample::select(&[
            " = ", "\n", "[", "]", "[[", "]]", "{", "}", ",", ".", "\"", "'", "#", " ",
            "\n[scenario]\n", "\n[map]\n", "\n[robots]\n", "\n[radio]\n", "\n[behaviour]\n",
            "\n[consensus]\n", "\n[[faults.kill]]\n",
        ][..])
        .prop_map(String::from),
        1 => "\\PC{0,8}",
    ];
    prop_oneof![
        4 => prop::collection::vec(token, 0..40).prop_map(|t| t.concat()),
        1 => "\\PC{0,200}",
        1 => prop::collection::vec(any::<u8>(), 0..200)
            .prop_map(|b| String::from_utf8_lossy(&b).into_owned()),
    ]
    .boxed()
}
