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

/// CL, CD, Cm against total angle of attack (radians internally), 0 to pi.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AeroTable<T: Real> {
    alpha: [T; AERO_TABLE_CAPACITY],
    coefficients: [AeroCoefficients<T>; AERO_TABLE_CAPACITY],
    rows: usize,
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
        Ok(table)
    }

    /// Number of rows.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Coefficients at total angle of attack `alpha` (radians), linearly
    /// interpolated; clamped to the table's end rows outside 0..pi.
    pub fn at(&self, alpha: T) -> AeroCoefficients<T> {
        let n = self.rows;
        if alpha <= self.alpha[0] {
            return self.coefficients[0];
        }
        if alpha >= self.alpha[n - 1] {
            return self.coefficients[n - 1];
        }
        // Binary search for the interval [lo, lo + 1] holding alpha.
        let (mut lo, mut hi) = (0usize, n - 1);
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            if self.alpha[mid] <= alpha {
                lo = mid;
            } else {
                hi = mid;
            }
        }
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
