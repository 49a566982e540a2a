//! Validation: every field of a [`SystemConfig`] within its physical range,
//! the first problem reported as a typed [`ConfigError`] naming the field and
//! the file that gave it.

use std::collections::BTreeMap;

use crate::error::ConfigError;
use crate::schema::{EnvelopeSection, ManagementSection, SystemConfig};

/// The only atmosphere model supported (`environment.atmosphere`).
pub const SUPPORTED_ATMOSPHERE: &str = "ISA-1976";

/// Largest horizontal wind speed a configuration may give, m/s: the strongest
/// jet-stream cores measured are about 110 m/s.
pub const MAX_WIND_MPS: f64 = 120.0;
/// Largest steady vertical wind, m/s (mountain waves reach about 20 m/s).
pub const MAX_VERTICAL_WIND_MPS: f64 = 25.0;
/// Largest offset of an aircraft station from the reference point, per body
/// axis, m: twice the length of the largest towing aircraft (a B-52, 48 m).
pub const MAX_BODY_OFFSET_M: f64 = 100.0;
/// Which file gave each field: for a file on its own, that file; for an overlay,
/// the overlay for the fields it writes and its base (or the base's base) for
/// the others.
#[derive(Clone, Debug, Default)]
pub(crate) struct Origins {
    /// The file named where no field matches (the file loaded).
    default: String,
    /// Dotted key paths (`decoy.x_mrp`, `management.posture`) to the file that
    /// wrote them last.
    by_key: BTreeMap<String, String>,
}

impl Origins {
    /// Every field from `file`.
    pub(crate) fn single(file: &str) -> Self {
        Origins {
            default: file.to_owned(),
            by_key: BTreeMap::new(),
        }
    }

    /// `default` for fields without an entry, then each `(key path, file)`.
    pub(crate) fn new(default: &str, by_key: BTreeMap<String, String>) -> Self {
        Origins {
            default: default.to_owned(),
            by_key,
        }
    }

    /// The file that gave `field`, written as the checks name it (`decoy.mass`,
    /// `envelope.mach[1]`, `decoy.inertia_cg (pitch)`): the entry of the field's
    /// key path, else of the nearest table above it, else the default.
    pub(crate) fn file_of(&self, field: &str) -> &str {
        let mut key = field.split([' ', '[']).next().unwrap_or(field).to_owned();
        loop {
            if let Some(file) = self.by_key.get(&key) {
                return file;
            }
            match key.rfind('.') {
                Some(dot) => key.truncate(dot),
                None => return &self.default,
            }
        }
    }
}

impl SystemConfig {
    /// Checks every field of the TOML tables (not the aerodynamic table, which is
    /// checked when parsed): finite numbers, positive masses and lengths, stations
    /// on the body, a supported atmosphere.
    /// Errors name [`SystemConfig::source`] as the file.
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.validate_with(&Origins::single(&self.source))
    }

    /// [`SystemConfig::validate`], each error naming the file `origins` says gave
    /// the field (an overlay, or its base).
    pub(crate) fn validate_with(&self, origins: &Origins) -> Result<(), ConfigError> {
        let c = Checker { origins };
        let env = &self.environment;
        if env.atmosphere != SUPPORTED_ATMOSPHERE {
            return Err(ConfigError::UnsupportedAtmosphere {
                file: origins.file_of("environment.atmosphere").to_owned(),
                name: env.atmosphere.clone(),
            });
        }
        // Physical ranges: a value outside one is a typing error or a unit slip,
        // never a flight condition, and would trim to nonsense rather than fail.
        c.positive("environment.gravity", env.gravity)?;
        c.range("environment.gravity", env.gravity, 9.7, 9.9)?;
        c.positive("environment.gas_constant", env.gas_constant)?;
        c.range("environment.gas_constant", env.gas_constant, 280.0, 300.0)?;
        c.positive("environment.gamma", env.gamma)?;
        c.range("environment.gamma", env.gamma, 1.3, 1.45)?;
        c.finite_vec("environment.wind_ned", env.wind_ned)?;
        let [north, east, down] = env.wind_ned;
        let horizontal = north.hypot(east);
        if horizontal > MAX_WIND_MPS {
            return Err(c.invalid(
                "environment.wind_ned",
                format!(
                    "must have a horizontal speed of at most {MAX_WIND_MPS} m/s (the strongest jet-stream winds), got {horizontal} m/s"
                ),
            ));
        }
        c.range(
            "environment.wind_ned[2]",
            down,
            -MAX_VERTICAL_WIND_MPS,
            MAX_VERTICAL_WIND_MPS,
        )?;

        let a = &self.aircraft;
        for (field, point) in [
            ("aircraft.connection_point", a.connection_point),
            ("aircraft.exhaust_nozzle", a.exhaust_nozzle),
            ("aircraft.exhaust_axis", a.exhaust_axis),
            ("aircraft.envelope_fore", a.envelope_fore),
            ("aircraft.envelope_aft", a.envelope_aft),
        ] {
            c.finite_vec(field, point)?;
            for (i, v) in point.iter().enumerate() {
                c.range(
                    &format!("{field}[{i}]"),
                    *v,
                    -MAX_BODY_OFFSET_M,
                    MAX_BODY_OFFSET_M,
                )?;
            }
        }
        if a.exhaust_axis.iter().all(|v| *v == 0.0) {
            return Err(c.invalid(
                "aircraft.exhaust_axis",
                "must not be the zero vector".to_owned(),
            ));
        }
        c.range(
            "aircraft.exhaust_nozzle_radius",
            a.exhaust_nozzle_radius,
            0.0,
            5.0,
        )?;
        c.range(
            "aircraft.exhaust_half_angle_deg",
            a.exhaust_half_angle_deg,
            0.0,
            89.0,
        )?;
        c.range("aircraft.exhaust_length", a.exhaust_length, 0.0, 500.0)?;
        c.range("aircraft.envelope_radius", a.envelope_radius, 0.0, 20.0)?;

        let cable = &self.cable;
        c.positive("cable.length", cable.length)?;
        c.range("cable.length", cable.length, 1.0, 1000.0)?;
        c.positive("cable.diameter", cable.diameter)?;
        c.range("cable.diameter", cable.diameter, 1e-4, 0.05)?;
        c.positive("cable.linear_density", cable.linear_density)?;
        c.range("cable.linear_density", cable.linear_density, 1e-4, 5.0)?;
        c.positive("cable.elastic_modulus", cable.elastic_modulus)?;
        c.range("cable.elastic_modulus", cable.elastic_modulus, 1e8, 1e12)?;
        c.positive("cable.allowable_tension", cable.allowable_tension)?;
        c.range("cable.allowable_tension", cable.allowable_tension, 1.0, 1e6)?;
        c.non_negative("cable.cd_normal", cable.cd_normal)?;
        c.range("cable.cd_normal", cable.cd_normal, 0.0, 3.0)?;
        c.non_negative("cable.cf_tangential", cable.cf_tangential)?;
        c.range("cable.cf_tangential", cable.cf_tangential, 0.0, 0.5)?;

        let d = &self.decoy;
        c.positive("decoy.mass", d.mass)?;
        c.range("decoy.mass", d.mass, 0.1, 500.0)?;
        c.positive("decoy.length", d.length)?;
        c.range("decoy.length", d.length, 0.1, 10.0)?;
        c.positive("decoy.diameter", d.diameter)?;
        c.range("decoy.diameter", d.diameter, 0.01, 2.0)?;
        c.range("decoy.x_cg", d.x_cg, 0.0, d.length)?;
        c.range("decoy.x_tow", d.x_tow, 0.0, d.length)?;
        c.range("decoy.x_mrp", d.x_mrp, 0.0, d.length)?;
        for (axis, value) in ["roll", "pitch", "yaw"].iter().zip(d.inertia_cg) {
            c.positive(&format!("decoy.inertia_cg ({axis})"), value)?;
            c.range(&format!("decoy.inertia_cg ({axis})"), value, 1e-6, 1e4)?;
        }
        c.range("decoy.cm_q", d.cm_q, -1e4, 1e4)?;
        c.range("decoy.cl_p", d.cl_p, -1e4, 1e4)?;
        if d.aero_table.trim().is_empty() {
            return Err(c.invalid(
                "decoy.aero_table",
                "must name the aerodynamic table file".to_owned(),
            ));
        }

        let s = &self.solver;
        if s.segments_host == 0 {
            return Err(c.invalid("solver.segments_host", "must be at least 1".to_owned()));
        }
        if s.segments_embedded == 0 {
            return Err(c.invalid("solver.segments_embedded", "must be at least 1".to_owned()));
        }
        c.range(
            "solver.grading_ratio_embedded",
            s.grading_ratio_embedded,
            1.0,
            10.0,
        )?;
        c.positive("solver.time_step_host", s.time_step_host)?;
        c.range("solver.time_step_host", s.time_step_host, 1e-6, 0.01)?;
        self.management.validate(&c)?;
        self.envelope.validate(&c)?;
        Ok(())
    }
}

impl EnvelopeSection {
    /// Each range ordered and inside the physical bounds a frame is rejected
    /// beyond (docs/protocol.md §4): the envelope says what the controller
    /// guarantees within what it accepts.
    fn validate(&self, c: &Checker<'_>) -> Result<(), ConfigError> {
        use decoy_controller::validate::{
            MAX_ACCELERATION_MPS2, MAX_ALTITUDE_M, MAX_BODY_RATE_RADPS, MAX_MACH, MIN_ALTITUDE_M,
        };
        let g_limit = f64::from(MAX_ACCELERATION_MPS2) / 9.80665;
        let ranges = [
            (
                "envelope.altitude_m",
                self.altitude_m,
                MIN_ALTITUDE_M,
                MAX_ALTITUDE_M,
            ),
            ("envelope.mach", self.mach, 0.0, MAX_MACH),
            ("envelope.load_factor", self.load_factor, -g_limit, g_limit),
        ];
        for (field, [low, high], min, max) in ranges {
            c.range(&format!("{field}[0]"), low, min, max)?;
            c.range(&format!("{field}[1]"), high, min, max)?;
            if low > high {
                return Err(c.invalid(
                    field,
                    format!("the low end {low} is above the high end {high}"),
                ));
            }
        }
        c.range(
            "envelope.max_body_rate_radps",
            self.max_body_rate_radps,
            0.0,
            f64::from(MAX_BODY_RATE_RADPS),
        )?;
        c.range(
            "envelope.max_along_path_acceleration_mps2",
            self.max_along_path_acceleration_mps2,
            0.0,
            f64::from(MAX_ACCELERATION_MPS2),
        )?;
        // Up to the dynamic pressure of the physical bounds' Mach 2 at sea level.
        c.range(
            "envelope.max_dynamic_pressure_pa",
            self.max_dynamic_pressure_pa,
            1.0,
            0.7 * 101_325.0 * MAX_MACH * MAX_MACH,
        )
    }
}

impl ManagementSection {
    fn validate(&self, c: &Checker<'_>) -> Result<(), ConfigError> {
        c.range("management.horizon_s", self.horizon_s, 0.1, 30.0)?;
        if !(1..=64).contains(&self.prediction_steps_per_frame) {
            return Err(c.invalid(
                "management.prediction_steps_per_frame",
                format!(
                    "must be between 1 and 64, got {}",
                    self.prediction_steps_per_frame
                ),
            ));
        }
        c.range(
            "management.prediction_max_step_s",
            self.prediction_max_step_s,
            1e-4,
            0.05,
        )?;
        if !(1..=decoy_controller::PREDICTION_CAPACITY).contains(&self.prediction_segments) {
            return Err(c.invalid(
                "management.prediction_segments",
                format!(
                    "must be between 1 and {} (the look-ahead's capacity), got {}",
                    decoy_controller::PREDICTION_CAPACITY,
                    self.prediction_segments
                ),
            ));
        }
        let p = &self.posture;
        c.positive(
            "management.posture.amplitude_limit_deg",
            p.amplitude_limit_deg,
        )?;
        c.range(
            "management.posture.window_s",
            p.window_s,
            4.0 * decoy_controller::monitor::POSTURE_SAMPLE_S,
            decoy_controller::monitor::MAX_POSTURE_WINDOW_S,
        )?;
        c.levels(
            "management.posture.",
            "deg",
            p.caution_deg,
            p.warning_deg,
            p.hysteresis_deg,
        )?;
        let k = &self.collision;
        c.non_negative("management.collision.min_clearance_m", k.min_clearance_m)?;
        c.non_negative(
            "management.collision.cable_exclusion_m",
            k.cable_exclusion_m,
        )?;
        c.levels(
            "management.collision.",
            "m",
            k.caution_m,
            k.warning_m,
            k.hysteresis_m,
        )?;
        let t = &self.tension;
        c.non_negative("management.tension.slack_n", t.slack_n)?;
        c.levels(
            "management.tension.",
            "n",
            t.caution_n,
            t.warning_n,
            t.hysteresis_n,
        )?;
        c.levels(
            "management.tension.slack_",
            "n",
            t.slack_caution_n,
            t.slack_warning_n,
            t.slack_hysteresis_n,
        )?;
        let e = &self.exhaust;
        c.finite("management.exhaust.min_clearance_m", e.min_clearance_m)?;
        c.levels(
            "management.exhaust.",
            "m",
            e.caution_m,
            e.warning_m,
            e.hysteresis_m,
        )?;
        Ok(())
    }
}

/// Field checks that name the field and the file that gave it.
struct Checker<'a> {
    origins: &'a Origins,
}

impl Checker<'_> {
    fn invalid(&self, field: &str, message: String) -> ConfigError {
        ConfigError::Invalid {
            file: self.origins.file_of(field).to_owned(),
            field: field.to_owned(),
            message,
        }
    }
    fn finite(&self, field: &str, v: f64) -> Result<(), ConfigError> {
        if v.is_finite() {
            Ok(())
        } else {
            Err(self.invalid(field, format!("must be a finite number, got {v}")))
        }
    }
    fn finite_vec(&self, field: &str, v: [f64; 3]) -> Result<(), ConfigError> {
        if v.iter().all(|x| x.is_finite()) {
            Ok(())
        } else {
            Err(self.invalid(field, format!("must hold finite numbers, got {v:?}")))
        }
    }
    fn positive(&self, field: &str, v: f64) -> Result<(), ConfigError> {
        self.finite(field, v)?;
        if v > 0.0 {
            Ok(())
        } else {
            Err(self.invalid(field, format!("must be positive, got {v}")))
        }
    }
    fn non_negative(&self, field: &str, v: f64) -> Result<(), ConfigError> {
        self.finite(field, v)?;
        if v >= 0.0 {
            Ok(())
        } else {
            Err(self.invalid(field, format!("must not be negative, got {v}")))
        }
    }
    /// Caution, warning and hysteresis of a monitor (the keys
    /// `<prefix>caution_<unit>`, ..., for example `management.tension.slack_` and
    /// `n`): finite, 0 <= warning <= caution, hysteresis >= 0.
    fn levels(
        &self,
        prefix: &str,
        unit: &str,
        caution: f64,
        warning: f64,
        hysteresis: f64,
    ) -> Result<(), ConfigError> {
        self.non_negative(&format!("{prefix}warning_{unit}"), warning)?;
        self.non_negative(&format!("{prefix}hysteresis_{unit}"), hysteresis)?;
        self.finite(&format!("{prefix}caution_{unit}"), caution)?;
        if caution < warning {
            return Err(self.invalid(
                &format!("{prefix}caution_{unit}"),
                format!("must not be below the warning threshold {warning}, got {caution}"),
            ));
        }
        Ok(())
    }
    fn range(&self, field: &str, v: f64, lo: f64, hi: f64) -> Result<(), ConfigError> {
        self.finite(field, v)?;
        if (lo..=hi).contains(&v) {
            Ok(())
        } else {
            Err(self.invalid(field, format!("must be between {lo} and {hi}, got {v}")))
        }
    }
}
