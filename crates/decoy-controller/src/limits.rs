//! The manoeuvre envelope map on board: the largest pull-up rate, turn rate
//! and along-path acceleration the map of the controller's configuration allows
//! at the aircraft's flight condition, reported in every Output
//! (`Management::limits`, docs/protocol.md §3, "Limits") so that the mission
//! computer can cue the pilot before a manoeuvre starts.
//!
//! The map is `decoy envelope`'s (docs/envelope.md), made on the host model for
//! this configuration and kept in the repository as a file
//! (`config/reference-system.limits.toml`, written by `decoy limits-table`);
//! `decoy-config` reads it with the configuration and refuses it unless it was
//! made for exactly that configuration (its hash), and the firmware's build
//! script writes it as a constant, as it does [`crate::SystemParams`]. On board
//! it is plain numbers in f32 (the Output's precision), one grid per manoeuvre;
//! a lookup is a bilinear interpolation in altitude and Mach between the four
//! cells around the condition, a few hundred instructions, run with the
//! management after the real-time solution.

use solver_core::Real;

use decoy_link::{Limits, limited_by};
use decoy_schema::Requirement;

/// Most altitudes, and most Mach numbers, of one manoeuvre's grid.
pub const LIMIT_AXIS_CAPACITY: usize = 12;
/// Most cells of one manoeuvre's grid.
pub const LIMIT_CELL_CAPACITY: usize = 96;

/// What limits a cell of the map ([`LimitGrid::limiting`]): a requirement, or
/// a bound of the declared envelope (load factor, body rate or along-path
/// acceleration), the map's cap.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Limiting {
    /// A requirement is violated just above the limit.
    Requirement(Requirement),
    /// The envelope's bound caps the manoeuvre and the cap is clear.
    Bound,
}

impl Limiting {
    /// Its code in an Output ([`decoy_link::limited_by`]).
    pub const fn code(self) -> u8 {
        match self {
            Limiting::Requirement(r) => limited_by::REQUIREMENT + r.index() as u8,
            Limiting::Bound => limited_by::BOUND,
        }
    }
}

/// One manoeuvre's map: its grid of altitude × Mach and each cell's limit and
/// what limits it. Plain `Copy` data whose derived `Debug` form is the Rust
/// expression of the value (the firmware's generated constant). All zero: no
/// grid (the lookup finds nothing).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LimitGrid {
    /// The grid's altitudes, m, ascending ([`LimitGrid::altitude_count`] used).
    pub altitudes_m: [f32; LIMIT_AXIS_CAPACITY],
    /// Altitudes used.
    pub altitude_count: u8,
    /// The grid's Mach numbers, ascending ([`LimitGrid::mach_count`] used).
    pub machs: [f32; LIMIT_AXIS_CAPACITY],
    /// Mach numbers used.
    pub mach_count: u8,
    /// Each cell's limit, altitude by altitude (cell `(i, j)` at
    /// `i * mach_count + j`): rad/s for the rotations, m/s² for the
    /// acceleration; 0 where even steady flight violates a requirement.
    pub limits: [f32; LIMIT_CELL_CAPACITY],
    /// What limits each cell, as [`Limiting::code`], in the same order.
    pub limiting: [u8; LIMIT_CELL_CAPACITY],
}

impl LimitGrid {
    /// No grid.
    pub const EMPTY: Self = LimitGrid {
        altitudes_m: [0.0; LIMIT_AXIS_CAPACITY],
        altitude_count: 0,
        machs: [0.0; LIMIT_AXIS_CAPACITY],
        mach_count: 0,
        limits: [0.0; LIMIT_CELL_CAPACITY],
        limiting: [0; LIMIT_CELL_CAPACITY],
    };

    /// The grid of `altitudes_m` × `machs` (each ascending, at most
    /// [`LIMIT_AXIS_CAPACITY`]) with `cells` in altitude-major order (limit,
    /// what limits it); an error if the sizes do not fit, an axis is not
    /// strictly ascending and finite, or a limit is negative or not finite.
    pub fn new(
        altitudes_m: &[f32],
        machs: &[f32],
        cells: &[(f32, Limiting)],
    ) -> Result<Self, LimitGridError> {
        let ascending = |axis: &[f32]| {
            axis.iter().all(|v| v.is_finite()) && axis.windows(2).all(|w| w[0] < w[1])
        };
        if altitudes_m.is_empty()
            || machs.is_empty()
            || altitudes_m.len() > LIMIT_AXIS_CAPACITY
            || machs.len() > LIMIT_AXIS_CAPACITY
        {
            return Err(LimitGridError::AxisSize);
        }
        if altitudes_m.len() * machs.len() > LIMIT_CELL_CAPACITY {
            return Err(LimitGridError::CellCount);
        }
        if cells.len() != altitudes_m.len() * machs.len() {
            return Err(LimitGridError::CellCount);
        }
        if !ascending(altitudes_m) || !ascending(machs) {
            return Err(LimitGridError::NotAscending);
        }
        let mut grid = LimitGrid::EMPTY;
        grid.altitudes_m[..altitudes_m.len()].copy_from_slice(altitudes_m);
        grid.machs[..machs.len()].copy_from_slice(machs);
        grid.altitude_count = altitudes_m.len() as u8;
        grid.mach_count = machs.len() as u8;
        for (k, &(limit, limiting)) in cells.iter().enumerate() {
            if !(limit.is_finite() && limit >= 0.0) {
                return Err(LimitGridError::Limit);
            }
            grid.limits[k] = limit;
            grid.limiting[k] = limiting.code();
        }
        Ok(grid)
    }

    /// Whether the grid has cells.
    pub fn is_empty(&self) -> bool {
        self.altitude_count == 0 || self.mach_count == 0
    }

    /// The grid's altitudes (none if its count is beyond the capacity).
    pub fn altitudes(&self) -> &[f32] {
        self.altitudes_m
            .get(..usize::from(self.altitude_count))
            .unwrap_or(&[])
    }

    /// The grid's Mach numbers (none if its count is beyond the capacity).
    pub fn machs(&self) -> &[f32] {
        self.machs
            .get(..usize::from(self.mach_count))
            .unwrap_or(&[])
    }

    /// The limit at `altitude_m` and `mach`, interpolated bilinearly between
    /// the four cells around it (between two along an axis of one value), and
    /// the code of what limits the nearest of them; `None` outside the grid
    /// (beyond [`crate::envelope::BOUND_TOLERANCE`] of its edges) or without one.
    pub fn at<T: Real>(&self, altitude_m: T, mach: T) -> Option<(T, u8)> {
        self.lookup(altitude_m, mach)
            .map(|(limit, _, code)| (limit, code))
    }

    /// [`LimitGrid::at`] with the floor: the smallest limit of the cells
    /// around the condition that the interpolation weighs (all four between
    /// grid lines, two on a line, the one at a grid point).
    ///
    /// On the frame path, so without a panic site (`hil-tests`' `panic_free`):
    /// every index is taken with `get`, and a grid whose counts do not fit its
    /// arrays finds nothing.
    pub fn lookup<T: Real>(&self, altitude_m: T, mach: T) -> Option<(T, f32, u8)> {
        let (i, i1, u) = bracket(self.altitudes(), altitude_m)?;
        let (j, j1, v) = bracket(self.machs(), mach)?;
        let columns = usize::from(self.mach_count);
        let index = |a: usize, m: usize| a.checked_mul(columns)?.checked_add(m);
        let limit_at = |a: usize, m: usize| self.limits.get(index(a, m)?).copied();
        let corners = [
            limit_at(i, j)?,
            limit_at(i, j1)?,
            limit_at(i1, j)?,
            limit_at(i1, j1)?,
        ];
        let [c00, c01, c10, c11] = corners.map(|c| T::lit(f64::from(c)));
        let one = T::one();
        let low = c00 * (one - v) + c01 * v;
        let high = c10 * (one - v) + c11 * v;
        let limit = low * (one - u) + high * u;
        // The cells of nonzero weight: one at a grid point, two on a line.
        let weighed = [
            one - u > T::zero() && one - v > T::zero(),
            one - u > T::zero() && v > T::zero(),
            u > T::zero() && one - v > T::zero(),
            u > T::zero() && v > T::zero(),
        ];
        let floor = corners
            .iter()
            .zip(weighed)
            .filter(|(_, w)| *w)
            .map(|(c, _)| *c)
            .fold(f32::INFINITY, f32::min);
        let half = T::lit(0.5);
        let a = if u > half { i1 } else { i };
        let m = if v > half { j1 } else { j };
        let code = *self.limiting.get(index(a, m)?)?;
        Some((limit, floor, code))
    }
}

/// The interval of the ascending `axis` holding `x`: the indices of its ends
/// (the same on a one-value axis) and the fraction of the way from the first
/// to the second (0 on a one-value axis); `None` outside (beyond the
/// tolerance) or on an empty axis. Without a panic site (no indexing).
fn bracket<T: Real>(axis: &[f32], x: T) -> Option<(usize, usize, T)> {
    let (first, last) = (*axis.first()?, *axis.last()?);
    let tolerance = |v: f32| T::lit(crate::envelope::BOUND_TOLERANCE * f64::from(v).abs().max(1.0));
    let lit = |v: f32| T::lit(f64::from(v));
    if !(x >= lit(first) - tolerance(first) && x <= lit(last) + tolerance(last)) {
        return None;
    }
    // The last interval whose lower end x is above (the first if none).
    let mut interval = None;
    for (k, pair) in axis.windows(2).enumerate() {
        if let [x0, x1] = *pair
            && (interval.is_none() || x > lit(x0))
        {
            interval = Some((k, x0, x1));
        }
    }
    let Some((i, x0, x1)) = interval else {
        return Some((0, 0, T::zero()));
    };
    let mut f = (x - lit(x0)) / (lit(x1) - lit(x0));
    if f < T::zero() {
        f = T::zero();
    }
    if f > T::one() {
        f = T::one();
    }
    Some((i, i + 1, f))
}

/// Why a grid could not be built ([`LimitGrid::new`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LimitGridError {
    /// An axis is empty or longer than [`LIMIT_AXIS_CAPACITY`].
    AxisSize,
    /// More cells than [`LIMIT_CELL_CAPACITY`], or not one per grid point.
    CellCount,
    /// An axis is not strictly ascending and finite.
    NotAscending,
    /// A limit is negative or not finite.
    Limit,
}

impl core::fmt::Display for LimitGridError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            LimitGridError::AxisSize => "each axis needs 1 to 12 values (LIMIT_AXIS_CAPACITY)",
            LimitGridError::CellCount => {
                "needs one cell per altitude and Mach number, at most 96 (LIMIT_CELL_CAPACITY)"
            }
            LimitGridError::NotAscending => "an axis is not strictly ascending",
            LimitGridError::Limit => "a limit is negative or not finite",
        })
    }
}

/// The map of a configuration on board: a grid per mapped manoeuvre (pull-up,
/// turn, acceleration), each possibly empty.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LimitMap {
    /// The pull-up's largest clear rate, rad/s.
    pub pull_up: LimitGrid,
    /// The turn's largest clear rate, rad/s.
    pub turn: LimitGrid,
    /// The largest clear along-path acceleration, m/s².
    pub acceleration: LimitGrid,
}

impl LimitMap {
    /// No map: every limit unknown.
    pub const EMPTY: Self = LimitMap {
        pull_up: LimitGrid::EMPTY,
        turn: LimitGrid::EMPTY,
        acceleration: LimitGrid::EMPTY,
    };

    /// The limits at `altitude_m` and `mach` as an Output reports them: each
    /// interpolated and its floor, or [`Limits::UNKNOWN`]'s -1 and code 0
    /// where its grid does not reach (or there is none).
    pub fn at<T: Real>(&self, altitude_m: T, mach: T) -> Limits {
        let mut limits = Limits::UNKNOWN;
        let narrow = |v: T| v.to_f64() as f32;
        if let Some((v, floor, code)) = self.pull_up.lookup(altitude_m, mach) {
            limits.pull_up_radps = narrow(v);
            limits.pull_up_floor_radps = floor;
            limits.limited_by[0] = code;
        }
        if let Some((v, floor, code)) = self.turn.lookup(altitude_m, mach) {
            limits.turn_radps = narrow(v);
            limits.turn_floor_radps = floor;
            limits.limited_by[1] = code;
        }
        if let Some((v, floor, code)) = self.acceleration.lookup(altitude_m, mach) {
            limits.acceleration_mps2 = narrow(v);
            limits.acceleration_floor_mps2 = floor;
            limits.limited_by[2] = code;
        }
        limits
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid() -> LimitGrid {
        let exhaust = Limiting::Requirement(Requirement::Exhaust);
        let posture = Limiting::Requirement(Requirement::Posture);
        LimitGrid::new(
            &[0.0, 3000.0, 6000.0],
            &[0.3, 0.4],
            &[
                (0.2, exhaust),
                (0.1, exhaust),
                (0.3, posture),
                (0.2, Limiting::Bound),
                (0.4, posture),
                (0.0, posture),
            ],
        )
        .unwrap()
    }

    #[test]
    fn the_grid_points_are_the_cells_and_between_them_bilinear() {
        let g = grid();
        // The grid's own points (its Mach numbers are f32's).
        let (m3, m4) = (f64::from(0.3f32), f64::from(0.4f32));
        assert_eq!(g.at(0.0f64, m3), Some((f64::from(0.2f32), 4)));
        assert_eq!(g.at(3000.0f64, m4), Some((f64::from(0.2f32), 0x80)));
        assert_eq!(g.at(6000.0f64, m4), Some((0.0, 1)));
        let (v, code) = g.at(1500.0f64, 0.35).unwrap();
        assert!((v - 0.2).abs() < 1e-7, "{v}");
        // The nearest cell of (1500, 0.35) is the lower-left one, on ties.
        assert_eq!(
            code,
            limited_by::REQUIREMENT + Requirement::Exhaust.index() as u8
        );
        let (v, code) = g.at(4500.0f64, 0.4).unwrap();
        assert!((v - 0.1).abs() < 1e-7, "{v}");
        // Halfway between two altitudes: the lower one's cell.
        assert_eq!(code, limited_by::BOUND);
        let (_, code) = g.at(4600.0f64, 0.4).unwrap();
        assert_eq!(
            code,
            limited_by::REQUIREMENT + Requirement::Posture.index() as u8
        );
        // f32 the same points.
        let (v, _) = g.at(6000.0f32, 0.3).unwrap();
        assert!((v - 0.4).abs() < 1e-7);
    }

    #[test]
    fn outside_the_grid_nothing_within_the_tolerance_the_edge() {
        let g = grid();
        assert_eq!(g.at(-1.0f64, 0.3), None);
        assert_eq!(g.at(0.0f64, 0.29), None);
        assert_eq!(g.at(6001.0f64, 0.3), None);
        assert_eq!(g.at(0.0f64, 0.41), None);
        assert!(g.at(6000.05f64, 0.400001).is_some());
        assert!(g.at(f64::NAN, 0.3).is_none());
        assert_eq!(LimitGrid::EMPTY.at(0.0f64, 0.3), None);
        let map = LimitMap {
            pull_up: g,
            ..LimitMap::EMPTY
        };
        let limits = map.at(0.0f64, 0.3);
        assert_eq!(limits.pull_up_radps, 0.2);
        assert_eq!(limits.pull_up_floor_radps, 0.2);
        // Between cells the floor is the smallest of the four.
        let between = map.at(1500.0f64, 0.35);
        assert_eq!(between.pull_up_floor_radps, 0.1);
        assert!(between.pull_up_radps > between.pull_up_floor_radps);
        assert_eq!((limits.turn_radps, limits.acceleration_mps2), (-1.0, -1.0));
        assert_eq!(limits.limited_by, [4, 0, 0]);
        assert_eq!(LimitMap::EMPTY.at(0.0f32, 0.3), Limits::UNKNOWN);
    }

    #[test]
    fn a_one_value_axis_is_its_line() {
        let g = LimitGrid::new(
            &[9000.0],
            &[0.5, 0.7],
            &[(0.1, Limiting::Bound), (0.3, Limiting::Bound)],
        )
        .unwrap();
        let (v, _) = g.at(9000.0f64, 0.6).unwrap();
        assert!((v - 0.2).abs() < 1e-7);
        assert_eq!(g.at(9100.0f64, 0.6), None);
    }

    #[test]
    fn bad_grids_are_refused() {
        let b = Limiting::Bound;
        assert_eq!(
            LimitGrid::new(&[], &[0.3], &[]),
            Err(LimitGridError::AxisSize)
        );
        assert_eq!(
            LimitGrid::new(&[0.0, 0.0], &[0.3], &[(0.1, b), (0.1, b)]),
            Err(LimitGridError::NotAscending)
        );
        assert_eq!(
            LimitGrid::new(&[0.0], &[0.3], &[(0.1, b), (0.1, b)]),
            Err(LimitGridError::CellCount)
        );
        assert_eq!(
            LimitGrid::new(&[0.0], &[0.3], &[(-0.1, b)]),
            Err(LimitGridError::Limit)
        );
        assert_eq!(
            LimitGrid::new(&[0.0], &[0.3], &[(f32::NAN, b)]),
            Err(LimitGridError::Limit)
        );
        let axis: Vec<f32> = (0..12).map(|k| k as f32).collect();
        assert_eq!(
            LimitGrid::new(&axis, &axis, &vec![(0.1, b); 144]),
            Err(LimitGridError::CellCount)
        );
    }
}
