//! Typed errors. Every failure names what and where; none is a silent zero.

use core::fmt;

/// The atmosphere model cannot give air properties.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub enum AtmosphereError {
    /// Altitude outside the model's range (-500 m to 20 km).
    AltitudeOutOfRange {
        /// The requested altitude, m.
        altitude_m: f64,
    },
    /// Altitude is NaN or infinite.
    NonFinite,
}

/// The decoy aerodynamic table cannot be used.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum AeroTableError {
    /// Fewer than two rows.
    TooFewRows,
    /// More rows than the fixed-size table holds.
    TooManyRows {
        /// Rows given.
        rows: usize,
        /// Rows the table holds.
        capacity: usize,
    },
    /// A value is NaN or infinite.
    NonFinite {
        /// Zero-based row.
        row: usize,
    },
    /// Angles are not strictly increasing.
    NotIncreasing {
        /// Zero-based row whose angle is not above the previous one.
        row: usize,
    },
    /// The table does not span 0 to 180 degrees of total angle of attack.
    DoesNotCover0To180,
}

/// A model parameter is unusable.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub enum ConfigError {
    /// A parameter is NaN or infinite.
    NonFinite {
        /// Parameter name.
        field: &'static str,
    },
    /// A parameter that must be positive is zero or negative.
    NonPositive {
        /// Parameter name.
        field: &'static str,
        /// Its value.
        value: f64,
    },
    /// A parameter is outside its physical range.
    OutOfRange {
        /// Parameter name.
        field: &'static str,
        /// Its value.
        value: f64,
    },
    /// No segments requested.
    NoSegments,
    /// More segments than the solver's compile-time capacity.
    TooManySegments {
        /// Segments requested.
        requested: usize,
        /// The capacity `N`.
        capacity: usize,
    },
    /// The decoy aerodynamic table is unusable.
    AeroTable(AeroTableError),
    /// A graded layout whose ratio, raised to the segment count, leaves the
    /// scalar's range: the shortest segment's length underflows to zero (or the
    /// sum of the length weights overflows).
    GradingOverflow {
        /// Segments requested.
        count: usize,
        /// The grading ratio.
        ratio: f64,
    },
}

/// The prescribed aircraft motion at some time is unusable.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub enum InputError {
    /// A field is NaN or infinite.
    NonFinite {
        /// Field name (for example `"velocity"`).
        field: &'static str,
    },
    /// The attitude quaternion has (near) zero norm.
    DegenerateAttitude,
    /// The air at the connection point is outside the atmosphere model.
    Atmosphere(AtmosphereError),
    /// The time step is not a positive finite number.
    BadTimeStep,
}

/// The dynamics could not be evaluated at a state.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub enum SolveError {
    /// The elimination met a pivot that is not positive (or not finite) at a joint:
    /// the system is not positive definite there (a degenerate state or parameters).
    NonPositivePivot {
        /// Joint index, 0 = connection point, N = towing point.
        joint: usize,
    },
    /// A NaN or infinite value appeared at a joint or segment.
    NonFinite {
        /// Joint index, 0 = connection point, N = towing point.
        joint: usize,
    },
    /// The prescribed motion was unusable.
    Input(InputError),
}

/// Trim (the steady equilibrium) could not be found.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub enum TrimError {
    /// The flight condition is unusable (non-finite, outside the atmosphere).
    Input(InputError),
    /// The aircraft is not in steady straight flight (acceleration or rotation given).
    NotSteady,
    /// No decoy attitude within +-80 degrees of the airflow balances the moment about the towing point.
    NoDecoyTrim,
    /// The static balance of a segment did not converge (for example no airflow to stretch the cable upward).
    SegmentDidNotConverge {
        /// Segment index, 1 = at the connection point.
        segment: usize,
    },
    /// Chain altitudes did not settle in the density iteration.
    ColumnDidNotConverge,
}

impl From<AeroTableError> for ConfigError {
    fn from(e: AeroTableError) -> Self {
        ConfigError::AeroTable(e)
    }
}
impl From<InputError> for SolveError {
    fn from(e: InputError) -> Self {
        SolveError::Input(e)
    }
}
impl From<AtmosphereError> for InputError {
    fn from(e: AtmosphereError) -> Self {
        InputError::Atmosphere(e)
    }
}
impl From<InputError> for TrimError {
    fn from(e: InputError) -> Self {
        TrimError::Input(e)
    }
}

impl fmt::Display for AtmosphereError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            AtmosphereError::AltitudeOutOfRange { altitude_m } => write!(
                f,
                "altitude {altitude_m:.1} m is outside the ISA 1976 model range (-500 m to 20000 m)"
            ),
            AtmosphereError::NonFinite => write!(f, "altitude is not a finite number"),
        }
    }
}

impl fmt::Display for AeroTableError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            AeroTableError::TooFewRows => write!(f, "aerodynamic table needs at least two rows"),
            AeroTableError::TooManyRows { rows, capacity } => {
                write!(
                    f,
                    "aerodynamic table has {rows} rows, at most {capacity} are supported"
                )
            }
            AeroTableError::NonFinite { row } => {
                write!(f, "aerodynamic table row {row} has a non-finite value")
            }
            AeroTableError::NotIncreasing { row } => {
                write!(
                    f,
                    "aerodynamic table row {row}: angle of attack must increase strictly"
                )
            }
            AeroTableError::DoesNotCover0To180 => {
                write!(
                    f,
                    "aerodynamic table must run from 0 to 180 degrees of total angle of attack"
                )
            }
        }
    }
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ConfigError::NonFinite { field } => write!(f, "{field} is not a finite number"),
            ConfigError::NonPositive { field, value } => {
                write!(f, "{field} must be positive, got {value}")
            }
            ConfigError::OutOfRange { field, value } => {
                write!(f, "{field} = {value} is out of range")
            }
            ConfigError::NoSegments => write!(f, "the cable needs at least one segment"),
            ConfigError::TooManySegments {
                requested,
                capacity,
            } => {
                write!(
                    f,
                    "{requested} segments requested, the solver holds at most {capacity}"
                )
            }
            ConfigError::AeroTable(e) => write!(f, "{e}"),
            ConfigError::GradingOverflow { count, ratio } => write!(
                f,
                "grading ratio {ratio} over {count} segments overflows: the longest segment would be {ratio}^{} times the shortest, beyond the floating-point range, so the shortest segment's length underflows to zero; use a smaller grading ratio or fewer segments",
                count.saturating_sub(1)
            ),
        }
    }
}

impl fmt::Display for InputError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            InputError::NonFinite { field } => {
                write!(f, "aircraft state field `{field}` is not finite")
            }
            InputError::DegenerateAttitude => {
                write!(f, "aircraft attitude quaternion has zero norm")
            }
            InputError::Atmosphere(e) => write!(f, "{e}"),
            InputError::BadTimeStep => write!(f, "time step must be a positive finite number"),
        }
    }
}

impl fmt::Display for SolveError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SolveError::NonPositivePivot { joint } => {
                write!(f, "tension recurrence: non-positive pivot at joint {joint}")
            }
            SolveError::NonFinite { joint } => write!(f, "non-finite value at joint {joint}"),
            SolveError::Input(e) => write!(f, "{e}"),
        }
    }
}

impl fmt::Display for TrimError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TrimError::Input(e) => write!(f, "{e}"),
            TrimError::NotSteady => write!(
                f,
                "trim needs steady straight flight (no acceleration, no rotation)"
            ),
            TrimError::NoDecoyTrim => {
                write!(
                    f,
                    "no decoy attitude within 80 degrees of the airflow balances the moment about the towing point"
                )
            }
            TrimError::SegmentDidNotConverge { segment } => {
                write!(
                    f,
                    "static balance of cable segment {segment} did not converge"
                )
            }
            TrimError::ColumnDidNotConverge => {
                write!(f, "cable altitudes did not converge in trim")
            }
        }
    }
}

impl core::error::Error for AtmosphereError {}
impl core::error::Error for AeroTableError {}
impl core::error::Error for ConfigError {}
impl core::error::Error for InputError {}
impl core::error::Error for SolveError {}
impl core::error::Error for TrimError {}
