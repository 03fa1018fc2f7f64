//! Hostile config inputs for the no-panic properties (issue 48): the real configs of
//! `configs/` parsed into tables and mutated where they hold values (a leaf replaced by an
//! extreme or wrongly typed value, a key removed, an unknown key added, an array grown past
//! its bound), plus `--set` arguments with the same values. Polygons are drawn from a handful
//! of coordinates, so repeated, collinear, tiny and oversized ones come up often: random
//! floats almost never repeat a point, and those are what the geometry library chokes on.
//!
//! Shared by `scenario/tests/hostile_config.rs` (load and validate) and
//! `tests/tests/e2e/config_fuzz.rs` (everything `swarm check` does), which include it with
//! `#[path]`. Every draw comes from proptest's runner, seeded by [`runner`].

#![allow(dead_code)]

use proptest::prelude::*;
use proptest::sample::Index;
use proptest::test_runner::{Config as ProptestConfig, RngSeed};

/// The runner config of a property: `cases` cases from a fixed seed, no failure files.
/// `PROPTEST_CASES` and `PROPTEST_RNG_SEED` override both, to explore further by hand.
pub fn runner(cases: u32) -> ProptestConfig {
    runner_from(0x48_b0_0d, cases)
}

/// [`runner`] from another fixed `seed`: one property split into tests that draw different
/// cases, so that they run on different cores.
pub fn runner_from(seed: u64, cases: u32) -> ProptestConfig {
    let base = ProptestConfig::default();
    ProptestConfig {
        cases: if std::env::var_os("PROPTEST_CASES").is_some() {
            base.cases
        } else {
            cases
        },
        rng_seed: match base.rng_seed {
            RngSeed::Random => RngSeed::Fixed(seed),
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

/// One hostile input: a config's name, its (mutated) text, `--set` arguments, and what was
/// done to it (for the failure message).
#[derive(Debug, Clone)]
pub struct Case {
    /// File name of the real config it started from.
    pub name: String,
    /// The TOML text to load.
    pub text: String,
    /// `--set` arguments.
    pub overrides: Vec<String>,
    /// The mutations, in words.
    pub what: Vec<String>,
}

/// Numbers on the edges of types and bounds, and beyond them.
const NUMBERS: &[f64] = &[
    f64::NAN,
    f64::INFINITY,
    f64::NEG_INFINITY,
    f64::MAX,
    f64::MIN,
    1e308,
    -1e308,
    1e300,
    1e15,
    1e6,
    1e6 + 0.5,
    -1e6,
    1e-300,
    5e-324,
    -5e-324,
    0.0,
    -0.0,
    1e-3,
    0.5,
    1.0,
    -1.0,
    2.0,
    64.0,
    257.0,
];

/// Integers on the edges of `u32`, `u64` and TOML's `i64`.
const INTEGERS: &[i64] = &[
    i64::MIN,
    i64::MAX,
    -1,
    0,
    1,
    2,
    3,
    64,
    65,
    256,
    257,
    4_294_967_295,
    4_294_967_296,
    100_001,
    10_001,
];

/// Lengths of long strings: just past the name bound, past a file name, past a path, and
/// past the file bound.
const LONG: &[usize] = &[65, 300, 4097, 100_000, 1_100_000];

/// Strings that mean something somewhere (names of variants, of the built-in robot, "leader").
const WORDS: &[&str] = &[
    "",
    "leader",
    "raft",
    "quadrant",
    "gilbert-elliott",
    "bernoulli",
    "swarm-agent",
    "goto",
    "../../etc/passwd",
    "/dev/zero",
    "a\u{0}b",
    "a\nb",
    "\u{1b}[31m",
    "\u{1F916}",
    "0..4",
    "4..0",
    "0..4294967295",
];

/// A float as TOML value.
fn float(v: f64) -> toml::Value {
    toml::Value::Float(v)
}

/// A scalar: a number, an integer, a string (often long), a boolean.
fn scalar() -> BoxedStrategy<toml::Value> {
    prop_oneof![
        4 => prop::sample::select(NUMBERS).prop_map(float),
        3 => prop::sample::select(INTEGERS).prop_map(toml::Value::Integer),
        2 => (-3.0f64..30.0).prop_map(float),
        2 => prop::sample::select(WORDS).prop_map(|s| toml::Value::String(s.to_string())),
        1 => (prop::sample::select(LONG), prop::sample::select(&['n', '-', '\u{e9}', ' '][..]))
            .prop_map(|(n, c)| toml::Value::String(c.to_string().repeat(n))),
        1 => any::<bool>().prop_map(toml::Value::Boolean),
    ]
    .boxed()
}

/// A coordinate for polygons: a handful of values, so points repeat and line up.
fn coord() -> BoxedStrategy<f64> {
    prop_oneof![
        6 => prop::sample::select(&[0.0, 1.0, 2.0, 5.0, 1.0 + 1e-12, 5e-324][..]),
        1 => prop::sample::select(NUMBERS),
        1 => -2.0f64..14.0,
    ]
    .boxed()
}

/// A polygon obstacle: few to many points from [`coord`], now and then past the vertex
/// bound; or one of the shapes a convex hull cannot be built from, placed anywhere: one point
/// repeated, points on a line, a triangle so small its sides square to zero or nearly.
fn polygon() -> BoxedStrategy<toml::Value> {
    let sizes = prop_oneof![8 => 0usize..7, 1 => Just(256usize), 1 => Just(257usize)];
    let scattered = (sizes, prop::collection::vec((coord(), coord()), 7)).prop_map(|(n, pool)| {
        (0..n)
            .map(|i| {
                if i < pool.len() {
                    pool[i]
                } else {
                    // Past the pool, points walk a circle so a large polygon has an area.
                    let a = i as f64 * std::f64::consts::TAU / n as f64;
                    (5.0 + a.cos(), 5.0 + a.sin())
                }
            })
            .collect::<Vec<_>>()
    });
    let at = || (-2.0f64..14.0).prop_map(|v| (v * 4.0).round() / 4.0);
    let degenerate = prop_oneof![
        (at(), at(), 1usize..6).prop_map(|(x, y, n)| vec![(x, y); n]),
        (at(), at(), at(), at(), 3usize..6).prop_map(|(x, y, dx, dy, n)| {
            (0..n)
                .map(|i| (x + i as f64 * dx, y + i as f64 * dy))
                .collect()
        }),
        (
            at(),
            at(),
            prop::sample::select(&[5e-324, 1e-310, 1e-160, 1e-8, 1e-4][..])
        )
            .prop_map(|(x, y, s)| vec![(x, y), (x + s, y), (x, y + s)]),
    ];
    prop_oneof![2 => scattered, 1 => degenerate]
        .prop_map(|points| {
            let points = points
                .into_iter()
                .map(|(x, y)| toml::Value::Array(vec![float(x), float(y)]))
                .collect();
            let mut t = toml::Table::new();
            t.insert("points".into(), toml::Value::Array(points));
            toml::Value::Table(t)
        })
        .boxed()
}

/// A circle whose centre and radius are from [`coord`] (zero, negative, NaN, tiny).
fn circle() -> BoxedStrategy<toml::Value> {
    (coord(), coord(), coord())
        .prop_map(|(x, y, r)| {
            let mut t = toml::Table::new();
            t.insert("x".into(), float(x));
            t.insert("y".into(), float(y));
            t.insert("r".into(), float(r));
            toml::Value::Table(t)
        })
        .boxed()
}

/// A rectangle whose corners are from [`coord`] (inverted, empty, NaN, tiny).
fn rectangle() -> BoxedStrategy<toml::Value> {
    (coord(), coord(), coord(), coord())
        .prop_map(|(a, b, c, d)| {
            let mut t = toml::Table::new();
            for (k, v) in [("x_min", a), ("y_min", b), ("x_max", c), ("y_max", d)] {
                t.insert(k.into(), float(v));
            }
            toml::Value::Table(t)
        })
        .boxed()
}

/// `(key, obstacles)`: one to three obstacles of the kind the key holds.
fn obstacles() -> BoxedStrategy<(&'static str, toml::Value)> {
    let list =
        |s: BoxedStrategy<toml::Value>| prop::collection::vec(s, 1..4).prop_map(toml::Value::Array);
    prop_oneof![
        2 => list(polygon()).prop_map(|v| ("polygons", v)),
        1 => list(circle()).prop_map(|v| ("circles", v)),
        1 => list(rectangle()).prop_map(|v| ("rectangles", v)),
    ]
    .boxed()
}

/// A value of the type `like` has: a float for a float, an integer for an integer, a
/// string for a string, an array of such for an array; `pick` chooses among the edges.
fn same_type(like: &toml::Value, pick: Index) -> toml::Value {
    match like {
        toml::Value::Float(_) => float(*pick.get(NUMBERS)),
        toml::Value::Integer(_) => toml::Value::Integer(*pick.get(INTEGERS)),
        toml::Value::String(_) => {
            let all: Vec<String> = WORDS
                .iter()
                .map(|w| w.to_string())
                .chain(LONG.iter().map(|&n| "n".repeat(n)))
                .collect();
            toml::Value::String(pick.get(&all).clone())
        }
        toml::Value::Boolean(b) => toml::Value::Boolean(!b),
        toml::Value::Array(a) if !a.is_empty() => {
            toml::Value::Array(a.iter().map(|v| same_type(v, pick)).collect())
        }
        other => other.clone(),
    }
}

/// Any value: a scalar, an array (empty, of one value repeated up to past a bound, nested),
/// a table, or an obstacle.
pub fn value() -> BoxedStrategy<toml::Value> {
    prop_oneof![
        8 => scalar(),
        2 => (scalar(), prop::sample::select(&[0usize, 1, 2, 3, 4, 257, 1025][..]))
            .prop_map(|(v, n)| toml::Value::Array(vec![v; n])),
        1 => Just(toml::Value::Array(vec![toml::Value::Array(Vec::new())])),
        1 => Just(toml::Value::Table(toml::Table::new())),
        2 => prop::collection::vec(polygon(), 1..3).prop_map(toml::Value::Array),
        1 => polygon(),
        1 => prop::collection::vec(circle(), 1..3).prop_map(toml::Value::Array),
        1 => prop::collection::vec(rectangle(), 1..3).prop_map(toml::Value::Array),
    ]
    .boxed()
}

/// One change to a parsed config.
#[derive(Debug, Clone)]
enum Mutation {
    /// Replace the value at a leaf (or a table, or an array element).
    Set(Index, toml::Value),
    /// Remove a key.
    Remove(Index),
    /// Add a key no schema has.
    Unknown(Index, toml::Value),
    /// Repeat an array's first element until it has this many.
    Grow(Index, usize),
    /// Set one obstacle list to these obstacles.
    Obstacles(&'static str, toml::Value),
    /// Replace the value at a place by an extreme one of the same type.
    SameType(Index, Index),
}

fn mutation() -> BoxedStrategy<Mutation> {
    let ix = any::<Index>;
    prop_oneof![
        8 => (ix(), ix()).prop_map(|(i, p)| Mutation::SameType(i, p)),
        3 => (ix(), value()).prop_map(|(i, v)| Mutation::Set(i, v)),
        1 => ix().prop_map(Mutation::Remove),
        1 => (ix(), scalar()).prop_map(|(i, v)| Mutation::Unknown(i, v)),
        1 => (ix(), prop::sample::select(&[0usize, 257, 1025, 10_001][..]))
            .prop_map(|(i, n)| Mutation::Grow(i, n)),
        4 => obstacles().prop_map(|(k, v)| Mutation::Obstacles(k, v)),
    ]
    .boxed()
}

/// A step of a path into a table: a key or an array index.
#[derive(Debug, Clone, PartialEq)]
enum Step {
    Key(String),
    At(usize),
}

/// Every place in `t` that holds a value (tables, arrays and their elements included).
fn places(t: &toml::Table) -> Vec<Vec<Step>> {
    fn walk(v: &toml::Value, here: &mut Vec<Step>, out: &mut Vec<Vec<Step>>) {
        out.push(here.clone());
        match v {
            toml::Value::Table(t) => {
                for (k, v) in t {
                    here.push(Step::Key(k.clone()));
                    walk(v, here, out);
                    here.pop();
                }
            }
            toml::Value::Array(a) => {
                for (i, v) in a.iter().enumerate() {
                    here.push(Step::At(i));
                    walk(v, here, out);
                    here.pop();
                }
            }
            _ => {}
        }
    }
    let mut out = Vec::new();
    walk(&toml::Value::Table(t.clone()), &mut Vec::new(), &mut out);
    out.remove(0);
    out
}

fn get<'a>(v: &'a toml::Value, path: &[Step]) -> Option<&'a toml::Value> {
    let mut cur = v;
    for s in path {
        cur = match (s, cur) {
            (Step::Key(k), toml::Value::Table(t)) => t.get(k)?,
            (Step::At(i), toml::Value::Array(a)) => a.get(*i)?,
            _ => return None,
        };
    }
    Some(cur)
}

fn at<'a>(v: &'a mut toml::Value, path: &[Step]) -> Option<&'a mut toml::Value> {
    let mut cur = v;
    for s in path {
        cur = match (s, cur) {
            (Step::Key(k), toml::Value::Table(t)) => t.get_mut(k)?,
            (Step::At(i), toml::Value::Array(a)) => a.get_mut(*i)?,
            _ => return None,
        };
    }
    Some(cur)
}

/// The dotted key of `path` (array indices as `[i]`), for the failure message.
fn dotted(path: &[Step]) -> String {
    let mut s = String::new();
    for p in path {
        match p {
            Step::Key(k) if s.is_empty() => s.push_str(k),
            Step::Key(k) => {
                s.push('.');
                s.push_str(k);
            }
            Step::At(i) => s.push_str(&format!("[{i}]")),
        }
    }
    s
}

fn short(v: &toml::Value) -> String {
    let s = v.to_string();
    if s.len() > 80 {
        format!(
            "{}... ({} bytes)",
            &s[..s.floor_char_boundary_compat(80)],
            s.len()
        )
    } else {
        s
    }
}

/// `str::floor_char_boundary` for a stable toolchain.
trait FloorBoundary {
    fn floor_char_boundary_compat(&self, i: usize) -> usize;
}

impl FloorBoundary for String {
    fn floor_char_boundary_compat(&self, mut i: usize) -> usize {
        while !self.is_char_boundary(i) {
            i -= 1;
        }
        i
    }
}

fn apply(root: &mut toml::Value, m: &Mutation, what: &mut Vec<String>) {
    let toml::Value::Table(t) = &*root else {
        return;
    };
    let all = places(t);
    match m {
        Mutation::Set(i, v) => {
            let path = i.get(&all).clone();
            what.push(format!("{} = {}", dotted(&path), short(v)));
            if let Some(slot) = at(root, &path) {
                *slot = v.clone();
            }
        }
        Mutation::Remove(i) => {
            let path = i.get(&all).clone();
            what.push(format!("removed {}", dotted(&path)));
            let (last, parent) = path.split_last().expect("places are never the root");
            match (at(root, parent), last) {
                (Some(toml::Value::Table(t)), Step::Key(k)) => {
                    t.remove(k);
                }
                (Some(toml::Value::Array(a)), Step::At(i)) => {
                    a.remove(*i);
                }
                _ => {}
            }
        }
        Mutation::Unknown(i, v) => {
            let tables: Vec<&Vec<Step>> = all
                .iter()
                .filter(|p| matches!(get(root, p), Some(toml::Value::Table(_))))
                .collect();
            let Some(path) = (!tables.is_empty()).then(|| i.get(&tables).to_vec()) else {
                return;
            };
            what.push(format!("{}.unknown_key = {}", dotted(&path), short(v)));
            if let Some(toml::Value::Table(t)) = at(root, &path) {
                t.insert("unknown_key".into(), v.clone());
            }
        }
        Mutation::Grow(i, n) => {
            let arrays: Vec<&Vec<Step>> = all
                .iter()
                .filter(|p| matches!(get(root, p), Some(toml::Value::Array(a)) if !a.is_empty()))
                .collect();
            let Some(path) = (!arrays.is_empty()).then(|| i.get(&arrays).to_vec()) else {
                return;
            };
            if let Some(toml::Value::Array(a)) = at(root, &path) {
                let first = a[0].clone();
                // At most ~4 MB of text: enough to pass every bound, quick to parse.
                let n = (*n).min((4 << 20) / first.to_string().len().max(1));
                what.push(format!("{} grown to {n} elements", dotted(&path)));
                a.resize(n, first);
            }
        }
        Mutation::SameType(i, pick) => {
            let path = i.get(&all).clone();
            let Some(slot) = at(root, &path) else {
                return;
            };
            *slot = same_type(slot, *pick);
            what.push(format!("{} = {}", dotted(&path), short(slot)));
        }
        Mutation::Obstacles(kind, v) => {
            what.push(format!("map.{kind} = {}", short(v)));
            if let Some(toml::Value::Table(map)) = at(root, &[Step::Key("map".into())]) {
                map.insert(kind.to_string(), v.clone());
            }
        }
    }
}

/// Keys a `--set` may name, with the value the config gives them: the dotted keys of the
/// config (without array indices, which `--set` cannot address) and a few made up.
fn set_keys(t: &toml::Table) -> Vec<(String, toml::Value)> {
    let root = toml::Value::Table(t.clone());
    let mut keys: Vec<(String, toml::Value)> = places(t)
        .into_iter()
        .filter(|p| p.iter().all(|s| matches!(s, Step::Key(_))))
        .map(|p| {
            (
                dotted(&p),
                get(&root, &p).cloned().expect("a place holds a value"),
            )
        })
        .collect();
    let string = || toml::Value::String(String::new());
    keys.extend(
        [
            ("robots.program", toml::Value::Array(vec![string()])),
            ("scenario.name", string()),
            ("no.such.key", toml::Value::Integer(1)),
            ("scenario.name.x", string()),
        ]
        .map(|(k, v)| (k.to_string(), v)),
    );
    keys
}

/// One `--set` argument: `key=value` (an extreme value of the key's type, any value as TOML
/// text, obstacles, a bare string), or something malformed.
fn override_arg(keys: Vec<(String, toml::Value)>) -> BoxedStrategy<String> {
    let names: Vec<String> = keys.iter().map(|(k, _)| k.clone()).collect();
    prop_oneof![
        6 => (prop::sample::select(keys), any::<Index>())
            .prop_map(|((k, v), pick)| format!("{k}={}", same_type(&v, pick))),
        2 => (prop::sample::select(names.clone()), value())
            .prop_map(|(k, v)| format!("{k}={v}")),
        4 => obstacles().prop_map(|(k, v)| format!("map.{k}={v}")),
        1 => (prop::sample::select(names), "\\PC{0,12}").prop_map(|(k, v)| format!("{k}={v}")),
        1 => prop::sample::select(&["", "=", "=1", "a", "a..b=1", ".x=1", "x.=1"][..])
            .prop_map(String::from),
    ]
    .boxed()
}

/// A hostile [`Case`]: a real config, 0 to 3 mutations of its table, 0 to 2 `--set`s.
pub fn case() -> BoxedStrategy<Case> {
    prop::sample::select(real_configs())
        .prop_flat_map(|(name, text)| {
            let table: toml::Table = toml::from_str(&text).expect("a real config is TOML");
            let keys = set_keys(&table);
            (
                Just((name, table)),
                prop::collection::vec(mutation(), 0..3),
                prop::collection::vec(override_arg(keys), 0..3),
            )
        })
        .prop_map(|((name, table), mutations, overrides)| {
            let mut root = toml::Value::Table(table);
            let mut what = Vec::new();
            for m in &mutations {
                apply(&mut root, m, &mut what);
            }
            let text = match &root {
                toml::Value::Table(t) => toml::to_string(t).unwrap_or_else(|e| {
                    what.push(format!("(not serializable: {e}; kept as a value)"));
                    format!("v = {root}")
                }),
                _ => unreachable!("the root stays a table"),
            };
            what.extend(overrides.iter().map(|o| {
                let shown = if o.len() > 120 {
                    &o[..o.floor_char_boundary_compat(120)]
                } else {
                    o
                };
                format!("--set {shown}")
            }));
            Case {
                name,
                text,
                overrides,
                what,
            }
        })
        .boxed()
}
