//! The decoy's aerodynamic coefficient table: CL, CD, Cm against total angle of
//! attack, linearly interpolated, stored in a fixed-size array.

use crate::error::AeroTableError;
use crate::scalar::Real;

/// Rows the table holds.
pub const AERO_TABLE_CAPACITY: usize = 64;

/// Coefficients at one angle.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AeroCoefficients<T: Real> {
    /// Lift coefficient (in the plane of the total angle of attack).
    pub cl: T,
    /// Drag coefficient.
    pub cd: T,
    /// Pitching moment coefficient about the moment reference point, positive nose-up.
    pub cm: T,
}

/// Bins of the lookup index over 0 to pi ([`AeroTable::at`]).
const INDEX_BINS: usize = 32;

/// CL, CD, Cm against total angle of attack (radians internally), 0 to pi.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AeroTable<T: Real> {
    alpha: [T; AERO_TABLE_CAPACITY],
    coefficients: [AeroCoefficients<T>; AERO_TABLE_CAPACITY],
    rows: usize,
    /// For each of [`INDEX_BINS`] equal bins of 0 to pi, the row whose interval
    /// holds the bin's start: where [`AeroTable::at`] starts its search.
    index: [u8; INDEX_BINS],
    /// INDEX_BINS / pi, rad⁻¹.
    bins_per_radian: T,
}

impl<T: Real> AeroTable<T> {
    /// No rows, all zero bits: the table of an unconfigured model
    /// ([`Solver::UNCONFIGURED`](crate::Solver::UNCONFIGURED)), never looked up.
    pub(crate) const EMPTY: Self = AeroTable {
        alpha: [T::ZERO; AERO_TABLE_CAPACITY],
        coefficients: [AeroCoefficients {
            cl: T::ZERO,
            cd: T::ZERO,
            cm: T::ZERO,
        }; AERO_TABLE_CAPACITY],
        rows: 0,
        index: [0; INDEX_BINS],
        bins_per_radian: T::ZERO,
    };

    /// Builds the table from rows `(alpha_deg, cl, cd, cm)`.
    ///
    /// Angles must be finite, strictly increasing, start at 0 and end at 180 degrees.
    pub fn from_degrees(rows: &[[f64; 4]]) -> Result<Self, AeroTableError> {
        if rows.len() < 2 {
            return Err(AeroTableError::TooFewRows);
        }
        if rows.len() > AERO_TABLE_CAPACITY {
            return Err(AeroTableError::TooManyRows {
                rows: rows.len(),
                capacity: AERO_TABLE_CAPACITY,
            });
        }
        let mut table = AeroTable {
            alpha: [T::zero(); AERO_TABLE_CAPACITY],
            coefficients: [AeroCoefficients::default(); AERO_TABLE_CAPACITY],
            rows: rows.len(),
            index: [0; INDEX_BINS],
            bins_per_radian: T::lit(INDEX_BINS as f64 / core::f64::consts::PI),
        };
        for (i, row) in rows.iter().enumerate() {
            if row.iter().any(|v| !v.is_finite()) {
                return Err(AeroTableError::NonFinite { row: i });
            }
            if i > 0 && row[0] <= rows[i - 1][0] {
                return Err(AeroTableError::NotIncreasing { row: i });
            }
            table.alpha[i] = T::lit(row[0].to_radians());
            table.coefficients[i] = AeroCoefficients {
                cl: T::lit(row[1]),
                cd: T::lit(row[2]),
                cm: T::lit(row[3]),
            };
        }
        if rows[0][0].abs() > 1e-9 || (rows[rows.len() - 1][0] - 180.0).abs() > 1e-9 {
            return Err(AeroTableError::DoesNotCover0To180);
        }
        // Any start gives the same interval (the search walks to it); a start
        // near it keeps the walk short.
        for (bin, start) in table.index.iter_mut().enumerate() {
            let from = bin as f64 * core::f64::consts::PI / INDEX_BINS as f64;
            let row = rows
                .iter()
                .rposition(|r| r[0].to_radians() <= from)
                .unwrap_or(0)
                .min(rows.len() - 2);
            *start = row as u8;
        }
        Ok(table)
    }

    /// Number of rows.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Coefficients at total angle of attack `alpha` (radians), linearly
    /// interpolated; clamped to the table's end rows outside 0..pi.
    pub fn at(&self, alpha: T) -> AeroCoefficients<T> {
        // At least two rows, at most the capacity: what `new` accepts, restated
        // for the optimiser (no bounds check below, no panic on the frame path;
        // the empty table of an unconfigured model is never looked up).
        let n = self.rows.clamp(2, AERO_TABLE_CAPACITY);
        if alpha <= self.alpha[0] {
            return self.coefficients[0];
        }
        if alpha >= self.alpha[n - 1] {
            return self.coefficients[n - 1];
        }
        // The interval [lo, lo + 1] with alpha[lo] <= alpha < alpha[lo + 1] (one
        // only: the angles increase strictly), walked to from the bin's start row.
        let bin = (alpha * self.bins_per_radian).truncated_index();
        let mut lo = usize::from(self.index[bin.min(INDEX_BINS - 1)]).min(n - 2);
        while lo > 0 && alpha < self.alpha[lo] {
            lo -= 1;
        }
        while lo + 2 < n && alpha >= self.alpha[lo + 1] {
            lo += 1;
        }
        let hi = lo + 1;
        let s = (alpha - self.alpha[lo]) / (self.alpha[hi] - self.alpha[lo]);
        let a = self.coefficients[lo];
        let b = self.coefficients[hi];
        AeroCoefficients {
            cl: a.cl + s * (b.cl - a.cl),
            cd: a.cd + s * (b.cd - a.cd),
            cm: a.cm + s * (b.cm - a.cm),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The interval of a binary search over the rows (the lookup before the index).
    fn bisected<T: Real>(t: &AeroTable<T>, alpha: T) -> usize {
        let (mut lo, mut hi) = (0usize, t.rows - 1);
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            if t.alpha[mid] <= alpha {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        lo
    }

    fn indexed_lookup_is_the_bisection<T: Real>() {
        // The reference table's angles: 2 deg steps to 40, then 10 deg; and a
        // table with an odd spacing.
        let mut reference: Vec<f64> = (0..=20).map(|i| 2.0 * f64::from(i)).collect();
        reference.extend((5..=18).map(|i| 10.0 * f64::from(i)));
        let odd = [0.0, 0.5, 1.0, 33.0, 33.5, 90.0, 179.0, 180.0];
        for angles in [reference, odd.to_vec()] {
            let rows: Vec<[f64; 4]> = angles
                .iter()
                .map(|&a| [a, (a * 0.1).sin(), 0.3 + a * 1e-3, -(a * 0.05).cos()])
                .collect();
            let t = AeroTable::<T>::from_degrees(&rows).unwrap();
            let n = t.rows;
            let mut probes: Vec<T> = (1..20_000)
                .map(|k| T::lit(core::f64::consts::PI * f64::from(k) / 20_000.0))
                .collect();
            // Every row's angle and its neighbours in T.
            for &a in &t.alpha[1..n - 1] {
                probes.push(a);
                probes.push(a + a * T::eps());
                probes.push(a - a * T::eps());
            }
            for alpha in probes {
                if alpha <= t.alpha[0] || alpha >= t.alpha[n - 1] {
                    continue;
                }
                let lo = bisected(&t, alpha);
                let s = (alpha - t.alpha[lo]) / (t.alpha[lo + 1] - t.alpha[lo]);
                let (a, b) = (t.coefficients[lo], t.coefficients[lo + 1]);
                let expected = AeroCoefficients {
                    cl: a.cl + s * (b.cl - a.cl),
                    cd: a.cd + s * (b.cd - a.cd),
                    cm: a.cm + s * (b.cm - a.cm),
                };
                assert_eq!(t.at(alpha), expected, "alpha {alpha}");
            }
        }
    }

    #[test]
    fn the_indexed_lookup_finds_the_bisections_interval() {
        indexed_lookup_is_the_bisection::<f32>();
        indexed_lookup_is_the_bisection::<f64>();
    }

    #[test]
    fn interpolates_and_rejects() {
        let t = AeroTable::<f64>::from_degrees(&[
            [0.0, 0.0, 0.4, 0.0],
            [90.0, 1.0, 2.0, -1.0],
            [180.0, 0.0, 0.4, 0.0],
        ])
        .unwrap();
        let c = t.at(45f64.to_radians());
        assert!(
            (c.cl - 0.5).abs() < 1e-12 && (c.cd - 1.2).abs() < 1e-12 && (c.cm + 0.5).abs() < 1e-12
        );
        assert_eq!(
            AeroTable::<f64>::from_degrees(&[
                [0.0, 0.0, 0.0, 0.0],
                [0.0, 0.0, 0.0, 0.0],
                [180.0, 0.0, 0.0, 0.0]
            ]),
            Err(AeroTableError::NotIncreasing { row: 1 })
        );
        assert_eq!(
            AeroTable::<f64>::from_degrees(&[[0.0, 0.0, 0.0, 0.0]]),
            Err(AeroTableError::TooFewRows)
        );
        assert_eq!(
            AeroTable::<f64>::from_degrees(&[[0.0, f64::NAN, 0.0, 0.0], [180.0, 0.0, 0.0, 0.0]]),
            Err(AeroTableError::NonFinite { row: 0 })
        );
        assert_eq!(
            AeroTable::<f64>::from_degrees(&[[0.0, 0.0, 0.0, 0.0], [90.0, 0.0, 0.0, 0.0]]),
            Err(AeroTableError::DoesNotCover0To180)
        );
    }
}
