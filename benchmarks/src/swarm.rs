//! `swarm bench swarm`: for each robot count N, the real runtime (world + N robot processes,
//! `processes::run`, exactly what `swarm run` does) and the floor (the same services and
//! processes with empty cores, [`super::floor`]); then the same cores in-process.
//!
//! Tick numbers come from the world's own timing (`shell.timing` in its metrics): the ticks
//! and their wall time, not the start-up or shutdown around them. Memory is read once per run
//! from `/proc/<pid>/smaps_rollup` of every process after tick 17, when every process is up
//! and each of the 16 observation samples has been written once. The runtime's world keeps
//! ticking while it is read (a few ticks pay for it); the floor's world waits between two
//! ticks (outside its timing).
//!
//! With `--peers` each round also runs peer floors ([`peers`], issue 34): the floor's
//! lock-step over Unix sockets and over Zenoh, after the iceoryx2 floor. Every row has the CPU
//! of its processes ([`peers::Cpu`]): the reaped children's rusage over the whole run, and
//! the part from the memory reading to the end (nearly only ticking).

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use anyhow::Context;
use serde::{Deserialize, Serialize};
use swarmrt_harness::lockstep::Lockstep;
use swarmrt_scenario::Config;
use swarmrt_world::Stage;

use super::child::{ChildMsg, ChildSpec};
use super::floor::{FloorResult, SAMPLE_TICK};
use super::peers::{
    self, Cpu, Fault, Peer, TURN_WINDOW, live_cpu_secs, reaped_children_cpu_secs, robot_turn_us,
};
use super::procs::{Children, Memory, Messages, memory, my_children, open_fds};
use super::stats::median;
use super::{
    BenchRun, Interrupt, PEER_TIMEOUT, default_out, fmt_bytes, fmt_rate, machine, make_out_dir,
    progress, write_json,
};
use swarmrt_analysis::plot::bench::{Legend, Panel, Series, write_figure};
use swarmrt_orchestrator::config::load_config;
use swarmrt_orchestrator::error::{SwarmError, SwarmResult};
use swarmrt_orchestrator::{processes, run_dir};

/// Longest an in-process measurement steps, whatever `--in-process-ticks` says.
const IN_PROCESS_BUDGET: Duration = Duration::from_secs(20);
/// Most robot processes this command starts (each costs ~1.4 MB PSS and a few descriptors
/// in the world; see docs/benchmarks.md for where it stops).
pub const MAX_PROCESS_AGENTS: u32 = 5_000;
/// Most `--rounds`.
pub const MAX_ROUNDS: u32 = 50;

/// What `swarm bench swarm` measures (its command-line options, without clap).
#[derive(Debug, Clone, PartialEq)]
pub struct SwarmOptions {
    /// Robot process counts to run, each in 1..=[`MAX_PROCESS_AGENTS`] (`--agents`).
    pub agents: Vec<u32>,
    /// Lock-step ticks per run, the runtime and the floor alike (`--ticks`).
    pub ticks: u64,
    /// Robot counts for the in-process measurement (`--in-process-agents`).
    pub in_process_agents: Vec<u32>,
    /// Ticks per in-process measurement; it also stops after 20 s (`--in-process-ticks`).
    pub in_process_ticks: u64,
    /// Rounds of runtime and floor runs, alternated, in 1..=[`MAX_ROUNDS`] (`--rounds`).
    pub rounds: u32,
    /// The floors each round runs after the runtime, in this order (`--peers`; default all:
    /// iceoryx2, Unix sockets, Zenoh).
    pub peers: Vec<Peer>,
    /// A peer robot that kills itself at a tick (`--peer-fault`, hidden: the watchdog's test).
    pub peer_fault: Option<Fault>,
    /// The scenario the runtime runs; robots.count and the map are set per N (`--config`).
    pub config: PathBuf,
    /// Print the results as JSON instead of tables (`--json`).
    pub json: bool,
    /// Output directory; `None` is `bench/swarm-<time>/` (`--out`).
    pub out: Option<PathBuf>,
}

/// The runtime at one N.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct RuntimeRow {
    /// Robot processes.
    pub agents: u32,
    /// Which round (from 1) of `--rounds`.
    pub round: u32,
    /// Ticks the world stepped.
    pub ticks: u64,
    /// Ticks per second while ticking.
    pub ticks_per_s: f64,
    /// Median tick, ms.
    pub tick_ms_median: f64,
    /// 99th percentile tick, ms.
    pub tick_ms_p99: f64,
    /// Mean ms per tick in each phase of the world's loop.
    pub phases_ms: serde_json::Value,
    /// From the world's services existing to the last robot's hello (spawning included), ms.
    pub startup_ms: Option<f64>,
    /// Memory of the world and all robots.
    pub memory: Option<Memory>,
    /// Open descriptors of the world process.
    pub world_fds: Option<usize>,
    /// Wall seconds of the whole run (start-up, ticks, shutdown).
    pub wall_secs: f64,
    /// CPU of the world and all robots.
    #[serde(default)]
    pub cpu: Option<Cpu>,
    /// The run directory.
    pub dir: String,
    /// Set when the run failed.
    pub error: Option<String>,
}

/// The floor at one N.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct FloorRow {
    /// Robot processes.
    pub agents: u32,
    /// Which round (from 1) of `--rounds`.
    pub round: u32,
    /// What the floor world measured.
    pub result: Option<FloorResult>,
    /// Ticks per second while ticking.
    pub ticks_per_s: f64,
    /// Memory of the floor world and all floor robots.
    pub memory: Option<Memory>,
    /// CPU of the floor world and all floor robots.
    #[serde(default)]
    pub cpu: Option<Cpu>,
    /// Set when the floor failed.
    pub error: Option<String>,
}

/// A peer floor (Unix sockets, Zenoh) at one N: the floor's lock-step over that transport.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PeerRow {
    /// The transport.
    pub peer: Peer,
    /// Robot processes.
    pub agents: u32,
    /// Which round (from 1) of `--rounds`.
    pub round: u32,
    /// What its world measured (the iceoryx2 floor's fields).
    pub result: Option<FloorResult>,
    /// Ticks per second while ticking.
    pub ticks_per_s: f64,
    /// Memory of its world and all its robots.
    pub memory: Option<Memory>,
    /// CPU of its world and all its robots.
    pub cpu: Option<Cpu>,
    /// Wall seconds of the whole run (start-up, ticks, shutdown).
    pub wall_secs: f64,
    /// Set when it failed (or could not run at this N).
    pub error: Option<String>,
}

/// One transport at one N, the median over its rounds that did not fail.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct TransportSummary {
    /// Robot processes.
    pub agents: u32,
    /// "runtime", "iox2", "uds" or "zenoh".
    pub transport: String,
    /// Rounds that ran.
    pub runs: usize,
    /// Rounds that failed.
    pub failed: usize,
    /// Ticks per second.
    pub ticks_per_s: f64,
    /// Median tick, ms.
    pub tick_ms_median: f64,
    /// 99th percentile tick, ms.
    pub tick_ms_p99: f64,
    /// CPU of all processes per tick, start-up included, ms.
    pub cpu_ms_per_tick: f64,
    /// CPU of all processes per tick from the memory reading on, ms.
    pub ticking_cpu_ms_per_tick: f64,
    /// A robot's turn: CPU per tick of one robot process while ticking, µs (runtime and
    /// iceoryx2 floor; NaN for the peers, which do not measure it).
    #[serde(default)]
    pub robot_turn_us: f64,
    /// PSS of all processes, KiB.
    pub pss_kib: f64,
    /// Start-up until every robot said hello, ms.
    pub startup_ms: f64,
    /// The first failure, if any.
    pub error: Option<String>,
}

/// Runtime against floor at one N.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct Comparison {
    /// Robot processes.
    pub agents: u32,
    /// Runtime median tick / floor median tick; with several rounds, the median of
    /// `ratios`.
    pub median_ratio: f64,
    /// Runtime p99 tick / floor p99 tick (the median over rounds).
    pub p99_ratio: f64,
    /// Each round's runtime median / floor median, in round order (rounds that failed are
    /// left out).
    pub ratios: Vec<f64>,
}

/// In-process at one N.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct InProcessRow {
    /// Robots.
    pub agents: u32,
    /// Ticks stepped.
    pub ticks: u64,
    /// Seconds building the world and the agents.
    pub setup_secs: f64,
    /// Seconds stepping.
    pub secs: f64,
    /// agents * ticks / secs.
    pub robot_steps_per_s: f64,
    /// CPU seconds this process spent stepping, all threads (`World::observe` uses several
    /// from 64 robots; less than `secs` when other processes took the CPU).
    pub cpu_secs: f64,
    /// agents * ticks / cpu_secs: the work per CPU-second, whatever else ran.
    pub robot_steps_per_cpu_s: f64,
    /// Mean ms per tick in `World::observe`.
    pub observe_ms: f64,
    /// Mean ms per tick in all `Agent::step` calls.
    pub agents_ms: f64,
    /// Mean ms per tick in `World::step`.
    pub step_ms: f64,
    /// Radio copies sent per tick (the medium's load).
    pub radio_copies_per_tick: f64,
    /// Mean ms per tick in each stage of the world (`World::set_stage_timing`): `sensing`
    /// is observe plus the goal check, the others are parts of `step`.
    #[serde(default)]
    pub stages_ms: Vec<(String, f64)>,
    /// Set when the measurement failed.
    pub error: Option<String>,
}

/// Everything `swarm bench swarm` measured.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct SwarmReport {
    /// The machine.
    pub machine: serde_json::Value,
    /// The scenario file.
    pub config: String,
    /// Lock-step ticks per run.
    pub ticks: u64,
    /// The runtime, per N.
    pub runtime: Vec<RuntimeRow>,
    /// The floor, per N.
    pub floor: Vec<FloorRow>,
    /// Runtime / floor, per N.
    pub comparison: Vec<Comparison>,
    /// The peer floors (`--peers` uds, zenoh), per round and N.
    #[serde(default)]
    pub peers: Vec<PeerRow>,
    /// Per N and transport (runtime and every floor), the median over rounds.
    #[serde(default)]
    pub transports: Vec<TransportSummary>,
    /// In-process, per N.
    pub in_process: Vec<InProcessRow>,
    /// Run ids used (their iceoryx2 roots and shared memory are gone afterwards).
    pub run_ids: Vec<String>,
    /// Where the results were written.
    pub out: String,
    /// Wall seconds of the whole benchmark.
    pub wall_secs: f64,
}

/// The scenario at `n` robots: `base` with the count, the tick budget, no early stop, and a
/// square map around the start grid big enough for the start layout and the goal slots.
pub fn scenario(base: &Path, n: u32, ticks: u64) -> SwarmResult<Config> {
    let cfg = load_config(base, &[])?;
    let spacing = cfg.robots.start.spacing;
    let r_start = (n as f64 / std::f64::consts::PI).sqrt() * spacing + 1.0;
    let side = (2.0 * r_start + 6.0).max(12.0).ceil();
    let centre = side / 2.0;
    let goal = centre + r_start / 2.0;
    let set = vec![
        format!("robots.count={n}"),
        format!("scenario.ticks={ticks}"),
        "scenario.stop_when_done=false".to_string(),
        format!("map.bounds=[0.0, 0.0, {side:.1}, {side:.1}]"),
        format!("robots.start.x={centre:.1}"),
        format!("robots.start.y={centre:.1}"),
        format!("map.goal.x={goal:.1}"),
        format!("map.goal.y={goal:.1}"),
    ];
    load_config(base, &set)
}

fn validate(args: &SwarmOptions) -> SwarmResult<()> {
    let user = |m: String| Err(SwarmError::User(m));
    if args
        .agents
        .iter()
        .any(|&n| n == 0 || n > MAX_PROCESS_AGENTS)
    {
        return user(format!(
            "--agents: expected robot counts in 1..={MAX_PROCESS_AGENTS}, got {:?}",
            args.agents
        ));
    }
    if args.ticks == 0 || args.ticks > 10_000_000 {
        return user(format!(
            "--ticks: expected 1..=10000000, got {}",
            args.ticks
        ));
    }
    if args
        .in_process_agents
        .iter()
        .any(|&n| n == 0 || n > swarmrt_scenario::MAX_ROBOTS)
    {
        return user(format!(
            "--in-process-agents: expected robot counts in 1..={}, got {:?}",
            swarmrt_scenario::MAX_ROBOTS,
            args.in_process_agents
        ));
    }
    if args.in_process_ticks == 0 {
        return user("--in-process-ticks: expected at least 1".into());
    }
    if args.rounds == 0 || args.rounds > MAX_ROUNDS {
        return user(format!(
            "--rounds: expected 1..={MAX_ROUNDS}, got {}",
            args.rounds
        ));
    }
    Ok(())
}

/// `swarm bench swarm`.
pub fn run(args: &SwarmOptions, interrupt: &Interrupt) -> SwarmResult<()> {
    validate(args)?;
    // Resolve every scenario first: a bad config or an impossible layout is a user error
    // before anything starts.
    let mut scenarios = Vec::new();
    for &n in &args.agents {
        scenarios.push((n, scenario(&args.config, n, args.ticks)?));
    }
    let mut in_proc = Vec::new();
    for &n in &args.in_process_agents {
        in_proc.push((n, scenario(&args.config, n, args.in_process_ticks)?));
    }
    let out = args.out.clone().unwrap_or_else(|| default_out("swarm"));
    make_out_dir(&out)?;
    let started = Instant::now();
    let mut report = SwarmReport {
        machine: machine(),
        config: args.config.display().to_string(),
        ticks: args.ticks,
        out: out.display().to_string(),
        ..SwarmReport::default()
    };
    let rounds = args.rounds;
    let per_n = 1 + args.peers.len() as u64;
    let pb = progress((scenarios.len() as u64 * per_n) * rounds as u64 + in_proc.len() as u64);
    for round in 1..=rounds {
        for (n, cfg) in &scenarios {
            let of = if rounds > 1 {
                format!(", round {round} of {rounds}")
            } else {
                String::new()
            };
            pb.set_message(format!("runtime, {n} robots{of}"));
            let name = if rounds > 1 {
                format!("n{n}-r{round}")
            } else {
                format!("n{n}")
            };
            let dir = out.join("runs").join(name);
            let mut row = runtime_run(cfg, &dir, interrupt, &mut report.run_ids);
            row.round = round;
            interrupt.check()?;
            if let Some(e) = &row.error {
                tracing::warn!("runtime with {n} robots failed: {e}");
            }
            report.runtime.push(row);
            pb.inc(1);
            for &peer in &args.peers {
                pb.set_message(format!("{}, {n} robots{of}", peer.label()));
                if peer == Peer::Iox2 {
                    let mut row = floor_run(*n, args.ticks, interrupt, &mut report.run_ids);
                    row.round = round;
                    interrupt.check()?;
                    if let Some(e) = &row.error {
                        tracing::warn!("floor with {n} robots failed: {e}");
                    }
                    report.floor.push(row);
                } else {
                    let mut row = peer_run(
                        peer,
                        *n,
                        args.ticks,
                        args.peer_fault,
                        interrupt,
                        &mut report.run_ids,
                    );
                    row.round = round;
                    interrupt.check()?;
                    if let Some(e) = &row.error {
                        tracing::warn!("{} with {n} robots failed: {e}", peer.label());
                    }
                    report.peers.push(row);
                }
                pb.inc(1);
            }
        }
    }
    report.comparison = compare(&report.runtime, &report.floor);
    report.transports = summarize_transports(&report);
    for (n, cfg) in &in_proc {
        pb.set_message(format!("in-process, {n} robots"));
        let row = in_process(cfg, interrupt).unwrap_or_else(|e| InProcessRow {
            agents: *n,
            error: Some(format!("{e:#}")),
            ..InProcessRow::default()
        });
        interrupt.check()?;
        report.in_process.push(row);
        pb.inc(1);
    }
    pb.finish_and_clear();
    report.wall_secs = started.elapsed().as_secs_f64();

    let value = serde_json::to_value(&report).map_err(anyhow::Error::from)?;
    write_json(&out.join("results.json"), &value)?;
    if let Err(e) = plots(&report, &out) {
        tracing::warn!("could not draw the plots: {e:#}");
    }
    if args.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&value).map_err(anyhow::Error::from)?
        );
    } else {
        print!("{}", table(&report));
        println!("results: {}", out.display());
    }
    Ok(())
}

/// Memory of every child of this process and the world's descriptors, read now.
fn sample_children() -> (Memory, Option<usize>) {
    let kids = my_children();
    let pids: Vec<u32> = kids.iter().map(|(p, _)| *p).collect();
    let world = kids
        .iter()
        .find(|(_, cmd)| cmd.contains("swarm-world"))
        .map(|(p, _)| open_fds(*p));
    (memory(&pids), world)
}

/// CPU seconds of every child of this process so far, and how many there are.
fn children_cpu() -> (f64, usize) {
    let pids: Vec<u32> = my_children().iter().map(|(p, _)| *p).collect();
    (live_cpu_secs(&pids), pids.len())
}

fn runtime_run(
    cfg: &Config,
    dir: &Path,
    interrupt: &Interrupt,
    run_ids: &mut Vec<String>,
) -> RuntimeRow {
    let mut row = RuntimeRow {
        agents: cfg.robots.count,
        dir: dir.display().to_string(),
        ..RuntimeRow::default()
    };
    let started = Instant::now();
    let r = (|| -> anyhow::Result<()> {
        let dir = &swarmrt_scenario::safe_fs::OutDir::create(dir)?;
        let config_path = run_dir::prepare(dir, cfg)?;
        // Read at the world's report of tick SAMPLE_TICK (every observation sample has been
        // written once), in the supervisor's thread (it only delays reading the world's next
        // reports); the world goes on ticking meanwhile.
        //
        // The CPU of the live processes is read at the next report (with its tick), so the
        // memory reading stays where it was and the CPU reading has a known tick.
        let mut sample: Option<(Memory, Option<usize>)> = None;
        let mut cpu_read: Option<(u64, (f64, usize))> = None;
        let mut turn = None;
        let cpu_before = reaped_children_cpu_secs();
        let outcome = processes::run(cfg, &config_path, dir, interrupt.receiver(), |tick| {
            if sample.is_none() && (tick >= SAMPLE_TICK || tick == cfg.scenario.ticks) {
                sample = Some(sample_children());
            } else if sample.is_some() && cpu_read.is_none() {
                cpu_read = Some((tick, children_cpu()));
                // Then a robot's turn, while the world ticks on.
                let robots: Vec<u32> = my_children()
                    .into_iter()
                    .filter(|(_, cmd)| cmd.contains("swarm-agent"))
                    .map(|(p, _)| p)
                    .collect();
                turn = robot_turn_us(&robots, TURN_WINDOW);
            }
        })?;
        let cpu_after = reaped_children_cpu_secs();
        run_ids.push(outcome.run_id.clone());
        // Every process was still there when the CPU was read.
        let cpu_mid = cpu_read
            .filter(|(_, (_, k))| *k == cfg.robots.count as usize + 1)
            .map(|(tick, (secs, _))| (tick, secs));
        if let Some((mem, fds)) = sample {
            // A run shorter than the reading itself leaves fewer processes to read.
            if mem.processes == cfg.robots.count as usize + 1 {
                row.memory = Some(mem);
                row.world_fds = fds;
            } else {
                tracing::warn!(
                    read = mem.processes,
                    "the run ended while its memory was read; no memory figures"
                );
            }
        }
        row.startup_ms = outcome.startup_ms.map(|v| v as f64);
        if let Some(f) = &outcome.world_failure {
            anyhow::bail!("{f}");
        }
        if outcome.interrupted {
            anyhow::bail!("interrupted");
        }
        let metrics = outcome
            .world_metrics
            .context("the world reported no metrics")?;
        let t = &metrics["shell"]["timing"];
        let num = |k: &str| t[k].as_f64().unwrap_or(f64::NAN);
        row.ticks = t["ticks"].as_u64().unwrap_or(0);
        row.cpu = Some(Cpu {
            robot_turn_us: turn,
            ..Cpu::new(cpu_before, cpu_after, cpu_mid, row.ticks)
        });
        row.ticks_per_s = row.ticks as f64 / num("seconds");
        row.tick_ms_median = num("tick_ms_median");
        row.tick_ms_p99 = num("tick_ms_p99");
        row.phases_ms = serde_json::json!({
            "observe": num("observe_ms_mean"),
            "publish": num("publish_ms_mean"),
            "publish_cpu": num("publish_cpu_ms_mean"),
            "wait": num("wait_ms_mean"),
            "step": num("step_ms_mean"),
            "record": num("record_ms_mean"),
        });
        if !outcome.unscheduled_deaths.is_empty() {
            anyhow::bail!(
                "{} robot processes died: {:?}",
                outcome.unscheduled_deaths.len(),
                outcome.unscheduled_deaths.iter().next()
            );
        }
        Ok(())
    })();
    row.wall_secs = started.elapsed().as_secs_f64();
    if let Err(e) = r {
        row.error = Some(format!("{e:#}"));
    }
    row
}

fn floor_run(n: u32, ticks: u64, interrupt: &Interrupt, run_ids: &mut Vec<String>) -> FloorRow {
    let mut row = FloorRow {
        agents: n,
        ..FloorRow::default()
    };
    let r = (|| -> anyhow::Result<()> {
        let run = BenchRun::claim()?;
        run_ids.push(run.id().to_string());
        let cpu_before = reaped_children_cpu_secs();
        let mut kids = Children::new();
        let mut world = kids
            .spawn(
                "floor world",
                &ChildSpec::FloorWorld {
                    run_id: run.id().to_string(),
                    robots: n as usize,
                    ticks,
                },
                true,
            )?
            .context("floor world messages")?;
        world.ready(Duration::from_secs(30), interrupt)?;
        for id in 0..n {
            interrupt.check()?;
            kids.spawn(
                &format!("floor robot {id}"),
                &ChildSpec::FloorAgent {
                    run_id: run.id().to_string(),
                    robot: id,
                },
                false,
            )?;
        }
        let startup = PEER_TIMEOUT + Duration::from_millis(100) * n;
        let mut msg = world.next(startup, interrupt)?;
        let mut cpu_mid = None;
        let mut turn = None;
        if msg == ChildMsg::Progress {
            cpu_mid = Some((SAMPLE_TICK.min(ticks), live_cpu_secs(&kids.pids())));
            row.memory = Some(memory(&kids.pids()));
            world.go()?;
            // The floor robots' turn while their world ticks on (the world was spawned first).
            turn = robot_turn_us(&kids.pids()[1..], TURN_WINDOW);
            msg = world.next(PEER_TIMEOUT + Duration::from_secs(ticks), interrupt)?;
        }
        let ChildMsg::Result { value } = msg else {
            anyhow::bail!("floor world: expected a result, got {msg:?}");
        };
        let res: FloorResult = serde_json::from_value(value)?;
        row.ticks_per_s = res.ticks as f64 / res.secs;
        kids.finish(PEER_TIMEOUT)?;
        row.cpu = Some(Cpu {
            robot_turn_us: turn,
            ..Cpu::new(cpu_before, reaped_children_cpu_secs(), cpu_mid, res.ticks)
        });
        row.result = Some(res);
        Ok(())
    })();
    if let Err(e) = r {
        row.error = Some(format!("{e:#}"));
    }
    row
}

/// The world's next message, a failure it reported turned into an error.
fn next_of(world: &Messages, timeout: Duration, interrupt: &Interrupt) -> anyhow::Result<ChildMsg> {
    match world.next(timeout, interrupt)? {
        ChildMsg::Failed { error } => Err(anyhow::anyhow!("{error}")),
        m => Ok(m),
    }
}

/// One peer floor at `n` robots: its world, then the robots (each told the world's address),
/// memory and CPU read between two ticks after [`SAMPLE_TICK`] as for the iceoryx2 floor.
/// Anything that goes wrong (a robot that dies, a start-up that does not fit) is the row's
/// error; every process is killed and reaped on the way out.
fn peer_run(
    peer: Peer,
    n: u32,
    ticks: u64,
    fault: Option<Fault>,
    interrupt: &Interrupt,
    run_ids: &mut Vec<String>,
) -> PeerRow {
    let mut row = PeerRow {
        peer,
        agents: n,
        round: 0,
        result: None,
        ticks_per_s: 0.0,
        memory: None,
        cpu: None,
        wall_secs: 0.0,
        error: None,
    };
    let started = Instant::now();
    let r = (|| -> anyhow::Result<()> {
        let run = BenchRun::claim()?;
        run_ids.push(run.id().to_string());
        let cpu_before = reaped_children_cpu_secs();
        let mut kids = Children::new();
        let mut world = kids
            .spawn(
                &format!("{} world", peer.label()),
                &ChildSpec::PeerWorld {
                    run_id: run.id().to_string(),
                    peer,
                    robots: n as usize,
                    ticks,
                },
                true,
            )?
            .context("peer world messages")?;
        let addr = match next_of(&world, Duration::from_secs(30), interrupt)? {
            ChildMsg::Ready { addr: Some(a) } => a,
            other => anyhow::bail!("{} world: expected ready, got {other:?}", peer.label()),
        };
        for id in 0..n {
            interrupt.check()?;
            kids.spawn(
                &format!("{} robot {id}", peer.label()),
                &ChildSpec::PeerAgent {
                    run_id: run.id().to_string(),
                    peer,
                    robot: id,
                    robots: n as usize,
                    addr: addr.clone(),
                    die_at: fault.filter(|f| f.robot == id).map(|f| f.tick),
                },
                false,
            )?;
        }
        let startup = peers::startup_limit(n as usize) + PEER_TIMEOUT;
        let mut msg = next_of(&world, startup, interrupt)?;
        let mut cpu_mid = None;
        if msg == ChildMsg::Progress {
            cpu_mid = Some((SAMPLE_TICK.min(ticks), live_cpu_secs(&kids.pids())));
            row.memory = Some(memory(&kids.pids()));
            world.go()?;
            msg = next_of(
                &world,
                PEER_TIMEOUT * 2 + Duration::from_secs(ticks),
                interrupt,
            )?;
        }
        let ChildMsg::Result { value } = msg else {
            anyhow::bail!("{} world: expected a result, got {msg:?}", peer.label());
        };
        let res: FloorResult = serde_json::from_value(value)?;
        row.ticks_per_s = res.ticks as f64 / res.secs;
        kids.finish(PEER_TIMEOUT)?;
        row.cpu = Some(Cpu::new(
            cpu_before,
            reaped_children_cpu_secs(),
            cpu_mid,
            res.ticks,
        ));
        row.result = Some(res);
        Ok(())
    })();
    row.wall_secs = started.elapsed().as_secs_f64();
    if let Err(e) = r {
        row.error = Some(format!("{e:#}"));
    }
    row
}

/// CPU time of this process (all its threads), seconds.
fn process_cpu_secs() -> f64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: clock_gettime only writes the struct we pass.
    unsafe {
        libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut ts);
    }
    ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9
}

/// The same cores in one process, no IPC and no records: the harness's lock-step loop
/// (observe on several threads from 64 robots, every running robot's step, the world's step),
/// each phase timed.
fn in_process(cfg: &Config, interrupt: &Interrupt) -> anyhow::Result<InProcessRow> {
    let n = cfg.robots.count as usize;
    let t = Instant::now();
    let mut run = Lockstep::new(cfg).map_err(|e| anyhow::anyhow!("{}: {}", e.key, e.message))?;
    let setup_secs = t.elapsed().as_secs_f64();
    let (mut observe, mut think, mut step) = (Duration::ZERO, Duration::ZERO, Duration::ZERO);
    let start = Instant::now();
    let cpu_start = process_cpu_secs();
    let mut ticks = 0u64;
    run.world_mut().set_stage_timing(true);
    while ticks < cfg.scenario.ticks && start.elapsed() < IN_PROCESS_BUDGET {
        interrupt.check()?;
        let t0 = Instant::now();
        run.observe();
        let t1 = Instant::now();
        run.propagate();
        let t2 = Instant::now();
        run.advance();
        run.drain_events();
        let t3 = Instant::now();
        observe += t1 - t0;
        think += t2 - t1;
        step += t3 - t2;
        ticks += 1;
    }
    let secs = start.elapsed().as_secs_f64();
    let cpu_secs = process_cpu_secs() - cpu_start;
    let per = |d: Duration| d.as_secs_f64() * 1e3 / ticks.max(1) as f64;
    let stage_times = run.world_mut().take_stage_times();
    let stages_ms = Stage::ALL
        .iter()
        .map(|&st| (st.name().to_string(), per(stage_times.get(st))))
        .collect();
    Ok(InProcessRow {
        agents: n as u32,
        ticks,
        setup_secs,
        secs,
        robot_steps_per_s: (n as f64 * ticks as f64) / secs,
        cpu_secs,
        robot_steps_per_cpu_s: (n as f64 * ticks as f64) / cpu_secs,
        observe_ms: per(observe),
        agents_ms: per(think),
        step_ms: per(step),
        radio_copies_per_tick: run.world().metrics().radio.sent as f64 / ticks.max(1) as f64,
        stages_ms,
        error: None,
    })
}

/// The text tables.
pub fn table(r: &SwarmReport) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let m = &r.machine;
    let _ = writeln!(
        s,
        "machine: {} cpus, {}, kernel {}, load {}; {} ticks per run of {}",
        m["nproc"], m["cpu"], m["kernel"], m["loadavg_at_start"], r.ticks, r.config
    );
    let _ = writeln!(
        s,
        "\nlock-step runtime (world + N robot processes) against the floor (same IPC, empty cores)"
    );
    let _ = writeln!(
        s,
        "{:>5} | {:>8} {:>9} {:>9} {:>9} {:>9} {:>9} {:>5} | {:>8} {:>9} {:>9} {:>9} {:>9} | {:>6}",
        "N",
        "ticks/s",
        "median",
        "p99",
        "startup",
        "RSS",
        "PSS",
        "fds",
        "ticks/s",
        "median",
        "p99",
        "startup",
        "PSS",
        "x floor"
    );
    for (i, rt) in r.runtime.iter().enumerate() {
        let fl = r.floor.get(i);
        let left = match &rt.error {
            Some(e) => format!("failed: {e}"),
            None => {
                let mem = rt.memory.unwrap_or_default();
                format!(
                    "{:>8.1} {:>9} {:>9} {:>9} {:>9} {:>9} {:>5}",
                    rt.ticks_per_s,
                    ms(rt.tick_ms_median),
                    ms(rt.tick_ms_p99),
                    rt.startup_ms.map(ms).unwrap_or_else(|| "-".into()),
                    fmt_bytes(mem.rss_kib as f64 * 1024.0),
                    fmt_bytes(mem.pss_kib as f64 * 1024.0),
                    rt.world_fds.map(|f| f.to_string()).unwrap_or_default()
                )
            }
        };
        let right = match fl {
            Some(FloorRow {
                result: Some(f),
                memory,
                ticks_per_s,
                ..
            }) => format!(
                "{:>8.1} {:>9} {:>9} {:>9} {:>9}",
                ticks_per_s,
                ms(f.tick_ns.median / 1e6),
                ms(f.tick_ns.p99 / 1e6),
                ms(f.startup_ms),
                fmt_bytes(memory.unwrap_or_default().pss_kib as f64 * 1024.0)
            ),
            Some(FloorRow { error: Some(e), .. }) => format!("failed: {e}"),
            _ => "-".into(),
        };
        // This row's own ratio (its round's pair).
        let ratio = match (&rt.error, fl.and_then(|f| f.result.as_ref())) {
            (None, Some(f)) => format!("{:.2}x", rt.tick_ms_median / (f.tick_ns.median / 1e6)),
            _ => "-".into(),
        };
        let _ = writeln!(s, "{:>5} | {left} | {right} | {ratio:>6}", rt.agents);
    }
    if r.runtime.iter().any(|x| x.round > 1) {
        let _ = writeln!(s, "\nruntime / floor, median over rounds (min - max)");
        for c in &r.comparison {
            let lo = c.ratios.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = c.ratios.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            let _ = writeln!(
                s,
                "{:>5}   {:.2}x ({:.2}x - {:.2}x) over {} rounds",
                c.agents,
                c.median_ratio,
                lo,
                hi,
                c.ratios.len()
            );
        }
    }
    if !r.peers.is_empty() || !r.floor.is_empty() {
        transport_tables(&mut s, r);
    }
    let _ = writeln!(s, "\nwhere a runtime tick goes (mean ms per tick)");
    let _ = writeln!(
        s,
        "{:>5} {:>9} {:>9} {:>9} {:>9} {:>9} {:>9}",
        "N", "observe", "publish", "pub CPU", "wait", "step", "record"
    );
    for rt in r.runtime.iter().filter(|x| x.error.is_none()) {
        let p = &rt.phases_ms;
        let f = |k: &str| ms(p[k].as_f64().unwrap_or(f64::NAN));
        let _ = writeln!(
            s,
            "{:>5} {:>9} {:>9} {:>9} {:>9} {:>9} {:>9}",
            rt.agents,
            f("observe"),
            f("publish"),
            f("publish_cpu"),
            f("wait"),
            f("step"),
            f("record")
        );
    }
    let _ = writeln!(
        s,
        "\nin-process (same cores, one process, no IPC, no records; observe split over the cores from 64 robots)"
    );
    let _ = writeln!(
        s,
        "{:>6} {:>6} {:>13} {:>13} {:>9} {:>9} {:>9} {:>12} {:>8}",
        "N",
        "ticks",
        "robot-steps/s",
        "per CPU-s",
        "observe",
        "agents",
        "step",
        "radio/tick",
        "setup"
    );
    for p in &r.in_process {
        if let Some(e) = &p.error {
            let _ = writeln!(s, "{:>6} failed: {e}", p.agents);
            continue;
        }
        let _ = writeln!(
            s,
            "{:>6} {:>6} {:>13} {:>13} {:>9} {:>9} {:>9} {:>12} {:>8}",
            p.agents,
            p.ticks,
            fmt_rate(p.robot_steps_per_s),
            fmt_rate(p.robot_steps_per_cpu_s),
            ms(p.observe_ms),
            ms(p.agents_ms),
            ms(p.step_ms),
            fmt_rate(p.radio_copies_per_tick),
            format!("{:.2} s", p.setup_secs)
        );
        if !p.stages_ms.is_empty() {
            let stages: Vec<String> = p
                .stages_ms
                .iter()
                .map(|(name, v)| format!("{name} {}", ms(*v)))
                .collect();
            let _ = writeln!(s, "{:>6} world stages per tick: {}", "", stages.join(", "));
        }
    }
    s
}

/// The runtime and every floor side by side: each run, then the medians over rounds.
fn transport_tables(s: &mut String, r: &SwarmReport) {
    use std::fmt::Write as _;
    let _ = writeln!(
        s,
        "\nthe same lock-step over each transport (CPU/tick: user+sys of all the run's processes \
         over its ticks, start-up included; tick CPU: from about tick {SAMPLE_TICK} to the end)"
    );
    let head = format!(
        "{:>5} {:>5} {:<12} {:>8} {:>9} {:>9} {:>9} {:>9} {:>9} {:>8} {:>9}",
        "N",
        "round",
        "transport",
        "ticks/s",
        "median",
        "p99",
        "startup",
        "CPU/tick",
        "tick CPU",
        "turn",
        "PSS"
    );
    let _ = writeln!(s, "{head}");
    let cpu = |v: Option<f64>| v.map(ms).unwrap_or_else(|| "-".into());
    for l in lines(r) {
        if let Some(e) = &l.error {
            let _ = writeln!(
                s,
                "{:>5} {:>5} {:<12} failed: {e}",
                l.agents, l.round, l.label
            );
            continue;
        }
        let _ = writeln!(
            s,
            "{:>5} {:>5} {:<12} {:>8.1} {:>9} {:>9} {:>9} {:>9} {:>9} {:>8} {:>9}",
            l.agents,
            l.round,
            l.label,
            l.ticks_per_s,
            ms(l.median_ms),
            ms(l.p99_ms),
            cpu(l.startup_ms),
            cpu(l.cpu.map(|c| c.ms_per_tick)),
            cpu(l.cpu.and_then(|c| c.ticking_ms_per_tick)),
            us(l.cpu.and_then(|c| c.robot_turn_us).unwrap_or(f64::NAN)),
            l.memory
                .map(|m| fmt_bytes(m.pss_kib as f64 * 1024.0))
                .unwrap_or_else(|| "-".into())
        );
    }
    if r.runtime.iter().all(|x| x.round <= 1) {
        return;
    }
    let _ = writeln!(s, "\nper N and transport, median over rounds");
    let _ = writeln!(
        s,
        "{:>5} {:>5} {:<12} {:>8} {:>9} {:>9} {:>9} {:>9} {:>9} {:>8} {:>9}",
        "N",
        "ok",
        "transport",
        "ticks/s",
        "median",
        "p99",
        "startup",
        "CPU/tick",
        "tick CPU",
        "turn",
        "PSS"
    );
    for t in &r.transports {
        let label = TRANSPORTS
            .iter()
            .find(|(n, _)| *n == t.transport)
            .map_or(t.transport.as_str(), |(_, l)| l);
        let ok = format!("{}/{}", t.runs - t.failed, t.runs);
        if t.runs == t.failed {
            let _ = writeln!(
                s,
                "{:>5} {ok:>5} {label:<12} failed: {}",
                t.agents,
                t.error.as_deref().unwrap_or("")
            );
            continue;
        }
        let _ = writeln!(
            s,
            "{:>5} {ok:>5} {label:<12} {:>8.1} {:>9} {:>9} {:>9} {:>9} {:>9} {:>8} {:>9}",
            t.agents,
            t.ticks_per_s,
            ms(t.tick_ms_median),
            ms(t.tick_ms_p99),
            ms(t.startup_ms),
            ms(t.cpu_ms_per_tick),
            ms(t.ticking_cpu_ms_per_tick),
            us(t.robot_turn_us),
            fmt_bytes(t.pss_kib * 1024.0)
        );
    }
    let turns: Vec<String> = r
        .transports
        .iter()
        .filter(|t| t.transport == TRANSPORTS[0].0)
        .filter_map(|rt| {
            let floor = r
                .transports
                .iter()
                .find(|f| f.agents == rt.agents && f.transport == TRANSPORTS[1].0)?;
            let x = rt.robot_turn_us / floor.robot_turn_us;
            x.is_finite().then(|| format!("{:.2}x at {}", x, rt.agents))
        })
        .collect();
    if !turns.is_empty() {
        let _ = writeln!(
            s,
            "a robot's turn (CPU per tick of one robot process), runtime / iceoryx2 floor: {}",
            turns.join(", ")
        );
    }
}

/// Microseconds, or "-".
fn us(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.1} us")
    } else {
        "-".into()
    }
}

fn ms(v: f64) -> String {
    if !v.is_finite() {
        "-".into()
    } else if v < 1.0 {
        format!("{:.0} us", v * 1e3)
    } else if v < 1000.0 {
        format!("{v:.2} ms")
    } else {
        format!("{:.2} s", v / 1e3)
    }
}

/// The runtime / floor ratios of each round's pair (the runtime and floor rows of one round
/// and N), and per N the median over rounds, in the order the counts were given.
fn compare(runtime: &[RuntimeRow], floor: &[FloorRow]) -> Vec<Comparison> {
    let mut out: Vec<(Comparison, Vec<f64>)> = Vec::new();
    for (r, f) in runtime.iter().zip(floor) {
        let Some(fr) = f.result.as_ref().filter(|_| r.error.is_none()) else {
            continue;
        };
        let (median, p99) = (
            r.tick_ms_median / (fr.tick_ns.median / 1e6),
            r.tick_ms_p99 / (fr.tick_ns.p99 / 1e6),
        );
        match out.iter_mut().find(|(c, _)| c.agents == r.agents) {
            Some((c, p99s)) => {
                c.ratios.push(median);
                p99s.push(p99);
            }
            None => out.push((
                Comparison {
                    agents: r.agents,
                    ratios: vec![median],
                    ..Comparison::default()
                },
                vec![p99],
            )),
        }
    }
    out.into_iter()
        .map(|(mut c, p99s)| {
            c.median_ratio = median(&c.ratios);
            c.p99_ratio = median(&p99s);
            c
        })
        .collect()
}

/// One run of one transport, whatever its kind of row: what the transport tables and plots
/// show.
#[derive(Debug, Clone)]
struct Line {
    agents: u32,
    round: u32,
    /// "runtime", "iox2", "uds", "zenoh".
    transport: &'static str,
    label: &'static str,
    ticks_per_s: f64,
    median_ms: f64,
    p99_ms: f64,
    startup_ms: Option<f64>,
    cpu: Option<Cpu>,
    memory: Option<Memory>,
    error: Option<String>,
}

/// The transports in table (and colour) order.
const TRANSPORTS: [(&str, &str); 4] = [
    ("runtime", "runtime"),
    ("iox2", "iox2 floor"),
    ("uds", "UDS floor"),
    ("zenoh", "Zenoh floor"),
];

/// What a floor row and a peer row have in common.
struct FloorView<'a> {
    agents: u32,
    round: u32,
    result: Option<&'a FloorResult>,
    ticks_per_s: f64,
    cpu: Option<Cpu>,
    memory: Option<Memory>,
    error: Option<&'a String>,
}

fn floor_line(f: FloorView<'_>, (transport, label): (&'static str, &'static str)) -> Line {
    Line {
        agents: f.agents,
        round: f.round,
        transport,
        label,
        ticks_per_s: f.ticks_per_s,
        median_ms: f.result.map_or(f64::NAN, |x| x.tick_ns.median / 1e6),
        p99_ms: f.result.map_or(f64::NAN, |x| x.tick_ns.p99 / 1e6),
        startup_ms: f.result.map(|x| x.startup_ms),
        cpu: f.cpu,
        memory: f.memory,
        error: f
            .error
            .cloned()
            .or_else(|| f.result.is_none().then(|| "no result".to_string())),
    }
}

/// Every run of every transport, in the order they ran (per round, per N: the runtime, then
/// the floors).
fn lines(r: &SwarmReport) -> Vec<Line> {
    let mut out = Vec::new();
    for rt in &r.runtime {
        out.push(Line {
            agents: rt.agents,
            round: rt.round,
            transport: TRANSPORTS[0].0,
            label: TRANSPORTS[0].1,
            ticks_per_s: rt.ticks_per_s,
            median_ms: rt.tick_ms_median,
            p99_ms: rt.tick_ms_p99,
            startup_ms: rt.startup_ms,
            cpu: rt.cpu,
            memory: rt.memory,
            error: rt.error.clone(),
        });
        for f in r
            .floor
            .iter()
            .filter(|f| f.round == rt.round && f.agents == rt.agents)
        {
            out.push(floor_line(
                FloorView {
                    agents: f.agents,
                    round: f.round,
                    result: f.result.as_ref(),
                    ticks_per_s: f.ticks_per_s,
                    cpu: f.cpu,
                    memory: f.memory,
                    error: f.error.as_ref(),
                },
                TRANSPORTS[1],
            ));
        }
        for &(name, label) in &TRANSPORTS[2..] {
            for p in r
                .peers
                .iter()
                .filter(|p| p.round == rt.round && p.agents == rt.agents && p.peer.name() == name)
            {
                out.push(floor_line(
                    FloorView {
                        agents: p.agents,
                        round: p.round,
                        result: p.result.as_ref(),
                        ticks_per_s: p.ticks_per_s,
                        cpu: p.cpu,
                        memory: p.memory,
                        error: p.error.as_ref(),
                    },
                    (name, label),
                ));
            }
        }
    }
    out
}

/// Per N (in the order given) and transport (in table order), the median over the rounds
/// that did not fail.
fn summarize_transports(r: &SwarmReport) -> Vec<TransportSummary> {
    let all = lines(r);
    let mut ns: Vec<u32> = Vec::new();
    for l in &all {
        if !ns.contains(&l.agents) {
            ns.push(l.agents);
        }
    }
    let mut out = Vec::new();
    for n in ns {
        for (name, _) in TRANSPORTS {
            let of: Vec<&Line> = all
                .iter()
                .filter(|l| l.agents == n && l.transport == name)
                .collect();
            if of.is_empty() {
                continue;
            }
            let ok: Vec<&&Line> = of.iter().filter(|l| l.error.is_none()).collect();
            let med = |f: &dyn Fn(&Line) -> Option<f64>| -> f64 {
                median(&ok.iter().filter_map(|l| f(l)).collect::<Vec<f64>>())
            };
            out.push(TransportSummary {
                agents: n,
                transport: name.to_string(),
                runs: of.len(),
                failed: of.len() - ok.len(),
                ticks_per_s: med(&|l| Some(l.ticks_per_s)),
                tick_ms_median: med(&|l| Some(l.median_ms)),
                tick_ms_p99: med(&|l| Some(l.p99_ms)),
                cpu_ms_per_tick: med(&|l| l.cpu.map(|c| c.ms_per_tick)),
                ticking_cpu_ms_per_tick: med(&|l| l.cpu.and_then(|c| c.ticking_ms_per_tick)),
                robot_turn_us: med(&|l| l.cpu.and_then(|c| c.robot_turn_us)),
                pss_kib: med(&|l| l.memory.map(|m| m.pss_kib as f64)),
                startup_ms: med(&|l| l.startup_ms),
                error: of.iter().find_map(|l| l.error.clone()),
            });
        }
    }
    out
}

/// One point per N, the median of its rounds' values, in the order the counts first come.
fn per_n_median(points: Vec<(f64, f64)>) -> Vec<(f64, f64)> {
    let mut by_n: Vec<(f64, Vec<f64>)> = Vec::new();
    for (x, y) in points {
        match by_n.iter_mut().find(|(n, _)| *n == x) {
            Some((_, ys)) => ys.push(y),
            None => by_n.push((x, vec![y])),
        }
    }
    by_n.into_iter().map(|(x, ys)| (x, median(&ys))).collect()
}

fn plots(r: &SwarmReport, dir: &Path) -> anyhow::Result<()> {
    // One line per transport (the same colour in every panel), each point the median of the
    // rounds of its N that did not fail.
    let of = |name: &str| -> Vec<&TransportSummary> {
        r.transports
            .iter()
            .filter(|t| t.transport == name && t.runs > t.failed)
            .collect()
    };
    let line = |name: &str, what: &str, dashed: bool, y: &dyn Fn(&TransportSummary) -> f64| {
        let colour = TRANSPORTS.iter().position(|(n, _)| *n == name).unwrap_or(0);
        let label = TRANSPORTS[colour].1;
        Series {
            name: if what.is_empty() {
                label.to_string()
            } else {
                format!("{label} {what}")
            },
            points: of(name)
                .into_iter()
                .map(|t| (t.agents as f64, y(t)))
                .collect(),
            colour,
            dashed,
        }
    };
    let present: Vec<&str> = TRANSPORTS
        .iter()
        .map(|(n, _)| *n)
        .filter(|n| !of(n).is_empty())
        .collect();
    let each = |what: &str, dashed: bool, y: &dyn Fn(&TransportSummary) -> f64| -> Vec<Series> {
        present.iter().map(|n| line(n, what, dashed, y)).collect()
    };
    let mut latency = each("median", false, &|t| t.tick_ms_median);
    latency.extend(each("p99", true, &|t| t.tick_ms_p99));
    let mut memory = vec![Series {
        name: "runtime RSS".into(),
        points: per_n_median(
            r.runtime
                .iter()
                .filter(|x| x.error.is_none())
                .filter_map(|x| {
                    x.memory
                        .map(|m| (x.agents as f64, m.rss_kib as f64 / 1024.0))
                })
                .collect(),
        ),
        colour: 0,
        dashed: true,
    }];
    memory.extend(each("PSS", false, &|t| t.pss_kib / 1024.0));
    let mut cpu = each("", false, &|t| t.cpu_ms_per_tick);
    cpu.extend(each("ticking", true, &|t| t.ticking_cpu_ms_per_tick));
    let panels = vec![
        Panel {
            title: "lock-step ticks per second".into(),
            x_desc: "robot processes N".into(),
            y_desc: "ticks/s".into(),
            series: each("", false, &|t| t.ticks_per_s),
            legend: Legend::UpperRight,
        },
        Panel {
            title: "tick latency".into(),
            x_desc: "robot processes N".into(),
            y_desc: "ms".into(),
            series: latency,
            legend: Legend::UpperLeft,
        },
        Panel {
            title: "CPU of all processes per tick (dashed: from tick 17 on)".into(),
            x_desc: "robot processes N".into(),
            y_desc: "CPU ms per tick".into(),
            series: cpu,
            legend: Legend::UpperLeft,
        },
        Panel {
            title: "memory of all processes (PSS)".into(),
            x_desc: "robot processes N".into(),
            y_desc: "MiB".into(),
            series: memory,
            legend: Legend::UpperLeft,
        },
        Panel {
            title: "start-up until every robot is ready".into(),
            x_desc: "robot processes N".into(),
            y_desc: "ms".into(),
            series: each("", false, &|t| t.startup_ms),
            legend: Legend::UpperLeft,
        },
    ];
    let title = format!(
        "swarm bench swarm: {} cpus, {}",
        r.machine["nproc"],
        r.machine["cpu"].as_str().unwrap_or("")
    );
    write_figure(dir, "swarm", &title, &panels)
}
