//! ISA 1976 standard atmosphere from sea level to 20 km, and the local air column
//! the cable flies in.
//!
//! Troposphere (h <= 11 km): T = T0 - L h, p = p0 (T/T0)^(g0/(L R)).
//! Lower stratosphere (11-20 km): T = 216.65 K, p = p11 exp(-g0 (h - 11 km)/(R T11)).
//! rho = p/(R T), a = sqrt(gamma R T). The laws are written in geopotential
//! altitude H; the solver's altitude h is geometric height above mean sea level,
//! positive up (h = -z in NED), converted with H = r0 h / (r0 + h), r0 = 6,356,766 m.

use crate::error::AtmosphereError;
use crate::scalar::Real;

/// Lowest altitude the model accepts, m (a dead-sea margin below mean sea level).
pub const MIN_ALTITUDE_M: f64 = -500.0;
/// Highest altitude the model accepts, m (top of the ISA 1976 lower stratosphere layer used).
pub const MAX_ALTITUDE_M: f64 = 20_000.0;

const T0: f64 = 288.15;
const P0: f64 = 101_325.0;
const LAPSE: f64 = 0.0065;
/// Tropopause, geopotential altitude, m.
const H_TROPOPAUSE: f64 = 11_000.0;
/// Effective earth radius of the 1976 standard for geopotential altitude, m.
const EARTH_RADIUS: f64 = 6_356_766.0;
/// Tropopause, geometric altitude, m.
const H_TROPOPAUSE_GEOMETRIC: f64 = EARTH_RADIUS * H_TROPOPAUSE / (EARTH_RADIUS - H_TROPOPAUSE);
const T_TROPOPAUSE: f64 = 216.65;

/// Air properties at one altitude.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AirProperties<T: Real> {
    /// Density, kg/m^3.
    pub density: T,
    /// First derivative of density with altitude, kg/m^4.
    pub density_slope: T,
    /// Second derivative of density with altitude, kg/m^5.
    pub density_curvature: T,
    /// Speed of sound, m/s.
    pub speed_of_sound: T,
    /// Static temperature, K.
    pub temperature: T,
    /// Static pressure, Pa.
    pub pressure: T,
}

/// The atmosphere model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Atmosphere<T: Real> {
    /// ISA 1976 to 20 km with the given gas constant, ratio of specific heats and
    /// standard gravity (the hydrostatic constant g0).
    Isa1976 {
        /// Specific gas constant of air, J/(kg K).
        gas_constant: T,
        /// Ratio of specific heats.
        gamma: T,
        /// Standard gravity used in the hydrostatic equation, m/s^2.
        gravity: T,
    },
    /// No air at all (the compound pendulum): zero density, no aerodynamic force.
    Vacuum,
}

impl<T: Real> Atmosphere<T> {
    /// The standard ISA 1976 atmosphere (R = 287.05287, gamma = 1.4, g0 = 9.80665).
    pub fn isa() -> Self {
        Atmosphere::Isa1976 {
            gas_constant: T::lit(287.052_87),
            gamma: T::lit(1.4),
            gravity: T::lit(9.806_65),
        }
    }

    /// Air properties at `altitude` (m, positive up).
    ///
    /// Errors with [`AtmosphereError::AltitudeOutOfRange`] outside
    /// [`MIN_ALTITUDE_M`, `MAX_ALTITUDE_M`] and [`AtmosphereError::NonFinite`] for NaN.
    pub fn at(&self, altitude: T) -> Result<AirProperties<T>, AtmosphereError> {
        let (r, gamma, g0) = match *self {
            Atmosphere::Vacuum => {
                if !altitude.finite() {
                    return Err(AtmosphereError::NonFinite);
                }
                let z = T::zero();
                return Ok(AirProperties {
                    density: z,
                    density_slope: z,
                    density_curvature: z,
                    speed_of_sound: z,
                    temperature: z,
                    pressure: z,
                });
            }
            Atmosphere::Isa1976 {
                gas_constant,
                gamma,
                gravity,
            } => (gas_constant, gamma, gravity),
        };
        if !altitude.finite() {
            return Err(AtmosphereError::NonFinite);
        }
        let h = altitude.to_f64();
        if !(MIN_ALTITUDE_M..=MAX_ALTITUDE_M).contains(&h) {
            return Err(AtmosphereError::AltitudeOutOfRange { altitude_m: h });
        }
        Ok(isa_layer(
            altitude,
            h <= H_TROPOPAUSE_GEOMETRIC,
            r,
            gamma,
            g0,
        ))
    }
}

/// ISA properties at geometric altitude `h_geometric` evaluated with the troposphere
/// (`troposphere = true`) or stratosphere law; derivatives are with respect to
/// geometric altitude. Evaluated in `T`: on the Cortex-M4F f64 is software-emulated
/// and this runs at every RK4 stage.
fn isa_layer<T: Real>(
    h_geometric: T,
    troposphere: bool,
    r: T,
    gamma: T,
    g0: T,
) -> AirProperties<T> {
    let lit = T::lit;
    let radius = lit(EARTH_RADIUS);
    let (t0, lapse) = (lit(T0), lit(LAPSE));
    let one = T::one();
    let h = radius * h_geometric / (radius + h_geometric);
    // dH/dh and d2H/dh2 for the chain rule.
    let ratio = radius / (radius + h_geometric);
    let dh1 = ratio * ratio;
    let dh2 = -lit(2.0) * ratio * ratio / (radius + h_geometric);
    let exponent = g0 / (lapse * r);
    let (temperature, pressure, slope_factor, curvature_factor);
    if troposphere {
        temperature = t0 - lapse * h;
        pressure = lit(P0) * (temperature / t0).powf(exponent);
        // rho ~ T^(n), n = exponent - 1: drho/dH = -n L rho / T, d2rho/dH2 = n (n-1) L^2 rho / T^2.
        let n = exponent - one;
        slope_factor = -n * lapse / temperature;
        curvature_factor = n * (n - one) * lapse * lapse / (temperature * temperature);
    } else {
        let t11 = lit(T_TROPOPAUSE);
        let p11 = lit(P0) * (t11 / t0).powf(exponent);
        temperature = t11;
        let inv_scale_height = g0 / (r * t11);
        pressure = p11 * (-(h - lit(H_TROPOPAUSE)) * inv_scale_height).exp();
        slope_factor = -inv_scale_height;
        curvature_factor = inv_scale_height * inv_scale_height;
    }
    let density = pressure / (r * temperature);
    let slope_geopotential = density * slope_factor;
    let curvature_geopotential = density * curvature_factor;
    AirProperties {
        density,
        density_slope: slope_geopotential * dh1,
        density_curvature: curvature_geopotential * dh1 * dh1 + slope_geopotential * dh2,
        speed_of_sound: (gamma * r * temperature).square_root(),
        temperature,
        pressure,
    }
}

/// The air around the towed system during one derivative evaluation: density as a
/// second-order expansion in altitude about the connection point.
///
/// The cable hangs within its length of the aircraft; over +-100 m the quadratic
/// expansion of the ISA density differs from the exact value by less than 1e-6
/// relative (the cubic term, (dh/H_scale)^3/6; checked in the tests), and it avoids
/// a `pow` per segment in the hot loop. The temperature lapse rate jumps at the 11 km tropopause, so a
/// column within 1 km of it also keeps the other layer's expansion about 11 km and
/// uses it for points on the other side.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AirColumn<T: Real> {
    /// Altitude of the expansion point, m.
    pub reference_altitude: T,
    /// Properties at the expansion point.
    pub air: AirProperties<T>,
    /// The other layer's properties at the tropopause, when the reference is within 1 km of it.
    pub across_tropopause: Option<AirProperties<T>>,
}

/// Spacing of the reference altitudes the solver expands the air about, m
/// ([`AirColumn::about`]). A power of two, so that `altitude / COLUMN_GRID_M` is exact.
pub const COLUMN_GRID_M: f64 = 16.0;

impl<T: Real> AirColumn<T> {
    /// The air column the solver uses at a connection-point `altitude` (m, positive
    /// up): the expansion about the grid altitude nearest to it, a multiple of
    /// [`COLUMN_GRID_M`] (ties away from zero).
    ///
    /// A pure function of the altitude that takes the same value for every altitude
    /// within the same grid cell, so that a caller can keep the last column and
    /// reuse it while [`AirColumn::serves`] the next altitude, bit-identically to
    /// building it again, whatever came before. The reference moves at most 8 m from
    /// the connection point, within the +-100 m over which the quadratic expansion
    /// holds to 1e-6 (tested); it spares the ISA evaluation (a `pow`) at every flight
    /// path sample of a climbing aircraft.
    ///
    /// Errors as [`Atmosphere::at`] for `altitude` itself (non-finite or outside
    /// [`MIN_ALTITUDE_M`, `MAX_ALTITUDE_M`]); every grid altitude of that range is
    /// inside it (-496 m to 20,000 m).
    pub fn about(atmosphere: &Atmosphere<T>, altitude: T) -> Result<Self, AtmosphereError> {
        if !altitude.finite() {
            return Err(AtmosphereError::NonFinite);
        }
        let h = altitude.to_f64();
        if !(MIN_ALTITUDE_M..=MAX_ALTITUDE_M).contains(&h) {
            return Err(AtmosphereError::AltitudeOutOfRange { altitude_m: h });
        }
        let cell = T::lit(1.0 / COLUMN_GRID_M) * altitude;
        let reference = cell.round() * T::lit(COLUMN_GRID_M);
        Self::new(atmosphere, reference)
    }

    /// True when [`AirColumn::about`] at `altitude` gives this column, for a column
    /// made by [`AirColumn::about`]: `altitude` within the atmosphere's range and
    /// less than half a grid spacing from the reference (then `altitude / 16` rounds
    /// to the reference's cell). False for NaN. A false answer only means "build
    /// it": a tie exactly half a cell away is built again, to the same column.
    #[inline]
    pub fn serves(&self, altitude: T) -> bool {
        let half = T::lit(0.5 * COLUMN_GRID_M);
        (altitude - self.reference_altitude).abs() < half
            && altitude >= T::lit(MIN_ALTITUDE_M)
            && altitude <= T::lit(MAX_ALTITUDE_M)
    }

    /// The air column about `altitude` (m, positive up).
    pub fn new(atmosphere: &Atmosphere<T>, altitude: T) -> Result<Self, AtmosphereError> {
        let air = atmosphere.at(altitude)?;
        let h = altitude.to_f64();
        let across_tropopause = match *atmosphere {
            Atmosphere::Isa1976 {
                gas_constant,
                gamma,
                gravity,
            } if (h - H_TROPOPAUSE_GEOMETRIC).abs() < 1000.0 => Some(isa_layer(
                T::lit(H_TROPOPAUSE_GEOMETRIC),
                h > H_TROPOPAUSE_GEOMETRIC,
                gas_constant,
                gamma,
                gravity,
            )),
            _ => None,
        };
        Ok(AirColumn {
            reference_altitude: altitude,
            air,
            across_tropopause,
        })
    }

    /// The expansion that [`AirColumn::density`] uses everywhere in the column, when
    /// there is only one (the column is not within 1 km of the tropopause): lets a hot
    /// loop skip the per-point layer choice.
    #[inline]
    pub fn single_layer(&self) -> Option<DensityExpansion<T>> {
        match self.across_tropopause {
            None => Some(DensityExpansion {
                reference_altitude: self.reference_altitude,
                air: self.air,
            }),
            Some(_) => None,
        }
    }

    /// Density at altitude `h` (m, positive up), never negative.
    #[inline]
    pub fn density(&self, h: T) -> T {
        let (h_ref, air) = match &self.across_tropopause {
            None => (self.reference_altitude, &self.air),
            Some(other) => {
                let tropopause = T::lit(H_TROPOPAUSE_GEOMETRIC);
                if (h > tropopause) != (self.reference_altitude > tropopause) {
                    (tropopause, other)
                } else {
                    (self.reference_altitude, &self.air)
                }
            }
        };
        quadratic_density(air, h - h_ref)
    }
}

/// One layer's second-order density expansion about a reference altitude (see
/// [`AirColumn::single_layer`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DensityExpansion<T: Real> {
    /// Altitude of the expansion point, m.
    pub reference_altitude: T,
    /// Properties at the expansion point.
    pub air: AirProperties<T>,
}

impl<T: Real> DensityExpansion<T> {
    /// Density at altitude `h` (m, positive up), never negative; equal to
    /// [`AirColumn::density`] of the column it came from.
    #[inline(always)]
    pub fn density(&self, h: T) -> T {
        quadratic_density(&self.air, h - self.reference_altitude)
    }
}

/// rho + dh (rho' + dh rho''/2), clamped at zero.
#[inline(always)]
fn quadratic_density<T: Real>(air: &AirProperties<T>, dh: T) -> T {
    // dh (rho''/2) rather than (dh/2) rho'': the same bits (halving is exact), and
    // rho''/2 is invariant in the solver's segment loop.
    let half_curvature = T::lit(0.5) * air.density_curvature;
    let rho = air.density + dh * (air.density_slope + dh * half_curvature);
    if rho > T::zero() { rho } else { T::zero() }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn isa_table_values() {
        // US Standard Atmosphere 1976, tabulated against geometric altitude.
        let isa = Atmosphere::<f64>::isa();
        let sl = isa.at(0.0).unwrap();
        assert!((sl.density - 1.2250).abs() < 1e-4);
        assert!((sl.speed_of_sound - 340.294).abs() < 0.01);
        let h9 = isa.at(9000.0).unwrap();
        assert!((h9.density - 0.46706).abs() < 1e-4, "{}", h9.density);
        assert!(
            (h9.temperature - 229.733).abs() < 1e-3,
            "{}",
            h9.temperature
        );
        assert!(
            (h9.speed_of_sound - 303.85).abs() < 0.05,
            "{}",
            h9.speed_of_sound
        );
        let h11 = isa.at(11_000.0).unwrap();
        assert!((h11.pressure - 22_700.0).abs() < 5.0, "{}", h11.pressure);
        let h20 = isa.at(20_000.0).unwrap();
        assert!((h20.density - 0.088_910).abs() < 1e-4, "{}", h20.density);
        assert!((h20.temperature - 216.65).abs() < 1e-9);
    }

    #[test]
    fn out_of_range_is_an_error() {
        let isa = Atmosphere::<f64>::isa();
        assert!(matches!(
            isa.at(20_001.0),
            Err(AtmosphereError::AltitudeOutOfRange { .. })
        ));
        assert!(matches!(
            isa.at(-600.0),
            Err(AtmosphereError::AltitudeOutOfRange { .. })
        ));
        assert_eq!(isa.at(f64::NAN), Err(AtmosphereError::NonFinite));
    }

    #[test]
    fn the_grid_column_is_the_same_across_its_cell_and_stays_accurate() {
        let isa = Atmosphere::<f64>::isa();
        for &h0 in &[
            -500.0, 0.0, 8999.0, 9000.0, 9007.9, 10_995.0, 11_004.0, 20_000.0,
        ] {
            let column = AirColumn::about(&isa, h0).unwrap();
            let reference = column.reference_altitude;
            assert_eq!(reference % COLUMN_GRID_M, 0.0, "{h0}");
            assert!((h0 - reference).abs() <= 0.5 * COLUMN_GRID_M, "{h0}");
            assert!((MIN_ALTITUDE_M..=MAX_ALTITUDE_M).contains(&reference));
            // Reuse is exact: every altitude the column serves builds the same column.
            for k in -40..=40 {
                let h = h0 + 0.25 * k as f64;
                if column.serves(h) {
                    assert_eq!(AirColumn::about(&isa, h).unwrap(), column, "{h0} {h}");
                } else if (MIN_ALTITUDE_M..=MAX_ALTITUDE_M).contains(&h) {
                    assert!((h - reference).abs() >= 0.5 * COLUMN_GRID_M, "{h0} {h}");
                }
            }
            // The cable and decoy hang within 100 m below the connection point.
            for k in -10..=0 {
                let h = h0 + 10.0 * k as f64;
                if h < MIN_ALTITUDE_M {
                    continue;
                }
                let exact = isa.at(h).unwrap().density;
                let rel = (column.density(h) - exact).abs() / exact;
                assert!(rel < 1e-6, "h0 {h0} h {h} rel {rel}");
            }
        }
        assert!(AirColumn::about(&isa, 20_000.5).is_err());
        assert!(AirColumn::about(&isa, f64::NAN).is_err());
        let top = AirColumn::about(&isa, 20_000.0).unwrap();
        assert!(!top.serves(20_000.5) && !top.serves(f64::NAN));
    }

    #[test]
    fn quadratic_column_is_accurate_over_the_cable_span() {
        let isa = Atmosphere::<f64>::isa();
        for &h0 in &[
            3000.0, 9000.0, 10_950.0, 11_050.0, 11_100.0, 12_000.0, 19_950.0,
        ] {
            let column = AirColumn::new(&isa, h0).unwrap();
            for k in -10..=5 {
                let h = h0 + 10.0 * k as f64;
                let exact = isa.at(h).unwrap().density;
                let rel = (column.density(h) - exact).abs() / exact;
                assert!(rel < 1e-6, "h0 {h0} h {h} rel {rel}");
            }
        }
    }
}
