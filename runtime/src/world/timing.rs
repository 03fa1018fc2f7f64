//! Wall-clock cost of the lock-step ticks, for `metrics.json` (`shell.timing`) and
//! `swarm bench swarm`. Never part of the replayable records.
//!
//! Tick durations go into a log-bucketed histogram (1 % wide buckets), so memory stays
//! constant however long a run is, and percentiles are exact to within 1 %.

use std::time::Instant;

use serde::Serialize;

use swarmrt_world::{Stage, StageTimes};

/// Bucket width: each bucket spans a factor of this.
const GROWTH: f64 = 1.01;
/// Buckets cover 1 ns .. ~10 s.
const BUCKETS: usize = 2400;

/// Where the time of one tick went, in nanoseconds.
#[derive(Debug, Clone, Copy, Default)]
pub struct TickPhases {
    /// `World::observe`.
    pub observe: u64,
    /// Loan, copy, send and notify the observation sample.
    pub publish: u64,
    /// From the notify until every live robot's command was drained.
    pub wait: u64,
    /// `World::step` and draining its events.
    pub step: u64,
    /// Writing the tick's records.
    pub record: u64,
    /// CPU time of the world's thread within `publish` ([`thread_cpu_ns`]): the rest of
    /// `publish` is the world waiting for its core behind the robots it has just woken.
    pub publish_cpu: u64,
    /// The world's stages within `observe` and `step` (not added to the total again).
    pub stages: StageTimes,
}

impl TickPhases {
    /// The whole tick.
    pub fn total(&self) -> u64 {
        self.observe + self.publish + self.wait + self.step + self.record
    }
}

/// CPU time the calling thread has used, ns (`CLOCK_THREAD_CPUTIME_ID`).
pub fn thread_cpu_ns() -> u64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: clock_gettime only writes the struct we pass.
    unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64
}

/// Accumulates [`TickPhases`].
#[derive(Debug, Clone)]
pub struct TickTimer {
    hist: Vec<u64>,
    ticks: u64,
    sums: [u128; 5],
    publish_cpu_sum: u128,
    stage_sums: [u128; Stage::ALL.len()],
    max: u64,
}

impl Default for TickTimer {
    fn default() -> Self {
        TickTimer {
            hist: vec![0; BUCKETS],
            ticks: 0,
            sums: [0; 5],
            publish_cpu_sum: 0,
            stage_sums: [0; Stage::ALL.len()],
            max: 0,
        }
    }
}

fn bucket(ns: u64) -> usize {
    if ns <= 1 {
        return 0;
    }
    ((ns as f64).ln() / GROWTH.ln()) as usize
}

/// Upper edge of bucket `b` in ns.
fn upper(b: usize) -> f64 {
    GROWTH.powi(b as i32 + 1)
}

/// Summary of the ticks timed so far (milliseconds).
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct TickTiming {
    /// Ticks timed.
    pub ticks: u64,
    /// Sum of the tick durations, seconds (ticks / this = ticks per second while ticking).
    pub seconds: f64,
    /// Median tick, ms (to within 1 %).
    pub tick_ms_median: f64,
    /// 99th percentile tick, ms (to within 1 %).
    pub tick_ms_p99: f64,
    /// Longest tick, ms.
    pub tick_ms_max: f64,
    /// Mean ms per tick in `World::observe`.
    pub observe_ms_mean: f64,
    /// Mean ms per tick publishing the observations.
    pub publish_ms_mean: f64,
    /// Mean ms per tick of the world's own CPU in publishing (part of `publish_ms_mean`).
    #[serde(default)]
    pub publish_cpu_ms_mean: f64,
    /// Mean ms per tick waiting for the robots' commands.
    pub wait_ms_mean: f64,
    /// Mean ms per tick in `World::step`.
    pub step_ms_mean: f64,
    /// Mean ms per tick writing records.
    pub record_ms_mean: f64,
    /// Mean ms per tick of the world's faults stage (part of `step_ms_mean`).
    pub stage_faults_ms_mean: f64,
    /// Mean ms per tick of the world's commands stage (part of `step_ms_mean`).
    pub stage_commands_ms_mean: f64,
    /// Mean ms per tick of the world's radio stage, routing and delivery (part of
    /// `step_ms_mean`).
    pub stage_radio_ms_mean: f64,
    /// Mean ms per tick of the world's kinematics stage (part of `step_ms_mean`).
    pub stage_kinematics_ms_mean: f64,
    /// Mean ms per tick of the world's contacts stage (part of `step_ms_mean`).
    pub stage_contacts_ms_mean: f64,
    /// Mean ms per tick of the world's sensing stage: the observations (most of
    /// `observe_ms_mean`) and the goal check (part of `step_ms_mean`).
    pub stage_sensing_ms_mean: f64,
}

impl TickTimer {
    /// Adds one tick.
    pub fn add(&mut self, p: TickPhases) {
        let total = p.total();
        let b = bucket(total).min(BUCKETS - 1);
        self.hist[b] += 1;
        self.ticks += 1;
        self.max = self.max.max(total);
        for (s, v) in self
            .sums
            .iter_mut()
            .zip([p.observe, p.publish, p.wait, p.step, p.record])
        {
            *s += v as u128;
        }
        self.publish_cpu_sum += p.publish_cpu as u128;
        for (s, stage) in self.stage_sums.iter_mut().zip(Stage::ALL) {
            *s += p.stages.get(stage).as_nanos();
        }
    }

    /// The tick-duration percentile `q` in ns (bucket upper edge, capped at the maximum).
    pub fn percentile_ns(&self, q: f64) -> f64 {
        if self.ticks == 0 {
            return 0.0;
        }
        let rank = ((q * self.ticks as f64).ceil() as u64).clamp(1, self.ticks);
        let mut seen = 0;
        for (b, &c) in self.hist.iter().enumerate() {
            seen += c;
            if seen >= rank {
                return upper(b).min(self.max as f64);
            }
        }
        self.max as f64
    }

    /// The summary.
    pub fn summary(&self) -> TickTiming {
        let n = self.ticks.max(1) as f64;
        let mean_ms = |i: usize| self.sums[i] as f64 / n / 1e6;
        let stage_ms = |s: Stage| self.stage_sums[s as usize] as f64 / n / 1e6;
        let total: u128 = self.sums.iter().sum();
        TickTiming {
            ticks: self.ticks,
            seconds: total as f64 / 1e9,
            tick_ms_median: self.percentile_ns(0.5) / 1e6,
            tick_ms_p99: self.percentile_ns(0.99) / 1e6,
            tick_ms_max: self.max as f64 / 1e6,
            observe_ms_mean: mean_ms(0),
            publish_ms_mean: mean_ms(1),
            publish_cpu_ms_mean: self.publish_cpu_sum as f64 / n / 1e6,
            wait_ms_mean: mean_ms(2),
            step_ms_mean: mean_ms(3),
            record_ms_mean: mean_ms(4),
            stage_faults_ms_mean: stage_ms(Stage::Faults),
            stage_commands_ms_mean: stage_ms(Stage::Commands),
            stage_radio_ms_mean: stage_ms(Stage::Radio),
            stage_kinematics_ms_mean: stage_ms(Stage::Kinematics),
            stage_contacts_ms_mean: stage_ms(Stage::Contacts),
            stage_sensing_ms_mean: stage_ms(Stage::Sensing),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percentiles_within_one_percent() {
        let mut t = TickTimer::default();
        for ms in 1..=1000u64 {
            t.add(TickPhases {
                wait: ms * 1_000_000,
                ..TickPhases::default()
            });
        }
        let s = t.summary();
        assert_eq!(s.ticks, 1000);
        assert!((s.tick_ms_median - 500.0).abs() <= 5.0, "{s:?}");
        assert!((s.tick_ms_p99 - 990.0).abs() <= 10.0, "{s:?}");
        assert_eq!(s.tick_ms_max, 1000.0);
        assert!((s.wait_ms_mean - 500.5).abs() < 1e-9);
        assert!((s.seconds - 500.5).abs() < 1e-6);
        assert_eq!(TickTimer::default().summary().tick_ms_median, 0.0);
        assert_eq!(s.stage_radio_ms_mean, 0.0, "no stage was timed");
        t.add(TickPhases {
            publish: 3_000_000,
            publish_cpu: 1_001_000,
            ..TickPhases::default()
        });
        let s = t.summary();
        assert!((s.publish_cpu_ms_mean - 0.001).abs() < 1e-12, "{s:?}");
        // The CPU is part of publish, not added to the tick again.
        assert!((s.seconds - 500.503).abs() < 1e-9, "{s:?}");
    }

    #[test]
    fn world_stage_times_become_means_per_tick() {
        use swarmrt_protocol::Observation;
        use swarmrt_scenario::Config;
        let cfg = Config::from_toml_str(
            "timing.toml",
            r#"
                [scenario]
                name = "timing"
                ticks = 10
                [map]
                bounds = [0.0, 0.0, 10.0, 10.0]
                goal = { x = 8.0, y = 8.0, radius = 1.0 }
                [robots]
                count = 2
            "#,
            &[],
        )
        .unwrap();
        let mut world = swarmrt_world::World::new(&cfg, swarmrt_protocol::Vocabulary::ANY).unwrap();
        world.set_stage_timing(true);
        let mut obs = vec![Observation::empty(0, 0); 2];
        let mut timer = TickTimer::default();
        let mut sensing = 0u128;
        for _ in 0..2 {
            world.observe(&mut obs);
            world.step(&[None, None]);
            let stages = world.take_stage_times();
            sensing += stages.get(Stage::Sensing).as_nanos();
            timer.add(TickPhases {
                stages,
                ..TickPhases::default()
            });
        }
        let s = timer.summary();
        assert!(sensing > 0);
        assert_eq!(s.stage_sensing_ms_mean, sensing as f64 / 2.0 / 1e6);
        assert_eq!(s.tick_ms_max, 0.0, "stages are not added to the tick again");
    }
}

/// When the phases of the current tick began, for `shell.timing`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Stamps {
    pub(crate) observe: Instant,
    pub(crate) publish: Instant,
    pub(crate) wait: Instant,
    pub(crate) step: Instant,
    pub(crate) publish_cpu: u64,
}

impl Default for Stamps {
    fn default() -> Stamps {
        let now = Instant::now();
        Stamps {
            observe: now,
            publish: now,
            wait: now,
            step: now,
            publish_cpu: 0,
        }
    }
}
