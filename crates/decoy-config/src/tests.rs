//! Tests of loading, overlays, validation and the conversion.

use std::path::Path;

use solver_core::{Atmosphere, Model};

use crate::*;

fn with(from: &str, to: &str) -> String {
    assert!(BUILTIN_TOML.contains(from), "test edit `{from}` not found");
    BUILTIN_TOML.replacen(from, to, 1)
}

#[test]
fn the_management_section_is_optional_and_checked() {
    let config = SystemConfig::builtin().unwrap();
    // The reference file states the defaults explicitly.
    assert_eq!(config.management, ManagementSection::default());
    // Without the section: the same values.
    let start = BUILTIN_TOML.find("[management]").unwrap();
    let without = SystemConfig::from_str(&BUILTIN_TOML[..start], BUILTIN_AERO_CSV).unwrap();
    assert_eq!(without.management, config.management);
    // A warning threshold above the caution one is named.
    let bad = BUILTIN_TOML.replace("warning_m = 0.25", "warning_m = 0.75");
    let e = SystemConfig::from_str(&bad, BUILTIN_AERO_CSV).unwrap_err();
    assert!(
        e.to_string().contains("management.exhaust.caution_m"),
        "{e}"
    );
    // The usable angle of attack of the reference table: where its restoring
    // moment stops growing, 40 degrees.
    let params = config.params().unwrap();
    assert!((params.usable_angle_of_attack().to_degrees() - 40.0).abs() < 1e-9);
}

/// `[management]` has one table per requirement, named as it
/// (`[management.posture]`, ...), and no other.
#[test]
fn the_management_tables_are_the_requirements() {
    let section = toml::Value::try_from(ManagementSection::default()).unwrap();
    let tables: Vec<&str> = section
        .as_table()
        .unwrap()
        .iter()
        .filter(|(_, v)| v.is_table())
        .map(|(k, _)| k.as_str())
        .collect();
    let mut names: Vec<&str> = decoy_controller::Requirement::ALL
        .iter()
        .map(|r| r.name())
        .collect();
    names.sort_unstable();
    let mut tables = tables;
    tables.sort_unstable();
    assert_eq!(tables, names);
}

#[test]
fn builtin_parses_and_builds_models() {
    let config = SystemConfig::builtin().unwrap();
    assert_eq!(config.environment.atmosphere, "ISA-1976");
    assert_eq!(config.aircraft.connection_point, [-2.0, 0.0, 1.7]);
    assert_eq!(config.aircraft.exhaust_half_angle_deg, 3.0);
    assert_eq!(config.aircraft.exhaust_length, 35.0);
    assert_eq!(config.aircraft.envelope_radius, 1.6);
    assert_eq!(config.cable.allowable_tension, 1200.0);
    assert_eq!(config.decoy.inertia_cg, [0.0025, 0.27, 0.27]);
    assert_eq!(config.solver.segments_host, 300);
    assert_eq!(config.aero_rows.len(), 35);
    assert_eq!(
        config.aero_rows[1],
        AeroRow {
            alpha_deg: 2.0,
            cl: 0.428087,
            cd: 0.464949,
            cm: -0.092994
        }
    );

    let host: Model<f64, 300> = config.model(config.host_layout()).unwrap();
    assert_eq!(host.segment_count(), 300);
    assert!((host.lengths().iter().sum::<f64>() - 100.0).abs() < 1e-9);
    let (decoy, _) = host.decoy().unwrap();
    assert_eq!(decoy.mass, 4.0);
    assert_eq!(decoy.aero.rows(), 35);

    let embedded: Model<f32, 16> = config.model(config.embedded_layout()).unwrap();
    let l = embedded.lengths();
    assert_eq!(l.len(), 12);
    assert!((l[0] / l[11] - 1.26f32.powi(11)).abs() < 1e-2);
}

#[test]
fn from_str_and_from_file_match_builtin() {
    let builtin = SystemConfig::builtin().unwrap();
    let parsed = SystemConfig::from_str(BUILTIN_TOML, BUILTIN_AERO_CSV).unwrap();
    assert_eq!(parsed.aero_rows, builtin.aero_rows);
    assert_eq!(parsed.decoy, builtin.decoy);
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/reference-system.toml");
    let file = SystemConfig::from_file(&path).unwrap();
    assert_eq!(file.cable, builtin.cable);
    assert_eq!(file.aero_rows, builtin.aero_rows);
}

/// A scratch directory of this test process, removed when dropped.
struct Scratch(std::path::PathBuf);

impl Scratch {
    fn new(test: &str) -> Self {
        let dir = std::env::temp_dir().join(format!("decoy-config-{}-{test}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        Scratch(dir)
    }

    /// Writes `text` to `name` (with its directories) and returns its path.
    fn write(&self, name: &str, text: &str) -> std::path::PathBuf {
        let path = self.0.join(name);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(&path, text).unwrap();
        path
    }

    /// The reference system as `dir/reference.toml` beside its aerodynamic table.
    fn reference(&self, dir: &str) -> std::path::PathBuf {
        self.write(&format!("{dir}/decoy-aero.csv"), BUILTIN_AERO_CSV);
        self.write(
            &format!("{dir}/reference-system.limits.toml"),
            BUILTIN_LIMITS_TOML,
        );
        self.write(&format!("{dir}/reference.toml"), BUILTIN_TOML)
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// The weak-stability decoy is the reference system with exactly its decoy's
/// moment reference point and towing point changed: built in and from its file
/// alike, [management], [envelope] and the embedded model the reference's.
#[test]
fn the_weak_stability_overlay_is_the_reference_with_two_decoy_stations_moved() {
    let reference = SystemConfig::builtin().unwrap();
    let weak = SystemConfig::weak_stability().unwrap();
    let mut expected = reference.clone();
    expected.decoy.x_tow = 0.225;
    expected.decoy.x_mrp = 0.1715;
    expected.source = WEAK_STABILITY_NAME.to_owned();
    // Not the reference's envelope map: an overlay is another system.
    expected.envelope.limits_map = None;
    expected.limits = None;
    expected.limits_text = None;
    assert_eq!(weak, expected);
    assert!(weak.decoy.x_mrp < reference.decoy.x_mrp);

    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/weak-stability-decoy.toml");
    let mut file = SystemConfig::from_file(&path).unwrap();
    assert_eq!(file.source, path.display().to_string());
    file.source = WEAK_STABILITY_NAME.to_owned();
    assert_eq!(file, weak);
}

/// An overlay's tables merge key by key onto its base's (nested tables too),
/// arrays are replaced whole, and the base's aerodynamic table is found beside
/// the base; an overlay of an overlay stacks.
#[test]
fn an_overlay_merges_table_by_table_onto_its_base() {
    let scratch = Scratch::new("merge");
    scratch.reference("systems");
    let overlay = scratch.write(
        "variants/light.toml",
        "base = \"../systems/reference.toml\"\n\
         [decoy]\nmass = 3.0\n\
         [solver]\nsegments_embedded = 10\n\
         [management.tension]\ncaution_n = 250.0\n\
         [envelope]\nmach = [0.4, 0.9]\n",
    );
    let reference = SystemConfig::builtin().unwrap();
    let light = SystemConfig::from_file(&overlay).unwrap();
    let mut expected = reference.clone();
    expected.decoy.mass = 3.0;
    expected.solver.segments_embedded = 10;
    expected.management.tension.caution_n = 250.0;
    expected.envelope.mach = [0.4, 0.9];
    expected.envelope.limits_map = None;
    expected.limits = None;
    expected.limits_text = None;
    expected.source = overlay.display().to_string();
    assert_eq!(light, expected);

    let lighter = scratch.write(
        "variants/lighter.toml",
        "base = \"light.toml\"\n[decoy]\nmass = 2.5\n",
    );
    let lighter = SystemConfig::from_file(&lighter).unwrap();
    assert_eq!(lighter.decoy.mass, 2.5);
    assert_eq!(lighter.solver.segments_embedded, 10);
    assert_eq!(lighter.aero_rows, reference.aero_rows);
}

/// An overlay that names its own aerodynamic table finds it beside itself.
#[test]
fn an_overlays_aero_table_is_relative_to_the_overlay() {
    let scratch = Scratch::new("aero");
    scratch.reference("systems");
    let csv = BUILTIN_AERO_CSV.replacen(
        "\n0,0.000000,0.450000,-0.000000",
        "\n0,0.000000,0.500000,-0.000000",
        1,
    );
    assert_ne!(csv, BUILTIN_AERO_CSV, "the row at 0 degrees");
    scratch.write("variants/draggy.csv", &csv);
    let overlay = scratch.write(
        "variants/draggy.toml",
        "base = \"../systems/reference.toml\"\n[decoy]\naero_table = \"draggy.csv\"\n",
    );
    let config = SystemConfig::from_file(&overlay).unwrap();
    assert_eq!(config.aero_rows[0].cd, 0.5);
}

/// Text without a file (a Python dict's) resolves its names in the directory
/// given, else among the built-in files; its errors name it as given.
#[test]
fn text_in_a_directory_resolves_its_names_there_else_among_the_builtins() {
    let scratch = Scratch::new("text-in");
    let reference = SystemConfig::builtin().unwrap();
    // The built-in reference, whole: its aerodynamic table is the built-in one.
    let whole = SystemConfig::from_text_in("config dict", BUILTIN_TOML, &scratch.0).unwrap();
    let mut expected = reference.clone();
    expected.source = "config dict".to_owned();
    assert_eq!(whole, expected);
    // An overlay on the built-in reference.
    let overlay = "base = \"reference-system.toml\"\n[decoy]\nmass = 3.0\n";
    let light = SystemConfig::from_text_in("config dict", overlay, &scratch.0).unwrap();
    assert_eq!(light.decoy.mass, 3.0);
    assert_eq!(light.cable, reference.cable);
    // A file of that name in the directory comes first (for the names the
    // text itself writes: the overlay's aerodynamic table is its base's).
    scratch.write(
        "decoy-aero.csv",
        &BUILTIN_AERO_CSV.replacen(
            "\n0,0.000000,0.450000,-0.000000",
            "\n0,0.000000,0.500000,-0.000000",
            1,
        ),
    );
    // (Without the reference's envelope map, which is not this system's.)
    let unmapped = BUILTIN_TOML.replace("limits_map = \"reference-system.limits.toml\"", "");
    assert_ne!(unmapped, BUILTIN_TOML);
    let draggy = SystemConfig::from_text_in("config dict", &unmapped, &scratch.0).unwrap();
    assert_eq!(draggy.aero_rows[0].cd, 0.5);
    let light = SystemConfig::from_text_in("config dict", overlay, &scratch.0).unwrap();
    assert_eq!(light.aero_rows, reference.aero_rows);
    // Errors name the text as given; a name that is neither is the read error.
    let bad = SystemConfig::from_text_in(
        "config dict",
        "base = \"reference-system.toml\"\n[decoy]\nmass = -1.0\n",
        &scratch.0,
    )
    .unwrap_err();
    assert_eq!(
        bad.to_string(),
        "config dict: decoy.mass must be positive, got -1"
    );
    let missing =
        SystemConfig::from_text_in("config dict", "base = \"nowhere.toml\"\n", &scratch.0)
            .unwrap_err();
    assert!(matches!(missing, ConfigError::Io { .. }), "{missing}");
}

/// Errors in an overlay name the file that wrote the field: an unknown or
/// mistyped key with its line in the overlay, a value out of range in the
/// overlay or in its base.
#[test]
fn overlay_errors_name_the_file_and_the_field() {
    let scratch = Scratch::new("errors");
    let base = scratch.reference("systems");
    let overlay = |name: &str, body: &str| {
        scratch.write(
            &format!("variants/{name}.toml"),
            &format!("base = \"../systems/reference.toml\"\n{body}"),
        )
    };

    let unknown = overlay("unknown", "\n[decoy]\nx_mpr = 0.2\n");
    match SystemConfig::from_file(&unknown).unwrap_err() {
        ConfigError::Toml {
            file,
            line,
            message,
        } => {
            assert_eq!(file, unknown.display().to_string());
            assert_eq!(line, Some(4));
            assert!(message.contains("unknown field `x_mpr`"), "{message}");
        }
        other => panic!("{other:?}"),
    }

    let mistyped = overlay("mistyped", "[decoy]\nx_tow = \"far\"\n");
    match SystemConfig::from_file(&mistyped).unwrap_err() {
        ConfigError::Toml { file, line, .. } => {
            assert_eq!(file, mistyped.display().to_string());
            assert_eq!(line, Some(3));
        }
        other => panic!("{other:?}"),
    }

    let heavy = overlay("heavy", "[decoy]\nmass = -1.0\n");
    match SystemConfig::from_file(&heavy).unwrap_err() {
        ConfigError::Invalid { file, field, .. } => {
            assert_eq!(file, heavy.display().to_string());
            assert_eq!(field, "decoy.mass");
        }
        other => panic!("{other:?}"),
    }

    // The base's own mistake is the base's, whatever the overlay writes.
    std::fs::write(
        &base,
        BUILTIN_TOML.replacen("length = 100.0 ", "length = -100.0 ", 1),
    )
    .unwrap();
    match SystemConfig::from_file(&heavy).unwrap_err() {
        ConfigError::Invalid { file, field, .. } => {
            assert_eq!(file, base.display().to_string());
            assert_eq!(field, "cable.length");
        }
        other => panic!("{other:?}"),
    }
}

/// `base` must be a string naming a file that exists, and the chain of bases
/// must not come back to a file in it.
#[test]
fn bad_bases_are_typed_errors() {
    let scratch = Scratch::new("bases");
    let a = scratch.write("a.toml", "base = \"b.toml\"\n");
    scratch.write("b.toml", "base = \"./a.toml\"\n");
    match SystemConfig::from_file(&a).unwrap_err() {
        ConfigError::BaseCycle { file, base, chain } => {
            assert!(file.ends_with("b.toml"), "{file}");
            assert_eq!(base, "./a.toml");
            assert_eq!(chain.len(), 3, "{chain:?}");
        }
        other => panic!("{other:?}"),
    }
    let own = scratch.write("own.toml", "base = \"own.toml\"\n");
    assert!(
        matches!(
            SystemConfig::from_file(&own),
            Err(ConfigError::BaseCycle { .. })
        ),
        "a file cannot be its own base"
    );

    let number = scratch.write("number.toml", "base = 3\n");
    match SystemConfig::from_file(&number).unwrap_err() {
        ConfigError::Invalid {
            file,
            field,
            message,
        } => {
            assert_eq!(file, number.display().to_string());
            assert_eq!(field, BASE_KEY);
            assert!(message.contains("got an integer"), "{message}");
        }
        other => panic!("{other:?}"),
    }

    let missing = scratch.write("missing.toml", "base = \"nowhere.toml\"\n");
    match SystemConfig::from_file(&missing).unwrap_err() {
        ConfigError::Io { path, .. } => assert!(path.ends_with("nowhere.toml"), "{path:?}"),
        other => panic!("{other:?}"),
    }

    // Text without a file has nothing to resolve a base against.
    match SystemConfig::from_str("base = \"reference-system.toml\"\n", BUILTIN_AERO_CSV) {
        Err(ConfigError::Invalid { field, .. }) => assert_eq!(field, BASE_KEY),
        other => panic!("{other:?}"),
    }
}

#[test]
fn too_many_segments_is_a_solver_error() {
    let config = SystemConfig::builtin().unwrap();
    let err = config.model::<f64, 16>(config.host_layout()).unwrap_err();
    assert!(
        matches!(
            err,
            ConfigError::Solver(solver_core::ConfigError::TooManySegments { .. })
        ),
        "{err}"
    );
}

#[test]
fn missing_field_is_named() {
    let toml = with("mass = 4.0 ", "# no mass ");
    let err = SystemConfig::from_str(&toml, BUILTIN_AERO_CSV).unwrap_err();
    assert!(matches!(err, ConfigError::Toml { .. }), "{err:?}");
    let message = err.to_string();
    assert!(
        message.contains("missing field `mass`") && message.contains("decoy"),
        "{message}"
    );
}

#[test]
fn unknown_field_is_named_with_its_line() {
    let toml = with("cl_p = -0.3", "cl_p = -0.3\ncl_r = 1.0");
    let err = SystemConfig::from_str(&toml, BUILTIN_AERO_CSV).unwrap_err();
    let line = toml.lines().position(|l| l.starts_with("cl_r")).unwrap() + 1;
    match &err {
        ConfigError::Toml {
            line: Some(l),
            message,
            ..
        } => {
            assert_eq!(*l, line);
            assert!(message.contains("unknown field `cl_r`"), "{message}");
        }
        other => panic!("wrong error {other:?}"),
    }
    assert!(err.to_string().contains(&format!("line {line}")), "{err}");
}

/// Issue 27, item 8: every number of the configuration has a physical range.
/// Each numeric value of the reference system's TOML (every element of an
/// array too) set to a huge value, then to its negative, is rejected as
/// `Invalid` naming its own field (`wind_ned = [1e30, 0, 0]` trimmed to
/// 4.37e57 N before).
#[test]
fn every_configuration_number_has_a_physical_range() {
    let reference: toml::Table = toml::from_str(BUILTIN_TOML).unwrap();
    let mut checked = 0;
    for (table, keys) in &reference {
        let toml::Value::Table(keys) = keys else {
            continue;
        };
        for (key, value) in keys {
            let elements = match value {
                toml::Value::Array(a) => a.len(),
                toml::Value::Float(_) => 0,
                _ => continue,
            };
            for element in 0..elements.max(1) {
                for huge in [1e30, -1e30] {
                    let mut edited = reference.clone();
                    let slot = edited[table.as_str()]
                        .as_table_mut()
                        .unwrap()
                        .get_mut(key.as_str())
                        .unwrap();
                    let slot = match slot {
                        toml::Value::Array(a) => &mut a[element],
                        other => other,
                    };
                    *slot = toml::Value::Float(huge);
                    let text = toml::to_string(&edited).unwrap();
                    let field = format!("{table}.{key}");
                    match SystemConfig::from_str(&text, BUILTIN_AERO_CSV) {
                        Err(ConfigError::Invalid { field: named, .. }) => assert!(
                            named.starts_with(&field),
                            "{field}[{element}] = {huge}: blamed on {named}"
                        ),
                        other => panic!("{field}[{element}] = {huge}: {other:?}"),
                    }
                    checked += 1;
                }
            }
        }
    }
    assert!(checked > 100, "{checked} values checked");
    // The aerodynamic table's coefficients too.
    for (edit, named) in [
        ("\n0,1e30,0.450000,-0.000000", "cl"),
        ("\n0,0.000000,-0.1,-0.000000", "cd"),
        ("\n0,0.000000,0.450000,-1e30", "cm"),
    ] {
        let csv = BUILTIN_AERO_CSV.replacen("\n0,0.000000,0.450000,-0.000000", edit, 1);
        assert_ne!(csv, BUILTIN_AERO_CSV, "the row at 0 degrees");
        match SystemConfig::from_str(BUILTIN_TOML, &csv) {
            Err(ConfigError::AeroCsv { message, .. }) => {
                assert!(
                    message.starts_with(&format!("{named} must be between")),
                    "{message}"
                )
            }
            other => panic!("{named}: {other:?}"),
        }
    }
}

#[test]
fn negative_mass_is_invalid() {
    let toml = with("mass = 4.0 ", "mass = -4.0 ");
    let err = SystemConfig::from_str(&toml, BUILTIN_AERO_CSV).unwrap_err();
    match &err {
        ConfigError::Invalid { field, .. } => assert_eq!(field, "decoy.mass"),
        other => panic!("wrong error {other:?}"),
    }
    assert!(
        err.to_string()
            .contains("decoy.mass must be positive, got -4"),
        "{err}"
    );
}

/// The envelope's dynamic-pressure bound: negative, zero, NaN and missing are
/// refused naming the field; the reference's gives Mach 0.805 at sea level
/// and the Mach range's 0.95 from 2.7 km.
#[test]
fn the_dynamic_pressure_bound_is_checked_and_cuts_the_low_fast_corner() {
    for bad in ["-1.0", "0.0", "nan", "1e9"] {
        let toml = with(
            "max_dynamic_pressure_pa = 46000.0",
            &format!("max_dynamic_pressure_pa = {bad}"),
        );
        let err = SystemConfig::from_str(&toml, BUILTIN_AERO_CSV).unwrap_err();
        assert!(
            matches!(&err, ConfigError::Invalid { field, .. } if field == "envelope.max_dynamic_pressure_pa"),
            "{bad}: {err:?}"
        );
    }
    let toml = with("max_dynamic_pressure_pa = 46000.0\n", "");
    let err = SystemConfig::from_str(&toml, BUILTIN_AERO_CSV).unwrap_err();
    assert!(err.to_string().contains("max_dynamic_pressure_pa"), "{err}");
    let config = SystemConfig::builtin().unwrap();
    let sea_level = config.max_mach_at(0.0).unwrap();
    assert!((sea_level - 0.8053).abs() < 1e-4, "{sea_level}");
    assert_eq!(config.max_mach_at(2_800.0), Some(0.95));
    let q = config.dynamic_pressure(0.0, sea_level).unwrap();
    assert!((q - 46_000.0).abs() < 1e-6, "{q}");
}

#[test]
fn non_finite_and_unsupported_values_are_rejected() {
    let toml = with("length = 100.0 ", "length = nan ");
    let err = SystemConfig::from_str(&toml, BUILTIN_AERO_CSV).unwrap_err();
    assert!(
        matches!(&err, ConfigError::Invalid { field, .. } if field == "cable.length"),
        "{err:?}"
    );
    let toml = with("\"ISA-1976\"", "\"US-1962\"");
    let err = SystemConfig::from_str(&toml, BUILTIN_AERO_CSV).unwrap_err();
    assert!(
        matches!(&err, ConfigError::UnsupportedAtmosphere { name, .. } if name == "US-1962"),
        "{err:?}"
    );
    let toml = with("x_tow = 0.12", "x_tow = 1.5");
    let err = SystemConfig::from_str(&toml, BUILTIN_AERO_CSV).unwrap_err();
    assert!(
        matches!(&err, ConfigError::Invalid { field, .. } if field == "decoy.x_tow"),
        "{err:?}"
    );
}

#[test]
fn bad_csv_row_names_its_line() {
    let csv = BUILTIN_AERO_CSV.replacen(
        "4,0.903119,0.513152,-0.185451",
        "4,0.903119,oops,-0.185451",
        1,
    );
    let line = csv.lines().position(|l| l.contains("oops")).unwrap() + 1;
    let err = SystemConfig::from_str(BUILTIN_TOML, &csv).unwrap_err();
    match &err {
        ConfigError::AeroCsv {
            line: Some(l),
            message,
            ..
        } => {
            assert_eq!(*l, line);
            assert!(message.contains("cd: `oops` is not a number"), "{message}");
        }
        other => panic!("wrong error {other:?}"),
    }
    assert!(
        err.to_string()
            .contains(&format!("decoy-aero.csv, line {line}")),
        "{err}"
    );

    let csv = BUILTIN_AERO_CSV.replacen("6,1.420349,0.599285,-0.276836", "6,1.420349,0.599285", 1);
    let err = SystemConfig::from_str(BUILTIN_TOML, &csv).unwrap_err();
    assert!(
        matches!(err, ConfigError::AeroCsv { line: Some(_), .. }),
        "{err:?}"
    );
}

#[test]
fn non_increasing_alpha_names_its_line() {
    let csv = BUILTIN_AERO_CSV.replacen("\n12,", "\n9,", 1);
    let line = csv.lines().position(|l| l.starts_with("9,")).unwrap() + 1;
    let err = SystemConfig::from_str(BUILTIN_TOML, &csv).unwrap_err();
    match &err {
        ConfigError::AeroCsv {
            line: Some(l),
            message,
            ..
        } => {
            assert_eq!(*l, line);
            assert!(
                message.contains("alpha_deg 9 does not increase"),
                "{message}"
            );
        }
        other => panic!("wrong error {other:?}"),
    }
}

#[test]
fn table_not_spanning_0_to_180_and_bad_header_are_rejected() {
    let csv = BUILTIN_AERO_CSV.replacen("\n180,0.000000,0.450000,0.000000", "", 1);
    let err = SystemConfig::from_str(BUILTIN_TOML, &csv).unwrap_err();
    assert!(
        matches!(err, ConfigError::AeroCsv { line: None, .. }),
        "{err:?}"
    );
    let csv = BUILTIN_AERO_CSV.replacen("alpha_deg,cl,cd,cm", "alpha,cl,cd,cm", 1);
    let err = SystemConfig::from_str(BUILTIN_TOML, &csv).unwrap_err();
    assert!(
        matches!(err, ConfigError::AeroCsv { line: Some(_), .. }),
        "{err:?}"
    );
}

#[test]
fn missing_files_are_io_errors_naming_the_path() {
    let err = SystemConfig::from_file("/nonexistent/system.toml").unwrap_err();
    assert!(matches!(err, ConfigError::Io { .. }), "{err:?}");
    assert!(
        err.to_string().contains("/nonexistent/system.toml"),
        "{err}"
    );
}

#[test]
fn mach_to_speed_uses_isa() {
    let config = SystemConfig::builtin().unwrap();
    let a0 = config.speed_of_sound(0.0).unwrap();
    assert!((a0 - 340.294).abs() < 0.01, "{a0}");
    let v = config.mach_to_speed(9000.0, 0.8).unwrap();
    let a9 = Atmosphere::<f64>::isa().at(9000.0).unwrap().speed_of_sound;
    assert_eq!(v, 0.8 * a9);
    assert!((a9 - 303.85).abs() < 0.05, "{a9}");
    assert!(matches!(
        config.mach_to_speed(25_000.0, 0.8),
        Err(ConfigError::Atmosphere(_))
    ));
}

/// The reference system carries its envelope map on board, made for it: the
/// file's cells are the controller's, and the map is in the params the
/// firmware is built from.
#[test]
fn the_reference_system_carries_its_envelope_map() {
    let config = SystemConfig::builtin().unwrap();
    let map = config.limits.expect("the reference system names its map");
    let file = LimitsFile::parse("built-in", BUILTIN_LIMITS_TOML).unwrap();
    assert_eq!(file.config_hash, config_hash(&config));
    for (grid, table) in [
        (&map.pull_up, file.pull_up.as_ref()),
        (&map.turn, file.turn.as_ref()),
        (&map.acceleration, file.acceleration.as_ref()),
    ] {
        let table = table.expect("the three manoeuvres are mapped");
        assert_eq!(grid.altitudes().len(), table.altitudes_m.len());
        assert_eq!(grid.machs().len(), table.machs.len());
        for (i, row) in table.limits.iter().enumerate() {
            for (j, &limit) in row.iter().enumerate() {
                let at = grid.at(f64::from(grid.altitudes()[i]), f64::from(grid.machs()[j]));
                assert_eq!(at.map(|(v, _)| v), Some(f64::from(limit as f32)));
            }
        }
    }
    assert_eq!(config.params().unwrap().limits, map);
    // The file on disk is the built-in one.
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/reference-system.toml");
    assert_eq!(SystemConfig::from_file(&path).unwrap().limits, Some(map));
}

/// The hash is of the values: comments and the embedded model's
/// discretisation do not change it, any other value does; a map of another
/// configuration is not used (the configuration loads without it, and
/// `check_limits`, which the firmware's build calls, names the file and the
/// command that remakes it); an overlay does not inherit its base's map.
#[test]
fn a_map_of_another_configuration_is_refused() {
    let config = SystemConfig::builtin().unwrap();
    let hash = config_hash(&config);
    assert!(hash.starts_with(HASH_PREFIX) && hash.len() == HASH_PREFIX.len() + 64);
    let commented = SystemConfig::from_str(
        &with("mass = 4.0 ", "mass = 4.0    # a comment "),
        BUILTIN_AERO_CSV,
    )
    .unwrap();
    assert_eq!(config_hash(&commented), hash);
    let variant = SystemConfig::from_str(
        &with("segments_embedded = 12", "segments_embedded = 16"),
        BUILTIN_AERO_CSV,
    )
    .unwrap();
    assert_eq!(
        config_hash(&variant),
        hash,
        "a firmware variant carries the map"
    );
    let heavier = with("mass = 4.0 ", "mass = 4.1 ");
    let other = SystemConfig::from_str(&heavier, BUILTIN_AERO_CSV).unwrap();
    assert_ne!(config_hash(&other), hash);

    let scratch = Scratch::new("stale-limits");
    let path = scratch.reference("a");
    std::fs::write(&path, &heavier).unwrap();
    let stale = SystemConfig::from_file(&path).unwrap();
    assert_eq!(stale.limits, None);
    assert_eq!(
        stale.params().unwrap().limits,
        decoy_controller::LimitMap::EMPTY
    );
    let e = stale.check_limits().unwrap_err();
    let text = e.to_string();
    assert!(matches!(e, ConfigError::StaleLimits { .. }), "{text}");
    assert!(
        text.contains("reference-system.limits.toml") && text.contains("decoy limits-table"),
        "{text}"
    );
    assert!(
        text.contains(&hash) && text.contains(&config_hash(&other)),
        "{text}"
    );
    assert!(SystemConfig::builtin().unwrap().check_limits().is_ok());
    let unmapped = SystemConfig::from_file_unmapped(&path).unwrap();
    assert_eq!(unmapped.limits, None);
    assert_eq!(config_hash(&unmapped), config_hash(&other));

    let weak = SystemConfig::weak_stability().unwrap();
    assert_eq!(
        (weak.limits, weak.envelope.limits_map.as_deref()),
        (None, None)
    );
    assert_eq!(
        weak.params().unwrap().limits,
        decoy_controller::LimitMap::EMPTY
    );
}

/// A limits file that is not a map the controller can carry is refused with
/// the file and the field named: a wrong unit, a row too short, an unknown
/// limiting name, a negative or NaN limit, an axis not ascending, an unknown
/// key, a missing file; an overlay may name a map, used only if its own.
#[test]
fn a_malformed_limits_file_is_refused() {
    let good = LimitsFile::parse("built-in", BUILTIN_LIMITS_TOML).unwrap();
    let grids = good.to_grids("f").unwrap();
    assert_eq!(Some(grids), SystemConfig::builtin().unwrap().limits);
    let refuse = |edit: &dyn Fn(&mut LimitsFile), field: &str| {
        let mut file = good.clone();
        edit(&mut file);
        let e = file.to_grids("f.toml").unwrap_err().to_string();
        assert!(e.starts_with("f.toml: ") && e.contains(field), "{e}");
    };
    refuse(
        &|f| f.turn.as_mut().unwrap().unit = "m/s^2".into(),
        "turn.unit",
    );
    refuse(
        &|f| {
            f.pull_up.as_mut().unwrap().limits[2].pop();
        },
        "pull-up.limits",
    );
    refuse(
        &|f| f.acceleration.as_mut().unwrap().limiting[0][0] = "drag".into(),
        "acceleration.limiting",
    );
    refuse(
        &|f| f.pull_up.as_mut().unwrap().limits[0][0] = -0.1,
        "pull-up.limits",
    );
    refuse(
        &|f| f.pull_up.as_mut().unwrap().limits[0][0] = f64::NAN,
        "pull-up.limits",
    );
    refuse(
        &|f| f.turn.as_mut().unwrap().machs.reverse(),
        "turn.altitudes_m or machs",
    );
    // The map's cover: both times or neither, each 0 to 1e6 s.
    refuse(
        &|f| f.pull_up.as_mut().unwrap().aftermath_s = None,
        "pull-up.manoeuvre_s",
    );
    refuse(
        &|f| f.turn.as_mut().unwrap().manoeuvre_s = Some(-1.0),
        "turn.manoeuvre_s",
    );
    refuse(
        &|f| f.pull_up.as_mut().unwrap().aftermath_s = Some(f64::INFINITY),
        "pull-up.aftermath_s",
    );
    assert_eq!(
        (grids.pull_up.manoeuvre_s, grids.pull_up.aftermath_s),
        (5.5, 12.5)
    );
    assert_eq!(
        (
            grids.acceleration.manoeuvre_s,
            grids.acceleration.aftermath_s
        ),
        (0.0, 0.0)
    );
    let e =
        LimitsFile::parse("f.toml", &format!("{BUILTIN_LIMITS_TOML}\nextra = 1\n")).unwrap_err();
    assert!(e.to_string().contains("extra"), "{e}");

    let scratch = Scratch::new("limits-missing");
    scratch.write("a/decoy-aero.csv", BUILTIN_AERO_CSV);
    let toml = scratch.write("a/system.toml", BUILTIN_TOML);
    let e = SystemConfig::from_file(&toml).unwrap_err();
    assert!(matches!(e, ConfigError::Io { .. }), "{e}");
    assert!(
        e.to_string().contains("reference-system.limits.toml"),
        "{e}"
    );
    // An overlay that names a map uses it only if it is its own.
    scratch.reference("b");
    let overlay = scratch.write(
        "b/heavy.toml",
        "base = \"reference.toml\"\n[decoy]\nmass = 4.5\n[envelope]\nlimits_map = \"reference-system.limits.toml\"\n",
    );
    let heavy = SystemConfig::from_file(&overlay).unwrap();
    assert_eq!(
        heavy.limits, None,
        "the reference's map is not the heavier decoy's"
    );
    assert!(heavy.check_limits().is_err());
}
