//! End-to-end tests of the `decoy` binary: output shapes, physics sanity, errors.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use serde_json::Value;

fn decoy(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_decoy"))
        .args(args)
        .output()
        .expect("the decoy binary runs")
}

fn stdout_of(args: &[&str]) -> String {
    let out = decoy(args);
    assert!(
        out.status.success(),
        "decoy {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        out.stderr.is_empty(),
        "unexpected stderr: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).expect("UTF-8 output")
}

fn json(args: &[&str]) -> Value {
    let text = stdout_of(args);
    serde_json::from_str(&text)
        .unwrap_or_else(|e| panic!("decoy {args:?}: invalid JSON ({e}): {text}"))
}

/// Runs a failing command; checks the exit code and the one-line `error:` message, returns it.
fn error_of(args: &[&str], code: i32) -> String {
    let out = decoy(args);
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(
        out.status.code(),
        Some(code),
        "decoy {args:?}: stderr {stderr}"
    );
    assert!(
        out.stdout.is_empty(),
        "decoy {args:?} printed to stdout on error"
    );
    assert!(stderr.starts_with("error: "), "decoy {args:?}: {stderr}");
    assert_eq!(
        stderr.trim_end().lines().count(),
        1,
        "decoy {args:?}: not one line: {stderr}"
    );
    stderr
}

fn keys(v: &Value) -> BTreeSet<&str> {
    v.as_object()
        .expect("a JSON object")
        .keys()
        .map(String::as_str)
        .collect()
}

fn num(v: &Value, key: &str) -> f64 {
    v[key]
        .as_f64()
        .unwrap_or_else(|| panic!("`{key}` is not a number in {v}"))
}

fn tip(sample: &Value) -> [f64; 2] {
    let t = sample["tip"].as_array().expect("tip is an array");
    assert_eq!(t.len(), 2);
    [t[0].as_f64().unwrap(), t[1].as_f64().unwrap()]
}

const TIMES: &str = "0,0.1,0.2,0.3,0.4,0.5";

#[test]
fn pendulum_json_shape_and_energy_conservation() {
    let v = json(&[
        "pendulum",
        "--segments",
        "10",
        "--t-end",
        "0.5",
        "--dt",
        "1e-4",
        "--times",
        TIMES,
        "--json",
    ]);
    assert_eq!(keys(&v), BTreeSet::from(["segments", "dt", "samples"]));
    assert_eq!(v["segments"], 10);
    assert_eq!(num(&v, "dt"), 1e-4);
    let samples = v["samples"].as_array().unwrap();
    assert_eq!(samples.len(), 6);
    for (s, t) in samples.iter().zip([0.0, 0.1, 0.2, 0.3, 0.4, 0.5]) {
        assert_eq!(
            keys(s),
            BTreeSet::from(["t", "tip", "support_tension_N", "energy_J"])
        );
        assert_eq!(num(s, "t"), t);
        let [x, z] = tip(s);
        assert!(
            x.hypot(z) <= 1.0 + 1e-12,
            "tip outside the chain's reach: {s}"
        );
        assert!(num(s, "support_tension_N") > 0.0);
    }
    // Released at rest with every rod 60 deg toward -x: tip at (-sin 60, -cos 60) x 1 m, z up.
    let [x0, z0] = tip(&samples[0]);
    assert!(
        (x0 + 3f64.sqrt() / 2.0).abs() < 1e-12 && (z0 + 0.5).abs() < 1e-12,
        "initial tip {x0} {z0}"
    );
    // Energy at rest: sum of m g h_c = 0.5 * 9.81 * (-0.05) * sum(i - 1/2) = -12.2625 J.
    let e0 = num(&samples[0], "energy_J");
    assert!((e0 + 12.2625).abs() < 1e-9, "{e0}");
    for s in samples {
        let e = num(s, "energy_J");
        assert!(
            (e - e0).abs() <= 1e-6 * e0.abs(),
            "energy drift at t = {}: {e} vs {e0}",
            s["t"]
        );
    }
    // The chain has moved: the tip swung through the bottom.
    assert!(tip(&samples[5])[0] > 0.0);
}

#[test]
fn dense_reference_agrees_with_the_recurrence() {
    let run = |solver: &str| {
        json(&[
            "pendulum",
            "--segments",
            "5",
            "--t-end",
            "0.5",
            "--dt",
            "1e-4",
            "--times",
            TIMES,
            "--solver",
            solver,
            "--json",
        ])
    };
    let (recurrence, dense) = (run("recurrence"), run("dense"));
    let (a, b) = (
        recurrence["samples"].as_array().unwrap(),
        dense["samples"].as_array().unwrap(),
    );
    assert_eq!(a.len(), b.len());
    for (p, q) in a.iter().zip(b) {
        let (tp, tq) = (tip(p), tip(q));
        for k in 0..2 {
            assert!(
                (tp[k] - tq[k]).abs() < 1e-8,
                "tip at t = {}: {tp:?} vs {tq:?}",
                p["t"]
            );
        }
        let (fp, fq) = (num(p, "support_tension_N"), num(q, "support_tension_N"));
        assert!(
            (fp - fq).abs() < 1e-6 * fp,
            "support tension at t = {}: {fp} vs {fq}",
            p["t"]
        );
        let (ep, eq) = (num(p, "energy_J"), num(q, "energy_J"));
        assert!(
            (ep - eq).abs() < 1e-8,
            "energy at t = {}: {ep} vs {eq}",
            p["t"]
        );
    }
}

#[test]
fn pendulum_human_output_is_a_table_in_request_order() {
    let text = stdout_of(&[
        "pendulum",
        "--segments",
        "3",
        "--t-end",
        "0.1",
        "--dt",
        "1e-3",
        "--times",
        "0.1,0",
    ]);
    assert!(
        text.contains("support tension [N]") && text.contains("energy [J]"),
        "{text}"
    );
    let rows: Vec<&str> = text
        .lines()
        .filter(|l| l.trim_start().starts_with(['0', '1']))
        .collect();
    assert_eq!(rows.len(), 2, "{text}");
    assert!(
        rows[0].trim_start().starts_with("0.1") && rows[1].trim_start().starts_with("0 "),
        "{text}"
    );
}

fn trim_json(extra: &[&str]) -> Value {
    let mut args = vec!["trim", "--altitude", "9000", "--mach", "0.8", "--json"];
    args.extend_from_slice(extra);
    json(&args)
}

#[test]
fn trim_json_is_plausible() {
    let v = trim_json(&[]);
    assert_eq!(
        keys(&v),
        BTreeSet::from([
            "decoy_pitch_deg",
            "tension_connection_N",
            "tension_tow_N",
            "decoy_cg_behind_m",
            "decoy_cg_below_m",
            "decoy_cg_behind_connection_m",
            "decoy_cg_below_connection_m",
            "tension_profile_N",
        ])
    );
    let connection = num(&v, "tension_connection_N");
    let tow = num(&v, "tension_tow_N");
    assert!(
        tow > 0.0 && connection > tow,
        "connection {connection}, tow {tow}"
    );
    // The reference system is built for about 270 N at 9 km, Mach 0.8.
    assert!((200.0..350.0).contains(&connection), "{connection}");
    let pitch = num(&v, "decoy_pitch_deg");
    assert!(pitch.abs() < 20.0, "{pitch}");
    let behind = num(&v, "decoy_cg_behind_connection_m");
    assert!(behind > 90.0 && behind < 101.0, "{behind}");
    let below = num(&v, "decoy_cg_below_connection_m");
    assert!(below > 0.0 && below < 50.0, "{below}");
    let profile: Vec<f64> = v["tension_profile_N"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t.as_f64().unwrap())
        .collect();
    assert_eq!(profile.len(), 301);
    assert_eq!(profile[0], connection);
    assert_eq!(profile[300], tow);
    assert!(
        profile.windows(2).all(|w| w[0] > w[1]),
        "tension must fall from the aircraft to the decoy"
    );
}

#[test]
fn graded_16_segments_reproduce_300_uniform() {
    let fine = trim_json(&[]);
    let graded = trim_json(&["--segments", "16", "--grading", "1.3"]);
    assert_eq!(graded["tension_profile_N"].as_array().unwrap().len(), 17);
    for (key, tolerance) in [
        ("tension_connection_N", 0.005),
        ("tension_tow_N", 0.005),
        ("decoy_cg_below_m", 0.01),
    ] {
        let (a, b) = (num(&fine, key), num(&graded, key));
        assert!(
            (a - b).abs() < tolerance * a.abs(),
            "{key}: 300 uniform {a}, 16 graded {b}"
        );
    }
    // --grading 1 is the uniform layout.
    let uniform = trim_json(&["--segments", "16"]);
    assert_eq!(uniform, trim_json(&["--segments", "16", "--grading", "1"]));
}

#[test]
fn trim_human_output_has_units() {
    let text = stdout_of(&[
        "trim",
        "--altitude",
        "9000",
        "--mach",
        "0.8",
        "--segments",
        "16",
        "--grading",
        "1.3",
    ]);
    for needle in [
        "pitch",
        "deg",
        "CG behind",
        "CG below",
        "connection point",
        "towing point",
        " N ",
        "allowable",
        "joint",
    ] {
        assert!(text.contains(needle), "missing `{needle}` in:\n{text}");
    }
}

/// A copy of the reference system in a fresh directory, with `edit` applied to the TOML.
fn config_copy(name: &str, edit: impl Fn(&str) -> String) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("decoy-cli-test-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let source = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config");
    let toml = std::fs::read_to_string(source.join("reference-system.toml")).unwrap();
    std::fs::write(dir.join("system.toml"), edit(&toml)).unwrap();
    std::fs::copy(source.join("decoy-aero.csv"), dir.join("decoy-aero.csv")).unwrap();
    let limits = "reference-system.limits.toml";
    std::fs::copy(source.join(limits), dir.join(limits)).unwrap();
    dir
}

#[test]
fn config_file_is_used_and_checked() {
    let dir = config_copy("short", |t| {
        t.replacen("length = 100.0 ", "length = 80.0 ", 1)
    });
    let path = dir.join("system.toml");
    let v = json(&[
        "--config",
        path.to_str().unwrap(),
        "trim",
        "--altitude",
        "9000",
        "--mach",
        "0.8",
        "--segments",
        "40",
        "--json",
    ]);
    let behind = num(&v, "decoy_cg_behind_connection_m");
    assert!(behind > 70.0 && behind < 81.0, "{behind}");

    let bad = config_copy("bad", |t| t.replacen("mass = 4.0 ", "mass = -4.0 ", 1));
    let bad_path = bad.join("system.toml");
    let message = error_of(
        &[
            "trim",
            "--altitude",
            "9000",
            "--mach",
            "0.8",
            "--config",
            bad_path.to_str().unwrap(),
        ],
        2,
    );
    assert!(
        message.contains("decoy.mass") && message.contains("system.toml"),
        "{message}"
    );
    let _ = std::fs::remove_dir_all(dir);
    let _ = std::fs::remove_dir_all(bad);
}

#[test]
fn bad_input_is_a_one_line_error() {
    let message = error_of(&["trim", "--altitude", "9000", "--mach", "nan"], 2);
    assert!(message.contains("--mach"), "{message}");
    let message = error_of(
        &[
            "trim",
            "--altitude",
            "9000",
            "--mach",
            "0.8",
            "--segments",
            "100000",
        ],
        2,
    );
    assert!(message.contains("100000"), "{message}");
    let message = error_of(
        &[
            "pendulum",
            "--segments",
            "100000",
            "--t-end",
            "1",
            "--dt",
            "1e-3",
            "--times",
            "0",
        ],
        2,
    );
    assert!(message.contains("100000"), "{message}");
    let message = error_of(
        &[
            "--config",
            "/nonexistent/decoy.toml",
            "trim",
            "--altitude",
            "9000",
            "--mach",
            "0.8",
        ],
        2,
    );
    assert!(message.contains("/nonexistent/decoy.toml"), "{message}");
    let message = error_of(&["trim", "--altitude", "30000", "--mach", "0.8"], 2);
    assert!(message.contains("--altitude"), "{message}");
    let message = error_of(
        &[
            "trim",
            "--altitude",
            "9000",
            "--mach",
            "0.8",
            "--grading",
            "0.5",
        ],
        2,
    );
    assert!(message.contains("--grading"), "{message}");
    let message = error_of(
        &[
            "pendulum",
            "--segments",
            "3",
            "--t-end",
            "1",
            "--dt",
            "0.1",
            "--times",
            "0.15",
        ],
        2,
    );
    assert!(message.contains("0.15"), "{message}");
    error_of(
        &[
            "pendulum",
            "--segments",
            "3",
            "--t-end",
            "1",
            "--dt",
            "0.1",
            "--times",
            "1.1",
        ],
        2,
    );
    error_of(
        &[
            "pendulum",
            "--segments",
            "3",
            "--t-end",
            "1",
            "--dt",
            "0.1",
            "--times",
            "-0.1",
        ],
        2,
    );
    // Usage errors from the argument parser are one line too.
    let message = error_of(&["trim", "--altitude", "9000"], 2);
    assert!(message.contains("--mach"), "{message}");
    error_of(
        &["trim", "--altitude", "9000", "--mach", "0.8", "--bogus"],
        2,
    );
}

#[test]
fn solver_failures_exit_with_1() {
    // Far too slow to hold the decoy up: no trim.
    let message = error_of(&["trim", "--altitude", "9000", "--mach", "0.01"], 1);
    assert!(message.contains("trim"), "{message}");
    // A time step far above the stable one breaks the integration.
    let message = error_of(
        &[
            "pendulum",
            "--segments",
            "3",
            "--t-end",
            "1",
            "--dt",
            "0.1",
            "--times",
            "1",
        ],
        1,
    );
    assert!(message.contains("integration failed"), "{message}");
}

/// A fresh output directory for one `simulate` test.
fn sim_out(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("decoy-cli-simulate")
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

#[test]
fn simulate_json_is_the_summary_and_the_files_are_written() {
    let out = sim_out("steady-json");
    let out_arg = out.to_str().unwrap();
    let v = json(&[
        "simulate",
        "--scenario",
        "steady",
        "--segments",
        "16",
        "--grading",
        "1.3",
        "--t-end",
        "2",
        "--json",
        "--out",
        out_arg,
    ]);
    let expected: BTreeSet<&str> = [
        "scenario",
        "segments",
        "dt",
        "t_end",
        "steps",
        "max_tension_connection_N",
        "t_at_max_tension_s",
        "pitch_oscillation_amplitude_deg",
        "settling_time_s",
        "final",
        "min_cable_clearance_to_exhaust_m",
        "min_decoy_clearance_to_aircraft_m",
        "management",
        "wall_s",
    ]
    .into_iter()
    .collect();
    assert_eq!(keys(&v), expected);
    // One entry per requirement of the paper, each with the four keys of
    // docs/outputs.md; steady flight violates and advises nothing.
    for r in decoy_schema::Requirement::ALL.map(|r| r.name()) {
        let m = &v["management"][r];
        let entry: BTreeSet<&str> = m.as_object().unwrap().keys().map(|k| k.as_str()).collect();
        assert_eq!(
            entry,
            [
                "worst_margin",
                "first_violation_s",
                "first_advisory_s",
                "advisory_lead_s"
            ]
            .into_iter()
            .collect(),
            "{r}"
        );
        assert!(m["worst_margin"].as_f64().unwrap() > 0.0, "{r}: {m}");
        assert!(
            m["first_violation_s"].is_null() && m["first_advisory_s"].is_null(),
            "{r}: {m}"
        );
    }
    assert_eq!(v["scenario"], "steady");
    assert_eq!(v["segments"], 16);
    assert_eq!(num(&v, "t_end"), 2.0);
    // No --dt: the adaptive rule chose the steps.
    assert!(v["dt"].is_null(), "{v}");
    assert_eq!(v["steps"]["rule"], "adaptive");
    assert!(
        num(&v["steps"], "count") >= 200.0,
        "at least a step per 10 ms row: {v}"
    );
    // Steady flight from trim stays at trim (about 271 N at Mach 0.8, 9 km).
    let tension = num(&v["final"], "tension_connection_N");
    assert!((tension - 271.0).abs() < 5.0, "{tension}");
    assert!((num(&v, "max_tension_connection_N") - tension).abs() < 1e-3 * tension);
    // stdout is summary.json.
    let file: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(file, v);
    for name in [
        "timeseries.csv",
        "cable.csv",
        "tensions.png",
        "tensions.svg",
        "attitude.png",
        "cable-side.svg",
        "cable-top.png",
        "tension-profile.svg",
    ] {
        assert!(out.join(name).is_file(), "{name} missing");
    }
    let rows = std::fs::read_to_string(out.join("timeseries.csv"))
        .unwrap()
        .lines()
        .count();
    assert_eq!(rows, 1 + 201, "header and a row every 10 ms");
}

#[test]
fn simulate_human_output_lists_the_files() {
    let out = sim_out("turn-text");
    let text = stdout_of(&[
        "simulate",
        "--scenario",
        "turn",
        "--segments",
        "16",
        "--grading",
        "1.3",
        "--t-end",
        "1",
        "--no-plots",
        "--out",
        out.to_str().unwrap(),
    ]);
    for expected in [
        "Simulation `turn`",
        "16 segments graded 1.3",
        "Connection-point tension",
        "N at t = ",
        "cable to the exhaust plume",
        "Files written to",
        "timeseries.csv",
        "summary.json",
    ] {
        assert!(text.contains(expected), "`{expected}` missing in:\n{text}");
    }
    assert!(!text.contains("tensions.png"), "--no-plots drew plots");
}

#[test]
fn simulate_text_shows_the_condition_flown() {
    let out = sim_out("steady-overridden");
    let args = |extra: &[&str]| {
        let mut v = vec![
            "simulate",
            "--scenario",
            "steady",
            "--segments",
            "16",
            "--grading",
            "1.3",
            "--no-plots",
            "--out",
            out.to_str().unwrap(),
        ];
        v.extend_from_slice(extra);
        v.into_iter().map(str::to_owned).collect::<Vec<_>>()
    };
    let run = |extra: &[&str]| {
        let owned = args(extra);
        let refs: Vec<&str> = owned.iter().map(String::as_str).collect();
        stdout_of(&refs)
    };
    let text = run(&["--mach", "0.6", "--altitude", "5000", "--t-end", "0.2"]);
    assert!(
        !text.contains("Mach 0.8, 9 km"),
        "the scenario's condition:\n{text}"
    );
    assert!(
        text.contains("initial flight condition: Mach 0.600 at 5000 m"),
        "{text}"
    );
    // Without overrides the description stays, beside the same condition.
    let text = run(&["--dt", "0.005"]);
    assert!(text.contains("Mach 0.8, 9 km"), "{text}");
    assert!(
        text.contains("initial flight condition: Mach 0.800 at 9000 m"),
        "{text}"
    );
}

/// One output contract: a key means the same quantity in `decoy trim` and in
/// `decoy simulate`'s summary (a steady run from trim ends at the trim).
#[test]
fn trim_and_simulate_keys_mean_the_same() {
    let layout = ["--segments", "16", "--grading", "1.3"];
    let mut trim_args = vec!["trim", "--altitude", "9000", "--mach", "0.8", "--json"];
    trim_args.extend_from_slice(&layout);
    let trim = json(&trim_args);
    let out = sim_out("contract");
    let mut sim_args = vec![
        "simulate",
        "--scenario",
        "steady",
        "--t-end",
        "0.01",
        "--no-plots",
        "--json",
        "--out",
        out.to_str().unwrap(),
    ];
    sim_args.extend_from_slice(&layout);
    let summary = json(&sim_args);
    let last = summary["final"].as_object().unwrap();
    let mut shared = 0;
    for (key, value) in trim.as_object().unwrap() {
        if let (Some(a), Some(b)) = (value.as_f64(), last.get(key).and_then(Value::as_f64)) {
            assert!(
                (a - b).abs() < 1e-3 * (1.0 + b.abs()),
                "{key}: trim {a}, simulate {b}"
            );
            shared += 1;
        }
    }
    assert!(
        shared >= 4,
        "trim and simulate share the CG and tension keys"
    );
    // The connection point (config/reference-system.toml) is 2 m behind and 1.7 m
    // below the reference point.
    let behind = num(&trim, "decoy_cg_behind_m") - num(&trim, "decoy_cg_behind_connection_m");
    let below = num(&trim, "decoy_cg_below_m") - num(&trim, "decoy_cg_below_connection_m");
    assert!(
        (behind - 2.0).abs() < 1e-9 && (below - 1.7).abs() < 1e-9,
        "{behind}, {below}"
    );
}

#[test]
fn simulate_errors_are_one_line() {
    let message = error_of(&["simulate", "--scenario", "barrel-roll"], 2);
    assert!(
        message.contains("unknown scenario `barrel-roll`") && message.contains("pull-up"),
        "{message}"
    );
    let message = error_of(
        &[
            "simulate",
            "--scenario",
            "steady",
            "--mach",
            "2.5",
            "--json",
        ],
        2,
    );
    assert!(message.contains("--mach"), "{message}");
    let message = error_of(&["simulate", "--scenario", "steady", "--rate", "0.1"], 2);
    assert!(message.contains("--rate does not apply"), "{message}");
    let message = error_of(&["simulate", "--scenario", "/nonexistent.toml"], 2);
    assert!(message.contains("/nonexistent.toml"), "{message}");
    // A diverging run: exit 1, the outputs so far stay, summary.json says where it stopped.
    let out = sim_out("diverged");
    let message = error_of(
        &[
            "simulate",
            "--scenario",
            "steady",
            "--segments",
            "16",
            "--grading",
            "1.3",
            "--dt",
            "0.5",
            "--t-end",
            "10",
            "--no-plots",
            "--json",
            "--out",
            out.to_str().unwrap(),
        ],
        1,
    );
    assert!(message.contains("simulation stopped at t = "), "{message}");
    let summary: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert!(summary["stopped"]["reason"].is_string(), "{summary}");
}

/// Runs `decoy` in `dir` (so that default output directories land there).
fn decoy_in(dir: &Path, args: &[&str]) -> Output {
    std::fs::create_dir_all(dir).unwrap();
    Command::new(env!("CARGO_BIN_EXE_decoy"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("the decoy binary runs")
}

#[test]
fn sweep_speed_json_is_the_table_and_writes_the_files() {
    let dir = sim_out("sweep-speed");
    let out = decoy_in(
        &dir,
        &[
            "sweep", "speed", "--from", "0.6", "--to", "0.8", "--step", "0.1", "--json",
        ],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.stderr.is_empty());
    let v: Value = serde_json::from_slice(&out.stdout).expect("JSON");
    assert_eq!(v["variable"], "speed");
    assert_eq!(num(&v, "fixed_altitude_m"), 9000.0);
    assert!(v["fixed_mach"].is_null());
    assert_eq!(v["layout"], "300 uniform segments");
    let points = v["points"].as_array().unwrap();
    let mach: Vec<f64> = points.iter().map(|p| num(p, "mach")).collect();
    assert_eq!(mach, vec![0.6, 0.7, 0.8]);
    let tension: Vec<f64> = points
        .iter()
        .map(|p| num(p, "tension_connection_N"))
        .collect();
    let pitch: Vec<f64> = points.iter().map(|p| num(p, "decoy_pitch_deg")).collect();
    assert!(
        tension[0] < tension[1] && tension[1] < tension[2],
        "{tension:?}"
    );
    assert!(pitch[0] > pitch[1] && pitch[1] > pitch[2], "{pitch:?}");
    let expected: BTreeSet<&str> = [
        "mach",
        "altitude_m",
        "speed_mps",
        "tension_connection_N",
        "tension_tow_N",
        "tension_max_N",
        "decoy_pitch_deg",
        "decoy_aoa_deg",
        "decoy_cg_behind_m",
        "decoy_cg_below_m",
        "cable_plume_clearance_m",
    ]
    .into_iter()
    .collect();
    assert_eq!(keys(&points[0]), expected);
    // The default output directory: out/sweep-speed under the working directory.
    let files = dir.join("out").join("sweep-speed");
    let table = std::fs::read_to_string(files.join("sweep.csv")).unwrap();
    assert_eq!(table.lines().count(), 4);
    for name in [
        "cable.csv",
        "cable-shapes.png",
        "tension-profiles.svg",
        "decoy.png",
        "tensions.svg",
    ] {
        assert!(files.join(name).is_file(), "{name}");
    }
    // Without --json: a table and the files.
    let text = stdout_of(&[
        "sweep",
        "altitude",
        "--from",
        "6000",
        "--to",
        "8000",
        "--step",
        "1000",
        "--no-plots",
        "--out",
        dir.join("alt").to_str().unwrap(),
    ]);
    assert!(text.contains("altitude sweep at Mach 0.7"), "{text}");
    assert!(
        text.contains("sweep.csv") && !text.contains(".png"),
        "{text}"
    );
}

#[test]
fn sweep_errors_are_usage_errors() {
    let out = sim_out("sweep-errors");
    let out = out.to_str().unwrap();
    for (args, expected) in [
        (
            vec!["sweep", "speed", "--step", "0"],
            "--step must be positive",
        ),
        (
            vec!["sweep", "speed", "--step", "-0.1"],
            "--step must be positive",
        ),
        (
            vec!["sweep", "speed", "--from", "0.9", "--to", "0.5"],
            "--from 0.9 is above --to 0.5",
        ),
        (vec!["sweep", "speed", "--to", "3"], "--to must be above 0"),
        (
            vec!["sweep", "altitude", "--from", "-100"],
            "--from must be between 0 and 20000",
        ),
        (
            vec!["sweep", "speed", "--mach", "0.7"],
            "--mach does not apply",
        ),
        (
            vec!["sweep", "altitude", "--dt", "0.001"],
            "--dt does not apply",
        ),
        (
            vec!["sweep", "tow-point", "--to", "1.5"],
            "decoy.x_tow must be on the decoy body",
        ),
        (
            vec!["sweep", "cg", "--threshold", "0"],
            "--threshold must be a positive",
        ),
        (
            vec!["sweep", "cg", "--window", "20"],
            "--window must be positive and shorter",
        ),
        (
            vec!["sweep", "speed", "--segments", "0"],
            "--segments must be between",
        ),
        (
            vec!["sweep", "speed", "--tolerance", "0.01"],
            "--tolerance does not apply",
        ),
        (
            vec!["sweep", "tow-point", "--margin", "1"],
            "--margin does not apply",
        ),
        (
            vec!["sweep", "static-margin", "--margin", "1"],
            "--margin does not apply",
        ),
        (
            vec!["sweep", "pull-up-rate", "--threshold", "0.1"],
            "--threshold does not apply",
        ),
        (
            vec!["sweep", "pull-up-rate", "--to", "2"],
            "a pull-up rate must be above 0 and at most 1",
        ),
        (
            vec!["sweep", "pull-up-rate", "--tolerance", "0"],
            "--tolerance must be a positive rate",
        ),
        (
            vec!["sweep", "static-margin", "--from", "1.5", "--to", "1.5"],
            "off the body",
        ),
        (vec!["sweep", "sideways"], "invalid value 'sideways'"),
        (vec!["study", "everything"], "invalid value 'everything'"),
    ] {
        let mut args = args.clone();
        args.extend(["--out", out]);
        let message = error_of(&args, 2);
        assert!(message.contains(expected), "{args:?}: {message}");
    }
}

#[test]
fn hil_bad_input_is_a_usage_error() {
    let e = error_of(&["hil", "--scenario", "no-such-scenario"], 2);
    assert!(e.contains("acceleration"), "{e}");
    let e = error_of(
        &["hil", "--scenario", "acceleration", "--segments", "65"],
        2,
    );
    assert!(e.contains("--segments"), "{e}");
    let e = error_of(&["hil", "--scenario", "acceleration", "--segments", "0"], 2);
    assert!(e.contains("segments"), "{e}");
    let e = error_of(&["hil", "--scenario", "acceleration", "--board", "m9"], 2);
    assert!(e.contains("m9"), "{e}");
    let e = error_of(&["hil", "--scenario", "steady", "--rate", "0.1"], 2);
    assert!(e.contains("--rate"), "{e}");
    let e = error_of(&["hil", "--scenario", "acceleration", "--t-end", "-1"], 2);
    assert!(e.contains("--t-end"), "{e}");
    let config = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../config/reference-system.toml"
    );
    let e = error_of(&["--config", config, "hil", "--scenario", "turn"], 2);
    assert!(e.contains("--config"), "{e}");
}

/// `decoy hil` end to end: the firmware under QEMU flies 1 s of the acceleration
/// case; the summary has the keys of `decoy simulate` and of the run in the loop,
/// the firmware agrees with the host reference bit for bit, and the files exist.
#[test]
fn hil_flies_the_firmware_and_writes_the_outputs() {
    let dir = std::env::temp_dir().join(format!("decoy-cli-hil-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let out = dir.to_str().unwrap();
    let summary = json(&[
        "hil",
        "--scenario",
        "acceleration",
        "--t-end",
        "1",
        "--out",
        out,
        "--json",
    ]);
    for key in [
        "scenario",
        "segments",
        "max_tension_connection_N",
        "final",
        "instructions_per_step_max",
        "instructions_per_step_mean",
        "frames_sent",
        "frames_answered",
        "max_tension_diff_vs_host_N",
        "ram_bytes",
        "flash_bytes",
    ] {
        assert!(summary.get(key).is_some(), "no `{key}` in {summary}");
    }
    assert_eq!(summary["board"], "m4");
    assert_eq!(num(&summary, "segments"), 12.0);
    // Like with like: the State frames sent and the Outputs answering them.
    assert_eq!(num(&summary, "frames_sent"), 101.0);
    assert_eq!(num(&summary, "frames_answered"), 101.0);
    assert!(
        summary["firmware_source"]
            .as_str()
            .is_some_and(|s| s.starts_with("built from ")),
        "{summary}"
    );
    assert_eq!(
        num(&summary, "max_tension_diff_vs_host_same_precision_N"),
        0.0
    );
    assert!(
        num(&summary, "max_tension_diff_vs_host_N") < 1.0,
        "{summary}"
    );
    assert!(num(&summary, "instructions_per_step_max") > 10_000.0);
    assert!(num(&summary, "ram_bytes") > 0.0 && num(&summary, "flash_bytes") > 0.0);
    // The RAM peak (static RAM and the larger stack peak) within the M4's 64 KiB.
    let peak = num(&summary, "ram_peak_bytes");
    assert_eq!(
        peak,
        num(&summary, "ram_bytes")
            + num(&summary, "stack_boot_bytes").max(num(&summary, "stack_link_bytes"))
    );
    assert!(peak <= num(&summary, "ram_budget_bytes"), "{summary}");
    assert_eq!(num(&summary, "ram_budget_bytes"), 65536.0);
    let csv = std::fs::read_to_string(dir.join("timeseries.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 101);
    assert!(csv.starts_with("t_s,seq,tension_connection_N,"), "{csv}");
    for file in [
        "summary.json",
        "firmware.log",
        "tensions.png",
        "attitude.svg",
    ] {
        assert!(dir.join(file).is_file(), "{file} missing");
    }
    // The same ELF given with --firmware (as an installed `decoy` would): the
    // same answers, and the summary says where the firmware came from.
    let elf = summary["elf"].as_str().unwrap().to_owned();
    // Issue 27, item 5: written into a directory of an earlier `decoy simulate`
    // (and of the run above), the directory holds this run's files only.
    for stale in ["cable.csv", "cable-side.svg", "tension-profile.png"] {
        std::fs::write(dir.join(stale), "an earlier run's\n").unwrap();
    }
    let given = json(&[
        "hil",
        "--scenario",
        "acceleration",
        "--t-end",
        "0.2",
        "--firmware",
        &elf,
        "--no-plots",
        "--out",
        out,
        "--json",
    ]);
    assert_eq!(given["firmware_source"], "given with --firmware");
    assert_eq!(
        file_names(&dir),
        ["firmware.log", "summary.json", "timeseries.csv"],
        "only the --no-plots run's files"
    );
    // The same ELF on the wrong board: its Hello names its own.
    let wrong = decoy(&[
        "hil",
        "--scenario",
        "steady",
        "--t-end",
        "0.1",
        "--board",
        "m7",
        "--firmware",
        &elf,
        "--no-plots",
        "--out",
        out,
    ]);
    assert_eq!(wrong.status.code(), Some(2), "{wrong:?}");
    let stderr = String::from_utf8_lossy(&wrong.stderr);
    assert!(
        stderr.contains("built for the board mps2-an386"),
        "{stderr}"
    );
    // A run that fails before it starts leaves no earlier summary behind.
    assert!(file_names(&dir).is_empty(), "{:?}", file_names(&dir));
    assert_eq!(given["elf"], elf.as_str());
    assert_eq!(
        num(&given, "max_tension_diff_vs_host_same_precision_N"),
        0.0
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// `decoy hil --board stm32f405`: the STM32F405 firmware (netduinoplus2) flies
/// 0.5 s of the acceleration case, names its board, and agrees with the host f32
/// reference bit for bit.
#[test]
fn hil_flies_the_stm32f405() {
    let dir = std::env::temp_dir().join(format!("decoy-cli-hil-stm32-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let summary = json(&[
        "hil",
        "--board",
        "stm32f405",
        "--scenario",
        "acceleration",
        "--t-end",
        "0.5",
        "--no-plots",
        "--out",
        dir.to_str().unwrap(),
        "--json",
    ]);
    assert_eq!(summary["board"], "stm32f405");
    assert_eq!(num(&summary, "precision_bits"), 32.0);
    assert_eq!(num(&summary, "frames_sent"), 51.0);
    assert_eq!(num(&summary, "frames_answered"), 51.0);
    assert_eq!(
        num(&summary, "max_tension_diff_vs_host_same_precision_N"),
        0.0
    );
    assert_eq!(
        num(&summary, "frames_identical_to_host_same_precision"),
        51.0
    );
    assert!(
        summary["elf"]
            .as_str()
            .is_some_and(|elf| elf.contains("/target/stm32f405/")),
        "{summary}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn hil_rejects_a_firmware_that_is_not_an_elf() {
    let out = decoy(&[
        "hil",
        "--scenario",
        "steady",
        "--firmware",
        "Cargo.toml",
        "--no-plots",
    ]);
    assert_eq!(out.status.code(), Some(2), "{out:?}");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("not a readable ELF"), "{stderr}");
}

/// The names of the files in `dir`, sorted.
fn file_names(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// Every row of the CSV file `path` has the header's number of fields, each a
/// number (or empty); returns the rows (header left out).
fn full_rows(path: &Path) -> Vec<Vec<String>> {
    let text = std::fs::read_to_string(path).unwrap();
    assert!(text.ends_with('\n'), "{}: cut mid-row", path.display());
    let mut lines = text.lines();
    let columns = lines.next().unwrap().split(',').count();
    lines
        .enumerate()
        .map(|(i, line)| {
            let fields: Vec<String> = line.split(',').map(str::to_owned).collect();
            assert_eq!(
                fields.len(),
                columns,
                "{} row {}: {line}",
                path.display(),
                i + 1
            );
            for f in &fields {
                assert!(
                    f.is_empty() || f.parse::<f64>().is_ok(),
                    "{} row {}: `{f}`",
                    path.display(),
                    i + 1
                );
            }
            fields
        })
        .collect()
}

/// Issue 27, item 6: SIGINT or SIGTERM stops `decoy simulate` at a step boundary
/// with 130 or 143; the summary says it stopped and why, the CSV files hold whole
/// rows up to that step, the plots are complete, and no `.partial` file is left.
#[test]
fn simulate_stops_cleanly_on_sigint_and_sigterm() {
    for (signal, code) in [("INT", 130), ("TERM", 143)] {
        let out = sim_out(&format!("signal-{signal}"));
        let mut child = Command::new(env!("CARGO_BIN_EXE_decoy"))
            .args(["simulate", "--scenario", "turn", "--t-end", "600", "--out"])
            .arg(&out)
            .arg("--json")
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        // Well into the integration: the time series being written (under its
        // partial name).
        let written = || {
            ["timeseries.csv.partial", "timeseries.csv"]
                .iter()
                .map(|name| std::fs::metadata(out.join(name)).map_or(0, |m| m.len()))
                .max()
                .unwrap_or(0)
        };
        let deadline = std::time::Instant::now() + std::time::Duration::from_secs(120);
        while written() < 100_000 {
            assert!(
                std::time::Instant::now() < deadline,
                "SIG{signal}: the run did not start"
            );
            std::thread::sleep(std::time::Duration::from_millis(50));
        }
        let sent = Command::new("kill")
            .args([&format!("-{signal}"), &child.id().to_string()])
            .status()
            .unwrap();
        assert!(sent.success());
        let status = child.wait().unwrap();
        let mut stderr = String::new();
        std::io::Read::read_to_string(&mut child.stderr.take().unwrap(), &mut stderr).unwrap();
        assert_eq!(status.code(), Some(code), "SIG{signal}: {stderr}");
        assert!(
            stderr.starts_with(&format!("error: interrupted by SIG{signal} at t = ")),
            "{stderr}"
        );
        assert_eq!(stderr.lines().count(), 1, "{stderr}");

        let summary: Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap())
                .unwrap();
        let stopped = &summary["stopped"];
        assert_eq!(stopped["reason"], format!("interrupted by SIG{signal}"));
        let t_s = num(stopped, "t_s");
        assert!(t_s > 0.0 && t_s < 600.0, "{summary}");
        assert!(num(&summary["final"], "tension_connection_N").is_finite());
        let rows = full_rows(&out.join("timeseries.csv"));
        let last: f64 = rows.last().unwrap()[0].parse().unwrap();
        assert_eq!(last, t_s, "the last row is the stopping state");
        let cable = full_rows(&out.join("cable.csv"));
        let cable_last: f64 = cable.last().unwrap()[0].parse().unwrap();
        assert_eq!(cable_last, t_s, "the last snapshot is the stopping state");
        let names = file_names(&out);
        assert!(
            names.iter().all(|n| !n.ends_with(".partial")),
            "SIG{signal}: {names:?}"
        );
        for plot in ["tensions", "attitude", "cable-side", "management"] {
            let svg = std::fs::read_to_string(out.join(format!("{plot}.svg"))).unwrap();
            assert!(svg.trim_end().ends_with("</svg>"), "{plot}.svg is cut");
            assert!(out.join(format!("{plot}.png")).is_file(), "{plot}.png");
        }
        let _ = std::fs::remove_dir_all(&out);
    }
}

/// Issue 27, item 5: a run's directory holds only its own files; partial files
/// of a killed run are removed too, other files stay.
#[test]
fn simulate_removes_an_earlier_runs_partial_files() {
    let out = sim_out("partial-leftovers");
    std::fs::create_dir_all(&out).unwrap();
    for name in [
        "timeseries.csv.partial",
        "tensions.svg.partial",
        "firmware.log",
        "instructions.svg",
        "notes.txt",
    ] {
        std::fs::write(out.join(name), "left by an earlier run\n").unwrap();
    }
    stdout_of(&[
        "simulate",
        "--scenario",
        "steady",
        "--segments",
        "8",
        "--t-end",
        "0.2",
        "--no-plots",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(
        file_names(&out),
        ["cable.csv", "notes.txt", "summary.json", "timeseries.csv"]
    );
    let _ = std::fs::remove_dir_all(&out);
}

/// Issue 27, item 7: numbers that do not fit a duration or a frame count are
/// usage errors (exit 2) naming the flag, never a panic or a saturated count.
#[test]
fn huge_numbers_are_usage_errors() {
    for timeout in ["2e19", "1e-10", "inf", "1e6"] {
        let e = error_of(
            &[
                "feed",
                "--instance",
                "absent",
                "--scenario",
                "steady",
                "--timeout",
                timeout,
            ],
            2,
        );
        assert!(e.contains("--timeout must be"), "{timeout}: {e}");
        assert!(!e.contains("panicked"), "{e}");
    }
    // More frames than a run keeps: refused before the bridge is looked for.
    let e = error_of(
        &[
            "feed",
            "--instance",
            "absent",
            "--scenario",
            "steady",
            "--t-end",
            "1e5",
        ],
        2,
    );
    assert!(e.contains("--t-end 100000 s needs 1e7 frames"), "{e}");
    let e = error_of(&["hil", "--scenario", "steady", "--t-end", "1e5"], 2);
    assert!(e.contains("--t-end 100000 s needs 1e7 frames"), "{e}");
}

/// Issue 27, item 9: a value is blamed where it came from, a grading that
/// overflows says so, and negative numbers are values, not flags.
#[test]
fn messages_name_the_source_and_the_problem() {
    let dir = config_copy("segments-600", |t| {
        t.replacen("segments_host = 300 ", "segments_host = 600 ", 1)
            .replacen("segments_embedded = ", "segments_embedded = 600 #", 1)
    });
    let path = dir.join("system.toml");
    let config = path.to_str().unwrap();
    for args in [
        vec!["trim", "--altitude", "9000", "--mach", "0.8"],
        vec!["sweep", "speed", "--out", dir.to_str().unwrap()],
    ] {
        let mut all = vec!["--config", config];
        all.extend(&args);
        let e = error_of(&all, 2);
        assert!(
            e.contains("system.toml: solver.segments_host must be between 1 and 512, got 600"),
            "{args:?}: {e}"
        );
        assert!(!e.contains("command line"), "{args:?}: {e}");
    }
    let e = error_of(&["--config", config, "bridge", "--instance", "blame"], 2);
    assert!(
        e.contains("system.toml: solver.segments_embedded must be between 1 and 512"),
        "{e}"
    );
    // The flag when it is the flag's value.
    let e = error_of(
        &[
            "trim",
            "--altitude",
            "9000",
            "--mach",
            "0.8",
            "--segments",
            "600",
        ],
        2,
    );
    assert!(e.contains("command line: --segments"), "{e}");
    let _ = std::fs::remove_dir_all(dir);

    for command in [
        vec!["trim", "--altitude", "9000", "--mach", "0.8"],
        vec!["simulate", "--scenario", "steady", "--t-end", "0.1"],
    ] {
        let mut args = command.clone();
        args.extend(["--segments", "512", "--grading", "10"]);
        let e = error_of(&args, 2);
        assert!(
            e.contains("grading ratio 10 over 512 segments overflows"),
            "{command:?}: {e}"
        );
        assert!(!e.contains("not a finite number"), "{e}");
    }

    let e = error_of(
        &[
            "feed",
            "--instance",
            "absent",
            "--scenario",
            "steady",
            "--timeout",
            "-1",
        ],
        2,
    );
    assert!(
        e.contains("--timeout must be") && e.contains("got -1"),
        "{e}"
    );
    for command in [
        vec!["simulate", "--scenario", "steady"],
        vec!["trim", "--altitude", "9000", "--mach", "0.8"],
        vec!["hil", "--scenario", "steady"],
        vec!["bridge", "--instance", "negative"],
    ] {
        let mut args = command.clone();
        args.extend(["--segments", "-1"]);
        let e = error_of(&args, 2);
        assert!(
            e.contains("invalid value '-1' for '--segments"),
            "{command:?}: {e}"
        );
    }
}

/// `decoy envelope`: the JSON of the shape, the files, a resumed run,
/// and one-line errors for a bad list, a bad onset and a directory of other
/// inputs.
#[test]
fn envelope_maps_resumes_and_checks() {
    let dir = sim_out("envelope");
    let dir_s = dir.to_str().unwrap();
    let args = |extra: &[&'static str]| -> Vec<String> {
        let mut v: Vec<String> = [
            "envelope",
            "--manoeuvre",
            "pull-up",
            "--altitudes",
            "9000",
            "--machs",
            "0.6,0.8",
            "--segments",
            "12",
            "--grading",
            "1.26",
            "--tolerance",
            "0.01",
            "--workers",
            "2",
            "--out",
            dir_s,
        ]
        .iter()
        .map(|s| (*s).to_owned())
        .collect();
        v.extend(extra.iter().map(|s| (*s).to_owned()));
        v
    };
    let run = |extra: &[&'static str]| {
        let a = args(extra);
        let refs: Vec<&str> = a.iter().map(String::as_str).collect();
        json(&refs)
    };
    let map = run(&["--json"]);
    assert_eq!(map["manoeuvre"], "pull-up");
    let cells = map["cells"].as_array().unwrap();
    assert_eq!(cells.len(), 2);
    for cell in cells {
        assert_eq!(
            keys(cell),
            BTreeSet::from([
                "advised",
                "advised_clear_runs",
                "advisory_lead_s",
                "altitude_m",
                "cap",
                "clear_runs",
                "false_advisories",
                "inside_envelope",
                "limit",
                "limiting_requirement",
                "mach",
                "margin",
                "nuisance_advisories",
                "runs",
                "steady_margins"
            ])
        );
        assert_eq!(cell["inside_envelope"], true, "9 km is inside");
        assert!(num(cell, "limit") > 0.0 && num(cell, "limit") <= num(cell, "cap"));
        assert_eq!(
            keys(&cell["steady_margins"]),
            BTreeSet::from(["collision", "exhaust", "posture", "tension"])
        );
    }
    for file in [
        "envelope.csv",
        "envelope.json",
        "summary.txt",
        "inputs.json",
    ] {
        assert!(dir.join(file).is_file(), "{file}");
    }
    // Again into the same directory: every cell resumed, the same map.
    let a = args(&[]);
    let refs: Vec<&str> = a.iter().map(String::as_str).collect();
    let text = stdout_of(&refs);
    assert!(text.contains("2 cells (2 resumed"), "{text}");
    assert_eq!(run(&["--json"]), map);

    // A flag's value replaced (or the flag added): a one-line usage error.
    let bad = |flag: &str, value: &str, message: &str| {
        let mut a = args(&[]);
        match a.iter().position(|x| x == flag) {
            Some(i) => a[i + 1] = value.to_owned(),
            None => a.extend([flag.to_owned(), value.to_owned()]),
        }
        let refs: Vec<&str> = a.iter().map(String::as_str).collect();
        let e = error_of(&refs, 2);
        assert!(e.contains(message), "{e}");
    };
    bad(
        "--machs",
        "0.6:0.5:0.1",
        "--machs: `0.6:0.5:0.1` needs start <= stop",
    );
    bad("--onset", "-1", "--onset must be a non-negative number");
    bad("--onset", "0.25", "a map of other inputs");
    bad("--workers", "0", "--workers must be at least 1");
    bad(
        "--mach-gain",
        "0.1",
        "--mach-gain applies to an acceleration, not to a pull-up",
    );
    bad("--ray", "127.0.0.1:1", "cannot be used with '--ray");
}

/// `decoy envelope --manoeuvre acceleration`: the limit in m/s^2 up to the
/// envelope's bound, the Mach gain in the JSON, and the acceleration's own
/// one-line errors (a Mach with no room to accelerate, an onset).
#[test]
fn envelope_maps_the_acceleration() {
    let dir = sim_out("envelope-acceleration");
    let args = |extra: &[&str]| -> Vec<String> {
        let mut v: Vec<String> = [
            "envelope",
            "--manoeuvre",
            "acceleration",
            "--altitudes",
            "9000",
            "--machs",
            "0.6",
            "--segments",
            "12",
            "--grading",
            "1.26",
            "--tolerance",
            "1",
            "--out",
            dir.to_str().unwrap(),
        ]
        .iter()
        .map(|s| (*s).to_owned())
        .collect();
        v.extend(extra.iter().map(|s| (*s).to_owned()));
        v
    };
    let a = args(&["--json"]);
    let refs: Vec<&str> = a.iter().map(String::as_str).collect();
    let map = json(&refs);
    assert_eq!(map["manoeuvre"], "acceleration");
    assert_eq!(map["limit_unit"], "m/s^2");
    assert_eq!(map["mach_gain"], 0.1);
    let cell = &map["cells"][0];
    assert!(
        num(cell, "limit") <= 10.0 && num(cell, "cap") == 10.0,
        "{cell}"
    );
    let csv = std::fs::read_to_string(dir.join("envelope.csv")).unwrap();
    assert!(
        csv.starts_with("altitude_m,mach,limit_mps2,cap_mps2,"),
        "{csv}"
    );
    for (extra, message) in [
        (
            &["--machs", "0.95"][..],
            "must be below the envelope's upper Mach 0.95",
        ),
        (
            &["--onset", "0.5"][..],
            "--onset applies to a pull-up or a turn",
        ),
        (
            &["--mach-gain", "0"][..],
            "--mach-gain must be positive, got 0",
        ),
    ] {
        let mut a = args(&[]);
        for pair in extra.chunks(2) {
            match a.iter().position(|x| x == pair[0]) {
                Some(i) => a[i + 1] = pair[1].to_owned(),
                None => a.extend([pair[0].to_owned(), pair[1].to_owned()]),
            }
        }
        let refs: Vec<&str> = a.iter().map(String::as_str).collect();
        let e = error_of(&refs, 2);
        assert!(e.contains(message), "{e}");
    }
}
