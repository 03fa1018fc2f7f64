//! The `swarm-host` process: the world's stand-in on a remote host.
//!
//! It creates the run's iceoryx2 services in its own root with today's sizing, joins the world
//! over Zenoh, starts its robots, and then per tick republishes the world's slots for its
//! robots, wakes them, and sends their commands back in one batch once every robot the world
//! waits for has answered (or, past the deadline, as they come). It carries out its robots'
//! faults on the orchestrator's orders, which arrive as lines on its stdin through the
//! launcher; its reports go back on stdout. On every exit path it removes its resources.

mod robots;

use std::collections::{BTreeMap, BTreeSet};
use std::io::{BufRead, Write};
use std::path::PathBuf;
use std::time::{Duration, Instant};

use clap::Parser;
use crossbeam_channel::Receiver;
use iceoryx2::identifiers::UniquePublisherId;
use iceoryx2::port::listener::ListenerWaitError;
use iceoryx2::prelude::*;
use serde::Serialize;
use swarmrt_ipc::cleanup;
use swarmrt_ipc::{self as ipc, IpcError};
use swarmrt_protocol::control::{HostControl, HostReport};
use swarmrt_protocol::services::{RunServices, valid_run_id};
use swarmrt_protocol::{Command, CommandKind, ObservationHeader, PROTOCOL_VERSION};
use zenoh::Wait;
use zenoh::qos::CongestionControl;
use zenoh::sample::SampleKind;

use crate::link;
use crate::wire::{Down, Up};
use robots::{Launch, Reaped, Robots};

/// How long the host repeats its join before giving up on the world.
const JOIN_TIMEOUT: Duration = Duration::from_secs(20);
/// Robots get this long to exit after the shutdown sample, then SIGTERM, then SIGKILL.
const EXIT_GRACE: Duration = Duration::from_secs(3);

/// The `swarm-host` command line (started by `swarm run --hosts` through the host's launcher).
#[derive(Parser, Debug)]
#[command(
    name = "swarm-host",
    version,
    about = "Runs a group of a swarmrt run's robots on this host"
)]
struct Args {
    /// Run id (lower-case hex).
    #[arg(long)]
    run_id: String,
    /// This host's name in hosts.toml.
    #[arg(long, default_value = "host")]
    host: String,
    /// The first robot id this host runs.
    #[arg(long, default_value_t = 0)]
    first: u32,
    /// How many robots this host runs.
    #[arg(long, default_value_t = 0)]
    count: u32,
    /// The world's Zenoh endpoint.
    #[arg(long, default_value = "")]
    connect: String,
    /// Only remove this run's iceoryx2 resources on this host, then exit.
    #[arg(long)]
    clean: bool,
}

/// What the host counted (`metrics.json` -> `hosts`).
#[derive(Debug, Default, Serialize)]
pub struct HostStats {
    /// The host.
    pub host: String,
    /// Ticks received.
    pub ticks: u64,
    /// Observation slots received: its own robots' only.
    pub slots_received: u64,
    /// Bytes received from the world.
    pub bytes_down: u64,
    /// Bytes sent to the world.
    pub bytes_up: u64,
    /// Command batches sent.
    pub batches_up: u64,
    /// Commands forwarded.
    pub commands_up: u64,
    /// Batches sent before every awaited robot had answered (past `scenario.deadline_ms`).
    pub partial_batches: u64,
    /// Samples from publishers that are no robot of this host.
    pub unknown_sender: u64,
    /// Messages from the world that did not decode.
    pub malformed: u64,
}

enum Msg {
    Down(Down, usize),
    Malformed,
    WorldLost,
    Control(HostControl),
    ControlEof,
    Reaped(Reaped),
}

impl From<Reaped> for Msg {
    fn from(r: Reaped) -> Msg {
        Msg::Reaped(r)
    }
}

fn report(r: &HostReport) {
    let mut out = std::io::stdout().lock();
    let _ = out.write_all(r.to_line().as_bytes());
    let _ = out.flush();
}

/// Entry point of the `swarm-host` binary.
pub fn main() -> std::process::ExitCode {
    let args = Args::parse();
    swarmrt_scenario::process::init_logging();
    if !valid_run_id(&args.run_id) {
        eprintln!("error: invalid run id {:?}", args.run_id);
        return std::process::ExitCode::from(2);
    }
    if args.clean {
        let removed = cleanup::remove_run(&args.run_id);
        tracing::debug!(removed, "run resources removed");
        return std::process::ExitCode::SUCCESS;
    }
    let span = tracing::info_span!("host", host = %args.host);
    let _enter = span.enter();
    if let Err(e) = cleanup::claim(&args.run_id) {
        let why = format!(
            "cannot create the run's iceoryx2 directory (is this host's /dev/shm shared with the world's?): {e}"
        );
        report(&HostReport::Failed { why });
        return std::process::ExitCode::from(1);
    }
    let result = serve(&args);
    let removed = cleanup::remove_run(&args.run_id);
    tracing::debug!(removed, "run resources removed");
    match result {
        Ok(stats) => {
            report(&HostReport::Done {
                stats: serde_json::to_value(&stats).unwrap_or_default(),
            });
            std::process::ExitCode::SUCCESS
        }
        Err(e) => {
            report(&HostReport::Failed { why: e.to_string() });
            std::process::ExitCode::from(1)
        }
    }
}

fn read_config(run: &RunServices) -> Result<(swarmrt_scenario::Config, String, PathBuf), IpcError> {
    let mut line = String::new();
    std::io::stdin().lock().read_line(&mut line)?;
    let Ok(HostControl::Config { toml }) = serde_json::from_str::<HostControl>(&line) else {
        return Err("expected the run's config as the first line on stdin".into());
    };
    let dir = run.ipc_root().join("host");
    std::fs::create_dir_all(dir.join("storage"))?;
    let path = dir.join("config.toml");
    std::fs::write(&path, &toml)?;
    let cfg = swarmrt_scenario::Config::load(&path, &[]).map_err(|e| e.to_string())?;
    Ok((cfg, toml, dir))
}

fn serve(args: &Args) -> Result<HostStats, IpcError> {
    let run = RunServices::new(&args.run_id);
    let (cfg, toml, dir) = read_config(&run)?;
    let (first, count) = (args.first, args.count as usize);
    if count == 0 || first as u64 + count as u64 > cfg.robots.count as u64 {
        return Err(format!(
            "robots {first}..{} are not robots of this run (robots.count = {})",
            first as u64 + count as u64,
            cfg.robots.count
        )
        .into());
    }
    let agent = std::env::current_exe()?
        .parent()
        .map(|d| d.join("swarm-agent"))
        .filter(|p| p.exists())
        .ok_or("cannot find swarm-agent beside swarm-host")?;
    let _ = ipc::raise_fd_limit();
    let node = ipc::node(&run, &format!("swarmrt-{}-host", args.run_id))?;
    let observers = cfg.ipc.observers as usize;
    let services = ipc::create_services(&node, &run, count, cfg.faults.restart.len(), observers)?;
    let ports = ipc::WorldPorts::open(
        &services.observations,
        &services.observations_event,
        &services.commands,
        &services.commands_event,
        count,
        observers,
    )?;

    let (raw_tx, raw_rx) = crossbeam_channel::unbounded::<Msg>();
    let rx = ipc::wake_relay(&run, format!("swarmrt-{}-host-relay", args.run_id), raw_rx)?;
    {
        let tx = raw_tx.clone();
        std::thread::spawn(move || {
            for line in std::io::stdin().lock().lines() {
                let Ok(line) = line else { break };
                match serde_json::from_str::<HostControl>(&line) {
                    Ok(c) => {
                        if tx.send(Msg::Control(c)).is_err() {
                            return;
                        }
                    }
                    Err(e) => tracing::warn!("ignoring control line {line:?}: {e}"),
                }
            }
            let _ = tx.send(Msg::ControlEof);
        });
    }

    let session = link::host_session(&args.connect)
        .map_err(|e| format!("cannot reach the world at {}: {e}", args.connect))?;
    let tx = raw_tx.clone();
    let _down = session
        .declare_subscriber(link::down_key(&args.run_id, &args.host))
        .callback(move |sample| {
            let bytes = sample.payload().to_bytes();
            let _ = tx.send(match Down::decode(&bytes, count) {
                Ok(d) => Msg::Down(d, bytes.len()),
                Err(_) => Msg::Malformed,
            });
        })
        .wait()?;
    let tx = raw_tx.clone();
    let _world_alive = session
        .liveliness()
        .declare_subscriber(link::world_token(&args.run_id))
        .callback(move |sample| {
            if sample.kind() == SampleKind::Delete {
                let _ = tx.send(Msg::WorldLost);
            }
        })
        .wait()?;
    let up = session
        .declare_publisher(link::up_key(&args.run_id, &args.host))
        .congestion_control(CongestionControl::Block)
        .express(true)
        .wait()?;
    let _token = session
        .liveliness()
        .declare_token(link::host_token(&args.run_id, &args.host))
        .wait()?;

    let mut stats = HostStats {
        host: args.host.clone(),
        ..HostStats::default()
    };
    let send = |msg: &Up, stats: &mut HostStats| -> Result<(), IpcError> {
        let bytes = msg.encode();
        stats.bytes_up += bytes.len() as u64;
        up.put(bytes).wait()?;
        Ok(())
    };

    // Join: repeated until the world answers (its subscriber may not know us yet).
    let join = Up::Join {
        host: args.host.clone(),
        layout: link::layout(&toml),
    };
    let since = Instant::now();
    'join: loop {
        send(&join, &mut stats)?;
        let until = Instant::now() + Duration::from_millis(250);
        while let Ok(m) = rx.recv_deadline(until) {
            match m {
                Msg::Down(Down::Welcome, _) => break 'join,
                Msg::Down(Down::Refuse(why), _) => {
                    return Err(format!("the world refused this host: {why}").into());
                }
                Msg::ControlEof | Msg::Control(HostControl::Stop) => {
                    return Err("stopped before joining".into());
                }
                _ => {}
            }
        }
        if since.elapsed() > JOIN_TIMEOUT {
            return Err(format!(
                "the world at {} did not answer the join within {} s",
                args.connect,
                JOIN_TIMEOUT.as_secs()
            )
            .into());
        }
    }
    report(&HostReport::Joined);

    // `cd <this dir> && iox2 service list` on this host sees the run's local services.
    let ipc_config = dir.join("config/iceoryx2.toml");
    ipc::write_config_file(&run, &ipc_config)?;
    let mut robots = Robots::new(Launch {
        agent,
        run_id: args.run_id.clone(),
        config: dir.join("config.toml"),
        storage: dir.join("storage"),
        first,
        cfg: cfg.clone(),
        ipc_config,
    });
    let last = first + count as u32;
    for id in first..last {
        let pid = robots.spawn(id, 0, &raw_tx)?;
        report(&HostReport::Started {
            robot: id,
            incarnation: 0,
            pid,
        });
    }

    let deadline = Duration::from_millis(cfg.scenario.deadline_ms);
    let mut robot_of: BTreeMap<UniquePublisherId, u32> = BTreeMap::new();
    let mut awaiting_hello: BTreeSet<u32> = (first..last).collect();
    let mut expect: BTreeSet<u32> = BTreeSet::new();
    let mut batch: Vec<(u32, Command)> = Vec::new();
    let mut tick_at = Instant::now();
    let mut flush_each = false;
    let mut failure: Option<String> = None;
    'run: loop {
        // The robots' commands, attributed by publisher as the world does on one host.
        while let Some(sample) = ports.commands.receive()? {
            let origin = sample.origin();
            let c = *sample.payload();
            drop(sample);
            match robot_of.get(&origin) {
                Some(&robot) => {
                    expect.remove(&robot);
                    batch.push((robot, c));
                }
                None => {
                    let hello = c.version == PROTOCOL_VERSION
                        && CommandKind::from_u32(c.kind) == Some(CommandKind::Hello);
                    if hello && awaiting_hello.remove(&c.robot) {
                        robot_of.insert(origin, c.robot);
                        batch.push((c.robot, c));
                        flush_each = true;
                    } else {
                        stats.unknown_sender += 1;
                    }
                }
            }
        }
        if !batch.is_empty() && (expect.is_empty() || flush_each) {
            if !expect.is_empty() {
                stats.partial_batches += 1;
            }
            stats.batches_up += 1;
            stats.commands_up += batch.len() as u64;
            send(&Up::Commands(std::mem::take(&mut batch)), &mut stats)?;
        }
        for m in rx.try_iter() {
            match m {
                Msg::Down(
                    Down::Tick {
                        tick,
                        expect: e,
                        slots,
                    },
                    bytes,
                ) => {
                    stats.ticks += 1;
                    stats.slots_received += slots.len() as u64;
                    stats.bytes_down += bytes as u64;
                    if slots.len() != count {
                        stats.malformed += 1;
                        continue;
                    }
                    let sample = ports.publisher.loan_slice_uninit(count)?;
                    let mut sample = sample.write_from_slice(&slots);
                    *sample.user_header_mut() = ObservationHeader {
                        version: PROTOCOL_VERSION,
                        shutdown: 0,
                        tick,
                    };
                    sample.send()?;
                    ports.notifier.notify()?;
                    expect = e
                        .into_iter()
                        .filter(|r| (first..last).contains(r))
                        .collect();
                    tick_at = Instant::now();
                    flush_each = false;
                }
                Msg::Down(Down::Shutdown { .. }, bytes) => {
                    stats.bytes_down += bytes as u64;
                    break 'run;
                }
                Msg::Down(_, _) => {}
                Msg::Malformed => stats.malformed += 1,
                Msg::WorldLost => {
                    failure = Some("lost the world (its session ended or the link was cut)".into());
                    break 'run;
                }
                Msg::Control(c) => match c {
                    HostControl::Kill { robot } => {
                        robot_of.retain(|_, r| *r != robot);
                        awaiting_hello.remove(&robot);
                        robots.kill(robot);
                    }
                    HostControl::Freeze { robot } => robots.freeze(robot, true),
                    HostControl::Thaw { robot } => robots.freeze(robot, false),
                    HostControl::Restart { robot, incarnation } => {
                        robot_of.retain(|_, r| *r != robot);
                        robots.kill(robot);
                        awaiting_hello.insert(robot);
                        let pid = robots.spawn(robot, incarnation, &raw_tx)?;
                        report(&HostReport::Started {
                            robot,
                            incarnation,
                            pid,
                        });
                    }
                    HostControl::Stop => break 'run,
                    HostControl::Config { .. } => {}
                },
                Msg::ControlEof => {
                    failure = Some("the orchestrator is gone (stdin closed)".into());
                    break 'run;
                }
                Msg::Reaped(r) => reaped(&mut robots, &node, r),
            }
        }
        let timeout = if !expect.is_empty() && !flush_each {
            let waited = tick_at.elapsed();
            if waited >= deadline {
                // Past the deadline: send what came, then each answer as it comes.
                flush_each = true;
                continue;
            }
            deadline - waited
        } else {
            Duration::from_millis(500)
        };
        match ports.listener.timed_wait(|_| {}, timeout) {
            Ok(_) | Err(ListenerWaitError::InterruptSignal) => {
                if ipc::termination_requested(&node) {
                    failure = Some("terminated by a signal".into());
                    break 'run;
                }
            }
            Err(e) => return Err(e.into()),
        }
    }

    // Tell the robots (a header-only sample), then see them out.
    let sample = ports.publisher.loan_slice_uninit(0)?;
    let mut sample = sample.write_from_slice(&[]);
    *sample.user_header_mut() = ObservationHeader {
        version: PROTOCOL_VERSION,
        shutdown: 1,
        tick: 0,
    };
    sample.send()?;
    ports.notifier.notify()?;
    robots.thaw_all();
    see_out(&mut robots, &node, &rx);
    // The world waits for this before it closes its session, so the shutdown was delivered.
    let _ = send(&Up::Bye, &mut stats);
    drop(ports);
    drop(services);
    drop(node);
    let _ = session.close().wait();
    match failure {
        None => Ok(stats),
        Some(f) => Err(f.into()),
    }
}

fn reaped(robots: &mut Robots, node: &Node<ipc::Svc>, r: Reaped) {
    if let Some((robot, _, ordered)) = robots.reaped(r.pid) {
        // Its ports go, returning the observation samples it held.
        let _ = node.try_cleanup_dead_nodes();
        report(&HostReport::Exited {
            robot,
            pid: r.pid,
            how: r.how,
            ordered,
        });
    }
}

/// Waits for every robot to exit: [`EXIT_GRACE`] on its own, then SIGTERM, then SIGKILL.
fn see_out(robots: &mut Robots, node: &Node<ipc::Svc>, rx: &Receiver<Msg>) {
    let mut stage = 0;
    let mut until = Instant::now() + EXIT_GRACE;
    while !robots.is_empty() {
        match rx.recv_deadline(until) {
            Ok(Msg::Reaped(r)) => reaped(robots, node, r),
            Ok(_) => {}
            Err(crossbeam_channel::RecvTimeoutError::Timeout) => {
                let sig = if stage == 0 {
                    libc::SIGTERM
                } else {
                    libc::SIGKILL
                };
                swarmrt_scenario::process::signal_all(&robots.pids(), sig);
                swarmrt_scenario::process::signal_all(&robots.pids(), libc::SIGCONT);
                stage += 1;
                until = Instant::now() + EXIT_GRACE;
                if stage > 2 {
                    return;
                }
            }
            Err(_) => return,
        }
    }
}
