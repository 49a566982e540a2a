//! [`FramePath`]: the aircraft's flight path between two State frames, the one
//! path the controller and the host reference both integrate along.

use solver_core::{AircraftState, FlightPath, InputError, NodePath, PointKinematics, Real, Vec3};

use decoy_link::AircraftStateFrame;

/// One frame's kinematics in the solver's precision, position relative to the
/// run's origin: what the path returns at that frame's time.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Sample<T: Real> {
    position: Vec3<T>,
    velocity: Vec3<T>,
    acceleration: Vec3<T>,
    /// Normalised in `T`.
    attitude: [T; 4],
    rate: Vec3<T>,
    angular_acceleration: Vec3<T>,
}

impl<T: Real> Sample<T> {
    /// The frame's kinematics; the position is taken relative to `origin` in f64
    /// (the one quantity the wire carries in f64), the rest converted from the
    /// wire's f32 (exact for both precisions).
    fn of(frame: &AircraftStateFrame, origin: &[f64; 3]) -> Self {
        let p = frame.position_ned_m;
        let attitude = normalised(frame.attitude_wxyz.map(wide::<T>));
        Sample {
            position: Vec3::new(
                T::lit(p[0] - origin[0]),
                T::lit(p[1] - origin[1]),
                T::lit(p[2] - origin[2]),
            ),
            velocity: wide3(frame.velocity_ned_mps),
            acceleration: wide3(frame.acceleration_ned_mps2),
            attitude,
            rate: wide3(frame.body_rate_radps),
            angular_acceleration: wide3(frame.body_angular_acceleration_radps2),
        }
    }

    fn state(&self) -> AircraftState<T> {
        AircraftState {
            position: self.position,
            velocity: self.velocity,
            acceleration: self.acceleration,
            attitude: self.attitude,
            angular_rate: self.rate,
            angular_acceleration: self.angular_acceleration,
        }
    }
}

/// q / |q| (the identity for a zero quaternion).
#[inline(always)]
fn normalised<T: Real>(q: [T; 4]) -> [T; 4] {
    let norm = q
        .iter()
        .fold(T::zero(), |sum, c| sum + *c * *c)
        .square_root();
    if norm > T::zero() {
        q.map(|c| c / norm)
    } else {
        [T::one(), T::zero(), T::zero(), T::zero()]
    }
}

/// A wire f32 in the solver's precision (exact).
#[inline(always)]
fn wide<T: Real>(v: f32) -> T {
    T::lit(f64::from(v))
}

fn wide3<T: Real>(v: [f32; 3]) -> Vec3<T> {
    Vec3::new(wide(v[0]), wide(v[1]), wide(v[2]))
}

/// The flight path over [t0, t1] between the previous accepted State frame (t0)
/// and the current one (t1), in the solver's precision `T` (f32 on the
/// Cortex-M4F, where f64 is software-emulated). Built once per frame: positions
/// relative to the origin and the displacement p1 - p0 are taken in f64, every
/// other value comes from the wire's f32; quaternions are normalised in `T`.
/// With s = (t - t0)/h, h = t1 - t0:
///
/// - position and velocity: the cubic Hermite through both frames' positions and
///   velocities, written about p0: p = p0 + h01 (p1 - p0) + h h10 v0 + h h11 v1,
///   v = (p1 - p0) h01'/h + h10' v0 + h11' v1 (so the small displacement keeps
///   full relative precision even in f32);
/// - acceleration, body rate and body angular acceleration: linear in s;
/// - attitude: normalised linear interpolation (nlerp) of the normalised
///   quaternions along the shorter arc.
///
/// At t <= t0 (s = 0) the path is exactly the previous frame's sample and at
/// t >= t1 exactly the current frame's (its position, velocity and the quaternion
/// as sent, normalised): so the path of the next frame starts with the bits this
/// one ends with, and the solver evaluates the end of one frame and the start of
/// the next with the same inputs (and reuses that evaluation, `Solver::step`).
///
/// Positions are relative to `origin` (NED, m), which the controller sets to the
/// horizontal position of the frame it trimmed at, so that an f32 solver keeps
/// centimetre resolution however far the aircraft flies (the air depends only on
/// the altitude, so the shift changes nothing else). A single frame (or t1 <= t0)
/// gives a constant state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FramePath<T: Real> {
    /// Time of the previous frame, s.
    t0: f64,

    /// Bits of t1 - t0 (s, f64) as an integer, where t1 is the current frame's
    /// time; 0 when t1 is not after t0 (a constant path at `to`).
    span_bits: i64,
    /// 1 / (t1 - t0), 1/s (zero for a constant path).
    inverse_span: T,
    /// When 0 < t0 < t1 lie in one binade or two adjacent ones (every frame but
    /// the first, at t = 0) of exponents in range: the bits of t0 and t1 and
    /// the ulps of their binades in `T` ([`FramePath::fraction`]); `None`
    /// otherwise.
    binades: Option<Binades<T>>,
    /// t1 - t0, s.
    span: T,
    from: Sample<T>,
    to: Sample<T>,
    /// `to.attitude`, negated if that is the shorter arc from `from.attitude`.
    to_attitude_near: [T; 4],
    /// p1 - p0 taken in f64, then rounded once.
    delta: Vec3<T>,
    /// The towing point's own interpolation, when set ([`FramePath::towing`]).
    towing: Option<Towing<T>>,
    /// The towing point and its kinematics at the previous frame, from the path
    /// that ended there ([`FramePath::after`]), for [`FramePath::towing`].
    from_point: Option<(Vec3<T>, PointKinematics<T>)>,
}

/// The times of a [`FramePath`] as bit patterns, for its fraction in integers.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Binades<T: Real> {
    t0_bits: u64,
    t1_bits: u64,
    /// The ulp of t0's binade.
    ulp0: T,
    /// The ulp of t1's binade (t0's, or twice it).
    ulp1: T,
}

/// Where a [`FramePath`] ended: its current frame's sample and towing point
/// kinematics, for the next frame's path to start from without computing them
/// again ([`FramePath::after`]; about 700 instructions of soft-float work on the
/// M4F). Reused only for the very same frame and origin, bit for bit, so a path
/// built after it has the bits of one built from the frames alone. All zero bits
/// is "nothing" ([`PathEnd::NONE`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathEnd<T: Real> {
    /// False: nothing kept.
    kept: bool,
    frame: AircraftStateFrame,
    origin: [f64; 3],
    sample: Sample<T>,
    /// False: no towing point kept.
    towing_kept: bool,
    towing_point: Vec3<T>,
    towing_end: PointKinematics<T>,
}

impl<T: Real> PathEnd<T> {
    /// Nothing kept (all zero bits).
    pub const NONE: Self = {
        let z = Vec3::new(T::ZERO, T::ZERO, T::ZERO);
        PathEnd {
            kept: false,
            frame: AircraftStateFrame {
                seq: 0,
                time_s: 0.0,
                position_ned_m: [0.0; 3],
                velocity_ned_mps: [0.0; 3],
                acceleration_ned_mps2: [0.0; 3],
                attitude_wxyz: [0.0; 4],
                body_rate_radps: [0.0; 3],
                body_angular_acceleration_radps2: [0.0; 3],
            },
            origin: [0.0; 3],
            sample: Sample {
                position: z,
                velocity: z,
                acceleration: z,
                attitude: [T::ZERO; 4],
                rate: z,
                angular_acceleration: z,
            },
            towing_kept: false,
            towing_point: z,
            towing_end: PointKinematics {
                position: z,
                velocity: z,
                acceleration: z,
            },
        }
    };

    /// True when this is the end at `frame` with `origin`, bit for bit.
    fn is_at(&self, frame: &AircraftStateFrame, origin: &[f64; 3]) -> bool {
        fn same64(a: &[f64], b: &[f64]) -> bool {
            a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
        }
        fn same32(a: &[f32], b: &[f32]) -> bool {
            a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
        }
        let k = &self.frame;
        self.kept
            && same64(&[k.time_s], &[frame.time_s])
            && same64(&k.position_ned_m, &frame.position_ned_m)
            && same64(&self.origin, origin)
            && same32(&k.velocity_ned_mps, &frame.velocity_ned_mps)
            && same32(&k.acceleration_ned_mps2, &frame.acceleration_ned_mps2)
            && same32(&k.attitude_wxyz, &frame.attitude_wxyz)
            && same32(&k.body_rate_radps, &frame.body_rate_radps)
            && same32(
                &k.body_angular_acceleration_radps2,
                &frame.body_angular_acceleration_radps2,
            )
    }
}

/// The kinematics of one body-fixed point (the connection point) at both
/// frames of a [`FramePath`], for [`FlightPath::point_at`] to interpolate
/// directly.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Towing<T: Real> {
    /// The point, aircraft body frame (FRD), m.
    point: Vec3<T>,
    /// Its kinematics at the previous frame (`from`'s state).
    from: PointKinematics<T>,
    /// Its kinematics at the current frame (`to`'s state).
    to: PointKinematics<T>,
    /// Its offsets from the aircraft's reference point at the previous frame:
    /// R0 r in position, R0 (w0 x r) in velocity.
    offset0: (Vec3<T>, Vec3<T>),
    /// How those offsets change to the current frame's.
    offset_change: (Vec3<T>, Vec3<T>),
}

impl<T: Real> FramePath<T> {
    /// The path from `previous` to `current`, positions relative to `origin`.
    pub fn new(
        previous: &AircraftStateFrame,
        current: &AircraftStateFrame,
        origin: [f64; 3],
    ) -> Self {
        Self::after(&PathEnd::NONE, previous, current, origin)
    }

    /// [`FramePath::new`], starting from `end` where it is the end at `previous`
    /// with `origin` (the path of the frame before ended there): the same bits,
    /// without computing the previous frame's sample and towing point again.
    pub fn after(
        end: &PathEnd<T>,
        previous: &AircraftStateFrame,
        current: &AircraftStateFrame,
        origin: [f64; 3],
    ) -> Self {
        let mut path = Self::ZERO;
        path.set_after(end, previous, current, origin);
        path
    }

    /// A constant path at the origin at time 0 (all zero bits), to be set.
    pub const ZERO: Self = {
        let z = Vec3::new(T::ZERO, T::ZERO, T::ZERO);
        let sample = Sample {
            position: z,
            velocity: z,
            acceleration: z,
            attitude: [T::ZERO; 4],
            rate: z,
            angular_acceleration: z,
        };
        FramePath {
            t0: 0.0,
            binades: None,
            span_bits: 0,
            inverse_span: T::ZERO,
            span: T::ZERO,
            from: sample,
            to: sample,
            to_attitude_near: [T::ZERO; 4],
            delta: z,
            towing: None,
            from_point: None,
        }
    };

    /// Makes this [`FramePath::after`]`(end, previous, current, origin)`, in place
    /// (no path-sized value moved: about 110 words).
    pub fn set_after(
        &mut self,
        end: &PathEnd<T>,
        previous: &AircraftStateFrame,
        current: &AircraftStateFrame,
        origin: [f64; 3],
    ) {
        let reuse = end.is_at(previous, &origin);
        self.from = if reuse {
            end.sample
        } else {
            Sample::of(previous, &origin)
        };
        self.from_point = (reuse && end.towing_kept).then_some((end.towing_point, end.towing_end));
        self.to = Sample::of(current, &origin);
        // Shortest arc: q and -q are the same attitude.
        let (from, to) = (&self.from, &self.to);
        let dot = (0..4).fold(T::zero(), |sum, i| sum + from.attitude[i] * to.attitude[i]);
        self.to_attitude_near = if dot < T::zero() {
            to.attitude.map(|c: T| -c)
        } else {
            to.attitude
        };
        let (p0, p1) = (previous.position_ned_m, current.position_ned_m);
        self.delta = Vec3::new(
            T::lit(p1[0] - p0[0]),
            T::lit(p1[1] - p0[1]),
            T::lit(p1[2] - p0[2]),
        );
        let (t0_bits, t1_bits) = (previous.time_s.to_bits(), current.time_s.to_bits());
        // t1 > t0 >= 0 on their bits (positive doubles order as their bit patterns;
        // a soft-float compare costs about 30 instructions on the M4F); a span
        // that is not positive makes a constant path.
        let positive = t1_bits > t0_bits && t0_bits >> 63 == 0 && t1_bits < f64::INFINITY.to_bits();
        let span = current.time_s - previous.time_s;
        (self.span_bits, self.inverse_span, self.span) = if positive {
            // 1/h in T (one division in T, not a soft-float one in f64).
            let h = T::lit(span);
            (span.to_bits() as i64, T::one() / h, h)
        } else {
            (0, T::zero(), T::zero())
        };
        let (e0, e1) = (t0_bits >> 52, t1_bits >> 52);
        // 2^-60 s <= t0 < t1 < 2^61 s, positive (sign bit clear, so the exponent
        // field is the top 12 bits), t1 in t0's binade or the next: the ulps
        // there are normal in f32.
        let ulp = |e: u64| T::lit(f64::from_bits((e - 52) << 52));
        self.binades = (t1_bits > t0_bits && (1023 - 60..=1023 + 60).contains(&e0) && e1 - e0 <= 1)
            .then(|| Binades {
                t0_bits,
                t1_bits,
                ulp0: ulp(e0),
                ulp1: ulp(e1),
            });
        self.t0 = previous.time_s;
        self.towing = None;
    }

    /// The aircraft's state at the current frame (t1): the path's end, as
    /// [`FlightPath::state_at`] gives it there.
    pub fn end_state(&self) -> AircraftState<T> {
        self.to.state()
    }

    /// Where this path ends: at `current` (the frame it was built to) with
    /// `origin`, for [`FramePath::after`].
    pub fn end(&self, current: &AircraftStateFrame, origin: [f64; 3]) -> PathEnd<T> {
        let mut end = PathEnd::NONE;
        self.end_into(&mut end, current, origin);
        end
    }

    /// [`FramePath::end`] written into `end` (no path-end-sized value moved).
    pub fn end_into(&self, end: &mut PathEnd<T>, current: &AircraftStateFrame, origin: [f64; 3]) {
        end.kept = true;
        end.frame = *current;
        end.origin = origin;
        end.sample = self.to;
        match &self.towing {
            Some(towing) => {
                end.towing_kept = true;
                end.towing_point = towing.point;
                end.towing_end = towing.to;
            }
            None => end.towing_kept = false,
        }
    }

    /// The same path, with the kinematics of the body-fixed point `point` (FRD, m;
    /// the connection point) interpolated between the two frames by
    /// [`FlightPath::point_at`]: the aircraft's own Hermite position and velocity
    /// plus the point's offsets R r and R (w x r) at both frames, linear in s, and
    /// its acceleration linear in s, rather than derived from the interpolated
    /// aircraft state (position, nlerp attitude, rates and accelerations, then
    /// p + R r, v + R (w x r), a + R (dw x r + w x (w x r))). At both frames the
    /// point's kinematics are those [`AircraftState::point`] gives for the frame's
    /// state, bit for bit (so consecutive frames still meet with the same bits);
    /// between them the two interpolations differ by the path's own
    /// interpolation error, and this one costs a third as much on the Cortex-M4F.
    /// Frames whose states fail [`AircraftState::validate`] keep the default
    /// (which reports the failure); so does any other point.
    pub fn towing(mut self, point: Vec3<T>) -> Self {
        self.set_towing(point);
        self
    }

    /// [`FramePath::towing`] in place (no path-sized value moved).
    pub fn set_towing(&mut self, point: Vec3<T>) {
        let same_point = |p: &Vec3<T>| {
            p.x.same_bits(point.x) && p.y.same_bits(point.y) && p.z.same_bits(point.z)
        };
        // The previous frame's, from the path that ended there (checked there).
        let from = match self.from_point {
            Some((p, kinematics)) if same_point(&p) => Some(kinematics),
            _ => None,
        };
        let from = match from {
            Some(kinematics) => kinematics,
            None => {
                let state = self.from.state();
                if state.validate().is_err() {
                    self.towing = None;
                    return;
                }
                state.point(&point)
            }
        };
        let to = self.to.state();
        if to.validate().is_err() {
            self.towing = None;
            return;
        }
        let to = to.point(&point);
        // The point's offsets from the aircraft's reference point at both frames.
        let offset0 = (
            from.position - self.from.position,
            from.velocity - self.from.velocity,
        );
        let offset1 = (
            to.position - self.to.position,
            to.velocity - self.to.velocity,
        );
        self.towing = Some(Towing {
            point,
            from,
            to,
            offset0,
            offset_change: (offset1.0 - offset0.0, offset1.1 - offset0.1),
        });
    }

    /// The path's span t1 - t0, s, in f64 (0 for a constant path).
    pub fn span_s(&self) -> f64 {
        if self.span_bits > 0 {
            f64::from_bits(self.span_bits as u64)
        } else {
            0.0
        }
    }

    /// The constant path at one frame (its state at every time).
    pub fn single(frame: &AircraftStateFrame, origin: [f64; 3]) -> Self {
        FramePath::new(frame, frame, origin)
    }

    /// The origin of a run that trims at `frame`: the frame's horizontal
    /// position (so that an f32 solver keeps centimetre resolution, above).
    pub fn run_origin(frame: &AircraftStateFrame) -> [f64; 3] {
        let p = frame.position_ned_m;
        [p[0], p[1], 0.0]
    }
}

/// `aircraft` in steady straight flight, the trim's condition: its position,
/// velocity and attitude, its acceleration and rotation set to zero.
pub fn steady_flight<T: Real>(aircraft: &AircraftState<T>) -> AircraftState<T> {
    AircraftState {
        acceleration: Vec3::zeros(),
        angular_rate: Vec3::zeros(),
        angular_acceleration: Vec3::zeros(),
        ..*aircraft
    }
}

/// Where a time lies on a [`FramePath`].
enum Fraction<T> {
    /// At or before the previous frame.
    Before,
    /// At or after the current frame.
    After,
    /// s = (t - t0)/h in (0, 1].
    Inside(T),
}

impl<T: Real> FramePath<T> {
    /// Where `t` lies.
    #[inline(always)]
    fn fraction(&self, t: f64) -> Fraction<T> {
        // In integers, without the soft-float subtraction and narrowing (about 150
        // instructions on the M4F, 9 samples a frame), for a positive t: positive
        // doubles order as their bit patterns. Between t0 and t1, t lies in t0's
        // binade, where t - t0 is exactly n ulps (n the difference of the bit
        // patterns) and T::lit(t - t0) is n in T times the ulp (the same bits as
        // the subtraction below), or in t1's, where t1 - t is exactly n ulps of
        // that binade and s = 1 - (t1 - t)/h.
        if let Some(b) = &self.binades {
            let tb = t.to_bits();
            if tb >> 63 == 0 {
                if tb <= b.t0_bits {
                    return Fraction::Before;
                }
                if tb >= b.t1_bits {
                    return Fraction::After;
                }
                let s = if tb >> 52 == b.t0_bits >> 52 {
                    T::from_count(tb - b.t0_bits) * b.ulp0 * self.inverse_span
                } else {
                    T::one() - T::from_count(b.t1_bits - tb) * b.ulp1 * self.inverse_span
                };
                let s = if s < T::one() { s } else { T::one() };
                return Fraction::Inside(if s > T::zero() { s } else { T::zero() });
            }
        }
        // t - t0 against 0 and against t1 - t0 (the same f64 difference at t = t1),
        // compared as bit patterns: for non-negative doubles their order is that of
        // the integers (on the M4F a soft-float compare costs about 30 instructions).
        let elapsed = t - self.t0;
        let bits = elapsed.to_bits() as i64;
        // A NaN takes one of the two branches: with its sign bit set it is negative as
        // an integer, without it it lies above every span (a positive double, at most
        // +inf, whose bits are below every NaN's).
        if bits >= self.span_bits {
            return Fraction::After;
        }
        if bits <= 0 {
            return Fraction::Before;
        }
        let s = T::lit(elapsed) * self.inverse_span;
        Fraction::Inside(if s < T::one() { s } else { T::one() })
    }

    /// The cubic Hermite at `s` through `p0` with velocity `v0` and `p0 + delta`
    /// with velocity `v1`: position and velocity.
    #[inline(always)]
    fn hermite(
        &self,
        s: T,
        p0: &Vec3<T>,
        v0: &Vec3<T>,
        v1: &Vec3<T>,
        delta: &Vec3<T>,
    ) -> (Vec3<T>, Vec3<T>) {
        let step = self.span;
        let lit = T::lit;
        // Hermite basis (h01 = 1 - h00, so p = p0 + h01 (p1 - p0) + ...) and its
        // derivatives per unit s (d00 = -d01).
        let (s2, s3) = (s * s, s * s * s);
        let h10 = s3 - lit(2.0) * s2 + s;
        let h01 = lit(3.0) * s2 - lit(2.0) * s3;
        let h11 = s3 - s2;
        let d10 = lit(3.0) * s2 - lit(4.0) * s + T::one();
        let d01 = lit(6.0) * (s - s2);
        let d11 = lit(3.0) * s2 - lit(2.0) * s;
        let position = p0 + delta * h01 + (v0 * h10 + v1 * h11) * step;
        let velocity = delta * (d01 * self.inverse_span) + v0 * d10 + v1 * d11;
        (position, velocity)
    }
}

impl<T: Real> FramePath<T> {
    /// The towing point's interpolation if it is set for `r` (the same bits).
    #[inline(always)]
    fn towing_for(&self, r: &Vec3<T>) -> Option<&Towing<T>> {
        match &self.towing {
            Some(towing)
                if towing.point.x.same_bits(r.x)
                    && towing.point.y.same_bits(r.y)
                    && towing.point.z.same_bits(r.z) =>
            {
                Some(towing)
            }
            _ => None,
        }
    }

    /// The towing point's kinematics at `s` in (0, 1): the aircraft's own Hermite,
    /// plus the point's offsets interpolated linearly (not a Hermite through the
    /// point's positions: an attitude that steps between two frames, as a
    /// scenario's bank at its start, would turn the step of R r into a velocity
    /// of |r| x angle / h, hundreds of m/s over a 10 ms frame).
    #[inline(always)]
    fn towing_inside(&self, towing: &Towing<T>, s: T) -> PointKinematics<T> {
        let (from, to) = (&self.from, &self.to);
        let (aircraft_position, aircraft_velocity) =
            self.hermite(s, &from.position, &from.velocity, &to.velocity, &self.delta);
        let ((p0, v0), (dp, dv)) = (&towing.offset0, &towing.offset_change);
        let position = aircraft_position + (p0 + dp * s);
        let velocity = aircraft_velocity + (v0 + dv * s);
        let (a, b) = (&towing.from, &towing.to);
        let acceleration = a.acceleration + (b.acceleration - a.acceleration) * s;
        PointKinematics {
            position,
            velocity,
            acceleration,
        }
    }

    /// The aircraft state at `s` in (0, 1).
    fn state_inside(&self, s: T) -> AircraftState<T> {
        let (a, b) = (&self.from, &self.to);
        let (position, velocity) =
            self.hermite(s, &a.position, &a.velocity, &b.velocity, &self.delta);
        let lerp = |x: &Vec3<T>, y: &Vec3<T>| -> Vec3<T> { x + (y - x) * s };
        let attitude = normalised([0, 1, 2, 3].map(|i| {
            let qa = a.attitude[i];
            qa + (self.to_attitude_near[i] - qa) * s
        }));
        AircraftState {
            position,
            velocity,
            acceleration: lerp(&a.acceleration, &b.acceleration),
            attitude,
            angular_rate: lerp(&a.rate, &b.rate),
            angular_acceleration: lerp(&a.angular_acceleration, &b.angular_acceleration),
        }
    }

    /// The kinematics of `r` by the default rule (the state, validated, then the
    /// point), at `fraction`.
    fn default_point(
        &self,
        fraction: Fraction<T>,
        r: &Vec3<T>,
    ) -> Result<PointKinematics<T>, InputError> {
        let aircraft = match fraction {
            Fraction::Before => self.from.state(),
            Fraction::After => self.to.state(),
            Fraction::Inside(s) => self.state_inside(s),
        };
        aircraft.validate()?;
        Ok(aircraft.point(r))
    }
}

impl<T: Real> FlightPath<T> for FramePath<T> {
    /// With [`FramePath::towing`] at `r` (the same bits): the point's kinematics
    /// interpolated directly; otherwise the default.
    #[inline(always)]
    fn point_at(&self, t: f64, r: &Vec3<T>) -> Result<PointKinematics<T>, InputError> {
        let fraction = self.fraction(t);
        let Some(towing) = self.towing_for(r) else {
            return self.default_point(fraction, r);
        };
        Ok(match fraction {
            Fraction::Before => towing.from,
            Fraction::After => towing.to,
            Fraction::Inside(s) => self.towing_inside(towing, s),
        })
    }

    fn state_at(&self, t: f64) -> AircraftState<T> {
        match self.fraction(t) {
            Fraction::Before => self.from.state(),
            Fraction::After => self.to.state(),
            Fraction::Inside(s) => self.state_inside(s),
        }
    }
}

/// The frame path sampled at the nodes of its steps (the controller's way,
/// `Solver::steps_on`): node k of n at s = k / n exactly where n is a power of
/// two (four steps a frame: eighths), the previous frame's kinematics at node 0
/// and the current frame's at node n, bit for bit as [`FlightPath::point_at`]
/// gives them at t0 and t1.
impl<T: Real> NodePath<T> for FramePath<T> {
    fn span(&self) -> T {
        self.span
    }

    #[inline(always)]
    fn node_point(
        &self,
        k: u32,
        nodes: u32,
        r: &Vec3<T>,
    ) -> Result<PointKinematics<T>, InputError> {
        let fraction = if k == 0 || !(self.span > T::zero()) {
            Fraction::Before
        } else if k >= nodes {
            Fraction::After
        } else {
            Fraction::Inside(T::from_count(u64::from(k)) / T::from_count(u64::from(nodes)))
        };
        let Some(towing) = self.towing_for(r) else {
            return self.default_point(fraction, r);
        };
        Ok(match fraction {
            Fraction::Before => towing.from,
            Fraction::After => towing.to,
            Fraction::Inside(s) => self.towing_inside(towing, s),
        })
    }
}

/// The aircraft state `state` at `time_s` as the State frame numbered `seq` a host
/// sends (velocities, accelerations, attitude and rates narrowed to f32).
pub fn state_frame(seq: u32, time_s: f64, state: &AircraftState<f64>) -> AircraftStateFrame {
    let f32s = |v: &Vec3<f64>| [v.x as f32, v.y as f32, v.z as f32];
    AircraftStateFrame {
        seq,
        time_s,
        position_ned_m: [state.position.x, state.position.y, state.position.z],
        velocity_ned_mps: f32s(&state.velocity),
        acceleration_ned_mps2: f32s(&state.acceleration),
        attitude_wxyz: state.attitude.map(|q| q as f32),
        body_rate_radps: f32s(&state.angular_rate),
        body_angular_acceleration_radps2: f32s(&state.angular_acceleration),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(t: f64, x: f64, v: f32) -> AircraftStateFrame {
        AircraftStateFrame {
            seq: 0,
            time_s: t,
            position_ned_m: [x, 10.0, -9000.0],
            velocity_ned_mps: [v, 0.0, 0.0],
            acceleration_ned_mps2: [1.0, 0.0, 0.0],
            attitude_wxyz: [1.0, 0.0, 0.0, 0.0],
            body_rate_radps: [0.0; 3],
            body_angular_acceleration_radps2: [0.0; 3],
        }
    }

    #[test]
    fn hermite_reproduces_the_end_frames_and_a_quadratic() {
        // x = 100 t + t^2 / 2 is a cubic: the Hermite reproduces it (to the f32
        // rounding of the frames' velocities).
        let x = |t: f64| 100.0 * t + 0.5 * t * t;
        let (f0, f1) = (frame(1.0, x(1.0), 101.0), frame(1.01, x(1.01), 101.01));
        let path = FramePath::<f64>::new(&f0, &f1, [0.0, 10.0, 0.0]);
        for k in 0..=10 {
            let t = 1.0 + 0.001 * k as f64;
            let s = path.state_at(t);
            assert!((s.position.x - x(t)).abs() < 1e-7, "{t}");
            assert!((s.velocity.x - (100.0 + t)).abs() < 1e-4, "{t}");
            assert_eq!(s.position.y, 0.0);
            assert_eq!(s.position.z, -9000.0);
        }
        assert_eq!(path.state_at(1.01).position.x, x(1.01));
    }

    /// The fraction as computed before the same-binade shortcut: t - t0 in f64,
    /// classified on its bits, narrowed.
    fn fraction_by_subtraction<T: Real>(path: &FramePath<T>, t: f64) -> Option<u64> {
        let elapsed = t - path.t0;
        let bits = elapsed.to_bits() as i64;
        if bits >= path.span_bits {
            return None;
        }
        if bits <= 0 {
            return Some(u64::MAX);
        }
        let s = T::lit(elapsed) * path.inverse_span;
        Some(if s < T::one() { s } else { T::one() }.to_f64().to_bits())
    }

    fn same_fraction<T: Real>() {
        for t0 in [0.01f64, 1.0, 1.99, 2.37, 999.99, 1023.995, 12345.678] {
            // Frames across a power of two (1.99 to 2.0, 1023.995 to 1024.005):
            // from t1's side, within a few ulps of the subtraction.
            let crossing = (t0.to_bits() >> 52) != ((t0 + 0.01f64).to_bits() >> 52);
            let (f0, f1) = (frame(t0, 0.0, 240.0), frame(t0 + 0.01, 2.4, 240.0));
            let path = FramePath::<T>::new(&f0, &f1, [0.0; 3]);
            let t1 = f1.time_s;
            let mut times: Vec<f64> = (0..=2000).map(|k| t0 + 0.01 * k as f64 / 1999.0).collect();
            for d in -4i64..=4 {
                times.push(f64::from_bits((t1.to_bits() as i64 + d) as u64));
                times.push(f64::from_bits((t0.to_bits() as i64 + d) as u64));
            }
            for t in times {
                let got = match path.fraction(t) {
                    Fraction::After => None,
                    Fraction::Before => Some(u64::MAX),
                    Fraction::Inside(s) => Some(s.to_f64().to_bits()),
                };
                let expected = fraction_by_subtraction(&path, t);
                match (got, expected) {
                    (Some(g), Some(e)) if crossing && g != u64::MAX && e != u64::MAX => {
                        let (g, e) = (f64::from_bits(g), f64::from_bits(e));
                        assert!(
                            (g - e).abs() <= 4.0 * T::eps().to_f64(),
                            "t0 {t0}, t {t}: {g} {e}"
                        );
                    }
                    _ => assert_eq!(got, expected, "t0 {t0}, t {t}"),
                }
            }
        }
    }

    #[test]
    fn the_same_binade_fraction_is_the_subtraction() {
        same_fraction::<f32>();
        same_fraction::<f64>();
    }

    #[test]
    fn nlerp_takes_the_shorter_arc() {
        let mut f0 = frame(0.0, 0.0, 100.0);
        let mut f1 = frame(0.01, 1.0, 100.0);
        f0.attitude_wxyz = [1.0, 0.0, 0.0, 0.0];
        f1.attitude_wxyz = [-1.0, 0.0, 0.0, 0.0];
        let s = FramePath::<f64>::new(&f0, &f1, [0.0; 3]).state_at(0.005);
        assert!((s.attitude[0].abs() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn f32_samples_keep_the_velocity_far_from_the_origin() {
        // 50 km from the origin an f32 position has a 4 mm resolution; the
        // velocity must still come out right, from the f64 displacement.
        let (f0, f1) = (frame(10.0, 50_000.0, 240.0), frame(10.01, 50_002.4, 240.0));
        let path = FramePath::<f32>::new(&f0, &f1, [0.0; 3]);
        for k in 0..=4 {
            let s = path.state_at(10.0 + 0.0025 * k as f64);
            assert!((s.velocity.x - 240.0).abs() < 1e-3, "{}", s.velocity.x);
            let expected = 50_000.0 + 240.0 * 0.0025 * k as f64;
            assert!((f64::from(s.position.x) - expected).abs() < 5e-3);
        }
    }

    #[test]
    fn consecutive_paths_meet_with_the_same_bits() {
        // The end of one frame's path is the start of the next, bit for bit (so the
        // solver can reuse the evaluation there), in both precisions and with the
        // attitude flipped for the shorter arc.
        let mut f0 = frame(2.0, 480.123_456_7, 240.0);
        let mut f1 = frame(2.01, 482.523_456_7, 240.1);
        let mut f2 = frame(2.02, 484.924_456_7, 240.2);
        f0.attitude_wxyz = [0.999, 0.01, 0.02, 0.03];
        f1.attitude_wxyz = [-0.998, -0.011, -0.02, -0.031];
        f2.attitude_wxyz = [0.997, 0.012, 0.021, 0.032];
        let origin = [400.0, 10.0, 0.0];
        for_both(&f0, &f1, &f2, origin);
        fn for_both(
            f0: &AircraftStateFrame,
            f1: &AircraftStateFrame,
            f2: &AircraftStateFrame,
            origin: [f64; 3],
        ) {
            let (a, b) = (
                FramePath::<f32>::new(f0, f1, origin),
                FramePath::<f32>::new(f1, f2, origin),
            );
            assert_eq!(a.state_at(f1.time_s), b.state_at(f1.time_s));
            assert_eq!(
                a.state_at(f1.time_s),
                FramePath::<f32>::single(f1, origin).state_at(7.0)
            );
            let (a, b) = (
                FramePath::<f64>::new(f0, f1, origin),
                FramePath::<f64>::new(f1, f2, origin),
            );
            assert_eq!(a.state_at(f1.time_s), b.state_at(f1.time_s));
            assert_eq!(
                a.state_at(f1.time_s),
                FramePath::<f64>::single(f1, origin).state_at(-3.0)
            );
            // Inside the span the attitude follows the shorter arc (w stays positive).
            assert!(a.state_at(f1.time_s - 0.005).attitude[0] > 0.99);
        }
    }
}
