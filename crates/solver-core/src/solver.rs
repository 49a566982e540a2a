//! The solver: model + state + workspace, advanced by fixed-step RK4 (docs/design.md §4).

use nalgebra::UnitQuaternion;

use crate::atmosphere::{AirCache, AirColumn};
use crate::dynamics::{self, TensionMethod, Workspace};
use crate::error::{ConfigError, InputError, SolveError};
use crate::model::{Model, ModelParams};
use crate::motion::{AircraftState, FlightPath, NodePath, PointKinematics};
use crate::rk4::{DerivativeSource, Rk4, StageUpdate};
use crate::scalar::{Real, Vec3, zero3};
use crate::state::{Derivative, State};

/// A towed system ready to integrate: the model (immutable), the state (a plain
/// value) and the workspace (scratch, plus the results of the last evaluation).
///
/// Determinism: [`Solver::step`] reads only the model, the state, the flight path
/// and `dt`; the same inputs give bit-identical states.
#[derive(Clone, Debug)]
pub struct Solver<T: Real, const N: usize> {
    model: Model<T, N>,
    /// The state and RK4's buffers (the stage buffer is swapped with the state after
    /// a step rather than copied).
    rk4: Rk4<T, N>,
    method: TensionMethod,
    ws: Workspace<T, N>,
    /// The air columns built (a cache: [`AirColumn::about`] is a pure function of
    /// the altitude's cell, so a column reused while it [`AirColumn::serves`] is
    /// the one that would be built).
    air: AirCache<T>,
    /// When `ws` and the last derivative of `rk4` hold the evaluation at the current
    /// state: the connection-point kinematics and air reference it was evaluated
    /// with. The next step's first stage reuses it if its inputs are the same bits
    /// (see [`Solver::step_observed`]).
    evaluated: Option<EvaluationKey<T>>,
}

/// The inputs of an evaluation besides the model and the state: equal bits, equal
/// results.
#[derive(Clone, Copy, Debug)]
struct EvaluationKey<T: Real> {
    connection: PointKinematics<T>,
    air_reference: T,
    method: TensionMethod,
}

impl<T: Real> EvaluationKey<T> {
    fn new(connection: &PointKinematics<T>, air: &AirColumn<T>, method: TensionMethod) -> Self {
        EvaluationKey {
            connection: *connection,
            air_reference: air.reference_altitude,
            method,
        }
    }

    /// Bitwise equality (so +0 and -0 differ; NaN never occurs: inputs are validated).
    fn same(&self, other: &Self) -> bool {
        let same3 = |a: &Vec3<T>, b: &Vec3<T>| {
            a.x.same_bits(b.x) && a.y.same_bits(b.y) && a.z.same_bits(b.z)
        };
        let (a, b) = (&self.connection, &other.connection);
        self.method == other.method
            && self.air_reference.same_bits(other.air_reference)
            && same3(&a.position, &b.position)
            && same3(&a.velocity, &b.velocity)
            && same3(&a.acceleration, &b.acceleration)
    }
}

/// The product's derivative for [`Rk4`]: the three passes of
/// [`dynamics::evaluate`] along a flight path, with the solver's air column cache
/// and its last output evaluation as the first stage's candidate.
///
/// `KEEP`: every stage keeps and checks its forces (the product's steps, whose
/// stages a caller may observe or read); without it only the last output
/// evaluation's forces are kept ([`Solver::steps_on`], the controller's frames:
/// the same states, bit for bit).
struct Towed<'a, T: Real, const N: usize, P: ?Sized, const KEEP: bool = true> {
    model: &'a Model<T, N>,
    path: &'a P,
    method: TensionMethod,
    ws: &'a mut Workspace<T, N>,
    air: &'a mut AirCache<T>,
    evaluated: &'a mut Option<EvaluationKey<T>>,
}

impl<T: Real, const N: usize, P: FlightPath<T> + ?Sized, const KEEP: bool> DerivativeSource<T, N>
    for Towed<'_, T, N, P, KEEP>
{
    type Inputs = (PointKinematics<T>, AirColumn<T>);

    #[inline(always)]
    fn segment_count(&self) -> usize {
        self.model.segment_count()
    }

    #[inline(always)]
    fn inputs_at(&mut self, time: f64) -> Result<Self::Inputs, SolveError> {
        let connection = self
            .path
            .point_at(time, &self.model.params().connection_point)?;
        Ok(inputs_at(self.model, self.air, connection)?)
    }

    #[inline(always)]
    fn evaluate(
        &mut self,
        state: &State<T, N>,
        (connection, air): &Self::Inputs,
        out: &mut Derivative<T, N>,
    ) -> Result<(), SolveError> {
        if !KEEP && self.method == TensionMethod::TwoSweep {
            dynamics::prepare(self.model, state, connection, air, self.ws);
            return dynamics::solve_tensions_and_accelerations_of_a_stage(
                self.model, state, self.ws, out,
            );
        }
        dynamics::evaluate(
            self.model,
            state,
            connection,
            air,
            self.method,
            self.ws,
            out,
        )
    }

    #[inline(always)]
    fn evaluate_to_stage(
        &mut self,
        stage: &mut State<T, N>,
        (connection, air): &Self::Inputs,
        out: &mut Derivative<T, N>,
        next: StageUpdate<'_, T, N>,
    ) -> Result<(), SolveError> {
        dynamics::evaluate_to_stage(
            self.model,
            stage,
            connection,
            air,
            self.method,
            self.ws,
            out,
            next,
        )
    }

    #[inline(always)]
    fn evaluate_first_stage(
        &mut self,
        state: &State<T, N>,
        (connection, air): &Self::Inputs,
        stage: &mut State<T, N>,
        out: &mut Derivative<T, N>,
        h: T,
    ) -> Result<(), SolveError> {
        if !KEEP && self.method == TensionMethod::TwoSweep {
            dynamics::prepare(self.model, state, connection, air, self.ws);
            return dynamics::solve_tensions_first_stage_unkept(
                self.model, state, self.ws, out, stage, h,
            );
        }
        dynamics::evaluate_first_stage(
            self.model,
            state,
            connection,
            air,
            self.method,
            self.ws,
            stage,
            out,
            h,
        )
    }

    /// The evaluation [`Solver::outputs`] left is the first stage when its inputs are
    /// the same bits (it is forgotten either way: the step overwrites it).
    #[inline(always)]
    fn holds_first_stage(&mut self, (connection, air): &Self::Inputs) -> bool {
        let key = EvaluationKey::new(connection, air, self.method);
        matches!(self.evaluated.take(), Some(last) if last.same(&key))
    }
}

impl<T: Real, const N: usize, P: NodePath<T> + ?Sized, const KEEP: bool> Towed<'_, T, N, P, KEEP> {
    /// The inputs at node `k` of `nodes` of the path ([`Solver::steps_on`]).
    #[inline(always)]
    fn inputs_at_node(
        &mut self,
        k: u32,
        nodes: u32,
        point: &Vec3<T>,
    ) -> Result<(PointKinematics<T>, AirColumn<T>), SolveError> {
        let connection = self.path.node_point(k, nodes, point)?;
        Ok(inputs_at(self.model, self.air, connection)?)
    }
}

impl<T: Real, const N: usize> Solver<T, N> {
    /// A solver without a model yet, as a constant of all zero bits: where a solver
    /// must not pass through the stack (tens of KB on a microcontroller), put this
    /// in its final place (a `static`, where it lies in `.bss`, or a field of a
    /// larger value built the same way) and give it its model there with
    /// [`Solver::configure`].
    ///
    /// Until configured it has no model ([`Model::is_configured`] is false):
    /// [`Solver::configure`] is the only method to call; stepping or evaluating
    /// it computes nonsense from zero lengths and masses (never a panic).
    pub const UNCONFIGURED: Self = Solver {
        model: Model::UNCONFIGURED,
        rk4: Rk4::ZERO,
        method: TensionMethod::TwoSweep,
        ws: Workspace::ZERO,
        // `Some` of zero values rather than `None`: these options keep `None` in a
        // niche of nonzero bits, and the constant must be all zero bits to lie in
        // `.bss` (the HIL tests check that the firmware's controller does). Never
        // read: `configure` clears both caches.
        air: AirCache::EMPTY,
        evaluated: Some(EvaluationKey {
            connection: PointKinematics {
                position: zero3(),
                velocity: zero3(),
                acceleration: zero3(),
            },
            air_reference: T::ZERO,
            method: TensionMethod::TwoSweep,
        }),
    };

    /// Makes this the solver [`Solver::new`] builds for `Model::new(*params)` and
    /// the state at rest ([`State::default`]), in place: the model is built in the
    /// solver's own memory, and nothing solver- or model-sized passes through the
    /// stack. Everything the solver held before is replaced (state, caches,
    /// method).
    ///
    /// On error ([`Model::new`]'s) the solver is left exactly as it was.
    pub fn configure(&mut self, params: &ModelParams<T>) -> Result<(), ConfigError> {
        self.model.configure(params)?;
        self.rk4 = Rk4::ZERO;
        self.rk4.set_state(State::default());
        self.method = TensionMethod::TwoSweep;
        self.ws.reset();
        self.air.clear();
        self.evaluated = None;
        Ok(())
    }

    /// A solver for `model` starting from `state`.
    ///
    /// Errors with [`SolveError::NonFinite`] if the state holds NaN or infinity.
    pub fn new(model: Model<T, N>, state: State<T, N>) -> Result<Self, SolveError> {
        let mut solver = Solver {
            model,
            rk4: Rk4::new(State::default()),
            method: TensionMethod::TwoSweep,
            ws: Workspace::default(),
            air: AirCache::EMPTY,
            evaluated: None,
        };
        solver.set_state(state)?;
        Ok(solver)
    }

    /// Chooses the tension solver (the shooting form is for reference tests only).
    pub fn set_method(&mut self, method: TensionMethod) {
        self.method = method;
        self.evaluated = None;
    }

    /// The model.
    pub fn model(&self) -> &Model<T, N> {
        &self.model
    }

    /// The current state (copy it to save; restore with [`Solver::set_state`]).
    pub fn state(&self) -> &State<T, N> {
        self.rk4.state()
    }

    /// Replaces the state after checking it is finite; on error the old state stays.
    pub fn set_state(&mut self, state: State<T, N>) -> Result<(), SolveError> {
        if !state.is_finite(self.model.segment_count()) {
            return Err(SolveError::NonFinite { joint: 0 });
        }
        self.rk4.set_state(state);
        self.evaluated = None;
        Ok(())
    }

    /// Makes the state the trim for steady straight flight with the aircraft in
    /// `aircraft` ([`crate::trim::trim`]), at `time`, computed in place: no
    /// state-sized value on the stack (the Cortex-M7 controller's state is
    /// 3 KB). On error the state is what the search had reached, possibly not a
    /// valid state: restore a saved copy with [`Solver::set_state`].
    pub fn trim(&mut self, aircraft: &AircraftState<T>, time: f64) -> Result<(), crate::TrimError> {
        self.evaluated = None;
        let state = self.rk4.state_mut();
        crate::trim::trim_into(&self.model, aircraft, state)?;
        state.time = time;
        if !state.is_finite(self.model.segment_count()) {
            return Err(crate::TrimError::ColumnDidNotConverge);
        }
        Ok(())
    }

    /// Starts a trim for steady straight flight with the aircraft in `aircraft`
    /// to be carried on in slices ([`Solver::advance_trim`]): the state is reset
    /// to rest and the search to its beginning ([`crate::trim::TrimTask`]). On
    /// error the state is left as it was.
    pub fn start_trim(
        &mut self,
        aircraft: &AircraftState<T>,
    ) -> Result<crate::trim::TrimTask<T, N>, crate::TrimError> {
        // `TrimTask::start` checks everything before it writes the state.
        let task = crate::trim::TrimTask::start(&self.model, aircraft, self.rk4.state_mut())?;
        self.evaluated = None;
        Ok(task)
    }

    /// Carries `task` (from [`Solver::start_trim`] on this solver) on into the
    /// state for about `budget` work units ([`crate::trim::TrimTask::advance`]):
    /// `Ok(true)` when the trim is complete, then at `time`. On error the state
    /// is what the search had reached: restore a saved copy with
    /// [`Solver::set_state`].
    pub fn advance_trim(
        &mut self,
        task: &mut crate::trim::TrimTask<T, N>,
        budget: u32,
        time: f64,
    ) -> Result<bool, crate::TrimError> {
        self.evaluated = None;
        let state = self.rk4.state_mut();
        if !task.advance(&self.model, state, budget)? {
            return Ok(false);
        }
        state.time = time;
        if !state.is_finite(self.model.segment_count()) {
            return Err(crate::TrimError::ColumnDidNotConverge);
        }
        Ok(true)
    }

    /// Turns the state about the vertical (NED z) by the rotation with cosine
    /// `cos` and sine `sin` (`cos² + sin² = 1`; a positive angle turns north
    /// toward east): every segment's direction and rate and the decoy's attitude
    /// (its body rate is in the body frame and does not change). A trim for one
    /// heading is then the trim for the other in still air.
    pub fn turn_about_vertical(&mut self, cos: T, sin: T) {
        self.evaluated = None;
        let n = self.model.segment_count();
        let state = self.rk4.state_mut();
        let turn = |v: &Vec3<T>| Vec3::new(cos * v.x - sin * v.y, sin * v.x + cos * v.y, v.z);
        for i in 0..n {
            state.directions[i] = turn(&state.directions[i]);
            state.rates[i] = turn(&state.rates[i]);
        }
        // q_z (half angle) q: q_z = (cos h, 0, 0, sin h), cos h = sqrt((1 + cos)/2),
        // sin h = sin / (2 cos h) (the turn is within +-180 degrees, cos h >= 0).
        let half = T::lit(0.5);
        let ch = (half * (T::one() + cos)).square_root();
        if ch > T::zero() {
            let sh = half * sin / ch;
            let [w, x, y, z] = state.decoy_attitude;
            state.decoy_attitude = [
                ch * w - sh * z,
                ch * x - sh * y,
                ch * y + sh * x,
                ch * z + sh * w,
            ];
        }
    }

    /// Builds the air columns of the cells next to the one the solver used last
    /// ([`AirCache::prefetch`]), for a caller with time to spare between frames:
    /// a later step that climbs or descends into them finds them built.
    pub fn prefetch_air(&mut self) {
        self.air
            .prefetch(&self.model.params().environment.atmosphere);
    }

    /// Sets the state's time (s) without touching the rest of the state; for a
    /// caller that integrates to an exact end time, where n steps of (t1 - t0)/n
    /// can land an ulp away from t1. A non-finite `time` is ignored.
    pub fn set_time(&mut self, time: f64) {
        if time.is_finite() {
            self.rk4.set_time(time);
        }
    }

    /// Advances the state by one RK4 step of `dt` seconds along `path`, then
    /// renormalises (unit directions, rates perpendicular to them, unit quaternion).
    ///
    /// On any error (unusable aircraft state, non-positive pivot, non-finite result)
    /// the state is left exactly as it was.
    ///
    /// `dt` is f64 in every precision so that time advances identically for f32 and
    /// f64 solvers; the arithmetic of the step uses `dt` rounded to `T`.
    pub fn step<P: FlightPath<T> + ?Sized>(&mut self, path: &P, dt: f64) -> Result<(), SolveError> {
        // As `step_observed` with nothing to observe (no joint kinematics for outputs).
        let mut towed: Towed<'_, T, N, P, true> = Towed {
            model: &self.model,
            path,
            method: self.method,
            ws: &mut self.ws,
            air: &mut self.air,
            evaluated: &mut self.evaluated,
        };
        self.rk4.step(&mut towed, dt, |_, _, _| {})
    }

    /// One RK4 step along `path` from the state's time to `t_end` exactly (the
    /// step `t_end` minus that time; the new state's time is `t_end` itself, so a
    /// caller stepping to the times of its own grid keeps an exact clock). The
    /// host's adaptive runs step this way (`decoy_sim`'s step rule). The first stage
    /// reuses the evaluation [`Solver::outputs`] left at this state, as
    /// [`Solver::step`]'s does; the later stages keep only T_0 and T_N.
    /// On any error the state is left exactly as it was.
    pub fn step_to<P: FlightPath<T> + ?Sized>(
        &mut self,
        path: &P,
        t_end: f64,
    ) -> Result<(), SolveError> {
        // The stages keep only T_0 and T_N (the last stage's are the error
        // estimate's, [`Solver::step_to_checked`]): the same derivatives, bit for
        // bit, without storing and probing every joint's force three times a step.
        let mut towed: Towed<'_, T, N, P, false> = Towed {
            model: &self.model,
            path,
            method: self.method,
            ws: &mut self.ws,
            air: &mut self.air,
            evaluated: &mut self.evaluated,
        };
        self.rk4
            .step_to(&mut towed, t_end, None, |_, _, _| {})
            .map(|_| ())
    }

    /// [`Solver::step_to`], then the derivative at the new state (the next step's
    /// first stage, which that step reuses: no evaluation is added) and from it an
    /// estimate of the step's error ([`StepError`]), with the choice to accept the
    /// step ([`CheckedStep::accept`], the new state's outputs) or undo it
    /// ([`CheckedStep::undo`]: the state before it, exactly).
    ///
    /// The estimate compares the end forces (at the connection point and at the
    /// towing point, [`StepError`]) of two states the step has evaluated anyway: the last stage's,
    /// at the predictor y + dt k3, and the new state's, y + dt/6 (k1 + 2 k2 + 2 k3 +
    /// k4). The two states differ by dt ((k1 + 2 k2 + 2 k3 + k4)/6 - k3), whose
    /// first-order terms cancel: O(dt^3), small where the motion is smooth on the
    /// step's scale and large where a tension changes within the step (a snatch
    /// load, the onset of a manoeuvre), the quantity the host's accuracy is judged
    /// by. The cable's undamped short-wave ringing, which a state norm would chase
    /// for the whole run, changes the end forces only at second order.
    ///
    /// On any error (the step's, or an evaluation of the new state that fails) the
    /// state is left exactly as it was.
    pub fn step_to_checked<P: FlightPath<T> + ?Sized>(
        &mut self,
        path: &P,
        t_end: f64,
    ) -> Result<CheckedStep<'_, T, N>, SolveError> {
        self.step_to(path, t_end)?;
        self.evaluated = None;
        // The last stage's end forces (at the predictor y + dt k3), to compare
        // with the new state's.
        let n = self.model.segment_count();
        let stage_forces = (self.ws.connection_force, self.ws.joint_force[n - 1]);
        let evaluation = (|| -> Result<StepError, SolveError> {
            let point = self.model.params().connection_point;
            let (state, spare) = self.rk4.state_and_spare();
            let connection = path.point_at(state.time, &point)?;
            let (connection, air) = inputs_at(&self.model, &mut self.air, connection)?;
            dynamics::evaluate(
                &self.model,
                state,
                &connection,
                &air,
                self.method,
                &mut self.ws,
                spare,
            )?;
            let error = StepError::between(
                stage_forces,
                (self.ws.connection_force, self.ws.joint_force[n - 1]),
            );
            dynamics::joint_kinematics(&self.model, state, &mut self.ws);
            self.evaluated = Some(EvaluationKey::new(&connection, &air, self.method));
            Ok(error)
        })();
        match evaluation {
            Ok(error) => {
                self.rk4.keep_spare();
                Ok(CheckedStep {
                    solver: self,
                    error,
                })
            }
            Err(e) => {
                self.evaluated = None;
                self.rk4.undo_step();
                Err(e)
            }
        }
    }

    /// `count` steps of `dt` seconds along `path`: the same bits as `count` calls of
    /// [`Solver::step`], sampling the path one time fewer per step (a step's start
    /// is the step before's end: its inputs are carried over, not sampled again).
    ///
    /// On an error the steps before the failing one stand and the failing one
    /// leaves the state as it was, as with the calls of [`Solver::step`].
    pub fn steps<P: FlightPath<T> + ?Sized>(
        &mut self,
        path: &P,
        dt: f64,
        count: u32,
    ) -> Result<(), SolveError> {
        let mut towed: Towed<'_, T, N, P, true> = Towed {
            model: &self.model,
            path,
            method: self.method,
            ws: &mut self.ws,
            air: &mut self.air,
            evaluated: &mut self.evaluated,
        };
        let mut start = None;
        for _ in 0..count {
            start = Some(self.rk4.step_from(&mut towed, dt, start, |_, _, _| {})?);
        }
        Ok(())
    }

    /// `count` RK4 steps over the whole interval of `path`, sampled at its nodes
    /// ([`NodePath`]: step i from node 2i through 2i + 1 to 2i + 2 of 2 `count`),
    /// each of the interval's span / `count` in `T`; the state's time is then
    /// `time_after` (the interval's end, which the caller knows in f64). No time is
    /// formed in f64 on the way (on the Cortex-M4F every f64 operation is a library
    /// call). The first stage reuses the evaluation [`Solver::outputs`] left, as in
    /// [`Solver::step`]. The stages keep no forces but T_0 and T_N: after these
    /// steps, read the forces of [`Solver::outputs`] (the end state's), not
    /// [`Solver::last_outputs`].
    ///
    /// `count` must be at least 1 ([`InputError::BadTimeStep`] otherwise, as for a
    /// span that is not positive and finite). On an error the steps before the
    /// failing one stand and the failing one leaves the state as it was; the time
    /// is set only when every step succeeds.
    pub fn steps_on<P: FlightPath<T> + NodePath<T> + ?Sized>(
        &mut self,
        path: &P,
        count: u32,
        time_after: f64,
    ) -> Result<(), SolveError> {
        let span = path.span();
        if count == 0 || !(span > T::zero() && span.finite()) {
            return Err(InputError::BadTimeStep.into());
        }
        let full = span / T::from_count(u64::from(count));
        let nodes = 2 * count;
        let point = self.model.params().connection_point;
        let mut towed: Towed<'_, T, N, P, false> = Towed {
            model: &self.model,
            path,
            method: self.method,
            ws: &mut self.ws,
            air: &mut self.air,
            evaluated: &mut self.evaluated,
        };
        let time = self.rk4.state().time;
        let mut start = towed.inputs_at_node(0, nodes, &point)?;
        for i in 0..count {
            let k = 2 * i;
            start = self.rk4.step_sampled(
                &mut towed,
                full,
                start,
                |t| t.inputs_at_node(k + 1, nodes, &point),
                |t| t.inputs_at_node(k + 2, nodes, &point),
                time,
                |_, _, _| {},
            )?;
        }
        self.rk4.set_time(time_after);
        Ok(())
    }

    /// [`Solver::step`], calling `observe` with the outputs at the state *before* the
    /// step. RK4's first stage evaluates the dynamics there anyway, so recording every
    /// step this way costs no extra evaluation (calling [`Solver::outputs`] after each
    /// step would cost a fifth one). `observe` is not called if that evaluation fails.
    ///
    /// The step is [`Rk4::step`] with the product's passes. The flight path is
    /// sampled once per distinct time (k2 and k3 share t + dt/2); the first stage
    /// reuses the evaluation [`Solver::outputs`] left at this state when its inputs
    /// (connection-point kinematics, air column, method) are the same bits (the
    /// outputs a caller read after the previous step, on a path that continues
    /// through them).
    pub fn step_observed<P, F>(&mut self, path: &P, dt: f64, observe: F) -> Result<(), SolveError>
    where
        P: FlightPath<T> + ?Sized,
        F: FnOnce(&Outputs<'_, T, N>),
    {
        let mut towed: Towed<'_, T, N, P, true> = Towed {
            model: &self.model,
            path,
            method: self.method,
            ws: &mut self.ws,
            air: &mut self.air,
            evaluated: &mut self.evaluated,
        };
        self.rk4.step(&mut towed, dt, |towed, state, k1| {
            dynamics::joint_kinematics(towed.model, state, towed.ws);
            observe(&Outputs {
                model: towed.model,
                state,
                ws: towed.ws,
                derivative: k1,
            })
        })
    }

    /// Evaluates the dynamics at the current state and returns the outputs
    /// (forces at every joint, positions, decoy attitude, rates, aerodynamics).
    /// [`SolveError::NonFinite`] names the first joint whose force is not finite:
    /// `Ok` outputs never carry an infinite or NaN tension.
    pub fn outputs<P: FlightPath<T> + ?Sized>(
        &mut self,
        path: &P,
    ) -> Result<Outputs<'_, T, N>, SolveError> {
        self.evaluate_here(path)?;
        let outputs = self.last_outputs();
        finite_tensions(&outputs)?;
        Ok(outputs)
    }

    /// The outputs of the most recent evaluation (the last RK4 stage of a step, or
    /// the last [`Solver::outputs`] call), without evaluating again. After
    /// [`Solver::outputs`] they belong to the current state; after a step, to its
    /// last stage, except the joint and CG positions and the joint velocities, which
    /// are those of the last [`Solver::outputs`] (or observed first stage): a step's
    /// stages do not form them. Before any evaluation the forces are zero.
    pub fn last_outputs(&self) -> Outputs<'_, T, N> {
        Outputs {
            model: &self.model,
            state: self.rk4.state(),
            ws: &self.ws,
            derivative: self.rk4.last_derivative(),
        }
    }

    /// The state derivative at the current state (for tests and references).
    pub fn derivative<P: FlightPath<T> + ?Sized>(
        &mut self,
        path: &P,
    ) -> Result<Derivative<T, N>, SolveError> {
        self.evaluate_here(path)?;
        Ok(*self.rk4.last_derivative())
    }

    /// Evaluates the dynamics at the current state and time into `ws` and the last
    /// derivative, and remembers the inputs for the next step's first stage.
    fn evaluate_here<P: FlightPath<T> + ?Sized>(&mut self, path: &P) -> Result<(), SolveError> {
        self.evaluated = None;
        let (state, slope) = self.rk4.state_and_last_derivative();
        let connection = path.point_at(state.time, &self.model.params().connection_point)?;
        let (connection, air) = inputs_at(&self.model, &mut self.air, connection)?;
        dynamics::evaluate(
            &self.model,
            state,
            &connection,
            &air,
            self.method,
            &mut self.ws,
            slope,
        )?;
        dynamics::joint_kinematics(&self.model, state, &mut self.ws);
        self.evaluated = Some(EvaluationKey::new(&connection, &air, self.method));
        Ok(())
    }
}

/// The inputs of an evaluation from the connection point's kinematics
/// ([`FlightPath::point_at`]): the air column about its altitude, from the
/// solver's cache `air` ([`crate::motion::connection_and_air`]'s result for the default
/// `point_at`).
#[inline(always)]
fn inputs_at<T: Real, const N: usize>(
    model: &Model<T, N>,
    air: &mut AirCache<T>,
    connection: PointKinematics<T>,
) -> Result<(PointKinematics<T>, AirColumn<T>), InputError> {
    let altitude = -connection.position.z;
    let column = air.column(&model.params().environment.atmosphere, altitude)?;
    Ok((connection, column))
}

/// Decoy outputs of one evaluation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DecoyOutputs<T: Real> {
    /// CG position, NED, m.
    pub cg_position: Vec3<T>,
    /// CG velocity, NED, m/s.
    pub cg_velocity: Vec3<T>,
    /// Attitude, body (FRD) to NED.
    pub attitude: UnitQuaternion<T>,
    /// Euler angles (roll, pitch, yaw), rad, ZYX convention, body relative to NED.
    pub euler: (T, T, T),
    /// Angular velocity, body frame, rad/s.
    pub rate: Vec3<T>,
    /// Angular acceleration, body frame, rad/s^2.
    pub angular_acceleration: Vec3<T>,
    /// Total angle of attack, rad.
    pub angle_of_attack: T,
    /// Airspeed at the CG, m/s.
    pub airspeed: T,
    /// Aerodynamic force, NED, N.
    pub aero_force: Vec3<T>,
    /// Aerodynamic moment about the CG, body frame, N m.
    pub aero_moment: Vec3<T>,
}

/// The error estimate of a step ([`Solver::step_to_checked`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepError {
    /// The change of the end forces between the step's last stage (a) and its
    /// new state (b), relative to the connection force:
    /// max(|F0_a - F0_b|, |FN_a - FN_b|) / sqrt(|F0_a|^2 + |F0_b|^2), with F0 the
    /// force at the connection point and FN the one at the towing point (0 when
    /// the connection force is zero in both). O(dt^3). The towing point's change
    /// is measured on the connection force's scale, not its own: the decoy's
    /// pull is a few per cent of the connection force, and while the cable
    /// near the decoy is slack its own scale would ask for short steps to
    /// follow a force of a few newtons.
    pub end_force: f64,
}

impl StepError {
    /// The estimate from the end forces (connection, towing point) of the step's
    /// last stage and of its new state.
    fn between<T: Real>(stage: (Vec3<T>, Vec3<T>), new: (Vec3<T>, Vec3<T>)) -> Self {
        let scale = (stage.0.norm_squared() + new.0.norm_squared()).to_f64();
        let connection = (stage.0 - new.0).norm_squared().to_f64();
        let towing = (stage.1 - new.1).norm_squared().to_f64();
        let larger = if towing > connection {
            towing
        } else {
            connection
        };
        StepError {
            end_force: if scale > 0.0 {
                libm::sqrt(larger / scale)
            } else {
                0.0
            },
        }
    }
}

/// A step taken by [`Solver::step_to_checked`], to be accepted or undone; the
/// solver is borrowed until then, so nothing else can step in between.
pub struct CheckedStep<'s, T: Real, const N: usize> {
    solver: &'s mut Solver<T, N>,
    error: StepError,
}

impl<'s, T: Real, const N: usize> CheckedStep<'s, T, N> {
    /// The step's local error estimate.
    pub fn error(&self) -> StepError {
        self.error
    }

    /// Keeps the step: the outputs at the new state, already evaluated (the next
    /// step's first stage reuses that evaluation). [`SolveError::NonFinite`] (and
    /// the step kept) when a tension is not finite, as [`Solver::outputs`] says.
    pub fn accept(self) -> Result<Outputs<'s, T, N>, SolveError> {
        let solver = self.solver;
        finite_tensions(&solver.last_outputs())?;
        Ok(solver.last_outputs())
    }

    /// Undoes the step: the state before it, exactly, with its time.
    pub fn undo(self) {
        self.solver.evaluated = None;
        self.solver.rk4.undo_step();
    }
}

/// [`SolveError::NonFinite`] naming the first joint whose force is not finite.
/// Every tension finite (|T_j| from its square, which overflows f32 first: at
/// 1.8e19 N, for accelerations far beyond any aircraft's), or a typed error
/// naming the first joint where it is not. One sum of the squares, finite only
/// if every |T_j|² is; the joints are searched only when it is not.
#[inline(always)]
fn finite_tensions<T: Real, const N: usize>(outputs: &Outputs<'_, T, N>) -> Result<(), SolveError> {
    let segments = outputs.segment_count();
    let squares = outputs
        .downstream_joint_forces()
        .iter()
        .fold(outputs.joint_force(0).norm_squared(), |sum, f| {
            sum + f.norm_squared()
        });
    if !squares.finite()
        && let Some(joint) =
            (0..=segments).find(|&j| !outputs.joint_force(j).norm_squared().finite())
    {
        return Err(SolveError::NonFinite { joint });
    }
    Ok(())
}

/// Safety factor of the wave-speed step limit: every RK4 step is at most
/// `WAVE_STEP_FACTOR` / [`Outputs::wave_rate`] (l_i / c_i for every segment i):
/// the chain's fastest mode swings at sqrt(12) c/l and RK4 is stable to about
/// 2.8 rad per step, so 0.8 is within 2 % of the limit.
pub const WAVE_STEP_FACTOR: f64 = 0.8;

/// A view of the results of the last evaluation.
#[derive(Clone, Copy, Debug)]
pub struct Outputs<'a, T: Real, const N: usize> {
    model: &'a Model<T, N>,
    state: &'a State<T, N>,
    ws: &'a Workspace<T, N>,
    derivative: &'a Derivative<T, N>,
}

impl<'a, T: Real, const N: usize> Outputs<'a, T, N> {
    /// Time of the evaluated state, s.
    pub fn time(&self) -> f64 {
        self.state.time
    }
    /// Number of segments.
    pub fn segment_count(&self) -> usize {
        self.model.segment_count()
    }
    /// Force T_j at joint `j` (0 = connection point, N = towing point), exerted by the
    /// upstream body on the downstream body, NED, N. A taut cable pulls segment j+1
    /// toward the aircraft, so T_j points roughly along -e_{j+1}.
    pub fn joint_force(&self, j: usize) -> Vec3<T> {
        if j == 0 {
            self.ws.connection_force
        } else {
            // j past the towing point reads the towing point's (never a panic).
            self.ws.joint_force[(j - 1).min(self.model.segment_count() - 1)]
        }
    }
    /// The forces T_1 .. T_N ([`Outputs::joint_force`] of joints 1 to N) as one
    /// slice, for a pass over them without a branch per joint.
    pub fn downstream_joint_forces(&self) -> &[Vec3<T>] {
        &self.ws.joint_force[..self.model.segment_count()]
    }
    /// The wave-speed rate max_i c_i / l_i of this evaluation, 1/s: c_i =
    /// sqrt(T_i / mu) is the transverse wave speed of segment i at the larger of its
    /// two end forces, l_i its length, mu the cable's linear density. The fastest
    /// mode of the rod chain, alternate rods swinging against each other, has the
    /// angular frequency sqrt(12) c/l, and RK4 is stable to about 2.8 rad per step:
    /// a step of at most [`WAVE_STEP_FACTOR`] / rate keeps every segment stable. The
    /// step rule of the controller (docs/protocol.md §5) and of the host's adaptive
    /// runs. Two roots in all: max_i |T_i|^2 / l_i^4 is found first.
    pub fn wave_rate(&self) -> T {
        // Compare-and-select rather than `max`, which is a libm call on the M4F.
        let larger = |a: T, b: T| if b > a { b } else { a };
        let mut worst = T::zero();
        let mut upstream = self.joint_force(0).norm_squared();
        for (l, force) in self
            .model
            .lengths()
            .iter()
            .zip(self.downstream_joint_forces())
        {
            let downstream = force.norm_squared();
            let l2 = *l * *l;
            worst = larger(worst, larger(upstream, downstream) / (l2 * l2));
            upstream = downstream;
        }
        (worst.square_root() / self.model.params().cable.linear_density).square_root()
    }
    /// Cable tension at joint `j`, N: the force's component along the cable, positive
    /// when the cable pulls (|T_j| signed by -T_j . e).
    pub fn tension(&self, j: usize) -> T {
        let f = self.joint_force(j);
        let n = self.model.segment_count();
        let e = self.state.directions[if j == 0 { 0 } else { (j - 1).min(n - 1) }];
        let magnitude = crate::scalar::norm(&f);
        if f.dot(&e) > T::zero() {
            -magnitude
        } else {
            magnitude
        }
    }
    /// Tension at the connection point (joint 0), N.
    pub fn connection_tension(&self) -> T {
        self.tension(0)
    }
    /// Tension at the towing point (joint N), N.
    pub fn tow_tension(&self) -> T {
        self.tension(self.model.segment_count())
    }
    /// Position of joint `j`, NED, m (0 = connection point).
    pub fn joint_position(&self, j: usize) -> Vec3<T> {
        if j == 0 {
            self.ws.connection.position
        } else {
            // j past the towing point reads the towing point's (never a panic).
            self.ws.joints[(j - 1).min(self.model.segment_count() - 1)].position
        }
    }
    /// Velocity of joint `j`, NED, m/s.
    pub fn joint_velocity(&self, j: usize) -> Vec3<T> {
        if j == 0 {
            self.ws.connection.velocity
        } else {
            self.ws.joints[j - 1].velocity
        }
    }
    /// Angular acceleration of segment `i` (1-based), NED, rad/s^2.
    pub fn segment_angular_acceleration(&self, i: usize) -> Vec3<T> {
        self.derivative.rates[i - 1]
    }
    /// The state derivative of this evaluation.
    pub fn derivative(&self) -> &Derivative<T, N> {
        self.derivative
    }
    /// Decoy outputs, or `None` for a free end.
    pub fn decoy(&self) -> Option<DecoyOutputs<T>> {
        self.model.decoy()?;
        let d = &self.ws.decoy;
        let attitude = self.state.decoy_rotation();
        Some(DecoyOutputs {
            cg_position: d.cg_position,
            cg_velocity: d.cg_velocity,
            attitude,
            euler: crate::scalar::euler_zyx(&crate::scalar::rotation_matrix(
                self.state.decoy_attitude,
            )),
            rate: self.state.decoy_rate,
            angular_acceleration: self.derivative.decoy_rate,
            angle_of_attack: d.angle_of_attack,
            airspeed: d.airspeed,
            aero_force: d.aero_force,
            aero_moment: d.aero_moment_body,
        })
    }
}
