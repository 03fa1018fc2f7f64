//! Peer floors (issue 34): the floor's lock-step ([`crate::floor`]) over other
//! transports, so the runtime's iceoryx2 floor can be read against what a Unix-socket or a
//! Zenoh user would build.
//!
//! Every peer floor does the same thing per tick: the world hands each robot a message of
//! `size_of::<Observation>()` bytes (its slot, the tick written into it this tick), with one
//! send per robot; each robot reads its message and answers `size_of::<Command>()` bytes;
//! the world waits for all N answers before the next tick. Before the first tick every robot
//! says hello; after the last the world sends each robot a shutdown message (its slot with
//! the tick [`SHUTDOWN`]). Every wait has the watchdog [`PEER_TIMEOUT`]: a robot that does
//! not answer (or, over a socket, closes its connection) ends the world with an error naming
//! it, and the bench row says so.
//!
//! The messages are plain bytes laid out as the `#[repr(C)]` structs are (zeros, with
//! `version`, `robot`, `tick` and `kind` at their fields' offsets), so no padding of a Rust
//! value is ever read.
//!
//! - [`uds`]: one Unix stream socket per robot; the world writes each slot with one
//!   `write`, collects answers with `epoll`; robots block in `read`.
//! - [`zenoh_star`]: Zenoh peers in a star (robots connect to the world's TCP endpoint on
//!   127.0.0.1, no scouting, no gossip); one `put` per robot on its own key.

pub mod uds;
pub mod zenoh_star;

use std::mem::{offset_of, size_of};
use std::time::{Duration, Instant};

use anyhow::bail;
use serde::{Deserialize, Serialize};
use swarmrt_protocol::{Command, CommandKind, Observation, PROTOCOL_VERSION};

use crate::PEER_TIMEOUT;
use crate::child::{ChildMsg, say};
use crate::floor::FloorClock;

/// A transport of `swarm bench swarm --peers`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Peer {
    /// The iceoryx2 floor ([`crate::floor`]): the runtime's own services.
    Iox2,
    /// Unix domain stream sockets, epoll in the world.
    Uds,
    /// Zenoh peers in a star over TCP on localhost.
    Zenoh,
}

impl Peer {
    /// Every peer floor, in table order.
    pub const ALL: [Peer; 3] = [Peer::Iox2, Peer::Uds, Peer::Zenoh];

    /// The name used on the command line, in tables and JSON.
    pub fn name(self) -> &'static str {
        match self {
            Peer::Iox2 => "iox2",
            Peer::Uds => "uds",
            Peer::Zenoh => "zenoh",
        }
    }

    /// The name of its line in tables and plots.
    pub fn label(self) -> &'static str {
        match self {
            Peer::Iox2 => "iox2 floor",
            Peer::Uds => "UDS floor",
            Peer::Zenoh => "Zenoh floor",
        }
    }

    /// Parses one name of `--peers`.
    pub fn parse(s: &str) -> Option<Peer> {
        Peer::ALL.into_iter().find(|p| p.name() == s.trim())
    }
}

/// Parses `--peers`: a comma-separated list of [`Peer`] names, `all`, or `none`.
pub fn parse_peers(list: &[String]) -> Result<Vec<Peer>, String> {
    let mut out = Vec::new();
    for item in list.iter().flat_map(|s| s.split(',')) {
        let item = item.trim();
        match item {
            "" => {}
            "none" => {}
            "all" => {
                for p in Peer::ALL {
                    if !out.contains(&p) {
                        out.push(p);
                    }
                }
            }
            _ => match Peer::parse(item) {
                Some(p) if !out.contains(&p) => out.push(p),
                Some(_) => {}
                None => {
                    return Err(format!(
                        "--peers: unknown transport {item:?} (expected iox2, uds, zenoh, all or none)"
                    ));
                }
            },
        }
    }
    // Table order, whatever order they were given in.
    out.sort_by_key(|p| Peer::ALL.iter().position(|q| q == p));
    Ok(out)
}

/// A robot of a peer floor that kills itself (SIGKILL) on receiving tick `tick`: the test of
/// the watchdog (`swarm bench swarm --peer-fault ROBOT@TICK`, hidden).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Fault {
    /// The robot that dies.
    pub robot: u32,
    /// The tick at which it dies.
    pub tick: u64,
}

impl Fault {
    /// Parses `ROBOT@TICK`.
    pub fn parse(s: &str) -> Result<Fault, String> {
        let bad = || format!("--peer-fault: expected ROBOT@TICK, got {s:?}");
        let (r, t) = s.split_once('@').ok_or_else(bad)?;
        Ok(Fault {
            robot: r.trim().parse().map_err(|_| bad())?,
            tick: t.trim().parse().map_err(|_| bad())?,
        })
    }
}

/// Bytes of a world -> robot message: one observation slot.
pub const OBS_BYTES: usize = size_of::<Observation>();
/// Bytes of a robot -> world message: one command.
pub const CMD_BYTES: usize = size_of::<Command>();
/// The tick of the shutdown message.
pub const SHUTDOWN: u64 = u64::MAX;

fn put_u32(b: &mut [u8], at: usize, v: u32) {
    b[at..at + 4].copy_from_slice(&v.to_ne_bytes());
}

fn put_u64(b: &mut [u8], at: usize, v: u64) {
    b[at..at + 8].copy_from_slice(&v.to_ne_bytes());
}

fn get_u32(b: &[u8], at: usize) -> u32 {
    u32::from_ne_bytes(b[at..at + 4].try_into().expect("4 bytes"))
}

fn get_u64(b: &[u8], at: usize) -> u64 {
    u64::from_ne_bytes(b[at..at + 8].try_into().expect("8 bytes"))
}

/// Robot `robot`'s observation slot, as bytes (tick 0).
pub fn obs_slot(robot: u32) -> Vec<u8> {
    let mut b = vec![0u8; OBS_BYTES];
    put_u32(&mut b, offset_of!(Observation, version), PROTOCOL_VERSION);
    put_u32(&mut b, offset_of!(Observation, robot), robot);
    b
}

/// Writes `tick` into an observation slot.
pub fn set_obs_tick(slot: &mut [u8], tick: u64) {
    put_u64(slot, offset_of!(Observation, tick), tick);
}

/// The robot and tick of an observation message.
pub fn read_obs(b: &[u8]) -> anyhow::Result<(u32, u64)> {
    if b.len() != OBS_BYTES {
        bail!("observation of {} bytes, expected {OBS_BYTES}", b.len());
    }
    Ok((
        get_u32(b, offset_of!(Observation, robot)),
        get_u64(b, offset_of!(Observation, tick)),
    ))
}

/// A command message from `robot` for `tick`.
pub fn command(buf: &mut [u8], robot: u32, tick: u64, kind: CommandKind) {
    put_u32(buf, offset_of!(Command, version), PROTOCOL_VERSION);
    put_u32(buf, offset_of!(Command, robot), robot);
    put_u64(buf, offset_of!(Command, tick), tick);
    put_u32(buf, offset_of!(Command, kind), kind as u32);
}

/// What the world reads of a command message.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Answer {
    /// The sending robot.
    pub robot: u32,
    /// The tick it answers (0 for a hello).
    pub tick: u64,
    /// Hello or Act.
    pub kind: Option<CommandKind>,
}

/// Reads a command message.
pub fn read_command(b: &[u8]) -> Option<Answer> {
    if b.len() != CMD_BYTES || get_u32(b, offset_of!(Command, version)) != PROTOCOL_VERSION {
        return None;
    }
    Some(Answer {
        robot: get_u32(b, offset_of!(Command, robot)),
        tick: get_u64(b, offset_of!(Command, tick)),
        kind: CommandKind::from_u32(get_u32(b, offset_of!(Command, kind))),
    })
}

/// The world's side of a peer floor's transport.
pub trait WorldLink {
    /// Hands robot `robot` its message (one send).
    fn send(&mut self, robot: u32, msg: &[u8]) -> anyhow::Result<()>;
    /// Waits, at most until `deadline`, until at least one command arrived; hands every
    /// complete command received to `on`. Returns at the deadline without error; an error
    /// is a broken transport (e.g. a robot's socket closed), naming the robot.
    fn receive(&mut self, deadline: Instant, on: &mut dyn FnMut(&[u8])) -> anyhow::Result<()>;
}

/// The first few of `ids`, for an error message.
fn some_ids(ids: impl Iterator<Item = usize>) -> String {
    let v: Vec<usize> = ids.collect();
    let shown: Vec<String> = v.iter().take(8).map(|i| i.to_string()).collect();
    if v.len() > 8 {
        format!("robots {} and {} more", shown.join(", "), v.len() - 8)
    } else if v.len() == 1 {
        format!("robot {}", shown[0])
    } else {
        format!("robots {}", shown.join(", "))
    }
}

/// How long the world waits for every hello (the robots are started one by one).
pub fn startup_limit(n: usize) -> Duration {
    PEER_TIMEOUT + Duration::from_millis(100) * n as u32
}

/// The world's lock-step over `link`, as [`crate::floor::world`] does it over
/// iceoryx2: hellos, `ticks` ticks (each: write the tick into every slot, send each robot
/// its slot, wait for every answer), the pause for the memory reading at [`crate::floor::SAMPLE_TICK`],
/// the shutdown message.
pub fn drive(link: &mut dyn WorldLink, what: &str, n: usize, ticks: u64) -> anyhow::Result<()> {
    let ready_at = Instant::now();
    let limit = startup_limit(n);
    let mut hello = vec![false; n];
    let mut missing = n;
    while missing > 0 {
        let deadline = ready_at + limit;
        if Instant::now() >= deadline {
            bail!(
                "{missing} of {n} {what} robots never said hello ({})",
                some_ids((0..n).filter(|&i| !hello[i]))
            );
        }
        link.receive(deadline, &mut |b| {
            if let Some(a) = read_command(b)
                && a.kind == Some(CommandKind::Hello)
                && let Some(h) = hello.get_mut(a.robot as usize)
                && !*h
            {
                *h = true;
                missing -= 1;
            }
        })?;
    }
    let startup_ms = ready_at.elapsed().as_secs_f64() * 1e3;

    let mut slots: Vec<Vec<u8>> = (0..n as u32).map(obs_slot).collect();
    let mut answered = vec![u64::MAX; n];
    let mut clock = FloorClock::new(ticks);
    for tick in 0..ticks {
        let t0 = Instant::now();
        for (i, slot) in slots.iter_mut().enumerate() {
            set_obs_tick(slot, tick);
            link.send(i as u32, slot)?;
        }
        let t1 = Instant::now();
        let deadline = t1 + PEER_TIMEOUT;
        let mut pending = n;
        while pending > 0 {
            if Instant::now() >= deadline {
                bail!(
                    "{} did not answer tick {tick} within {PEER_TIMEOUT:?} ({what})",
                    some_ids((0..n).filter(|&i| answered[i] != tick))
                );
            }
            link.receive(deadline, &mut |b| {
                if let Some(a) = read_command(b)
                    && a.tick == tick
                    && a.kind == Some(CommandKind::Act)
                    && let Some(x) = answered.get_mut(a.robot as usize)
                    && *x != tick
                {
                    *x = tick;
                    pending -= 1;
                }
            })?;
        }
        // As the iceoryx2 floor: the parent reads memory and CPU now, between two ticks.
        clock.tick(tick, t0, t1, Instant::now())?;
    }
    for (i, slot) in slots.iter_mut().enumerate() {
        set_obs_tick(slot, SHUTDOWN);
        link.send(i as u32, slot)?;
    }
    say(&ChildMsg::Result {
        value: serde_json::to_value(clock.result(n, startup_ms))?,
    })
}

/// Runs a peer world; a failure is also told to the parent ([`ChildMsg::Failed`]) so the
/// bench row names it.
pub fn world(run_id: &str, peer: Peer, n: usize, ticks: u64) -> anyhow::Result<()> {
    if let Err(e) = swarmrt_ipc::raise_fd_limit() {
        tracing::warn!("cannot raise the open-file limit: {e}");
    }
    let r = match peer {
        Peer::Uds => uds::world(run_id, n, ticks),
        Peer::Zenoh => zenoh_star::world(run_id, n, ticks),
        Peer::Iox2 => Err(anyhow::anyhow!(
            "the iceoryx2 floor runs as floor-world, not as a peer world"
        )),
    };
    if let Err(e) = &r {
        let _ = say(&ChildMsg::Failed {
            error: format!("{e:#}"),
        });
    }
    r
}

/// What a peer robot does with each message: the shutdown ends it, the fault kills it, any
/// other message is answered (into `answer`) for its tick. Returns `None` on shutdown.
pub fn answer(
    msg: &[u8],
    me: u32,
    die_at: Option<u64>,
    answer: &mut [u8],
) -> anyhow::Result<Option<()>> {
    let (robot, tick) = read_obs(msg)?;
    if tick == SHUTDOWN {
        return Ok(None);
    }
    if robot != me {
        bail!("robot {me} was handed robot {robot}'s slot");
    }
    if die_at == Some(tick) {
        // SAFETY: a signal to this very process; it does not return.
        unsafe {
            libc::kill(libc::getpid(), libc::SIGKILL);
        }
    }
    command(answer, me, tick, CommandKind::Act);
    Ok(Some(()))
}

/// Runs a peer robot.
pub fn agent(
    run_id: &str,
    peer: Peer,
    robot: u32,
    robots: usize,
    addr: &str,
    die_at: Option<u64>,
) -> anyhow::Result<()> {
    match peer {
        Peer::Uds => uds::agent(robot, robots, addr, die_at),
        Peer::Zenoh => zenoh_star::agent(run_id, robot, robots, addr, die_at),
        Peer::Iox2 => bail!("the iceoryx2 floor runs as floor-agent, not as a peer robot"),
    }
}

/// CPU time (user + system, seconds) of every child this process has reaped so far
/// (`getrusage(RUSAGE_CHILDREN)`: exited threads and the children's own reaped children
/// included).
pub fn reaped_children_cpu_secs() -> f64 {
    // SAFETY: an all-zero rusage is valid; getrusage only writes the struct we pass.
    let mut ru: libc::rusage = unsafe { std::mem::zeroed() };
    // SAFETY: as above.
    if unsafe { libc::getrusage(libc::RUSAGE_CHILDREN, &mut ru) } != 0 {
        return f64::NAN;
    }
    let tv = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    tv(ru.ru_utime) + tv(ru.ru_stime)
}

/// CPU time (seconds) the live processes `pids` have used so far. Per process the larger of
/// the sum of its live threads' run time (`/proc/<pid>/task/*/schedstat`, nanoseconds, but
/// without exited threads) and `utime + stime` of `/proc/<pid>/stat` (every thread, but in
/// clock ticks, truncated): both are lower bounds.
pub fn live_cpu_secs(pids: &[u32]) -> f64 {
    // SAFETY: sysconf only reads a constant.
    let hz = unsafe { libc::sysconf(libc::_SC_CLK_TCK) }.max(1) as f64;
    let mut total = 0.0;
    for pid in pids {
        let stat = std::fs::read_to_string(format!("/proc/{pid}/stat"))
            .ok()
            .and_then(|s| {
                let rest = s.rsplit_once(')')?.1.to_string();
                let f: Vec<&str> = rest.split_whitespace().collect();
                // Fields 14 and 15 of stat; `rest` starts at field 3.
                let u: f64 = f.get(11)?.parse().ok()?;
                let s: f64 = f.get(12)?.parse().ok()?;
                Some((u + s) / hz)
            })
            .unwrap_or(0.0);
        let mut sched = 0.0;
        if let Ok(tasks) = std::fs::read_dir(format!("/proc/{pid}/task")) {
            for t in tasks.flatten() {
                if let Some(ns) = std::fs::read_to_string(t.path().join("schedstat"))
                    .ok()
                    .and_then(|s| s.split_whitespace().next()?.parse::<f64>().ok())
                {
                    sched += ns * 1e-9;
                }
            }
        }
        total += stat.max(sched);
    }
    total
}

/// How long [`robot_turn_us`] watches the robots.
pub const TURN_WINDOW: std::time::Duration = std::time::Duration::from_millis(100);

/// Run time (ns, every thread) and voluntary sleeps of live process `pid` so far, from
/// `/proc/<pid>/task/*/schedstat` and `status`: the scheduler's own counters, the ones
/// `perf stat`'s task-clock reads.
fn turns_so_far(pid: u32) -> Option<(u64, u64)> {
    let (mut ns, mut sleeps) = (0u64, 0u64);
    for t in std::fs::read_dir(format!("/proc/{pid}/task"))
        .ok()?
        .flatten()
    {
        let run = std::fs::read_to_string(t.path().join("schedstat")).ok()?;
        ns += run.split_whitespace().next()?.parse::<u64>().ok()?;
        let status = std::fs::read_to_string(t.path().join("status")).ok()?;
        sleeps += status
            .lines()
            .find_map(|l| l.strip_prefix("voluntary_ctxt_switches:"))?
            .trim()
            .parse::<u64>()
            .ok()?;
    }
    Some((ns, sleeps))
}

/// A robot's turn, µs: the CPU the robot processes `pids` use per sleep over `window` of
/// ticking. A lock-step robot sleeps once per tick (it answers, then waits for the next), so
/// this is its CPU per tick. `None` when no robot slept in the window or one was gone.
pub fn robot_turn_us(pids: &[u32], window: std::time::Duration) -> Option<f64> {
    let before: Vec<(u64, u64)> = pids
        .iter()
        .map(|&p| turns_so_far(p))
        .collect::<Option<_>>()?;
    std::thread::sleep(window);
    let (mut ns, mut sleeps) = (0u64, 0u64);
    for (&p, (ns0, s0)) in pids.iter().zip(before) {
        let (ns1, s1) = turns_so_far(p)?;
        ns += ns1.saturating_sub(ns0);
        sleeps += s1.saturating_sub(s0);
    }
    (sleeps > 0).then(|| ns as f64 / sleeps as f64 / 1e3)
}

/// CPU of one run's processes.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Cpu {
    /// User + system seconds of every process of the run (world and robots), start-up and
    /// shutdown included: the reaped children's rusage, as `benchmarks/scripts/alternate.py`
    /// reads it.
    pub total_secs: f64,
    /// `total_secs` / ticks, ms.
    pub ms_per_tick: f64,
    /// CPU from the memory reading (after tick `from_tick`) to the end of the run, per tick
    /// of that span, ms: nearly only ticking (the exits are in it, the start-up is not).
    pub ticking_ms_per_tick: Option<f64>,
    /// The tick at which the CPU of the live processes was read.
    pub from_tick: Option<u64>,
    /// A robot's turn while ticking, µs of CPU per robot per tick ([`robot_turn_us`]).
    #[serde(default)]
    pub robot_turn_us: Option<f64>,
}

impl Cpu {
    /// From the rusage before and after the run, the reading of the live processes mid-run
    /// (`(tick, seconds)`), and the ticks run.
    pub fn new(before: f64, after: f64, mid: Option<(u64, f64)>, ticks: u64) -> Cpu {
        let total = after - before;
        let ticking = mid.and_then(|(at, secs)| {
            (ticks > at).then(|| (total - secs).max(0.0) * 1e3 / (ticks - at) as f64)
        });
        Cpu {
            total_secs: total,
            ms_per_tick: total * 1e3 / ticks.max(1) as f64,
            ticking_ms_per_tick: ticking,
            from_tick: mid.map(|(t, _)| t),
            robot_turn_us: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_have_the_runtime_sizes_and_round_trip() {
        assert_eq!(OBS_BYTES, size_of::<Observation>());
        assert_eq!(CMD_BYTES, size_of::<Command>());
        let mut slot = obs_slot(7);
        set_obs_tick(&mut slot, 42);
        assert_eq!(read_obs(&slot).unwrap(), (7, 42));
        let mut cmd = vec![0u8; CMD_BYTES];
        assert_eq!(answer(&slot, 7, None, &mut cmd).unwrap(), Some(()));
        assert_eq!(
            read_command(&cmd),
            Some(Answer {
                robot: 7,
                tick: 42,
                kind: Some(CommandKind::Act)
            })
        );
        // Someone else's slot is an error; the shutdown ends the robot.
        assert!(answer(&slot, 8, None, &mut cmd).is_err());
        set_obs_tick(&mut slot, SHUTDOWN);
        assert_eq!(answer(&slot, 7, None, &mut cmd).unwrap(), None);
        assert!(read_obs(&slot[1..]).is_err());
        assert_eq!(read_command(&cmd[1..]), None);
    }

    #[test]
    fn a_robot_turn_is_the_cpu_per_sleep() {
        // 2 ms of CPU (by its own CPU clock, whatever else runs), then a sleep, in a loop.
        let script = "import time\nwhile True:\n    t = time.thread_time()\n    \
                      while time.thread_time() - t < 0.002: pass\n    time.sleep(0.002)\n";
        let mut child = std::process::Command::new("python3")
            .args(["-c", script])
            .spawn()
            .unwrap();
        std::thread::sleep(std::time::Duration::from_millis(200));
        let turn = robot_turn_us(&[child.id()], std::time::Duration::from_millis(500));
        child.kill().unwrap();
        child.wait().unwrap();
        let turn = turn.expect("the child slept in the window");
        // The window cuts a turn at each end, so on a loaded machine, where the child gets
        // only a few dozen turns in it, the reading may be short by a tenth or so (1.84 ms
        // seen in CI).
        assert!((1_500.0..4_000.0).contains(&turn), "{turn} us per sleep");
        assert_eq!(
            robot_turn_us(&[child.id()], TURN_WINDOW),
            None,
            "a gone process"
        );
    }

    #[test]
    fn peers_parse_in_table_order() {
        let p = |s: &str| parse_peers(&[s.to_string()]);
        assert_eq!(p("zenoh,uds").unwrap(), vec![Peer::Uds, Peer::Zenoh]);
        assert_eq!(p("all").unwrap(), Peer::ALL.to_vec());
        assert_eq!(p("none").unwrap(), vec![]);
        assert_eq!(p("iox2, iox2").unwrap(), vec![Peer::Iox2]);
        assert!(p("tcp").is_err());
        assert_eq!(Fault::parse("1@5").unwrap(), Fault { robot: 1, tick: 5 });
        assert!(Fault::parse("1").is_err());
    }

    #[test]
    fn cpu_per_tick_splits_start_up_from_ticking() {
        let c = Cpu::new(1.0, 4.0, Some((17, 2.0)), 117);
        assert!((c.total_secs - 3.0).abs() < 1e-12);
        assert!((c.ms_per_tick - 3000.0 / 117.0).abs() < 1e-9);
        assert!((c.ticking_ms_per_tick.unwrap() - 10.0).abs() < 1e-9);
        assert_eq!(Cpu::new(0.0, 1.0, None, 10).ticking_ms_per_tick, None);
    }

    #[test]
    fn live_cpu_reads_this_process() {
        // Burn 30 ms of this thread's own CPU (not of the wall clock: on a loaded machine a
        // 30 ms spin may get only half of it); the process's counters include it.
        let thread_cpu = || {
            let mut ts = libc::timespec {
                tv_sec: 0,
                tv_nsec: 0,
            };
            // SAFETY: clock_gettime only writes the struct we pass.
            unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
            Duration::new(ts.tv_sec as u64, ts.tv_nsec as u32)
        };
        let start = thread_cpu();
        while thread_cpu() - start < Duration::from_millis(30) {
            std::hint::spin_loop();
        }
        let secs = live_cpu_secs(&[std::process::id()]);
        assert!(secs >= 0.02, "{secs}");
        assert_eq!(live_cpu_secs(&[u32::MAX]), 0.0);
    }
}
