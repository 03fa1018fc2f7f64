//! Percentiles of latency samples.

use serde::{Deserialize, Serialize};

/// Summary of a set of samples (the unit is the caller's, usually nanoseconds).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    /// Number of samples.
    pub samples: usize,
    /// Median (nearest rank).
    pub median: f64,
    /// 99th percentile (nearest rank).
    pub p99: f64,
    /// 99.9th percentile (nearest rank).
    pub p999: f64,
    /// Arithmetic mean.
    pub mean: f64,
    /// Smallest sample.
    pub min: f64,
    /// Largest sample.
    pub max: f64,
}

/// Nearest-rank percentile `q` in [0, 1] of sorted `v` (`NaN` when empty).
pub fn percentile(sorted: &[u64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let rank = (q * sorted.len() as f64).ceil() as usize;
    sorted[rank.clamp(1, sorted.len()) - 1] as f64
}

/// Sorts `v` and summarizes it.
pub fn summarize(v: &mut [u64]) -> Summary {
    v.sort_unstable();
    if v.is_empty() {
        return Summary {
            median: f64::NAN,
            p99: f64::NAN,
            p999: f64::NAN,
            mean: f64::NAN,
            min: f64::NAN,
            max: f64::NAN,
            ..Summary::default()
        };
    }
    let sum: f64 = v.iter().map(|&x| x as f64).sum();
    Summary {
        samples: v.len(),
        median: percentile(v, 0.5),
        p99: percentile(v, 0.99),
        p999: percentile(v, 0.999),
        mean: sum / v.len() as f64,
        min: v[0] as f64,
        max: v[v.len() - 1] as f64,
    }
}

/// Median of `v` (mean of the middle two for an even count; `NaN` when empty).
pub fn median(v: &[f64]) -> f64 {
    let mut v = v.to_vec();
    v.sort_unstable_by(f64::total_cmp);
    match v.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => v[n / 2],
        n => (v[n / 2 - 1] + v[n / 2]) / 2.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_rank_percentiles() {
        let mut v: Vec<u64> = (1..=1000).rev().collect();
        let s = summarize(&mut v);
        assert_eq!(s.samples, 1000);
        assert_eq!(s.median, 500.0);
        assert_eq!(s.p99, 990.0);
        assert_eq!(s.p999, 999.0);
        assert_eq!(s.min, 1.0);
        assert_eq!(s.max, 1000.0);
        assert_eq!(percentile(&[7], 0.999), 7.0);
        assert!(summarize(&mut []).median.is_nan());
    }
}
