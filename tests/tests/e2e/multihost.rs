//! One swarm across three emulated hosts (issue 16): network namespaces joined by a bridge,
//! each host with its own /dev/shm, the world on host 0 and groups of robots on hosts 1 and 2
//! reached over Zenoh. Needs root and iproute2; fails (never skips) without them.

use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use swarmrt_tests::lab::Lab;
use swarmrt_tests::{LOSSY_RADIO, assert_ok, bytes, metrics, swarm_bin, workspace};

const LIMIT: Duration = Duration::from_secs(300);

fn lab() -> Lab {
    Lab::new(3).unwrap_or_else(|e| {
        panic!("cannot build the emulated hosts (this test needs root and iproute2): {e}")
    })
}

/// A hosts file: the world on host 0, `counts[i]` robots on host i + 1, over the default
/// mutually authenticated `quic/` link with certificates from `swarm certs` in `dir/certs`.
fn hosts_file(lab: &Lab, dir: &Path, counts: &[u32], extra: &str) -> std::path::PathBuf {
    let path = hosts_file_with(lab, dir, counts, extra, "quic");
    let certs = swarmrt_tests::swarm(&["certs", path.to_str().unwrap()], LIMIT);
    assert_ok(&certs);
    path
}

/// [`hosts_file`] with endpoints of `scheme` and no certificates.
fn hosts_file_with(
    lab: &Lab,
    dir: &Path,
    counts: &[u32],
    extra: &str,
    scheme: &str,
) -> std::path::PathBuf {
    let mut text = format!("[world]\nlisten = \"{scheme}/{}:7447\"\n", lab.addr(0));
    for (i, c) in counts.iter().enumerate() {
        let launcher: Vec<String> = lab
            .launcher(i + 1)
            .iter()
            .map(|s| format!("{s:?}"))
            .collect();
        text += &format!(
            "\n[[host]]\nname = \"h{}\"\nlauncher = [{}]\nrobots = {c}\n{extra}",
            i + 1,
            launcher.join(", ")
        );
    }
    let path = dir.join("hosts.toml");
    std::fs::write(&path, text).unwrap();
    path
}

/// `swarm args...` on host 0.
fn swarm_on_host0(lab: &Lab, args: &[&str]) -> std::process::Child {
    swarm_on_host0_with(lab, args, &[])
}

/// [`swarm_on_host0`] with environment variables `env` (which reach every host's
/// `swarm-host` through the launchers).
fn swarm_on_host0_with(lab: &Lab, args: &[&str], env: &[(&str, &str)]) -> std::process::Child {
    let l = lab.launcher(0);
    // nsenter -m starts in /; the configs are relative to the workspace.
    let wd = format!("--wd={}", workspace().display());
    Command::new(&l[0])
        .args(&l[1..l.len() - 1])
        .args([wd.as_str(), "--"])
        .arg(swarm_bin())
        .args(args)
        .envs(env.iter().copied())
        .current_dir(workspace())
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("nsenter starts")
}

fn run_on_host0(lab: &Lab, args: &[&str]) -> Output {
    swarmrt_tests::wait_with_watchdog(swarm_on_host0(lab, args), LIMIT)
}

/// Nothing of the run is left on any host: no process, no shared memory, no iceoryx2 files.
fn assert_hosts_clean(lab: &Lab) {
    for i in 0..3 {
        // Processes the run left would show here (the lab's holder excluded).
        let since = Instant::now();
        while !lab.processes(i).is_empty() && since.elapsed() < Duration::from_secs(5) {
            std::thread::sleep(Duration::from_millis(50));
        }
        assert_eq!(
            lab.processes(i),
            Vec::<i32>::new(),
            "processes left on host {i}"
        );
        let shm: Vec<String> = lab
            .shm(i)
            .into_iter()
            .filter(|e| e.starts_with("swarmrt"))
            .collect();
        // The base directory of run roots may stay; no run root or segment may.
        let roots = lab_roots(lab, i);
        assert!(
            shm.iter()
                .all(|e| swarmrt_protocol::services::ipc_base_dir().ends_with(e))
                && roots.is_empty(),
            "host {i} keeps {shm:?} {roots:?}"
        );
    }
}

fn lab_roots(lab: &Lab, i: usize) -> Vec<String> {
    let l = lab.launcher(i);
    let out = Command::new(&l[0])
        .args(&l[1..])
        .args(["ls", "-A"])
        .arg(swarmrt_protocol::services::ipc_base_dir())
        .output()
        .unwrap();
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(str::to_string)
        .collect()
}

#[test]
fn three_hosts_write_the_bytes_of_one_with_remote_faults() {
    let lab = lab();
    let tmp = tempfile::tempdir().unwrap();
    // Robots 5 and 6 on host 2, 7 and 8 on host 1: a kill, a freeze and a restart all land
    // on remote robots, over a lossy, late radio.
    let faults = [
        "--set",
        "faults.kill=[{tick=60,robot=8}]",
        "--set",
        "faults.freeze=[{robot=5,from=70,to=110}]",
        "--set",
        "faults.restart=[{tick=120,robot=7,down_ticks=10}]",
    ];
    let mut common = vec!["--ticks", "300"];
    common.extend_from_slice(&faults);
    common.extend_from_slice(&LOSSY_RADIO);
    let one = tmp.path().join("one");
    let mut args = vec![
        "run",
        "configs/raft_election.toml",
        "--out",
        one.to_str().unwrap(),
    ];
    args.extend_from_slice(&common);
    assert_ok(&swarmrt_tests::swarm(&args, LIMIT));

    let hosts = hosts_file(&lab, tmp.path(), &[2, 2], "");
    let three = tmp.path().join("three");
    let mut args = vec![
        "run",
        "configs/raft_election.toml",
        "--hosts",
        hosts.to_str().unwrap(),
        "--out",
        three.to_str().unwrap(),
    ];
    args.extend_from_slice(&common);
    assert_ok(&run_on_host0(&lab, &args));

    for f in ["trajectory.csv", "events.jsonl"] {
        assert!(
            bytes(&one, f) == bytes(&three, f),
            "{f} differs between one host and three"
        );
    }
    let m = metrics(&three);
    assert_eq!(m["reproducible"], true, "{m}");
    assert_eq!(m["faults_injected"], 3, "{m}");
    let ticks = m["ticks"].as_u64().unwrap();
    // Each host received only its own robots' slots, every tick.
    for (host, count) in [("h1", 2), ("h2", 2)] {
        let h = &m["hosts"][host];
        assert_eq!(h["ticks"].as_u64(), Some(ticks), "{host}: {h}");
        assert_eq!(
            h["slots_received"].as_u64(),
            Some(count * ticks),
            "{host}: {h}"
        );
        assert_eq!(h["malformed"], 0, "{host}: {h}");
        // Two messages per host per tick: one batch back per tick (plus the hellos), none
        // sent early.
        assert_eq!(h["partial_batches"], 0, "{host}: {h}");
        assert!(
            h["batches_up"].as_u64().unwrap() <= ticks + 4,
            "{host}: {h}"
        );
    }
    assert_eq!(
        m["hosts"]["h1"]["robots"],
        serde_json::json!({"start": 7, "end": 9})
    );
    assert_eq!(
        m["hosts"]["h2"]["robots"],
        serde_json::json!({"start": 5, "end": 7})
    );
    // The restarted robot ran twice on host 1; the killed one was killed there.
    let procs = m["processes"].as_array().unwrap();
    let on = |robot: u64| -> Vec<&serde_json::Value> {
        procs.iter().filter(|p| p["robot"] == robot).collect()
    };
    assert_eq!(on(7).len(), 2, "{procs:?}");
    assert!(on(7).iter().all(|p| p["host"] == "h1"));
    assert_eq!(on(8)[0]["end"], "killed by signal 9");
    assert_eq!(on(0)[0].get("host"), None, "robot 0 runs beside the world");
    assert_hosts_clean(&lab);
}

#[test]
fn a_killed_host_kills_its_robots_and_the_run_goes_on() {
    lose_host_2(|_, host_pid| unsafe {
        libc::kill(host_pid, libc::SIGKILL);
    });
}

#[test]
fn a_cut_link_kills_the_hosts_robots_and_the_run_goes_on() {
    lose_host_2(|lab, _| {
        let ns = lab.netns(2);
        let out = Command::new("ip")
            .args(["-n", &ns, "link", "set", "h2", "down"])
            .output()
            .unwrap();
        assert!(out.status.success(), "cannot cut host 2's link");
    });
}

/// Runs flocking over three hosts and, once it is going, loses host 2 by `lose(lab, pid of
/// its swarm-host)`; asserts that its robots die, the run goes on and nothing is left.
fn lose_host_2(lose: impl FnOnce(&Lab, i32)) {
    let lab = lab();
    let tmp = tempfile::tempdir().unwrap();
    let hosts = hosts_file(&lab, tmp.path(), &[3, 3], "");
    let out = tmp.path().join("run");
    let child = swarm_on_host0(
        &lab,
        &[
            "run",
            "configs/flocking_crossing.toml",
            "--hosts",
            hosts.to_str().unwrap(),
            "--ticks",
            "100000",
            "--out",
            out.to_str().unwrap(),
            "--set",
            "scenario.stop_when_done=false",
        ],
    );
    // Once host 2's robots are running, kill its swarm-host.
    let since = Instant::now();
    let host_pid = loop {
        let rows = std::fs::read_to_string(out.join("trajectory.csv"))
            .map(|t| t.lines().count())
            .unwrap_or(0);
        let found = lab.processes(2).into_iter().find(|&p| {
            std::fs::read_to_string(format!("/proc/{p}/comm"))
                .is_ok_and(|c| c.trim() == "swarm-host")
        });
        if let Some(p) = found
            && rows > 10 * 50
        {
            break p;
        }
        assert!(since.elapsed() < LIMIT, "the run never got going");
        std::thread::sleep(Duration::from_millis(50));
    };
    lose(&lab, host_pid);
    // Let the run go on a while without host 2 (a cut link is noticed after Zenoh's lease,
    // 3 s), then stop it as a user would.
    std::thread::sleep(Duration::from_secs(6));
    unsafe {
        libc::kill(child.id() as i32, libc::SIGINT);
    }
    let o = swarmrt_tests::wait_with_watchdog(child, LIMIT);
    let m = metrics(&out);
    assert!(
        !String::from_utf8_lossy(&o.stderr).contains("panicked"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert_eq!(m["reproducible"], false, "{m}");
    let deaths: Vec<u64> = m["unscheduled_deaths"]
        .as_array()
        .unwrap()
        .iter()
        .map(|d| d["robot"].as_u64().unwrap())
        .collect();
    // Host 2 ran robots 4, 5, 6 (host 1 the top three, 7-9).
    assert_eq!(deaths, vec![4, 5, 6], "{m}");
    assert!(m["hosts"]["h2"]["lost"].is_string(), "{m}");
    // The run went on: host 1's robots kept answering after host 2 was gone.
    let ticks = m["ticks"].as_u64().unwrap();
    let h1_ticks = m["hosts"]["h1"]["ticks"].as_u64().unwrap();
    assert!(
        h1_ticks + 2 >= ticks,
        "host 1 saw {h1_ticks} of {ticks} ticks"
    );
    let traj = String::from_utf8(bytes(&out, "trajectory.csv")).unwrap();
    let last_tick = traj
        .lines()
        .last()
        .unwrap()
        .split(',')
        .next()
        .unwrap()
        .to_string();
    let dead_at_end = traj
        .lines()
        .filter(|l| l.starts_with(&format!("{last_tick},")) && l.contains("dead"))
        .count();
    assert_eq!(dead_at_end, 3, "host 2's robots are dead at the end");
    assert_hosts_clean(&lab);
}

#[test]
fn bad_or_unreachable_hosts_fail_fast_with_their_name() {
    let lab = lab();
    let tmp = tempfile::tempdir().unwrap();
    // A host that cannot reach the world (nobody listens there).
    let bad = hosts_file(
        &lab,
        tmp.path(),
        &[2, 2],
        &format!("connect = \"quic/{}:7999\"\n", lab.addr(0)),
    );
    // Runs flocking with `hosts`; returns the error output of a run that must fail with
    // exit 2 and leave nothing on any host.
    let fails = |hosts: &Path, out: &str| -> String {
        let o = run_on_host0(
            &lab,
            &[
                "run",
                "configs/flocking_crossing.toml",
                "--hosts",
                hosts.to_str().unwrap(),
                "--out",
                tmp.path().join(out).to_str().unwrap(),
            ],
        );
        let err = String::from_utf8_lossy(&o.stderr).into_owned();
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert_hosts_clean(&lab);
        err
    };
    let started = Instant::now();
    let err = fails(&bad, "a");
    let line = err
        .lines()
        .find(|l| l.starts_with("error:"))
        .unwrap_or_default();
    assert!(
        line.contains("host h") && line.contains("cannot reach the world"),
        "{err}"
    );
    assert!(started.elapsed() < Duration::from_secs(60));

    // A launcher that does not exist.
    let text =
        std::fs::read_to_string(&bad)
            .unwrap()
            .replacen("\"nsenter\"", "\"/nonexistent/ssh\"", 1);
    std::fs::write(&bad, text).unwrap();
    let err = fails(&bad, "b");
    assert!(
        err.contains("hosts.toml")
            && err.contains("host[0].launcher")
            && err.contains("/nonexistent/ssh"),
        "{err}"
    );
}

/// The link's trust, end to end (docs/security.md): plain `tcp/` is refused unless asked
/// for; a stranger on a fourth host, posing as host h1 with a certificate of another CA or
/// with none, never gets in while a secure run goes on; and the secure run writes the bytes
/// of the insecure one.
#[test]
fn an_insecure_link_must_be_asked_for_and_a_stranger_never_gets_in() {
    let lab = Lab::new(4).unwrap_or_else(|e| panic!("cannot build the emulated hosts: {e}"));
    let tmp = tempfile::tempdir().unwrap();
    let (tcp_dir, quic_dir, evil_dir) = (
        tmp.path().join("tcp"),
        tmp.path().join("quic"),
        tmp.path().join("evil"),
    );
    for d in [&tcp_dir, &quic_dir, &evil_dir] {
        std::fs::create_dir(d).unwrap();
    }
    let counts = [2, 2];
    let tcp = hosts_file_with(&lab, &tcp_dir, &counts, "", "tcp");
    let run = |hosts: &Path, out: &str, extra: &[&str]| {
        let out = tmp.path().join(out);
        let mut args = vec![
            "run",
            "configs/flocking_crossing.toml",
            "--ticks",
            "200",
            "--hosts",
            hosts.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        (run_on_host0(&lab, &args), out)
    };
    let (o, _) = run(&tcp, "refused", &[]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("plain TCP") && err.contains("--insecure-link") && err.contains("swarm certs"),
        "{err}"
    );
    assert_hosts_clean(&lab);
    let (o, insecure) = run(&tcp, "insecure", &["--insecure-link"]);
    assert_ok(&o);
    assert_eq!(metrics(&insecure)["link"], "tcp (insecure)");

    // The stranger's certificates: a CA of its own, naming h1.
    let quic = hosts_file(&lab, &quic_dir, &counts, "");
    // Its hosts file and certificates, from a CA of its own.
    hosts_file(&lab, &evil_dir, &counts, "");
    let toml = std::fs::read_to_string(workspace().join("configs/flocking_crossing.toml")).unwrap();
    let config = swarmrt_protocol::control::HostControl::Config { toml }.to_line();
    let stranger = |certs: Option<&Path>| {
        let l = lab.launcher(3);
        let mut c = Command::new(&l[0]);
        c.args(&l[1..])
            .arg(swarmrt_tests::bin_dir().join("swarm-host"))
            .args(["--run-id", "5712a9", "--host", "h1", "--first", "7"])
            .args(["--count", "2", "--connect"])
            .arg(format!("quic/{}:7447", lab.addr(0)));
        if let Some(d) = certs {
            c.arg("--certs").arg(d);
        }
        let mut child = c
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        use std::io::Write;
        child
            .stdin
            .as_mut()
            .unwrap()
            .write_all(config.as_bytes())
            .unwrap();
        child
    };
    let with_evil_ca = stranger(Some(&evil_dir.join("certs")));
    let (o, secure) = run(&quic, "secure", &[]);
    assert_ok(&o);
    let out = swarmrt_tests::wait_with_watchdog(with_evil_ca, LIMIT);
    let said = String::from_utf8_lossy(&out.stdout);
    assert!(
        !out.status.success() && said.contains("cannot reach the world"),
        "the stranger with another CA's certificate got in: {said}"
    );
    // A certificate of the run's CA, but h2's, offered as h1's: refused by the host itself
    // in one line (the world's access control would drop all it says).
    let stolen = tmp.path().join("stolen");
    std::fs::create_dir(&stolen).unwrap();
    let quic_certs = quic_dir.join("certs");
    std::fs::copy(quic_certs.join("ca.pem"), stolen.join("ca.pem")).unwrap();
    for ext in ["pem", "key"] {
        std::fs::copy(
            quic_certs.join(format!("host-h2.{ext}")),
            stolen.join(format!("host-h1.{ext}")),
        )
        .unwrap();
    }
    let posing = swarmrt_tests::wait_with_watchdog(stranger(Some(&stolen)), LIMIT);
    let said = String::from_utf8_lossy(&posing.stdout);
    assert!(
        !posing.status.success() && said.contains(r#"names host \"h2\", not \"h1\""#),
        "{said}"
    );
    let without = swarmrt_tests::wait_with_watchdog(stranger(None), LIMIT);
    let said = String::from_utf8_lossy(&without.stdout);
    assert!(
        !without.status.success() && said.contains("needs --certs"),
        "{said}"
    );
    let m = metrics(&secure);
    assert_eq!(m["link"], "mutual tls", "{m}");
    for host in ["h1", "h2"] {
        assert_eq!(
            m["shell"]["link"].as_array().map(|a| a.len()),
            Some(2),
            "{m}"
        );
        assert_eq!(m["hosts"][host]["malformed"], 0, "{host}: {m}");
    }
    for f in ["trajectory.csv", "events.jsonl"] {
        assert!(
            bytes(&insecure, f) == bytes(&secure, f),
            "{f} differs between the insecure and the secure link"
        );
    }
    assert_hosts_clean(&lab);
}

/// Issue 48's flood, end to end: host h1, holding its own valid certificate, floods valid
/// empty batches on its own up key for the whole run (the test build's
/// `SWARMRT_TEST_HOST_FLOOD`), while h2's robots keep answering. Before, the world's one
/// shared queue dropped batches of h2, whose robots were then declared unresponsive and dead.
/// Now no robot dies, neither h2's nor h1's own (what the world dropped of h1 it asks h1 to
/// resend), the flood is counted against h1 alone with one warning line, and the run writes
/// the bytes of the same run on one host.
#[test]
fn a_host_flooding_its_own_key_costs_no_robot_its_life() {
    let lab = lab();
    let tmp = tempfile::tempdir().unwrap();
    // 80 ticks: the flood takes most of both cores (a tick ~0.5 s, 200 ticks took 108 s).
    // At c0b8b90 the first dropped batch of h2 cost its robots their lives 30 s later
    // (`unresponsive_ms`), well inside the run; now no robot may die at all.
    let common = ["--ticks", "80", "--set", "scenario.stop_when_done=false"];
    let one = tmp.path().join("one");
    let mut args = vec![
        "run",
        "configs/flocking_crossing.toml",
        "--out",
        one.to_str().unwrap(),
    ];
    args.extend_from_slice(&common);
    assert_ok(&swarmrt_tests::swarm(&args, LIMIT));

    let hosts = hosts_file(&lab, tmp.path(), &[3, 3], "");
    let flooded = tmp.path().join("flooded");
    let mut args = vec![
        "run",
        "configs/flocking_crossing.toml",
        "--hosts",
        hosts.to_str().unwrap(),
        "--out",
        flooded.to_str().unwrap(),
    ];
    args.extend_from_slice(&common);
    let started = Instant::now();
    let o = swarmrt_tests::wait_with_watchdog(
        swarm_on_host0_with(&lab, &args, &[("SWARMRT_TEST_HOST_FLOOD", "h1")]),
        LIMIT,
    );
    let took = started.elapsed();
    assert_ok(&o);
    let m = metrics(&flooded);
    assert_eq!(m["unscheduled_deaths"], serde_json::json!([]), "{m}");
    assert_eq!(m["reproducible"], true, "{m}");
    let link = m["shell"]["link"].as_array().unwrap();
    let of = |name: &str| link.iter().find(|l| l["host"] == name).unwrap();
    assert!(of("h1")["dropped"].as_u64().unwrap() > 0, "h1 flooded: {m}");
    assert_eq!(
        of("h2")["dropped"],
        0,
        "h2 lost messages to h1's flood: {m}"
    );
    assert_eq!(of("h2")["resends"], 0, "{m}");
    let err = String::from_utf8_lossy(&o.stderr);
    let warned = err
        .lines()
        .filter(|l| l.contains("sends faster than the world reads"))
        .collect::<Vec<_>>();
    assert!(
        warned.len() == 1 && warned[0].contains("host h1"),
        "one warning line, naming h1: {err}"
    );
    for f in ["trajectory.csv", "events.jsonl"] {
        assert!(
            bytes(&one, f) == bytes(&flooded, f),
            "{f} differs between one host and three under a flood"
        );
    }
    eprintln!(
        "flooded run {took:.1?}; h1: dropped {}, resends {}, recovered {}",
        of("h1")["dropped"],
        of("h1")["resends"],
        of("h1")["recovered"]
    );
    assert_hosts_clean(&lab);
}

/// `swarm certs` with a link planted at `ca.key` (issue 48): before, it wrote `ca.pem`, then
/// stopped at the link with a bare "File exists". Now it refuses in one line naming the link,
/// exits 2, writes nothing, and leaves the link's target as it was. No namespaces needed.
#[test]
fn swarm_certs_refuses_a_planted_link_in_one_line_and_writes_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let hosts = tmp.path().join("hosts.toml");
    std::fs::write(
        &hosts,
        "[world]\nlisten = \"quic/10.0.0.1:7447\"\n\n[[host]]\nname = \"h1\"\nlauncher = [\"ssh\", \"h1\"]\nrobots = 2\n",
    )
    .unwrap();
    let certs = tmp.path().join("certs");
    std::fs::create_dir(&certs).unwrap();
    let victim = tmp.path().join("victim");
    std::fs::write(&victim, "the victim's own file\n").unwrap();
    std::os::unix::fs::symlink(&victim, certs.join("ca.key")).unwrap();
    let o = swarmrt_tests::swarm(&["certs", hosts.to_str().unwrap()], LIMIT);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
    assert!(
        lines.len() == 1
            && lines[0].starts_with("error:")
            && lines[0].contains(&certs.join("ca.key").display().to_string())
            && lines[0].contains("is a symbolic link"),
        "{err}"
    );
    let left: Vec<String> = std::fs::read_dir(&certs)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(left, vec!["ca.key"], "swarm certs left files behind");
    assert_eq!(
        std::fs::read_to_string(&victim).unwrap(),
        "the victim's own file\n"
    );
}
