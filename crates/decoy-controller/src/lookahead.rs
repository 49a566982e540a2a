//! The look-ahead: a copy of the controller's solution flown forward over a
//! horizon with the aircraft holding its current manoeuvre, and what it predicts
//! for each requirement (the worst margin over the horizon and when, if at all,
//! the margin falls below zero).
//!
//! **The held manoeuvre** ([`HeldManoeuvre`]), from the aircraft's state at the
//! prediction's start (t0): the body rates stay constant in the body frame (the
//! attitude keeps rotating at them; angular acceleration zero); the velocity
//! direction turns with the body (the angle of attack and sideslip are held); the
//! along-path acceleration (the acceleration's component along the velocity) is
//! held, so the speed changes linearly (floored at half the initial speed); the
//! normal acceleration (the rest of the acceleration, the load factor) is held in
//! the body frame, turning with it. The position, which enters the solution only
//! through the air density, is p0 + v0 τ + a0 τ²/2 + j0 τ³/6 (j0 the rate of
//! change of that acceleration at t0; 5 m off after 3 s of a 0.2 rad/s pull-up).
//!
//! **The work** is spread over frames: each accepted State frame, after its
//! Output is computed (the real-time solution is never changed or delayed by the
//! prediction), runs at most `prediction_steps_per_frame` RK4 steps of the copy.
//! A prediction starts from the solution of the frame after the previous one
//! completed (or at once when the aircraft leaves the manoeuvre the prediction
//! holds: [`HeldManoeuvre::departs_from`]), so a new one completes every horizon / (steps per frame x step)
//! frames; a violation it finds on the way is reported at once (the advisory
//! does not wait for the rest of the horizon). Each step is at most `prediction_max_step_s` and at most the
//! controller's wave-speed limit ([`crate::wave::WAVE_STEP_FACTOR`]) at the
//! copy's last tensions. The predicted state is measured on every third step
//! (and at the horizon's end): at most 18 ms between the samples of the margins
//! (the measures cost about a fifth of a step; the slice's instruction budget). A step that fails ends the prediction at the time reached.
//!
//! **The copy is a coarser model, or the same** ([`prediction_params`]):
//! `[management] prediction_segments` segments graded as the controller's (the
//! same ratio), the same cable, decoy and environment. With fewer segments than
//! the controller's the shortest segment, at the decoy, whose wave-speed limit
//! sets the step in a snatch, is longer, and the same slice of work flies
//! further ahead (with the earlier embedded model, 16 segments at ratio 1.3, 12
//! in the copy had 1.35 m at the decoy instead of 0.46 m). The reference
//! system's embedded model has 12 segments graded 1.26 (issue 14) and its copy
//! is that same model, stepped at its own longer steps (up to 12 ms). A prediction starts from the controller's
//! solution mapped onto it ([`coarse_state`]). A copy of more than `P` segments
//! does not exist: that controller has no look-ahead (its reports say so: no
//! prediction ever completes).

use nalgebra::{Quaternion, UnitQuaternion};
use solver_core::{
    AircraftState, FlightPath, Model, ModelParams, Outputs, Real, SegmentLayout, Solver, State,
    Vec3,
};

use crate::geometry::Geometry;
use crate::monitor::{ManagementConfig, Measures, tension_margin_of};
use crate::wave::{WAVE_STEP_FACTOR, wave_rate_of};
use decoy_schema::{PerRequirement, Requirement};

/// The shortest look-ahead step, s: a step that fails at this length ends the
/// prediction at the time reached.
const MIN_STEP_S: f64 = 2.5e-4;

/// The aircraft holding the manoeuvre it flies at t0 (see the module's documentation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HeldManoeuvre<T: Real> {
    t0: f64,
    position: Vec3<T>,
    velocity: Vec3<T>,
    acceleration: Vec3<T>,
    attitude: UnitQuaternion<T>,
    body_rate: Vec3<T>,
    /// Body rate in NED at t0.
    rate_ned: Vec3<T>,
    speed: T,
    direction: Vec3<T>,
    along: T,
    normal: Vec3<T>,
    /// Rate of change of the acceleration at t0, NED (the position's third term).
    jerk: Vec3<T>,
}

impl<T: Real> HeldManoeuvre<T> {
    /// Every field zero (the quaternion's included, so not a rotation): only
    /// the placeholder of [`Lookahead::UNCONFIGURED`], never flown.
    const ZERO: Self = {
        let z = Vec3::new(T::ZERO, T::ZERO, T::ZERO);
        HeldManoeuvre {
            t0: 0.0,
            position: z,
            velocity: z,
            acceleration: z,
            attitude: UnitQuaternion::new_unchecked(Quaternion::new(
                T::ZERO,
                T::ZERO,
                T::ZERO,
                T::ZERO,
            )),
            body_rate: z,
            rate_ned: z,
            speed: T::ZERO,
            direction: z,
            along: T::ZERO,
            normal: z,
            jerk: z,
        }
    };

    /// The manoeuvre `aircraft` flies at time `t0`.
    pub fn new(t0: f64, aircraft: &AircraftState<T>) -> Self {
        let attitude = aircraft.rotation();
        let speed = aircraft.velocity.norm();
        let direction = if speed > T::zero() {
            aircraft.velocity / speed
        } else {
            attitude * Vec3::x()
        };
        let along = aircraft.acceleration.dot(&direction);
        let rate_ned = attitude * aircraft.angular_rate;
        let normal = aircraft.acceleration - direction * along;
        HeldManoeuvre {
            t0,
            position: aircraft.position,
            velocity: aircraft.velocity,
            acceleration: aircraft.acceleration,
            attitude,
            body_rate: aircraft.angular_rate,
            rate_ned,
            speed,
            direction,
            along,
            normal,
            jerk: rate_ned.cross(&(direction * along + normal)),
        }
    }
}

/// A change of body rate beyond which the aircraft flies another manoeuvre, rad/s.
pub const MANOEUVRE_CHANGE_RADPS: f64 = 0.05;
/// A change of acceleration beyond which the aircraft flies another manoeuvre, m/s².
pub const MANOEUVRE_CHANGE_MPS2: f64 = 5.0;

impl<T: Real> HeldManoeuvre<T> {
    /// Whether `aircraft` (at a later time) no longer flies this manoeuvre: its
    /// body rate differs by more than [`MANOEUVRE_CHANGE_RADPS`] or its
    /// acceleration by more than [`MANOEUVRE_CHANGE_MPS2`] from the held ones
    /// at its time.
    pub fn departs_from(&self, aircraft: &AircraftState<T>) -> bool {
        let rate = (aircraft.angular_rate - self.body_rate).norm();
        let held = self.acceleration_at(aircraft);
        let accel = (aircraft.acceleration - held).norm();
        rate > T::lit(MANOEUVRE_CHANGE_RADPS) || accel > T::lit(MANOEUVRE_CHANGE_MPS2)
    }

    /// The held acceleration with the velocity direction of `aircraft`: the
    /// along-path part along it and the normal part turned as the body turned.
    fn acceleration_at(&self, aircraft: &AircraftState<T>) -> Vec3<T> {
        let turn = aircraft.rotation() * self.attitude.inverse();
        let speed = aircraft.velocity.norm();
        let direction = if speed > T::zero() {
            aircraft.velocity / speed
        } else {
            turn * self.direction
        };
        direction * self.along + turn * self.normal
    }
}

impl<T: Real> FlightPath<T> for HeldManoeuvre<T> {
    fn state_at(&self, t: f64) -> AircraftState<T> {
        let tau = T::lit(t - self.t0);
        // The body's rotation since t0, in NED: constant body rates are a
        // constant NED rate too (the rate's axis turns with the body about itself).
        let turn = UnitQuaternion::from_scaled_axis(self.rate_ned * tau);
        let attitude = turn * self.attitude;
        let direction = turn * self.direction;
        let speed = (self.speed + self.along * tau).max(self.speed * T::lit(0.5));
        let half = T::lit(0.5);
        let q = attitude.into_inner();
        AircraftState {
            position: self.position
                + self.velocity * tau
                + self.acceleration * (half * tau * tau)
                + self.jerk * (tau * tau * tau * T::lit(1.0 / 6.0)),
            velocity: direction * speed,
            acceleration: direction * self.along + turn * self.normal,
            attitude: [q.w, q.i, q.j, q.k],
            angular_rate: self.body_rate,
            angular_acceleration: Vec3::zeros(),
        }
    }
}

/// What one completed prediction found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Prediction<T: Real> {
    /// Time of the state it started from, s.
    pub from: f64,
    /// Horizon reached, s (the configured one unless a step failed).
    pub horizon: f64,
    /// Smallest margin over the horizon, per requirement (in its unit).
    pub worst: PerRequirement<T>,
    /// Time at which each margin first falls below zero, s (absolute).
    pub violation_at: PerRequirement<Option<f64>>,
}

/// A prediction under way.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Running<T: Real> {
    path: HeldManoeuvre<T>,
    from: f64,
    worst: PerRequirement<T>,
    violation_at: PerRequirement<Option<f64>>,
    /// Pitch and yaw ranges over the prediction, rad: [min, max] per axis.
    ranges: [[T; 2]; 2],
    /// Wave-speed rate of the copy's last evaluation, 1/s.
    wave_rate: T,
    /// Steps accepted so far: the measures are taken on every third one (and
    /// at the horizon's end).
    accepted: u32,
}

/// The look-ahead: the copy, the prediction under way and the last completed one.
#[derive(Clone, Debug)]
pub struct Lookahead<T: Real, const P: usize> {
    /// The copy (configured only when `available`).
    solver: Solver<T, P>,
    /// The model fits `P`: there is a copy to fly.
    available: bool,
    running: Option<Running<T>>,
    last: Option<Prediction<T>>,
}

impl<T: Real, const P: usize> PartialEq for Lookahead<T, P> {
    fn eq(&self, other: &Self) -> bool {
        self.running == other.running
            && self.last == other.last
            && self.available == other.available
            && (!self.available || self.solver.state() == other.solver.state())
    }
}

impl<T: Real, const P: usize> Lookahead<T, P> {
    /// A look-ahead with no model, as a constant of all zero bits (its solver
    /// is [`Solver::UNCONFIGURED`]): see `Controller::UNCONFIGURED`.
    pub const UNCONFIGURED: Self = Lookahead {
        solver: Solver::UNCONFIGURED,
        available: false,
        // `Some` of zero values rather than `None`: these options keep `None` in
        // the niche of an inner `Option<f64>`'s tag (nonzero bits), and the
        // constant must be all zero bits to lie in `.bss`. Never read: an
        // unavailable look-ahead does no work, and `configure` clears both.
        running: Some(Running {
            path: HeldManoeuvre::ZERO,
            from: 0.0,
            worst: PerRequirement::splat(T::ZERO),
            violation_at: PerRequirement::splat(None),
            ranges: [[T::ZERO; 2]; 2],
            wave_rate: T::ZERO,
            accepted: 0,
        }),
        last: Some(Prediction {
            from: 0.0,
            horizon: 0.0,
            worst: PerRequirement::splat(T::ZERO),
            violation_at: PerRequirement::splat(None),
        }),
    };

    /// A look-ahead for `model` with a copy of `segments` segments
    /// ([`prediction_params`]; none if that has more than `P` segments).
    pub fn new<const N: usize>(model: &Model<T, N>, segments: usize) -> Self {
        let mut lookahead = Self::UNCONFIGURED;
        lookahead.configure(model.params(), segments);
        lookahead
    }

    /// Makes this the look-ahead of the model of `params`, in place (nothing
    /// solver-sized passes through the stack); none if the model has more than
    /// `P` segments or does not build. Forgets every prediction.
    pub fn configure(&mut self, params: &ModelParams<T>, segments: usize) {
        self.available = self
            .solver
            .configure(&prediction_params(params, segments))
            .is_ok();
        self.reset();
    }

    /// The copy's model (when [`Lookahead::available`]).
    pub fn model(&self) -> &Model<T, P> {
        self.solver.model()
    }

    /// Whether there is a copy to fly (the model fits `P`).
    pub fn available(&self) -> bool {
        self.available
    }

    /// Forgets every prediction (a new run).
    pub fn reset(&mut self) {
        self.running = None;
        self.last = None;
    }

    /// The last completed prediction.
    pub fn last(&self) -> Option<&Prediction<T>> {
        self.last.as_ref()
    }

    /// Whether a prediction is under way.
    pub fn is_running(&self) -> bool {
        self.running.is_some()
    }

    /// The violations the prediction under way has found so far (absolute
    /// times): an advisory need not wait for the whole horizon.
    pub fn running_violations(&self) -> PerRequirement<Option<f64>> {
        self.running
            .map_or(PerRequirement::splat(None), |r| r.violation_at)
    }

    /// The first, cheap part of a frame's slice, at the accepted frame: starts
    /// a prediction from `state` (the accepted solution at its time, `aircraft`
    /// the aircraft there, `wave_rate` its wave-speed rate, `measures` its
    /// measures) unless one is under way whose manoeuvre the aircraft still
    /// flies. Reads `state` only here, so that [`Lookahead::advance`] may run
    /// later (after the frame's answer is sent) or elsewhere (another thread).
    pub fn begin<const N: usize>(
        &mut self,
        state: &State<T, N>,
        lengths: &[T],
        aircraft: &AircraftState<T>,
        wave_rate: T,
        measures: &Measures<T>,
        config: &ManagementConfig<T>,
    ) {
        if !self.available {
            return;
        }
        // A prediction whose manoeuvre the aircraft no longer flies (the pull-up
        // stopped rotating, a turn began) is abandoned for a new one from now.
        if self.running.is_some_and(|r| !r.path.departs_from(aircraft)) {
            return;
        }
        self.running = None;
        let copy = coarse_state(state, lengths, self.solver.model().lengths());
        if self.solver.set_state(copy).is_err() {
            return;
        }
        let [p, y] = measures.pitch_yaw;
        let mut r = Running {
            path: HeldManoeuvre::new(state.time, aircraft),
            from: state.time,
            worst: PerRequirement::splat(T::lit(f64::INFINITY)),
            violation_at: PerRequirement::splat(None),
            ranges: [[p, p], [y, y]],
            wave_rate,
            accepted: 0,
        };
        r.take(measures, config);
        self.running = Some(r);
    }

    /// The frame's slice of prediction steps: at most the configured steps of
    /// the prediction under way ([`Lookahead::begin`]); a prediction that
    /// reaches its horizon becomes the last completed one. Returns the steps
    /// taken.
    pub fn advance(&mut self, geometry: &Geometry<T>, config: &ManagementConfig<T>) -> u32 {
        if !self.available {
            return 0;
        }
        let Some(mut running) = self.running else {
            return 0;
        };
        let solver = &mut self.solver;
        let end = running.from + config.horizon_s;
        let mut steps = 0;
        let mut done = false;
        while steps < config.prediction_steps_per_frame {
            let t = solver.state().time;
            let remaining = end - t;
            if remaining <= 1e-9 {
                done = true;
                break;
            }
            let wave = if running.wave_rate > T::zero() {
                WAVE_STEP_FACTOR / running.wave_rate.to_f64()
            } else {
                f64::INFINITY
            };
            let h = config.prediction_max_step_s.min(wave).min(remaining);
            steps += 1;
            let before = *solver.state();
            let measure = running.accepted % 3 == 2 || remaining - h <= 1e-9;
            let stepped = solver.step(&running.path, h).and_then(|()| {
                let out = solver.outputs(&running.path)?;
                // The full measures on every third step; the tensions on every
                // step (a snatch's dip or peak lasts a few steps).
                let measures = if measure {
                    let aircraft = running.path.state_at(out.time());
                    Some(Measures::of(&out, &aircraft, geometry, config))
                } else {
                    None
                };
                let tensions = tension_extremes(&out);
                Ok((measures, tensions, wave_rate_of(solver)))
            });
            match stepped {
                // The tensions at the step's end ask for a shorter step than
                // taken (they rose within it, a snatch): again from the step's
                // start with what they ask (as the controller's own rule does).
                Ok((_, _, rate))
                    if h > MIN_STEP_S && T::lit(h) * rate > T::lit(WAVE_STEP_FACTOR) =>
                {
                    let _ = solver.set_state(before);
                    running.wave_rate = rate;
                }
                Ok((m, tensions, rate)) => {
                    match m {
                        Some(m) => running.take(&m, config),
                        None => running.take_tensions(tensions, solver.state().time, config),
                    }
                    running.accepted += 1;
                    running.wave_rate = rate;
                }
                Err(_) if h > MIN_STEP_S => {
                    // A snatch load raised the tensions within the step: again
                    // from the step's start with a step as short as the wave
                    // speed then asks, at most half (this counts as a step).
                    let _ = solver.set_state(before);
                    running.wave_rate = running.wave_rate.max(T::lit(2.0 * WAVE_STEP_FACTOR / h));
                }
                Err(_) => {
                    done = true;
                    break;
                }
            }
        }
        if done || solver.state().time >= end - 1e-9 {
            self.last = Some(Prediction {
                from: running.from,
                horizon: solver.state().time - running.from,
                worst: running.worst,
                violation_at: running.violation_at,
            });
            self.running = None;
        } else {
            self.running = Some(running);
        }
        steps
    }
}

/// The lowest and highest joint tensions of `out`, N.
fn tension_extremes<T: Real, const N: usize>(out: &Outputs<'_, T, N>) -> [T; 2] {
    let first = out.tension(0);
    (1..=out.segment_count()).fold([first, first], |[lo, hi], j| {
        let t = out.tension(j);
        [lo.min(t), hi.max(t)]
    })
}

impl<T: Real> Running<T> {
    /// Takes the tension margin of a predicted state whose other measures are
    /// not taken: its lowest and highest joint `tensions` at `time`.
    fn take_tensions(&mut self, tensions: [T; 2], time: f64, config: &ManagementConfig<T>) {
        let (margin, _) = tension_margin_of(tensions, config);
        self.worst.tension = self.worst.tension.min(margin);
        if margin < T::zero() && self.violation_at.tension.is_none() {
            self.violation_at.tension = Some(time);
        }
    }

    /// Takes one predicted state's measures.
    fn take(&mut self, m: &Measures<T>, config: &ManagementConfig<T>) {
        let mut margins = m.instant_margins(config);
        let half = T::lit(0.5);
        let mut amplitude = T::zero();
        for (axis, range) in self.ranges.iter_mut().enumerate() {
            range[0] = range[0].min(m.pitch_yaw[axis]);
            range[1] = range[1].max(m.pitch_yaw[axis]);
            amplitude = amplitude.max((range[1] - range[0]) * half);
        }
        margins.posture = margins.posture.min(config.amplitude_limit - amplitude);
        for requirement in Requirement::ALL {
            let margin = margins[requirement];
            let worst = &mut self.worst[requirement];
            *worst = worst.min(margin);
            let at = &mut self.violation_at[requirement];
            if margin < T::zero() && at.is_none() {
                *at = Some(m.time);
            }
        }
    }
}

/// The copy's model for the controller's model `params`: `segments` segments
/// graded as the controller's (the same ratio, or uniform), the same cable,
/// decoy and environment. With fewer segments than the controller's the
/// longest segment, at the aircraft, stays about as long (the cable's path past
/// the plume is resolved alike) while the shortest, at the decoy, whose
/// wave-speed limit sets the step, is longer. A `segments` of 0, or more than
/// the controller's, keeps the controller's model.
pub fn prediction_params<T: Real>(params: &ModelParams<T>, segments: usize) -> ModelParams<T> {
    let count = params.layout.count();
    if segments == 0 || segments >= count {
        return *params;
    }
    let layout = match params.layout {
        SegmentLayout::Uniform { .. } => SegmentLayout::Uniform { count: segments },
        SegmentLayout::Graded { ratio, .. } => SegmentLayout::Graded {
            count: segments,
            ratio,
        },
    };
    ModelParams { layout, ..*params }
}

/// The controller's `state` (segment `lengths`, from the connection point) on
/// the copy's model (segment `coarse` lengths, the same cable): the copy's
/// joints at the same arc lengths along the cable as the controller's cable
/// has them (a point inside a segment moves with it), each of the copy's
/// segments along the chord between its joints and turning at the rate that
/// moves the chord's end relative to its start (`e × v / |c|`, v the relative
/// velocity, perpendicular to `e`); the decoy as it is. Where the controller's
/// segments bend the chord is shorter than the copy's segment by the bend (1 -
/// cos of the kink angle), and the decoy sits that much further from the
/// aircraft in the copy.
pub fn coarse_state<T: Real, const N: usize, const P: usize>(
    state: &State<T, N>,
    lengths: &[T],
    coarse: &[T],
) -> State<T, P> {
    let mut copy = State::<T, P> {
        time: state.time,
        ..State::default()
    };
    // Walks the controller's cable once: `i` its segment, `p`/`v` the position
    // and velocity of its joint i relative to the connection point, `s` its
    // arc length.
    let mut i = 0;
    let mut p = Vec3::zeros();
    let mut v = Vec3::zeros();
    let mut s = T::zero();
    let mut start = (Vec3::zeros(), Vec3::zeros());
    let mut target = T::zero();
    for (k, l) in coarse.iter().enumerate().take(P) {
        target += *l;
        let last = k + 1 == coarse.len();
        while i < lengths.len() && (last || s + lengths[i] <= target) {
            p += state.directions[i] * lengths[i];
            v += state.rates[i].cross(&(state.directions[i] * lengths[i]));
            s += lengths[i];
            i += 1;
        }
        let end = if i < lengths.len() && !last {
            let f = ((target - s) / lengths[i]).max(T::zero()).min(T::one());
            let arm = state.directions[i] * (lengths[i] * f);
            (p + arm, v + state.rates[i].cross(&arm))
        } else {
            (p, v)
        };
        let chord = end.0 - start.0;
        let length = chord.norm();
        if length > T::zero() {
            let e = chord / length;
            copy.directions[k] = e;
            copy.rates[k] = e.cross(&(end.1 - start.1)) / length;
        }
        start = end;
    }
    copy.decoy_attitude = state.decoy_attitude;
    copy.decoy_rate = state.decoy_rate;
    copy
}

#[cfg(test)]
mod tests {
    use super::*;
    use solver_core::profiles::{LevelTurn, PullUp};

    /// A bent, turning cable of 16 graded segments (ratio 1.3, 100 m).
    fn fine_cable() -> ([f64; 16], State<f64, 16>) {
        let r: f64 = 1.3;
        let l0 = 100.0 * (r - 1.0) / (r.powi(16) - 1.0);
        let lengths = core::array::from_fn(|i| l0 * r.powi(15 - i as i32));
        let mut state = State::<f64, 16> {
            time: 2.5,
            ..State::default()
        };
        for i in 0..16 {
            let a = 0.1 + 0.02 * i as f64;
            let e = Vec3::new(
                -libm::cos(a),
                0.05 * libm::sin(0.3 * i as f64),
                libm::sin(a),
            )
            .normalize();
            let w = Vec3::new(0.01 * i as f64, -0.2, 0.03);
            state.directions[i] = e;
            state.rates[i] = w - e * w.dot(&e);
        }
        state.decoy_attitude = [0.9, 0.1, -0.2, 0.1];
        state.decoy_rate = Vec3::new(0.1, 0.2, 0.3);
        (lengths, state)
    }

    /// On a model of the same segments the mapping is the identity; on a
    /// coarser one the joints lie on the cable at their arc lengths (the end
    /// at the controller's towing point to the bend), and a cable turning
    /// rigidly keeps its rate.
    #[test]
    fn the_coarse_state_lies_on_the_cable() {
        let (lengths, state) = fine_cable();
        let same: State<f64, 16> = coarse_state(&state, &lengths, &lengths);
        for i in 0..16 {
            assert!(
                (same.directions[i] - state.directions[i]).norm() < 1e-12,
                "{i}"
            );
            assert!((same.rates[i] - state.rates[i]).norm() < 1e-12, "{i}");
        }
        assert_eq!(same.decoy_attitude, state.decoy_attitude);
        assert_eq!(same.time, state.time);
        // 12 segments graded 1.3 over the same 100 m.
        let r: f64 = 1.3;
        let l0 = 100.0 * (r - 1.0) / (r.powi(12) - 1.0);
        let coarse: [f64; 12] = core::array::from_fn(|i| l0 * r.powi(11 - i as i32));
        let copy: State<f64, 12> = coarse_state(&state, &lengths, &coarse);
        let fine_end: Vec3<f64> = (0..16).map(|i| state.directions[i] * lengths[i]).sum();
        let coarse_end: Vec3<f64> = (0..12).map(|k| copy.directions[k] * coarse[k]).sum();
        // The chords are shorter than the segments by the bend: well under 1 %.
        assert!(
            (coarse_end - fine_end).norm() < 0.3,
            "{coarse_end} {fine_end}"
        );
        for k in 0..12 {
            assert!((copy.directions[k].norm() - 1.0).abs() < 1e-12);
            assert!(copy.rates[k].dot(&copy.directions[k]).abs() < 1e-12);
        }
        // A straight cable turning as one body at w: every segment turns at w.
        let mut rigid = state;
        let e = Vec3::new(-0.9, 0.1, 0.4).normalize();
        let w = Vec3::new(0.0, -0.3, 0.1);
        for i in 0..16 {
            rigid.directions[i] = e;
            rigid.rates[i] = w - e * w.dot(&e);
        }
        let copy: State<f64, 12> = coarse_state(&rigid, &lengths, &coarse);
        for k in 0..12 {
            assert!((copy.directions[k] - e).norm() < 1e-12, "{k}");
            assert!((copy.rates[k] - rigid.rates[0]).norm() < 1e-12, "{k}");
        }
    }

    /// Holding a constant-rate manoeuvre reproduces it: a pull-up and a
    /// coordinated turn extrapolated from one instant follow the profile.
    #[test]
    fn a_held_constant_manoeuvre_is_the_manoeuvre() {
        let pull = PullUp {
            altitude: 9000.0,
            speed: 180.0,
            start: 0.0,
            rate: 0.2,
            duration: 100.0,
        };
        let turn = LevelTurn {
            altitude: 9000.0,
            speed: 240.0,
            start: 0.0,
            rate: 0.2,
            gravity: 9.80665,
        };
        let paths: [&dyn FlightPath<f64>; 2] = [&pull, &turn];
        for path in paths {
            let held = HeldManoeuvre::new(1.0, &path.state_at(1.0));
            for tau in [0.5, 1.0, 2.0, 3.0] {
                let a: AircraftState<f64> = held.state_at(1.0 + tau);
                let b = path.state_at(1.0 + tau);
                assert!((a.velocity - b.velocity).norm() < 1e-6 * 240.0, "{tau}");
                assert!((a.acceleration - b.acceleration).norm() < 1e-3, "{tau}");
                let qa = a.rotation();
                let qb = b.rotation();
                assert!(qa.angle_to(&qb) < 1e-6, "{tau}");
                // Position to third order: V w^3 tau^4 / 24, 5 m after 3 s at
                // 0.2 rad/s (the altitude enters only through the air density).
                let bound = 240.0 * 0.008 * tau.powi(4) / 24.0 * 1.1 + 1e-6;
                assert!((a.position - b.position).norm() < bound, "{tau}");
            }
        }
    }
}
