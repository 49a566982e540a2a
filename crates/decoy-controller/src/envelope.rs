//! The operating envelope the controller guarantees: the flight conditions and
//! manoeuvres over which every 10 ms frame stays within its instruction budget
//! and the solution within its accuracy (docs/protocol.md §4, firmware/README.md
//! "Real time over the operating envelope"). A frame outside it is answered as any other, with
//! [`decoy_link::StatusFlags::OUTSIDE_ENVELOPE`] set; only the physical input
//! bounds of [`crate::validate`] reject a frame.

use solver_core::atmosphere::{LAPSE, MAX_ALTITUDE_M, MIN_ALTITUDE_M, T_TROPOPAUSE};
use solver_core::{Atmosphere, Real};

use decoy_link::AircraftStateFrame;

/// The envelope as plain numbers (`[envelope]` of the configuration): closed
/// ranges `[low, high]` and upper bounds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EnvelopeParams {
    /// Altitude of the aircraft reference point, m (geometric, -z).
    pub altitude_m: [f64; 2],
    /// Mach number of the aircraft's velocity through the air.
    pub mach: [f64; 2],
    /// Normal load factor, g: minus the specific force (acceleration less
    /// gravity) along the body z axis, over standard gravity (1 in level flight,
    /// 1/cos(bank) in a coordinated turn, about 1 + V w / g in a pull-up, cos of
    /// the climb angle in a straight climb).
    pub load_factor: [f64; 2],
    /// Largest |body rate|, rad/s.
    pub max_body_rate_radps: f64,
    /// Largest |acceleration along the velocity|, m/s².
    pub max_along_path_acceleration_mps2: f64,
    /// Largest dynamic pressure, Pa: q = rho V^2 / 2 = gamma p M^2 / 2 of the
    /// aircraft's airspeed at its altitude's static pressure. It cuts the
    /// low, fast corner of the altitude and Mach ranges, where the cable's
    /// steady tension comes within the tension monitor's caution of the
    /// allowable (docs/protocol.md §4, "The operating envelope").
    pub max_dynamic_pressure_pa: f64,
}

impl EnvelopeParams {
    /// The reference system's envelope (`config/reference-system.toml`
    /// `[envelope]`, whose comments justify it).
    pub const REFERENCE: Self = EnvelopeParams {
        altitude_m: [0.0, 15_000.0],
        mach: [0.3, 0.95],
        load_factor: [0.0, 4.0],
        max_body_rate_radps: 0.35,
        max_along_path_acceleration_mps2: 10.0,
        max_dynamic_pressure_pa: 46_000.0,
    };

    /// The largest Mach number inside the envelope at `altitude` (m) in
    /// `atmosphere` (ratio of specific heats `gamma`): the Mach range's upper end,
    /// or lower where the dynamic-pressure bound binds first (exact, f64; the
    /// controller's check uses [`OperatingEnvelope`]'s table, which is inside
    /// this by at most [`Q_TABLE_MAX_INSET`]). `None` outside the atmosphere.
    pub fn max_mach_at(
        &self,
        altitude: f64,
        atmosphere: &Atmosphere<f64>,
        gamma: f64,
    ) -> Option<f64> {
        let pressure = atmosphere.at(altitude).ok()?.pressure;
        let by_pressure =
            Real::square_root(2.0 * self.max_dynamic_pressure_pa / (gamma * pressure));
        Some(if pressure > 0.0 {
            by_pressure.min(self.mach[1])
        } else {
            self.mach[1]
        })
    }

    /// The dynamic pressure, Pa, of Mach `mach` at `altitude` (m) in
    /// `atmosphere` (`None` outside it).
    pub fn dynamic_pressure(
        mach: f64,
        altitude: f64,
        atmosphere: &Atmosphere<f64>,
        gamma: f64,
    ) -> Option<f64> {
        Some(0.5 * gamma * atmosphere.at(altitude).ok()?.pressure * mach * mach)
    }
}

/// Nodes of [`OperatingEnvelope`]'s table of the dynamic-pressure bound, at
/// equal steps over the altitude range (236 m apart over 0-15 km).
pub const Q_TABLE_NODES: usize = 64;

/// The most the table's bound on Mach² is inside the exact one, relative, for
/// any altitude range within the atmosphere's (-500 m to 20 km): the nodes are
/// lowered by the linear interpolation's largest error (its chord above the
/// convex bound, from the ISA's curvature) and f32 rounding, so that a frame
/// the check passes is within the bound, and one flagged is within this of it
/// (measured: 2.3e-4 over the reference's 0-15 km, 1.2e-4 in Mach; 4.3e-4 over
/// the atmosphere's whole range).
pub const Q_TABLE_MAX_INSET: f64 = 5e-4;

/// Relative widening of the envelope's bounds in [`OperatingEnvelope::new`]
/// (1e-5: a hundred times f32's rounding, 0.15 m at 15 km, Mach 1e-5).
pub const BOUND_TOLERANCE: f64 = 1e-5;

/// The envelope in the controller's precision, its bounds squared where the
/// check compares squares.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OperatingEnvelope<T: Real> {
    altitude: [T; 2],
    mach: [T; 2],
    /// The load factor's bounds times standard gravity, m/s².
    specific_force: [T; 2],
    body_rate2: T,
    along2: T,
    /// The dynamic-pressure bound as the largest Mach² at [`Q_TABLE_NODES`]
    /// altitudes from `table_base` every 1 / `table_scale` m, interpolated
    /// linearly (never above the exact bound).
    mach2_table: [T; Q_TABLE_NODES],
    table_base: T,
    table_scale: T,
}

impl<T: Real> OperatingEnvelope<T> {
    /// Every bound zero (all zero bits): nothing is inside.
    pub const ZERO: Self = OperatingEnvelope {
        altitude: [T::ZERO; 2],
        mach: [T::ZERO; 2],
        specific_force: [T::ZERO; 2],
        body_rate2: T::ZERO,
        along2: T::ZERO,
        mach2_table: [T::ZERO; Q_TABLE_NODES],
        table_base: T::ZERO,
        table_scale: T::ZERO,
    };

    /// `params` in `T`, with gravity `g0` (m/s²) for the load factor. Each bound
    /// is widened by [`BOUND_TOLERANCE`] of its magnitude (at least of its unit),
    /// so that a frame exactly at a bound, in the wire's f32 and the check's
    /// rounding, counts as inside; but for the dynamic pressure's, in
    /// `atmosphere` (ratio of specific heats `gamma`), whose table is never
    /// above it ([`Q_TABLE_MAX_INSET`]).
    pub fn new(params: &EnvelopeParams, g0: f64, atmosphere: &Atmosphere<f64>, gamma: f64) -> Self {
        let lit = T::lit;
        let widen = |[low, high]: [f64; 2], unit: f64| {
            [
                lit(low - BOUND_TOLERANCE * low.abs().max(unit)),
                lit(high + BOUND_TOLERANCE * high.abs().max(unit)),
            ]
        };
        let square = |v: f64| lit(v * v * (1.0 + 2.0 * BOUND_TOLERANCE));
        let mut envelope = OperatingEnvelope {
            altitude: widen(params.altitude_m, 1.0),
            mach: widen(params.mach, 1.0),
            specific_force: widen(params.load_factor.map(|n| n * g0), g0),
            body_rate2: square(params.max_body_rate_radps),
            along2: square(params.max_along_path_acceleration_mps2),
            ..Self::ZERO
        };
        envelope.dynamic_pressure_table(params, atmosphere, gamma);
        envelope
    }

    /// The dynamic-pressure table (`mach2_table`, `table_base`,
    /// `table_scale`): Mach² = 2 q_max / (gamma p(h)) at the nodes over the
    /// envelope's altitude range (widened as the other bounds, within the
    /// atmosphere's), lowered so that the linear interpolation between them
    /// never exceeds it. The bound is increasing and convex in altitude (1/p,
    /// with (1/p)'/(1/p) = g / (R T) and (1/p)''/(1/p) = (g / (R T))² + g L /
    /// (R T²) in the ISA's layers, largest at the tropopause's 216.65 K; the
    /// slope is continuous there, the temperature being so), so the chord over a
    /// step D is above it by at most k2 D² / 8 times its value at the step's
    /// upper end, itself at most exp(k1 D) times the value where the chord is
    /// measured; beyond the range the end intervals' chords extended lie below
    /// it too. A node outside the atmosphere would be 0 (nothing inside there).
    fn dynamic_pressure_table(
        &mut self,
        params: &EnvelopeParams,
        atmosphere: &Atmosphere<f64>,
        gamma: f64,
    ) {
        let (gas_constant, gravity) = match *atmosphere {
            Atmosphere::Isa1976 {
                gas_constant,
                gravity,
                ..
            } => (gas_constant, gravity),
            Atmosphere::Vacuum => (1.0, 0.0),
        };
        let [low, high] = params.altitude_m;
        let low = (low - BOUND_TOLERANCE * low.abs().max(1.0)).max(MIN_ALTITUDE_M);
        let high = (high + BOUND_TOLERANCE * high.abs().max(1.0)).min(MAX_ALTITUDE_M);
        let step = (high - low) / (Q_TABLE_NODES - 1) as f64;
        let k1 = gravity / (gas_constant * T_TROPOPAUSE);
        let k2 = k1 * k1 + gravity * LAPSE / (gas_constant * T_TROPOPAUSE * T_TROPOPAUSE);
        // The chord's excess (exp(y) <= 1 + 2 y for 0 <= y <= 1.25: y is 0.04
        // over 0-15 km), and 4 f32 ulps of the node and the interpolation.
        let growth = 1.0 + 2.0 * (k1 * step).min(1.25);
        let inset = k2 * step * step / 8.0 * growth + 4.0 * f64::from(f32::EPSILON);
        for (i, node) in self.mach2_table.iter_mut().enumerate() {
            let h = low + step * i as f64;
            let bound = match atmosphere.at(h) {
                Ok(air) if air.pressure > 0.0 => {
                    2.0 * params.max_dynamic_pressure_pa / (gamma * air.pressure)
                }
                // No air: no dynamic pressure, nothing excluded.
                Ok(_) => f64::from(f32::MAX),
                Err(_) => 0.0,
            };
            *node = T::lit((bound / (1.0 + inset)).min(f64::from(f32::MAX)));
        }
        self.table_base = T::lit(low);
        self.table_scale = T::lit(if step > 0.0 { 1.0 / step } else { 0.0 });
    }

    /// The table's bound on Mach² at `altitude` (m): the linear interpolation
    /// between its nodes (the end intervals extended beyond the range). Without
    /// a panic site (on the frame path): every index is a `get`.
    #[inline(always)]
    fn mach2_bound(&self, altitude: T) -> T {
        let x = (altitude - self.table_base) * self.table_scale;
        let last = Q_TABLE_NODES - 2;
        let i = x.truncated_index();
        let i = if i > last { last } else { i };
        match (self.mach2_table.get(i), self.mach2_table.get(i + 1)) {
            (Some(&a), Some(&b)) => a + (b - a) * (x - T::from_count(i as u64)),
            _ => T::ZERO,
        }
    }

    /// True when the aircraft state `frame`, flying at Mach `mach`, is inside:
    /// every bound met (closed ranges), the dynamic pressure's from the table
    /// at the frame's altitude. In `T` from the frame's f32 fields: a few dozen
    /// instructions, the same for every frame; the quaternion is taken as unit
    /// (validation holds it within 1e-3).
    pub fn contains(&self, frame: &AircraftStateFrame, mach: T, gravity: T) -> bool {
        let w = |v: f32| T::lit(f64::from(v));
        let altitude = T::lit(-frame.position_ned_m[2]);
        let [qw, qx, qy, qz] = frame.attitude_wxyz.map(w);
        let [ax, ay, az] = frame.acceleration_ned_mps2.map(w);
        let [vx, vy, vz] = frame.velocity_ned_mps.map(w);
        let [p, q, r] = frame.body_rate_radps.map(w);
        // The body z axis in NED: the rotation's third column.
        let two = T::lit(2.0);
        let zx = two * (qx * qz + qw * qy);
        let zy = two * (qy * qz - qw * qx);
        let zz = T::one() - two * (qx * qx + qy * qy);
        // n g = -(a - g e_z) . z_b.
        let normal = (gravity - az) * zz - ax * zx - ay * zy;
        let along = ax * vx + ay * vy + az * vz;
        let speed2 = vx * vx + vy * vy + vz * vz;
        let rate2 = p * p + q * q + r * r;
        let within = |v: T, range: &[T; 2]| v >= range[0] && v <= range[1];
        within(altitude, &self.altitude)
            & within(mach, &self.mach)
            & within(normal, &self.specific_force)
            & (rate2 <= self.body_rate2)
            & (along * along <= self.along2 * speed2)
            & (mach * mach <= self.mach2_bound(altitude))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn level(altitude: f64, speed: f32) -> AircraftStateFrame {
        AircraftStateFrame {
            seq: 0,
            time_s: 0.0,
            position_ned_m: [0.0, 0.0, -altitude],
            velocity_ned_mps: [speed, 0.0, 0.0],
            acceleration_ned_mps2: [0.0; 3],
            attitude_wxyz: [1.0, 0.0, 0.0, 0.0],
            body_rate_radps: [0.0; 3],
            body_angular_acceleration_radps2: [0.0; 3],
        }
    }

    fn reference<T: Real>() -> OperatingEnvelope<T> {
        OperatingEnvelope::new(&EnvelopeParams::REFERENCE, 9.80665, &Atmosphere::isa(), 1.4)
    }

    /// The table's bound against the exact one, at every metre of the altitude
    /// range: never above, and within [`Q_TABLE_MAX_INSET`]; in f32 (the M4F's)
    /// and f64, for the reference and a bound that binds everywhere, over the
    /// reference's range and the atmosphere's whole range.
    #[test]
    fn the_dynamic_pressure_table_is_within_the_exact_bound_and_close_to_it() {
        let isa = Atmosphere::<f64>::isa();
        // The reference's range, and the atmosphere's whole range (the table
        // within it, its end intervals extended to the widened bounds).
        let ranges = [[0.0, 15_000.0], [-500.0, 20_000.0]];
        for (q, altitude_m) in [46_000.0, 5_000.0]
            .into_iter()
            .flat_map(|q| ranges.map(|r| (q, r)))
        {
            let params = EnvelopeParams {
                max_dynamic_pressure_pa: q,
                altitude_m,
                ..EnvelopeParams::REFERENCE
            };
            let e32 = OperatingEnvelope::<f32>::new(&params, 9.80665, &isa, 1.4);
            let e64 = OperatingEnvelope::<f64>::new(&params, 9.80665, &isa, 1.4);
            let mut worst = 0.0f64;
            let [h0, h1] = altitude_m.map(|h| h as i32);
            for h in (h0..=h1).map(f64::from) {
                let exact = 2.0 * q / (1.4 * isa.at(h).unwrap().pressure);
                for table in [f64::from(e32.mach2_bound(h as f32)), e64.mach2_bound(h)] {
                    assert!(table <= exact, "q {q} at {h} m: {table} above {exact}");
                    assert!(table > 0.0, "q {q} at {h} m: the table is 0");
                    worst = worst.max(1.0 - table / exact);
                }
            }
            assert!(
                worst < Q_TABLE_MAX_INSET,
                "q {q} {altitude_m:?}: inset {worst}"
            );
            assert!(worst > 1e-6, "q {q}: the table was lowered ({worst})");
            // The helper's exact Mach at sea level agrees.
            let m = params.max_mach_at(0.0, &isa, 1.4).unwrap();
            let expected = (2.0 * q / (1.4 * 101_325.0f64)).sqrt().min(0.95);
            assert!((m - expected).abs() < 1e-12, "{m} {expected}");
        }
    }

    #[test]
    fn the_reference_envelope_holds_level_flight_and_rejects_its_outside() {
        let e = reference::<f32>();
        let g = 9.80665f32;
        assert!(e.contains(&level(9000.0, 243.0), 0.8, g));
        assert!(e.contains(&level(0.0, 243.0), 0.3, g));
        assert!(e.contains(&level(15_000.0, 243.0), 0.95, g));
        // The dynamic-pressure corner: sea level up to Mach 0.805 (46 kPa).
        assert!(e.contains(&level(0.0, 243.0), 0.80, g));
        assert!(!e.contains(&level(0.0, 243.0), 0.81, g));
        assert!(e.contains(&level(3_000.0, 243.0), 0.95, g));
        assert!(!e.contains(&level(15_001.0, 243.0), 0.8, g));
        assert!(!e.contains(&level(-1.0, 243.0), 0.8, g));
        assert!(!e.contains(&level(9000.0, 243.0), 0.96, g));
        assert!(!e.contains(&level(9000.0, 243.0), 0.29, g));
        // A 4 g pull-up is inside, 4.1 g not; a 3.9 g turn (bank 75 deg) inside.
        let mut pull = level(9000.0, 180.0);
        pull.acceleration_ned_mps2 = [0.0, 0.0, -3.0 * g];
        assert!(e.contains(&pull, 0.6, g));
        pull.acceleration_ned_mps2 = [0.0, 0.0, -3.1 * g];
        assert!(!e.contains(&pull, 0.6, g));
        let bank = 75.0f32.to_radians();
        let mut turn = level(9000.0, 243.0);
        turn.attitude_wxyz = [(bank / 2.0).cos(), (bank / 2.0).sin(), 0.0, 0.0];
        turn.acceleration_ned_mps2 = [0.0, g * bank.tan(), 0.0];
        assert!(e.contains(&turn, 0.8, g));
        // Body rates and the along-path acceleration.
        let mut rolling = level(9000.0, 243.0);
        rolling.body_rate_radps = [0.36, 0.0, 0.0];
        assert!(!e.contains(&rolling, 0.8, g));
        let mut accelerating = level(9000.0, 243.0);
        accelerating.acceleration_ned_mps2 = [10.0, 0.0, 0.0];
        assert!(e.contains(&accelerating, 0.8, g));
        accelerating.acceleration_ned_mps2 = [10.5, 0.0, 0.0];
        assert!(!e.contains(&accelerating, 0.8, g));
        // A straight vertical climb: load factor 0.
        let mut climb = level(9000.0, 0.0);
        climb.velocity_ned_mps = [0.0, 0.0, -180.0];
        let pitch = 90.0f32.to_radians();
        climb.attitude_wxyz = [(pitch / 2.0).cos(), 0.0, (pitch / 2.0).sin(), 0.0];
        assert!(e.contains(&climb, 0.6, g));
    }
}
