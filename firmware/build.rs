//! Build script of the firmware.
//!
//! 1. Links the board's memory map: copies `memory-mps2.x` to `OUT_DIR` as
//!    `memory.x`, where cortex-m-rt's `link.x` finds it. (A `memory.x` in the crate
//!    root would silently win over `OUT_DIR`, so there is none.)
//! 2. Passes the linker scripts (`-Tlink.x`, and `-Tdefmt.x` for defmt) from here
//!    rather than from `rustflags`, so that a `RUSTFLAGS` in the environment (for
//!    example `-C target-cpu=cortex-m7`) cannot drop them.
//! 3. Generates `OUT_DIR/reference.rs`, the reference system's constants, from the
//!    project's configuration files `../config/reference-system.toml` and the
//!    aerodynamic table it names, so the firmware cannot drift from them: the
//!    model, the exhaust plume and collision capsule, the allowable tension.
//!    Derived values (the plume's unit axis and the tangent of its half angle) are
//!    computed here in f64 with std, exactly as the host's `decoy_sim::geometry`
//!    computes them, so host reference and target use the same numbers.

use std::env;
use std::error::Error;
use std::fmt::Write as _;
use std::fs;
use std::path::{Path, PathBuf};

/// The board's memory map (QEMU `mps2-an386`: 4 MiB flash at 0, 4 MiB RAM at 0x2000_0000).
const MEMORY_MAP: &str = "memory-mps2.x";
/// The reference system, relative to this crate.
const SYSTEM_TOML: &str = "../config/reference-system.toml";
/// The only atmosphere the solver implements.
const SUPPORTED_ATMOSPHERE: &str = "ISA-1976";

type Result<T> = std::result::Result<T, Box<dyn Error>>;

fn main() -> Result<()> {
    let out = PathBuf::from(env::var_os("OUT_DIR").ok_or("OUT_DIR is not set")?);

    fs::copy(MEMORY_MAP, out.join("memory.x"))
        .map_err(|e| format!("cannot copy {MEMORY_MAP}: {e}"))?;
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed={MEMORY_MAP}");
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
    println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
    // The same for the measurement examples (examples/step_cost.rs).
    println!("cargo:rustc-link-arg-examples=-Tlink.x");
    println!("cargo:rustc-link-arg-examples=-Tdefmt.x");
    // The M7 profile's f64 runs in hardware only with the Cortex-M7's FPv5-D16.
    if env::var_os("CARGO_FEATURE_M7").is_some() {
        let flags = env::var("CARGO_ENCODED_RUSTFLAGS").unwrap_or_default();
        if !flags.contains("target-cpu=cortex-m7") {
            println!(
                "cargo:warning=feature `m7` without `-C target-cpu=cortex-m7`: f64 is software-emulated; build with `cargo build-m7`"
            );
        }
    }

    let toml_path = Path::new(SYSTEM_TOML);
    println!("cargo:rerun-if-changed={SYSTEM_TOML}");
    let text =
        fs::read_to_string(toml_path).map_err(|e| format!("cannot read {SYSTEM_TOML}: {e}"))?;
    let system: toml::Table = text.parse().map_err(|e| format!("{SYSTEM_TOML}: {e}"))?;
    let config = Config {
        table: &system,
        file: SYSTEM_TOML,
    };

    let aero_name = config.string("decoy", "aero_table")?;
    let aero_path = toml_path.parent().unwrap_or(Path::new(".")).join(aero_name);
    println!("cargo:rerun-if-changed={}", aero_path.display());
    let csv = fs::read_to_string(&aero_path)
        .map_err(|e| format!("cannot read {}: {e}", aero_path.display()))?;
    let aero_rows = parse_aero_csv(&aero_path.display().to_string(), &csv)?;

    let source = generate(&config, &aero_rows, &aero_path.display().to_string())?;
    fs::write(out.join("reference.rs"), source)?;
    Ok(())
}

/// The parsed TOML and its file name, for messages.
struct Config<'a> {
    table: &'a toml::Table,
    file: &'a str,
}

impl Config<'_> {
    fn value(&self, section: &str, key: &str) -> Result<&toml::Value> {
        self.table
            .get(section)
            .and_then(|s| s.get(key))
            .ok_or_else(|| format!("{}: missing `{section}.{key}`", self.file).into())
    }

    /// A finite number (TOML integer or float).
    fn number(&self, section: &str, key: &str) -> Result<f64> {
        let v = match self.value(section, key)? {
            toml::Value::Float(f) => *f,
            toml::Value::Integer(i) => *i as f64,
            other => {
                return Err(format!(
                    "{}: `{section}.{key}` must be a number, found {}",
                    self.file,
                    other.type_str()
                )
                .into());
            }
        };
        if !v.is_finite() {
            return Err(format!("{}: `{section}.{key}` is not finite", self.file).into());
        }
        Ok(v)
    }

    /// A non-negative integer.
    fn count(&self, section: &str, key: &str) -> Result<usize> {
        match self.value(section, key)? {
            toml::Value::Integer(i) if *i >= 0 => Ok(usize::try_from(*i)?),
            _ => Err(format!(
                "{}: `{section}.{key}` must be a non-negative integer",
                self.file
            )
            .into()),
        }
    }

    /// Three finite numbers.
    fn vec3(&self, section: &str, key: &str) -> Result<[f64; 3]> {
        let bad = || format!("{}: `{section}.{key}` must be three numbers", self.file);
        let array = self.value(section, key)?.as_array().ok_or_else(bad)?;
        if array.len() != 3 {
            return Err(bad().into());
        }
        let mut v = [0.0; 3];
        for (slot, item) in v.iter_mut().zip(array) {
            *slot = match item {
                toml::Value::Float(f) if f.is_finite() => *f,
                toml::Value::Integer(i) => *i as f64,
                _ => return Err(bad().into()),
            };
        }
        Ok(v)
    }

    fn string(&self, section: &str, key: &str) -> Result<&str> {
        self.value(section, key)?
            .as_str()
            .ok_or_else(|| format!("{}: `{section}.{key}` must be a string", self.file).into())
    }
}

/// Rows `alpha_deg, cl, cd, cm` of the aerodynamic table; `#` lines and the
/// header are skipped. The solver checks the angles when it builds the table.
fn parse_aero_csv(file: &str, text: &str) -> Result<Vec<[f64; 4]>> {
    let mut rows = Vec::new();
    for (number, line) in text.lines().enumerate().map(|(i, l)| (i + 1, l.trim())) {
        if line.is_empty() || line.starts_with('#') || line.starts_with("alpha") {
            continue;
        }
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        if fields.len() != 4 {
            return Err(format!(
                "{file}:{number}: expected 4 columns, found {}",
                fields.len()
            )
            .into());
        }
        let mut row = [0.0; 4];
        for (slot, field) in row.iter_mut().zip(&fields) {
            *slot = field
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| format!("{file}:{number}: `{field}` is not a finite number"))?;
        }
        rows.push(row);
    }
    Ok(rows)
}

/// A Rust literal that reads back as exactly `v`: `Debug` prints a finite f64 in
/// its shortest round-trip form, always with a `.` or an exponent.
fn literal(v: f64) -> String {
    format!("{v:?}")
}

fn vec_literal(v: &[f64]) -> String {
    let items: Vec<String> = v.iter().map(|x| literal(*x)).collect();
    format!("[{}]", items.join(", "))
}

/// The generated module: one documented constant per configuration value.
fn generate(config: &Config, aero_rows: &[[f64; 4]], aero_file: &str) -> Result<String> {
    let atmosphere = config.string("environment", "atmosphere")?;
    if atmosphere != SUPPORTED_ATMOSPHERE {
        return Err(format!(
            "{}: `environment.atmosphere` is {atmosphere:?}; the solver implements only {SUPPORTED_ATMOSPHERE:?}",
            config.file
        )
        .into());
    }

    let mut s = String::new();
    writeln!(
        s,
        "// @generated by firmware/build.rs from {} and {aero_file}; do not edit.",
        config.file
    )?;
    let numbers: &[(&str, &str, &str, &str)] = &[
        ("GRAVITY", "environment", "gravity", "m/s^2, along +z (NED)"),
        ("GAS_CONSTANT", "environment", "gas_constant", "J/(kg K)"),
        ("GAMMA", "environment", "gamma", "ratio of specific heats"),
        ("CABLE_LENGTH", "cable", "length", "m"),
        ("CABLE_DIAMETER", "cable", "diameter", "m"),
        ("CABLE_LINEAR_DENSITY", "cable", "linear_density", "kg/m"),
        (
            "CABLE_CD_NORMAL",
            "cable",
            "cd_normal",
            "cross-flow drag coefficient",
        ),
        (
            "CABLE_CF_TANGENTIAL",
            "cable",
            "cf_tangential",
            "skin-friction coefficient",
        ),
        ("DECOY_MASS", "decoy", "mass", "kg"),
        ("DECOY_LENGTH", "decoy", "length", "m"),
        ("DECOY_DIAMETER", "decoy", "diameter", "m"),
        ("DECOY_X_CG", "decoy", "x_cg", "m behind the nose"),
        ("DECOY_X_TOW", "decoy", "x_tow", "m behind the nose"),
        ("DECOY_X_MRP", "decoy", "x_mrp", "m behind the nose"),
        ("DECOY_CM_Q", "decoy", "cm_q", "per rad"),
        ("DECOY_CL_P", "decoy", "cl_p", "per rad"),
        (
            "ALLOWABLE_TENSION",
            "cable",
            "allowable_tension",
            "N, management limit at the connection point",
        ),
        (
            "EXHAUST_NOZZLE_RADIUS",
            "aircraft",
            "exhaust_nozzle_radius",
            "m",
        ),
        ("EXHAUST_LENGTH", "aircraft", "exhaust_length", "m"),
        ("ENVELOPE_RADIUS", "aircraft", "envelope_radius", "m"),
        (
            "GRADING_RATIO_EMBEDDED",
            "solver",
            "grading_ratio_embedded",
            "segment length ratio",
        ),
    ];
    for (name, section, key, unit) in numbers {
        let v = config.number(section, key)?;
        writeln!(s, "/// `{section}.{key}`, {unit}.")?;
        writeln!(s, "pub const {name}: f64 = {};", literal(v))?;
    }
    let vectors: &[(&str, &str, &str, &str)] = &[
        ("WIND_NED", "environment", "wind_ned", "m/s, NED"),
        (
            "CONNECTION_POINT",
            "aircraft",
            "connection_point",
            "m, aircraft body frame (FRD)",
        ),
        (
            "EXHAUST_NOZZLE",
            "aircraft",
            "exhaust_nozzle",
            "m, aircraft body frame (FRD)",
        ),
        (
            "ENVELOPE_FORE",
            "aircraft",
            "envelope_fore",
            "m, aircraft body frame (FRD)",
        ),
        (
            "ENVELOPE_AFT",
            "aircraft",
            "envelope_aft",
            "m, aircraft body frame (FRD)",
        ),
        (
            "DECOY_INERTIA_CG",
            "decoy",
            "inertia_cg",
            "kg m^2 (roll, pitch, yaw)",
        ),
    ];
    for (name, section, key, unit) in vectors {
        let v = config.vec3(section, key)?;
        writeln!(s, "/// `{section}.{key}`, {unit}.")?;
        writeln!(s, "pub const {name}: [f64; 3] = {};", vec_literal(&v))?;
    }
    // Derived geometry, in f64 with std (as decoy_sim::geometry::plume_from_config).
    let axis = config.vec3("aircraft", "exhaust_axis")?;
    let norm = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt();
    if norm.is_nan() || norm <= 0.0 {
        return Err(format!("{}: `aircraft.exhaust_axis` must not be zero", config.file).into());
    }
    let unit = [axis[0] / norm, axis[1] / norm, axis[2] / norm];
    writeln!(
        s,
        "/// `aircraft.exhaust_axis` normalised: the plume axis, aircraft body frame (FRD)."
    )?;
    writeln!(
        s,
        "pub const EXHAUST_AXIS_UNIT: [f64; 3] = {};",
        vec_literal(&unit)
    )?;
    let half_angle = config.number("aircraft", "exhaust_half_angle_deg")?;
    writeln!(
        s,
        "/// tan(`aircraft.exhaust_half_angle_deg`): the plume's spread per metre."
    )?;
    writeln!(
        s,
        "pub const EXHAUST_TAN_HALF_ANGLE: f64 = {};",
        literal(half_angle.to_radians().tan())
    )?;

    let segments = config.count("solver", "segments_embedded")?;
    writeln!(
        s,
        "/// `solver.segments_embedded`: segments of the reduced model."
    )?;
    writeln!(s, "pub const SEGMENTS_EMBEDDED: usize = {segments};")?;

    writeln!(s, "/// `{aero_file}`: rows `alpha_deg, cl, cd, cm`.")?;
    writeln!(
        s,
        "pub const AERO_ROWS: [[f64; 4]; {}] = [",
        aero_rows.len()
    )?;
    for row in aero_rows {
        writeln!(s, "    {},", vec_literal(row))?;
    }
    writeln!(s, "];")?;
    Ok(s)
}
