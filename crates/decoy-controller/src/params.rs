//! The reference system as plain numbers, and the one conversion from them to
//! what the solver and the controller are built from.
//!
//! [`SystemParams`] holds the values of `config/reference-system.toml` and its
//! aerodynamic table in f64 (SI units, the frames of docs/outputs.md), with no
//! validation of its own: `decoy-config` reads and validates the files and fills
//! it (on the host at run time, and in the firmware's build script at build time).
//! It is plain `Copy` data with public fields, so its derived `Debug` form is a
//! Rust expression that rebuilds it exactly (floats print in their shortest
//! round-trip form): the build script writes it as the firmware's `const`, with no
//! parser or decoder on the target. Everything else is derived here, once, in
//! the precision `T` the consumer runs: the solver's [`ModelParams`], the
//! [`Geometry`] of the clearances and the [`ControllerConfig`]. The solver checks
//! the model when it is built ([`solver_core::Model::new`]).

use solver_core::aero::AERO_TABLE_CAPACITY;
use solver_core::{
    AeroTable, AeroTableError, Atmosphere, CableParams, DecoyParams, EndBody, Environment,
    ModelParams, Real, SegmentLayout, Vec3,
};

use crate::controller::ControllerConfig;
use crate::envelope::{EnvelopeParams, OperatingEnvelope};
use crate::geometry::{Envelope, ExhaustPlume, Geometry};
use crate::limits::LimitMap;
use crate::monitor::{ManagementConfig, ManagementParams, usable_angle_of_attack};

/// Rows `[alpha_deg, cl, cd, cm]` of the decoy's aerodynamic table, room for the
/// solver's table capacity ([`SystemParams::aero_row_count`] of them are used).
pub type AeroRows = [[f64; 4]; AERO_TABLE_CAPACITY];

/// The towed system: environment, aircraft, cable, decoy and the embedded model's
/// discretisation. Field by field the `[section] key` of the configuration file;
/// units SI, vectors in the frame named on each field.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SystemParams {
    /// `environment.gravity`, m/s², along +z (NED).
    pub gravity: f64,
    /// `environment.gas_constant`, J/(kg K) (ISA 1976).
    pub gas_constant: f64,
    /// `environment.gamma`, ratio of specific heats.
    pub gamma: f64,
    /// `environment.wind_ned`, m/s, NED.
    pub wind_ned: [f64; 3],
    /// `aircraft.connection_point`, m, aircraft body frame (FRD) from its reference point.
    pub connection_point: [f64; 3],
    /// `aircraft.exhaust_nozzle`, m, body frame.
    pub exhaust_nozzle: [f64; 3],
    /// `aircraft.exhaust_axis`, body frame (any length but zero).
    pub exhaust_axis: [f64; 3],
    /// `aircraft.exhaust_nozzle_radius`, m.
    pub exhaust_nozzle_radius: f64,
    /// `aircraft.exhaust_half_angle_deg`, degrees.
    pub exhaust_half_angle_deg: f64,
    /// `aircraft.exhaust_length`, m.
    pub exhaust_length: f64,
    /// `aircraft.envelope_fore`, m, body frame: fore end of the collision capsule's axis.
    pub envelope_fore: [f64; 3],
    /// `aircraft.envelope_aft`, m, body frame: aft end of the capsule's axis.
    pub envelope_aft: [f64; 3],
    /// `aircraft.envelope_radius`, m.
    pub envelope_radius: f64,
    /// `cable.length`, m.
    pub cable_length: f64,
    /// `cable.diameter`, m.
    pub cable_diameter: f64,
    /// `cable.linear_density`, kg/m.
    pub cable_linear_density: f64,
    /// `cable.cd_normal`, cross-flow drag coefficient.
    pub cable_cd_normal: f64,
    /// `cable.cf_tangential`, skin-friction coefficient.
    pub cable_cf_tangential: f64,
    /// `cable.allowable_tension`, N: the management limit at the connection point.
    pub allowable_tension: f64,
    /// `decoy.mass`, kg.
    pub decoy_mass: f64,
    /// `decoy.length`, m.
    pub decoy_length: f64,
    /// `decoy.diameter`, m.
    pub decoy_diameter: f64,
    /// `decoy.x_cg`, m behind the nose.
    pub decoy_x_cg: f64,
    /// `decoy.x_tow`, m behind the nose.
    pub decoy_x_tow: f64,
    /// `decoy.x_mrp`, m behind the nose.
    pub decoy_x_mrp: f64,
    /// `decoy.inertia_cg`, kg m² (roll, pitch, yaw).
    pub decoy_inertia_cg: [f64; 3],
    /// `decoy.cm_q`, per rad.
    pub decoy_cm_q: f64,
    /// `decoy.cl_p`, per rad.
    pub decoy_cl_p: f64,
    /// The table `decoy.aero_table` names: its first
    /// [`SystemParams::aero_row_count`] rows (the rest zero).
    pub aero_rows: AeroRows,
    /// Rows of the table in use.
    pub aero_row_count: usize,
    /// `solver.segments_embedded`: segments of the embedded (reduced) model.
    pub segments_embedded: usize,
    /// `solver.grading_ratio_embedded`: length ratio of consecutive segments.
    pub grading_ratio_embedded: f64,
    /// `[management]`: the monitors' thresholds, the look-ahead's horizon and slice.
    pub management: ManagementParams,
    /// `[envelope]`: the operating envelope the controller guarantees.
    pub envelope: EnvelopeParams,
    /// `envelope.limits_map`: the manoeuvre envelope map of this configuration
    /// (its hash checked), or [`LimitMap::EMPTY`] without one.
    pub limits: LimitMap,
}

/// A configuration triple as a solver vector in `T`.
pub fn vec3<T: Real>(v: [f64; 3]) -> Vec3<T> {
    Vec3::new(T::lit(v[0]), T::lit(v[1]), T::lit(v[2]))
}

impl SystemParams {
    /// The ISA 1976 atmosphere with the configured constants.
    pub fn atmosphere<T: Real>(&self) -> Atmosphere<T> {
        Atmosphere::Isa1976 {
            gas_constant: T::lit(self.gas_constant),
            gamma: T::lit(self.gamma),
            gravity: T::lit(self.gravity),
        }
    }

    /// The embedded model's discretisation: [`SystemParams::segments_embedded`]
    /// segments graded by [`SystemParams::grading_ratio_embedded`], the shortest
    /// at the decoy.
    pub fn embedded_layout<T: Real>(&self) -> SegmentLayout<T> {
        SegmentLayout::Graded {
            count: self.segments_embedded,
            ratio: T::lit(self.grading_ratio_embedded),
        }
    }

    /// The decoy's aerodynamic table in the solver's form.
    pub fn aero_table<T: Real>(&self) -> Result<AeroTable<T>, AeroTableError> {
        let rows =
            self.aero_rows
                .get(..self.aero_row_count)
                .ok_or(AeroTableError::TooManyRows {
                    rows: self.aero_row_count,
                    capacity: AERO_TABLE_CAPACITY,
                })?;
        AeroTable::from_degrees(rows)
    }

    /// The solver's parameters for this system with `layout` (the decoy at the end
    /// of the chain).
    pub fn model_params<T: Real>(
        &self,
        layout: SegmentLayout<T>,
    ) -> Result<ModelParams<T>, AeroTableError> {
        let t = T::lit;
        Ok(ModelParams {
            environment: Environment {
                gravity: t(self.gravity),
                wind: vec3(self.wind_ned),
                atmosphere: self.atmosphere(),
            },
            connection_point: vec3(self.connection_point),
            cable: CableParams {
                length: t(self.cable_length),
                diameter: t(self.cable_diameter),
                linear_density: t(self.cable_linear_density),
                cd_normal: t(self.cable_cd_normal),
                cf_tangential: t(self.cable_cf_tangential),
            },
            layout,
            end: EndBody::Decoy(DecoyParams {
                mass: t(self.decoy_mass),
                length: t(self.decoy_length),
                diameter: t(self.decoy_diameter),
                x_cg: t(self.decoy_x_cg),
                x_tow: t(self.decoy_x_tow),
                x_mrp: t(self.decoy_x_mrp),
                inertia_cg: vec3(self.decoy_inertia_cg),
                cm_q: t(self.decoy_cm_q),
                cl_p: t(self.decoy_cl_p),
                aero: self.aero_table()?,
            }),
        })
    }

    /// The exhaust plume (axis normalised, half-angle tangent by libm, in f64).
    pub fn plume<T: Real>(&self) -> ExhaustPlume<T> {
        ExhaustPlume::new(
            self.exhaust_nozzle,
            self.exhaust_axis,
            self.exhaust_nozzle_radius,
            self.exhaust_half_angle_deg,
            self.exhaust_length,
        )
    }

    /// The aircraft's collision capsule.
    pub fn envelope<T: Real>(&self) -> Envelope<T> {
        Envelope::new(self.envelope_fore, self.envelope_aft, self.envelope_radius)
    }

    /// The plume and capsule the clearances are measured to.
    pub fn geometry<T: Real>(&self) -> Geometry<T> {
        Geometry {
            plume: self.plume(),
            envelope: self.envelope(),
        }
    }

    /// The usable total angle of attack of the decoy's table, rad
    /// ([`usable_angle_of_attack`]).
    pub fn usable_angle_of_attack(&self) -> f64 {
        usable_angle_of_attack(&self.aero_rows[..self.aero_row_count.min(self.aero_rows.len())])
    }

    /// The management configuration in `T`.
    pub fn management<T: Real>(&self) -> ManagementConfig<T> {
        ManagementConfig {
            wind: vec3(self.wind_ned),
            ..ManagementConfig::new(
                &self.management,
                self.allowable_tension,
                self.usable_angle_of_attack(),
            )
        }
    }

    /// The controller's configuration with `layout`: the model, the geometry,
    /// the allowable tension and the management configuration.
    pub fn controller_config<T: Real>(
        &self,
        layout: SegmentLayout<T>,
    ) -> Result<ControllerConfig<T>, AeroTableError> {
        Ok(ControllerConfig {
            params: self.model_params(layout)?,
            geometry: self.geometry(),
            allowable_tension_n: T::lit(self.allowable_tension),
            management: self.management(),
            envelope: OperatingEnvelope::new(
                &self.envelope,
                self.gravity,
                &self.atmosphere::<f64>(),
                self.gamma,
            ),
            limits: self.limits,
            trim_units_per_frame: crate::controller::trim_slice_units::<T>(),
            max_steps_per_frame: crate::controller::MAX_STEPS_PER_FRAME,
        })
    }
}
