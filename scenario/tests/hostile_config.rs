//! No panic reaches a user from loading a config (issue 48): hostile mutations of the real
//! configs and hostile `--set` values load or are refused with one short line naming the
//! key; a config that loads writes a resolved config that loads again and writes the same
//! text (the world and robot processes load that one). The bounds of issue 48 (file size, name
//! length, vertex and obstacle counts, degenerate polygons, `robots.program = []`) each have
//! a test of their own here, through [`Config::load`], the path every command shares.

#[path = "common/hostile.rs"]
mod hostile;

use std::io::Write;
use std::path::{Path, PathBuf};

use proptest::prelude::*;
use swarmrt_scenario::Config;

/// An error line, as a user sees it: one line, no control characters, short.
fn assert_one_short_line(shown: &str) -> Result<(), TestCaseError> {
    prop_assert!(!shown.is_empty());
    prop_assert!(!shown.chars().any(char::is_control), "{shown:?}");
    let n = shown.chars().count();
    let head: String = shown.chars().take(200).collect();
    prop_assert!(n <= 2048, "{n} characters: {head}");
    Ok(())
}

/// What every hostile case must come to: loaded (and its resolved config loads again to the
/// same text) or refused in one short line.
fn loads_or_is_refused_in_one_short_line(case: &hostile::Case) -> Result<(), TestCaseError> {
    match Config::from_toml_str(&case.name, &case.text, &case.overrides) {
        Ok(cfg) => {
            // Compared as text: `[behaviour]` is opaque here, and may hold a NaN the
            // behaviour refuses later (`tests/tests/e2e/config_fuzz.rs` goes that far).
            let resolved = cfg.to_toml();
            let again = Config::from_toml_str("config.toml", &resolved, &[]).map(|c| c.to_toml());
            prop_assert_eq!(again, Ok(resolved), "{:?}", case.what);
        }
        Err(e) => assert_one_short_line(&e.to_string())?,
    }
    Ok(())
}

// 1,000 cases in two tests of 500 from two seeds, so that they run side by side.
proptest! {
    #![proptest_config(hostile::runner(500))]

    #[test]
    fn hostile_configs_and_sets_load_or_are_refused_in_one_short_line(case in hostile::case()) {
        loads_or_is_refused_in_one_short_line(&case)?;
    }
}

proptest! {
    #![proptest_config(hostile::runner_from(0x48_b0_0e, 500))]

    #[test]
    fn more_hostile_configs_and_sets_load_or_are_refused_in_one_short_line(
        case in hostile::case()
    ) {
        loads_or_is_refused_in_one_short_line(&case)?;
    }
}

fn goto_simple() -> String {
    std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs/goto_simple.toml"),
    )
    .unwrap()
}

/// A fresh directory under the system's temporary one, removed when dropped.
struct Tmp(PathBuf);

impl Tmp {
    fn new(name: &str) -> Tmp {
        let p = std::env::temp_dir().join(format!("swarmrt-hostile-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&p);
        std::fs::create_dir_all(&p).unwrap();
        Tmp(p)
    }
}

impl Drop for Tmp {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn load_text(dir: &Tmp, text: &str, set: &[&str]) -> Result<Config, String> {
    let p = dir.0.join("c.toml");
    std::fs::write(&p, text).unwrap();
    let set: Vec<String> = set.iter().map(|s| s.to_string()).collect();
    Config::load(&p, &set).map_err(|e| e.to_string())
}

#[test]
fn a_config_past_one_mebibyte_is_refused_by_its_size() {
    let dir = Tmp::new("size");
    let big = goto_simple().replace("goto_simple", &"n".repeat(100_000_000));
    let e = load_text(&dir, &big, &[]).unwrap_err();
    assert!(
        e.contains("c.toml: expected at most 1048576 bytes (1 MiB), got 1000"),
        "{e}"
    );
    // The same bound holds for text handed over directly and for one `--set`.
    let e = Config::from_toml_str("t.toml", &big, &[]).unwrap_err();
    assert!(e.to_string().contains("at most 1048576 bytes"), "{e}");
    let set = format!("scenario.name={}", "n".repeat(1 << 20));
    let e = Config::from_toml_str("t.toml", &goto_simple(), &[set]).unwrap_err();
    assert_eq!(e.key, "scenario.name");
    assert!(
        e.to_string()
            .starts_with("--set: key `scenario.name`: expected at most"),
        "{e}"
    );
}

#[test]
fn a_device_a_fifo_and_a_directory_are_refused_without_blocking() {
    // /dev/null, not /dev/zero: a loader without the bound would read /dev/zero until this
    // test process is killed for its memory (`tests/tests/e2e/bad_input.rs` tries /dev/zero in a
    // child process with a capped address space).
    let e = Config::load(Path::new("/dev/null"), &[]).unwrap_err();
    assert_eq!(
        e.to_string(),
        "/dev/null: cannot read: a character device, not a regular file"
    );
    let dir = Tmp::new("fifo");
    let fifo = dir.0.join("pipe.toml");
    let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
    // SAFETY: mkfifo on a NUL-terminated path.
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
    // A thread with a deadline: a blocking open would wait for a writer for ever.
    let (tx, rx) = std::sync::mpsc::channel();
    let p = fifo.clone();
    std::thread::spawn(move || {
        let _ = tx.send(Config::load(&p, &[]).map_err(|e| e.to_string()));
    });
    let got = rx
        .recv_timeout(std::time::Duration::from_secs(20))
        .expect("loading a FIFO returned within 20 s");
    assert!(
        got.unwrap_err()
            .contains("a FIFO (named pipe), not a regular file")
    );
    let e = Config::load(&dir.0, &[]).unwrap_err();
    assert!(
        e.to_string()
            .ends_with("cannot read: a directory, not a regular file"),
        "{e}"
    );
}

#[test]
fn a_file_that_grows_past_the_bound_is_cut_at_the_bound() {
    // /proc files say they are empty and are not: the read itself is bounded.
    let e = Config::load(Path::new("/proc/self/environ"), &[]);
    assert!(e.is_err());
    let dir = Tmp::new("grow");
    let p = dir.0.join("c.toml");
    let mut f = std::fs::File::create(&p).unwrap();
    f.write_all(goto_simple().as_bytes()).unwrap();
    f.write_all(&vec![b'#'; 1 << 20]).unwrap();
    let e = Config::load(&p, &[]).unwrap_err().to_string();
    assert!(e.contains("expected at most 1048576 bytes"), "{e}");
}

#[test]
fn names_longer_than_a_run_directory_allows_are_refused_with_the_bound() {
    let dir = Tmp::new("name");
    for n in [65, 300, 100_000] {
        let e = load_text(
            &dir,
            &goto_simple(),
            &[&format!("scenario.name={}", "a".repeat(n))],
        )
        .unwrap_err();
        assert!(
            e.ends_with(&format!(
                "key `scenario.name`: expected a name of at most 64 bytes (it becomes a \
                 directory name), got {n} bytes"
            )),
            "{e}"
        );
    }
    let ok = load_text(
        &dir,
        &goto_simple(),
        &[&format!("scenario.name={}", "a".repeat(64))],
    );
    assert_eq!(ok.unwrap().scenario.name.len(), 64);
}

/// `map.polygons=[{ points = [...] }]` of `points`.
fn polygon_set(points: &[[f64; 2]]) -> String {
    let num = |v: f64| {
        if v.is_nan() {
            "nan".to_string()
        } else {
            format!("{v:?}")
        }
    };
    let p: Vec<String> = points
        .iter()
        .map(|&[x, y]| format!("[{}, {}]", num(x), num(y)))
        .collect();
    format!("map.polygons=[{{ points = [{}] }}]", p.join(", "))
}

#[test]
fn polygons_parry_cannot_hull_are_refused_with_their_index_and_why() {
    let dir = Tmp::new("poly");
    let refused = |points: &[[f64; 2]], why: &str| {
        let e = load_text(&dir, &goto_simple(), &[&polygon_set(points)]).unwrap_err();
        assert!(
            e.contains(
                "key `map.polygons[0].points`: expected a polygon of at least 3 distinct points"
            ),
            "{e}"
        );
        assert!(e.ends_with(why), "{e}");
    };
    // parry2d 0.25's hull asserts on these (issue 48: exit 101 with a backtrace) ...
    refused(
        &[[1.0, 1.0]; 3],
        "got 1 distinct of its 3 points (the others repeat them)",
    );
    // ... or indexes past its facets (points so close their distance squared is zero).
    refused(
        &[[0.0, 0.0], [5e-324, 0.0], [0.0, 5e-324]],
        "got its 3 distinct points on one line",
    );
    refused(
        &[[1.0, 1.0], [2.0, 2.0], [3.0, 3.0]],
        "got its 3 distinct points on one line",
    );
    refused(
        &[[1.0, 1.0], [1.0, 1.0], [2.0, 2.0], [2.0, 2.0]],
        "got 2 distinct of its 4 points (the others repeat them)",
    );
    refused(
        &[[0.0, 0.0], [1e-4, 0.0], [0.0, 2e-4]],
        "got an area of 1e-8 m²",
    );
    let e = load_text(
        &dir,
        &goto_simple(),
        &[&polygon_set(&[[f64::NAN, 1.0], [2.0, 1.0], [1.0, 2.0]])],
    )
    .unwrap_err();
    assert!(
        e.contains(
            "key `map.polygons[0].points[0][0]`: expected a number in [-1000000, 1000000], got NaN"
        ),
        "{e}"
    );
    // The second polygon is named by its index; a repeated closing point is fine.
    let good = "{ points = [[2.5, 6.5], [4.0, 6.5], [3.2, 8.0], [2.5, 6.5]] }";
    let e = load_text(
        &dir,
        &goto_simple(),
        &[&format!(
            "map.polygons=[{good}, {{ points = [[1.0, 1.0], [1.0, 1.0], [1.0, 1.0]] }}]"
        )],
    )
    .unwrap_err();
    assert!(e.contains("key `map.polygons[1].points`"), "{e}");
    load_text(&dir, &goto_simple(), &[&format!("map.polygons=[{good}]")]).unwrap();
}

fn circle_of(n: usize) -> Vec<[f64; 2]> {
    (0..n)
        .map(|i| {
            let a = i as f64 * std::f64::consts::TAU / n as f64;
            [5.0 + a.cos(), 5.0 + a.sin()]
        })
        .collect()
}

#[test]
fn a_polygon_past_256_vertices_and_more_than_10000_obstacles_are_refused() {
    let dir = Tmp::new("count");
    load_text(&dir, &goto_simple(), &[&polygon_set(&circle_of(256))]).unwrap();
    let e = load_text(&dir, &goto_simple(), &[&polygon_set(&circle_of(257))]).unwrap_err();
    assert!(
        e.ends_with("key `map.polygons[0].points`: expected 3 to 256 points [x, y], got 257"),
        "{e}"
    );
    let circles = vec!["{ x = 11.0, y = 1.0, r = 0.1 }"; 10_001].join(", ");
    let e = load_text(&dir, &goto_simple(), &[&format!("map.circles=[{circles}]")]).unwrap_err();
    assert!(
        e.ends_with("key `map.circles`: expected at most 10000 circles, got 10001"),
        "{e}"
    );
}

#[test]
fn an_empty_robot_program_is_refused_as_the_reference_says() {
    let dir = Tmp::new("program");
    let e = load_text(&dir, &goto_simple(), &["robots.program=[]"]).unwrap_err();
    assert!(e.contains("key `robots.program`: expected a command line like [\"python3\", \"robot.py\"] whose first word is a program, got []"), "{e}");
    let text = goto_simple().replace("[robots]\n", "[robots]\nprogram = []\n");
    assert!(
        load_text(&dir, &text, &[])
            .unwrap_err()
            .contains("key `robots.program`")
    );
    let long = format!("robots.program=[\"{}\"]", "p".repeat(4097));
    let e = load_text(&dir, &goto_simple(), &[&long]).unwrap_err();
    assert!(
        e.contains("key `robots.program[0]`: expected a word of at most 4096 bytes"),
        "{e}"
    );
    load_text(&dir, &goto_simple(), &["robots.program=[\"swarm-agent\"]"]).unwrap();
}

#[test]
fn the_reference_states_the_bounds_the_loader_checks() {
    use swarmrt_scenario::limits::*;
    use swarmrt_scenario::reference::{Bounds, KEYS, find};
    let rule = |key: &str| match find(KEYS, key).bounds {
        Bounds::Rule(r) => r.to_string(),
        _ => find(KEYS, key).also.to_string(),
    };
    assert!(rule("scenario.name").contains(&format!("at most {MAX_NAME_BYTES} bytes")));
    assert!(rule("map.polygons[i].points").contains(&format!("3 to {MAX_POLYGON_POINTS} points")));
    assert!(rule("map.polygons[i].points").contains(&format!("{MIN_POLYGON_AREA:e} m²")));
    for key in ["robots.program", "robots.programs[i].program"] {
        assert!(rule(key).contains(&format!(
            "1 to {MAX_ARGS} words of at most {MAX_ARG_BYTES} bytes"
        )));
    }
}
