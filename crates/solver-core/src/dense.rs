//! Dense reference solver (host only): an independent mass-matrix formulation.
//!
//! Kane's method in 2N + 3 generalised speeds: for each segment the two components
//! of its angular velocity in a basis (n1, n2) perpendicular to e_i, and for the
//! decoy the three NED components of its angular velocity. Hinge forces never
//! appear. With partial velocities ∂v_c/∂u and ∂w/∂u, Kane's equations
//!
//! ```text
//!   sum over bodies  ∂v_c/∂u_r . (F - m a_c) + ∂w/∂u_r . (tau - I dw/dt - w x I w) = 0
//! ```
//!
//! give a dense symmetric positive-definite system M(q) du/dt = f(q, u), assembled
//! with O(N²) entries and factored by dense Cholesky (O(N³)). The joint forces are
//! recovered afterwards from each body's Newton equation, from the free end up.
//! It shares only the kinematics and load models with the O(N) solver (pass 1 of
//! [`crate::dynamics`]), not the tension recurrence.
//!
//! [`DenseDerivative`] steps it with the solver's RK4 ([`crate::rk4::Rk4`]): the
//! same stages, weights and renormalisation, only the derivative differs.

extern crate std;
use std::vec::Vec;

use nalgebra::{DMatrix, DVector};

use crate::atmosphere::AirColumn;
use crate::dynamics::{Workspace, prepare_keeping_loads};
use crate::error::{InputError, SolveError};
use crate::model::Model;
use crate::motion::{FlightPath, PointKinematics};
use crate::rk4::DerivativeSource;
use crate::scalar::{Real, Vec3};
use crate::state::{Derivative, State};

/// Result of a dense evaluation.
#[derive(Clone, Debug)]
pub struct DenseSolution<T: Real, const N: usize> {
    /// The state derivative (same layout as the O(N) solver's).
    pub derivative: Derivative<T, N>,
    /// Joint forces T_0..T_N (T_N = 0 for a free end), NED, N.
    pub joint_forces: Vec<Vec3<T>>,
}

/// Two unit vectors perpendicular to `e` and to each other.
fn basis<T: Real>(e: &Vec3<T>) -> (Vec3<T>, Vec3<T>) {
    let (ax, ay, az) = (e.x.abs(), e.y.abs(), e.z.abs());
    let helper = if ax <= ay && ax <= az {
        Vec3::x()
    } else if ay <= az {
        Vec3::y()
    } else {
        Vec3::z()
    };
    let n1 = e.cross(&helper).normalize();
    let n2 = e.cross(&n1);
    (n1, n2)
}

/// Evaluates the dynamics at `state` with the dense Kane formulation.
pub fn evaluate_dense<T: Real, const N: usize>(
    model: &Model<T, N>,
    state: &State<T, N>,
    connection: &PointKinematics<T>,
    air: &AirColumn<T>,
) -> Result<DenseSolution<T, N>, SolveError> {
    let n = model.segment_count();
    // Loads (gravity, drag, decoy aerodynamics) from the shared pass 1.
    let mut ws = std::boxed::Box::new(Workspace::<T, N>::default());
    prepare_keeping_loads(model, state, connection, air, &mut ws);
    let lengths = model.lengths();
    let masses = model.masses();
    let half = T::lit(0.5);
    let decoy = model.decoy();
    let dof = 2 * n + if decoy.is_some() { 3 } else { 0 };

    // Velocity-only accelerations of joints and centres, and each body's "residual force" G = F - m a⁰.
    let mut joint_accel0 = connection.acceleration;
    let mut residual: Vec<Vec3<T>> = Vec::with_capacity(n);
    let mut centre_accel0: Vec<Vec3<T>> = Vec::with_capacity(n);
    let bases: Vec<(Vec3<T>, Vec3<T>)> = state.directions[..n].iter().map(basis).collect();
    for i in 0..n {
        let e = state.directions[i];
        let w = state.rates[i];
        let wwe = w.cross(&w.cross(&e));
        let centre = joint_accel0 + wwe * (half * lengths[i]);
        joint_accel0 += wwe * lengths[i];
        centre_accel0.push(centre);
        residual.push(ws.joints[i].specific_force * masses[i] - centre * masses[i]);
    }
    // Decoy: rho = CG from towing point (NED), residual force, moment and inertia in NED.
    let mut decoy_terms = None;
    if let Some((params, derived)) = decoy {
        let rotation = state.decoy_rotation();
        let rot = rotation.to_rotation_matrix();
        let r = *rot.matrix();
        let rho = -(rotation * derived.tow_from_cg);
        let w = rotation * state.decoy_rate;
        let inertia = r * nalgebra::Matrix3::from_diagonal(&params.inertia_cg) * r.transpose();
        let cg_accel0 = joint_accel0 + w.cross(&w.cross(&rho));
        let gravity = Vec3::new(T::zero(), T::zero(), model.params().environment.gravity);
        let force = ws.decoy.aero_force + gravity * params.mass;
        let g_decoy = force - cg_accel0 * params.mass;
        let moment = rotation * ws.decoy.aero_moment_body - w.cross(&(inertia * w));
        decoy_terms = Some((
            params.mass,
            rho,
            inertia,
            g_decoy,
            moment,
            cg_accel0,
            force,
            rotation,
        ));
    }

    // Suffix sums: mass and residual force of everything downstream of segment j.
    let mut suffix_mass = std::vec![T::zero(); n];
    let mut suffix_residual = std::vec![Vec3::zeros(); n];
    let (mut m_acc, mut g_acc) = match &decoy_terms {
        Some((m, _, _, g, ..)) => (*m, *g),
        None => (T::zero(), Vec3::zeros()),
    };
    for j in (0..n).rev() {
        suffix_mass[j] = m_acc;
        suffix_residual[j] = g_acc;
        m_acc += masses[j];
        g_acc += residual[j];
    }

    // Partial velocity of a centre with respect to speed (j, a) is c_kj (n_a x e_j), with
    // c_kj = l_j for j < k, l_k/2 for j = k, 0 otherwise; the decoy CG sees l_j for every j.
    let mut mass_matrix = DMatrix::<T>::zeros(dof, dof);
    let mut rhs = DVector::<T>::zeros(dof);
    let cross_dirs: Vec<[Vec3<T>; 2]> = (0..n)
        .map(|j| {
            [
                bases[j].0.cross(&state.directions[j]),
                bases[j].1.cross(&state.directions[j]),
            ]
        })
        .collect();
    for j in 0..n {
        let lj = lengths[j];
        for jp in j..n {
            let ljp = lengths[jp];
            let coefficient = if j < jp {
                lj * ljp * (masses[jp] * half + suffix_mass[jp])
            } else {
                lj * lj * (masses[j] * T::lit(0.25) + suffix_mass[j])
            };
            for a in 0..2 {
                for b in 0..2 {
                    let mut value = coefficient * cross_dirs[j][a].dot(&cross_dirs[jp][b]);
                    if j == jp {
                        let inertia = masses[j] * lj * lj / T::lit(12.0);
                        let na = if a == 0 { bases[j].0 } else { bases[j].1 };
                        let nb = if b == 0 { bases[j].0 } else { bases[j].1 };
                        value += inertia * na.dot(&nb);
                    }
                    mass_matrix[(2 * j + a, 2 * jp + b)] = value;
                    mass_matrix[(2 * jp + b, 2 * j + a)] = value;
                }
            }
        }
        let force_arm = residual[j] * half + suffix_residual[j];
        let e = state.directions[j];
        let w = state.rates[j];
        let inertia = masses[j] * lj * lj / T::lit(12.0);
        let gyroscopic = w.cross(&((w - e * w.dot(&e)) * inertia));
        for a in 0..2 {
            let na = if a == 0 { bases[j].0 } else { bases[j].1 };
            rhs[2 * j + a] = cross_dirs[j][a].dot(&force_arm) * lj - na.dot(&gyroscopic);
        }
    }
    if let Some((m_d, rho, inertia, g_decoy, moment, ..)) = &decoy_terms {
        let base = 2 * n;
        let axes = [Vec3::x(), Vec3::y(), Vec3::z()];
        for a in 0..3 {
            let va = axes[a].cross(rho);
            for b in 0..3 {
                let vb = axes[b].cross(rho);
                mass_matrix[(base + a, base + b)] = *m_d * va.dot(&vb) + inertia[(a, b)];
            }
            for j in 0..n {
                for s in 0..2 {
                    let value = *m_d * lengths[j] * cross_dirs[j][s].dot(&va);
                    mass_matrix[(2 * j + s, base + a)] = value;
                    mass_matrix[(base + a, 2 * j + s)] = value;
                }
            }
            rhs[base + a] = va.dot(g_decoy) + axes[a].dot(moment);
        }
    }

    let accel = mass_matrix
        .cholesky()
        .ok_or(SolveError::NonPositivePivot { joint: 0 })?
        .solve(&rhs);

    // Map back to the state derivative, and recover joint forces from Newton's law per body.
    let mut derivative = Derivative::<T, N>::default();
    let mut joint_accel = connection.acceleration;
    let mut centre_accel = Vec::with_capacity(n);
    for i in 0..n {
        let e = state.directions[i];
        let dw = bases[i].0 * accel[2 * i] + bases[i].1 * accel[2 * i + 1];
        derivative.directions[i] = state.rates[i].cross(&e);
        derivative.rates[i] = dw;
        let tangential = dw.cross(&e);
        let w = state.rates[i];
        let ddot_e = tangential + w.cross(&w.cross(&e));
        centre_accel.push(joint_accel + ddot_e * (half * lengths[i]));
        joint_accel += ddot_e * lengths[i];
    }
    let mut joint_forces = std::vec![Vec3::zeros(); n + 1];
    if let Some((m_d, rho, _, _, _, _, force, rotation)) = &decoy_terms {
        let dw = Vec3::new(accel[2 * n], accel[2 * n + 1], accel[2 * n + 2]);
        let w = rotation * state.decoy_rate;
        let cg_accel = joint_accel + dw.cross(rho) + w.cross(&w.cross(rho));
        joint_forces[n] = cg_accel * *m_d - force;
        derivative.decoy_rate = rotation.inverse_transform_vector(&dw);
        let [qw, qx, qy, qz] = state.decoy_attitude;
        let wb = state.decoy_rate;
        let dq = nalgebra::Quaternion::new(qw, qx, qy, qz)
            * nalgebra::Quaternion::new(T::zero(), wb.x, wb.y, wb.z);
        derivative.decoy_attitude = [dq.w * half, dq.i * half, dq.j * half, dq.k * half];
    }
    for k in (0..n).rev() {
        // m_k a_ck = T_{k-1} - T_k + F_k.
        joint_forces[k] = centre_accel[k] * masses[k] - ws.joints[k].specific_force * masses[k]
            + joint_forces[k + 1];
    }
    let _ = centre_accel0;
    Ok(DenseSolution {
        derivative,
        joint_forces,
    })
}

/// The dense Kane derivative along a flight path, as a [`DerivativeSource`] for
/// [`crate::rk4::Rk4`]: each stage samples the path ([`crate::motion::connection_and_air`], no
/// cache) and evaluates [`evaluate_dense`] (which allocates its matrices).
#[derive(Clone, Copy, Debug)]
pub struct DenseDerivative<'a, T: Real, const N: usize, P: ?Sized> {
    model: &'a Model<T, N>,
    path: &'a P,
}

impl<'a, T: Real, const N: usize, P: FlightPath<T> + ?Sized> DenseDerivative<'a, T, N, P> {
    /// The dense derivative of `model` hanging from the aircraft flying `path`.
    pub fn new(model: &'a Model<T, N>, path: &'a P) -> Self {
        DenseDerivative { model, path }
    }
}

impl<T: Real, const N: usize, P: FlightPath<T> + ?Sized> DerivativeSource<T, N>
    for DenseDerivative<'_, T, N, P>
{
    type Inputs = (PointKinematics<T>, AirColumn<T>);

    fn segment_count(&self) -> usize {
        self.model.segment_count()
    }

    fn inputs_at(&mut self, time: f64) -> Result<Self::Inputs, SolveError> {
        let params = self.model.params();
        let connection = self.path.point_at(time, &params.connection_point)?;
        let air = AirColumn::about(&params.environment.atmosphere, -connection.position.z)
            .map_err(InputError::from)?;
        Ok((connection, air))
    }

    fn evaluate(
        &mut self,
        state: &State<T, N>,
        (connection, air): &Self::Inputs,
        out: &mut Derivative<T, N>,
    ) -> Result<(), SolveError> {
        *out = evaluate_dense(self.model, state, connection, air)?.derivative;
        Ok(())
    }
}
