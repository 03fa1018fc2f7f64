//! `swarm view` and `swarm run --view` as a user meets them: in a real browser (Debian's
//! chromium over WebDriver), reading what the page drew, clicking what a user clicks.
//! Screenshots land in `target/viewer-screenshots/`.

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::Child;
use std::time::Duration;

use fantoccini::actions::InputSource;
use serde_json::Value;
use swarmrt_tests::browser::Browser;
use swarmrt_tests::{run_config, spawn_swarm, swarm};

const LIMIT: Duration = Duration::from_secs(60);

/// A `swarm` process killed when the test ends, passed or panicked.
struct Swarm(Child);

impl std::ops::Deref for Swarm {
    type Target = Child;
    fn deref(&self) -> &Child {
        &self.0
    }
}

impl Drop for Swarm {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Starts `swarm args...` and returns it with the page's URL, read from its output (`swarm
/// view` prints it on stdout, `swarm run --view` on stderr).
fn start_viewer(args: &[&str]) -> (Swarm, String) {
    let mut child = spawn_swarm(args, &[]);
    let (tx, rx) = std::sync::mpsc::channel::<String>();
    let out = child.stdout.take().unwrap();
    let err = child.stderr.take().unwrap();
    for stream in [
        Box::new(out) as Box<dyn std::io::Read + Send>,
        Box::new(err),
    ] {
        let tx = tx.clone();
        std::thread::spawn(move || {
            for line in BufReader::new(stream).lines().map_while(Result::ok) {
                if let Some(at) = line.find("http://") {
                    let _ = tx.send(line[at..].split_whitespace().next().unwrap().to_string());
                }
            }
        });
    }
    let url = rx
        .recv_timeout(LIMIT)
        .unwrap_or_else(|_| panic!("swarm {args:?} printed no URL"));
    (Swarm(child), url)
}

fn interrupt(child: &Child) {
    unsafe {
        libc::kill(child.id() as i32, libc::SIGINT);
    }
}

fn wait_exit(mut swarm: Swarm) -> std::process::ExitStatus {
    let child = &mut swarm.0;
    let started = std::time::Instant::now();
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            return status;
        }
        if started.elapsed() > LIMIT {
            let _ = child.kill();
            panic!("swarm did not stop after Ctrl-C");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// Robot `id` at `tick` as `trajectory.csv` says: (x, y).
fn csv_pose(dir: &Path, tick: u64, id: u32) -> (f64, f64) {
    let text = std::fs::read_to_string(dir.join("trajectory.csv")).unwrap();
    let want = format!("{tick},{id},");
    let line = text
        .lines()
        .find(|l| l.starts_with(&want))
        .expect("row exists");
    let f: Vec<f64> = line
        .split(',')
        .skip(2)
        .take(2)
        .map(|v| v.parse().unwrap())
        .collect();
    (f[0], f[1])
}

/// Moves the scrubber to `frame` as its `input` event does, and waits until it is drawn.
async fn scrub_to(b: &Browser, frame: u64) {
    b.eval(&format!(
        "document.getElementById('scrub').value = {frame}, document.getElementById('scrub').dispatchEvent(new Event('input'))"
    ))
    .await;
    b.wait_for(&format!("swarmView.drawnFrame === {frame}"), LIMIT)
        .await;
}

fn num(v: &Value) -> f64 {
    v.as_f64().unwrap_or_else(|| panic!("not a number: {v}"))
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn replay_plays_scrubs_jumps_to_events_and_inspects_robots() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("crossing");
    let d = dir.to_str().unwrap().to_string();
    run_config(
        "configs/flocking_crossing.toml",
        &dir,
        &[
            "--ticks",
            "500",
            "--set",
            "scenario.record_radio=true",
            "--set",
            "radio.loss=0.3",
        ],
    );
    let (viewer, url) = start_viewer(&["view", &d]);
    let b = Browser::start(1400, 900).await;
    b.client.goto(&url).await.unwrap();
    b.wait_for("window.swarmView && window.swarmView.ready", LIMIT)
        .await;
    assert_eq!(b.eval("swarmView.meta.robots").await, 10);
    assert_eq!(b.eval("swarmView.status.state").await, "complete");
    let frames = num(&b.eval("swarmView.status.frames").await) as u64;
    assert!(frames >= 500, "{frames} frames");
    b.wait_for("swarmView.radioTicks > 0", LIMIT).await;
    b.screenshot("replay-start").await;

    // Play: the tick advances on its own.
    b.select("#speed", "2").await;
    b.click("#play").await;
    b.wait_for("swarmView.playing && swarmView.drawnFrame >= 20", LIMIT)
        .await;
    b.click("#play").await;
    assert_eq!(b.eval("swarmView.playing").await, false);

    // Scrub to tick T with the keyboard on the scrubber, as a user can: robot k is drawn
    // where trajectory.csv puts it.
    let scrub = b
        .client
        .find(fantoccini::Locator::Css("#scrub"))
        .await
        .unwrap();
    scrub.send_keys("\u{E011}").await.unwrap(); // Home
    let target = 137u64;
    scrub
        .send_keys(&"\u{E014}".repeat(target as usize))
        .await
        .unwrap(); // ArrowRight
    b.wait_for(&format!("swarmView.drawnFrame === {target}"), LIMIT)
        .await;
    assert_eq!(num(&b.eval("swarmView.tick").await) as u64, target);
    for k in [0u32, 7] {
        let drawn = b.eval(&format!("swarmView.robot({k})")).await;
        let (x, y) = csv_pose(&dir, target, k);
        assert!(
            (num(&drawn["x"]) - x).abs() < 1e-4 && (num(&drawn["y"]) - y).abs() < 1e-4,
            "robot {k} at tick {target}: drawn {drawn}, trajectory.csv ({x}, {y})"
        );
    }
    let links = b
        .wait_for(&format!("swarmView.linksAt({target})"), LIMIT)
        .await;
    assert!(
        links
            .as_array()
            .is_some_and(|l| !l.is_empty() && l.len() % 3 == 0),
        "radio links of tick {target} are drawn: {links}"
    );
    // Every link is a copy radio.csv has at that tick.
    let csv = std::fs::read_to_string(dir.join("radio.csv")).unwrap();
    let rows = csv
        .lines()
        .filter(|l| l.starts_with(&format!("{target},")))
        .filter(|l| !l.split(',').nth(3).unwrap().is_empty())
        .count();
    assert_eq!(links.as_array().unwrap().len(), 3 * rows);

    // Click a robot on the map: the panel shows it.
    let at = b.eval("swarmView.screenOf(3)").await;
    let map = b
        .client
        .find(fantoccini::Locator::Css("#map"))
        .await
        .unwrap();
    let (dx, dy) = (
        num(&at["x"]) - num(&at["width"]) / 2.0,
        num(&at["y"]) - num(&at["height"]) / 2.0,
    );
    let actions = fantoccini::actions::MouseActions::new("mouse".to_string())
        .then(fantoccini::actions::PointerAction::MoveToElement {
            element: map.clone(),
            duration: None,
            x: dx.round(),
            y: dy.round(),
        })
        .then(fantoccini::actions::PointerAction::Down {
            button: fantoccini::actions::MOUSE_BUTTON_LEFT,
        })
        .then(fantoccini::actions::PointerAction::Up {
            button: fantoccini::actions::MOUSE_BUTTON_LEFT,
        });
    b.client.perform_actions(actions).await.unwrap();
    b.wait_for("swarmView.selected === 3 && swarmView.inspected", LIMIT)
        .await;
    let row = b.eval("swarmView.inspected.row").await;
    assert_eq!(row["id"], 3);
    assert_eq!(num(&row["tick"]) as u64, target);
    let panel = b.text("#inspector").await;
    assert!(panel.contains("pose") && panel.contains("state"), "{panel}");
    b.screenshot("replay-inspect").await;

    // Click an event in the list: the page jumps to its tick and highlights its robots.
    let markers = b.eval("swarmView.markers.length").await;
    assert!(num(&markers) > 0.0, "flocking_crossing has events");
    let li = b
        .client
        .find(fantoccini::Locator::Css("#events li:last-child"))
        .await
        .unwrap();
    let tick: u64 = li
        .attr("data-tick")
        .await
        .unwrap()
        .unwrap()
        .parse()
        .unwrap();
    li.click().await.unwrap();
    b.wait_for(&format!("swarmView.tick === {tick}"), LIMIT)
        .await;
    let hl = b.eval("swarmView.highlight.robots").await;
    assert!(hl.as_array().is_some_and(|r| !r.is_empty()), "{hl}");
    // Next event / previous event buttons move between marks.
    b.click("#prev-event").await;
    b.wait_for(&format!("swarmView.tick < {tick}"), LIMIT).await;
    b.screenshot("replay-event").await;
    // Where the two flocks meet (the README's picture).
    scrub_to(&b, 440).await;
    b.wait_for(
        "swarmView.inspected && swarmView.inspected.row.tick === 440",
        LIMIT,
    )
    .await;
    b.screenshot("flocks-meet").await;
    assert_eq!(b.eval("swarmView.error").await, Value::Null);
    b.close().await;
    interrupt(&viewer);
    assert!(wait_exit(viewer).success(), "Ctrl-C ends swarm view with 0");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn live_view_follows_the_run_and_becomes_its_replay() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("live");
    let d = dir.to_str().unwrap().to_string();
    // The browser first (it takes seconds to start on a busy machine), then the run, in real
    // time (one tick per 0.1 s) so the page sees it while it goes.
    let b = Browser::start(1200, 800).await;
    let (run, url) = start_viewer(&[
        "run",
        "configs/goto_simple.toml",
        "--realtime",
        "--ticks",
        "150",
        "--set",
        "scenario.stop_when_done=false",
        "--out",
        &d,
        "--view",
    ]);
    b.client.goto(&url).await.unwrap();
    b.wait_for("window.swarmView && window.swarmView.ready", LIMIT)
        .await;
    b.wait_for("swarmView.status.state === 'live'", LIMIT).await;
    let first = num(&b.eval("swarmView.status.frames").await);
    b.wait_for(
        &format!("swarmView.status.state === 'live' && swarmView.drawnFrame > {first} + 5"),
        LIMIT,
    )
    .await;
    assert_eq!(
        b.eval("swarmView.following").await,
        true,
        "a live view follows the newest tick"
    );
    b.screenshot("live").await;
    b.wait_for("swarmView.status.state === 'complete'", LIMIT)
        .await;
    let frames = num(&b.eval("swarmView.status.frames").await) as u64;
    assert!(frames >= 150, "{frames}");
    let badge = b.text("#state").await;
    assert_eq!(badge, "replay");
    // As a replay it plays from the start.
    b.click("#play").await;
    b.wait_for("swarmView.playing", LIMIT).await;
    b.screenshot("live-then-replay").await;
    b.close().await;
    interrupt(&run);
    assert!(wait_exit(run).success());
    assert!(dir.join("metrics.json").exists());
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn crashed_run_replays_to_its_last_whole_tick_with_a_banner() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("crashed");
    run_config(
        "configs/goto_simple.toml",
        &dir,
        &["--ticks", "60", "--in-process"],
    );
    // What a crash leaves: no metrics.json, a torn last line.
    std::fs::remove_file(dir.join("metrics.json")).unwrap();
    let csv = std::fs::read_to_string(dir.join("trajectory.csv")).unwrap();
    let cut = csv.len() - 20;
    std::fs::write(dir.join("trajectory.csv"), &csv[..cut]).unwrap();
    let (viewer, url) = start_viewer(&["view", dir.to_str().unwrap()]);
    let b = Browser::start(1200, 800).await;
    b.client.goto(&url).await.unwrap();
    b.wait_for("window.swarmView && window.swarmView.ready", LIMIT)
        .await;
    assert_eq!(b.eval("swarmView.status.state").await, "crashed");
    // 61 ticks (0..=60) recorded; the last one is torn.
    assert_eq!(b.eval("swarmView.status.frames").await, 60);
    let banner = b.text("#banner").await;
    assert!(banner.contains("last whole tick, 59"), "{banner}");
    b.screenshot("crashed").await;
    b.close().await;
    interrupt(&viewer);
    wait_exit(viewer);
}

#[test]
fn a_directory_that_is_not_a_run_or_a_port_in_use_is_one_line_and_exit_2() {
    let tmp = tempfile::tempdir().unwrap();
    let out = swarm(&["view", tmp.path().to_str().unwrap()], LIMIT);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(err.contains("not a run directory"), "{err}");

    let out = swarm(&["view", "/no/such/run"], LIMIT);
    assert_eq!(out.status.code(), Some(2));

    let run = tmp.path().join("run");
    run_config(
        "configs/goto_simple.toml",
        &run,
        &["--ticks", "5", "--in-process"],
    );
    let taken = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = taken.local_addr().unwrap().port().to_string();
    let out = swarm(&["view", run.to_str().unwrap(), "--port", &port], LIMIT);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("in use"), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");

    // A run directory with an empty trajectory (a run that died before tick 0).
    std::fs::write(run.join("trajectory.csv"), "").unwrap();
    let out = swarm(&["view", run.to_str().unwrap()], LIMIT);
    assert_eq!(out.status.code(), Some(2), "{out:?}");
}

#[test]
fn a_live_view_changes_no_record_byte_in_either_mode() {
    let tmp = tempfile::tempdir().unwrap();
    for mode in [&[][..], &["--in-process"][..]] {
        let plain = tmp.path().join(format!("plain{}", mode.len()));
        let mut extra = vec!["--set", "radio.loss=0.2", "--set", "radio.delay_ticks=2"];
        extra.extend_from_slice(mode);
        run_config("configs/raft_election.toml", &plain, &extra);
        let viewed = tmp.path().join(format!("viewed{}", mode.len()));
        let mut args = vec![
            "run",
            "configs/raft_election.toml",
            "--out",
            viewed.to_str().unwrap(),
            "--view",
        ];
        args.extend_from_slice(&extra);
        let (child, url) = start_viewer(&args);
        // A client follows it the whole run as the page does: the status, then the newest
        // frames and the timeline.
        let poll = std::thread::spawn(move || {
            let host = url
                .trim_start_matches("http://")
                .trim_end_matches('/')
                .to_string();
            let get = |path: &str| -> Option<String> {
                use std::io::{Read, Write};
                let mut s = std::net::TcpStream::connect(&host).ok()?;
                write!(
                    s,
                    "GET {path} HTTP/1.1\r\nHost: {host}\r\nConnection: close\r\n\r\n"
                )
                .ok()?;
                let mut body = Vec::new();
                s.read_to_end(&mut body).ok()?;
                Some(String::from_utf8_lossy(&body).into_owned())
            };
            let mut followed = 0;
            while let Some(reply) = get("/api/status") {
                let status: Value = match reply.split("\r\n\r\n").nth(1).map(serde_json::from_str) {
                    Some(Ok(v)) => v,
                    _ => break,
                };
                let frames = status["frames"].as_u64().unwrap_or(0);
                if frames > 0 {
                    let from = frames - 1;
                    get(&format!("/api/frames?from={from}&to={frames}"));
                    get("/api/markers?from=0");
                    followed += 1;
                }
                // Until the finished run's frames are in (under load the page may see the
                // run end before it has read a frame; the server lives until Ctrl-C).
                if status["state"] != "live" && frames > 0 {
                    break;
                }
                std::thread::sleep(Duration::from_millis(20));
            }
            followed
        });
        swarmrt_tests::wait_until("the run to finish", LIMIT * 5, || {
            viewed.join("metrics.json").exists()
        });
        std::thread::sleep(Duration::from_millis(300));
        interrupt(&child);
        assert!(
            wait_exit(child).success(),
            "swarm run --view exits 0 after Ctrl-C"
        );
        assert!(poll.join().unwrap() > 0);
        swarmrt_tests::assert_same_records(&plain, &viewed, "with --view");
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn consensus_lanes_roles_and_the_aerial_side_view_are_drawn() {
    let tmp = tempfile::tempdir().unwrap();
    let b = Browser::start(1400, 1000).await;
    // Raft: a lane per robot with its role and term; the election is a headline.
    let raft = tmp.path().join("raft");
    run_config(
        "configs/raft_election.toml",
        &raft,
        &["--ticks", "300", "--in-process"],
    );
    let (viewer, url) = start_viewer(&["view", raft.to_str().unwrap()]);
    b.client.goto(&url).await.unwrap();
    b.wait_for("window.swarmView && window.swarmView.ready", LIMIT)
        .await;
    b.wait_for("swarmView.lanes > 0", LIMIT).await;
    assert_eq!(
        b.eval("!document.getElementById('lanes-canvas').hidden")
            .await,
        true
    );
    let elected = b
        .eval("swarmView.markers.filter(m => m.kind === 'elected').length")
        .await;
    assert!(num(&elected) >= 1.0, "an election is on the timeline");
    scrub_to(&b, 250).await;
    b.screenshot("raft-lanes").await;
    interrupt(&viewer);
    wait_exit(viewer);

    // Seed 002's UAVs: roles from the planner's notes, and a side view (y against z).
    let uav = tmp.path().join("uav");
    run_config(
        "configs/planner_uav3.toml",
        &uav,
        &["--ticks", "300", "--in-process"],
    );
    let (viewer, url) = start_viewer(&["view", uav.to_str().unwrap()]);
    b.client.goto(&url).await.unwrap();
    b.wait_for("window.swarmView && window.swarmView.ready", LIMIT)
        .await;
    assert_eq!(b.eval("swarmView.meta.aerial").await, true);
    assert_eq!(
        b.eval("!document.getElementById('side').hidden").await,
        true
    );
    scrub_to(&b, 200).await;
    let roles: Vec<String> = (0..3)
        .map(|k| format!("swarmView.robot({k}).role"))
        .collect();
    let in_flight = b
        .eval(&format!(
            "[{}].filter(r => swarmView.meta.roles[r] && swarmView.meta.roles[r].name === 'in flight').length",
            roles.join(",")
        ))
        .await;
    assert!(num(&in_flight) >= 1.0, "a UAV flies at tick 200");
    let z = num(&b.eval("swarmView.robot(0).z").await);
    assert!(z > 0.0, "height is drawn: {z}");
    b.screenshot("uav-side-view").await;
    interrupt(&viewer);
    wait_exit(viewer);
    b.close().await;
}

/// Load time, frame rate and memory of the page for 100, 1,000 and 10,000 robots (numbers
/// for docs/benchmarks.md, not assertions): `cargo test --release -p swarmrt-tests --test
/// viewer -- --ignored --nocapture viewer_scale`.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
#[ignore = "a measurement: minutes of in-process runs, prints a table"]
async fn viewer_scale() {
    let tmp = tempfile::tempdir().unwrap();
    println!(
        "| robots | ticks | trajectory.csv | load to first frame | fps at 8x | fps at 64x | JS heap | frame cache | chromium RSS |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for (n, ticks) in [(100u32, 3000u64), (1000, 3000), (10000, 300)] {
        let dir = tmp.path().join(format!("n{n}"));
        // The benchmark's square map around the start grid (benchmarks/src/swarm.rs).
        let r_start = (n as f64 / std::f64::consts::PI).sqrt() * 0.5 + 1.0;
        let side = (2.0 * r_start + 6.0).max(12.0).ceil();
        let (centre, goal) = (side / 2.0, side / 2.0 + r_start / 2.0);
        let sets = [
            format!("robots.count={n}"),
            "scenario.stop_when_done=false".to_string(),
            format!("map.bounds=[0.0, 0.0, {side:.1}, {side:.1}]"),
            format!("robots.start.x={centre:.1}"),
            format!("robots.start.y={centre:.1}"),
            "robots.start.spacing=0.5".to_string(),
            format!("map.goal.x={goal:.1}"),
            format!("map.goal.y={goal:.1}"),
        ];
        let ticks_s = ticks.to_string();
        let mut extra = vec!["--in-process", "--ticks", &ticks_s];
        for s in &sets {
            extra.push("--set");
            extra.push(s);
        }
        run_config("configs/goto_simple.toml", &dir, &extra);
        let csv_mb = std::fs::metadata(dir.join("trajectory.csv")).unwrap().len() as f64 / 1e6;
        let (viewer, url) = start_viewer(&["view", dir.to_str().unwrap()]);
        let b = Browser::start(1400, 900).await;
        let started = std::time::Instant::now();
        b.client.goto(&url).await.unwrap();
        b.wait_for("window.swarmView && window.swarmView.ready", LIMIT * 5)
            .await;
        let load = started.elapsed().as_secs_f64();
        let mut fps = Vec::new();
        for speed in ["8", "64"] {
            b.select("#speed", speed).await;
            b.eval("document.getElementById('scrub').value = 0, document.getElementById('scrub').dispatchEvent(new Event('input'))").await;
            b.click("#play").await;
            tokio::time::sleep(Duration::from_secs(1)).await;
            let d0 = num(&b.eval("swarmView.drawn").await);
            let t0 = std::time::Instant::now();
            tokio::time::sleep(Duration::from_secs(5)).await;
            let d1 = num(&b.eval("swarmView.drawn").await);
            fps.push((d1 - d0) / t0.elapsed().as_secs_f64());
            b.eval("swarmView.playing && document.getElementById('play').click()")
                .await;
        }
        let heap = num(&b.eval("performance.memory.usedJSHeapSize").await) / 1e6;
        let cache = num(&b.eval("swarmView.cacheBytes").await) / 1e6;
        let rss_mb = chromium_rss_kb() as f64 / 1e3;
        println!(
            "| {n} | {ticks} | {csv_mb:.0} MB | {load:.2} s | {:.0} | {:.0} | {heap:.0} MB | {cache:.0} MB | {rss_mb:.0} MB |",
            fps[0], fps[1]
        );
        if n == 1000 {
            b.screenshot("scale-1000").await;
        }
        b.close().await;
        interrupt(&viewer);
        wait_exit(viewer);
    }
}

/// Resident memory of every chromium process, in KiB.
fn chromium_rss_kb() -> u64 {
    let mut total = 0;
    for entry in std::fs::read_dir("/proc").unwrap().flatten() {
        let Ok(cmd) = std::fs::read_to_string(entry.path().join("cmdline")) else {
            continue;
        };
        if !cmd.starts_with("/usr/lib/chromium/chromium") && !cmd.starts_with("/usr/bin/chromium") {
            continue;
        }
        let status = std::fs::read_to_string(entry.path().join("status")).unwrap_or_default();
        total += status
            .lines()
            .find(|l| l.starts_with("VmRSS:"))
            .and_then(|l| l.split_whitespace().nth(1))
            .and_then(|v| v.parse::<u64>().ok())
            .unwrap_or(0);
    }
    total
}
