//! The compound multi-pendulum validation case (docs/design.md §7.1, the paper's Fig. 4/5):
//! N rods of 0.5 kg and 0.1 m, the first hinged to a fixed point, g = 9.81 m/s^2,
//! all rods initially at -pi/3 rad from the downward vertical (toward -x), at rest,
//! no air.
//!
//! The solver works in NED (z down). The pendulum's own frame has the hinge at the
//! origin, x horizontal and z up, so its z is the solver's -z.

use crate::atmosphere::Atmosphere;
use crate::error::ConfigError;
use crate::model::{CableParams, EndBody, Environment, Model, ModelParams, SegmentLayout};
use crate::scalar::{Real, Vec3};
use crate::state::State;

/// Rod mass, kg.
pub const ROD_MASS: f64 = 0.5;
/// Rod length, m.
pub const ROD_LENGTH: f64 = 0.1;
/// Gravity, m/s^2.
pub const GRAVITY: f64 = 9.81;
/// Initial angle of every rod from the downward vertical, rad (negative: toward -x).
pub const INITIAL_ANGLE: f64 = -core::f64::consts::FRAC_PI_3;

/// The pendulum model with `count` rods: a free-ended chain hinged at the origin, in vacuum.
pub fn reference_pendulum<T: Real, const N: usize>(
    count: usize,
) -> Result<Model<T, N>, ConfigError> {
    Model::new(ModelParams {
        environment: Environment {
            gravity: T::lit(GRAVITY),
            wind: Vec3::zeros(),
            atmosphere: Atmosphere::Vacuum,
        },
        connection_point: Vec3::zeros(),
        cable: CableParams {
            length: T::lit(ROD_LENGTH * count as f64),
            diameter: T::zero(),
            linear_density: T::lit(ROD_MASS / ROD_LENGTH),
            cd_normal: T::zero(),
            cf_tangential: T::zero(),
        },
        layout: SegmentLayout::Uniform { count },
        end: EndBody::Free,
    })
}

/// All rods at [`INITIAL_ANGLE`] from the downward vertical, at rest.
pub fn pendulum_initial_state<T: Real, const N: usize>(count: usize) -> State<T, N> {
    let mut s = State::default();
    let angle = T::lit(INITIAL_ANGLE);
    let e = Vec3::new(angle.sin(), T::zero(), angle.cos());
    for d in &mut s.directions[..count] {
        *d = e;
    }
    s
}

/// Kinetic plus potential energy of a free chain hinged at a fixed origin, J,
/// potential zero at the hinge height: sum of m v_c^2/2 + J w^2/2 + m g h_c.
pub fn pendulum_energy<T: Real, const N: usize>(model: &Model<T, N>, state: &State<T, N>) -> T {
    let g = model.params().environment.gravity;
    let half = T::lit(0.5);
    let mut p = Vec3::zeros();
    let mut v = Vec3::zeros();
    let mut energy = T::zero();
    for i in 0..model.segment_count() {
        let (l, m) = (model.lengths()[i], model.masses()[i]);
        let e = state.directions[i];
        let w = state.rates[i];
        let we = w.cross(&e);
        let centre = p + e * (half * l);
        let vc = v + we * (half * l);
        let inertia = m * l * l / T::lit(12.0);
        energy +=
            half * m * vc.norm_squared() + half * inertia * w.norm_squared() - m * g * centre.z;
        p += e * l;
        v += we * l;
    }
    energy
}
