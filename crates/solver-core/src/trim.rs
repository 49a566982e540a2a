//! Trim: the steady equilibrium of the towed system in steady straight flight
//! (docs/design.md §5).
//!
//! In steady flight every body moves with the connection point's velocity v and
//! none rotates, so all bodies see the same relative air velocity u = wind - v.
//!
//! 1. Decoy: the attitude in the plane of the airflow and gravity whose moment
//!    about the towing point vanishes, with a restoring slope (nose-up
//!    perturbation gives a nose-down moment); then T_N = -(F_aero + m_d g). The
//!    pitch about the airflow is scanned over +-80 degrees for the stable root
//!    nearest the airflow, then found within its interval.
//! 2. Segments, from the decoy up: segment i carries T_{i-1} = T_i - F_i(e_i) and its
//!    hinge torques vanish when e_i is parallel to T_{i-1} + T_i = 2T_i - F_i(e_i).
//!    Normal drag is k_n |u_n| u_n with u_n = u - (u.e)e and tangential drag lies
//!    along e, so with W = 2T_i - m_i g and sigma = k_n |u_n| the condition reads
//!    e = -normalize(W - sigma u), with sigma = k_n |u x e(sigma)|: a scalar root on
//!    [0, k_n |u|].
//! 3. Densities depend on the chain's altitudes, which depend on the shape: repeat
//!    1-2 with the altitudes of the previous pass until they settle. A pass after
//!    the first looks for the decoy's root next to the last one before scanning
//!    again (the densities change it by far less than a scan interval).
//!
//! Both roots are found by the Illinois method (regula falsi with the retained
//! end's value halved), which keeps a bracket and converges superlinearly: about
//! 8 evaluations to the precision's resolution where bisection takes 25 in f32
//! and 55 in f64.
//!
//! The work is a [`TrimTask`]: a resumable search that [`TrimTask::advance`]
//! carries on for a given number of work units (a decoy moment is
//! [`MOMENT_UNITS`], a segment's residual one), so that a controller can spread a
//! trim over several frames at a bounded cost each ([`crate::Solver::trim`] runs
//! it to the end at once). The same units give the same bits however the work is
//! sliced.
//!
//! Densities come from the same air column as the dynamics, so the trim is an
//! equilibrium of the discrete dynamics to round-off.

use nalgebra::{Matrix3, Rotation3, UnitQuaternion};

use crate::atmosphere::AirColumn;
use crate::dynamics::{cable_drag, decoy_aero};
use crate::error::TrimError;
use crate::model::Model;
use crate::motion::{AircraftState, PointKinematics, connection_and_air};
use crate::scalar::{Mat3, Real, Vec3, norm};
use crate::state::State;

/// Passes over the chain before the altitudes must have settled.
const MAX_COLUMN_PASSES: u32 = 60;
/// Root-finder iterations before a root is taken as found (the Illinois method
/// takes about 8; bisection steps guarantee the bracket halves at least every
/// other iteration, so 200 is far beyond any precision's resolution).
const MAX_ROOT_ITERATIONS: u32 = 200;
/// Decoy pitch search range about the airflow, degrees.
const PITCH_LIMIT_DEG: f64 = 80.0;
/// Intervals of the full pitch scan.
const PITCH_SCAN_STEPS: u32 = 160;
/// Work units of one decoy moment evaluation (its aerodynamics, the attitude's
/// trigonometry and transforms: about eight times a segment's residual).
pub const MOMENT_UNITS: u32 = 8;
/// Work units of one segment residual, and of one pass's altitude update.
pub const RESIDUAL_UNITS: u32 = 1;

/// The trim state for steady straight flight with the aircraft in `aircraft`
/// (its acceleration and rates must be zero). The returned state has time 0.
pub fn trim<T: Real, const N: usize>(
    model: &Model<T, N>,
    aircraft: &AircraftState<T>,
) -> Result<State<T, N>, TrimError> {
    let mut state = State::<T, N>::default();
    trim_into(model, aircraft, &mut state)?;
    Ok(state)
}

/// [`trim`] written into `state` (for a caller that must not hold a state on
/// its stack: [`crate::Solver::trim`]). On error `state` holds what the search
/// had reached: the caller restores its own copy.
pub fn trim_into<T: Real, const N: usize>(
    model: &Model<T, N>,
    aircraft: &AircraftState<T>,
    state: &mut State<T, N>,
) -> Result<(), TrimError> {
    let mut task = TrimTask::start(model, aircraft, state)?;
    while !task.advance(model, state, u32::MAX)? {}
    Ok(())
}

/// Where a root search stands: the bracket [lo, hi] with the function's values
/// there (opposite signs, `f_lo` >= 0 > `f_hi` for the pitch, `f_lo` >= 0 >=
/// `f_hi` for a segment), the end retained last (Illinois), the iterations and
/// the bracket width at which the root counts as found.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Root<T: Real> {
    lo: T,
    hi: T,
    f_lo: T,
    f_hi: T,
    /// -1: the lower end was retained last, +1: the upper, 0: neither yet.
    retained: i8,
    iterations: u32,
    /// Found when hi - lo is at most this: four ulps of the bracket's scale.
    resolution: T,
}

impl<T: Real> Root<T> {
    /// The search on [lo, hi] with the values there, to four ulps of `scale`.
    fn new(lo: T, hi: T, f_lo: T, f_hi: T, scale: T) -> Self {
        Root {
            lo,
            hi,
            f_lo,
            f_hi,
            retained: 0,
            iterations: 0,
            resolution: T::lit(4.0) * T::eps() * scale.abs(),
        }
    }

    /// The next point to evaluate, or the root (the bracket's midpoint) when the
    /// bracket is down to its resolution or to adjacent values, or the
    /// iterations are spent: the regula falsi point, or the midpoint when that is
    /// not strictly inside and every eighth iteration (so that the bracket always
    /// shrinks).
    fn next(&self) -> Result<T, T> {
        let half = T::lit(0.5);
        let mid = (self.lo + self.hi) * half;
        if !(mid > self.lo && mid < self.hi)
            || self.hi - self.lo <= self.resolution
            || self.iterations >= MAX_ROOT_ITERATIONS
        {
            return Err(mid);
        }
        let denominator = self.f_lo - self.f_hi;
        let secant = if denominator > T::zero() {
            self.lo + (self.hi - self.lo) * (self.f_lo / denominator)
        } else {
            mid
        };
        let x = if secant > self.lo && secant < self.hi && self.iterations % 8 != 7 {
            secant
        } else {
            mid
        };
        Ok(x)
    }

    /// Takes f(x) at the point [`Root::next`] gave; `Some(x)` when it is the root
    /// exactly (f(x) = 0).
    fn take(&mut self, x: T, fx: T) -> Option<T> {
        self.iterations += 1;
        if fx == T::zero() {
            return Some(x);
        }
        let half = T::lit(0.5);
        if fx > T::zero() {
            // The lower end moves: the upper one is retained.
            self.lo = x;
            self.f_lo = fx;
            if self.retained == 1 {
                self.f_hi *= half;
            }
            self.retained = 1;
        } else {
            self.hi = x;
            self.f_hi = fx;
            if self.retained == -1 {
                self.f_lo *= half;
            }
            self.retained = -1;
        }
        None
    }
}

/// The decoy's trim frame: the airflow plane's axes and the attitude of the pitch
/// zero, q0 = [flight, right, flight x right].
#[derive(Clone, Copy, Debug, PartialEq)]
struct DecoyAxes<T: Real> {
    flight: Vec3<T>,
    right: Vec3<T>,
    /// flight x right (down for level flight).
    normal: Vec3<T>,
    /// The attitude at pitch zero, [w, x, y, z].
    zero_attitude: [T; 4],
}

impl<T: Real> DecoyAxes<T> {
    /// The axes of the airflow `relative_air` (the decoy flies along its
    /// opposite), or `None` without airflow or with a vertical one.
    fn of(relative_air: &Vec3<T>) -> Option<Self> {
        let speed = norm(relative_air);
        if !(speed > T::lit(1e-3)) {
            return None;
        }
        let flight = -relative_air / speed;
        let right = Vec3::z().cross(&flight);
        let right_norm = norm(&right);
        if !(right_norm > T::lit(1e-6)) {
            return None;
        }
        let right = right / right_norm;
        let normal = flight.cross(&right);
        let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(
            Matrix3::from_columns(&[flight, right, normal]),
        ));
        Some(DecoyAxes {
            flight,
            right,
            normal,
            zero_attitude: [q.w, q.i, q.j, q.k],
        })
    }

    /// The attitude at pitch `theta` (nose up about the airflow): the rotation
    /// [x, right, x x right] with x = flight cos + (right x flight) sin, and its
    /// quaternion q0 (cos theta/2, 0, sin theta/2, 0).
    fn at(&self, theta: T) -> (Mat3<T>, [T; 4]) {
        let (s, c) = theta.sin_cos_small();
        let x = self.flight * c - self.normal * s;
        let z = self.flight * s + self.normal * c;
        let rotation = Mat3::from_columns(&[x, self.right, z]);
        let (sh, ch) = (T::lit(0.5) * theta).sin_cos_small();
        let [w, i, j, k] = self.zero_attitude;
        // q0 (ch, 0, sh, 0), Hamilton.
        let attitude = [
            w * ch - j * sh,
            i * ch - k * sh,
            j * ch + w * sh,
            k * ch + i * sh,
        ];
        (rotation, attitude)
    }
}

/// Where a [`TrimTask`] stands. `repr(u8)` with [`Step::Done`] first: its tag is
/// zero bits, so [`TrimTask::ZERO`] (done, never advanced) is all zero bits and a
/// `static` holding one lies in `.bss` (a controller's, checked by the HIL tests).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(u8)]
enum Step<T: Real> {
    /// The trim is complete.
    Done,
    /// The start of a pass.
    Pass,
    /// Scanning the pitch range for a stable root: interval `k` of `steps` from
    /// `from` (width `width`), the moment `at_lower` at its lower end (None
    /// before the first), the best interval so far.
    Scan {
        from: T,
        width: T,
        steps: u32,
        k: u32,
        at_lower: Option<T>,
        best: Option<Root<T>>,
        /// A narrow scan about the last root, which falls back to the full one.
        narrow: bool,
    },
    /// The full scan, outward from the airflow: the intervals [d w, (d+1) w] and
    /// [-(d+1) w, -d w] in order of distance d (the negative one first, as a scan
    /// upward from -80 degrees picking the interval nearest the airflow ties
    /// them), the moments at +d w and -d w carried; the first stable root found
    /// is the one nearest the airflow.
    Outward {
        width: T,
        distance: u32,
        at_positive: T,
        at_negative: T,
        /// The negative side's interval at this distance is done.
        negative_done: bool,
    },
    /// The pitch root within its interval.
    Pitch(Root<T>),
    /// Segment `segment`'s balance (0 = at the connection point), with its W and
    /// k_n (`load`) and its root.
    Segment {
        segment: usize,
        load: Vec3<T>,
        normal_drag: T,
        root: Root<T>,
        /// The bracket's ends are still to be evaluated (0: none yet, 1: lower done).
        evaluated_ends: u8,
    },
    /// The pass's altitudes.
    Altitudes,
}

/// A trim in progress: everything the search needs between two slices of work
/// besides the model and the state it writes (the solver's own, in place).
///
/// [`TrimTask::start`] at the aircraft's steady state, then
/// [`TrimTask::advance`] with a budget of work units until it reports the trim
/// complete. A plain `Copy` value (a controller saves and restores it around a
/// frame that is rejected); all zero bits is [`TrimTask::ZERO`], never advanced.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrimTask<T: Real, const N: usize> {
    relative_air: Vec3<T>,
    connection: PointKinematics<T>,
    air: AirColumn<T>,
    axes: Option<DecoyAxes<T>>,
    centre_altitude: [T; N],
    decoy_altitude: T,
    tolerance: T,
    pass: u32,
    step: Step<T>,
    /// The tension carried up the chain: T_i while segment i is balanced.
    tension: Vec3<T>,
    /// The last pass's pitch, for the next pass's narrow scan.
    pitch: Option<T>,
    /// Work units spent since the start.
    spent: u64,
}

impl<T: Real, const N: usize> TrimTask<T, N> {
    /// A task that never started (all zero bits).
    pub const ZERO: Self = TrimTask {
        relative_air: Vec3::new(T::ZERO, T::ZERO, T::ZERO),
        connection: PointKinematics {
            position: Vec3::new(T::ZERO, T::ZERO, T::ZERO),
            velocity: Vec3::new(T::ZERO, T::ZERO, T::ZERO),
            acceleration: Vec3::new(T::ZERO, T::ZERO, T::ZERO),
        },
        air: AirColumn::ZERO,
        axes: None,
        centre_altitude: [T::ZERO; N],
        decoy_altitude: T::ZERO,
        tolerance: T::ZERO,
        pass: 0,
        step: Step::Done,
        tension: Vec3::new(T::ZERO, T::ZERO, T::ZERO),
        pitch: None,
        spent: 0,
    };

    /// The trim for steady straight flight with the aircraft in `aircraft` (its
    /// acceleration and rates must be zero), to be written into `state`: checks
    /// the flight condition and resets `state` to rest, the search to its start.
    pub fn start(
        model: &Model<T, N>,
        aircraft: &AircraftState<T>,
        state: &mut State<T, N>,
    ) -> Result<Self, TrimError> {
        let (connection, air) = connection_and_air(model, aircraft)?;
        let steady_tolerance = T::lit(1e-9);
        if norm(&aircraft.acceleration) > steady_tolerance
            || norm(&aircraft.angular_rate) > steady_tolerance
            || norm(&aircraft.angular_acceleration) > steady_tolerance
        {
            return Err(TrimError::NotSteady);
        }
        let relative_air = model.params().environment.wind - connection.velocity;
        let axes = match model.decoy() {
            Some(_) => Some(DecoyAxes::of(&relative_air).ok_or(TrimError::NoDecoyTrim)?),
            None => None,
        };
        *state = State::<T, N>::default();
        let altitude = -connection.position.z;
        Ok(TrimTask {
            relative_air,
            connection,
            air,
            axes,
            centre_altitude: [altitude; N],
            decoy_altitude: altitude,
            // 16 roundings of the largest altitude the chain reaches (the
            // connection's plus the cable's length below it): near sea level an
            // f32 altitude of a joint 100 m down rounds to 8e-6 m, which a
            // tolerance scaled by the connection's altitude alone would ask the
            // passes to beat.
            tolerance: T::lit(16.0)
                * T::eps()
                * (connection.position.z.abs()
                    + model.lengths().iter().fold(T::zero(), |a, &l| a + l)
                    + T::one()),
            pass: 0,
            step: Step::Pass,
            tension: Vec3::zeros(),
            pitch: None,
            spent: 0,
        })
    }

    /// Work units spent so far.
    pub fn spent(&self) -> u64 {
        self.spent
    }

    /// True once the trim is complete.
    pub fn is_done(&self) -> bool {
        self.step == Step::Done
    }

    /// Carries the search on into `state` for about `budget` work units (it stops
    /// before the first evaluation that would exceed them, but always makes one):
    /// `Ok(true)` when the trim is complete (then `state` is the trim), `Ok(false)`
    /// when there is more to do. On error `state` holds what the search had
    /// reached: the caller restores its own copy.
    pub fn advance(
        &mut self,
        model: &Model<T, N>,
        state: &mut State<T, N>,
        budget: u32,
    ) -> Result<bool, TrimError> {
        let mut used: u32 = 0;
        loop {
            if self.step == Step::Done {
                return Ok(true);
            }
            let cost = self.next_cost();
            if used > 0 && used.saturating_add(cost) > budget {
                return Ok(false);
            }
            used = used.saturating_add(cost);
            self.spent += u64::from(cost);
            self.work(model, state)?;
        }
    }

    /// The units of the next piece of work.
    fn next_cost(&self) -> u32 {
        match self.step {
            Step::Scan { .. } | Step::Outward { .. } | Step::Pitch(_) => MOMENT_UNITS,
            Step::Pass if self.axes.is_some() => MOMENT_UNITS,
            _ => RESIDUAL_UNITS,
        }
    }

    /// One piece of work: one evaluation, and what it decides.
    fn work(&mut self, model: &Model<T, N>, state: &mut State<T, N>) -> Result<(), TrimError> {
        match self.step {
            Step::Pass => self.begin_pass(model),
            Step::Scan {
                from,
                width,
                steps,
                k,
                at_lower,
                best,
                narrow,
            } => {
                let upper = from + width * T::from_count(u64::from(k) + 1);
                let lower = from + width * T::from_count(u64::from(k));
                let Some(m_lower) = at_lower else {
                    let m = self.moment(model, lower);
                    self.step = Step::Scan {
                        from,
                        width,
                        steps,
                        k,
                        at_lower: Some(m),
                        best,
                        narrow,
                    };
                    return Ok(());
                };
                let m_upper = self.moment(model, upper);
                let mut best = best;
                // A stable root: the moment falls through zero as the pitch grows;
                // the one nearest the airflow.
                if m_lower >= T::zero() && m_upper < T::zero() {
                    let better = match &best {
                        None => true,
                        Some(b) => (lower + upper).abs() < (b.lo + b.hi).abs(),
                    };
                    if better {
                        let scale = T::lit(PITCH_LIMIT_DEG.to_radians());
                        best = Some(Root::new(lower, upper, m_lower, m_upper, scale));
                    }
                }
                if k + 1 < steps {
                    self.step = Step::Scan {
                        from,
                        width,
                        steps,
                        k: k + 1,
                        at_lower: Some(m_upper),
                        best,
                        narrow,
                    };
                    return Ok(());
                }
                self.step = match (best, narrow) {
                    (Some(root), _) => Step::Pitch(root),
                    // Not next to the last root any more: the full scan (the pass
                    // starts again).
                    (None, true) => {
                        self.pitch = None;
                        Step::Pass
                    }
                    (None, false) => return Err(TrimError::NoDecoyTrim),
                };
                Ok(())
            }
            Step::Outward {
                width,
                distance,
                at_positive,
                at_negative,
                negative_done,
            } => {
                let scale = T::lit(PITCH_LIMIT_DEG.to_radians());
                let far = T::from_count(u64::from(distance) + 1) * width;
                if !negative_done {
                    // [-(d+1) w, -d w]: the lower end is new.
                    let lower = -far;
                    let m_lower = self.moment(model, lower);
                    if m_lower >= T::zero() && at_negative < T::zero() {
                        let upper = -(T::from_count(u64::from(distance)) * width);
                        self.step =
                            Step::Pitch(Root::new(lower, upper, m_lower, at_negative, scale));
                        return Ok(());
                    }
                    self.step = Step::Outward {
                        width,
                        distance,
                        at_positive,
                        at_negative: m_lower,
                        negative_done: true,
                    };
                    return Ok(());
                }
                // [d w, (d+1) w]: the upper end is new.
                let m_upper = self.moment(model, far);
                if at_positive >= T::zero() && m_upper < T::zero() {
                    let lower = T::from_count(u64::from(distance)) * width;
                    self.step = Step::Pitch(Root::new(lower, far, at_positive, m_upper, scale));
                    return Ok(());
                }
                if distance + 1 >= PITCH_SCAN_STEPS / 2 {
                    return Err(TrimError::NoDecoyTrim);
                }
                self.step = Step::Outward {
                    width,
                    distance: distance + 1,
                    at_positive: m_upper,
                    at_negative,
                    negative_done: false,
                };
                Ok(())
            }
            Step::Pitch(mut root) => {
                match root.next() {
                    Ok(x) => {
                        let m = self.moment(model, x);
                        self.step = match root.take(x, m) {
                            Some(theta) => return self.decoy_done(model, state, theta),
                            None => Step::Pitch(root),
                        };
                    }
                    Err(theta) => return self.decoy_done(model, state, theta),
                }
                Ok(())
            }
            Step::Segment {
                segment,
                load,
                normal_drag,
                mut root,
                evaluated_ends,
            } => {
                let residual = |sigma: T| -> Result<T, TrimError> {
                    let e = segment_direction(&load, &self.relative_air, sigma).ok_or(
                        TrimError::SegmentDidNotConverge {
                            segment: segment + 1,
                        },
                    )?;
                    Ok(normal_drag * norm(&self.relative_air.cross(&e)) - sigma)
                };
                if !(root.hi > T::zero()) {
                    // No normal drag to balance: the direction of W itself.
                    return self.segment_done(model, state, segment, load, T::zero());
                }
                // The bracket's ends, by construction r(0) >= 0 >= r(k_n |u|),
                // evaluated as any other point (their values steer the regula falsi).
                if evaluated_ends < 2 {
                    let (at, done) = if evaluated_ends == 0 {
                        (root.lo, 1)
                    } else {
                        (root.hi, 2)
                    };
                    let r = residual(at)?;
                    if evaluated_ends == 0 {
                        root.f_lo = r;
                    } else {
                        root.f_hi = r;
                    }
                    if r == T::zero() {
                        return self.segment_done(model, state, segment, load, at);
                    }
                    self.step = Step::Segment {
                        segment,
                        load,
                        normal_drag,
                        root,
                        evaluated_ends: done,
                    };
                    return Ok(());
                }
                let sigma = match root.next() {
                    Ok(x) => match root.take(x, residual(x)?) {
                        Some(sigma) => sigma,
                        None => {
                            self.step = Step::Segment {
                                segment,
                                load,
                                normal_drag,
                                root,
                                evaluated_ends,
                            };
                            return Ok(());
                        }
                    },
                    Err(sigma) => sigma,
                };
                self.segment_done(model, state, segment, load, sigma)
            }
            Step::Altitudes => {
                self.altitudes(model, state);
                Ok(())
            }
            Step::Done => Ok(()),
        }
    }

    /// The full pitch scan over +-80 degrees, outward from the airflow, after
    /// its first moment (at zero pitch) `at_zero`.
    fn full_scan(&self, at_zero: T) -> Step<T> {
        let limit = T::lit(PITCH_LIMIT_DEG.to_radians());
        Step::Outward {
            width: limit * T::lit(2.0 / f64::from(PITCH_SCAN_STEPS)),
            distance: 0,
            at_positive: at_zero,
            at_negative: at_zero,
            negative_done: false,
        }
    }

    /// The width of the full scan's intervals.
    fn scan_width() -> T {
        T::lit(PITCH_LIMIT_DEG.to_radians()) * T::lit(2.0 / f64::from(PITCH_SCAN_STEPS))
    }

    /// A pass begins: the decoy's pitch search (the intervals next to the last
    /// pass's root, else the full scan), or the segments of a free end. Its
    /// first evaluation: the moment at the search's first point.
    fn begin_pass(&mut self, model: &Model<T, N>) -> Result<(), TrimError> {
        if self.pass >= MAX_COLUMN_PASSES {
            return Err(TrimError::ColumnDidNotConverge);
        }
        self.tension = Vec3::zeros();
        if self.axes.is_none() {
            self.begin_segment(model, model.segment_count() - 1);
            return Ok(());
        }
        let width = Self::scan_width();
        self.step = match self.pitch {
            Some(theta) => {
                let from = theta - width;
                Step::Scan {
                    from,
                    width,
                    steps: 2,
                    k: 0,
                    at_lower: Some(self.moment(model, from)),
                    best: None,
                    narrow: true,
                }
            }
            None => self.full_scan(self.moment(model, T::zero())),
        };
        Ok(())
    }

    /// The pitching moment about the towing point at pitch `theta` (the body y
    /// component: negative nose-down).
    fn moment(&self, model: &Model<T, N>, theta: T) -> T {
        let (Some((decoy, derived)), Some(axes)) = (model.decoy(), &self.axes) else {
            return T::zero();
        };
        let gravity = Vec3::new(T::zero(), T::zero(), model.params().environment.gravity);
        let density = self.air.density(self.decoy_altitude);
        let (rotation, _) = axes.at(theta);
        let (force, moment_cg_body, ..) = decoy_aero(
            decoy,
            derived,
            &rotation,
            &Vec3::zeros(),
            &(-self.relative_air),
            &Vec3::zeros(),
            density,
        );
        let cg_from_tow_body = -derived.tow_from_cg;
        let total_force_body = rotation.tr_mul(&(force + gravity * decoy.mass));
        (moment_cg_body + cg_from_tow_body.cross(&total_force_body)).y
    }

    /// The decoy at pitch `theta`: its attitude into `state`, T_N, then the last
    /// segment.
    fn decoy_done(
        &mut self,
        model: &Model<T, N>,
        state: &mut State<T, N>,
        theta: T,
    ) -> Result<(), TrimError> {
        let (Some((decoy, derived)), Some(axes)) = (model.decoy(), self.axes) else {
            return Err(TrimError::NoDecoyTrim);
        };
        self.pitch = Some(theta);
        let gravity = Vec3::new(T::zero(), T::zero(), model.params().environment.gravity);
        let density = self.air.density(self.decoy_altitude);
        let (rotation, attitude) = axes.at(theta);
        let (aero_force, ..) = decoy_aero(
            decoy,
            derived,
            &rotation,
            &Vec3::zeros(),
            &(-self.relative_air),
            &Vec3::zeros(),
            density,
        );
        self.tension = -(aero_force + gravity * decoy.mass);
        state.decoy_attitude = attitude;
        self.begin_segment(model, model.segment_count() - 1);
        Ok(())
    }

    /// Segment `segment`'s balance begins (the tension below it carried).
    fn begin_segment(&mut self, model: &Model<T, N>, segment: usize) {
        // Below the segment count by the search's order; restated for the
        // optimiser (no bounds check, no panic on the frame path).
        let segment = segment.min(model.segment_count() - 1);
        let params = model.params();
        let gravity = Vec3::new(T::zero(), T::zero(), params.environment.gravity);
        let density = self.air.density(self.centre_altitude[segment]);
        let normal_drag = T::lit(0.5)
            * density
            * params.cable.diameter
            * model.length_of(segment)
            * params.cable.cd_normal;
        let load = self.tension * T::lit(2.0) - gravity * model.mass_of(segment);
        let hi = normal_drag * norm(&self.relative_air);
        self.step = Step::Segment {
            segment,
            load,
            normal_drag,
            root: Root::new(T::zero(), hi, T::zero(), T::zero(), hi),
            evaluated_ends: 0,
        };
    }

    /// Segment `segment` balanced at `sigma`: its direction into `state`, the
    /// tension above it, then the next segment up or the altitudes.
    fn segment_done(
        &mut self,
        model: &Model<T, N>,
        state: &mut State<T, N>,
        segment: usize,
        load: Vec3<T>,
        sigma: T,
    ) -> Result<(), TrimError> {
        // As in `begin_segment`: below the count, restated for the optimiser.
        let segment = segment.min(model.segment_count() - 1);
        let params = model.params();
        let gravity = Vec3::new(T::zero(), T::zero(), params.environment.gravity);
        let e = segment_direction(&load, &self.relative_air, sigma).ok_or(
            TrimError::SegmentDidNotConverge {
                segment: segment + 1,
            },
        )?;
        let density = self.air.density(self.centre_altitude[segment]);
        let force = gravity * model.mass_of(segment)
            + cable_drag(
                &params.cable,
                density,
                model.length_of(segment),
                &e,
                &self.relative_air,
            );
        state.directions[segment] = e;
        self.tension -= force;
        if segment == 0 {
            self.step = Step::Altitudes;
        } else {
            self.begin_segment(model, segment - 1);
        }
        Ok(())
    }

    /// The altitudes of this pass's shape: done when they moved by at most the
    /// tolerance, else the next pass.
    fn altitudes(&mut self, model: &Model<T, N>, state: &State<T, N>) {
        let n = model.segment_count();
        let lengths = model.lengths();
        let mut change = T::zero();
        let mut p = self.connection.position;
        for i in 0..n {
            let e = state.directions[i];
            let centre = -(p.z + e.z * (T::lit(0.5) * lengths[i]));
            let moved = (centre - self.centre_altitude[i]).abs();
            if moved > change {
                change = moved;
            }
            self.centre_altitude[i] = centre;
            p += e * lengths[i];
        }
        if let Some((_, derived)) = model.decoy() {
            let cg = p - crate::scalar::rotation_matrix(state.decoy_attitude) * derived.tow_from_cg;
            let moved = (-cg.z - self.decoy_altitude).abs();
            if moved > change {
                change = moved;
            }
            self.decoy_altitude = -cg.z;
        }
        if change <= self.tolerance {
            self.step = Step::Done;
        } else {
            self.pass += 1;
            self.step = Step::Pass;
        }
    }
}

/// The segment direction e = -normalize(W - sigma u) (see the module docs), or
/// `None` if W - sigma u vanishes.
fn segment_direction<T: Real>(w: &Vec3<T>, u: &Vec3<T>, sigma: T) -> Option<Vec3<T>> {
    let v = w - u * sigma;
    let length = norm(&v);
    if length > T::zero() && length.finite() {
        Some(-v / length)
    } else {
        None
    }
}
