//! `swarm bench ipc`: round trip and throughput per transport and payload, fan-out to many
//! subscriber processes, loss accounting, and the runtime's message path against raw
//! iceoryx2. Writes `results.json`, `ipc.svg` and `ipc.png` into the output directory and
//! prints a table (or the JSON with `--json`).

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use anyhow::Context;
use serde::{Deserialize, Serialize};

use super::child::{ChildMsg, ChildSpec, LossMode, Transport};
use super::fanout::FanoutResult;
use super::loss::{PubResult, SubResult};
use super::procs::{Children, Memory, memory};
use super::stats::{Summary, summarize};
use super::transports::{MIN_PAYLOAD, PATH_REPLY, PATH_REQUEST, PingResult, crossbeam_pair};
use super::{
    BenchRun, Interrupt, PEER_TIMEOUT, default_out, fmt_bytes, fmt_ns, fmt_rate, machine,
    make_out_dir, progress, write_json,
};
use swarmrt_analysis::plot::bench::{Legend, Panel, Series, write_figure};
use swarmrt_orchestrator::error::{SwarmError, SwarmResult};

/// The transport every row is compared with: iceoryx2 sleeping in a listener, as the
/// runtime's shells do.
pub const BASELINE: Transport = Transport::Iox2Listener;
/// Simulated work per sample of the loss demonstration's slow subscriber.
pub const LOSS_WORK_US: u64 = 20;
/// Pause between the loss demonstration's sends: faster than the subscriber can go (its
/// work plus a wake-up), slow enough that some samples get through.
pub const LOSS_INTERVAL_US: u64 = 10;

/// One transport at one payload size.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct Row {
    /// Transport name.
    pub transport: String,
    /// Message size, bytes.
    pub payload: usize,
    /// Round-trip latency, ns.
    pub rtt_ns: Summary,
    /// One-way throughput, messages per second (counted by the receiver; the median of the
    /// throughput windows).
    pub msgs_per_s: f64,
    /// One-way throughput, bytes per second.
    pub bytes_per_s: f64,
    /// Messages the sender sent in the throughput phase.
    pub sent: u64,
    /// Messages the receiver counted (equal to `sent`: every transport here is lossless).
    pub received: u64,
    /// Throughput of each window of the throughput phase (`msgs_per_s` is their median).
    #[serde(default)]
    pub window_msgs_per_s: Vec<f64>,
    /// CPU seconds the sender used in the throughput phase.
    #[serde(default)]
    pub sender_cpu_secs: f64,
    /// Times the sender was preempted in the throughput phase (about one per message: the
    /// pair shared a core with each other or with other load).
    #[serde(default)]
    pub sender_involuntary_switches: i64,
    /// Median round trip divided by the baseline's at this payload (lower is faster).
    pub rtt_vs_baseline: f64,
    /// Throughput divided by the baseline's at this payload (higher is faster).
    pub throughput_vs_baseline: f64,
    /// Set when this measurement failed.
    pub error: Option<String>,
}

/// One fan-out size.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct FanoutRow {
    /// Subscriber processes.
    pub subscribers: usize,
    /// The publisher's numbers (absent if it failed).
    pub result: Option<FanoutResult>,
    /// Memory of the publisher and all subscribers during the measurement.
    pub memory: Option<Memory>,
    /// Milliseconds the parent spent spawning the subscriber processes.
    pub spawn_ms: f64,
    /// Set when this size failed (where fan-out stops).
    pub error: Option<String>,
}

/// One loss demonstration.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct LossRow {
    /// Mode id.
    pub id: String,
    /// What the mode configures.
    pub settings: String,
    /// Samples the publisher sent.
    pub sent: u64,
    /// Samples the subscriber received.
    pub received: u64,
    /// sent - received.
    pub dropped: u64,
    /// Sequence numbers the subscriber saw skipped.
    pub gaps: u64,
    /// Seconds the publisher took (with retrying or lock-step it waits for the subscriber).
    pub publisher_secs: f64,
    /// Simulated work per sample in the subscriber, microseconds.
    pub work_us: u64,
    /// Set when this demonstration failed.
    pub error: Option<String>,
}

/// The runtime's message path against raw iceoryx2.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct PathResult {
    /// Bytes world -> robot (one observation).
    pub request_bytes: usize,
    /// Bytes robot -> world (one command).
    pub reply_bytes: usize,
    /// Raw iceoryx2 (`[u8]` services with default settings), ns.
    pub raw_rtt_ns: Summary,
    /// `swarmrt_ipc` services and types, the shells' send/notify/wait pattern, ns.
    pub runtime_rtt_ns: Summary,
    /// runtime median / raw median.
    pub median_ratio: f64,
    /// Set when this comparison failed.
    pub error: Option<String>,
}

/// Everything `swarm bench ipc` measured.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct IpcReport {
    /// The machine.
    pub machine: serde_json::Value,
    /// Seconds per transport and payload.
    pub secs: f64,
    /// The transport ratios refer to.
    pub baseline: String,
    /// Every transport measured.
    pub transports: Vec<String>,
    /// One row per payload and transport.
    pub rows: Vec<Row>,
    /// One row per fan-out size.
    pub fanout: Vec<FanoutRow>,
    /// Loss accounting.
    pub loss: Vec<LossRow>,
    /// The runtime's message path.
    pub path: PathResult,
    /// Run ids used (their iceoryx2 roots and shared memory are gone afterwards).
    pub run_ids: Vec<String>,
    /// Where the results were written.
    pub out: String,
    /// Wall seconds of the whole benchmark.
    pub wall_secs: f64,
}

/// What `swarm bench ipc` measures (its command-line options, without clap).
#[derive(Debug, Clone, PartialEq)]
pub struct IpcOptions {
    /// Payload sizes in bytes, each at least [`MIN_PAYLOAD`] (`--payload`).
    pub payload: Vec<usize>,
    /// Seconds of measurement per transport and payload (`--secs`).
    pub secs: f64,
    /// Subscriber process counts for the fan-out measurement (`--fanout`).
    pub fanout: Vec<usize>,
    /// Print the results as JSON instead of tables (`--json`).
    pub json: bool,
    /// Output directory; `None` is `bench/ipc-<time>/` (`--out`).
    pub out: Option<PathBuf>,
}

fn user(msg: String) -> SwarmError {
    SwarmError::User(msg)
}

/// `swarm bench ipc`.
pub fn run(args: &IpcOptions, interrupt: &Interrupt) -> SwarmResult<()> {
    if args.payload.is_empty() || args.payload.iter().any(|&p| p < MIN_PAYLOAD) {
        return Err(user(format!(
            "--payload: expected sizes of at least {MIN_PAYLOAD} bytes, got {:?}",
            args.payload
        )));
    }
    if args.payload.iter().any(|&p| p > 64 << 20) {
        return Err(user("--payload: at most 64 MiB per message".into()));
    }
    if !(args.secs.is_finite() && args.secs > 0.0 && args.secs <= 3600.0) {
        return Err(user(format!(
            "--secs: expected a number of seconds in (0, 3600], got {}",
            args.secs
        )));
    }
    if args.fanout.iter().any(|&k| k == 0 || k > 10_000) {
        return Err(user(format!(
            "--fanout: expected subscriber counts in 1..=10000, got {:?}",
            args.fanout
        )));
    }
    let out = args.out.clone().unwrap_or_else(|| default_out("ipc"));
    make_out_dir(&out)?;
    let started = Instant::now();
    let mut report = IpcReport {
        machine: machine(),
        secs: args.secs,
        baseline: BASELINE.name().to_string(),
        transports: Transport::ALL
            .iter()
            .map(|t| t.name().to_string())
            .collect(),
        out: out.display().to_string(),
        ..IpcReport::default()
    };
    let steps = args.payload.len() * Transport::ALL.len() + args.fanout.len() + 5;
    let pb = progress(steps as u64);

    for &payload in &args.payload {
        for t in Transport::ALL {
            pb.set_message(format!("{} {}", t.name(), fmt_bytes(payload as f64)));
            let row = match measure_pair(t, payload, args.secs, interrupt, &mut report.run_ids) {
                Ok(r) => Row {
                    transport: t.name().to_string(),
                    payload,
                    rtt_ns: r.rtt_ns,
                    msgs_per_s: r.msgs_per_s,
                    bytes_per_s: r.bytes_per_s,
                    sent: r.sent,
                    received: r.received,
                    window_msgs_per_s: r.window_msgs_per_s,
                    sender_cpu_secs: r.cpu_secs,
                    sender_involuntary_switches: r.involuntary_switches,
                    ..Row::default()
                },
                Err(e) => {
                    interrupt.check()?;
                    tracing::warn!("{} at {payload} B failed: {e:#}", t.name());
                    Row {
                        transport: t.name().to_string(),
                        payload,
                        error: Some(format!("{e:#}")),
                        ..Row::default()
                    }
                }
            };
            report.rows.push(row);
            pb.inc(1);
        }
    }
    ratios(&mut report.rows);

    let mut stopped = false;
    for &k in &args.fanout {
        pb.set_message(format!("fan-out to {k}"));
        if stopped {
            report.fanout.push(FanoutRow {
                subscribers: k,
                error: Some("skipped: a smaller fan-out failed".into()),
                ..FanoutRow::default()
            });
            pb.inc(1);
            continue;
        }
        let row = measure_fanout(k, args.secs, interrupt, &mut report.run_ids);
        interrupt.check()?;
        if let Some(e) = &row.error {
            tracing::warn!("fan-out to {k} failed: {e}");
            stopped = true;
        }
        report.fanout.push(row);
        pb.inc(1);
    }

    for mode in LossMode::ALL {
        pb.set_message(format!("loss: {}", mode.id()));
        let row = measure_loss(mode, args.secs, interrupt, &mut report.run_ids);
        interrupt.check()?;
        report.loss.push(row);
        pb.inc(1);
    }

    pb.set_message("runtime path");
    report.path = measure_path(args.secs, interrupt, &mut report.run_ids);
    interrupt.check()?;
    pb.inc(1);
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

/// Fills the ratio columns against [`BASELINE`] at the same payload.
fn ratios(rows: &mut [Row]) {
    let base: Vec<(usize, f64, f64)> = rows
        .iter()
        .filter(|r| r.transport == BASELINE.name() && r.error.is_none())
        .map(|r| (r.payload, r.rtt_ns.median, r.msgs_per_s))
        .collect();
    for r in rows.iter_mut() {
        if let Some(&(_, rtt, tput)) = base.iter().find(|b| b.0 == r.payload) {
            r.rtt_vs_baseline = r.rtt_ns.median / rtt;
            r.throughput_vs_baseline = r.msgs_per_s / tput;
        } else {
            r.rtt_vs_baseline = f64::NAN;
            r.throughput_vs_baseline = f64::NAN;
        }
    }
}

/// Alternating rounds of the path comparison.
const PATH_ROUNDS: usize = 3;

/// Time a child gets to set up before it counts as failed.
const SETUP: Duration = Duration::from_secs(30);

fn measure_pair(
    t: Transport,
    payload: usize,
    secs: f64,
    interrupt: &Interrupt,
    run_ids: &mut Vec<String>,
) -> anyhow::Result<PingResult> {
    interrupt.check()?;
    if t == Transport::Crossbeam {
        return crossbeam_pair(payload, secs);
    }
    let run = BenchRun::claim()?;
    run_ids.push(run.id().to_string());
    let mut kids = Children::new();
    let pong = kids
        .spawn(
            "pong",
            &ChildSpec::Pong {
                run_id: run.id().to_string(),
                transport: t,
                payload,
            },
            true,
        )?
        .context("pong messages")?;
    let addr = pong.ready(SETUP, interrupt)?;
    let ping = kids
        .spawn(
            "ping",
            &ChildSpec::Ping {
                run_id: run.id().to_string(),
                transport: t,
                payload,
                secs,
                addr,
            },
            true,
        )?
        .context("ping messages")?;
    let limit = Duration::from_secs_f64(secs * 2.0) + SETUP + PEER_TIMEOUT;
    let value = ping.result(limit, interrupt)?;
    kids.finish(PEER_TIMEOUT)?;
    Ok(serde_json::from_value(value)?)
}

fn measure_fanout(
    k: usize,
    secs: f64,
    interrupt: &Interrupt,
    run_ids: &mut Vec<String>,
) -> FanoutRow {
    let mut row = FanoutRow {
        subscribers: k,
        ..FanoutRow::default()
    };
    let r = (|| -> anyhow::Result<()> {
        let run = BenchRun::claim()?;
        run_ids.push(run.id().to_string());
        let mut kids = Children::new();
        let publisher = kids
            .spawn(
                "fan-out publisher",
                &ChildSpec::FanoutPub {
                    run_id: run.id().to_string(),
                    subscribers: k,
                    secs,
                },
                true,
            )?
            .context("publisher messages")?;
        publisher.ready(SETUP, interrupt)?;
        let spawn_start = Instant::now();
        for i in 0..k {
            interrupt.check()?;
            kids.spawn(
                &format!("fan-out subscriber {i}"),
                &ChildSpec::FanoutSub {
                    run_id: run.id().to_string(),
                    index: i as u32,
                },
                false,
            )?;
        }
        row.spawn_ms = spawn_start.elapsed().as_secs_f64() * 1e3;
        let startup = PEER_TIMEOUT + Duration::from_millis(100) * k as u32;
        match publisher.next(startup, interrupt)? {
            ChildMsg::Progress => row.memory = Some(memory(&kids.pids())),
            other => anyhow::bail!("publisher: expected progress, got {other:?}"),
        }
        let limit = Duration::from_secs_f64(secs * 2.0) + PEER_TIMEOUT * 2;
        let value = publisher.result(limit, interrupt)?;
        row.result = Some(serde_json::from_value(value)?);
        kids.finish(PEER_TIMEOUT)?;
        Ok(())
    })();
    if let Err(e) = r {
        row.error = Some(format!("{e:#}"));
    }
    row
}

fn measure_loss(
    mode: LossMode,
    secs: f64,
    interrupt: &Interrupt,
    run_ids: &mut Vec<String>,
) -> LossRow {
    let count = ((secs * 5_000.0) as u64).clamp(500, 20_000);
    let mut row = LossRow {
        id: mode.id().to_string(),
        settings: mode.settings().to_string(),
        work_us: LOSS_WORK_US,
        ..LossRow::default()
    };
    let r = (|| -> anyhow::Result<()> {
        let run = BenchRun::claim()?;
        run_ids.push(run.id().to_string());
        let mut kids = Children::new();
        let sub = kids
            .spawn(
                "loss subscriber",
                &ChildSpec::LossSub {
                    run_id: run.id().to_string(),
                    mode,
                    work_us: LOSS_WORK_US,
                },
                true,
            )?
            .context("subscriber messages")?;
        sub.ready(SETUP, interrupt)?;
        let publisher = kids
            .spawn(
                "loss publisher",
                &ChildSpec::LossPub {
                    run_id: run.id().to_string(),
                    mode,
                    count,
                    interval_us: LOSS_INTERVAL_US,
                },
                true,
            )?
            .context("publisher messages")?;
        let limit = Duration::from_micros(count * (LOSS_WORK_US + 200)) + SETUP + PEER_TIMEOUT;
        let p: PubResult = serde_json::from_value(publisher.result(limit, interrupt)?)?;
        let s: SubResult = serde_json::from_value(sub.result(limit, interrupt)?)?;
        kids.finish(PEER_TIMEOUT)?;
        row.sent = p.sent;
        row.received = s.received;
        row.dropped = p.sent.saturating_sub(s.received);
        row.gaps = s.gaps;
        row.publisher_secs = p.secs;
        Ok(())
    })();
    if let Err(e) = r {
        row.error = Some(format!("{e:#}"));
    }
    row
}

fn measure_path(secs: f64, interrupt: &Interrupt, run_ids: &mut Vec<String>) -> PathResult {
    let mut res = PathResult {
        request_bytes: PATH_REQUEST,
        reply_bytes: PATH_REPLY,
        ..PathResult::default()
    };
    let mut one = |runtime: bool, secs: f64| -> anyhow::Result<Vec<u64>> {
        let run = BenchRun::claim()?;
        run_ids.push(run.id().to_string());
        let mut kids = Children::new();
        let world = kids
            .spawn(
                "path world",
                &ChildSpec::PathWorld {
                    run_id: run.id().to_string(),
                    runtime,
                    secs,
                },
                true,
            )?
            .context("world messages")?;
        world.ready(SETUP, interrupt)?;
        kids.spawn(
            "path robot",
            &ChildSpec::PathRobot {
                run_id: run.id().to_string(),
                runtime,
            },
            false,
        )?;
        let limit = Duration::from_secs_f64(secs) + SETUP + PEER_TIMEOUT;
        let v = world.result(limit, interrupt)?;
        kids.finish(PEER_TIMEOUT)?;
        Ok(serde_json::from_value(v["samples_ns"].clone())?)
    };
    // Raw and runtime alternate in PATH_ROUNDS rounds each and their samples are pooled, so
    // bursts of background load on a shared machine hit both alike.
    let r = (|| -> anyhow::Result<()> {
        let round = secs / PATH_ROUNDS as f64;
        let (mut raw, mut rt) = (Vec::new(), Vec::new());
        for _ in 0..PATH_ROUNDS {
            raw.extend(one(false, round)?);
            rt.extend(one(true, round)?);
        }
        res.raw_rtt_ns = summarize(&mut raw);
        res.runtime_rtt_ns = summarize(&mut rt);
        res.median_ratio = res.runtime_rtt_ns.median / res.raw_rtt_ns.median;
        Ok(())
    })();
    if let Err(e) = r {
        res.error = Some(format!("{e:#}"));
    }
    res
}

/// The text tables.
pub fn table(r: &IpcReport) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let m = &r.machine;
    let _ = writeln!(
        s,
        "machine: {} cpus, {}, kernel {}, load {}",
        m["nproc"], m["cpu"], m["kernel"], m["loadavg_at_start"]
    );
    let _ = writeln!(
        s,
        "\nround trip (one message each way) and one-way throughput; ratios against {}",
        r.baseline
    );
    let _ = writeln!(
        s,
        "{:>8}  {:<17} {:>9} {:>9} {:>9} {:>7}   {:>9} {:>10} {:>7}",
        "payload", "transport", "median", "p99", "p99.9", "x rtt", "msgs/s", "bytes/s", "x tput"
    );
    for row in &r.rows {
        if let Some(e) = &row.error {
            let _ = writeln!(
                s,
                "{:>8}  {:<17} failed: {e}",
                fmt_bytes(row.payload as f64),
                row.transport
            );
            continue;
        }
        let _ = writeln!(
            s,
            "{:>8}  {:<17} {:>9} {:>9} {:>9} {:>7}   {:>9} {:>10} {:>7}",
            fmt_bytes(row.payload as f64),
            row.transport,
            fmt_ns(row.rtt_ns.median),
            fmt_ns(row.rtt_ns.p99),
            fmt_ns(row.rtt_ns.p999),
            ratio(row.rtt_vs_baseline),
            fmt_rate(row.msgs_per_s),
            format!("{}/s", fmt_bytes(row.bytes_per_s)),
            ratio(row.throughput_vs_baseline),
        );
    }
    let _ = writeln!(
        s,
        "\nfan-out: one publisher, K subscriber processes (64 B sample, event wake-up, shared ack service)"
    );
    let _ = writeln!(
        s,
        "{:>6} {:>10} {:>10} {:>10} {:>10} {:>9} {:>9} {:>9} {:>6}",
        "K", "last rx", "p99", "all acked", "p99", "startup", "RSS", "PSS", "fds"
    );
    for f in &r.fanout {
        match (&f.result, &f.error) {
            (Some(x), None) => {
                let mem = f.memory.unwrap_or_default();
                let _ = writeln!(
                    s,
                    "{:>6} {:>10} {:>10} {:>10} {:>10} {:>9} {:>9} {:>9} {:>6}",
                    f.subscribers,
                    fmt_ns(x.last_receive_ns.median),
                    fmt_ns(x.last_receive_ns.p99),
                    fmt_ns(x.all_acked_ns.median),
                    fmt_ns(x.all_acked_ns.p99),
                    format!("{:.0} ms", x.startup_ms),
                    fmt_bytes(mem.rss_kib as f64 * 1024.0),
                    fmt_bytes(mem.pss_kib as f64 * 1024.0),
                    x.publisher_fds,
                );
            }
            (_, e) => {
                let _ = writeln!(
                    s,
                    "{:>6} failed: {}",
                    f.subscribers,
                    e.as_deref().unwrap_or("?")
                );
            }
        }
    }
    let _ = writeln!(
        s,
        "\nloss accounting: publisher sending every {LOSS_INTERVAL_US} us, subscriber spending {LOSS_WORK_US} us per sample"
    );
    let _ = writeln!(
        s,
        "{:<30} {:>7} {:>9} {:>8} {:>9}  settings",
        "mode", "sent", "received", "dropped", "pub time"
    );
    for l in &r.loss {
        if let Some(e) = &l.error {
            let _ = writeln!(s, "{:<30} failed: {e}", l.id);
            continue;
        }
        let _ = writeln!(
            s,
            "{:<30} {:>7} {:>9} {:>8} {:>9}  {}",
            l.id,
            l.sent,
            l.received,
            l.dropped,
            fmt_ns(l.publisher_secs * 1e9),
            l.settings
        );
    }
    let p = &r.path;
    let _ = writeln!(
        s,
        "\nthe runtime's message path ({} B observation out, {} B command back, listener wake-up)",
        p.request_bytes, p.reply_bytes
    );
    if let Some(e) = &p.error {
        let _ = writeln!(s, "failed: {e}");
    } else {
        let _ = writeln!(
            s,
            "raw iceoryx2  median {}  p99 {}\nswarmrt path  median {}  p99 {}  ratio {:.2}",
            fmt_ns(p.raw_rtt_ns.median),
            fmt_ns(p.raw_rtt_ns.p99),
            fmt_ns(p.runtime_rtt_ns.median),
            fmt_ns(p.runtime_rtt_ns.p99),
            p.median_ratio
        );
    }
    s
}

fn ratio(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.2}x")
    } else {
        "-".into()
    }
}

fn plots(r: &IpcReport, dir: &Path) -> anyhow::Result<()> {
    let mut rtt = Vec::new();
    let mut tput = Vec::new();
    for (i, name) in r.transports.iter().enumerate() {
        let rows: Vec<&Row> = r
            .rows
            .iter()
            .filter(|x| &x.transport == name && x.error.is_none())
            .collect();
        rtt.push(Series {
            name: name.clone(),
            points: rows
                .iter()
                .map(|x| (x.payload as f64, x.rtt_ns.median / 1e3))
                .collect(),
            colour: i,
            dashed: false,
        });
        tput.push(Series {
            name: name.clone(),
            points: rows
                .iter()
                .map(|x| (x.payload as f64, x.msgs_per_s))
                .collect(),
            colour: i,
            dashed: false,
        });
    }
    let ok: Vec<&FanoutResult> = r.fanout.iter().filter_map(|f| f.result.as_ref()).collect();
    let fan = vec![
        Series {
            name: "last receive, median".into(),
            points: ok
                .iter()
                .map(|f| (f.subscribers as f64, f.last_receive_ns.median / 1e3))
                .collect(),
            colour: 0,
            dashed: false,
        },
        Series {
            name: "last receive, p99".into(),
            points: ok
                .iter()
                .map(|f| (f.subscribers as f64, f.last_receive_ns.p99 / 1e3))
                .collect(),
            colour: 0,
            dashed: true,
        },
        Series {
            name: "all acked, median".into(),
            points: ok
                .iter()
                .map(|f| (f.subscribers as f64, f.all_acked_ns.median / 1e3))
                .collect(),
            colour: 1,
            dashed: false,
        },
        Series {
            name: "all acked, p99".into(),
            points: ok
                .iter()
                .map(|f| (f.subscribers as f64, f.all_acked_ns.p99 / 1e3))
                .collect(),
            colour: 1,
            dashed: true,
        },
    ];
    let panels = vec![
        Panel {
            title: "round trip, median".into(),
            x_desc: "payload (bytes)".into(),
            y_desc: "microseconds".into(),
            series: rtt,
            legend: Legend::UpperLeft,
        },
        Panel {
            title: "one-way throughput".into(),
            x_desc: "payload (bytes)".into(),
            y_desc: "messages per second".into(),
            series: tput,
            legend: Legend::LowerLeft,
        },
        Panel {
            title: "fan-out: one sample to K processes".into(),
            x_desc: "subscriber processes K".into(),
            y_desc: "microseconds".into(),
            series: fan,
            legend: Legend::UpperLeft,
        },
    ];
    let title = format!(
        "swarm bench ipc: {} cpus, {}",
        r.machine["nproc"],
        r.machine["cpu"].as_str().unwrap_or("")
    );
    write_figure(dir, "ipc", &title, &panels)
}
