//! `swarm fuzz`: seeded fault fuzzing of the consensus cores, and two seeded measurements
//! (election times, quadrant leader uniqueness) on the same in-process harness.

use std::io::IsTerminal;
use std::time::Instant;

use crossbeam_channel::Receiver;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use crate::cli::{ConsensusArgs, ElectionArgs, FuzzCmd, QuadrantArgs};
use crate::error::{SwarmError, SwarmResult};
#[cfg(feature = "mutants")]
use swarmrt_agent::consensus::raft::{Mutant, set_mutant};
use swarmrt_harness::fuzz::{consensus, election, quadrant};

fn progress(total: u64) -> ProgressBar {
    let pb = ProgressBar::with_draw_target(
        Some(total),
        if std::io::stderr().is_terminal() {
            ProgressDrawTarget::stderr()
        } else {
            ProgressDrawTarget::hidden()
        },
    );
    pb.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len}  {per_sec}  {elapsed_precise}")
            .expect("valid template"),
    );
    pb
}

fn user(msg: String) -> SwarmError {
    SwarmError::User(msg)
}

fn check_loss(key: &str, p: f64) -> SwarmResult<()> {
    if p.is_finite() && (0.0..=1.0).contains(&p) {
        Ok(())
    } else {
        Err(user(format!("{key}: expected a number in [0, 1], got {p}")))
    }
}

/// Runs a fuzzer or measurement.
pub fn fuzz(cmd: &FuzzCmd, interrupt: Receiver<()>) -> SwarmResult<()> {
    match cmd {
        FuzzCmd::Consensus(a) => fuzz_consensus(a, &interrupt),
        FuzzCmd::Election(a) => fuzz_election(a, &interrupt),
        FuzzCmd::Quadrant(a) => fuzz_quadrant(a, &interrupt),
    }
}

/// Ctrl-C (or SIGTERM) between seeds: stop there, report what ran, exit 130.
fn interrupted(interrupt: &Receiver<()>) -> bool {
    interrupt.try_recv().is_ok()
}

fn stopped() -> SwarmError {
    SwarmError::Interrupted("interrupted: stopped between seeds".into())
}

/// Selects the Raft core's known bug `name` for this thread's cores; only this thread runs
/// them, so the mutant reaches them all and nothing else.
#[cfg(feature = "mutants")]
fn select_mutant(name: Option<&str>) -> SwarmResult<()> {
    let mutant = match name {
        None => None,
        Some(name) => Some(Mutant::parse(name).ok_or_else(|| {
            let names: Vec<&str> = Mutant::ALL.iter().map(|(n, _)| *n).collect();
            user(format!(
                "--mutant {name}: expected one of {}",
                names.join(", ")
            ))
        })?),
    };
    set_mutant(mutant);
    Ok(())
}

/// Without the `mutants` feature the Raft core has no known bugs to select: they are test
/// code, kept out of the release robot (`swarm-agent`) and `swarm`.
#[cfg(not(feature = "mutants"))]
fn select_mutant(name: Option<&str>) -> SwarmResult<()> {
    match name {
        None => Ok(()),
        Some(name) => Err(user(format!(
            "--mutant {name}: this swarm was built without the Raft core's known bugs; \
             build one with them: cargo build --release --features swarmrt-orchestrator/mutants"
        ))),
    }
}

fn fuzz_consensus(a: &ConsensusArgs, interrupt: &Receiver<()>) -> SwarmResult<()> {
    if a.seeds == 0 {
        return Err(user("--seeds: expected at least 1, got 0".into()));
    }
    let end = a.start_seed.checked_add(a.seeds).ok_or_else(|| {
        user(format!(
            "--start-seed {} + --seeds {} overflows a 64-bit seed",
            a.start_seed, a.seeds
        ))
    })?;
    // Checked once and written through its handle, as a run directory is.
    let dump = match &a.dump {
        Some(d) => Some(crate::run_dir::open_out("--dump", d)?),
        None => None,
    };
    select_mutant(a.mutant.as_deref())?;
    let started = Instant::now();
    let pb = progress(a.seeds);
    let mut failed: Vec<u64> = Vec::new();
    let mut ticks = 0u64;
    let mut recovered: Vec<u64> = Vec::new();
    let (mut left_for_notes, mut unsent) = (0u64, 0u64);
    let mut ran = 0u64;
    let mut stop = false;
    for seed in a.start_seed..end {
        if interrupted(interrupt) {
            stop = true;
            break;
        }
        ran += 1;
        let case = consensus::draw(seed);
        let out = consensus::run(&case, a.dump.is_some());
        ticks += out.ticks;
        left_for_notes += out.budget.0;
        unsent += out.budget.1;
        if let Some(r) = out.recovered_after {
            recovered.push(r);
        }
        if a.verbose {
            pb.suspend(|| {
                println!(
                    "seed {seed}: {} ({case}; {} ticks{})",
                    if out.failures.is_empty() {
                        "ok"
                    } else {
                        "FAIL"
                    },
                    out.ticks,
                    out.recovered_after
                        .map(|r| format!(", recovered {r} ticks after the heal"))
                        .unwrap_or_default()
                )
            });
        }
        if !out.failures.is_empty() {
            failed.push(seed);
            pb.suspend(|| {
                println!("seed {seed}: FAIL ({case})");
                for f in &out.failures {
                    println!("  {f}");
                }
                let m = a
                    .mutant
                    .as_ref()
                    .map(|m| format!(" --mutant {m}"))
                    .unwrap_or_default();
                println!(
                    "  reproduce: swarm fuzz consensus --seeds 1 --start-seed {seed}{m} --verbose"
                );
            });
            // The seed replays to the same notes: record them and show the last ones.
            let rec = if out.events.is_some() {
                out.clone()
            } else {
                consensus::run(&case, true)
            };
            if let Some(ev) = &rec.events {
                let t = consensus::timeline(ev, 30);
                pb.suspend(|| {
                    println!("  last notes before the violation (tick robot: note):");
                    for l in &t {
                        println!("    {l}");
                    }
                });
            }
            if let (Some(dir), Some(ev)) = (&dump, &out.events) {
                let name = format!("seed-{seed}.events.jsonl");
                let p = dir.join(&name);
                dir.write(&name, ev)?;
                pb.suspend(|| println!("  notes: {}", p.display()));
            }
        }
        pb.inc(1);
    }
    pb.finish_and_clear();
    let secs = started.elapsed().as_secs_f64();
    let mut rec = recovered.clone();
    println!(
        "{} seeds ({}..{}), {} failed; {:.1} seeds/s, {:.0} ticks/s; median recovery after heal {} ticks",
        ran,
        a.start_seed,
        (a.start_seed + ran).saturating_sub(1),
        failed.len(),
        ran as f64 / secs.max(1e-9),
        ticks as f64 / secs.max(1e-9),
        election::median(&mut rec).map_or("-".to_string(), |m| m.to_string())
    );
    println!(
        "messages left unprocessed for lack of note room: {left_for_notes}; dropped for lack of free frames: {unsent}"
    );
    if !failed.is_empty() {
        Err(SwarmError::Internal(anyhow::anyhow!(
            "{} of {} seeds failed: {:?}",
            failed.len(),
            ran,
            failed
        )))
    } else if stop {
        Err(stopped())
    } else {
        Ok(())
    }
}

fn fuzz_election(a: &ElectionArgs, interrupt: &Receiver<()>) -> SwarmResult<()> {
    if a.runs == 0 {
        return Err(user("--runs: expected at least 1, got 0".into()));
    }
    for &n in &a.robots {
        if !(1..=10_000).contains(&n) {
            return Err(user(format!("--robots: expected 1..=10000, got {n}")));
        }
    }
    for &p in &a.loss {
        check_loss("--loss", p)?;
    }
    let end = a
        .start_seed
        .checked_add(a.runs)
        .ok_or_else(|| user("--start-seed + --runs overflows a 64-bit seed".into()))?;
    let pb = progress(a.robots.len() as u64 * a.loss.len() as u64 * a.runs);
    let started = Instant::now();
    let mut lines = Vec::new();
    for &n in &a.robots {
        for &loss in &a.loss {
            let (mut first, mut re) = (Vec::new(), Vec::new());
            for seed in a.start_seed..end {
                if interrupted(interrupt) {
                    pb.finish_and_clear();
                    return Err(stopped());
                }
                let r = election::measure(n, loss, seed, a.leader_wait);
                first.extend(r.first_leader);
                re.extend(r.reelection);
                pb.inc(1);
            }
            let span = |v: &mut Vec<u64>| match election::median(v) {
                Some(m) => format!(
                    "{m:>5} [{}..{}] ({}/{})",
                    v[0],
                    v[v.len() - 1],
                    v.len(),
                    a.runs
                ),
                None => format!("    - (0/{})", a.runs),
            };
            lines.push(format!(
                "{n:>6} {:>5.0}%   {}   {}",
                loss * 100.0,
                span(&mut first),
                span(&mut re)
            ));
        }
    }
    pb.finish_and_clear();
    println!(
        "robots  loss   first leader: median [min..max] (runs with one)   re-election after the leader's crash"
    );
    for l in lines {
        println!("{l}");
    }
    println!(
        "(ticks; seeds {}..{}; delay 2, capacity 4, election timeout 20..40, heartbeat 4; {:.1} s)",
        a.start_seed,
        end - 1,
        started.elapsed().as_secs_f64()
    );
    Ok(())
}

fn fuzz_quadrant(a: &QuadrantArgs, interrupt: &Receiver<()>) -> SwarmResult<()> {
    if a.trials == 0 {
        return Err(user("--trials: expected at least 1, got 0".into()));
    }
    check_loss("--loss", a.loss)?;
    if !(a.area_per_robot.is_finite() && a.area_per_robot > 0.0 && a.area_per_robot <= 1e4) {
        return Err(user(format!(
            "--area-per-robot: expected a number in (0, 10000], got {}",
            a.area_per_robot
        )));
    }
    let end = a
        .start_seed
        .checked_add(a.trials)
        .ok_or_else(|| user("--start-seed + --trials overflows a 64-bit seed".into()))?;
    let pb = progress(7 * a.trials);
    let mut lines = Vec::new();
    for n in 3..=9u32 {
        let (mut one, mut all_see, mut unique, mut agree, mut leaders) = (0, 0, 0, 0, 0);
        let (mut connected, mut one_connected) = (0, 0);
        for seed in a.start_seed..end {
            if interrupted(interrupt) {
                pb.finish_and_clear();
                return Err(stopped());
            }
            let t = quadrant::trial(n, a.loss, a.area_per_robot, seed);
            one += (t.leaders == 1) as u64;
            all_see += t.all_see_all as u64;
            unique += t.unique_top as u64;
            agree += t.agree as u64;
            leaders += t.leaders as u64;
            connected += t.connected as u64;
            one_connected += (t.connected && t.leaders == 1) as u64;
            pb.inc(1);
        }
        let pct = |k: u64| 100.0 * k as f64 / a.trials as f64;
        let of_connected = if connected > 0 {
            format!("{:>6.1}%", 100.0 * one_connected as f64 / connected as f64)
        } else {
            "     -".to_string()
        };
        lines.push(format!(
            "{n:>5}   {:>6.1}%     {:>6.1}%     {:>6.2}      {:>6.1}%      {:>6.1}%     {:>6.1}%    {of_connected}",
            pct(one),
            pct(agree),
            leaders as f64 / a.trials as f64,
            pct(unique),
            pct(all_see),
            pct(connected),
        ));
    }
    pb.finish_and_clear();
    println!(
        "group  one leader  all agree  leaders/group  unique top score  all see all  connected  one leader if connected"
    );
    for l in lines {
        println!("{l}");
    }
    println!(
        "({} trials per size, loss {}, {} m2 per robot, sensing range {} m)",
        a.trials,
        a.loss,
        a.area_per_robot,
        quadrant::SENSE_RANGE
    );
    Ok(())
}
