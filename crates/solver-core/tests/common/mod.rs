//! Shared helpers for the solver-core integration tests.
#![allow(dead_code, missing_docs)]

use solver_core::*;

/// A deterministic pseudo-random generator (SplitMix64) for reproducible random states.
pub struct Rng(pub u64);
impl Rng {
    pub fn next_f64(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
    pub fn symmetric(&mut self) -> f64 {
        2.0 * self.next_f64() - 1.0
    }
    pub fn unit(&mut self) -> Vec3<f64> {
        loop {
            let v = Vec3::new(self.symmetric(), self.symmetric(), self.symmetric());
            let n = v.norm();
            if n > 0.1 && n < 1.0 {
                return v / n;
            }
        }
    }
}

/// A random hanging-ish chain state: directions mostly downward, random perpendicular rates.
pub fn random_state<T: Real, const N: usize>(
    rng: &mut Rng,
    count: usize,
    rate_scale: f64,
) -> State<T, N> {
    let mut s = State::<T, N>::default();
    for i in 0..count {
        let mut e = rng.unit();
        e.z = e.z.abs() + 0.5;
        let e = e.normalize();
        let w = rng.unit() * rate_scale;
        let w = w - e * w.dot(&e);
        s.directions[i] = e.map(T::lit);
        s.rates[i] = w.map(T::lit);
    }
    let q = nalgebra::UnitQuaternion::from_euler_angles(
        0.3 * rng.symmetric(),
        0.2 * rng.symmetric(),
        0.5 * rng.symmetric(),
    );
    s.decoy_attitude = [T::lit(q.w), T::lit(q.i), T::lit(q.j), T::lit(q.k)];
    s.decoy_rate = Vec3::new(rng.symmetric(), rng.symmetric(), rng.symmetric()).map(T::lit);
    s
}

/// The reference towed system (the values of `config/reference-system.toml`),
/// built here from literals so solver-core's tests do not depend on the config crate.
pub fn reference_params<T: Real>(layout: SegmentLayout<T>) -> ModelParams<T> {
    let rows: Vec<[f64; 4]> = include_str!("../../../../config/decoy-aero.csv")
        .lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with("alpha"))
        .map(|l| {
            let v: Vec<f64> = l.split(',').map(|x| x.trim().parse().unwrap()).collect();
            [v[0], v[1], v[2], v[3]]
        })
        .collect();
    ModelParams {
        environment: Environment {
            gravity: T::lit(9.80665),
            wind: Vec3::zeros(),
            atmosphere: Atmosphere::isa(),
        },
        connection_point: Vec3::new(T::lit(-4.0), T::zero(), T::lit(1.0)),
        cable: CableParams {
            length: T::lit(100.0),
            diameter: T::lit(0.0025),
            linear_density: T::lit(0.010),
            cd_normal: T::lit(1.1),
            cf_tangential: T::lit(0.022),
        },
        layout,
        end: EndBody::Decoy(DecoyParams {
            mass: T::lit(4.0),
            length: T::lit(0.9),
            diameter: T::lit(0.064),
            x_cg: T::lit(0.27),
            x_tow: T::lit(0.12),
            x_mrp: T::lit(0.45),
            inertia_cg: Vec3::new(T::lit(0.0025), T::lit(0.27), T::lit(0.27)),
            cm_q: T::lit(-80.0),
            cl_p: T::lit(-0.3),
            aero: AeroTable::from_degrees(&rows).unwrap(),
        }),
    }
}

/// Speed of sound at 9 km (ISA), m/s.
pub fn speed_of_sound(altitude: f64) -> f64 {
    Atmosphere::<f64>::isa()
        .at(altitude)
        .unwrap()
        .speed_of_sound
}
