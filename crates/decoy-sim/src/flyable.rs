//! Flyable manoeuvres: the pull-up and the turn entered and left at a finite
//! angular acceleration ([`Flyable`]), on the host.
//!
//! The paper's profiles (solver-core's `PullUp` and `LevelTurn`, which the
//! controller also flies) step the rotation rate: at the pull-up's start and end
//! its pitch rate jumps between 0 and w, and at the turn's start its heading
//! rate does (with the bank). With the connection point 2 m aft of and 1.7 m
//! below the aircraft's reference point, each step makes the connection point's
//! velocity jump by w |r| (0.26 m/s at 0.10 rad/s), which no aircraft can do. A
//! flyable manoeuvre changes its rate (the pull-up's pitch rate, the turn's
//! bank) over `onset` seconds along a smootherstep, S(x) = 10 x^3 - 15 x^4 +
//! 6 x^5 of x = tau / T: the rate and the angular acceleration are continuous
//! (0 at both ends of the onset), so the connection point's velocity and
//! acceleration are too.
//!
//! **Pull-up** (start s, rate w, duration D, onset T): the flight-path angle's
//! rate is w S(tau / T) for tau = t - s in [0, T), w in [T, D), w (1 - S((tau -
//! D) / T)) in [D, D + T), then 0: the same climb angle w D as the step profile,
//! the rotation half an onset later; the pitch acceleration peaks at 1.875 w /
//! T. Pitch equals the flight-path angle, the speed is constant. It needs T <= D.
//!
//! **Turn** (start s, rate w, onset T): the aircraft rolls to the coordinated
//! bank phi_w = atan(V w / g) along phi_w S(tau / T) (the roll rate peaks at
//! 1.875 phi_w / T), the heading rate the coordinated g tan(phi) / V at every
//! instant, so that it reaches w as the roll ends; then the step profile's turn.
//! (A heading rate built along the smootherstep instead would do most of the
//! bank in the first third of the onset, the bank being atan of the rate.)
//!
//! Where the rate is constant the position is the step profile's closed form
//! (an arc). Over an onset the pull-up's angle is a polynomial in time and the
//! turn's heading the integral of its rate; the position is the integral of the
//! velocity, each by 16-point Gauss-Legendre quadrature (its error is far below
//! f64's rounding for the angles an onset turns through).

use nalgebra::{UnitQuaternion, Vector3};
use solver_core::profiles::{LevelTurn, PullUp};
use solver_core::{AircraftState, FlightPath, Real, Vec3};

/// Nodes of the Gauss-Legendre rule.
const GAUSS_NODES: usize = 16;
/// Panels of the quadrature of a turn's heading over its roll.
const HEADING_PANELS: u32 = 4;

/// A pull-up or turn with a finite onset ([`crate::flyable`]).
#[derive(Clone, Debug, PartialEq)]
pub enum Flyable {
    /// The pull-up.
    PullUp(FlyablePullUp),
    /// The level coordinated turn.
    Turn(FlyableTurn),
}

/// The Gauss-Legendre rule of the quadratures, computed once.
static GAUSS: std::sync::LazyLock<Gauss> = std::sync::LazyLock::new(Gauss::new);

/// The Gauss-Legendre rule on [-1, 1]: nodes and weights.
#[derive(Clone, Debug, PartialEq)]
struct Gauss {
    nodes: [f64; GAUSS_NODES],
    weights: [f64; GAUSS_NODES],
}

impl Gauss {
    /// The rule's nodes (roots of the Legendre polynomial P_16, by Newton's
    /// method from Chebyshev's estimates) and weights 2 / ((1 - x^2) P'(x)^2).
    fn new() -> Self {
        let n = GAUSS_NODES;
        let mut nodes = [0.0; GAUSS_NODES];
        let mut weights = [0.0; GAUSS_NODES];
        for i in 0..n {
            let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            let mut derivative = 0.0;
            for _ in 0..100 {
                // P_n(x) and P_n'(x) by the three-term recurrence.
                let (mut p0, mut p1) = (1.0, x);
                for k in 2..=n {
                    let k = k as f64;
                    (p0, p1) = (p1, ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k);
                }
                derivative = n as f64 * (x * p1 - p0) / (x * x - 1.0);
                let dx = p1 / derivative;
                x -= dx;
                if dx.abs() < 1e-16 {
                    break;
                }
            }
            nodes[i] = x;
            weights[i] = 2.0 / ((1.0 - x * x) * derivative * derivative);
        }
        Gauss { nodes, weights }
    }

    /// The integral of `f` over [a, b] by the rule on each of `panels` equal
    /// parts.
    fn integrate_panels(
        &self,
        a: f64,
        b: f64,
        panels: u32,
        f: impl Fn(f64) -> Vector3<f64>,
    ) -> Vector3<f64> {
        let width = (b - a) / f64::from(panels);
        (0..panels)
            .map(|i| {
                let lo = a + width * f64::from(i);
                let hi = if i + 1 == panels { b } else { lo + width };
                self.integrate(lo, hi, &f)
            })
            .sum()
    }

    /// The integral of `f` over [a, b].
    fn integrate(&self, a: f64, b: f64, f: impl Fn(f64) -> Vector3<f64>) -> Vector3<f64> {
        let (mid, half) = (0.5 * (a + b), 0.5 * (b - a));
        let mut sum = Vector3::zeros();
        for (x, w) in self.nodes.iter().zip(&self.weights) {
            sum += f(mid + half * x) * *w;
        }
        sum * half
    }
}

/// The angle and its first three derivatives at time `tau` since the start of
/// a rotation whose rate builds from 0 to `rate` over `onset` along the
/// smootherstep, holds, and (from `stop`, if any) falls back to 0 the same way.
#[derive(Clone, Copy, Debug, PartialEq)]
struct RampedRate {
    rate: f64,
    onset: f64,
    /// When the rate starts falling (since the start), s.
    stop: Option<f64>,
}

/// An angle and its rate, acceleration and jerk.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Angle {
    angle: f64,
    rate: f64,
    acceleration: f64,
    jerk: f64,
}

/// The smootherstep's part at `x` in [0, 1] of a change by `amount` over
/// `onset` s: the integral of amount S over [0, x T], amount S, and its
/// derivatives in time.
fn smootherstep(amount: f64, onset: f64, x: f64) -> Angle {
    let (x2, t) = (x * x, onset);
    let x3 = x2 * x;
    Angle {
        angle: amount * t * x2 * x2 * (2.5 - 3.0 * x + x2),
        rate: amount * x3 * (10.0 - 15.0 * x + 6.0 * x2),
        acceleration: amount * 30.0 * x2 * (1.0 - x) * (1.0 - x) / t,
        jerk: amount * 60.0 * x * (1.0 - x) * (1.0 - 2.0 * x) / (t * t),
    }
}

impl RampedRate {
    /// The rising part at `x` = tau / onset in [0, 1]: the angle turned since
    /// its start, the rate, acceleration and jerk.
    fn rising(&self, x: f64) -> Angle {
        smootherstep(self.rate, self.onset, x)
    }

    /// The angle and its derivatives at `tau` >= 0.
    fn at(&self, tau: f64) -> Angle {
        let (w, t) = (self.rate, self.onset);
        if tau < t {
            return self.rising(tau / t);
        }
        let at_full = 0.5 * w * t;
        match self.stop {
            Some(stop) if tau >= stop => {
                let at_stop = at_full + w * (stop - t);
                let u = (tau - stop).min(t);
                // Falling: the rate w - (the rising part's rate).
                let r = self.rising(u / t);
                let angle = at_stop + w * u - r.angle;
                if tau - stop < t {
                    Angle {
                        angle,
                        rate: w - r.rate,
                        acceleration: -r.acceleration,
                        jerk: -r.jerk,
                    }
                } else {
                    Angle {
                        angle,
                        rate: 0.0,
                        acceleration: 0.0,
                        jerk: 0.0,
                    }
                }
            }
            _ => Angle {
                angle: at_full + w * (tau - t),
                rate: w,
                acceleration: 0.0,
                jerk: 0.0,
            },
        }
    }
}

/// The pull-up of solver-core's [`PullUp`] with its rate built and removed over
/// `onset` s ([`crate::flyable`]).
#[derive(Clone, Debug, PartialEq)]
pub struct FlyablePullUp {
    /// The step profile it smooths (altitude, speed, start, rate, duration).
    pub step: PullUp,
    /// Time to build (and to remove) the rate, s.
    pub onset: f64,
    ramp: RampedRate,
    /// Positions relative to the start's at the end of the entry ramp, the
    /// start and the end of the exit ramp.
    ramp_ends: [Vector3<f64>; 3],
}

impl FlyablePullUp {
    /// The pull-up `step` flown with an onset of `onset` s (positive, at most the
    /// step's duration).
    pub fn new(step: PullUp, onset: f64) -> Self {
        let ramp = RampedRate {
            rate: step.rate,
            onset,
            stop: Some(step.duration),
        };
        let mut path = FlyablePullUp {
            step,
            onset,
            ramp,
            ramp_ends: [Vector3::zeros(); 3],
        };
        let first = path.ramp_integral(0.0, onset);
        let hold = path.arc(onset, step.duration);
        let second = path.ramp_integral(step.duration, step.duration + onset);
        path.ramp_ends = [first, first + hold, first + hold + second];
        path
    }

    /// The direction of flight at flight-path angle `gamma`: forward and up.
    fn direction(gamma: f64) -> Vector3<f64> {
        Vector3::new(gamma.cos(), 0.0, -gamma.sin())
    }

    /// The displacement over [a, b] (since the start) while the rate ramps.
    fn ramp_integral(&self, a: f64, b: f64) -> Vector3<f64> {
        let v = self.step.speed;
        GAUSS.integrate(a, b, |tau| Self::direction(self.ramp.at(tau).angle) * v)
    }

    /// The displacement over [a, b] (since the start) at the constant rate.
    fn arc(&self, a: f64, b: f64) -> Vector3<f64> {
        let (g0, g1) = (self.ramp.at(a).angle, self.ramp.at(b).angle);
        let radius = self.step.speed / self.step.rate;
        Vector3::new(
            radius * (g1.sin() - g0.sin()),
            0.0,
            radius * (g1.cos() - g0.cos()),
        )
    }

    /// When the manoeuvre's rate changes its law (start, entry ramp's end,
    /// exit ramp's start and end), s.
    pub fn breakpoints(&self) -> [f64; 4] {
        let (s, d, t) = (self.step.start, self.step.duration, self.onset);
        [s, s + t, s + d, s + d + t]
    }
}

impl FlightPath<f64> for FlyablePullUp {
    fn state_at(&self, t: f64) -> AircraftState<f64> {
        let p = &self.step;
        let v = p.speed;
        if t <= p.start || p.rate == 0.0 {
            return FlightPath::<f64>::state_at(p, t);
        }
        let tau = t - p.start;
        let Angle {
            angle: gamma,
            rate,
            acceleration,
            ..
        } = self.ramp.at(tau);
        let (onset, duration) = (self.onset, p.duration);
        let moved = if tau < onset {
            self.ramp_integral(0.0, tau)
        } else if tau < duration {
            self.ramp_ends[0] + self.arc(onset, tau)
        } else if tau < duration + onset {
            self.ramp_ends[1] + self.ramp_integral(duration, tau)
        } else {
            self.ramp_ends[2] + Self::direction(gamma) * (v * (tau - duration - onset))
        };
        let direction = Self::direction(gamma);
        AircraftState {
            position: Vector3::new(v * p.start, 0.0, -p.altitude) + moved,
            velocity: direction * v,
            acceleration: Vector3::new(-gamma.sin(), 0.0, -gamma.cos()) * (v * rate),
            attitude: quaternion(UnitQuaternion::from_euler_angles(0.0, gamma, 0.0)),
            angular_rate: Vector3::new(0.0, rate, 0.0),
            angular_acceleration: Vector3::new(0.0, acceleration, 0.0),
        }
    }
}

/// The turn of solver-core's [`LevelTurn`] rolled into over `onset` s
/// ([`crate::flyable`]).
#[derive(Clone, Debug, PartialEq)]
pub struct FlyableTurn {
    /// The step profile it smooths (altitude, speed, start, rate, gravity).
    pub step: LevelTurn,
    /// Time to roll in, s.
    pub onset: f64,
    /// Heading at the end of the roll, rad.
    rolled_heading: f64,
    /// Position relative to the start's at the end of the roll.
    ramp_end: Vector3<f64>,
}

/// A turn's heading and bank at one instant, with their derivatives.
struct TurnAngles {
    heading: Angle,
    bank: Angle,
}

impl FlyableTurn {
    /// The turn `step` rolled into over `onset` s (positive).
    pub fn new(step: LevelTurn, onset: f64) -> Self {
        let mut path = FlyableTurn {
            step,
            onset,
            rolled_heading: 0.0,
            ramp_end: Vector3::zeros(),
        };
        path.rolled_heading = path.roll_heading(onset);
        path.ramp_end = path.roll_integral(onset);
        path
    }

    /// The bank and its derivatives at `tau` in [0, onset].
    fn bank(&self, tau: f64) -> Angle {
        let b = smootherstep(self.step.bank(), self.onset, tau / self.onset);
        // `smootherstep`'s "rate" is the bank itself here: shift the derivatives.
        Angle {
            angle: b.rate,
            rate: b.acceleration,
            acceleration: b.jerk,
            jerk: f64::NAN,
        }
    }

    /// The coordinated heading rate at bank `phi`, rad/s.
    fn heading_rate(&self, phi: f64) -> f64 {
        self.step.gravity * phi.tan() / self.step.speed
    }

    /// The heading at `tau` in [0, onset] (the integral of its rate, in
    /// [`HEADING_PANELS`] panels: tan of the bank grows steeply toward the end
    /// of a steep roll).
    fn roll_heading(&self, tau: f64) -> f64 {
        GAUSS
            .integrate_panels(0.0, tau, HEADING_PANELS, |s| {
                Vector3::new(self.heading_rate(self.bank(s).angle), 0.0, 0.0)
            })
            .x
    }

    /// Heading, bank and their rates at `tau` >= 0 since the start.
    fn angles(&self, tau: f64) -> TurnAngles {
        let p = &self.step;
        if tau < self.onset {
            let bank = self.bank(tau);
            let (g, v) = (p.gravity, p.speed);
            let cos = bank.angle.cos();
            TurnAngles {
                heading: Angle {
                    angle: self.roll_heading(tau),
                    rate: self.heading_rate(bank.angle),
                    acceleration: g * bank.rate / (v * cos * cos),
                    jerk: f64::NAN,
                },
                bank,
            }
        } else {
            TurnAngles {
                heading: Angle {
                    angle: self.rolled_heading + p.rate * (tau - self.onset),
                    rate: p.rate,
                    acceleration: 0.0,
                    jerk: 0.0,
                },
                bank: Angle {
                    angle: p.bank(),
                    rate: 0.0,
                    acceleration: 0.0,
                    jerk: 0.0,
                },
            }
        }
    }

    /// The displacement over [0, b] (since the start) during the roll.
    fn roll_integral(&self, b: f64) -> Vector3<f64> {
        let v = self.step.speed;
        GAUSS.integrate(0.0, b, |tau| {
            let heading = self.roll_heading(tau);
            Vector3::new(heading.cos(), heading.sin(), 0.0) * v
        })
    }

    /// When the manoeuvre's rate changes its law (start, the roll's end), s.
    pub fn breakpoints(&self) -> [f64; 2] {
        [self.step.start, self.step.start + self.onset]
    }
}

impl FlightPath<f64> for FlyableTurn {
    fn state_at(&self, t: f64) -> AircraftState<f64> {
        let p = &self.step;
        let v = p.speed;
        if t <= p.start || p.rate == 0.0 {
            return FlightPath::<f64>::state_at(p, t);
        }
        let tau = t - p.start;
        let TurnAngles { heading, bank } = self.angles(tau);
        let psi = heading.angle;
        let moved = if tau < self.onset {
            self.roll_integral(tau)
        } else {
            let radius = v / p.rate;
            self.ramp_end
                + Vector3::new(
                    radius * (psi.sin() - self.rolled_heading.sin()),
                    -radius * (psi.cos() - self.rolled_heading.cos()),
                    0.0,
                )
        };
        let (sb, cb) = bank.angle.sin_cos();
        let (rate, acceleration) = (heading.rate, heading.acceleration);
        AircraftState {
            position: Vector3::new(v * p.start, 0.0, -p.altitude) + moved,
            velocity: Vector3::new(psi.cos(), psi.sin(), 0.0) * v,
            acceleration: Vector3::new(-psi.sin(), psi.cos(), 0.0) * (v * rate),
            attitude: quaternion(UnitQuaternion::from_euler_angles(bank.angle, 0.0, psi)),
            // Body rates of a level attitude (pitch 0) of roll phi, heading psi:
            // (phi', psi' sin phi, psi' cos phi), and their derivatives.
            angular_rate: Vector3::new(bank.rate, rate * sb, rate * cb),
            angular_acceleration: Vector3::new(
                bank.acceleration,
                acceleration * sb + rate * bank.rate * cb,
                acceleration * cb - rate * bank.rate * sb,
            ),
        }
    }
}

impl Flyable {
    /// When the manoeuvre starts, s.
    pub fn manoeuvre_start(&self) -> f64 {
        match self {
            Flyable::PullUp(p) => p.step.start,
            Flyable::Turn(p) => p.step.start,
        }
    }

    /// When the rate changes its law, s, increasing.
    pub fn breakpoints(&self) -> Vec<f64> {
        match self {
            Flyable::PullUp(p) => p.breakpoints().to_vec(),
            Flyable::Turn(p) => p.breakpoints().to_vec(),
        }
    }

    /// The rate held, rad/s.
    pub fn rate(&self) -> f64 {
        match self {
            Flyable::PullUp(p) => p.step.rate,
            Flyable::Turn(p) => p.step.rate,
        }
    }

    /// The onset, s.
    pub fn onset(&self) -> f64 {
        match self {
            Flyable::PullUp(p) => p.onset,
            Flyable::Turn(p) => p.onset,
        }
    }
}

/// Computed in f64 and rounded to `T`.
impl<T: Real> FlightPath<T> for Flyable {
    fn state_at(&self, t: f64) -> AircraftState<T> {
        let s = match self {
            Flyable::PullUp(p) => p.state_at(t),
            Flyable::Turn(p) => p.state_at(t),
        };
        let v = |x: Vector3<f64>| Vec3::new(T::lit(x.x), T::lit(x.y), T::lit(x.z));
        AircraftState {
            position: v(s.position),
            velocity: v(s.velocity),
            acceleration: v(s.acceleration),
            attitude: s.attitude.map(T::lit),
            angular_rate: v(s.angular_rate),
            angular_acceleration: v(s.angular_acceleration),
        }
    }
}

/// `[w, x, y, z]` of `q`.
fn quaternion(q: UnitQuaternion<f64>) -> [f64; 4] {
    [q.w, q.i, q.j, q.k]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pull_up(onset: f64) -> FlyablePullUp {
        FlyablePullUp::new(
            PullUp {
                altitude: 9000.0,
                speed: 182.3,
                start: 2.0,
                rate: 0.2,
                duration: 5.0,
            },
            onset,
        )
    }

    fn turn(onset: f64, rate: f64) -> FlyableTurn {
        FlyableTurn::new(
            LevelTurn {
                altitude: 9000.0,
                speed: 240.0,
                start: 2.0,
                rate,
                gravity: 9.80665,
            },
            onset,
        )
    }

    /// The connection point (2 m aft, 1.7 m below the reference point).
    const CONNECTION: [f64; 3] = [-2.0, 0.0, 1.7];

    fn point(path: &impl FlightPath<f64>, t: f64) -> solver_core::PointKinematics<f64> {
        let r = Vec3::new(CONNECTION[0], CONNECTION[1], CONNECTION[2]);
        path.state_at(t).point(&r)
    }

    #[test]
    fn gauss_legendre_integrates_polynomials_to_degree_31_exactly() {
        let g = Gauss::new();
        for degree in [0, 1, 7, 20, 30, 31] {
            let integral = g
                .integrate(-0.3, 1.7, |x| Vector3::new(x.powi(degree), 0.0, 0.0))
                .x;
            let exact =
                (1.7f64.powi(degree + 1) - (-0.3f64).powi(degree + 1)) / f64::from(degree + 1);
            assert!(
                (integral - exact).abs() <= 1e-13 * exact.abs().max(1.0),
                "degree {degree}"
            );
        }
    }

    /// Position, velocity, acceleration, attitude, body rate and angular
    /// acceleration are continuous at every breakpoint, and so are the
    /// connection point's velocity and acceleration (where the step profile's
    /// velocity jumps by w |r|).
    #[test]
    fn the_state_and_the_connection_point_are_continuous_at_the_breakpoints() {
        let flyable = Flyable::PullUp(pull_up(0.5));
        // 0.2 rad/s at 240 m/s: a 5 g turn (the paper's), banked 78 deg.
        let turns = [
            Flyable::Turn(turn(0.5, 0.2)),
            Flyable::Turn(turn(1.0, -0.15)),
        ];
        let e = 1e-7;
        for path in std::iter::once(&flyable).chain(&turns) {
            for b in path.breakpoints() {
                let (before, after) = (path.state_at(b - e), path.state_at(b + e));
                let (before, after): (AircraftState<f64>, AircraftState<f64>) = (before, after);
                assert!((after.position - before.position).norm() < 2.0 * e * 300.0);
                assert!(
                    (after.velocity - before.velocity).norm() < 1e-4,
                    "velocity at {b}"
                );
                assert!(
                    (after.acceleration - before.acceleration).norm() < 1e-4,
                    "at {b}"
                );
                assert!(
                    (after.angular_rate - before.angular_rate).norm() < 1e-6,
                    "rate at {b}: {:?} {:?}",
                    before.angular_rate,
                    after.angular_rate
                );
                let jump = (after.angular_acceleration - before.angular_acceleration).norm();
                assert!(jump < 1e-4, "angular acceleration at {b}: {jump}");
                for i in 0..4 {
                    assert!((after.attitude[i] - before.attitude[i]).abs() < 1e-6);
                }
                let cp = |t| match path {
                    Flyable::PullUp(p) => point(p, t),
                    Flyable::Turn(p) => point(p, t),
                };
                let (a, c) = (cp(b - e), cp(b + e));
                assert!(
                    (c.velocity - a.velocity).norm() < 1e-5,
                    "connection point at {b}"
                );
                assert!((c.acceleration - a.acceleration).norm() < 1e-3, "at {b}");
            }
        }
        // The step profile's jump, for contrast: w |r| at the start.
        let step = pull_up(0.5).step;
        let jump = (point(&step, 2.0 + e).velocity - point(&step, 2.0 - e).velocity).norm();
        assert!((jump - 0.2 * 2.624).abs() < 1e-2, "{jump}");
    }

    /// The state is the derivative of itself: velocity of the position,
    /// acceleration of the velocity, body rate of the attitude and angular
    /// acceleration of the rate, by central differences, everywhere along the
    /// manoeuvres (an independent check of the kinematics and the quadrature).
    #[test]
    fn velocity_acceleration_and_rates_are_the_derivatives() {
        let paths = [
            Flyable::PullUp(pull_up(0.5)),
            Flyable::PullUp(pull_up(2.0)),
            Flyable::Turn(turn(0.5, 0.2)),
            Flyable::Turn(turn(1.5, -0.15)),
        ];
        let h = 2e-5;
        for path in &paths {
            let state = |t: f64| -> AircraftState<f64> { path.state_at(t) };
            let breaks = path.breakpoints();
            let mut t = 1.0;
            while t < 11.0 {
                t += 0.0371;
                if breaks.iter().any(|b| (b - t).abs() < 2.0 * h) {
                    continue;
                }
                let (a, s, b) = (state(t - h), state(t), state(t + h));
                let velocity = (b.position - a.position) / (2.0 * h);
                assert!((velocity - s.velocity).norm() < 1e-5, "velocity at {t}");
                let acceleration = (b.velocity - a.velocity) / (2.0 * h);
                assert!(
                    (acceleration - s.acceleration).norm() < 1e-5,
                    "acceleration at {t}"
                );
                let angular = (b.angular_rate - a.angular_rate) / (2.0 * h);
                assert!((angular - s.angular_acceleration).norm() < 1e-5, "at {t}");
                // Body rate from the attitude: 2 q* dq/dt.
                let q = |s: &AircraftState<f64>| {
                    UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
                        s.attitude[0],
                        s.attitude[1],
                        s.attitude[2],
                        s.attitude[3],
                    ))
                };
                let dq = q(&a).inverse() * q(&b);
                let body = dq.scaled_axis() / (2.0 * h);
                assert!((body - s.angular_rate).norm() < 1e-5, "body rate at {t}");
            }
        }
    }

    /// Past its onsets the flyable pull-up climbs at the step profile's angle,
    /// and as the onset shrinks its path tends to the step profile's.
    #[test]
    fn the_onset_tends_to_the_step_profile() {
        let smooth = pull_up(0.5);
        let late: AircraftState<f64> = smooth.state_at(12.0);
        let step: AircraftState<f64> = FlightPath::<f64>::state_at(&smooth.step, 12.0);
        assert!((late.velocity - step.velocity).norm() < 1e-9);
        let tiny = pull_up(1e-4);
        for t in [3.0, 6.9, 9.0] {
            let a: AircraftState<f64> = tiny.state_at(t);
            let b: AircraftState<f64> = FlightPath::<f64>::state_at(&tiny.step, t);
            assert!((a.position - b.position).norm() < 0.01, "at {t}");
        }
        let tiny = turn(1e-4, 0.2);
        let a: AircraftState<f64> = tiny.state_at(9.0);
        let b: AircraftState<f64> = FlightPath::<f64>::state_at(&tiny.step, 9.0);
        assert!((a.position - b.position).norm() < 0.1);
    }
}
