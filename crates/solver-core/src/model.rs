//! The immutable model: environment, cable discretisation, decoy. Validated once
//! when built; the hot loop only reads it.
//!
//! Frames and signs: world is flat-earth NED (x north, y east, z down, metres);
//! bodies are FRD (x forward, y right, z down). Decoy stations (`x_cg`, `x_tow`,
//! `x_mrp`) are distances measured backwards from the decoy nose along its axis,
//! so the body-frame position of station `s` relative to the nose is `(-s, 0, 0)`.

use crate::aero::AeroTable;
use crate::atmosphere::Atmosphere;
use crate::error::ConfigError;
use crate::scalar::{Mat3, Real, Vec3, vec_finite, zero3};

/// Gravity, wind and atmosphere.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Environment<T: Real> {
    /// Gravitational acceleration, m/s^2, acting along +z (NED down).
    pub gravity: T,
    /// Steady wind (velocity of the air over the ground), NED, m/s.
    pub wind: Vec3<T>,
    /// Atmosphere model.
    pub atmosphere: Atmosphere<T>,
}

/// Cable material and aerodynamics.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CableParams<T: Real> {
    /// Deployed length, m.
    pub length: T,
    /// Diameter, m (zero: no cable aerodynamics).
    pub diameter: T,
    /// Mass per unit length, kg/m.
    pub linear_density: T,
    /// Cross-flow drag coefficient on the normal velocity component.
    pub cd_normal: T,
    /// Skin-friction coefficient on the tangential velocity component.
    pub cf_tangential: T,
}

/// How the cable length is divided into rigid segments.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SegmentLayout<T: Real> {
    /// `count` segments of equal length.
    Uniform {
        /// Number of segments.
        count: usize,
    },
    /// `count` segments whose length grows geometrically by `ratio` from the decoy
    /// toward the aircraft (segment N, at the decoy, is the shortest).
    Graded {
        /// Number of segments.
        count: usize,
        /// Length ratio between neighbouring segments (>= 1).
        ratio: T,
    },
}

impl<T: Real> SegmentLayout<T> {
    /// The number of segments.
    pub fn count(&self) -> usize {
        match *self {
            SegmentLayout::Uniform { count } | SegmentLayout::Graded { count, .. } => count,
        }
    }
}

/// The decoy: a rigid axisymmetric body hinged to the cable at its towing point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DecoyParams<T: Real> {
    /// Mass, kg.
    pub mass: T,
    /// Body length, m (the aerodynamic reference length).
    pub length: T,
    /// Body diameter, m (reference area pi d^2 / 4).
    pub diameter: T,
    /// Centre of gravity, m behind the nose.
    pub x_cg: T,
    /// Towing point (cable hinge, on the axis), m behind the nose.
    pub x_tow: T,
    /// Moment reference point of the table, m behind the nose.
    pub x_mrp: T,
    /// Principal moments of inertia about the CG (roll, pitch, yaw), kg m^2.
    pub inertia_cg: Vec3<T>,
    /// Pitch/yaw damping derivative, per rad (negative damps).
    pub cm_q: T,
    /// Roll damping derivative, per rad (negative damps).
    pub cl_p: T,
    /// CL, CD, Cm against total angle of attack.
    pub aero: AeroTable<T>,
}

/// What hangs at the far end of the chain.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum EndBody<T: Real> {
    /// A decoy on a spherical hinge at joint N.
    Decoy(DecoyParams<T>),
    /// Nothing: joint N is a free end (the compound pendulum).
    Free,
}

/// Everything needed to build a [`Model`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ModelParams<T: Real> {
    /// Gravity, wind, atmosphere.
    pub environment: Environment<T>,
    /// Cable hinge on the aircraft, aircraft body frame (FRD), m, relative to the
    /// aircraft reference point whose motion the flight path prescribes.
    pub connection_point: Vec3<T>,
    /// Cable.
    pub cable: CableParams<T>,
    /// Discretisation.
    pub layout: SegmentLayout<T>,
    /// Decoy or free end.
    pub end: EndBody<T>,
}

/// Decoy quantities derived once from [`DecoyParams`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DecoyDerived<T: Real> {
    /// Towing point relative to the CG, body frame, m (`(x_cg - x_tow, 0, 0)`).
    pub tow_from_cg: Vec3<T>,
    /// Moment reference point relative to the CG, body frame, m.
    pub mrp_from_cg: Vec3<T>,
    /// Inverse principal inertia (body frame, diagonal entries).
    pub inertia_inv: Vec3<T>,
    /// `[r]x^T I^-1 [r]x` in the body frame, r = towing point from CG.
    pub hinge_compliance: Mat3<T>,
    /// Reference area pi d^2 / 4, m^2.
    pub reference_area: T,
}

/// A validated model with room for `N` segments.
///
/// Invariant: `1 <= segment_count <= N`, every length and mass positive and finite,
/// lengths sum to the cable length; entries beyond `segment_count` are unused.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Model<T: Real, const N: usize> {
    params: ModelParams<T>,
    segment_count: usize,
    // The arrays the segment loop reads together are side by side (small address
    // offsets from one base on the Cortex-M).
    lengths: [T; N],
    /// l_i / 2 (the segment loop's lever to the segment centre).
    half_lengths: [T; N],
    normal_drag_factors: [T; N],
    tangential_drag_factors: [T; N],
    inverse_masses: [T; N],
    rate_gains: [T; N],
    masses: [T; N],
    decoy: Option<DecoyDerived<T>>,
    /// `decoy.is_some()`, kept apart: one load where the evaluation only asks
    /// whether there is a decoy (several times per evaluation).
    has_decoy: bool,
}

fn positive<T: Real>(field: &'static str, v: T) -> Result<(), ConfigError> {
    if !v.finite() {
        return Err(ConfigError::NonFinite { field });
    }
    if v <= T::zero() {
        return Err(ConfigError::NonPositive {
            field,
            value: v.to_f64(),
        });
    }
    Ok(())
}

fn non_negative<T: Real>(field: &'static str, v: T) -> Result<(), ConfigError> {
    if !v.finite() {
        return Err(ConfigError::NonFinite { field });
    }
    if v < T::zero() {
        return Err(ConfigError::OutOfRange {
            field,
            value: v.to_f64(),
        });
    }
    Ok(())
}

fn finite_vec<T: Real>(field: &'static str, v: &Vec3<T>) -> Result<(), ConfigError> {
    if vec_finite(v) {
        Ok(())
    } else {
        Err(ConfigError::NonFinite { field })
    }
}

/// Checks everything in `params` but the segments' lengths and masses and the
/// decoy, in the order [`Model::new`] reports them; returns the segment count (at
/// most `capacity`).
fn validate<T: Real>(params: &ModelParams<T>, capacity: usize) -> Result<usize, ConfigError> {
    let count = params.layout.count();
    if count == 0 {
        return Err(ConfigError::NoSegments);
    }
    if count > capacity {
        return Err(ConfigError::TooManySegments {
            requested: count,
            capacity,
        });
    }
    let env = &params.environment;
    non_negative("environment.gravity", env.gravity)?;
    finite_vec("environment.wind_ned", &env.wind)?;
    if let Atmosphere::Isa1976 {
        gas_constant,
        gamma,
        gravity,
    } = env.atmosphere
    {
        positive("environment.gas_constant", gas_constant)?;
        positive("environment.gamma", gamma)?;
        positive("environment.gravity", gravity)?;
    }
    finite_vec("aircraft.connection_point", &params.connection_point)?;
    let cable = &params.cable;
    positive("cable.length", cable.length)?;
    positive("cable.linear_density", cable.linear_density)?;
    non_negative("cable.diameter", cable.diameter)?;
    non_negative("cable.cd_normal", cable.cd_normal)?;
    non_negative("cable.cf_tangential", cable.cf_tangential)?;
    if let SegmentLayout::Graded { ratio, .. } = params.layout {
        positive("grading ratio", ratio)?;
        if ratio < T::one() || ratio > T::lit(10.0) {
            return Err(ConfigError::OutOfRange {
                field: "grading ratio",
                value: ratio.to_f64(),
            });
        }
    }
    Ok(count)
}

/// Calls `f(i, length, mass)` for every segment of `params`' layout, from the
/// decoy end (`i = count - 1`) to the connection point (`i = 0`).
///
/// Graded: segment N (at the decoy) is the shortest, l_i = l_N r^(N-i); the weights
/// r^k are formed by repeated multiplication from the decoy end and scaled so that
/// the lengths sum to the cable length (the same bits on every call).
fn for_each_segment<T: Real>(
    params: &ModelParams<T>,
    count: usize,
    mut f: impl FnMut(usize, T, T),
) {
    let cable = &params.cable;
    let mass = |length: T| cable.linear_density * length;
    match params.layout {
        SegmentLayout::Uniform { .. } => {
            let l = cable.length / T::lit(count as f64);
            for i in (0..count).rev() {
                f(i, l, mass(l));
            }
        }
        SegmentLayout::Graded { ratio, .. } => {
            // Sum = l_N (r^N - 1)/(r - 1), or N l_N at r = 1.
            let mut weight = T::one();
            let mut total = T::zero();
            for _ in 0..count {
                total += weight;
                weight *= ratio;
            }
            let scale = cable.length / total;
            let mut weight = T::one();
            for i in (0..count).rev() {
                let l = weight * scale;
                f(i, l, mass(l));
                weight *= ratio;
            }
        }
    }
}

/// Validates the decoy and derives its constant quantities.
fn decoy_derived<T: Real>(d: &DecoyParams<T>) -> Result<DecoyDerived<T>, ConfigError> {
    positive("decoy.mass", d.mass)?;
    positive("decoy.length", d.length)?;
    positive("decoy.diameter", d.diameter)?;
    non_negative("decoy.x_cg", d.x_cg)?;
    non_negative("decoy.x_tow", d.x_tow)?;
    non_negative("decoy.x_mrp", d.x_mrp)?;
    positive("decoy.inertia_cg[roll]", d.inertia_cg.x)?;
    positive("decoy.inertia_cg[pitch]", d.inertia_cg.y)?;
    positive("decoy.inertia_cg[yaw]", d.inertia_cg.z)?;
    if !d.cm_q.finite() {
        return Err(ConfigError::NonFinite {
            field: "decoy.cm_q",
        });
    }
    if !d.cl_p.finite() {
        return Err(ConfigError::NonFinite {
            field: "decoy.cl_p",
        });
    }
    for (field, s) in [
        ("decoy.x_cg", d.x_cg),
        ("decoy.x_tow", d.x_tow),
        ("decoy.x_mrp", d.x_mrp),
    ] {
        if s > d.length {
            return Err(ConfigError::OutOfRange {
                field,
                value: s.to_f64(),
            });
        }
    }
    let tow_from_cg = Vec3::new(d.x_cg - d.x_tow, T::zero(), T::zero());
    let mrp_from_cg = Vec3::new(d.x_cg - d.x_mrp, T::zero(), T::zero());
    let inertia_inv = Vec3::new(
        T::one() / d.inertia_cg.x,
        T::one() / d.inertia_cg.y,
        T::one() / d.inertia_cg.z,
    );
    let rx = crate::scalar::skew(&tow_from_cg);
    let hinge_compliance = rx.transpose() * Mat3::from_diagonal(&inertia_inv) * rx;
    let reference_area = T::pi() * d.diameter * d.diameter / T::lit(4.0);
    Ok(DecoyDerived {
        tow_from_cg,
        mrp_from_cg,
        inertia_inv,
        hinge_compliance,
        reference_area,
    })
}

impl<T: Real, const N: usize> Model<T, N> {
    /// The capacity `N`.
    pub const CAPACITY: usize = N;

    /// No segments, every value zero, all zero bits: the model of
    /// [`Solver::UNCONFIGURED`](crate::Solver::UNCONFIGURED), which
    /// [`Model::configure`] replaces. It breaks the invariant (no segments) and is
    /// never evaluated.
    pub(crate) const UNCONFIGURED: Self = {
        let z = T::ZERO;
        let z3 = zero3();
        Model {
            params: ModelParams {
                environment: Environment {
                    gravity: z,
                    wind: z3,
                    atmosphere: Atmosphere::Isa1976 {
                        gas_constant: z,
                        gamma: z,
                        gravity: z,
                    },
                },
                connection_point: z3,
                cable: CableParams {
                    length: z,
                    diameter: z,
                    linear_density: z,
                    cd_normal: z,
                    cf_tangential: z,
                },
                layout: SegmentLayout::Uniform { count: 0 },
                // The first variant (like every enum here), so that the constant is
                // all zero bits in practice; `decoy` below is None, so the model has
                // no decoy.
                end: EndBody::Decoy(DecoyParams {
                    mass: z,
                    length: z,
                    diameter: z,
                    x_cg: z,
                    x_tow: z,
                    x_mrp: z,
                    inertia_cg: z3,
                    cm_q: z,
                    cl_p: z,
                    aero: AeroTable::EMPTY,
                }),
            },
            segment_count: 0,
            lengths: [z; N],
            half_lengths: [z; N],
            masses: [z; N],
            inverse_masses: [z; N],
            rate_gains: [z; N],
            normal_drag_factors: [z; N],
            tangential_drag_factors: [z; N],
            decoy: None,
            has_decoy: false,
        }
    };

    /// Validates `params` and builds the model.
    pub fn new(params: ModelParams<T>) -> Result<Self, ConfigError> {
        let mut model = Self::UNCONFIGURED;
        model.configure(&params)?;
        Ok(model)
    }

    /// Validates `params` and makes this the model built from them, in place (no
    /// model-sized temporary): [`Model::new`] for a model that already has its
    /// memory, for example inside a solver in a `static`. On error the model is
    /// left exactly as it was.
    pub(crate) fn configure(&mut self, params: &ModelParams<T>) -> Result<(), ConfigError> {
        // Every check first (the segments' lengths and masses computed once to be
        // checked), then the writes, which cannot fail.
        let count = validate(params, N)?;
        // The segments come from the decoy end: the error kept is the one of the
        // segment nearest the connection point, as checking from there would find.
        let mut segments = Ok(());
        for_each_segment(params, count, |_, length, mass| {
            let check =
                positive("segment length", length).and_then(|()| positive("segment mass", mass));
            if check.is_err() {
                segments = check;
            }
        });
        // The cable's length and density are checked above: a graded segment
        // that is not positive and finite comes from ratio^count leaving the range.
        segments.map_err(|e| match params.layout {
            SegmentLayout::Graded { count, ratio } => ConfigError::GradingOverflow {
                count,
                ratio: ratio.to_f64(),
            },
            SegmentLayout::Uniform { .. } => e,
        })?;
        let decoy = match &params.end {
            EndBody::Free => None,
            EndBody::Decoy(d) => Some(decoy_derived(d)?),
        };

        self.params = *params;
        self.segment_count = count;
        let cable = &params.cable;
        let unused = count..N;
        for array in [
            &mut self.lengths,
            &mut self.half_lengths,
            &mut self.masses,
            &mut self.inverse_masses,
            &mut self.rate_gains,
            &mut self.normal_drag_factors,
            &mut self.tangential_drag_factors,
        ] {
            array[unused.clone()].fill(T::zero());
        }
        // Checked above: every length and mass is positive and finite.
        for_each_segment(params, count, |i, length, mass| {
            self.lengths[i] = length;
            self.half_lengths[i] = T::lit(0.5) * length;
            self.masses[i] = mass;
            let inverse_mass = T::one() / mass;
            self.inverse_masses[i] = inverse_mass;
            self.rate_gains[i] = T::lit(6.0) / (mass * length);
            let area_per_mass = T::lit(0.5) * cable.diameter * length * inverse_mass;
            self.normal_drag_factors[i] = area_per_mass * cable.cd_normal;
            self.tangential_drag_factors[i] = area_per_mass * T::pi() * cable.cf_tangential;
        });
        self.has_decoy = decoy.is_some();
        self.decoy = decoy;
        Ok(())
    }

    /// The parameters the model was built from.
    pub fn params(&self) -> &ModelParams<T> {
        &self.params
    }
    /// Number of segments in use: 1 to `N`. The model holds that by
    /// construction ([`Model::configure`] rejects any other count); the clamp
    /// restates it where the optimiser sees it, so that no index below the
    /// count into an array of capacity `N` (nor the last segment's, count - 1)
    /// keeps a bounds check: the frame path has no reachable panic
    /// (firmware/examples/panic_never.rs). An unconfigured model (count 0)
    /// reports 1; it is never evaluated.
    #[inline]
    pub fn segment_count(&self) -> usize {
        self.segment_count.clamp(1, N)
    }
    /// Segment `i`'s length, m (`i` below the count; a larger `i` reads the
    /// capacity's last entry, never a panic: for the trim, whose indices the
    /// optimiser does not follow).
    pub(crate) fn length_of(&self, i: usize) -> T {
        self.lengths[i.min(N - 1)]
    }
    /// Segment `i`'s mass, kg (as [`Model::length_of`]).
    pub(crate) fn mass_of(&self, i: usize) -> T {
        self.masses[i.min(N - 1)]
    }
    /// True once configured (a model of zero bits, `Solver::UNCONFIGURED`'s,
    /// is not).
    pub fn is_configured(&self) -> bool {
        self.segment_count != 0
    }
    /// Segment lengths, index 0 = segment 1 at the connection point.
    pub fn lengths(&self) -> &[T] {
        &self.lengths[..self.segment_count()]
    }
    /// Half the segment lengths, l_i / 2 (exactly: halving is exact).
    pub fn half_lengths(&self) -> &[T] {
        &self.half_lengths[..self.segment_count()]
    }
    /// Segment masses, index 0 = segment 1 at the connection point.
    pub fn masses(&self) -> &[T] {
        &self.masses[..self.segment_count()]
    }
    /// Inverse segment masses 1/m_i.
    pub fn inverse_masses(&self) -> &[T] {
        &self.inverse_masses[..self.segment_count()]
    }
    /// 6/(m_i l_i): angular acceleration of segment i per unit of perpendicular hinge-force sum
    /// (a thin rod's transverse inertia about its centre is m l^2 / 12).
    pub fn rate_gains(&self) -> &[T] {
        &self.rate_gains[..self.segment_count()]
    }
    /// [`Model::rate_gains`] as the whole array of capacity `N` (the entries
    /// past the segment count are never read): for the sweeps, whose indices
    /// below the count the optimiser then proves in range (no bounds check).
    pub(crate) fn rate_gains_all(&self) -> &[T; N] {
        &self.rate_gains
    }
    /// Cable drag per unit mass and unit density of each segment (docs/design.md §2): the
    /// normal factors `0.5 d l_i C_n / m_i` and the tangential factors
    /// `0.5 d l_i pi C_f / m_i`, so that F_i/m_i = rho (k_n |u_n| u_n + k_t |u_t| u_t).
    pub fn drag_factors(&self) -> (&[T], &[T]) {
        (
            &self.normal_drag_factors[..self.segment_count()],
            &self.tangential_drag_factors[..self.segment_count()],
        )
    }
    /// True with a decoy at the cable's end (`decoy().is_some()`, one load).
    #[inline(always)]
    pub fn has_decoy(&self) -> bool {
        self.has_decoy
    }
    /// Decoy parameters, or `None` for a free end.
    pub fn decoy(&self) -> Option<(&DecoyParams<T>, &DecoyDerived<T>)> {
        match (&self.params.end, &self.decoy) {
            (EndBody::Decoy(p), Some(d)) => Some((p, d)),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params(layout: SegmentLayout<f64>) -> ModelParams<f64> {
        ModelParams {
            environment: Environment {
                gravity: 9.81,
                wind: Vec3::zeros(),
                atmosphere: Atmosphere::Vacuum,
            },
            connection_point: Vec3::zeros(),
            cable: CableParams {
                length: 100.0,
                diameter: 0.0,
                linear_density: 0.01,
                cd_normal: 0.0,
                cf_tangential: 0.0,
            },
            layout,
            end: EndBody::Free,
        }
    }

    #[test]
    fn graded_lengths_sum_and_ratio() {
        let m = Model::<f64, 32>::new(params(SegmentLayout::Graded {
            count: 16,
            ratio: 1.3,
        }))
        .unwrap();
        let l = m.lengths();
        assert!((l.iter().sum::<f64>() - 100.0).abs() < 1e-9);
        for i in 0..15 {
            assert!((l[i] / l[i + 1] - 1.3).abs() < 1e-12);
        }
        assert!(l[15] < l[0]);
    }

    #[test]
    fn capacity_and_bad_values_are_rejected() {
        assert_eq!(
            Model::<f64, 8>::new(params(SegmentLayout::Uniform { count: 9 })).unwrap_err(),
            ConfigError::TooManySegments {
                requested: 9,
                capacity: 8
            }
        );
        assert_eq!(
            Model::<f64, 8>::new(params(SegmentLayout::Uniform { count: 0 })).unwrap_err(),
            ConfigError::NoSegments
        );
        let mut p = params(SegmentLayout::Uniform { count: 4 });
        p.cable.linear_density = -1.0;
        assert!(matches!(
            Model::<f64, 8>::new(p),
            Err(ConfigError::NonPositive {
                field: "cable.linear_density",
                ..
            })
        ));
        p.cable.linear_density = f64::NAN;
        assert!(matches!(
            Model::<f64, 8>::new(p),
            Err(ConfigError::NonFinite { .. })
        ));
        let p = params(SegmentLayout::Graded {
            count: 4,
            ratio: 0.5,
        });
        assert!(matches!(
            Model::<f64, 8>::new(p),
            Err(ConfigError::OutOfRange { .. })
        ));
    }

    /// A ratio whose power over the segments leaves the range is named as such,
    /// in f64 (10^511) and in f32 (3^99), not as a non-finite segment length.
    #[test]
    fn a_grading_that_overflows_is_named() {
        let overflow = ConfigError::GradingOverflow {
            count: 512,
            ratio: 10.0,
        };
        assert_eq!(
            Model::<f64, 512>::new(params(SegmentLayout::Graded {
                count: 512,
                ratio: 10.0,
            }))
            .unwrap_err(),
            overflow
        );
        let p = ModelParams::<f32> {
            environment: Environment {
                gravity: 9.81,
                wind: Vec3::zeros(),
                atmosphere: Atmosphere::Vacuum,
            },
            connection_point: Vec3::zeros(),
            cable: CableParams {
                length: 100.0,
                diameter: 0.0,
                linear_density: 0.01,
                cd_normal: 0.0,
                cf_tangential: 0.0,
            },
            layout: SegmentLayout::Graded {
                count: 100,
                ratio: 3.0,
            },
            end: EndBody::Free,
        };
        assert_eq!(
            Model::<f32, 128>::new(p).unwrap_err(),
            ConfigError::GradingOverflow {
                count: 100,
                ratio: 3.0,
            }
        );
        let text = overflow.to_string();
        assert!(
            text.contains("10^511") && text.contains("fewer segments"),
            "{text}"
        );
    }
}
