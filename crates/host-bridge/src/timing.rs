//! Durations in a fixed histogram: the bridge's service times (its summary and
//! status line) and the benchmark's round trips, in memory that does not grow
//! with the number of samples however long a bridge runs.
//!
//! The histogram is `hdrhistogram`'s (HdrHistogram, Gil Tene's
//! high-dynamic-range histogram) over nanoseconds from 1 ns to
//! [`LatencyHistogram::HIGHEST_NS`], with [`LatencyHistogram::SIGNIFICANT_DIGITS`]
//! significant decimal digits: every value is counted in a bucket no wider than
//! 1/1024 of its lower bound, so a reported percentile is the nearest-rank
//! percentile of the recorded values to within 0.1 % (never below it, it is the
//! bucket's highest value). The largest value is kept exactly beside it.

use std::time::Duration;

use hdrhistogram::Histogram;
use serde::Serialize;

/// Percentiles of a set of durations, us.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Percentiles {
    /// Median.
    pub p50: f64,
    /// 99th percentile.
    pub p99: f64,
    /// 99.9th percentile.
    pub p999: f64,
    /// Largest.
    pub max: f64,
}

impl Percentiles {
    /// The percentiles of `values` (nearest rank); zeros when empty.
    pub fn of(values: &mut [f64]) -> Self {
        if values.is_empty() {
            return Percentiles::default();
        }
        values.sort_by(f64::total_cmp);
        let rank = |p: f64| {
            let i = ((p * values.len() as f64).ceil() as usize).clamp(1, values.len());
            values[i - 1]
        };
        Percentiles {
            p50: rank(0.50),
            p99: rank(0.99),
            p999: rank(0.999),
            max: values[values.len() - 1],
        }
    }
}

/// Durations recorded in a fixed histogram (see the module's documentation).
#[derive(Clone, Debug)]
pub struct LatencyHistogram {
    histogram: Histogram<u64>,
    /// The largest value recorded, exactly, ns.
    max_ns: u64,
}

impl Default for LatencyHistogram {
    fn default() -> Self {
        Self::new()
    }
}

impl LatencyHistogram {
    /// Significant decimal digits kept: a percentile within 0.1 %.
    pub const SIGNIFICANT_DIGITS: u8 = 3;
    /// The largest duration told apart, ns (one hour); longer ones are counted
    /// as this (the exact maximum is still reported).
    pub const HIGHEST_NS: u64 = 3_600_000_000_000;
    /// The relative precision of a reported percentile (0.1 %).
    pub const RELATIVE_PRECISION: f64 = 1e-3;

    /// An empty histogram; its counts are allocated here, once.
    pub fn new() -> Self {
        LatencyHistogram {
            // Valid bounds (1 <= 2 * 1 <= HIGHEST_NS, digits <= 5): cannot fail.
            histogram: Histogram::new_with_bounds(1, Self::HIGHEST_NS, Self::SIGNIFICANT_DIGITS)
                .unwrap_or_else(|e| unreachable!("fixed histogram bounds: {e}")),
            max_ns: 0,
        }
    }

    /// Counts one duration.
    pub fn record(&mut self, duration: Duration) {
        let ns = u64::try_from(duration.as_nanos()).unwrap_or(u64::MAX);
        self.record_ns(ns);
    }

    /// Counts one duration given in microseconds (negative or NaN counts as 0).
    pub fn record_us(&mut self, us: f64) {
        // `as` saturates: NaN and negatives to 0, beyond u64 to u64::MAX.
        self.record_ns((us * 1e3).round() as u64);
    }

    fn record_ns(&mut self, ns: u64) {
        // Clamped into [1 ns, HIGHEST_NS]: recording never fails or allocates.
        self.histogram.saturating_record(ns);
        self.max_ns = self.max_ns.max(ns);
    }

    /// How many durations were recorded.
    pub fn len(&self) -> u64 {
        self.histogram.len()
    }

    /// Whether none was recorded.
    pub fn is_empty(&self) -> bool {
        self.histogram.is_empty()
    }

    /// Forgets every recorded duration (the memory stays allocated).
    pub fn clear(&mut self) {
        self.histogram.reset();
        self.max_ns = 0;
    }

    /// p50, p99, p99.9 (nearest rank, within [`Self::RELATIVE_PRECISION`]) and
    /// the exact maximum, us; zeros when empty.
    pub fn percentiles(&self) -> Percentiles {
        if self.histogram.is_empty() {
            return Percentiles::default();
        }
        // A bucket's highest value can pass the largest value recorded: the
        // percentiles never exceed the exact maximum.
        let at = |q: f64| self.histogram.value_at_quantile(q).min(self.max_ns) as f64 / 1e3;
        Percentiles {
            p50: at(0.50),
            p99: at(0.99),
            p999: at(0.999),
            max: self.max_ns as f64 / 1e3,
        }
    }

    /// Bytes of the histogram's counts: fixed when it is made, whatever is
    /// recorded.
    pub fn heap_bytes(&self) -> usize {
        self.histogram.distinct_values() * std::mem::size_of::<u64>()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percentiles_by_nearest_rank() {
        let mut v: Vec<f64> = (1..=1000).map(f64::from).collect();
        let p = Percentiles::of(&mut v);
        assert_eq!((p.p50, p.p99, p.p999, p.max), (500.0, 990.0, 999.0, 1000.0));
        assert_eq!(Percentiles::of(&mut []), Percentiles::default());
    }

    /// The nearest-rank percentiles of `values` (the exact reference).
    fn exact(values: &[f64]) -> Percentiles {
        let mut v = values.to_vec();
        Percentiles::of(&mut v)
    }

    fn assert_within_precision(got: f64, exact: f64, what: &str) {
        assert!(
            got >= exact * (1.0 - 1e-12)
                && got <= exact * (1.0 + LatencyHistogram::RELATIVE_PRECISION) + 1e-3,
            "{what}: {got} against {exact}"
        );
    }

    #[test]
    fn percentiles_of_known_inputs_within_the_documented_precision() {
        // 1 to 1000 us in 1 us steps: nearest rank 500, 990, 999, 1000.
        let mut h = LatencyHistogram::new();
        for us in 1..=1000 {
            h.record(Duration::from_micros(us));
        }
        let p = h.percentiles();
        assert_within_precision(p.p50, 500.0, "p50");
        assert_within_precision(p.p99, 990.0, "p99");
        assert_within_precision(p.p999, 999.0, "p99.9");
        assert_eq!(p.max, 1000.0, "the maximum is exact");
        assert_eq!(h.len(), 1000);

        // Six decades with a long tail (100 ns to 100 ms, log-spaced, not
        // round numbers), against the nearest rank of the values themselves.
        let mut h = LatencyHistogram::new();
        let values: Vec<f64> = (0..20_000)
            .map(|i| 0.1 * 10f64.powf(6.0 * f64::from(i) / 20_000.0) * 1.000_37)
            .collect();
        for &us in &values {
            h.record_us(us);
        }
        let (p, e) = (h.percentiles(), exact(&values));
        // The histogram counts whole nanoseconds.
        let ns = |us: f64| (us * 1e3).round() / 1e3;
        assert_within_precision(p.p50, ns(e.p50), "p50");
        assert_within_precision(p.p99, ns(e.p99), "p99");
        assert_within_precision(p.p999, ns(e.p999), "p99.9");
        assert_eq!(p.max, ns(e.max));

        assert_eq!(
            LatencyHistogram::new().percentiles(),
            Percentiles::default()
        );
        h.clear();
        assert!(h.is_empty());
        assert_eq!(h.percentiles(), Percentiles::default());
    }

    #[test]
    fn memory_does_not_grow_with_the_samples() {
        let mut h = LatencyHistogram::new();
        let empty = h.heap_bytes();
        for i in 0..10u64 {
            h.record(Duration::from_micros(20 + i));
        }
        let after_10 = h.heap_bytes();
        for i in 0..1_000_000u64 {
            // Every magnitude, the huge ones (clamped) included.
            h.record(Duration::from_nanos(1 + i * i * 7919));
        }
        // Above everything before it (up to 7.9e15 ns) and the histogram's range.
        h.record(Duration::from_secs(10_000_000));
        assert_eq!(h.len(), 1_000_011);
        assert_eq!((empty, after_10), (h.heap_bytes(), h.heap_bytes()));
        // Counts in the order of a few hundred kB, fixed.
        assert!(h.heap_bytes() < 512 * 1024, "{}", h.heap_bytes());
        assert_eq!(h.percentiles().max, 10_000_000e6, "the exact maximum");
    }
}
