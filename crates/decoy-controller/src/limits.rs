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
//!
//! The map also advises ([`MapManoeuvre`]): while the aircraft manoeuvres,
//! the limits are those of the flight condition where it entered the
//! manoeuvre (the map's limits are of a manoeuvre entered from steady flight
//! at the cell's condition, over the manoeuvre and its aftermath), and a
//! pull-up, turn or acceleration whose rate is above its floor there is
//! advised against the requirement that limits the nearest cell, with
//! [`Advisories::MAP`] (docs/protocol.md §3, "Advisories").

use solver_core::{AircraftState, Real};

use decoy_link::{Advisories, Limits, limited_by};
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
    /// The longest the map's manoeuvre lasts from its entry, s: a manoeuvre
    /// of this kind lasting longer is not the map's ([`MapCover`]); 0: the map
    /// covers nothing.
    pub manoeuvre_s: f32,
    /// How long the map's runs fly on after the manoeuvre ends, s.
    pub aftermath_s: f32,
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
        manoeuvre_s: 0.0,
        aftermath_s: 0.0,
    };

    /// This grid with the map's manoeuvre lasting at most `manoeuvre_s` from
    /// its entry and its runs flying `aftermath_s` on after it.
    /// A time that is not finite and at least 0 is taken as 0 (no cover).
    pub fn with_cover(mut self, manoeuvre_s: f32, aftermath_s: f32) -> Self {
        let seconds = |s: f32| if s.is_finite() && s >= 0.0 { s } else { 0.0 };
        self.manoeuvre_s = seconds(manoeuvre_s);
        self.aftermath_s = seconds(aftermath_s);
        self
    }

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
    /// grid lines, two on a line, the one at a grid point; a condition within
    /// [`FLOOR_ROUNDING`] of the spacing from a grid line is on it).
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
        // The cells weighed: one at a grid point, two on a line (within
        // FLOOR_ROUNDING of it: a condition on a grid line, measured in f32,
        // is not a neighbour's by its rounding).
        let e = T::lit(FLOOR_ROUNDING);
        let weighed = [
            one - u > e && one - v > e,
            one - u > e && v > e,
            u > e && one - v > e,
            u > e && v > e,
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

/// The fraction of a grid spacing within which a condition is on the grid
/// line for the floor ([`LimitGrid::lookup`]): 1e-4, 0.3 m of the reference
/// map's 3,000 m, 1e-5 of its 0.1 in Mach, a hundred times the rounding of
/// an altitude or Mach number measured in f32.
pub const FLOOR_ROUNDING: f64 = 1e-4;

/// Body rate, rad/s, below which (with the along-path acceleration below
/// [`STEADY_ACCELERATION_MPS2`]) the aircraft flies none of the map's
/// manoeuvres: the condition where a manoeuvre is entered is the last such
/// frame's. A quarter of the smallest mapped limit inside the declared
/// envelope (0.043 rad/s, the pull-up at 12 km, Mach 0.95), so that no
/// manoeuvre below it reaches a limit.
pub const STEADY_RATE_RADPS: f64 = 0.01;
/// Along-path acceleration, m/s², below which the aircraft is in steady flight
/// ([`STEADY_RATE_RADPS`]).
pub const STEADY_ACCELERATION_MPS2: f64 = 0.2;
/// How far above its floor, relative to the floor (at least 1), a rate must be
/// for the map to advise: the rounding of a rate measured in f32 from the
/// frame's attitude and body rates, far below the bisection's tolerance that
/// separates a map's clear and violating runs (0.005 rad/s, 0.1 m/s²).
pub const MAP_ADVISORY_TOLERANCE: f64 = 1e-4;
/// The sine of the largest flight-path angle at which a manoeuvre's entry is
/// level, as the map's runs start (about 1.1 degrees).
pub const LEVEL_CLIMB: f64 = 0.02;
/// The least steady flight after a manoeuvre the map does not cover before
/// the cable is taken as settled again, s (with the map's longest aftermath,
/// if longer): about three time constants of the decoy's slowest mode
/// (decay about 0.35/s on the embedded model).
pub const SETTLE_S: f64 = 10.0;

/// The aircraft's manoeuvre as the map measures it ([`MapManoeuvre::of`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MapManoeuvre<T: Real> {
    /// The flight path's rotation up, rad/s: the angular velocity's component
    /// about the horizontal axis to the right of the velocity (0 in vertical
    /// flight).
    pub pull_up_radps: T,
    /// The heading's rate, rad/s: the angular velocity's vertical component,
    /// either way.
    pub turn_radps: T,
    /// The along-path acceleration, m/s².
    pub acceleration_mps2: T,
    /// No manoeuvre: body rate below [`STEADY_RATE_RADPS`] and along-path
    /// acceleration below [`STEADY_ACCELERATION_MPS2`] in size.
    pub steady: bool,
    /// The flight path within [`LEVEL_CLIMB`] (its sine) of level, as the
    /// map's runs are when their manoeuvre begins.
    pub level: bool,
}

impl<T: Real> MapManoeuvre<T> {
    /// The manoeuvre `aircraft` flies.
    pub fn of(aircraft: &AircraftState<T>) -> Self {
        let rate = aircraft.rotation() * aircraft.angular_rate;
        let v = aircraft.velocity;
        let horizontal = (v.x * v.x + v.y * v.y).square_root();
        let pull_up_radps = if horizontal > T::zero() {
            (rate.y * v.x - rate.x * v.y) / horizontal
        } else {
            T::zero()
        };
        let speed = v.norm();
        let acceleration_mps2 = if speed > T::zero() {
            aircraft.acceleration.dot(&v) / speed
        } else {
            T::zero()
        };
        MapManoeuvre {
            pull_up_radps,
            turn_radps: rate.z.abs(),
            acceleration_mps2,
            steady: aircraft.angular_rate.norm() < T::lit(STEADY_RATE_RADPS)
                && acceleration_mps2.abs() < T::lit(STEADY_ACCELERATION_MPS2),
            level: v.z.abs() <= T::lit(LEVEL_CLIMB) * speed,
        }
    }

    /// Whether a rate is above its floor in `entry` (by more than
    /// [`MAP_ADVISORY_TOLERANCE`]), whatever limits it there: the manoeuvre
    /// is beyond what the map clears (an envelope bound's limit included).
    pub fn above_floor(&self, entry: &Limits) -> bool {
        let kinds = [
            (self.pull_up_radps, entry.pull_up_floor_radps),
            (self.turn_radps, entry.turn_floor_radps),
            (self.acceleration_mps2, entry.acceleration_floor_mps2),
        ];
        kinds.iter().any(|&(rate, floor)| above(rate, floor))
    }

    /// The advisory bits the map gives this manoeuvre with `entry`, the limits
    /// at the condition where it was entered: for each of the pull-up, the
    /// turn and the acceleration whose rate is above its floor (by more than
    /// [`MAP_ADVISORY_TOLERANCE`]) and whose nearest cell a requirement limits,
    /// that requirement's bit, and [`Advisories::MAP`]. None in steady flight,
    /// nor where the limit is unknown or an envelope bound's (flying beyond a
    /// bound is the envelope check's `OUTSIDE_ENVELOPE`).
    pub fn advisories(&self, entry: &Limits) -> u8 {
        if self.steady {
            return 0;
        }
        let kinds = [
            (
                self.pull_up_radps,
                entry.pull_up_floor_radps,
                entry.limited_by[0],
            ),
            (self.turn_radps, entry.turn_floor_radps, entry.limited_by[1]),
            (
                self.acceleration_mps2,
                entry.acceleration_floor_mps2,
                entry.limited_by[2],
            ),
        ];
        let mut bits = 0;
        for (rate, floor, code) in kinds {
            let requirement = code
                .checked_sub(limited_by::REQUIREMENT)
                .and_then(|i| Requirement::ALL.get(usize::from(i)));
            let Some(&requirement) = requirement else {
                continue;
            };
            if above(rate, floor) {
                bits |= Advisories::bit(requirement) | Advisories::MAP;
            }
        }
        bits
    }
}

/// `rate` above a known `floor` (not -1) by more than
/// [`MAP_ADVISORY_TOLERANCE`] of it (at least that much absolute).
fn above<T: Real>(rate: T, floor: f32) -> bool {
    let floor = T::lit(f64::from(floor));
    let scale = if floor > T::one() { floor } else { T::one() };
    floor >= T::zero() && rate > floor + T::lit(MAP_ADVISORY_TOLERANCE) * scale
}

/// The map's manoeuvres, as codes ([`MapCover`]): 0 none yet.
const KIND_PULL_UP: u8 = 1;
const KIND_TURN: u8 = 2;
const KIND_ACCELERATION: u8 = 3;

impl<T: Real> MapManoeuvre<T> {
    /// Which of the map's manoeuvres this is, as a kind code: the pull-up,
    /// the turn or the acceleration whose rate alone is at least its steady
    /// threshold ([`STEADY_RATE_RADPS`], [`STEADY_ACCELERATION_MPS2`]); 0
    /// while none is (a roll into a turn); `None` when it is none of the
    /// map's: a push-over, a deceleration, or two at once.
    fn kind(&self) -> Option<u8> {
        let rate = T::lit(STEADY_RATE_RADPS);
        let acceleration = T::lit(STEADY_ACCELERATION_MPS2);
        if self.pull_up_radps <= -rate || self.acceleration_mps2 <= -acceleration {
            return None;
        }
        let flown = [
            (self.pull_up_radps >= rate, KIND_PULL_UP),
            (self.turn_radps >= rate, KIND_TURN),
            (self.acceleration_mps2 >= acceleration, KIND_ACCELERATION),
        ];
        let mut kind = 0;
        for (on, code) in flown {
            if on {
                if kind != 0 {
                    return None;
                }
                kind = code;
            }
        }
        Some(kind)
    }
}

/// Where the flight is in respect of the map ([`MapCover`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum CoverState {
    /// Steady flight, long enough after any manoeuvre that the cable has
    /// settled as the map's runs start (from the trim).
    Settled = 0,
    /// A manoeuvre entered from settled flight, the map's so far.
    Flying,
    /// Steady again after it, within the map's aftermath.
    After,
    /// A manoeuvre that is not the map's (or entered before the cable
    /// settled).
    Uncovered,
    /// Steady after such a manoeuvre, until it has settled.
    UncoveredAfter,
}

/// Whether the map's verdict covers the flight: a manoeuvre of the map's
/// kind, entered from settled steady flight, lasting no longer than the map's
/// ([`LimitGrid::manoeuvre_s`]), never above the map's limit (the floor) where
/// it was entered, and the map's aftermath after it
/// ([`LimitGrid::aftermath_s`]). There the map (its 300-segment runs) says
/// that the manoeuvre violates no requirement, and the controller advises
/// by it alone: the look-ahead's advisory bits are withheld (its
/// `time_to_violation_s` and predicted margins are still reported). Elsewhere
/// (another manoeuvre, two at once, one begun in another's aftermath, one
/// longer than the map's) the look-ahead advises. All zero: settled (after a
/// trim).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MapCover {
    state: CoverState,
    /// The manoeuvre's kind code (0 not known yet).
    kind: u8,
    /// The map knows that kind's limit where the manoeuvre was entered (taken
    /// when the kind shows: the entry's limits are the condition's at the
    /// last steady frame, and its climb or acceleration may leave the grid).
    known: bool,
    /// The map advised against the manoeuvre (its rate went above the
    /// floor): the map knows only the requirement that limits it, and one
    /// beyond its limit may violate others, so the look-ahead advises too.
    exceeded: bool,
    /// When the manoeuvre was entered, s (the frame's time).
    entered_s: f64,
    /// When it ended (the first steady frame after it), s.
    ended_s: f64,
}

impl MapCover {
    /// Settled, as after a trim.
    pub const SETTLED: Self = MapCover {
        state: CoverState::Settled,
        kind: 0,
        known: false,
        exceeded: false,
        entered_s: 0.0,
        ended_s: 0.0,
    };

    /// Takes the accepted frame at `now` (s) flying `manoeuvre`, with the
    /// controller's `map` and `entry`, the limits where the manoeuvre was
    /// entered (read when its kind shows); returns whether the map covers
    /// the flight now: a manoeuvre the map clears. A rate above its floor
    /// ([`MapManoeuvre::above_floor`], an envelope bound's limit included)
    /// ends the cover for the rest of the manoeuvre and its aftermath.
    pub fn update<T: Real>(
        &mut self,
        now: f64,
        manoeuvre: &MapManoeuvre<T>,
        map: &LimitMap,
        entry: &Limits,
    ) -> bool {
        let above_floor = !manoeuvre.steady && manoeuvre.above_floor(entry);
        let grid = |kind: u8| match kind {
            KIND_PULL_UP => Some(&map.pull_up),
            KIND_TURN => Some(&map.turn),
            KIND_ACCELERATION => Some(&map.acceleration),
            _ => None,
        };
        // How long steady flight settles the cable after a manoeuvre (the
        // map's aftermath ended, or one the map does not cover).
        let settle = [&map.pull_up, &map.turn, &map.acceleration]
            .iter()
            .fold(SETTLE_S, |a, g| a.max(f64::from(g.aftermath_s)));
        let steady = manoeuvre.steady;
        match self.state {
            CoverState::Settled if !steady => {
                self.entered_s = now;
                self.kind = 0;
                self.known = false;
                self.exceeded = false;
                // The map's manoeuvres begin in level flight.
                self.state = if manoeuvre.level {
                    CoverState::Flying
                } else {
                    CoverState::Uncovered
                };
            }
            CoverState::Flying if steady => {
                self.ended_s = now;
                self.state = CoverState::After;
            }
            CoverState::After if !steady => self.state = CoverState::Uncovered,
            CoverState::Uncovered if steady => {
                self.ended_s = now;
                self.state = CoverState::UncoveredAfter;
            }
            CoverState::UncoveredAfter if !steady => self.state = CoverState::Uncovered,
            _ => {}
        }
        // Past the map's aftermath the map says nothing more; the cable
        // settles (from the manoeuvre's end) before the next manoeuvre is the
        // map's again.
        if self.state == CoverState::After {
            let aftermath = grid(self.kind).map_or(0.0, |g| f64::from(g.aftermath_s));
            if !(now - self.ended_s < aftermath) {
                self.state = CoverState::UncoveredAfter;
            }
        }
        if self.state == CoverState::UncoveredAfter && now - self.ended_s > settle {
            self.state = CoverState::Settled;
        }
        if self.state == CoverState::Flying {
            match manoeuvre.kind() {
                None => self.state = CoverState::Uncovered,
                // Its rate gone but still rotating (a roll out of a turn):
                // not what the map flies.
                Some(0) if self.kind != 0 => self.state = CoverState::Uncovered,
                Some(0) => {}
                Some(kind) if self.kind == 0 => {
                    self.kind = kind;
                    let code = match kind {
                        KIND_PULL_UP => entry.limited_by[0],
                        KIND_TURN => entry.limited_by[1],
                        _ => entry.limited_by[2],
                    };
                    self.known = code != limited_by::UNKNOWN;
                }
                Some(kind) if kind != self.kind => self.state = CoverState::Uncovered,
                Some(_) => {}
            }
            let lasts = grid(self.kind).map_or(0.0, |g| f64::from(g.manoeuvre_s));
            if self.kind != 0 && !(now - self.entered_s <= lasts) {
                self.state = CoverState::Uncovered;
            }
        }
        if self.state == CoverState::Flying && above_floor {
            self.exceeded = true;
        }
        let mapped = grid(self.kind).is_some_and(|g| g.manoeuvre_s > 0.0);
        matches!(self.state, CoverState::Flying | CoverState::After)
            && self.known
            && mapped
            && !self.exceeded
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
    /// The longest of the map's manoeuvres ([`LimitGrid::manoeuvre_s`]), s,
    /// at least [`SETTLE_S`]: how long the limits where a manoeuvre was
    /// entered stay its.
    pub fn longest_manoeuvre_s(&self) -> f64 {
        [&self.pull_up, &self.turn, &self.acceleration]
            .iter()
            .fold(SETTLE_S, |a, g| a.max(f64::from(g.manoeuvre_s)))
    }

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

    /// An aircraft at `attitude` ([w, x, y, z]) with `velocity` (NED),
    /// `acceleration` and body rates `rates`.
    fn aircraft(
        attitude: [f64; 4],
        velocity: [f64; 3],
        acceleration: [f64; 3],
        rates: [f64; 3],
    ) -> AircraftState<f64> {
        AircraftState {
            position: solver_core::Vec3::new(0.0, 0.0, -9000.0),
            velocity: solver_core::Vec3::from(velocity),
            acceleration: solver_core::Vec3::from(acceleration),
            attitude,
            angular_rate: solver_core::Vec3::from(rates),
            angular_acceleration: solver_core::Vec3::zeros(),
        }
    }

    #[test]
    fn the_manoeuvre_is_measured_as_the_map_flies_it() {
        let close = |a: f64, b: f64| (a - b).abs() < 1e-12;
        // A pull-up heading north, pitched 0.3 rad, pitching up at 0.1 rad/s.
        let (c, s) = (0.15f64.cos(), 0.15f64.sin());
        let v = [180.0 * 0.3f64.cos(), 0.0, -180.0 * 0.3f64.sin()];
        let m = MapManoeuvre::of(&aircraft([c, 0.0, s, 0.0], v, [0.0; 3], [0.0, 0.1, 0.0]));
        assert!(close(m.pull_up_radps, 0.1) && close(m.turn_radps, 0.0) && !m.steady);
        // Heading east, level: the same pitch rate is the same pull-up.
        let h = core::f64::consts::FRAC_PI_4;
        let east = aircraft(
            [h.cos(), 0.0, 0.0, h.sin()],
            [0.0, 180.0, 0.0],
            [0.0; 3],
            [0.0, 0.1, 0.0],
        );
        assert!(close(MapManoeuvre::of(&east).pull_up_radps, 0.1));
        // A push-over is a negative pull-up.
        let down = aircraft(
            [1.0, 0.0, 0.0, 0.0],
            [180.0, 0.0, 0.0],
            [0.0; 3],
            [0.0, -0.1, 0.0],
        );
        assert!(close(MapManoeuvre::of(&down).pull_up_radps, -0.1));
        // A coordinated turn at 0.15 rad/s banked 1 rad: body rates q = w sin(bank),
        // r = w cos(bank); the heading turns at w, the flight path does not rise.
        let (w, bank) = (0.15f64, 1.0f64);
        let turn = aircraft(
            [(bank / 2.0).cos(), (bank / 2.0).sin(), 0.0, 0.0],
            [180.0, 0.0, 0.0],
            [0.0; 3],
            [0.0, w * bank.sin(), w * bank.cos()],
        );
        let m = MapManoeuvre::of(&turn);
        assert!(
            close(m.turn_radps, 0.15) && close(m.pull_up_radps, 0.0),
            "{m:?}"
        );
        // A level acceleration: along the path; steady below the thresholds.
        let level = [1.0, 0.0, 0.0, 0.0];
        let m = MapManoeuvre::of(&aircraft(
            level,
            [180.0, 0.0, 0.0],
            [6.0, 0.0, 0.0],
            [0.0; 3],
        ));
        assert!(close(m.acceleration_mps2, 6.0) && !m.steady);
        let m = MapManoeuvre::of(&aircraft(
            level,
            [180.0, 0.0, 0.0],
            [0.1, 0.0, 0.0],
            [0.0, 0.009, 0.0],
        ));
        assert!(m.steady);
    }

    #[test]
    fn the_map_advises_a_rate_above_the_floor_against_the_limiting_requirement() {
        let entry = Limits {
            pull_up_floor_radps: 0.1,
            turn_floor_radps: 0.2,
            acceleration_floor_mps2: 5.0,
            limited_by: [
                Limiting::Requirement(Requirement::Exhaust).code(),
                Limiting::Bound.code(),
                Limiting::Requirement(Requirement::Posture).code(),
            ],
            ..Limits::UNKNOWN
        };
        let at = |pull_up: f64, turn: f64, acceleration: f64, steady: bool| {
            MapManoeuvre {
                pull_up_radps: pull_up,
                turn_radps: turn,
                acceleration_mps2: acceleration,
                steady,
                level: true,
            }
            .advisories(&entry)
        };
        let exhaust = Requirement::Exhaust.bit() | Advisories::MAP;
        assert_eq!(at(0.1005, 0.0, 0.0, false), exhaust);
        // At the floor, and within the tolerance above it: no advisory.
        assert_eq!(at(0.1, 0.0, 0.0, false), 0);
        assert_eq!(at(0.10009, 0.0, 0.0, false), 0);
        // A turn beyond a bound's limit is the envelope check's, not advised.
        assert_eq!(at(0.0, 0.3, 0.0, false), 0);
        // The acceleration's tolerance scales with its floor (5e-4 m/s^2 at 5).
        assert_eq!(at(0.0, 0.0, 5.0004, false), 0);
        assert_eq!(
            at(0.0, 0.0, 5.001, false),
            Requirement::Posture.bit() | Advisories::MAP
        );
        assert_eq!(
            at(0.2, 0.0, 6.0, false),
            exhaust | Requirement::Posture.bit()
        );
        // Steady flight, and limits unknown: nothing.
        assert_eq!(at(0.2, 0.0, 6.0, true), 0);
        let none = MapManoeuvre {
            pull_up_radps: 1.0,
            turn_radps: 1.0,
            acceleration_mps2: 50.0,
            steady: false,
            level: true,
        };
        assert_eq!(none.advisories(&Limits::UNKNOWN), 0);
        assert_eq!(none.advisories(&Limits::ZERO), 0);
    }

    #[test]
    fn a_condition_on_a_grid_line_within_its_rounding_weighs_no_neighbour() {
        let g = grid();
        let m3 = f64::from(0.3f32);
        // 1e-6 of a spacing off the 3000 m line: the floor is that line's two cells.
        let (_, floor, _) = g.lookup(3000.003f64, m3 + 1e-8).unwrap();
        assert_eq!(floor, 0.3);
        // A tenth of a millimetre below it is rounding; a metre is not: the
        // sea-level cell (0.2) is weighed then.
        let (_, floor, _) = g.lookup(2999.9999f64, m3).unwrap();
        assert_eq!(floor, 0.3);
        let (_, floor, _) = g.lookup(2999.0f64, m3).unwrap();
        assert_eq!(floor, 0.2);
    }

    #[test]
    fn the_map_covers_its_own_manoeuvres_and_their_aftermath_only() {
        let one = |limiting: Limiting| LimitGrid::new(&[0.0], &[0.5], &[(0.1, limiting)]).unwrap();
        let exhaust = Limiting::Requirement(Requirement::Exhaust);
        let map = LimitMap {
            pull_up: one(exhaust).with_cover(5.5, 12.5),
            turn: one(Limiting::Requirement(Requirement::Posture)).with_cover(20.0, 0.0),
            acceleration: one(Limiting::Bound),
        };
        let entry = map.at(0.0f64, f64::from(0.5f32));
        let flying = |pull_up: f64, turn: f64, acceleration: f64| MapManoeuvre {
            pull_up_radps: pull_up,
            turn_radps: turn,
            acceleration_mps2: acceleration,
            steady: pull_up.abs() < STEADY_RATE_RADPS
                && turn.abs() < STEADY_RATE_RADPS
                && acceleration.abs() < STEADY_ACCELERATION_MPS2,
            level: true,
        };
        let steady = flying(0.0, 0.0, 0.0);
        let roll = MapManoeuvre {
            steady: false,
            ..steady
        };
        // Flies `frames` (time s, manoeuvre) and returns whether each was covered.
        let fly = |frames: &[(f64, MapManoeuvre<f64>)]| {
            let mut cover = MapCover::SETTLED;
            frames
                .iter()
                .map(|(t, m)| cover.update(*t, m, &map, &entry))
                .collect::<Vec<_>>()
        };
        // The map's pull-up: steady, 5 s of rotation, the climb to its run's end.
        let pull_up = fly(&[
            (1.0, steady),
            (2.0, flying(0.05, 0.0, 0.0)),
            (7.0, flying(0.05, 0.0, 0.0)),
            (7.5, steady),
            (19.9, steady),
            (20.1, steady),
        ]);
        assert_eq!(pull_up, [false, true, true, true, true, false]);
        // Rotating longer than the map's pull-up: the look-ahead's.
        let long = fly(&[
            (1.0, steady),
            (2.0, flying(0.05, 0.0, 0.0)),
            (7.6, flying(0.05, 0.0, 0.0)),
        ]);
        assert_eq!(long, [false, true, false]);
        // A turn begun in the pull-up's aftermath, a push-over, two at once: not
        // the map's; then settled after the longest aftermath, steady.
        let after = fly(&[
            (2.0, flying(0.05, 0.0, 0.0)),
            (8.0, steady),
            (9.0, flying(0.0, 0.1, 0.0)),
            (10.0, steady),
            (22.0, steady),
            (22.6, steady),
            (23.0, flying(0.0, 0.1, 0.0)),
        ]);
        assert_eq!(after, [true, true, false, false, false, false, true]);
        assert_eq!(fly(&[(1.0, flying(-0.05, 0.0, 0.0))]), [false]);
        assert_eq!(fly(&[(1.0, flying(0.05, 0.05, 0.0))]), [false]);
        // A roll into a turn (no heading rate yet) is not covered until the
        // turn shows; the turn is, to its end; the map has no acceleration cover.
        assert_eq!(
            fly(&[
                (0.0, roll),
                (0.3, flying(0.0, 0.1, 0.0)),
                (20.5, flying(0.0, 0.1, 0.0))
            ]),
            [false, true, false]
        );
        assert_eq!(fly(&[(1.0, flying(0.0, 0.0, 5.0))]), [false]);
        // Without the entry's limits: nothing covered; with them, the
        // climb leaving the grid afterwards (the entry's limits then unknown)
        // keeps the cover.
        let mut cover = MapCover::SETTLED;
        assert!(!cover.update(2.0, &flying(0.05, 0.0, 0.0), &map, &Limits::UNKNOWN));
        let mut cover = MapCover::SETTLED;
        assert!(cover.update(2.0, &flying(0.05, 0.0, 0.0), &map, &entry));
        assert!(cover.update(8.0, &steady, &map, &Limits::UNKNOWN));
        // A pull-up above the limit (0.1) is not covered from then on, the
        // aftermath included: the look-ahead advises the other requirements.
        let above = fly(&[
            (2.0, flying(0.05, 0.0, 0.0)),
            (3.0, flying(0.2, 0.0, 0.0)),
            (8.0, steady),
        ]);
        assert_eq!(above, [true, false, false]);
        // Above a limit an envelope bound sets: no advisory from the map (the
        // envelope check flags it), and not covered either.
        let bound_map = LimitMap {
            turn: one(Limiting::Bound).with_cover(20.0, 0.0),
            ..map
        };
        let bound_entry = bound_map.at(0.0f64, f64::from(0.5f32));
        let mut cover = MapCover::SETTLED;
        assert!(cover.update(1.0, &flying(0.0, 0.05, 0.0), &bound_map, &bound_entry));
        assert_eq!(flying(0.0, 0.2, 0.0).advisories(&bound_entry), 0);
        assert!(!cover.update(2.0, &flying(0.0, 0.2, 0.0), &bound_map, &bound_entry));
        // A turn's aftermath is none: a pull-up soon after it is not the map's
        // (the cable has not settled), nor is the roll out of a turn.
        assert_eq!(
            fly(&[
                (1.0, flying(0.0, 0.1, 0.0)),
                (5.0, steady),
                (6.0, flying(0.05, 0.0, 0.0))
            ]),
            [true, false, false]
        );
        assert_eq!(
            fly(&[(1.0, flying(0.0, 0.1, 0.0)), (5.0, roll)]),
            [true, false]
        );
        // Entered in a climb: the map's runs begin level.
        let climbing = MapManoeuvre {
            level: false,
            ..flying(0.05, 0.0, 0.0)
        };
        assert_eq!(
            fly(&[(1.0, climbing), (2.0, flying(0.05, 0.0, 0.0))]),
            [false, false]
        );
        // A time that is no time gives no cover.
        assert_eq!(one(exhaust).with_cover(f32::NAN, 1.0).manoeuvre_s, 0.0);
    }
}
