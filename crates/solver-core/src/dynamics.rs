//! One evaluation of the equations of motion, in named passes:
//!
//! 1. [`prepare`]: forward kinematics down the chain (joint 0 = connection point,
//!    joint N = towing point), loads on every body (gravity, cable cross-flow drag,
//!    decoy aerodynamics), and the velocity-dependent terms of each joint equation.
//! 2. [`solve_tensions`]: the tension recurrence (docs/design.md §3) as a block LDLᵀ
//!    (block Thomas) two-sweep elimination with 3x3 blocks; or
//!    [`solve_tensions_shooting`], the paper's single-sweep shooting form, kept as a
//!    reference that the tests show diverging with N.
//! 3. [`accelerations`]: segment and decoy angular accelerations from the tensions.
//!
//! The back sweep of pass 2 is written once (`back_sweep`), generic over what is
//! done with each segment's derivative as it is found (a `SegmentSink`, inlined and
//! monomorphised for each use): the separate pass ([`solve_tensions`]), passes 2
//! and 3 fused ([`solve_tensions_and_accelerations`]), and the RK4 stages formed in
//! the sweep ([`solve_tensions_first_stage`], [`solve_tensions_to_stage`]). Every use
//! does each segment's arithmetic in the same order, so gives the same bits.
//!
//! Notation (docs/design.md §3): T_j is the force the upstream body exerts on the downstream
//! body at joint j; segment i runs from joint i-1 to joint i with unit direction
//! e_i, mass m_i, length l_i, projector P_i = I - e_i e_iᵀ. For every joint the
//! joint's acceleration written from its two bodies must agree:
//!
//! ```text
//!   -(I - 3P_j)/m_j T_{j-1} + D_j T_j - (I - 3P_{j+1})/m_{j+1} T_{j+1} = b_j
//!   D_j = (I + 3P_j)/m_j + (I + 3P_{j+1})/m_{j+1}
//!   b_j = (F_j/m_j - c_j) - (F_{j+1}/m_{j+1} + c_{j+1}),  c_i = -(l_i/2) w_i x (w_i x e_i)
//! ```
//!
//! closed at joint 0 by the prescribed connection-point acceleration
//! (`D_0 = (I + 3P_1)/m_1`, `b_0 = a_0 - F_1/m_1 - c_1`) and at joint N by the decoy's
//! Newton-Euler equations (`D_N += I/m_d + [r]xᵀ I_d⁻¹ [r]x`), or by T_N = 0 for a free end.

use crate::atmosphere::AirColumn;
use crate::error::SolveError;
use crate::model::Model;
use crate::motion::PointKinematics;
use crate::rk4::StageUpdate;
use crate::scalar::{Mat3, Real, Vec3, norm, opaque, vec_finite, zero3, zero33};
use crate::state::{Derivative, State};

/// Per-evaluation scratch and results. Read after an evaluation through
/// [`crate::Outputs`]; the hot loop writes it and keeps nothing else.
///
/// Indexing: entry `i` of the per-segment arrays belongs to segment i+1 and its
/// downstream joint i+1; joint 0 (the connection point) has its own fields.
#[derive(Clone, Copy, Debug)]
pub struct Workspace<T: Real, const N: usize> {
    /// Joint 0 kinematics (connection point).
    pub(crate) connection: PointKinematics<T>,
    /// Per joint i+1 and its upstream segment i+1: position, air velocity, loads and
    /// right-hand side ([`JointScratch`]), side by side (one base address in the
    /// segment loop).
    pub(crate) joints: [JointScratch<T>; N],
    /// Right-hand side b_N of the towing-point joint (with the decoy's part).
    pub(crate) tow_rhs: Vec3<T>,
    /// Shooting reference: the affine carriers U_j of T_j = U_j T_0 + u_j (host
    /// builds only).
    #[cfg(feature = "std")]
    pub(crate) elimination: [Mat3<T>; N],
    /// Elimination: what the back sweep needs of joint j = i ([`Pivot`]); the
    /// shooting reference keeps its affine offsets u_j in `reduced_rhs`.
    pub(crate) pivots: [Pivot<T>; N],
    /// T_{i+1}: force of segment i+1 on the next body at joint i+1.
    pub(crate) joint_force: [Vec3<T>; N],
    /// T_0: force of the aircraft on segment 1 at the connection point.
    pub(crate) connection_force: Vec3<T>,
    /// Decoy quantities of this evaluation (zero for a free end).
    pub(crate) decoy: DecoyScratch<T>,
}

/// What one evaluation keeps of joint i+1 (entry i) and segment i+1.
#[derive(Clone, Copy, Debug)]
pub(crate) struct JointScratch<T: Real> {
    /// Position of joint i+1, NED (set by [`joint_kinematics`]).
    pub(crate) position: Vec3<T>,
    /// Velocity of joint i+1, NED (set by [`joint_kinematics`], with the position).
    pub(crate) velocity: Vec3<T>,
    /// External force per unit mass on segment i+1 (gravity + drag), F/m: kept by
    /// [`prepare_keeping_loads`] only (the product's evaluation does not need it).
    pub(crate) specific_force: Vec3<T>,
    /// Right-hand side b_j of joint j = i (docs/design.md §3; joint 0 holds the prescribed
    /// connection-point acceleration), assembled with the loads in pass 1.
    pub(crate) rhs: Vec3<T>,
    /// de/dt = w x e of segment i+1 (pass 1 forms it for the velocities; pass 3's
    /// derivative copies it).
    pub(crate) direction_rate: Vec3<T>,
}

impl<T: Real> JointScratch<T> {
    /// Every entry zero.
    const ZERO: Self = JointScratch {
        position: zero3(),
        velocity: zero3(),
        specific_force: zero3(),
        rhs: zero3(),
        direction_rate: zero3(),
    };
}

/// Decoy quantities of one evaluation.
#[derive(Clone, Copy, Debug)]
pub struct DecoyScratch<T: Real> {
    /// CG position, NED.
    pub cg_position: Vec3<T>,
    /// CG velocity, NED.
    pub cg_velocity: Vec3<T>,
    /// Aerodynamic force, NED, N.
    pub aero_force: Vec3<T>,
    /// Aerodynamic moment about the CG (table moment, lift/drag transfer, damping), body frame, N m.
    pub aero_moment_body: Vec3<T>,
    /// Total angle of attack, rad.
    pub angle_of_attack: T,
    /// Airspeed at the CG, m/s.
    pub airspeed: T,
    /// Dynamic pressure, Pa.
    pub dynamic_pressure: T,
    /// Decoy attitude as a rotation matrix (body FRD to NED), from the normalised quaternion.
    pub(crate) rotation: Mat3<T>,
    /// Decoy block of joint N: I/m_d + [r]xᵀ I⁻¹ [r]x (NED).
    pub(crate) joint_block: Sym3<T>,
    /// The towing point from the CG, NED: R r_tow.
    pub(crate) tow_from_cg: Vec3<T>,
    /// w x I w, body frame.
    pub(crate) gyroscopic: Vec3<T>,
    /// Decoy part of b_N.
    pub(crate) joint_rhs: Vec3<T>,
}

impl<T: Real, const N: usize> Workspace<T, N> {
    /// Every value zero, all zero bits (the workspace of
    /// [`Solver::UNCONFIGURED`](crate::Solver::UNCONFIGURED), which a `static` keeps
    /// in `.bss`); [`Workspace::default`] but for the decoy rotation, which is the
    /// identity there.
    pub(crate) const ZERO: Self = {
        let z = zero3();
        Workspace {
            connection: PointKinematics {
                position: z,
                velocity: z,
                acceleration: z,
            },
            joints: [JointScratch::ZERO; N],
            tow_rhs: z,
            #[cfg(feature = "std")]
            elimination: [zero33(); N],
            pivots: [Pivot::ZERO; N],
            joint_force: [z; N],
            connection_force: z,
            decoy: DecoyScratch {
                cg_position: z,
                cg_velocity: z,
                aero_force: z,
                aero_moment_body: z,
                angle_of_attack: T::ZERO,
                airspeed: T::ZERO,
                dynamic_pressure: T::ZERO,
                rotation: zero33(),
                joint_block: Sym3::ZERO,
                tow_from_cg: z,
                gyroscopic: z,
                joint_rhs: z,
            },
        }
    };

    /// Sets every value as [`Workspace::default`] does, in place (no workspace-sized
    /// temporary).
    pub(crate) fn reset(&mut self) {
        *self = Self::ZERO;
        self.decoy.rotation = Mat3::identity();
    }
}

impl<T: Real, const N: usize> Default for Workspace<T, N> {
    fn default() -> Self {
        let z = Vec3::zeros();
        Workspace {
            connection: PointKinematics {
                position: z,
                velocity: z,
                acceleration: z,
            },
            joints: [JointScratch::ZERO; N],
            tow_rhs: z,
            #[cfg(feature = "std")]
            elimination: [Mat3::zeros(); N],
            pivots: [Pivot::ZERO; N],
            joint_force: [z; N],
            connection_force: z,
            decoy: DecoyScratch {
                cg_position: z,
                cg_velocity: z,
                aero_force: z,
                aero_moment_body: z,
                angle_of_attack: T::zero(),
                airspeed: T::zero(),
                dynamic_pressure: T::zero(),
                rotation: Mat3::identity(),
                joint_block: Sym3::ZERO,
                tow_from_cg: z,
                gyroscopic: z,
                joint_rhs: z,
            },
        }
    }
}

/// Which tension solver [`evaluate`] uses. `repr(u8)`, the two-sweep 0: an
/// `Option` of it keeps `None` in a niche, `Some(TwoSweep)` is zero bits, in
/// every build (with one variant, as without `std`, it would otherwise be a
/// zero-sized type whose `Option` needs a tag byte: the solver's all-zero
/// constant, `Solver::UNCONFIGURED`, would not be).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum TensionMethod {
    /// Block LDLᵀ two-sweep elimination: O(N), numerically stable. The product's solver.
    TwoSweep,
    /// The paper's single-sweep shooting form: O(N), round-off grows about 3.7^N.
    /// Reference only, in host builds (feature `std`): a `no_std` build, the
    /// firmware's, has the two-sweep alone, so its frame path links no code of
    /// this method (whose general matrix inverse can panic).
    #[cfg(feature = "std")]
    Shooting,
}

/// Cable cross-flow drag on a segment (docs/design.md §2): with the air velocity relative to
/// the segment centre u split into u_t = (u.e)e and u_n = u - u_t,
/// `F = 0.5 rho d l (C_n |u_n| u_n + pi C_f |u.e| u_t)`.
///
/// |u_t| is taken as |u.e|: equal for the unit directions of every state; inside
/// an RK4 step the stage directions e0 + h k are not renormalised and |e| differs
/// from 1 by O(h² w²) (below 1e-5 for the product's steps), a change of the same
/// order as the stage itself. It spares one square root per segment.
#[inline(always)]
pub fn cable_drag<T: Real>(
    model_cable: &crate::model::CableParams<T>,
    density: T,
    length: T,
    direction: &Vec3<T>,
    relative_air: &Vec3<T>,
) -> Vec3<T> {
    let k = T::lit(0.5) * density * model_cable.diameter * length;
    let along = relative_air.dot(direction);
    let ut = direction * along;
    let un = relative_air - ut;
    un * (k * model_cable.cd_normal * norm(&un))
        + ut * (k * T::pi() * model_cable.cf_tangential * along.abs())
}

/// Aerodynamic force and moment on the decoy, docs/design.md §2.
///
/// Inputs: decoy attitude as the rotation matrix R (body FRD to NED), body rate, CG velocity over the
/// ground, wind, local density. Output: force (NED), moment about the CG (body
/// frame), total angle of attack, airspeed, dynamic pressure.
///
/// Lift acts in the plane of the total angle of attack along the part of the body
/// axis perpendicular to the airflow; drag opposes the airflow; the table moment Cm
/// (positive nose-up, i.e. increasing the angle of attack) acts about the axis
/// V̂ x x_b at the moment reference point and is transferred to the CG; damping
/// moments are `q S L cm_q (w_perp L / 2V)` and `q S L cl_p (p L / 2V)`.
pub fn decoy_aero<T: Real>(
    decoy: &crate::model::DecoyParams<T>,
    derived: &crate::model::DecoyDerived<T>,
    rotation: &Mat3<T>,
    body_rate: &Vec3<T>,
    cg_velocity: &Vec3<T>,
    wind: &Vec3<T>,
    density: T,
) -> (Vec3<T>, Vec3<T>, T, T, T) {
    let vb = rotation.tr_mul(&(cg_velocity - wind));
    let speed = norm(&vb);
    let zero = Vec3::zeros();
    if !(speed > T::lit(1e-6)) || !(density > T::zero()) {
        return (zero, zero, T::zero(), speed, T::zero());
    }
    let q = T::lit(0.5) * density * speed * speed;
    let inverse_speed = T::one() / speed;
    let vhat = vb * inverse_speed;
    // Within [-1, 1] by comparison (`clamp` is two library calls on the M4F, and
    // an assertion).
    let one = T::one();
    let cos_a = if vhat.x > one {
        one
    } else if vhat.x < -one {
        -one
    } else {
        vhat.x
    };
    // The part of the body axis x = (1, 0, 0) across the airflow, x - vhat cos_a,
    // and its length sin_a.
    let perp = Vec3::new(one - vhat.x * cos_a, -(vhat.y * cos_a), -(vhat.z * cos_a));
    let sin_a = norm(&perp);
    let alpha = sin_a.upper_atan2(cos_a);
    let c = decoy.aero.at(alpha);
    let qs = q * derived.reference_area;
    let qsl = qs * decoy.length;
    let drag = -qs * c.cd;
    let mut force_b = vhat * drag;
    let mut moment_b = Vec3::zeros();
    if sin_a > T::lit(1e-9) {
        let inv = T::one() / sin_a;
        let lift = qs * c.cl * inv;
        force_b += perp * lift;
        // vhat x x = (0, vhat.z, -vhat.y).
        let pitching = qsl * c.cm * inv;
        moment_b = Vec3::new(T::zero(), vhat.z * pitching, -(vhat.y * pitching));
    }
    // The force's moment about the CG from the moment reference point, on the body
    // x axis at (m, 0, 0): m (0, -f_z, f_y).
    let m = derived.mrp_from_cg.x;
    let damping = qsl * decoy.length * (T::lit(0.5) * inverse_speed);
    let pitch_yaw = damping * decoy.cm_q;
    moment_b += Vec3::new(
        damping * decoy.cl_p * body_rate.x,
        body_rate.y * pitch_yaw - m * force_b.z,
        body_rate.z * pitch_yaw + m * force_b.y,
    );
    (rotation * force_b, moment_b, alpha, speed, q)
}

/// The segment loop of [`prepare`]: `p_i = p_{i-1} + l_i e_i`, `v_i = v_{i-1} + l_i w_i x e_i`,
/// gravity and cable drag per unit mass F_i/m_i at each segment centre, the
/// centripetal term c_i = -(l_i/2) w_i x (w_i x e_i), and the joint right-hand sides
/// b_{i-1} += -(F_i/m_i + c_i), b_i += F_i/m_i - c_i (b_0 starts from a_0). Returns the
/// last segment's share F_N/m_N - c_N of b_N.
///
/// Carried down the chain: the joint position, the air velocity relative to the
/// joint (wind - v) and the joint altitude. With u the air velocity relative to the
/// segment centre, u·e its axial part and u_n = u - (u·e) e:
/// `F/m = g + rho (k_n |u_n|) u_n + rho (k_t |u·e| (u·e)) e`.
#[inline(always)]
fn cable_loads<T: Real, const N: usize, const AIR: bool, const LOADS: bool>(
    model: &Model<T, N>,
    state: &State<T, N>,
    connection: &PointKinematics<T>,
    ws: &mut Workspace<T, N>,
    density_at: impl Fn(T) -> T,
) -> (Vec3<T>, T, Vec3<T>) {
    let n = model.segment_count();
    let env = &model.params().environment;
    let gravity = env.gravity;
    let mut air = env.wind - connection.velocity;
    let mut altitude = -connection.position.z;
    let (normal_drag, tangential_drag) = model.drag_factors();
    // Through `opaque`: the joints' own base address in a register.
    let rows = state.directions[..n]
        .iter()
        .zip(&state.rates[..n])
        .zip(model.lengths().iter().zip(model.half_lengths()))
        .zip(normal_drag)
        .zip(tangential_drag)
        .zip(opaque(&mut ws.joints[..n]).iter_mut());
    let mut carry = connection.acceleration;
    for (((((e, w), (l, half_l)), normal_drag), tangential_drag), joint) in rows {
        // Copies first: the stores below may alias for all the optimiser knows.
        let (e, w, l, half_l) = (*e, *w, *l, *half_l);
        let we = Vec3::new(
            w.y * e.z - w.z * e.y,
            w.z * e.x - w.x * e.z,
            w.x * e.y - w.y * e.x,
        );
        let specific = if AIR {
            // cable_drag(..)/m_i with the per-unit-mass factors of the model.
            let density = density_at(altitude - e.z * half_l);
            let u = Vec3::new(
                air.x - we.x * half_l,
                air.y - we.y * half_l,
                air.z - we.z * half_l,
            );
            let along = u.x * e.x + u.y * e.y + u.z * e.z;
            let un = Vec3::new(u.x - e.x * along, u.y - e.y * along, u.z - e.z * along);
            let speed = (un.x * un.x + un.y * un.y + un.z * un.z).square_root();
            let normal = density * *normal_drag * speed;
            let axial = density * *tangential_drag * along.abs() * along;
            Vec3::new(
                un.x * normal + e.x * axial,
                un.y * normal + e.y * axial,
                gravity + un.z * normal + e.z * axial,
            )
        } else {
            Vec3::new(T::zero(), T::zero(), gravity)
        };
        // -c_i = (l/2) w x (w x e).
        let wwe = Vec3::new(
            w.y * we.z - w.z * we.y,
            w.z * we.x - w.x * we.z,
            w.x * we.y - w.y * we.x,
        );
        let minus_c = wwe * half_l;
        if LOADS {
            joint.specific_force = specific;
        }
        joint.rhs = carry - specific + minus_c;
        joint.direction_rate = we;
        carry = specific + minus_c;
        altitude -= e.z * l;
        air = Vec3::new(air.x - we.x * l, air.y - we.y * l, air.z - we.z * l);
    }
    (carry, altitude, air)
}

/// Joint positions and velocities (`p_i = p_{i-1} + l_i e_i`, `v_i = v_{i-1} + l_i w_i x e_i`
/// from the connection point) and the decoy's CG position, for the outputs of the
/// evaluation in `ws` at `state`. The evaluation itself needs only altitudes and air
/// velocities, which [`prepare`] carries down the chain; this pass runs only for
/// evaluations whose outputs are read ([`crate::Solver::outputs`], the observed first
/// stage of [`crate::Solver::step_observed`]).
pub(crate) fn joint_kinematics<T: Real, const N: usize>(
    model: &Model<T, N>,
    state: &State<T, N>,
    ws: &mut Workspace<T, N>,
) {
    let n = model.segment_count();
    let mut p = ws.connection.position;
    let mut v = ws.connection.velocity;
    let rows = state.directions[..n]
        .iter()
        .zip(&state.rates[..n])
        .zip(model.lengths())
        .zip(ws.joints[..n].iter_mut());
    for (((e, w), l), joint) in rows {
        p += e * *l;
        v += w.cross(e) * *l;
        joint.position = p;
        joint.velocity = v;
    }
    if model.has_decoy() {
        ws.decoy.cg_position = p - ws.decoy.tow_from_cg;
    }
}

/// Pass 1: kinematics, loads and the velocity terms.
///
/// Joint 0 is the connection point; `p_i = p_{i-1} + l_i e_i`,
/// `v_i = v_{i-1} + l_i w_i x e_i`. Cable loads act at segment centres; the
/// product's evaluation needs them only in the right-hand sides, so each
/// segment's F_i/m_i is not kept ([`prepare_keeping_loads`] keeps it).
#[inline(never)]
pub fn prepare<T: Real, const N: usize>(
    model: &Model<T, N>,
    state: &State<T, N>,
    connection: &PointKinematics<T>,
    air: &AirColumn<T>,
    ws: &mut Workspace<T, N>,
) {
    prepare_loads::<T, N, false>(model, state, connection, air, ws);
}

/// [`prepare`], keeping each segment's external force per unit mass F_i/m_i in
/// the workspace (for the dense reference, [`crate::dense`]); the same bits
/// otherwise.
pub fn prepare_keeping_loads<T: Real, const N: usize>(
    model: &Model<T, N>,
    state: &State<T, N>,
    connection: &PointKinematics<T>,
    air: &AirColumn<T>,
    ws: &mut Workspace<T, N>,
) {
    prepare_loads::<T, N, true>(model, state, connection, air, ws);
}

#[inline(always)]
fn prepare_loads<T: Real, const N: usize, const LOADS: bool>(
    model: &Model<T, N>,
    state: &State<T, N>,
    connection: &PointKinematics<T>,
    air: &AirColumn<T>,
    ws: &mut Workspace<T, N>,
) {
    let (model, state, ws) = opaque((model, state, ws));
    let params = model.params();
    let env = &params.environment;
    let gravity = Vec3::new(T::zero(), T::zero(), env.gravity);
    let has_air = air.air.density > T::zero() && params.cable.diameter > T::zero();
    ws.connection = *connection;
    // One density law at every altitude (the tropopause's kink a term of its own,
    // zero away from it): the segment loop's cost does not depend on the altitude.
    let law = air.law;
    let (tow_rhs, tow_altitude, tow_air) = if has_air {
        cable_loads::<T, N, true, LOADS>(model, state, connection, ws, |h| law.density(h))
    } else {
        cable_loads::<T, N, false, LOADS>(model, state, connection, ws, |_| T::zero())
    };
    ws.tow_rhs = tow_rhs;

    if let Some((decoy, derived)) = model.decoy() {
        // One normalisation and one rotation matrix per evaluation (also used by pass 3).
        let r = crate::scalar::rotation_matrix(state.decoy_attitude);
        let wb = state.decoy_rate;
        // The towing point lies on the body x axis from the CG (r_tow = (a, 0, 0), the
        // model's `tow_from_cg`), so R r_tow = a R x_b and w x r_tow = a (0, w_z, -w_y).
        let a = derived.tow_from_cg.x;
        let (c0, c1, c2) = (r.column(0), r.column(1), r.column(2));
        let tow_from_cg = Vec3::new(a * c0[0], a * c0[1], a * c0[2]);
        let cg_velocity = env.wind
            - tow_air
            - Vec3::new(
                a * (wb.z * c1[0] - wb.y * c2[0]),
                a * (wb.z * c1[1] - wb.y * c2[1]),
                a * (wb.z * c1[2] - wb.y * c2[2]),
            );
        let density = air.density(tow_altitude + tow_from_cg.z);
        let (aero_force, aero_moment_body, alpha, airspeed, dynamic_pressure) =
            decoy_aero(decoy, derived, &r, &wb, &cg_velocity, &env.wind, density);
        let inertia = decoy.inertia_cg;
        let iw = Vec3::new(inertia.x * wb.x, inertia.y * wb.y, inertia.z * wb.z);
        let gyroscopic = wb.cross(&iw);
        // Towing-point acceleration from the decoy side (a_tow = a_cg + dw x r + w x (w x r)):
        //   a_tow = (T_N + F_d)/m_d + [r]xᵀ I⁻¹ [r]x T_N - r x I⁻¹ (M - w x I w) + w x (w x r).
        // `rhs_body` is its force-free angular part in the body frame; with r = (a, 0, 0):
        // w x (w x r) = a (-(w_y² + w_z²), w_x w_y, w_x w_z), r x f = a (0, -f_z, f_y).
        let inv = &derived.inertia_inv;
        let free_angular = aero_moment_body - gyroscopic;
        let (fy, fz) = (free_angular.y * inv.y, free_angular.z * inv.z);
        let rhs_body = Vec3::new(
            -a * (wb.y * wb.y + wb.z * wb.z),
            a * (wb.x * wb.y + fz),
            a * (wb.x * wb.z - fy),
        );
        let inverse_mass = T::one() / decoy.mass;
        let force = aero_force + gravity * decoy.mass;
        // [r]xᵀ I⁻¹ [r]x = diag(0, a²/I_z, a²/I_y) (the model's hinge compliance), so
        // R (...) Rᵀ = (a²/I_z) c1 c1ᵀ + (a²/I_y) c2 c2ᵀ with c1, c2 columns of R.
        let compliance = &derived.hinge_compliance;
        let f1 = c1 * compliance[(1, 1)];
        let f2 = c2 * compliance[(2, 2)];
        let joint_block = Sym3 {
            xx: inverse_mass + f1[0] * c1[0] + f2[0] * c2[0],
            yy: inverse_mass + f1[1] * c1[1] + f2[1] * c2[1],
            zz: inverse_mass + f1[2] * c1[2] + f2[2] * c2[2],
            xy: f1[0] * c1[1] + f2[0] * c2[1],
            xz: f1[0] * c1[2] + f2[0] * c2[2],
            yz: f1[1] * c1[2] + f2[1] * c2[2],
        };
        // Field by field (the CG position, set by `joint_kinematics`, stays).
        let d = &mut ws.decoy;
        d.rotation = r;
        d.tow_from_cg = tow_from_cg;
        d.cg_velocity = cg_velocity;
        d.aero_force = aero_force;
        d.aero_moment_body = aero_moment_body;
        d.gyroscopic = gyroscopic;
        d.angle_of_attack = alpha;
        d.airspeed = airspeed;
        d.dynamic_pressure = dynamic_pressure;
        d.joint_block = joint_block;
        // a_N (segment side) = a_tow: the decoy contributes -(F_d/m_d + R rhs_body) to b_N.
        let joint_rhs = -(force * inverse_mass) - r * rhs_body;
        d.joint_rhs = joint_rhs;
        ws.tow_rhs = tow_rhs + joint_rhs;
    }
}

/// The diagonal contribution (I + 3P)/m = (4I - 3 e eᵀ)/m of one segment to each of its joints.
#[cfg(feature = "std")]
#[inline(always)]
fn segment_block<T: Real>(e: &Vec3<T>, inverse_mass: T) -> Mat3<T> {
    let three = T::lit(3.0);
    let four = T::lit(4.0);
    let mut m = e * e.transpose() * (-three * inverse_mass);
    let d = four * inverse_mass;
    m[(0, 0)] += d;
    m[(1, 1)] += d;
    m[(2, 2)] += d;
    m
}

/// `B X` for the coupling block B = -(I - 3P)/m = (2I - 3 e eᵀ)/m.
#[cfg(feature = "std")]
#[inline(always)]
fn coupling_times<T: Real>(e: &Vec3<T>, inverse_mass: T, x: &Mat3<T>) -> Mat3<T> {
    let row = e.transpose() * x;
    (x * T::lit(2.0) - e * row * T::lit(3.0)) * inverse_mass
}

#[cfg(feature = "std")]
#[inline(always)]
fn coupling_times_vec<T: Real>(e: &Vec3<T>, inverse_mass: T, v: &Vec3<T>) -> Vec3<T> {
    (v * T::lit(2.0) - e * (T::lit(3.0) * e.dot(v))) * inverse_mass
}

/// Right-hand side b_j and diagonal block D_j of joint `j` (0..=last).
#[cfg(feature = "std")]
#[inline(always)]
fn joint_row<T: Real, const N: usize>(
    model: &Model<T, N>,
    state: &State<T, N>,
    ws: &Workspace<T, N>,
    j: usize,
) -> (Mat3<T>, Vec3<T>) {
    let n = model.segment_count();
    let inverse_masses = model.inverse_masses();
    let mut block = Mat3::zeros();
    if j > 0 {
        // Upstream segment j (index j-1) seen from its downstream end.
        block += segment_block(&state.directions[j - 1], inverse_masses[j - 1]);
    }
    if j < n {
        // Downstream segment j+1 (index j) seen from its upstream end.
        block += segment_block(&state.directions[j], inverse_masses[j]);
        (block, ws.joints[j].rhs)
    } else {
        block += ws.decoy.joint_block.matrix();
        (block, ws.tow_rhs)
    }
}

/// What the back sweep needs of joint j's pivot S_j (segment j+1 with direction e and
/// mass m): T_j = z_j - Q_j T_{j+1} + U_j (e·T_{j+1}).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Pivot<T: Real> {
    /// Q_j = (2/m) S_j⁻¹ (symmetric).
    scaled_inverse: Sym3<T>,
    /// U_j = (3/m) S_j⁻¹ e.
    scaled_direction: Vec3<T>,
    /// z_j = S_j⁻¹ y_j (the shooting reference keeps its affine offsets here).
    pub(crate) reduced_rhs: Vec3<T>,
}

impl<T: Real> Pivot<T> {
    /// Every entry zero.
    const ZERO: Self = Pivot {
        scaled_inverse: Sym3::ZERO,
        scaled_direction: zero3(),
        reduced_rhs: zero3(),
    };
}

/// A symmetric 3x3 matrix, six entries (the pivot blocks S_j and their inverses).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Sym3<T: Real> {
    xx: T,
    yy: T,
    zz: T,
    xy: T,
    xz: T,
    yz: T,
}

impl<T: Real> Sym3<T> {
    /// Every entry zero.
    const ZERO: Self = Sym3 {
        xx: T::ZERO,
        yy: T::ZERO,
        zz: T::ZERO,
        xy: T::ZERO,
        xz: T::ZERO,
        yz: T::ZERO,
    };

    /// The segment contribution -3 e eᵀ/m to a joint's diagonal block, plus `diagonal`
    /// times the identity (4/m for (I + 3P)/m = (4I - 3 e eᵀ)/m alone).
    #[inline(always)]
    fn segment(e: &Vec3<T>, inverse_mass: T, diagonal: T) -> Self {
        let f = e * (-T::lit(3.0) * inverse_mass);
        Sym3 {
            xx: diagonal + f.x * e.x,
            yy: diagonal + f.y * e.y,
            zz: diagonal + f.z * e.z,
            xy: f.x * e.y,
            xz: f.x * e.z,
            yz: f.y * e.z,
        }
    }

    /// The full matrix.
    #[cfg(feature = "std")]
    fn matrix(&self) -> Mat3<T> {
        Mat3::new(
            self.xx, self.xy, self.xz, self.xy, self.yy, self.yz, self.xz, self.yz, self.zz,
        )
    }

    #[inline(always)]
    fn scaled(&self, k: T) -> Self {
        Sym3 {
            xx: self.xx * k,
            yy: self.yy * k,
            zz: self.zz * k,
            xy: self.xy * k,
            xz: self.xz * k,
            yz: self.yz * k,
        }
    }

    #[inline(always)]
    fn mul(&self, v: &Vec3<T>) -> Vec3<T> {
        Vec3::new(
            self.xx * v.x + self.xy * v.y + self.xz * v.z,
            self.xy * v.x + self.yy * v.y + self.yz * v.z,
            self.xz * v.x + self.yz * v.y + self.zz * v.z,
        )
    }

    /// Inverse by cofactors, or `None` unless positive definite by Sylvester's
    /// criterion (leading minors a, a d - b², det all positive; false for NaN too).
    /// One division.
    #[inline(always)]
    fn spd_inverse(&self) -> Option<Self> {
        let (cofactors, det) = self.cofactors();
        let inv = T::one() / det;
        self.positive_definite(det, inv)
            .then(|| cofactors.scaled(inv))
    }

    /// The cofactor (adjugate) matrix C, with S⁻¹ = C / det, and det.
    #[inline(always)]
    fn cofactors(&self) -> (Self, T) {
        let (a, b, c) = (self.xx, self.xy, self.xz);
        let (d, e, f) = (self.yy, self.yz, self.zz);
        let c00 = d * f - e * e;
        let c01 = c * e - b * f;
        let c02 = b * e - c * d;
        let det = a * c00 + b * c01 + c * c02;
        let cofactors = Sym3 {
            xx: c00,
            yy: a * f - c * c,
            zz: a * d - b * b,
            xy: c01,
            xz: c02,
            yz: b * c - a * e,
        };
        (cofactors, det)
    }

    /// The pivot test of the elimination: 1/det > 0 (one float compare, false for
    /// NaN): det positive and finite, or +0, whose infinite inverse then makes the
    /// forces non-finite, which the evaluation's finiteness checks report (a
    /// vanishing pivot shows as a non-finite force rather than a non-positive
    /// pivot).
    ///
    /// Every pivot is a Schur complement of the SPD system matrix, so SPD in exact
    /// arithmetic; rounding loses that near singularity by one eigenvalue crossing
    /// zero, which turns the determinant's sign: that is what this catches. (An
    /// indefinite pivot with a positive determinant, two eigenvalues crossing
    /// together, needs rounding errors as large as the pivot's eigenvalues
    /// themselves. Sylvester's other two minors, and `det > 0` besides `1/det >
    /// 0`, cost about 15 instructions a joint, 2,900 a frame on the M4F.)
    #[inline(always)]
    fn positive_definite(&self, _det: T, inv_det: T) -> bool {
        inv_det > T::zero()
    }
}

/// The last joint with an unknown force: N with a decoy, N-1 for a free end (T_N = 0),
/// of the model's segment count `n` read once by the caller (the optimiser then sees
/// last <= n <= N: no bounds check on the arrays).
#[inline(always)]
fn last_joint_of<T: Real, const N: usize>(model: &Model<T, N>, n: usize) -> usize {
    (if model.has_decoy() { n } else { n - 1 }).min(N)
}

/// Pass 2: the tension recurrence as a block LDLᵀ two-sweep elimination.
///
/// Forward sweep (joint 0 toward the decoy): S_0 = D_0, y_0 = b_0, and for each joint
/// X_j = S_j⁻¹ B_j, z_j = S_j⁻¹ y_j, S_{j+1} = D_{j+1} - B_j X_j, y_{j+1} = b_{j+1} - B_j z_j,
/// where B_j = -(I - 3P_{j+1})/m_{j+1} = (2I - 3 e eᵀ)/m is symmetric. Back sweep:
/// T_last = S_last⁻¹ y_last, T_j = z_j - X_j T_{j+1}. Every S_j is a Schur complement of
/// an SPD matrix and so SPD; a pivot block that is not positive definite is reported
/// with its joint.
///
/// Structure used (the cost per joint matters on the microcontroller): the pivots are
/// symmetric and kept as six entries; S_j⁻¹ by cofactors (one division). With
/// e = e_{j+1}, m = m_{j+1}, u = S_j⁻¹ e:
///
/// ```text
///   X_j T       = (2 S_j⁻¹ T - 3 u (e·T))/m                     (never formed)
///   B_j X_j     = (4 S_j⁻¹ - 6 (u eᵀ + e uᵀ) + 9 (e·u) e eᵀ)/m²
///   S_{j+1}     = 4/m I - 4/m² S_j⁻¹ + w eᵀ + e wᵀ + (segment j+2 or decoy block)
///   w           = (6 u - 4.5 (e·u) e)/m² - 1.5 e/m
/// ```
///
/// (the last two fold segment j+1's own diagonal contribution (4I - 3 e eᵀ)/m into the
/// rank-2 update). With C the cofactor matrix (S_j⁻¹ = C/det), u = (C e)/det and
/// z_j = (C y_j)/det: the products with C do not wait for the division, which keeps
/// the serial chain from one joint to the next short (the sweep is latency-bound on
/// hosts).
#[inline(never)]
pub fn solve_tensions<T: Real, const N: usize>(
    model: &Model<T, N>,
    state: &State<T, N>,
    ws: &mut Workspace<T, N>,
) -> Result<(), SolveError> {
    let (model, state, ws) = opaque((model, state, ws));
    back_sweep(model, ws, Forces { state })
}

/// What [`back_sweep`] does with each segment's derivative as it is found: the one
/// part in which its uses differ ([`Forces`], [`Accelerations`], [`FirstStage`],
/// [`ToStage`]). Every method is inlined and the sweep is monomorphised for each
/// sink, so each use compiles to one loop fused with its sink's work, as if written
/// out by hand (the firmware's instruction counts are those of the hand-fused
/// copies, or a few fewer).
///
/// A sink's rows are its entries of the segments (references into its arrays): the
/// loop walks them by index together with the workspace's arrays, one base address
/// per array.
trait SegmentSink<T: Real, const N: usize> {
    /// Every force T_j kept in the workspace and probed for finiteness; otherwise
    /// only T_0 and T_N (which the decoy's equations read) are kept, and nothing is
    /// probed (a non-finite force then makes the derivative non-finite, which the
    /// RK4 step's final check finds).
    const KEEP: bool;
    /// The sink's entries of one segment.
    type Row<'r>;
    /// The rows of a range of segment indices, in order.
    type Rows<'r>: DoubleEndedIterator<Item = Self::Row<'r>> + ExactSizeIterator
    where
        Self: 'r;
    /// What a row holds that its write needs besides the direction.
    type Read: Copy;
    /// The values every row's write uses (stage factor, weight).
    type Factors: Copy;

    /// The state evaluated: its directions e_i.
    fn state(&self) -> &State<T, N>;
    /// The factors of [`SegmentSink::write`].
    fn factors(&self) -> Self::Factors;
    /// The rows of segment indices `range`.
    fn rows(&mut self, range: core::ops::Range<usize>) -> Self::Rows<'_>;
    /// The row of segment index `i` (below the segment count), outside the loop:
    /// the first segment, and the last one of a free end.
    fn row(&mut self, i: usize) -> Self::Row<'_>;
    /// The row's direction e_i (of the state evaluated).
    fn direction(row: &Self::Row<'_>) -> Vec3<T>;
    /// What the row's write needs besides the direction. In the loop it is read,
    /// with the direction, before anything is stored (the stores may alias the
    /// loads for all the optimiser knows).
    fn read(row: &Self::Row<'_>) -> Self::Read;
    /// Segment i's derivative, de_i/dt = `de` and dw_i/dt = `dw`, into its row
    /// (`e` its direction, `read` what [`SegmentSink::read`] read of it).
    fn write(
        row: Self::Row<'_>,
        e: Vec3<T>,
        read: Self::Read,
        factors: Self::Factors,
        de: Vec3<T>,
        dw: Vec3<T>,
    );
    /// The decoy's part once every force is found (T_N, T_0 in the workspace).
    fn decoy(&mut self, model: &Model<T, N>, ws: &Workspace<T, N>);
}

/// Pass 2 and the segments' part of pass 3, written once for every use: the
/// forward sweep ([`forward_sweep`]), then the back sweep T_j = z_j - X_j T_{j+1}
/// ([`back_substitute`]) from joint last-1 down to joint 0, handing each segment's
/// derivative to `sink` as soon as both its forces are known:
///
/// ```text
///   de_i/dt = w_i x e_i,   dw_i/dt = -(6/(m_i l_i)) e_i x (T_{i-1} + T_i)
/// ```
///
/// (segment i+1, index i, between T_i upstream and T_{i+1}; for a free end the
/// last segment's downstream T_N is zero). T_last and T_0 are always kept, the
/// forces between them as the sink says ([`SegmentSink::KEEP`]), and then the
/// decoy's part is the sink's. Each segment's arithmetic is that of the separate
/// passes ([`solve_tensions`] then [`accelerations`]), in the same order: the same
/// bits whatever the sink.
#[inline(always)]
fn back_sweep<T: Real, const N: usize, S: SegmentSink<T, N>>(
    model: &Model<T, N>,
    ws: &mut Workspace<T, N>,
    mut sink: S,
) -> Result<(), SolveError> {
    let n = model.segment_count();
    let last = last_joint_of(model, n);
    let gains = model.rate_gains_all();
    let mut t = forward_sweep(model, sink.state(), ws)?;
    let mut probe = t.x + t.y + t.z;
    let factors = sink.factors();
    // T_{j+1} while T_j is found; for a free end the last segment's downstream
    // force T_N is zero.
    let mut downstream = if last == n {
        ws.joint_force[n - 1] = t;
        t
    } else {
        let zero = Vec3::zeros();
        ws.joint_force[n - 1] = zero;
        if last > 0 {
            ws.joint_force[last - 1] = t;
        }
        let we = ws.joints[n - 1].direction_rate;
        let row = sink.row(n - 1);
        let (e, read) = (S::direction(&row), S::read(&row));
        let dw = -e.cross(&(t + zero)) * gains[n - 1];
        S::write(row, e, read, factors, we, dw);
        t
    };
    // Joints last-1 down to 1 (T_j into joint_force[j-1]), then joint 0.
    if last > 0 {
        let range = 1..last;
        // Through `opaque`: the pivots' own base address in a register, so that their
        // fields are reached by small offsets (see `opaque`).
        let rows = opaque(&ws.pivots[range.clone()])
            .iter()
            .zip(opaque(&ws.joints[range.clone()]))
            .zip(&gains[range.clone()])
            .zip(sink.rows(range))
            .zip(ws.joint_force[..last - 1].iter_mut())
            .rev();
        for ((((pivot, joint), gain), row), force) in rows {
            // Copies first: the stores below may alias for all the optimiser knows.
            let (pivot, we, gain) = (*pivot, joint.direction_rate, *gain);
            let (e, read) = (S::direction(&row), S::read(&row));
            t = back_substitute(&pivot, &e, &t);
            if S::KEEP {
                probe += t.x + t.y + t.z;
            }
            // Segment j+1 (index j) between T_j (upstream) and T_{j+1}.
            let dw = -e.cross(&(t + downstream)) * gain;
            S::write(row, e, read, factors, we, dw);
            downstream = t;
            if S::KEEP {
                *force = t;
            }
        }
        let we = ws.joints[0].direction_rate;
        let row = sink.row(0);
        let e = S::direction(&row);
        t = back_substitute(&ws.pivots[0], &e, &t);
        if S::KEEP {
            probe += t.x + t.y + t.z;
        }
        let dw = -e.cross(&(t + downstream)) * gains[0];
        // No store since the row was taken: its other values are read as late as
        // they are needed (fewer values live across the substitution).
        let read = S::read(&row);
        S::write(row, e, read, factors, we, dw);
    }
    ws.connection_force = t;
    let result = if S::KEEP {
        finish_tensions(model, ws, probe)
    } else {
        Ok(())
    };
    sink.decoy(model, ws);
    result
}

/// Two arrays' entries `range` walked together (a sink's rows).
type Pair<'r, T> = core::iter::Zip<core::slice::Iter<'r, Vec3<T>>, core::slice::Iter<'r, Vec3<T>>>;
/// Two arrays' entries `range` walked together, to write (a sink's rows).
type PairMut<'r, T> =
    core::iter::Zip<core::slice::IterMut<'r, Vec3<T>>, core::slice::IterMut<'r, Vec3<T>>>;

/// [`Pair`] of `a` and `b` over `range`.
#[inline(always)]
fn pair<'r, T: Real, const N: usize>(
    a: &'r [Vec3<T>; N],
    b: &'r [Vec3<T>; N],
    range: core::ops::Range<usize>,
) -> Pair<'r, T> {
    a[range.clone()].iter().zip(&b[range])
}

/// [`PairMut`] of `a` and `b` over `range`.
#[inline(always)]
fn pair_mut<'r, T: Real, const N: usize>(
    a: &'r mut [Vec3<T>; N],
    b: &'r mut [Vec3<T>; N],
    range: core::ops::Range<usize>,
) -> PairMut<'r, T> {
    a[range.clone()].iter_mut().zip(b[range].iter_mut())
}

/// The sink of [`solve_tensions`]: every force kept and probed, no derivative.
struct Forces<'a, T: Real, const N: usize> {
    state: &'a State<T, N>,
}

impl<T: Real, const N: usize> SegmentSink<T, N> for Forces<'_, T, N> {
    const KEEP: bool = true;
    type Row<'r> = &'r Vec3<T>;
    type Rows<'r>
        = core::slice::Iter<'r, Vec3<T>>
    where
        Self: 'r;
    type Read = ();
    type Factors = ();

    #[inline(always)]
    fn state(&self) -> &State<T, N> {
        self.state
    }
    #[inline(always)]
    fn factors(&self) {}
    #[inline(always)]
    fn rows(&mut self, range: core::ops::Range<usize>) -> Self::Rows<'_> {
        self.state.directions[range].iter()
    }
    #[inline(always)]
    fn row(&mut self, i: usize) -> &Vec3<T> {
        // i is n - 1 or 0 (both below N), restated: no bounds check.
        &self.state.directions[i.min(N - 1)]
    }
    #[inline(always)]
    fn direction(e: &&Vec3<T>) -> Vec3<T> {
        **e
    }
    #[inline(always)]
    fn read(_: &&Vec3<T>) {}
    #[inline(always)]
    fn write(_: &Vec3<T>, _: Vec3<T>, _: (), _: (), _: Vec3<T>, _: Vec3<T>) {}
    #[inline(always)]
    fn decoy(&mut self, _: &Model<T, N>, _: &Workspace<T, N>) {}
}

/// Passes 2 and 3 in one: [`solve_tensions`] with the segment accelerations of
/// [`accelerations`] computed in its back sweep, where each segment's two joint
/// forces are at hand (the same arithmetic, so the same bits). The product's
/// evaluation; the separate passes remain for the pass-by-pass benchmarks.
#[inline(never)]
pub fn solve_tensions_and_accelerations<T: Real, const N: usize>(
    model: &Model<T, N>,
    state: &State<T, N>,
    ws: &mut Workspace<T, N>,
    out: &mut Derivative<T, N>,
) -> Result<(), SolveError> {
    tensions_and_accelerations::<T, N, true>(model, state, ws, out)
}

/// [`solve_tensions_and_accelerations`] for an intermediate RK4 stage, whose
/// forces nobody reads: only T_0 and T_N (the decoy's equations read it) are
/// kept, and nothing is probed (a non-finite force makes the stage's derivative
/// and the step's state non-finite, which the step's final check finds). The
/// same derivative, bit for bit.
#[inline(never)]
pub fn solve_tensions_and_accelerations_of_a_stage<T: Real, const N: usize>(
    model: &Model<T, N>,
    state: &State<T, N>,
    ws: &mut Workspace<T, N>,
    out: &mut Derivative<T, N>,
) -> Result<(), SolveError> {
    tensions_and_accelerations::<T, N, false>(model, state, ws, out)
}

/// [`solve_tensions_and_accelerations`], keeping and probing every force
/// (`KEEP`) or only T_0 and T_N.
#[inline(always)]
fn tensions_and_accelerations<T: Real, const N: usize, const KEEP: bool>(
    model: &Model<T, N>,
    state: &State<T, N>,
    ws: &mut Workspace<T, N>,
    out: &mut Derivative<T, N>,
) -> Result<(), SolveError> {
    let (model, state, ws, out) = opaque((model, state, ws, out));
    back_sweep(model, ws, Accelerations::<T, N, KEEP> { state, out })
}

/// The sink of [`solve_tensions_and_accelerations`]: each segment's derivative into
/// `out`, then the decoy's ([`accelerations`]'s arithmetic).
struct Accelerations<'a, T: Real, const N: usize, const KEEP: bool> {
    state: &'a State<T, N>,
    out: &'a mut Derivative<T, N>,
}

impl<T: Real, const N: usize, const KEEP: bool> SegmentSink<T, N>
    for Accelerations<'_, T, N, KEEP>
{
    const KEEP: bool = KEEP;
    type Row<'r> = (&'r Vec3<T>, (&'r mut Vec3<T>, &'r mut Vec3<T>));
    type Rows<'r>
        = core::iter::Zip<core::slice::Iter<'r, Vec3<T>>, PairMut<'r, T>>
    where
        Self: 'r;
    type Read = ();
    type Factors = ();

    #[inline(always)]
    fn state(&self) -> &State<T, N> {
        self.state
    }
    #[inline(always)]
    fn factors(&self) {}
    #[inline(always)]
    fn rows(&mut self, range: core::ops::Range<usize>) -> Self::Rows<'_> {
        let out = &mut *self.out;
        self.state.directions[range.clone()].iter().zip(pair_mut(
            &mut out.directions,
            &mut out.rates,
            range,
        ))
    }
    #[inline(always)]
    fn row(&mut self, i: usize) -> Self::Row<'_> {
        // i is n - 1 or 0 (both below N), restated: no bounds check.
        let i = i.min(N - 1);
        let out = &mut *self.out;
        (
            &self.state.directions[i],
            (&mut out.directions[i], &mut out.rates[i]),
        )
    }
    #[inline(always)]
    fn direction((e, _): &Self::Row<'_>) -> Vec3<T> {
        **e
    }
    #[inline(always)]
    fn read(_: &Self::Row<'_>) {}
    #[inline(always)]
    fn write(
        (_, (de_out, dw_out)): Self::Row<'_>,
        _: Vec3<T>,
        _: (),
        _: (),
        de: Vec3<T>,
        dw: Vec3<T>,
    ) {
        *de_out = de;
        *dw_out = dw;
    }
    #[inline(always)]
    fn decoy(&mut self, model: &Model<T, N>, ws: &Workspace<T, N>) {
        decoy_accelerations(model, self.state, ws, self.out);
    }
}

/// One step of the back sweep: T_j = z_j - X_j T_{j+1}, with
/// X_j T = (2 S_j⁻¹ T - 3 u_j (e·T))/m = Q_j T - U_j (e·T) from the stored
/// [`Pivot`] (`e`: segment j+1's direction).
#[inline(always)]
fn back_substitute<T: Real>(pivot: &Pivot<T>, e: &Vec3<T>, next: &Vec3<T>) -> Vec3<T> {
    let q = &pivot.scaled_inverse;
    let (u, z) = (&pivot.scaled_direction, &pivot.reduced_rhs);
    let along = e.x * next.x + e.y * next.y + e.z * next.z;
    Vec3::new(
        z.x - q.xx * next.x - q.xy * next.y - q.xz * next.z + u.x * along,
        z.y - q.xy * next.x - q.yy * next.y - q.yz * next.z + u.y * along,
        z.z - q.xz * next.x - q.yz * next.y - q.zz * next.z + u.z * along,
    )
}

/// The forward sweep of [`solve_tensions`]: fills the pivots, and returns
/// T_last = S_last⁻¹ y_last.
///
/// Per joint j (segment j+1 with e = e_{j+1}, k = 1/m_{j+1}), with the cofactor
/// matrix C and det of S_j (S_j⁻¹ = C/det, one division):
///
/// ```text
///   Q_j = 2k S_j⁻¹,  U_j = 3k S_j⁻¹ e,  z_j = S_j⁻¹ y_j           (stored)
///   w   = 2k U_j - 1.5k (e·U_j + 1) e
///   S_{j+1} = 4k I - 2k Q_j + w eᵀ + e wᵀ + (segment j+2 or decoy block)
///   y_{j+1} = b_{j+1} - 2k z_j + 3k (e·z_j) e
/// ```
///
/// (B_j S_j⁻¹ B_j = (4 S_j⁻¹ - 6 (u eᵀ + e uᵀ) + 9 (e·u) e eᵀ)/m² with u = S_j⁻¹ e, and
/// segment j+1's own diagonal contribution (4I - 3 e eᵀ)/m folded into the rank-2 term.)
#[inline(always)]
fn forward_sweep<T: Real, const N: usize>(
    model: &Model<T, N>,
    state: &State<T, N>,
    ws: &mut Workspace<T, N>,
) -> Result<Vec3<T>, SolveError> {
    let n = model.segment_count();
    let last = last_joint_of(model, n);
    let inverse_masses = &model.inverse_masses()[..n];
    let directions = &state.directions[..n];
    let four = T::lit(4.0);
    // Joint 0: D_0 = block of segment 1, b_0 = a_0 - F_1/m_1 - c_1.
    let mut e = directions[0];
    let mut k = inverse_masses[0];
    let mut s = Sym3::segment(&e, k, four * k);
    let mut y = ws.joints[0].rhs;
    // Joints 0..n-2: the next joint's own block is segment j+2's (4I - 3 e eᵀ)/m from its
    // upstream end. Through `opaque`: each array's own base address in a register.
    let rows = opaque(&mut ws.pivots[..n - 1])
        .iter_mut()
        .zip(&directions[1..])
        .zip(&inverse_masses[1..])
        .zip(opaque(&ws.joints[1..n]));
    for (j, (((pivot, e_next), k_next), joint)) in rows.enumerate() {
        // The next segment's values are loaded after the pivot is stored (fewer
        // values live across the elimination).
        let (update, diagonal) = eliminate(&s, &y, &e, k, j, pivot)?;
        let (e_next, k_next) = (*e_next, *k_next);
        let block = Sym3::segment(&e_next, k_next, diagonal + four * k_next);
        (s, y) = update.apply(&block, &joint.rhs, &e);
        e = e_next;
        k = k_next;
    }
    if last == n {
        // Joint n-1: the decoy's block at the towing point.
        let (update, diagonal) = eliminate(&s, &y, &e, k, n - 1, &mut ws.pivots[n - 1])?;
        let d = &ws.decoy.joint_block;
        let block = Sym3 {
            xx: d.xx + diagonal,
            yy: d.yy + diagonal,
            zz: d.zz + diagonal,
            ..*d
        };
        (s, y) = update.apply(&block, &ws.tow_rhs, &e);
    }
    let inv = s
        .spd_inverse()
        .ok_or(SolveError::NonPositivePivot { joint: last })?;
    Ok(inv.mul(&y))
}

/// What [`eliminate`] leaves for the next joint: S_{j+1} and y_{j+1} but for the next
/// joint's own block and right-hand side.
struct SchurUpdate<T: Real> {
    /// Q_j.
    q: Sym3<T>,
    /// z_j.
    z: Vec3<T>,
    /// w of the rank-2 term.
    w: Vec3<T>,
    /// 2k.
    two_k: T,
    /// 3k (e·z_j).
    h: T,
}

impl<T: Real> SchurUpdate<T> {
    /// S_{j+1} = block - 2k Q_j + w eᵀ + e wᵀ and y_{j+1} = b - 2k z_j + h e.
    #[inline(always)]
    fn apply(&self, block: &Sym3<T>, b: &Vec3<T>, e: &Vec3<T>) -> (Sym3<T>, Vec3<T>) {
        let (q, z, w, two_k, h) = (&self.q, &self.z, &self.w, self.two_k, self.h);
        let s = Sym3 {
            xx: block.xx - two_k * q.xx + (w.x + w.x) * e.x,
            yy: block.yy - two_k * q.yy + (w.y + w.y) * e.y,
            zz: block.zz - two_k * q.zz + (w.z + w.z) * e.z,
            xy: block.xy - two_k * q.xy + w.x * e.y + e.x * w.y,
            xz: block.xz - two_k * q.xz + w.x * e.z + e.x * w.z,
            yz: block.yz - two_k * q.yz + w.y * e.z + e.y * w.z,
        };
        let y = Vec3::new(
            b.x - two_k * z.x + h * e.x,
            b.y - two_k * z.y + h * e.y,
            b.z - two_k * z.z + h * e.z,
        );
        (s, y)
    }
}

/// Eliminates joint `j` (pivot S_j = `s`, reduced right-hand side `y`; segment j+1
/// with direction `e` and inverse mass `k`): stores its [`Pivot`] and returns the
/// Schur update for joint j+1 with the diagonal 4k that segment j+1 adds there.
#[inline(always)]
fn eliminate<T: Real>(
    s: &Sym3<T>,
    y: &Vec3<T>,
    e: &Vec3<T>,
    k: T,
    j: usize,
    pivot: &mut Pivot<T>,
) -> Result<(SchurUpdate<T>, T), SolveError> {
    let (cofactors, det) = s.cofactors();
    let cofactor_e = cofactors.mul(e);
    let cofactor_y = cofactors.mul(y);
    let inv_det = T::one() / det;
    if !s.positive_definite(det, inv_det) {
        return Err(SolveError::NonPositivePivot { joint: j });
    }
    let two_k = k + k;
    let three_k = T::lit(3.0) * k;
    let q = cofactors.scaled(inv_det * two_k);
    let u = cofactor_e * (inv_det * three_k);
    let z = cofactor_y * inv_det;
    pivot.scaled_inverse = q;
    pivot.scaled_direction = u;
    pivot.reduced_rhs = z;
    let c = T::lit(1.5) * k;
    let eu = e.x * u.x + e.y * u.y + e.z * u.z;
    let g = c + c * eu;
    let w = Vec3::new(
        two_k * u.x - g * e.x,
        two_k * u.y - g * e.y,
        two_k * u.z - g * e.z,
    );
    let ez = e.x * z.x + e.y * z.y + e.z * z.z;
    let update = SchurUpdate {
        q,
        z,
        w,
        two_k,
        h: three_k * ez,
    };
    Ok((update, T::lit(4.0) * k))
}

/// Clears T_N for a free end and checks every force is finite.
///
/// `probe` is the sum of every component of the forces T_0..T_last just computed: finite
/// only if they all are (when it is not, the forces are searched for the culprit).
fn finish_tensions<T: Real, const N: usize>(
    model: &Model<T, N>,
    ws: &mut Workspace<T, N>,
    probe: T,
) -> Result<(), SolveError> {
    let n = model.segment_count();
    if !model.has_decoy() {
        ws.joint_force[n - 1] = Vec3::zeros();
    }
    if probe.finite() {
        return Ok(());
    }
    if !vec_finite(&ws.connection_force) {
        return Err(SolveError::NonFinite { joint: 0 });
    }
    // A probe that overflowed on finite forces is not a failure.
    match ws.joint_force[..n].iter().position(|f| !vec_finite(f)) {
        Some(i) => Err(SolveError::NonFinite { joint: i + 1 }),
        None => Ok(()),
    }
}

/// Pass 2, reference: the paper's single-sweep shooting form.
///
/// T_0 is unknown; every T_j is carried as an affine function U_j T_0 + u_j of it,
/// from row j of the system: T_{j+1} = B_j⁻¹ (b_j - D_j T_j - B_{j-1} T_{j-1}), with
/// B_j⁻¹ = m (I/2 - 3/2 e eᵀ) in closed form. The last row's residual α T_0 + β = 0 fixes
/// T_0 = -α⁻¹ β. The transverse growth factor of this recurrence is about 2 + √3 per
/// segment, so round-off is amplified about 3.7^N: unusable beyond a few tens of
/// segments in f64 and about 8 in f32 (docs/design.md §3). Kept for tests and benchmarks only
/// (feature `std`).
#[cfg(feature = "std")]
pub fn solve_tensions_shooting<T: Real, const N: usize>(
    model: &Model<T, N>,
    state: &State<T, N>,
    ws: &mut Workspace<T, N>,
) -> Result<(), SolveError> {
    let last = last_joint_of(model, model.segment_count());
    let inverse_masses = model.inverse_masses();
    let masses = model.masses();
    // Affine carriers for T_{j-1} and T_j: (U, u).
    let (mut u_prev, mut v_prev) = (Mat3::zeros(), Vec3::zeros());
    let (mut u_cur, mut v_cur) = (Mat3::identity(), Vec3::zeros());
    // Store the carriers to recover every T_j once T_0 is known.
    ws.elimination[0] = u_cur;
    ws.pivots[0].reduced_rhs = v_cur;
    for j in 0..last {
        let (d, b) = joint_row(model, state, ws, j);
        // Row j: B_{j-1} T_{j-1} + D_j T_j + B_j T_{j+1} = b_j.
        let mut rest_u = d * u_cur;
        let mut rest_v = d * v_cur;
        if j > 0 {
            let e_up = state.directions[j - 1];
            rest_u += coupling_times(&e_up, inverse_masses[j - 1], &u_prev);
            rest_v += coupling_times_vec(&e_up, inverse_masses[j - 1], &v_prev);
        }
        let e = state.directions[j];
        // B_j = (2I - 3 e eᵀ)/m has eigenvalue -1/m along e and 2/m across it, so
        // B_j⁻¹ = m (I/2 - 3/2 e eᵀ).
        let binv = (Mat3::identity() * T::lit(0.5) - e * e.transpose() * T::lit(1.5)) * masses[j];
        let u_next = binv * (-rest_u);
        let v_next = binv * (b - rest_v);
        u_prev = u_cur;
        v_prev = v_cur;
        u_cur = u_next;
        v_cur = v_next;
        if j + 1 < N {
            ws.elimination[j + 1] = u_cur;
            ws.pivots[j + 1].reduced_rhs = v_cur;
        }
    }
    // Residual of the last row: B_{last-1} T_{last-1} + D_last T_last - b_last = α T_0 + β.
    let (d, b) = joint_row(model, state, ws, last);
    let mut alpha = d * u_cur;
    let mut beta = d * v_cur - b;
    if last > 0 {
        let e_up = state.directions[last - 1];
        alpha += coupling_times(&e_up, inverse_masses[last - 1], &u_prev);
        beta += coupling_times_vec(&e_up, inverse_masses[last - 1], &v_prev);
    }
    let t0 = alpha
        .lu()
        .solve(&(-beta))
        .ok_or(SolveError::NonPositivePivot { joint: last })?;
    ws.connection_force = t0;
    for j in 1..=last {
        let (u, v) = if j < N {
            (ws.elimination[j], ws.pivots[j].reduced_rhs)
        } else {
            (u_cur, v_cur)
        };
        ws.joint_force[j - 1] = u * t0 + v;
    }
    let mut probe = t0.x + t0.y + t0.z;
    for f in &ws.joint_force[..last] {
        probe += f.x + f.y + f.z;
    }
    finish_tensions(model, ws, probe)
}

/// Pass 3: accelerations from the tensions.
///
/// Segment i: dw_i/dt = -(6/(m_i l_i)) e_i x (T_{i-1} + T_i) (hinge torques about the
/// centre over the thin-rod inertia m l²/12), de_i/dt = w_i x e_i.
/// Decoy: I dw/dt = M + r x T_N - w x I w (body frame), dq/dt = q ⊗ (0, w)/2.
#[inline(never)]
pub fn accelerations<T: Real, const N: usize>(
    model: &Model<T, N>,
    state: &State<T, N>,
    ws: &Workspace<T, N>,
    out: &mut Derivative<T, N>,
) {
    let (model, state, ws, out) = opaque((model, state, ws, out));
    let n = model.segment_count();
    let gains = model.rate_gains();
    let mut upstream = ws.connection_force;
    for i in 0..n {
        let e = state.directions[i];
        let downstream = ws.joint_force[i];
        out.directions[i] = state.rates[i].cross(&e);
        out.rates[i] = -e.cross(&(upstream + downstream)) * gains[i];
        upstream = downstream;
    }
    decoy_accelerations(model, state, ws, out);
}

/// The decoy part of pass 3 (zero for a free end).
#[inline(always)]
fn decoy_accelerations<T: Real, const N: usize>(
    model: &Model<T, N>,
    state: &State<T, N>,
    ws: &Workspace<T, N>,
    out: &mut Derivative<T, N>,
) {
    (out.decoy_attitude, out.decoy_rate) = decoy_derivative(model, state, ws);
}

/// The decoy's dq/dt and dw/dt (zero for a free end).
#[inline(always)]
fn decoy_derivative<T: Real, const N: usize>(
    model: &Model<T, N>,
    state: &State<T, N>,
    ws: &Workspace<T, N>,
) -> ([T; 4], Vec3<T>) {
    let n = model.segment_count();
    if let Some((_, derived)) = model.decoy() {
        let wb = state.decoy_rate;
        let tension_body = ws.decoy.rotation.tr_mul(&ws.joint_force[n - 1]);
        // r x T with r = (a, 0, 0) on the body x axis: a (0, -T_z, T_y).
        let a = derived.tow_from_cg.x;
        let m = &ws.decoy.aero_moment_body;
        let g = &ws.decoy.gyroscopic;
        let inv = &derived.inertia_inv;
        let rate = Vec3::new(
            (m.x - g.x) * inv.x,
            (m.y - a * tension_body.z - g.y) * inv.y,
            (m.z + a * tension_body.y - g.z) * inv.z,
        );
        // dq/dt = q ⊗ (0, w)/2.
        let [qw, qx, qy, qz] = state.decoy_attitude;
        let half = T::lit(0.5);
        let (hx, hy, hz) = (wb.x * half, wb.y * half, wb.z * half);
        let attitude = [
            -qx * hx - qy * hy - qz * hz,
            qw * hx + qy * hz - qz * hy,
            qw * hy - qx * hz + qz * hx,
            qw * hz + qx * hy - qy * hx,
        ];
        (attitude, rate)
    } else {
        ([T::zero(); 4], Vec3::zeros())
    }
}

/// Passes 2 and 3 as [`solve_tensions_and_accelerations`], with the derivative of each
/// segment (and of the decoy), as it is found in the back sweep, turned into the next
/// RK4 stage in `stage` itself (the state evaluated, whose entries are no longer
/// needed once their segment is done) and into the weighted sum: no derivative is
/// stored and read back. Same arithmetic as the separate passes, so the same bits.
///
/// The forces found are not kept (only T_0 and T_N, which the decoy's equations
/// read) and not probed: this is an intermediate stage, nobody reads its forces,
/// and a non-finite force makes the stage non-finite, which the step's final check
/// finds (`Rk4::step`).
#[inline(never)]
pub fn solve_tensions_to_stage<T: Real, const N: usize>(
    model: &Model<T, N>,
    stage: &mut State<T, N>,
    ws: &mut Workspace<T, N>,
    next: StageUpdate<'_, T, N>,
) -> Result<(), SolveError> {
    let (model, stage, ws) = opaque((model, stage, ws));
    let StageUpdate {
        base,
        h,
        sum,
        weight,
    } = next;
    let (base, sum, weight) = opaque((base, sum, weight));
    let sink = ToStage {
        stage,
        base,
        sum,
        h,
        weight,
    };
    back_sweep(model, ws, sink)
}

/// The sink of [`solve_tensions_to_stage`]: each segment's derivative k turned
/// into its entries of the next stage, `stage = base + h k`, in the state
/// evaluated itself, and of the weighted sum, `sum = sum + weight k`; then the
/// decoy's.
struct ToStage<'a, T: Real, const N: usize> {
    /// The state evaluated, overwritten by the next stage.
    stage: &'a mut State<T, N>,
    /// The state the stage starts from.
    base: &'a State<T, N>,
    /// The weighted sum of the stages' derivatives.
    sum: &'a mut Derivative<T, N>,
    /// The stage factor.
    h: T,
    /// The derivative's weight in the sum.
    weight: T,
}

impl<T: Real, const N: usize> SegmentSink<T, N> for ToStage<'_, T, N> {
    const KEEP: bool = false;
    type Row<'r> = (
        (
            (&'r mut Vec3<T>, &'r mut Vec3<T>),
            (&'r Vec3<T>, &'r Vec3<T>),
        ),
        (&'r mut Vec3<T>, &'r mut Vec3<T>),
    );
    type Rows<'r>
        = core::iter::Zip<core::iter::Zip<PairMut<'r, T>, Pair<'r, T>>, PairMut<'r, T>>
    where
        Self: 'r;
    /// e0, w0 of the base, the sum's entries.
    type Read = (Vec3<T>, Vec3<T>, Vec3<T>, Vec3<T>);
    /// h, weight.
    type Factors = (T, T);

    #[inline(always)]
    fn state(&self) -> &State<T, N> {
        self.stage
    }
    #[inline(always)]
    fn factors(&self) -> (T, T) {
        (self.h, self.weight)
    }
    #[inline(always)]
    fn rows(&mut self, range: core::ops::Range<usize>) -> Self::Rows<'_> {
        let (stage, base, sum) = (&mut *self.stage, self.base, &mut *self.sum);
        pair_mut(&mut stage.directions, &mut stage.rates, range.clone())
            .zip(pair(&base.directions, &base.rates, range.clone()))
            .zip(pair_mut(&mut sum.directions, &mut sum.rates, range))
    }
    #[inline(always)]
    fn row(&mut self, i: usize) -> Self::Row<'_> {
        // i is n - 1 or 0 (both below N), restated: no bounds check.
        let i = i.min(N - 1);
        let (stage, base, sum) = (&mut *self.stage, self.base, &mut *self.sum);
        (
            (
                (&mut stage.directions[i], &mut stage.rates[i]),
                (&base.directions[i], &base.rates[i]),
            ),
            (&mut sum.directions[i], &mut sum.rates[i]),
        )
    }
    #[inline(always)]
    fn direction((((e, _), _), _): &Self::Row<'_>) -> Vec3<T> {
        **e
    }
    #[inline(always)]
    fn read(((_, (e0, w0)), (se, sw)): &Self::Row<'_>) -> Self::Read {
        (**e0, **w0, **se, **sw)
    }
    #[inline(always)]
    fn write(
        (((e_out, w_out), _), (se, sw)): Self::Row<'_>,
        _: Vec3<T>,
        (e0, w0, s_e, s_w): Self::Read,
        (h, weight): (T, T),
        de: Vec3<T>,
        dw: Vec3<T>,
    ) {
        *e_out = e0 + de * h;
        *w_out = w0 + dw * h;
        *se = s_e + de * weight;
        *sw = s_w + dw * weight;
    }
    #[inline(always)]
    fn decoy(&mut self, model: &Model<T, N>, ws: &Workspace<T, N>) {
        let (dq, dw) = decoy_derivative(model, self.stage, ws);
        let (h, weight) = (self.h, self.weight);
        for ((o, b), (s, d)) in self
            .stage
            .decoy_attitude
            .iter_mut()
            .zip(&self.base.decoy_attitude)
            .zip(self.sum.decoy_attitude.iter_mut().zip(&dq))
        {
            *o = *b + *d * h;
            *s += *d * weight;
        }
        self.stage.decoy_rate = self.base.decoy_rate + dw * h;
        self.sum.decoy_rate += dw * weight;
    }
}

/// Passes 2 and 3 as [`solve_tensions_and_accelerations`] at `state` (RK4's first
/// stage, k1, into `out`), with the second stage's state `stage = state + h k1`
/// formed in the back sweep as each segment's derivative is found (and the
/// decoy's after it): the bits of the separate passes followed by
/// `State::set_stage`, without reading the derivative back.
#[inline(never)]
pub fn solve_tensions_first_stage<T: Real, const N: usize>(
    model: &Model<T, N>,
    state: &State<T, N>,
    ws: &mut Workspace<T, N>,
    out: &mut Derivative<T, N>,
    stage: &mut State<T, N>,
    h: T,
) -> Result<(), SolveError> {
    tensions_first_stage::<T, N, true>(model, state, ws, out, stage, h)
}

/// [`solve_tensions_first_stage`] keeping only T_0 and T_N and probing nothing
/// (as [`solve_tensions_and_accelerations_of_a_stage`]), for a caller that reads
/// no force of the first stage: the same derivative and stage, bit for bit.
#[inline(never)]
pub fn solve_tensions_first_stage_unkept<T: Real, const N: usize>(
    model: &Model<T, N>,
    state: &State<T, N>,
    ws: &mut Workspace<T, N>,
    out: &mut Derivative<T, N>,
    stage: &mut State<T, N>,
    h: T,
) -> Result<(), SolveError> {
    tensions_first_stage::<T, N, false>(model, state, ws, out, stage, h)
}

/// [`solve_tensions_first_stage`], keeping and probing every force (`KEEP`) or
/// only T_0 and T_N.
#[inline(always)]
fn tensions_first_stage<T: Real, const N: usize, const KEEP: bool>(
    model: &Model<T, N>,
    state: &State<T, N>,
    ws: &mut Workspace<T, N>,
    out: &mut Derivative<T, N>,
    stage: &mut State<T, N>,
    h: T,
) -> Result<(), SolveError> {
    let (model, state, ws, out, stage) = opaque((model, state, ws, out, stage));
    back_sweep(
        model,
        ws,
        FirstStage::<T, N, KEEP> {
            state,
            out,
            stage,
            h,
        },
    )
}

/// The sink of [`solve_tensions_first_stage`]: each segment's derivative k1 into
/// `out` and its entries of the second stage, `stage = state + h k1`; then the
/// decoy's.
struct FirstStage<'a, T: Real, const N: usize, const KEEP: bool> {
    /// The state evaluated (y).
    state: &'a State<T, N>,
    /// k1.
    out: &'a mut Derivative<T, N>,
    /// The second stage's state.
    stage: &'a mut State<T, N>,
    /// The stage factor.
    h: T,
}

impl<T: Real, const N: usize, const KEEP: bool> SegmentSink<T, N> for FirstStage<'_, T, N, KEEP> {
    const KEEP: bool = KEEP;
    type Row<'r> = (
        (&'r Vec3<T>, &'r Vec3<T>),
        (
            (&'r mut Vec3<T>, &'r mut Vec3<T>),
            (&'r mut Vec3<T>, &'r mut Vec3<T>),
        ),
    );
    type Rows<'r>
        = core::iter::Zip<Pair<'r, T>, core::iter::Zip<PairMut<'r, T>, PairMut<'r, T>>>
    where
        Self: 'r;
    /// w of the state.
    type Read = Vec3<T>;
    /// h.
    type Factors = T;

    #[inline(always)]
    fn state(&self) -> &State<T, N> {
        self.state
    }
    #[inline(always)]
    fn factors(&self) -> T {
        self.h
    }
    #[inline(always)]
    fn rows(&mut self, range: core::ops::Range<usize>) -> Self::Rows<'_> {
        let (state, out, stage) = (self.state, &mut *self.out, &mut *self.stage);
        pair(&state.directions, &state.rates, range.clone()).zip(
            pair_mut(&mut out.directions, &mut out.rates, range.clone()).zip(pair_mut(
                &mut stage.directions,
                &mut stage.rates,
                range,
            )),
        )
    }
    #[inline(always)]
    fn row(&mut self, i: usize) -> Self::Row<'_> {
        // i is n - 1 or 0 (both below N), restated: no bounds check.
        let i = i.min(N - 1);
        let (state, out, stage) = (self.state, &mut *self.out, &mut *self.stage);
        (
            (&state.directions[i], &state.rates[i]),
            (
                (&mut out.directions[i], &mut out.rates[i]),
                (&mut stage.directions[i], &mut stage.rates[i]),
            ),
        )
    }
    #[inline(always)]
    fn direction(((e, _), _): &Self::Row<'_>) -> Vec3<T> {
        **e
    }
    #[inline(always)]
    fn read(((_, w), _): &Self::Row<'_>) -> Vec3<T> {
        **w
    }
    #[inline(always)]
    fn write(
        (_, ((de_out, dw_out), (e_out, w_out))): Self::Row<'_>,
        e: Vec3<T>,
        w: Vec3<T>,
        h: T,
        de: Vec3<T>,
        dw: Vec3<T>,
    ) {
        *de_out = de;
        *dw_out = dw;
        *e_out = e + de * h;
        *w_out = w + dw * h;
    }
    #[inline(always)]
    fn decoy(&mut self, model: &Model<T, N>, ws: &Workspace<T, N>) {
        decoy_accelerations(model, self.state, ws, self.out);
        let (state, out, stage, h) = (self.state, &*self.out, &mut *self.stage, self.h);
        for ((o, b), d) in stage
            .decoy_attitude
            .iter_mut()
            .zip(&state.decoy_attitude)
            .zip(&out.decoy_attitude)
        {
            *o = *b + *d * h;
        }
        stage.decoy_rate = state.decoy_rate + out.decoy_rate * h;
    }
}

/// [`evaluate`] at `state` (RK4's first stage) with the second stage's state
/// `stage = state + h k1` formed as the derivative is found
/// ([`solve_tensions_first_stage`]); the shooting reference evaluates and then
/// forms the stage. The same bits either way.
#[allow(clippy::too_many_arguments)]
pub fn evaluate_first_stage<T: Real, const N: usize>(
    model: &Model<T, N>,
    state: &State<T, N>,
    connection: &PointKinematics<T>,
    air: &AirColumn<T>,
    method: TensionMethod,
    ws: &mut Workspace<T, N>,
    stage: &mut State<T, N>,
    out: &mut Derivative<T, N>,
    h: T,
) -> Result<(), SolveError> {
    match method {
        TensionMethod::TwoSweep => {
            prepare(model, state, connection, air, ws);
            solve_tensions_first_stage(model, state, ws, out, stage, h)
        }
        #[cfg(feature = "std")]
        TensionMethod::Shooting => {
            evaluate(model, state, connection, air, method, ws, out)?;
            stage.set_stage(state, out, h, model.segment_count());
            Ok(())
        }
    }
}

/// [`evaluate`] followed by the next RK4 stage ([`StageUpdate`]) in `stage` itself,
/// with the same bits, the derivative never stored (see
/// [`solve_tensions_to_stage`]); the shooting reference evaluates into `out` and
/// forms the stage from it.
#[allow(clippy::too_many_arguments)]
pub fn evaluate_to_stage<T: Real, const N: usize>(
    model: &Model<T, N>,
    stage: &mut State<T, N>,
    connection: &PointKinematics<T>,
    air: &AirColumn<T>,
    method: TensionMethod,
    ws: &mut Workspace<T, N>,
    out: &mut Derivative<T, N>,
    next: StageUpdate<'_, T, N>,
) -> Result<(), SolveError> {
    #[cfg(not(feature = "std"))]
    let _ = out;
    match method {
        TensionMethod::TwoSweep => {
            prepare(model, stage, connection, air, ws);
            solve_tensions_to_stage(model, stage, ws, next)
        }
        #[cfg(feature = "std")]
        TensionMethod::Shooting => {
            evaluate(model, stage, connection, air, method, ws, out)?;
            let n = model.segment_count();
            stage.set_stage_accumulating(next.base, out, next.h, next.sum, next.weight, n);
            Ok(())
        }
    }
}

/// All three passes: the state derivative at `state` given the connection-point
/// kinematics and the air column.
pub fn evaluate<T: Real, const N: usize>(
    model: &Model<T, N>,
    state: &State<T, N>,
    connection: &PointKinematics<T>,
    air: &AirColumn<T>,
    method: TensionMethod,
    ws: &mut Workspace<T, N>,
    out: &mut Derivative<T, N>,
) -> Result<(), SolveError> {
    prepare(model, state, connection, air, ws);
    match method {
        TensionMethod::TwoSweep => solve_tensions_and_accelerations(model, state, ws, out),
        #[cfg(feature = "std")]
        TensionMethod::Shooting => {
            solve_tensions_shooting(model, state, ws)?;
            accelerations(model, state, ws, out);
            Ok(())
        }
    }
}
