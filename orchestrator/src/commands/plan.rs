//! `swarm plan`: the routes of a `planner` scenario (seed 002), planned without flying them:
//! every vehicle from its start to its goal, one after another, with the cells it holds and
//! when, the cost, the expansions and the planning time.

use std::time::Instant;

use serde_json::json;
use swarmrt_agent::behaviours::planner::{PlannerParams, metrics, scene};
use swarmrt_scenario::ConfigError;

use crate::cli::PlanArgs;
use crate::config::load_config;
use crate::error::{SwarmError, SwarmResult};

/// Plans and prints (a table, or JSON with `--json`).
pub fn plan(args: &PlanArgs) -> SwarmResult<()> {
    let cfg = load_config(&args.config, &args.set)?;
    if cfg.behaviour.kind != "planner" {
        return Err(SwarmError::User(format!(
            "{}: key `behaviour.kind`: expected \"planner\" (swarm plan plans UAV routes), got \"{}\"",
            args.config.display(),
            cfg.behaviour.kind
        )));
    }
    let params = PlannerParams::of(&cfg).map_err(|(key, message)| {
        ConfigError::new(&args.config.display().to_string(), key, message)
    })?;
    let t0 = Instant::now();
    let planned = scene::plan_scenario(&cfg, &params)
        .map_err(|e| SwarmError::User(format!("{}: {e}", args.config.display())))?;
    // The first plan, grid and buffers built cold, then the search alone, best of five.
    let cold_ms = t0.elapsed().as_secs_f64() * 1e3;
    let (per_route, total_ms) = metrics::plan_ms(&cfg, &params);
    let total_ms = total_ms.unwrap_or(cold_ms);
    let slot = params.slot();
    let routes: Vec<serde_json::Value> = planned
        .iter()
        .map(|p| match &p.route {
            Ok(r) => json!({
                "vehicle": p.vehicle,
                "start": [p.start.i, p.start.j, p.start.k],
                "goal": [p.goal.i, p.goal.j, p.goal.k],
                "cost": r.cost,
                "expansions": r.expansions,
                "cells": r.cells.iter().enumerate().map(|(k, c)| json!({
                    "cell": [c.i, c.j, c.k],
                    "t": (r.start_slot as usize + k) as f64 * slot,
                })).collect::<Vec<_>>(),
            }),
            Err(e) => json!({"vehicle": p.vehicle, "error": e.to_string()}),
        })
        .collect();
    let conflicts = scene::conflicts(&cfg, &params, &planned);
    if args.json {
        let out = json!({
            "scenario": cfg.scenario.name,
            "slot_s": slot,
            "plan_ms": {"total": total_ms, "per_route": per_route, "cold": cold_ms},
            "conflicts": conflicts,
            "routes": routes,
        });
        println!(
            "{}",
            serde_json::to_string_pretty(&out).expect("JSON always renders")
        );
        return Ok(());
    }
    println!(
        "{}: {} vehicles, d = {} m, slot = {} s, a = {}, b = {}, delta = {} s, epsilon = {}",
        cfg.scenario.name,
        planned.len(),
        params.cell,
        slot,
        params.a,
        params.b,
        params.delta,
        params.epsilon
    );
    for p in &planned {
        match &p.route {
            Ok(r) => {
                println!(
                    "vehicle {}: {} moves, cost {:.3}, {} expansions",
                    p.vehicle,
                    r.cells.len().saturating_sub(1),
                    r.cost,
                    r.expansions
                );
                let cells: Vec<String> = r
                    .cells
                    .iter()
                    .enumerate()
                    .map(|(k, c)| {
                        let t = (r.start_slot as usize + k) as f64 * slot;
                        format!("({},{},{})@{t:.0}s", c.i, c.j, c.k)
                    })
                    .collect();
                println!("  {}", cells.join(" "));
            }
            Err(e) => println!("vehicle {}: no route: {e}", p.vehicle),
        }
    }
    let per: Vec<String> = per_route.iter().map(|ms| format!("{ms:.3}")).collect();
    println!(
        "conflicts: {conflicts}; planning time: {total_ms:.3} ms (per route {} ms; wall clock, \
         best of 5; {cold_ms:.3} ms the first time, grid included)",
        per.join(", ")
    );
    Ok(())
}
