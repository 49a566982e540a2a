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
/// Temperature lapse rate of the troposphere, K per geopotential metre.
pub const LAPSE: f64 = 0.0065;
/// Tropopause, geopotential altitude, m.
const H_TROPOPAUSE: f64 = 11_000.0;
/// Effective earth radius of the 1976 standard for geopotential altitude, m.
const EARTH_RADIUS: f64 = 6_356_766.0;
/// Tropopause, geometric altitude, m.
const H_TROPOPAUSE_GEOMETRIC: f64 = EARTH_RADIUS * H_TROPOPAUSE / (EARTH_RADIUS - H_TROPOPAUSE);
/// Temperature of the tropopause and the lower stratosphere, K (the
/// atmosphere's lowest).
pub const T_TROPOPAUSE: f64 = 216.65;

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

impl<T: Real> Atmosphere<T> {
    /// The speed of sound at `altitude` (m, positive up), m/s, with the errors of
    /// [`Atmosphere::at`]: sqrt(gamma R T) with the layer's temperature, the same
    /// bits as `at(altitude).speed_of_sound` without the pressure's `pow` or `exp`
    /// (whose cost depends on the argument). Zero for [`Atmosphere::Vacuum`].
    pub fn speed_of_sound(&self, altitude: T) -> Result<T, AtmosphereError> {
        let (r, gamma) = match *self {
            Atmosphere::Vacuum => {
                if !altitude.finite() {
                    return Err(AtmosphereError::NonFinite);
                }
                return Ok(T::zero());
            }
            Atmosphere::Isa1976 {
                gas_constant,
                gamma,
                ..
            } => (gas_constant, gamma),
        };
        if !altitude.finite() {
            return Err(AtmosphereError::NonFinite);
        }
        let h = altitude.to_f64();
        if !(MIN_ALTITUDE_M..=MAX_ALTITUDE_M).contains(&h) {
            return Err(AtmosphereError::AltitudeOutOfRange { altitude_m: h });
        }
        let temperature = layer_temperature(altitude, h <= H_TROPOPAUSE_GEOMETRIC);
        Ok((gamma * r * temperature).square_root())
    }
}

/// The temperature at geometric altitude `h_geometric` in the troposphere
/// (`troposphere = true`, T0 - L H, H geopotential) or the lower stratosphere
/// (216.65 K).
#[inline(always)]
fn layer_temperature<T: Real>(h_geometric: T, troposphere: bool) -> T {
    if troposphere {
        let radius = T::lit(EARTH_RADIUS);
        let h = radius * h_geometric / (radius + h_geometric);
        T::lit(T0) - T::lit(LAPSE) * h
    } else {
        T::lit(T_TROPOPAUSE)
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
/// second-order polynomial in altitude about a reference altitude near the
/// connection point ([`DensityLaw`]), the same expression at every altitude.
///
/// The cable hangs within its length of the aircraft; over +-100 m the quadratic
/// expansion of the ISA density differs from the exact value by less than 1e-6
/// relative (the cubic term, (dh/H_scale)^3/6; checked in the tests), and it avoids
/// a `pow` per segment in the hot loop. The temperature lapse rate jumps at the 11
/// km tropopause, so the density's slope has a kink there, which no quadratic
/// follows: a column within 1 km of it takes the quadratic through the exact
/// two-layer density at the reference and [`FIT_OFFSET_M`] either side of it
/// (the Chebyshev nodes of a quadratic over [`COLUMN_REACH_M`]), within 7e-4
/// relative of the ISA over that reach (tested), 1e-6 where no point crosses the
/// tropopause. One expression everywhere: the hot loop's cost does not depend on
/// the altitude.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AirColumn<T: Real> {
    /// Altitude of the expansion point, m.
    pub reference_altitude: T,
    /// Properties at the expansion point.
    pub air: AirProperties<T>,
    /// The density at any altitude of the column, in the form the hot loop evaluates.
    pub law: DensityLaw<T>,
}

/// Spacing of the reference altitudes the solver expands the air about, m
/// ([`AirColumn::about`]). A power of two, so that `altitude / COLUMN_GRID_M` is exact.
pub const COLUMN_GRID_M: f64 = 16.0;

/// How far from its reference altitude a column's density is fitted and checked,
/// m: the cable's 100 m, the 8 m the reference may lie from the connection point,
/// and a margin.
pub const COLUMN_REACH_M: f64 = 120.0;

/// The fitting nodes of a column near the tropopause lie this far either side of
/// its reference altitude, m: the Chebyshev nodes of degree 3 over
/// [`COLUMN_REACH_M`], reach x sqrt(3)/2.
pub const FIT_OFFSET_M: f64 = COLUMN_REACH_M * 0.866_025_403_784_438_6;

/// Half-width of the band about the tropopause in which a column is fitted rather
/// than expanded, m (beyond it no point of a column crosses the tropopause).
pub const TROPOPAUSE_BAND_M: f64 = 1000.0;

impl<T: Real> AirColumn<T> {
    /// Every value zero (all zero bits): a placeholder never evaluated.
    pub const ZERO: Self = AirColumn {
        reference_altitude: T::ZERO,
        air: AirProperties {
            density: T::ZERO,
            density_slope: T::ZERO,
            density_curvature: T::ZERO,
            speed_of_sound: T::ZERO,
            temperature: T::ZERO,
            pressure: T::ZERO,
        },
        law: DensityLaw::ZERO,
    };

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
    /// within half a grid spacing of the reference, a tie exactly half a cell
    /// away on the side `about`'s rounding (half away from zero) gives it to
    /// (then `altitude / 16` rounds to the reference's cell: exactly, every
    /// operation is exact). False for NaN. A tie served by the wrong side would
    /// be built again in the frame, about a thousand instructions on the M4F
    /// (measured: the one costlier frame of a climb through 10,120 m).
    #[inline]
    pub fn serves(&self, altitude: T) -> bool {
        let half = T::lit(0.5 * COLUMN_GRID_M);
        let d = altitude - self.reference_altitude;
        let within = if altitude >= T::zero() {
            d >= -half && d < half
        } else {
            d > -half && d <= half
        };
        within && altitude >= T::lit(MIN_ALTITUDE_M) && altitude <= T::lit(MAX_ALTITUDE_M)
    }

    /// The air column about `altitude` (m, positive up).
    pub fn new(atmosphere: &Atmosphere<T>, altitude: T) -> Result<Self, AtmosphereError> {
        let air = atmosphere.at(altitude)?;
        let h = altitude.to_f64();
        let expansion = DensityLaw::expansion(altitude, &air);
        let law = match *atmosphere {
            Atmosphere::Isa1976 {
                gas_constant,
                gamma,
                gravity,
            } if (h - H_TROPOPAUSE_GEOMETRIC).abs() < TROPOPAUSE_BAND_M => {
                let tropopause = T::lit(H_TROPOPAUSE_GEOMETRIC);
                let above = h > H_TROPOPAUSE_GEOMETRIC;
                // The other layer about the tropopause.
                let other = DensityLaw::expansion(
                    tropopause,
                    &isa_layer(tropopause, above, gas_constant, gamma, gravity),
                );
                // The exact two-layer density (within the expansions' 1e-6).
                let exact = |h: T| {
                    if (h > tropopause) == above {
                        expansion.density(h)
                    } else {
                        other.density(h)
                    }
                };
                DensityLaw::through(altitude, air.density, exact)
            }
            _ => expansion,
        };
        Ok(AirColumn {
            reference_altitude: altitude,
            air,
            law,
        })
    }

    /// Density at altitude `h` (m, positive up): [`DensityLaw::density`].
    #[inline(always)]
    pub fn density(&self, h: T) -> T {
        self.law.density(h)
    }
}

/// The air columns a solver keeps: the last one built or used, and its two
/// neighbours in the grid (16 m above and below), filled ahead of need by
/// [`AirCache::prefetch`] (the controller calls it after a frame's answer), so
/// that a frame that climbs or descends into the next cell finds its column
/// built: none of a frame's samples evaluates the ISA (a `pow` or `exp` whose
/// cost depends on the argument) while the aircraft moves less than a cell per
/// frame. Every column is [`AirColumn::about`]'s for its cell, a pure function of
/// the cell, so where a column came from changes no bit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AirCache<T: Real> {
    /// Up to three columns (which ones are valid: `valid`).
    columns: [AirColumn<T>; 3],
    valid: [bool; 3],
    /// The index of the column last used.
    current: u8,
}

impl<T: Real> AirCache<T> {
    /// Nothing cached (all zero bits).
    pub const EMPTY: Self = AirCache {
        columns: [AirColumn::ZERO; 3],
        valid: [false; 3],
        current: 0,
    };

    /// The column of `altitude` ([`AirColumn::about`]): a cached one when one
    /// serves it (it becomes the current one), else built into the current
    /// one's place.
    #[inline(always)]
    pub fn column(
        &mut self,
        atmosphere: &Atmosphere<T>,
        altitude: T,
    ) -> Result<AirColumn<T>, AtmosphereError> {
        let current = usize::from(self.current) % 3;
        if self.valid[current] && self.columns[current].serves(altitude) {
            return Ok(self.columns[current]);
        }
        self.column_elsewhere(atmosphere, altitude)
    }

    /// [`AirCache::column`] when the current column does not serve `altitude`.
    #[inline(never)]
    fn column_elsewhere(
        &mut self,
        atmosphere: &Atmosphere<T>,
        altitude: T,
    ) -> Result<AirColumn<T>, AtmosphereError> {
        for k in 0..3 {
            if self.valid[k] && self.columns[k].serves(altitude) {
                self.current = k as u8;
                return Ok(self.columns[k]);
            }
        }
        let column = AirColumn::about(atmosphere, altitude)?;
        let current = usize::from(self.current) % 3;
        self.columns[current] = column;
        self.valid[current] = true;
        Ok(column)
    }

    /// Builds the current column's neighbours (16 m below and above) that are
    /// missing and inside the atmosphere's range, in the places of columns that
    /// are neither current nor a neighbour: at most two ISA evaluations, none when
    /// both are cached already.
    pub fn prefetch(&mut self, atmosphere: &Atmosphere<T>) {
        let current = usize::from(self.current) % 3;
        if !self.valid[current] {
            return;
        }
        let grid = T::lit(COLUMN_GRID_M);
        let reference = self.columns[current].reference_altitude;
        let neighbours = [reference - grid, reference + grid];
        let holds = |cache: &Self, altitude: T| {
            (0..3).any(|k| cache.valid[k] && cache.columns[k].reference_altitude == altitude)
        };
        for altitude in neighbours {
            if holds(self, altitude) {
                continue;
            }
            // A place that is neither the current column nor a neighbour.
            let free = (0..3).find(|&k| {
                k != current
                    && !(self.valid[k] && neighbours.contains(&self.columns[k].reference_altitude))
            });
            if let (Some(k), Ok(column)) = (free, AirColumn::new(atmosphere, altitude)) {
                self.columns[k] = column;
                self.valid[k] = true;
            }
        }
    }

    /// Forgets every column.
    pub fn clear(&mut self) {
        *self = AirCache::EMPTY;
    }
}

/// A column's density at any altitude h: `rho(h) = rho_r + dh (rho'_r + dh
/// rho''_r / 2)`, dh = h - h_r, with no branch (the hot loop's form). Away from the
/// tropopause its coefficients are the ISA's value and derivatives at h_r (the
/// Taylor expansion); near it, the quadratic through three points of the exact
/// two-layer law ([`AirColumn`]).
///
/// Never negative, so not clamped: the quadratic expansion of either ISA layer
/// has its minimum 0.35 (troposphere: 1 - n/(2(n-1)) of the reference density,
/// rho ~ T^n, n = 4.256) or 0.5 (stratosphere, exponential) of the reference
/// density, at whatever altitude; the fitted quadratics, within 7e-4 of the ISA
/// over their reach, have curvatures of the same order (tested).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DensityLaw<T: Real> {
    /// h_r, m.
    reference_altitude: T,
    /// rho_r, kg/m^3.
    density: T,
    /// rho'_r, kg/m^4.
    slope: T,
    /// rho''_r / 2, kg/m^5.
    half_curvature: T,
}

impl<T: Real> DensityLaw<T> {
    /// Every coefficient zero (all zero bits: part of
    /// [`Solver::UNCONFIGURED`](crate::Solver::UNCONFIGURED), which a `static` keeps
    /// in `.bss`).
    pub const ZERO: Self = DensityLaw {
        reference_altitude: T::ZERO,
        density: T::ZERO,
        slope: T::ZERO,
        half_curvature: T::ZERO,
    };

    /// The Taylor expansion about `reference` of a layer with properties `air` there.
    fn expansion(reference: T, air: &AirProperties<T>) -> Self {
        DensityLaw {
            reference_altitude: reference,
            density: air.density,
            slope: air.density_slope,
            // dh (rho''/2) rather than (dh/2) rho'': the same bits (halving is
            // exact), and rho''/2 is invariant in the solver's segment loop.
            half_curvature: T::lit(0.5) * air.density_curvature,
        }
    }

    /// The quadratic about `reference` through `density` there and `exact` at
    /// [`FIT_OFFSET_M`] either side: c1 = (f(+a) - f(-a)) / 2a,
    /// c2 = (f(+a) + f(-a) - 2 f(0)) / 2a².
    fn through(reference: T, density: T, exact: impl Fn(T) -> T) -> Self {
        let a = T::lit(FIT_OFFSET_M);
        let (above, below) = (exact(reference + a), exact(reference - a));
        let two_a = a + a;
        DensityLaw {
            reference_altitude: reference,
            density,
            slope: (above - below) / two_a,
            half_curvature: ((above - density) + (below - density)) / (two_a * a),
        }
    }

    /// Density at altitude `h` (m, positive up), kg/m^3.
    #[inline(always)]
    pub fn density(&self, h: T) -> T {
        let dh = h - self.reference_altitude;
        self.density + dh * (self.slope + dh * self.half_curvature)
    }
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
                assert!(rel < tolerance(reference), "h0 {h0} h {h} rel {rel}");
            }
        }
        assert!(AirColumn::about(&isa, 20_000.5).is_err());
        assert!(AirColumn::about(&isa, f64::NAN).is_err());
        let top = AirColumn::about(&isa, 20_000.0).unwrap();
        assert!(!top.serves(20_000.5) && !top.serves(f64::NAN));
    }

    /// An altitude exactly half a cell from two references is served by the
    /// column `about` builds for it, and by that column only (above and below
    /// sea level, in f32 and f64): a climb through a tie finds its column
    /// cached and builds none in the frame.
    #[test]
    fn a_tie_between_two_cells_is_served_as_about_rounds_it() {
        fn check<T: Real>() {
            let isa = Atmosphere::<T>::isa();
            for k in [-31i32, -2, -1, 0, 1, 632, 678, 1249] {
                let tie = T::lit((f64::from(k) + 0.5) * COLUMN_GRID_M);
                let built = AirColumn::about(&isa, tie).unwrap();
                assert!(built.serves(tie), "{k}");
                for neighbour in [k, k + 1] {
                    let at = T::lit(f64::from(neighbour) * COLUMN_GRID_M);
                    let column = AirColumn::about(&isa, at).unwrap();
                    assert_eq!(
                        column.serves(tie),
                        column == built,
                        "{k}: the column at {neighbour} cells"
                    );
                }
            }
        }
        check::<f32>();
        check::<f64>();
    }

    /// The accuracy a column about `reference` is held to over its reach (+-120
    /// m; 1e-6 over the cable's +-100 m, the cubic term growing as the cube):
    /// 2e-6 where no point of the reach crosses the tropopause and the column is
    /// a Taylor expansion, 7e-4 for the fitted columns of the band.
    fn tolerance(reference: f64) -> f64 {
        if (reference - H_TROPOPAUSE_GEOMETRIC).abs() < TROPOPAUSE_BAND_M {
            7e-4
        } else {
            2e-6
        }
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
                assert!(rel < tolerance(h0), "h0 {h0} h {h} rel {rel}");
            }
        }
    }

    /// Every grid column from 1,200 m below the tropopause to 1,200 m above it,
    /// over its whole reach (+-120 m), in f64 and f32: within 1e-6 of the ISA
    /// where it is an expansion, within 7e-4 where it is fitted, and outside
    /// the band an expansion is exactly the layer's Taylor polynomial (a fitted
    /// column is the only kind whose cost or form depends on the altitude: none
    /// does).
    #[test]
    fn every_column_near_the_tropopause_is_within_its_tolerance() {
        let isa = Atmosphere::<f64>::isa();
        let isa32 = Atmosphere::<f32>::isa();
        let lowest = (H_TROPOPAUSE_GEOMETRIC - 1200.0) / COLUMN_GRID_M;
        let (mut worst_band, mut worst_away) = (0.0f64, 0.0f64);
        for cell in (lowest as i64)..=(lowest as i64 + 2 * 1200 / 16 + 1) {
            let reference = cell as f64 * COLUMN_GRID_M;
            let column = AirColumn::new(&isa, reference).unwrap();
            let column32 = AirColumn::new(&isa32, reference as f32).unwrap();
            for k in -24..=24 {
                let h = reference + 5.0 * k as f64;
                let exact = isa.at(h).unwrap().density;
                let rel = (column.density(h) - exact).abs() / exact;
                let rel32 = (f64::from(column32.density(h as f32)) - exact).abs() / exact;
                let limit = tolerance(reference);
                assert!(
                    rel < limit && rel32 < limit + 1e-6,
                    "{reference} {h}: {rel} {rel32}"
                );
                if limit > 2e-6 {
                    worst_band = worst_band.max(rel);
                } else {
                    worst_away = worst_away.max(rel);
                }
            }
            if (reference - H_TROPOPAUSE_GEOMETRIC).abs() >= TROPOPAUSE_BAND_M {
                let air = isa.at(reference).unwrap();
                assert_eq!(column.law, DensityLaw::expansion(reference, &air));
            }
        }
        // The fit is needed: the band's worst is the kink's, far above 1e-6.
        assert!(
            worst_band > 1e-5 && worst_away < 2e-6,
            "{worst_band} {worst_away}"
        );
    }
}
