//! `swarm tune` end to end on a tiny budget: reproducible from its seed whatever `--jobs`,
//! resumes by running only what `tune.csv` lacks, keeps every parameter within its bounds,
//! and refuses bad input before anything is written.

use std::collections::BTreeSet;
use std::path::Path;
use std::time::Duration;

use swarmrt_tests::*;

const LIMIT: Duration = Duration::from_secs(300);

const PARAMS: [&str; 4] = [
    "--param",
    "behaviour.speed=0.3:1.0",
    "--param",
    "behaviour.beacon_period=1:10",
];

/// `tune configs/goto_simple.toml --out <out> --set scenario.ticks=60 --in-process <extra>`.
fn tune(out: &Path, extra: &[&str]) -> std::process::Output {
    let mut args = vec![
        "tune",
        "configs/goto_simple.toml",
        "--out",
        out.to_str().unwrap(),
        "--set",
        "scenario.ticks=60",
        "--in-process",
    ];
    args.extend(extra);
    swarm(&args, LIMIT)
}

/// Two particles, four evaluations an iteration (one re-evaluation each), two iterations;
/// the fitness is a radio counter, which the runs replay exactly.
fn small(out: &Path, jobs: &str) -> std::process::Output {
    let args = small_args(out, jobs);
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    swarm(&args, LIMIT)
}

fn small_args(out: &Path, jobs: &str) -> Vec<String> {
    let mut args = vec![
        "tune",
        "configs/goto_simple.toml",
        "--out",
        out.to_str().unwrap(),
        "--set",
        "scenario.ticks=60",
        "--in-process",
    ];
    args.extend(PARAMS);
    args.extend([
        "--fitness",
        "radio.sent",
        "--particles",
        "2",
        "--evaluations",
        "4",
        "--iterations",
        "2",
        "--seed",
        "5",
        "--jobs",
        jobs,
    ]);
    args.into_iter().map(str::to_string).collect()
}

fn rows(out: &Path) -> Vec<Vec<String>> {
    let text = std::fs::read_to_string(out.join("tune.csv")).unwrap();
    assert!(text.ends_with('\n'), "{text}");
    text.lines()
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect()
}

/// Run directories without the marker `mark_runs` left: the ones (re)made since.
fn unmarked(out: &Path) -> BTreeSet<String> {
    std::fs::read_dir(out.join("runs"))
        .unwrap()
        .flatten()
        .filter(|e| !e.path().join("MARK").exists())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect()
}

#[test]
fn tune_is_reproducible_resumes_and_stays_within_bounds() {
    let tmp = tempfile::tempdir().unwrap();
    let (a, b) = (tmp.path().join("a"), tmp.path().join("b"));
    assert_ok(&small(&a, "2"));

    let csv = rows(&a);
    assert_eq!(
        csv[0],
        [
            "eval",
            "iteration",
            "particle",
            "kind",
            "behaviour.speed",
            "behaviour.beacon_period",
            "seed",
            "fitness",
            "status"
        ]
    );
    assert_eq!(csv.len(), 1 + 2 * 4, "2 iterations x 4 evaluations");
    let kinds: Vec<&str> = csv[1..].iter().map(|r| r[3].as_str()).collect();
    assert_eq!(kinds, ["new", "reeval", "new", "reeval"].repeat(2));
    let mut seeds = BTreeSet::new();
    for (k, r) in csv[1..].iter().enumerate() {
        assert_eq!(r[0], k.to_string());
        let speed: f64 = r[4].parse().unwrap();
        assert!((0.3..=1.0).contains(&speed), "{r:?}");
        let period: u32 = r[5].parse().expect("an integer key gets integers");
        assert!((1..=10).contains(&period), "{r:?}");
        assert_eq!(r[8], "ok", "{r:?}");
        r[7].parse::<f64>().unwrap();
        seeds.insert(r[6].clone());
        assert!(a.join(format!("runs/e{k:05}/metrics.json")).exists());
    }
    assert_eq!(seeds.len(), 8, "every evaluation on its own seed");
    // A re-evaluation in iteration 1 is at its particle's personal best: an earlier position.
    let earlier: BTreeSet<&[String]> = csv[1..5].iter().map(|r| &r[4..6]).collect();
    assert!(earlier.contains(&csv[6][4..6]), "{csv:?}");

    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(a.join("tune.json")).unwrap()).unwrap();
    assert_eq!(summary["complete"], true);
    assert_eq!(summary["evaluations_done"], 8);
    let best_sent = summary["best"]["fitness"].as_f64().unwrap();
    let min_sent = csv[1..]
        .iter()
        .map(|r| r[7].parse::<f64>().unwrap())
        .fold(f64::INFINITY, f64::min);
    assert!(best_sent >= min_sent, "a mean is never below every sample");
    let best = std::fs::read_to_string(a.join("best.toml")).unwrap();
    let period = summary["best"]["params"]["behaviour.beacon_period"]
        .as_u64()
        .unwrap();
    assert!(
        best.contains(&format!("beacon_period = {period}\n")),
        "{best}"
    );
    for f in [
        "best_params.svg",
        "best_params.png",
        "fitness.svg",
        "fitness.png",
    ] {
        assert!(a.join(f).exists(), "{f}");
    }

    // The same command one run at a time, Ctrl-C'd after three rows and resumed: the same
    // bytes.
    let mut child = std::process::Command::new(swarm_bin())
        .current_dir(workspace())
        .args(small_args(&b, "1"))
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    wait_until("three rows", LIMIT, || {
        assert!(child.try_wait().unwrap().is_none(), "the tune ended early");
        std::fs::read_to_string(b.join("tune.csv")).is_ok_and(|t| t.lines().count() >= 4)
    });
    unsafe {
        libc::kill(child.id() as i32, libc::SIGINT);
    }
    let result = wait_with_watchdog(child, LIMIT);
    assert_eq!(result.status.code(), Some(130), "{result:?}");
    let err = String::from_utf8_lossy(&result.stderr);
    assert!(
        err.lines()
            .any(|l| l.contains("resume with:") && l.contains(b.to_str().unwrap())),
        "{err}"
    );
    // Whole rows only, and a run directory for each row and nothing else.
    let part = rows(&b);
    assert!(part.len() >= 4 && part.len() < 9, "{part:?}");
    let dirs: BTreeSet<String> = part[1..]
        .iter()
        .map(|r| format!("e{:05}", r[0].parse::<u64>().unwrap()))
        .collect();
    let all: BTreeSet<String> = std::fs::read_dir(b.join("runs"))
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(all, dirs);
    assert_ok(&small(&b, "1"));
    assert_eq!(bytes(&a, "tune.csv"), bytes(&b, "tune.csv"));
    assert_eq!(bytes(&a, "best.toml"), bytes(&b, "best.toml"));

    // Lose the last three rows (as if Ctrl-C had come before them): resume runs exactly
    // those and ends where the uninterrupted tune did.
    let text = std::fs::read_to_string(b.join("tune.csv")).unwrap();
    let keep: Vec<&str> = text.lines().collect();
    std::fs::write(b.join("tune.csv"), keep[..keep.len() - 3].join("\n") + "\n").unwrap();
    for e in std::fs::read_dir(b.join("runs")).unwrap().flatten() {
        std::fs::write(e.path().join("MARK"), "").unwrap();
    }
    assert_ok(&small(&b, "2"));
    assert_eq!(
        unmarked(&b),
        BTreeSet::from(["e00005".to_string(), "e00006".into(), "e00007".into()])
    );
    assert_eq!(bytes(&a, "tune.csv"), bytes(&b, "tune.csv"));
    assert_eq!(bytes(&a, "best.toml"), bytes(&b, "best.toml"));

    // Another setting in the same directory is refused, and runs nothing.
    let mut extra: Vec<&str> = PARAMS.to_vec();
    extra.extend([
        "--fitness",
        "radio.sent",
        "--particles",
        "2",
        "--iterations",
        "2",
    ]);
    let out = tune(&b, &extra);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("other settings") && err.contains("seed"),
        "{err}"
    );
    assert!(unmarked(&b).len() == 3);
}

#[test]
fn bad_input_is_refused_before_anything_is_written() {
    let tmp = tempfile::tempdir().unwrap();
    let cases: [(&[&str], &str); 7] = [
        (
            &[
                "--param",
                "behaviour.speed=1:0.5",
                "--fitness",
                "radio.sent",
            ],
            "behaviour.speed",
        ),
        (
            &[
                "--param",
                "behaviour.speed=0:nan",
                "--fitness",
                "radio.sent",
            ],
            "behaviour.speed",
        ),
        (
            &["--param", "behaviour.nope=0:1", "--fitness", "radio.sent"],
            "behaviour.nope",
        ),
        (
            &["--param", "behaviour.kind=0:1", "--fitness", "radio.sent"],
            "not a number",
        ),
        (
            &["--param", "radio.loss=0:2", "--fitness", "radio.sent"],
            "radio.loss",
        ),
        (
            &["--param", "radio.loss=0:1", "--fitness", "radio.bogus"],
            "radio.bogus",
        ),
        (
            &[
                "--param",
                "radio.loss=0:1",
                "--fitness",
                "radio.sent",
                "--particles",
                "3",
                "--evaluations",
                "5",
            ],
            "--evaluations",
        ),
    ];
    for (args, needle) in cases {
        let out_dir = tmp.path().join("never");
        let out = tune(&out_dir, args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: {err}");
        assert_eq!(err.lines().count(), 1, "one line: {err}");
        assert!(!out_dir.exists(), "{args:?} wrote {}", out_dir.display());
    }
}
