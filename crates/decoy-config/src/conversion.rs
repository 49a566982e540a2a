//! Conversion: a [`SystemConfig`] to the plain numbers the controller, the
//! solver and the firmware are built from ([`SystemParams`], through which the
//! one conversion to the solver's model runs), and the helpers around it.

use decoy_controller::{
    AeroRows, ControllerConfig, ManagementParams, PerRequirement, SystemParams, Thresholds,
};
use solver_core::aero::AERO_TABLE_CAPACITY;
use solver_core::{
    AeroTable, AeroTableError, Atmosphere, Model, ModelParams, Real, SegmentLayout, Vec3,
};

use crate::error::ConfigError;
use crate::schema::{EnvelopeSection, ManagementSection, SystemConfig};

impl EnvelopeSection {
    /// The plain values.
    pub fn params(&self) -> decoy_controller::EnvelopeParams {
        decoy_controller::EnvelopeParams {
            altitude_m: self.altitude_m,
            mach: self.mach,
            load_factor: self.load_factor,
            max_body_rate_radps: self.max_body_rate_radps,
            max_along_path_acceleration_mps2: self.max_along_path_acceleration_mps2,
            max_dynamic_pressure_pa: self.max_dynamic_pressure_pa,
        }
    }
}

impl ManagementSection {
    /// The plain values, SI (angles in rad).
    pub fn params(&self) -> ManagementParams {
        let (p, c, t, e) = (&self.posture, &self.collision, &self.tension, &self.exhaust);
        ManagementParams {
            // Each requirement's section (in its unit; the margins' units are
            // `Requirement::unit`: radians for the posture's degrees).
            thresholds: PerRequirement {
                posture: Thresholds {
                    caution: p.caution_deg.to_radians(),
                    warning: p.warning_deg.to_radians(),
                    hysteresis: p.hysteresis_deg.to_radians(),
                },
                collision: Thresholds {
                    caution: c.caution_m,
                    warning: c.warning_m,
                    hysteresis: c.hysteresis_m,
                },
                tension: Thresholds {
                    caution: t.caution_n,
                    warning: t.warning_n,
                    hysteresis: t.hysteresis_n,
                },
                exhaust: Thresholds {
                    caution: e.caution_m,
                    warning: e.warning_m,
                    hysteresis: e.hysteresis_m,
                },
            },
            posture_amplitude_limit: p.amplitude_limit_deg.to_radians(),
            posture_window_s: p.window_s,
            collision_min_clearance: c.min_clearance_m,
            collision_cable_exclusion: c.cable_exclusion_m,
            slack_tension: t.slack_n,
            slack: Thresholds {
                caution: t.slack_caution_n,
                warning: t.slack_warning_n,
                hysteresis: t.slack_hysteresis_n,
            },
            exhaust_min_clearance: e.min_clearance_m,
            horizon_s: self.horizon_s,
            prediction_steps_per_frame: self.prediction_steps_per_frame,
            prediction_max_step_s: self.prediction_max_step_s,
            prediction_segments: self.prediction_segments,
        }
    }
}

impl SystemConfig {
    /// The system as plain numbers ([`SystemParams`]): what the solver's model,
    /// the geometry and the onboard controller are built from, on the host and (by
    /// the firmware's build script) on the target. Fails only if the aerodynamic
    /// table has more rows than the solver's table holds.
    pub fn params(&self) -> Result<SystemParams, ConfigError> {
        let (env, a, c, d, s) = (
            &self.environment,
            &self.aircraft,
            &self.cable,
            &self.decoy,
            &self.solver,
        );
        let mut aero_rows: AeroRows = [[0.0; 4]; AERO_TABLE_CAPACITY];
        if self.aero_rows.len() > aero_rows.len() {
            return Err(ConfigError::Solver(
                AeroTableError::TooManyRows {
                    rows: self.aero_rows.len(),
                    capacity: AERO_TABLE_CAPACITY,
                }
                .into(),
            ));
        }
        for (slot, row) in aero_rows.iter_mut().zip(&self.aero_rows) {
            *slot = row.to_array();
        }
        Ok(SystemParams {
            gravity: env.gravity,
            gas_constant: env.gas_constant,
            gamma: env.gamma,
            wind_ned: env.wind_ned,
            connection_point: a.connection_point,
            exhaust_nozzle: a.exhaust_nozzle,
            exhaust_axis: a.exhaust_axis,
            exhaust_nozzle_radius: a.exhaust_nozzle_radius,
            exhaust_half_angle_deg: a.exhaust_half_angle_deg,
            exhaust_length: a.exhaust_length,
            envelope_fore: a.envelope_fore,
            envelope_aft: a.envelope_aft,
            envelope_radius: a.envelope_radius,
            cable_length: c.length,
            cable_diameter: c.diameter,
            cable_linear_density: c.linear_density,
            cable_cd_normal: c.cd_normal,
            cable_cf_tangential: c.cf_tangential,
            allowable_tension: c.allowable_tension,
            decoy_mass: d.mass,
            decoy_length: d.length,
            decoy_diameter: d.diameter,
            decoy_x_cg: d.x_cg,
            decoy_x_tow: d.x_tow,
            decoy_x_mrp: d.x_mrp,
            decoy_inertia_cg: d.inertia_cg,
            decoy_cm_q: d.cm_q,
            decoy_cl_p: d.cl_p,
            aero_rows,
            aero_row_count: self.aero_rows.len(),
            segments_embedded: s.segments_embedded,
            grading_ratio_embedded: s.grading_ratio_embedded,
            management: self.management.params(),
            envelope: self.envelope.params(),
            limits: self.limits.unwrap_or(decoy_controller::LimitMap::EMPTY),
        })
    }

    /// The atmosphere model with the configured constants.
    pub fn atmosphere<T: Real>(&self) -> Atmosphere<T> {
        let env = &self.environment;
        Atmosphere::Isa1976 {
            gas_constant: T::lit(env.gas_constant),
            gamma: T::lit(env.gamma),
            gravity: T::lit(env.gravity),
        }
    }

    /// The largest Mach number of the declared envelope at `altitude` (m): the
    /// Mach range's upper end, or lower where the dynamic-pressure bound binds
    /// first ([`decoy_controller::EnvelopeParams::max_mach_at`]); `None`
    /// outside the atmosphere.
    pub fn max_mach_at(&self, altitude: f64) -> Option<f64> {
        self.envelope
            .params()
            .max_mach_at(altitude, &self.atmosphere(), self.environment.gamma)
    }

    /// The dynamic pressure of Mach `mach` at `altitude` (m), Pa; `None`
    /// outside the atmosphere.
    pub fn dynamic_pressure(&self, altitude: f64, mach: f64) -> Option<f64> {
        decoy_controller::EnvelopeParams::dynamic_pressure(
            mach,
            altitude,
            &self.atmosphere(),
            self.environment.gamma,
        )
    }

    /// The host model's layout: `solver.segments_host` uniform segments.
    pub fn host_layout<T: Real>(&self) -> SegmentLayout<T> {
        SegmentLayout::Uniform {
            count: self.solver.segments_host,
        }
    }

    /// The embedded model's layout: `solver.segments_embedded` segments graded by
    /// `solver.grading_ratio_embedded` (short at the decoy).
    pub fn embedded_layout<T: Real>(&self) -> SegmentLayout<T> {
        SegmentLayout::Graded {
            count: self.solver.segments_embedded,
            ratio: T::lit(self.solver.grading_ratio_embedded),
        }
    }

    /// The decoy aerodynamic table in the solver's form.
    pub fn aero_table<T: Real>(&self) -> Result<AeroTable<T>, ConfigError> {
        let rows: Vec<[f64; 4]> = self.aero_rows.iter().map(|r| r.to_array()).collect();
        AeroTable::from_degrees(&rows).map_err(|e| ConfigError::Solver(e.into()))
    }

    /// The solver's model parameters for this system with the given segment layout
    /// (the decoy at the end of the chain, the ISA 1976 atmosphere), built by
    /// [`SystemParams::model_params`]: the one conversion, shared with the firmware.
    pub fn model_params<T: Real>(
        &self,
        layout: SegmentLayout<T>,
    ) -> Result<ModelParams<T>, ConfigError> {
        self.params()?
            .model_params(layout)
            .map_err(|e| ConfigError::Solver(e.into()))
    }

    /// The onboard controller's configuration for this system with `layout` (the
    /// model, the exhaust plume and collision capsule, the allowable tension), built
    /// by [`SystemParams::controller_config`] exactly as the firmware builds its own.
    pub fn controller_config<T: Real>(
        &self,
        layout: SegmentLayout<T>,
    ) -> Result<ControllerConfig<T>, ConfigError> {
        self.params()?
            .controller_config(layout)
            .map_err(|e| ConfigError::Solver(e.into()))
    }

    /// Builds and validates the solver model with capacity `N` for `layout`
    /// ([`ConfigError::Solver`] if, for example, `layout` has more than `N` segments).
    pub fn model<T: Real, const N: usize>(
        &self,
        layout: SegmentLayout<T>,
    ) -> Result<Model<T, N>, ConfigError> {
        Ok(Model::new(self.model_params(layout)?)?)
    }

    /// ISA speed of sound at `altitude` (m, positive up), m/s.
    pub fn speed_of_sound(&self, altitude: f64) -> Result<f64, ConfigError> {
        Ok(self.atmosphere::<f64>().at(altitude)?.speed_of_sound)
    }

    /// True airspeed for Mach number `mach` at `altitude` (m), m/s: Mach times the
    /// ISA speed of sound there. Errors outside the atmosphere's altitude range.
    pub fn mach_to_speed(&self, altitude: f64, mach: f64) -> Result<f64, ConfigError> {
        Ok(mach * self.speed_of_sound(altitude)?)
    }
}

/// A `[x, y, z]` triple as a solver vector.
pub fn vec3<T: Real>(v: [f64; 3]) -> Vec3<T> {
    Vec3::new(T::lit(v[0]), T::lit(v[1]), T::lit(v[2]))
}
