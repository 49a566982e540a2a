//! One derivative evaluation taken apart into its passes, for the breakdown
//! benchmarks (`eval_breakdown` in criterion, `breakdown` in gungraun).
//!
//! `solver_core::dynamics::evaluate` is [`prepare`] (kinematics, loads, velocity
//! terms, the decoy's joint block) then [`solve_tensions`] (the joint rows D_j, b_j
//! are assembled inside the forward sweep, fused with it, then the back sweep) then
//! [`accelerations`]. The aerodynamics inside `prepare` cannot be timed in place, so
//! [`Pass::CableDrag`] and [`Pass::DecoyAero`] call the same public functions
//! (`dynamics::cable_drag` with the local density for every segment,
//! `dynamics::decoy_aero` with the density at the decoy's centre of gravity) on the
//! inputs `prepare` gives them, computed here beforehand. The report derives
//! kinematics + assembly = prepare − (cable drag + decoy aero).

use std::hint::black_box;

use solver_core::dynamics::{
    accelerations, cable_drag, decoy_aero, evaluate, prepare, solve_tensions,
};
use solver_core::motion::connection_and_air;
use solver_core::{
    AirColumn, Derivative, FlightPath, Model, PointKinematics, Real, Solver, State, TensionMethod,
    Vec3, Workspace,
};

/// One measured part of a derivative evaluation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pass {
    /// `dynamics::evaluate`: all three passes (the whole).
    Evaluate,
    /// Pass 1, `dynamics::prepare`: kinematics, loads (including the aerodynamics),
    /// velocity terms, the decoy's joint block.
    Prepare,
    /// The cable drag of every segment (local density + `dynamics::cable_drag`), as
    /// done inside `prepare`.
    CableDrag,
    /// The decoy aerodynamics (density + `dynamics::decoy_aero`), as inside `prepare`.
    DecoyAero,
    /// Pass 2, `dynamics::solve_tensions`: assembly of the joint rows fused with the
    /// forward sweep, then the back sweep.
    SolveTensions,
    /// Pass 3, `dynamics::accelerations`.
    Accelerations,
}

impl Pass {
    /// Every pass, in the order of the report's table.
    pub const ALL: [Pass; 6] = [
        Pass::Evaluate,
        Pass::Prepare,
        Pass::CableDrag,
        Pass::DecoyAero,
        Pass::SolveTensions,
        Pass::Accelerations,
    ];

    /// The benchmark name of the pass (stable, parsed by the report).
    pub fn name(self) -> &'static str {
        match self {
            Pass::Evaluate => "evaluate",
            Pass::Prepare => "prepare",
            Pass::CableDrag => "cable_drag",
            Pass::DecoyAero => "decoy_aero",
            Pass::SolveTensions => "solve_tensions",
            Pass::Accelerations => "accelerations",
        }
    }
}

/// The inputs of one segment's drag, as `prepare` computes them.
#[derive(Clone, Copy, Debug)]
struct DragInput<T: Real> {
    centre_altitude: T,
    length: T,
    direction: Vec3<T>,
    relative_air: Vec3<T>,
}

/// The decoy's aerodynamic inputs, as `prepare` computes them.
#[derive(Clone, Copy, Debug)]
struct DecoyInput<T: Real> {
    cg_altitude: T,
    cg_velocity: Vec3<T>,
}

/// A model and state with everything the passes read, evaluated once so that every
/// pass can run alone on a filled workspace.
#[derive(Clone, Debug)]
pub struct Passes<T: Real, const N: usize> {
    model: Model<T, N>,
    state: State<T, N>,
    connection: PointKinematics<T>,
    air: AirColumn<T>,
    ws: Workspace<T, N>,
    out: Derivative<T, N>,
    drag: Vec<DragInput<T>>,
    decoy: Option<DecoyInput<T>>,
}

impl<T: Real, const N: usize> Passes<T, N> {
    /// The solver's model and current state, the flight path sampled at the state's
    /// time; boxed. Panics if the state cannot be evaluated.
    pub fn new<P: FlightPath<T>>(solver: &Solver<T, N>, path: &P) -> Box<Self> {
        let model = *solver.model();
        let state = *solver.state();
        let (connection, air) =
            connection_and_air(&model, &path.state_at(state.time)).expect("valid aircraft state");
        // The kinematics of `prepare` (p_i = p_{i-1} + l_i e_i, v_i = v_{i-1} + l_i w_i x e_i)
        // to get each drag's inputs.
        let n = model.segment_count();
        let wind = model.params().environment.wind;
        let half = T::lit(0.5);
        let (mut p, mut v) = (connection.position, connection.velocity);
        let mut drag = Vec::with_capacity(n);
        for i in 0..n {
            let (e, w, l) = (state.directions[i], state.rates[i], model.lengths()[i]);
            let we = w.cross(&e);
            drag.push(DragInput {
                centre_altitude: -(p.z + e.z * (half * l)),
                length: l,
                direction: e,
                relative_air: wind - (v + we * (half * l)),
            });
            p += e * l;
            v += we * l;
        }
        let decoy = model.decoy().map(|(_, derived)| {
            let rotation = state.decoy_rotation();
            let cg_position = p - rotation * derived.tow_from_cg;
            DecoyInput {
                cg_altitude: -cg_position.z,
                cg_velocity: v - rotation * state.decoy_rate.cross(&derived.tow_from_cg),
            }
        });
        let mut passes = Box::new(Passes {
            model,
            state,
            connection,
            air,
            ws: Workspace::default(),
            out: Derivative::default(),
            drag,
            decoy,
        });
        passes.run(Pass::Evaluate);
        passes
    }

    /// Runs `pass` once. The tension solve's result is checked (the state is a
    /// trimmed or initial one, the solve succeeds).
    pub fn run(&mut self, pass: Pass) {
        match pass {
            Pass::Evaluate => evaluate(
                &self.model,
                &self.state,
                &self.connection,
                &self.air,
                TensionMethod::TwoSweep,
                &mut self.ws,
                &mut self.out,
            )
            .expect("derivative evaluation"),
            Pass::Prepare => prepare(
                &self.model,
                &self.state,
                &self.connection,
                &self.air,
                &mut self.ws,
            ),
            Pass::CableDrag => {
                black_box(self.cable_drag());
            }
            Pass::DecoyAero => {
                black_box(self.decoy_aero());
            }
            Pass::SolveTensions => {
                solve_tensions(&self.model, &self.state, &mut self.ws).expect("tension solve")
            }
            Pass::Accelerations => accelerations(&self.model, &self.state, &self.ws, &mut self.out),
        }
        black_box(&self.out);
        black_box(&self.ws);
    }

    /// The sum of every segment's drag (the sum keeps every call alive).
    fn cable_drag(&self) -> Vec3<T> {
        let cable = &self.model.params().cable;
        let mut sum = Vec3::zeros();
        for input in &self.drag {
            let input = black_box(input);
            let density = self.air.density(input.centre_altitude);
            sum += cable_drag(
                cable,
                density,
                input.length,
                &input.direction,
                &input.relative_air,
            );
        }
        sum
    }

    /// The decoy's aerodynamic force and moment (zero without a decoy).
    fn decoy_aero(&self) -> (Vec3<T>, Vec3<T>) {
        match (self.model.decoy(), &self.decoy) {
            (Some((params, derived)), Some(input)) => {
                let input = black_box(input);
                let density = self.air.density(input.cg_altitude);
                let (force, moment, ..) = decoy_aero(
                    params,
                    derived,
                    &self
                        .state
                        .decoy_rotation()
                        .to_rotation_matrix()
                        .into_inner(),
                    &self.state.decoy_rate,
                    &input.cg_velocity,
                    &self.model.params().environment.wind,
                    density,
                );
                (force, moment)
            }
            _ => (Vec3::zeros(), Vec3::zeros()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{cruise_path, graded_layout, towed_solver};

    #[test]
    fn the_aerodynamics_inputs_are_those_of_prepare() {
        let solver = towed_solver::<f64, 16>(graded_layout());
        let mut passes = Passes::new(&*solver, &cruise_path::<f64>());
        for pass in Pass::ALL {
            passes.run(pass);
        }
        // The decoy's airload recomputed here is the one `prepare` found.
        let (decoy_force, _) = passes.decoy_aero();
        assert!(decoy_force.norm() > 1.0, "the decoy has airloads in cruise");
        let drag = passes.cable_drag();
        assert!(drag.norm() > 1.0, "the cable has drag in cruise");
        let mut outputs_solver = solver.clone();
        let outputs = outputs_solver.outputs(&cruise_path::<f64>()).unwrap();
        let decoy = outputs.decoy().unwrap();
        assert!(
            (decoy.aero_force - decoy_force).norm() <= 1e-9 * decoy_force.norm(),
            "{:?} != {decoy_force:?}",
            decoy.aero_force
        );
    }
}
