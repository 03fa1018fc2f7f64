//! Formation metrics (seed 000): how well the formation held, loops, epsilon flips.

use serde_json::{Value, json};
use swarmrt_protocol::records::Records;
use swarmrt_scenario::Config;

use super::{FormationNote, offsets};
use crate::consensus::behaviour_notes;

/// A loop: the virtual leader comes back within this distance of where it was (metres) ...
pub const LOOP_RADIUS: f64 = 1.0;
/// ... after travelling at least this many times that distance in between.
pub const LOOP_PATH: f64 = 4.0;

/// The metrics [`metrics`] computes.
pub const NAMES: [&str; 4] = [
    "formation_error_rms",
    "loops_detected",
    "loop_ticks",
    "epsilon_flips",
];

/// `formation_error_rms`, `loops_detected`, `loop_ticks`, `epsilon_flips`.
pub fn metrics(cfg: &Config, rec: &Records) -> Vec<(&'static str, Value)> {
    let offsets = offsets(cfg);
    let mut sq = 0.0;
    let mut samples = 0u64;
    let mut leader_path = Vec::with_capacity(rec.ticks.len());
    for rows in &rec.ticks {
        let active: Vec<_> = rows.iter().filter(|r| r.active).collect();
        if active.is_empty() {
            continue;
        }
        let off = |id: u32| offsets.get(id as usize).copied().unwrap_or((0.0, 0.0));
        // The true virtual leader of the robots still in the game (eq. 2-3).
        let n = active.len() as f64;
        let lx = active.iter().map(|r| r.x - off(r.id).0).sum::<f64>() / n;
        let ly = active.iter().map(|r| r.y - off(r.id).1).sum::<f64>() / n;
        for r in &active {
            let o = off(r.id);
            let (ex, ey) = (r.x - o.0 - lx, r.y - o.1 - ly);
            sq += ex * ex + ey * ey;
            samples += 1;
        }
        leader_path.push((lx, ly));
    }
    let (loops, loop_ticks) = loops(&leader_path);
    let rms = if samples > 0 {
        (sq / samples as f64).sqrt()
    } else {
        0.0
    };
    vec![
        ("formation_error_rms", json!(rms)),
        ("loops_detected", json!(loops)),
        ("loop_ticks", json!(loop_ticks)),
        (
            "epsilon_flips",
            json!(
                behaviour_notes::<FormationNote>(rec)
                    .filter(|(_, _, n)| *n == FormationNote::EpsilonFlip)
                    .count()
            ),
        ),
    ]
}

/// Loops in a path, detected as revisited states (seed 000, section 5.3: a trajectory that
/// begins and ends at the same position): a point within [`LOOP_RADIUS`] of an earlier point
/// from which the path has since travelled more than [`LOOP_PATH`] x that radius. Returns the
/// number of revisiting episodes and the ticks spent revisiting.
pub fn loops(path: &[(f64, f64)]) -> (u64, u64) {
    use std::collections::HashMap;
    let cell = |p: (f64, f64)| {
        (
            (p.0 / LOOP_RADIUS).floor() as i64,
            (p.1 / LOOP_RADIUS).floor() as i64,
        )
    };
    /// Arc length at a visit, and the point.
    type Visit = (f64, (f64, f64));
    // Cell -> visits; only lookups, so HashMap order never shows.
    let mut seen: HashMap<(i64, i64), Vec<Visit>> = HashMap::new();
    let (mut s, mut episodes, mut ticks, mut inside) = (0.0, 0u64, 0u64, false);
    let mut last: Option<(f64, f64)> = None;
    for &p in path {
        if let Some(q) = last {
            s += (p.0 - q.0).hypot(p.1 - q.1);
        }
        last = Some(p);
        let (cx, cy) = cell(p);
        let revisit = (-1..=1).any(|dx| {
            (-1..=1).any(|dy| {
                seen.get(&(cx + dx, cy + dy)).is_some_and(|v| {
                    v.iter().any(|&(su, u)| {
                        s - su > LOOP_PATH * LOOP_RADIUS
                            && (p.0 - u.0).hypot(p.1 - u.1) < LOOP_RADIUS
                    })
                })
            })
        });
        if revisit {
            ticks += 1;
            if !inside {
                episodes += 1;
            }
        }
        inside = revisit;
        let v = seen.entry((cx, cy)).or_default();
        // Keep one sample per 0.25 m of arc per cell: bounds the work on long runs.
        if v.last().is_none_or(|&(su, _)| s - su > 0.25 * LOOP_RADIUS) {
            v.push((s, p));
        }
    }
    (episodes, ticks)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_straight_path_has_no_loop_and_a_circle_twice_has_one() {
        let straight: Vec<_> = (0..1000).map(|i| (i as f64 * 0.05, 0.0)).collect();
        assert_eq!(loops(&straight), (0, 0));
        let circle: Vec<_> = (0..2000)
            .map(|i| {
                let a = i as f64 * 0.01;
                (3.0 * a.cos(), 3.0 * a.sin())
            })
            .collect();
        let (episodes, ticks) = loops(&circle);
        assert_eq!(episodes, 1, "second lap revisits the first");
        assert!(
            ticks > 1000 - 700,
            "most of the second lap revisits: {ticks}"
        );
    }

    #[test]
    fn standing_still_is_not_a_loop() {
        let park = vec![(1.0, 1.0); 500];
        assert_eq!(loops(&park), (0, 0));
    }
}
