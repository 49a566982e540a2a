//! Scenario runs on the embedded model (the configuration's
//! `solver.segments_embedded` graded by `solver.grading_ratio_embedded`): the shipped
//! scenarios, the paper's trends, recorded flights, errors, stopped runs and
//! determinism.

use std::path::{Path, PathBuf};

use decoy_config::SystemConfig;
use decoy_schema::columns::{SIMULATE_CABLE, SIMULATE_TIMESERIES};
use decoy_schema::{BUILTIN_ALTITUDE_M, Manoeuvre};
use decoy_sim::{
    BUILTIN_SCENARIOS, InitialState, RECORDED_COLUMNS, RecordedFlight, RecordedSample, RunOptions,
    RunOutput, Scenario, ScenarioKind, SimError, Summary, simulate,
};
use solver_core::FlightPath;
use solver_core::profiles::{LevelTurn, PullUp};

/// A fresh output directory for one test.
fn out_dir(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("decoy-sim")
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// Options for the embedded model, no plots.
fn reduced(name: &str) -> RunOptions {
    let solver = config().solver;
    RunOptions {
        segments: Some(solver.segments_embedded),
        grading: Some(solver.grading_ratio_embedded),
        dt: Some(1e-3),
        out_dir: Some(out_dir(name)),
        plots: false,
        ..RunOptions::default()
    }
}

fn config() -> SystemConfig {
    SystemConfig::builtin().expect("the built-in configuration loads")
}

fn run(scenario: &str, options: &RunOptions) -> RunOutput {
    let scenario = Scenario::load(scenario).expect("the scenario loads");
    simulate(&config(), &scenario, options, |_| {})
        .unwrap_or_else(|e| panic!("{} failed: {e}", scenario.name))
}

/// The rows of `timeseries.csv` as numbers, after checking the header and that
/// every row is complete.
fn timeseries(dir: &Path) -> Vec<Vec<f64>> {
    let text = std::fs::read_to_string(dir.join("timeseries.csv")).expect("timeseries.csv");
    let mut lines = text.lines();
    let header = SIMULATE_TIMESERIES.header().to_string();
    assert_eq!(lines.next(), Some(header.as_str()));
    let columns = SIMULATE_TIMESERIES.columns.len();
    assert!(text.ends_with('\n'), "the last row is complete");
    lines
        .map(|line| {
            let row: Vec<f64> = line
                .split(',')
                .map(|v| v.parse().unwrap_or_else(|_| panic!("`{v}` in `{line}`")))
                .collect();
            assert_eq!(row.len(), columns, "{line}");
            row
        })
        .collect()
}

fn column(name: &str) -> usize {
    SIMULATE_TIMESERIES
        .names()
        .position(|c| c == name)
        .unwrap_or_else(|| panic!("no column {name}"))
}

fn summary_json(dir: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(dir.join("summary.json")).expect("summary.json");
    serde_json::from_str(&text).expect("summary.json is JSON")
}

#[test]
fn every_shipped_scenario_parses_and_plans() {
    let config = config();
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios");
    for (name, text) in BUILTIN_SCENARIOS {
        let builtin = Scenario::builtin(name).unwrap();
        assert_eq!(builtin.name, name);
        assert!(!builtin.description.is_empty());
        // The file on disk is the embedded one and loads by path too.
        let path = dir.join(format!("{name}.toml"));
        assert_eq!(std::fs::read_to_string(&path).unwrap(), text);
        let from_file = Scenario::load(path.to_str().unwrap()).unwrap();
        assert_eq!(from_file.kind, builtin.kind);
        for scenario in [&builtin, &from_file] {
            let plan = scenario.plan(&config, &RunOptions::default()).unwrap();
            assert_eq!(plan.layout.count(), 300, "{name}");
            assert!(plan.timeline.t_end() > 0.0 && plan.t_end > 0.0);
        }
    }
    let acceleration = Scenario::builtin("acceleration").unwrap();
    assert_eq!(
        acceleration.kind,
        ScenarioKind::Manoeuvre(Manoeuvre::Acceleration)
    );
    assert_eq!(
        (
            acceleration.mach,
            acceleration.final_mach,
            acceleration.accel_start_s,
            acceleration.acceleration_mps2,
            acceleration.altitude_m,
            acceleration.t_end_s
        ),
        (
            Some(0.6),
            Some(0.8),
            Some(2.0),
            Some(10.0),
            Some(9000.0),
            25.0
        )
    );
    let pull_up = Scenario::builtin("pull-up").unwrap();
    assert_eq!(
        (pull_up.rate_radps, pull_up.start_s, pull_up.duration_s),
        (Some(0.10), Some(2.0), Some(5.0))
    );
    let turn = Scenario::builtin("turn").unwrap();
    assert_eq!((turn.rate_radps, turn.mach), (Some(0.20), Some(0.8)));
}

/// One shipped scenario per kind, named after it: `--scenario pull-up` flies
/// the pull-up, and a new manoeuvre ships its scenario.
#[test]
fn one_shipped_scenario_per_kind() {
    let names: Vec<&str> = BUILTIN_SCENARIOS.iter().map(|(n, _)| *n).collect();
    assert_eq!(names, ScenarioKind::ALL.map(ScenarioKind::name));
    for kind in ScenarioKind::ALL {
        assert_eq!(Scenario::builtin(kind.name()).unwrap().kind, kind);
        assert_eq!(ScenarioKind::from_name(kind.name()), Some(kind));
        assert!(!kind.help().is_empty());
    }
}

/// The shipped scenario of each manoeuvre flies the flight of its built-in
/// profile on the controller (`decoy_schema::ManoeuvreInfo::builtin`), the rate
/// aside (the link's command carries it), as docs/protocol.md says.
#[test]
fn shipped_manoeuvres_fly_their_builtin_flights() {
    for manoeuvre in Manoeuvre::ALL {
        let s = Scenario::builtin(manoeuvre.name()).unwrap();
        let b = manoeuvre.info().builtin;
        let name = manoeuvre.name();
        assert_eq!(s.altitude_m, Some(BUILTIN_ALTITUDE_M), "{name}");
        assert_eq!(s.mach, Some(b.mach), "{name}");
        assert_eq!(s.final_mach.unwrap_or(b.mach), b.final_mach, "{name}");
        assert_eq!(
            s.accel_start_s.or(s.start_s).unwrap_or_default(),
            b.start_s,
            "{name}"
        );
        assert_eq!(
            s.acceleration_mps2.unwrap_or_default(),
            b.acceleration_mps2,
            "{name}"
        );
        assert_eq!(s.duration_s.unwrap_or_default(), b.duration_s, "{name}");
        assert_eq!(s.rate_radps.is_some(), manoeuvre.has_rate(), "{name}");
    }
}

/// A scenario's `kind` reads and fails as serde's derived enum of kebab-case
/// unit variants did: the same TOML messages.
#[test]
fn scenario_kinds_parse_with_the_messages_of_a_derived_enum() {
    let parse =
        |kind: &str| Scenario::from_toml(&format!("name = \"x\"\nkind = {kind}\nt_end_s = 1\n"));
    for k in ScenarioKind::ALL {
        assert_eq!(parse(&format!("\"{}\"", k.name())).unwrap().kind, k);
    }
    let message = |kind: &str| parse(kind).unwrap_err().to_string();
    let expected: Vec<String> = ScenarioKind::ALL
        .iter()
        .map(|k| format!("`{}`", k.name()))
        .collect();
    assert_eq!(
        message("\"PullUp\""),
        format!(
            "scenario, line 2: unknown variant `PullUp`, expected one of {}",
            expected.join(", ")
        )
    );
    assert_eq!(message("3"), "scenario, line 2: wanted string or table");
    assert_eq!(
        toml::to_string(&Scenario {
            kind: ScenarioKind::Manoeuvre(Manoeuvre::PullUp),
            ..parse("\"steady\"").unwrap()
        })
        .unwrap()
        .lines()
        .find(|l| l.starts_with("kind"))
        .unwrap(),
        "kind = \"pull-up\""
    );
}

#[test]
fn acceleration_peak_tension_follows_the_acceleration() {
    let options = RunOptions {
        t_end: Some(12.0),
        ..reduced("acceleration")
    };
    let out = run("acceleration", &options);
    let rows = timeseries(&out.out_dir);
    let initial = rows[0][column("tension_connection_N")];
    let s = &out.summary;
    assert!(
        s.max_tension_connection_n > 1.5 * initial,
        "peak {} N vs trim {initial} N",
        s.max_tension_connection_n
    );
    assert!(
        s.t_at_max_tension_s > 2.0,
        "peak at {} s, before the acceleration starts",
        s.t_at_max_tension_s
    );
    // Mach 0.8 is reached about 6 s after the start: the peak is near its end, and
    // the tension falls back to the Mach 0.8 level afterwards.
    assert!(
        (7.0..9.0).contains(&s.t_at_max_tension_s),
        "{}",
        s.t_at_max_tension_s
    );
    assert!(s.final_values.tension_connection_n < s.max_tension_connection_n);
    assert!(s.pitch_oscillation_amplitude_deg > 0.1);
    assert!(s.stopped.is_none());
}

#[test]
fn steady_flight_stays_at_trim() {
    let options = RunOptions {
        t_end: Some(5.0),
        ..reduced("steady")
    };
    let out = run("steady", &options);
    let rows = timeseries(&out.out_dir);
    let c = column("tension_connection_N");
    let trim = rows[0][c];
    for row in &rows {
        assert!(
            (row[c] - trim).abs() <= 1e-3 * trim,
            "t = {}: {} N vs trim {trim} N",
            row[0],
            row[c]
        );
    }
    assert_eq!(rows.last().unwrap()[0], 5.0);
    assert_eq!(rows.len(), 501, "a row every 10 ms");
    assert_eq!(out.summary.settling_time_s, Some(0.0));
    assert!(out.summary.pitch_oscillation_amplitude_deg < 1e-3);
}

#[test]
fn turn_raises_tension_and_swings_the_decoy_outside() {
    let steady = run(
        "steady",
        &RunOptions {
            t_end: Some(6.0),
            ..reduced("turn-steady")
        },
    );
    let right = run(
        "turn",
        &RunOptions {
            t_end: Some(6.0),
            ..reduced("turn-right")
        },
    );
    let (s, r) = (&steady.summary.final_values, &right.summary.final_values);
    assert!(
        r.tension_connection_n > 1.2 * s.tension_connection_n,
        "turn {} N vs steady {} N",
        r.tension_connection_n,
        s.tension_connection_n
    );
    assert!(s.decoy_cg_lateral_m.abs() < 1e-6);
    // Right turn: the outside is to the left, reported positive.
    assert!(r.decoy_cg_lateral_m > 5.0, "{}", r.decoy_cg_lateral_m);
    // A left turn mirrors it: still positive toward the outside.
    let left = run(
        "turn",
        &RunOptions {
            t_end: Some(6.0),
            rate: Some(-0.2),
            ..reduced("turn-left")
        },
    );
    let l = &left.summary.final_values;
    assert!(
        (l.decoy_cg_lateral_m - r.decoy_cg_lateral_m).abs() < 1e-6 * r.decoy_cg_lateral_m,
        "left {} vs right {}",
        l.decoy_cg_lateral_m,
        r.decoy_cg_lateral_m
    );
    assert!(
        (l.tension_connection_n - r.tension_connection_n).abs() < 1e-6 * r.tension_connection_n
    );
}

#[test]
fn faster_pull_up_closes_the_cable_on_the_exhaust() {
    let clearance = |rate: f64| -> Summary {
        run(
            "pull-up",
            &RunOptions {
                rate: Some(rate),
                t_end: Some(10.0),
                ..reduced(&format!("pull-up-{rate}"))
            },
        )
        .summary
    };
    let gentle = clearance(0.05);
    let hard = clearance(0.20);
    assert!(
        hard.min_cable_clearance_to_exhaust_m < gentle.min_cable_clearance_to_exhaust_m - 1.0,
        "0.20 rad/s: {} m, 0.05 rad/s: {} m",
        hard.min_cable_clearance_to_exhaust_m,
        gentle.min_cable_clearance_to_exhaust_m
    );
    assert!(hard.max_tension_connection_n > gentle.max_tension_connection_n);
}

/// A pull-up built over an onset (`--onset`, `onset_s`) steps exactly on its
/// four breakpoints and starts without the step profile's tension transient;
/// an onset where it does not apply, negative or longer than the pull-up is a
/// typed error naming where it came from.
#[test]
fn an_onset_smooths_the_manoeuvre_and_is_checked() {
    let tension = column("tension_connection_N");
    let jolt = |onset: Option<f64>| -> f64 {
        let options = RunOptions {
            rate: Some(0.2),
            t_end: Some(3.0),
            onset,
            dt: None,
            ..reduced(&format!("pull-up-onset-{onset:?}"))
        };
        let out = run("pull-up", &options);
        let rows = timeseries(&out.out_dir);
        rows.windows(2)
            .filter(|w| w[0][0] > 1.9 && w[0][0] < 2.6)
            .map(|w| (w[1][tension] - w[0][tension]).abs())
            .fold(0.0, f64::max)
    };
    // The step profile's connection point jumps by 0.52 m/s at t = 2 s.
    let (step, smooth) = (jolt(None), jolt(Some(0.5)));
    assert!(
        step > 2.0 && smooth < 1.0,
        "step {step} N, onset 0.5 s {smooth} N"
    );

    let pull_up = Scenario::builtin("pull-up").unwrap();
    let plan = pull_up
        .plan(
            &config(),
            &RunOptions {
                onset: Some(0.5),
                ..RunOptions::default()
            },
        )
        .unwrap();
    assert_eq!(plan.profile.breakpoints(20.0), vec![2.0, 2.5, 7.0, 7.5]);
    let described = plan.describe_initial_condition(&config());
    assert!(described.ends_with("(built over 0.5 s)"), "{described}");
    // In a file too; 0 is the step profile.
    let text = include_str!("../../../scenarios/pull-up.toml");
    let file: Scenario = toml::from_str(&format!("{text}\nonset_s = 0.25\n")).unwrap();
    let plan = file.plan(&config(), &RunOptions::default()).unwrap();
    assert_eq!(plan.profile.breakpoints(20.0), vec![2.0, 2.25, 7.0, 7.25]);
    let zero = RunOptions {
        onset: Some(0.0),
        ..RunOptions::default()
    };
    let plan = pull_up.plan(&config(), &zero).unwrap();
    assert_eq!(plan.profile.breakpoints(20.0), vec![2.0, 7.0]);

    let onset = |t: f64| RunOptions {
        onset: Some(t),
        ..RunOptions::default()
    };
    let steady = Scenario::builtin("steady").unwrap();
    let recorded = Scenario::builtin("recorded").unwrap();
    for (scenario, options, message) in [
        (
            &steady,
            onset(0.5),
            "command line: --onset applies to a pull-up or a turn, not to level flight or an acceleration",
        ),
        (
            &recorded,
            onset(0.5),
            "command line: --onset applies to a pull-up or a turn, not a recorded flight",
        ),
        (
            &pull_up,
            onset(-0.1),
            "command line: --onset must not be negative, got -0.1",
        ),
        (
            &pull_up,
            onset(f64::NAN),
            "command line: --onset must be a finite number",
        ),
        (
            &pull_up,
            onset(6.0),
            "command line: --onset 6 s is longer than the pull-up's duration 5 s (the rate must be built before it is removed)",
        ),
    ] {
        let e = plan_error(scenario, &options);
        assert!(e.to_string().starts_with(message), "{e}");
    }
}

/// A recording of `path` sampled at `hz` from 0 to `t_end`.
fn record<P: FlightPath<f64> + ?Sized>(path: &P, hz: f64, t_end: f64) -> RecordedFlight {
    let n = (t_end * hz).round() as usize;
    let samples = (0..=n)
        .map(|k| RecordedSample::of_path(path, k as f64 / hz))
        .collect();
    RecordedFlight::from_samples(samples).expect("a valid recording")
}

#[test]
fn recorded_flight_reproduces_its_generating_profile() {
    let pull_up = PullUp {
        altitude: 9000.0,
        speed: 182.0,
        start: 1.0,
        rate: 0.1,
        duration: 2.0,
    };
    let turn = LevelTurn {
        altitude: 9000.0,
        speed: 243.0,
        start: 1.0,
        rate: 0.2,
        gravity: 9.80665,
    };
    let hz = 50.0;
    let paths: [&dyn FlightPath<f64>; 2] = [&pull_up, &turn];
    for (path, events) in paths.into_iter().zip([[1.0, 3.0], [1.0, 1.0]]) {
        let flight = record(path, hz, 5.0);
        // Through the CSV text and back: the same samples, bit for bit.
        let text = flight.to_csv();
        assert!(text.starts_with(&RECORDED_COLUMNS.join(",")));
        let parsed = RecordedFlight::parse("generated.csv", &text).unwrap();
        assert_eq!(parsed.samples().len(), flight.samples().len());
        for (a, b) in parsed.samples().iter().zip(flight.samples()) {
            assert!(a == b, "sample at {} changed: {a:?} vs {b:?}", b.time);
        }
        for s in parsed.samples() {
            let truth = path.state_at(s.time);
            let got = parsed.state_at(s.time);
            assert_eq!(got.position, truth.position, "position at {}", s.time);
            assert_eq!(got.velocity, truth.velocity, "velocity at {}", s.time);
            assert!(got.rotation().angle_to(&truth.rotation()) < 1e-12);
            assert_eq!(got.angular_rate, truth.angular_rate);
        }
        // Between the samples, away from the manoeuvre's start and end (where the
        // prescribed acceleration jumps), the Hermite acceleration matches.
        let mut worst: f64 = 0.0;
        for k in 0..(5.0 * hz) as usize {
            for fraction in [0.25, 0.5, 0.75] {
                let t = (k as f64 + fraction) / hz;
                if events.iter().any(|e| (t - e).abs() < 1.5 / hz) {
                    continue;
                }
                let truth = path.state_at(t);
                let got = parsed.state_at(t);
                worst = worst.max((got.acceleration - truth.acceleration).norm());
                assert!((got.position - truth.position).norm() < 1e-6, "t = {t}");
                assert!((got.velocity - truth.velocity).norm() < 1e-4, "t = {t}");
                assert!(got.rotation().angle_to(&truth.rotation()) < 1e-9, "t = {t}");
            }
        }
        assert!(worst < 1e-3, "acceleration error {worst} m/s^2");
        // Velocity is the derivative of position, acceleration of velocity.
        let h = 1e-5;
        for t in [0.51, 2.013, 4.377] {
            let (a, b) = (parsed.state_at(t - h), parsed.state_at(t + h));
            let s = parsed.state_at(t);
            assert!(((b.position - a.position) / (2.0 * h) - s.velocity).norm() < 1e-4);
            assert!(((b.velocity - a.velocity) / (2.0 * h) - s.acceleration).norm() < 1e-3);
        }
    }
}

#[test]
fn shipped_recorded_flight_runs() {
    let options = RunOptions {
        t_end: Some(2.0),
        ..reduced("recorded")
    };
    let out = run("recorded", &options);
    let rows = timeseries(&out.out_dir);
    assert_eq!(rows.last().unwrap()[0], 2.0);
    // The example starts level at Mach 0.6, 9 km, and pulls up from 1 s.
    let altitude = column("aircraft_altitude_m");
    assert_eq!(rows[0][altitude], 9000.0);
    assert!(rows.last().unwrap()[altitude] > 9000.0);
    assert!((rows[0][column("aircraft_speed_mps")] - 182.3).abs() < 0.1);
}

#[test]
fn a_recorded_scenario_file_names_its_csv_relative_to_itself() {
    let dir = out_dir("recorded-file");
    std::fs::create_dir_all(&dir).unwrap();
    let turn = LevelTurn {
        altitude: 5000.0,
        speed: 200.0,
        start: 0.5,
        rate: 0.1,
        gravity: 9.80665,
    };
    std::fs::write(dir.join("flight.csv"), record(&turn, 20.0, 3.0).to_csv()).unwrap();
    let scenario = dir.join("mine.toml");
    std::fs::write(
        &scenario,
        "name = \"mine\"\nkind = \"recorded\"\nfile = \"flight.csv\"\nt_end_s = 2.0\n",
    )
    .unwrap();
    let options = RunOptions {
        out_dir: Some(dir.join("out")),
        ..reduced("recorded-file-out")
    };
    let out = run(scenario.to_str().unwrap(), &options);
    assert!(out.summary.final_values.decoy_cg_lateral_m > 0.0);
    // Longer than the recording: an error naming t_end_s.
    std::fs::write(
        &scenario,
        "name = \"mine\"\nkind = \"recorded\"\nfile = \"flight.csv\"\nt_end_s = 4.0\n",
    )
    .unwrap();
    let e = Scenario::load(scenario.to_str().unwrap())
        .unwrap()
        .plan(&config(), &options)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("t_end_s") && e.contains("longer than the recording"),
        "{e}"
    );
}

/// The error of planning `scenario` with `options`.
fn plan_error(scenario: &Scenario, options: &RunOptions) -> SimError {
    scenario
        .plan(&config(), options)
        .expect_err("the plan is rejected")
}

#[test]
fn bad_inputs_are_typed_errors_that_name_the_input() {
    let e = Scenario::load("loop-the-loop").unwrap_err();
    assert!(matches!(e, SimError::UnknownScenario { .. }), "{e:?}");
    let message = e.to_string();
    for kind in ScenarioKind::ALL {
        assert!(message.contains(kind.name()), "{message}");
    }
    assert!(e.is_usage());

    let steady = Scenario::builtin("steady").unwrap();
    let cases: [(RunOptions, &str); 9] = [
        (
            RunOptions {
                mach: Some(f64::NAN),
                ..RunOptions::default()
            },
            "--mach must be above 0",
        ),
        (
            RunOptions {
                mach: Some(2.5),
                ..RunOptions::default()
            },
            "--mach must be above 0 and at most 2, got 2.5",
        ),
        (
            RunOptions {
                mach: Some(0.0),
                ..RunOptions::default()
            },
            "--mach",
        ),
        (
            RunOptions {
                dt: Some(-1e-3),
                ..RunOptions::default()
            },
            "--dt must be positive",
        ),
        (
            RunOptions {
                t_end: Some(0.0),
                ..RunOptions::default()
            },
            "--t-end must be positive",
        ),
        (
            RunOptions {
                altitude: Some(25_000.0),
                ..RunOptions::default()
            },
            "--altitude must be between 0 and 20000 m",
        ),
        (
            RunOptions {
                altitude: Some(-1.0),
                ..RunOptions::default()
            },
            "--altitude",
        ),
        (
            RunOptions {
                rate: Some(0.1),
                ..RunOptions::default()
            },
            "--rate does not apply to a steady scenario",
        ),
        (
            RunOptions {
                segments: Some(513),
                ..RunOptions::default()
            },
            "--segments must be between 1 and 512",
        ),
    ];
    for (options, expected) in cases {
        let e = plan_error(&steady, &options);
        assert!(matches!(e, SimError::InvalidInput { .. }), "{e:?}");
        assert!(e.is_usage());
        assert!(e.to_string().contains(expected), "`{e}` lacks `{expected}`");
    }

    // Values in a scenario file name the key and the file.
    let text = |extra: &str| {
        format!("name = \"x\"\nkind = \"steady\"\naltitude_m = 9000.0\nt_end_s = 1.0\n{extra}")
    };
    let e = plan_error(
        &Scenario::from_toml(&text("mach = nan")).unwrap(),
        &RunOptions::default(),
    );
    assert!(
        e.to_string().contains("scenario: mach must be above 0"),
        "{e}"
    );
    let e = plan_error(
        &Scenario::from_toml(&text("")).unwrap(),
        &RunOptions::default(),
    );
    assert!(
        e.to_string()
            .contains("mach is required for a steady scenario"),
        "{e}"
    );
    let e = plan_error(
        &Scenario::from_toml(&text("mach = 0.8\nrate_radps = 0.1")).unwrap(),
        &RunOptions::default(),
    );
    assert!(
        e.to_string()
            .contains("rate_radps does not apply to a steady scenario"),
        "{e}"
    );
    let e = plan_error(
        &Scenario::from_toml(&text("mach = 0.8\ndt_s = 2.0")).unwrap(),
        &RunOptions::default(),
    );
    assert!(
        e.to_string().contains("longer than the simulated time"),
        "{e}"
    );
    let e = Scenario::from_toml(&text("mach = 0.8\nmachh = 0.9")).unwrap_err();
    assert!(
        matches!(e, SimError::ScenarioSyntax { line: Some(6), .. }),
        "{e:?}"
    );
    assert!(e.to_string().contains("unknown field `machh`"), "{e}");
    let e =
        Scenario::from_toml("name = \"x\"\nkind = \"barrel-roll\"\nt_end_s = 1.0\n").unwrap_err();
    assert!(e.to_string().contains("line 2"), "{e}");
    let e = Scenario::load("/nonexistent/scenario.toml").unwrap_err();
    assert!(matches!(e, SimError::Read { .. }) && e.is_usage(), "{e:?}");
}

#[test]
fn no_trim_is_a_typed_error() {
    let options = RunOptions {
        mach: Some(0.001),
        ..reduced("no-trim")
    };
    let e = simulate(
        &config(),
        &Scenario::builtin("steady").unwrap(),
        &options,
        |_| {},
    )
    .unwrap_err();
    assert!(matches!(e, SimError::NoTrim(_)), "{e:?}");
    assert!(!e.is_usage());
    assert!(
        e.to_string()
            .starts_with("no trim for the initial flight condition"),
        "{e}"
    );
}

#[test]
fn divergence_stops_the_run_and_keeps_valid_outputs() {
    let options = RunOptions {
        dt: Some(0.5),
        t_end: Some(10.0),
        plots: true,
        ..reduced("diverged")
    };
    let mut last_progress = 0.0;
    let e = simulate(
        &config(),
        &Scenario::builtin("steady").unwrap(),
        &options,
        |f| last_progress = f,
    )
    .unwrap_err();
    let SimError::Stopped {
        t_s, ref reason, ..
    } = e
    else {
        panic!("expected a stopped run, got {e:?}");
    };
    assert!(reason.contains("diverged"), "{reason}");
    assert!(t_s < 10.0 && last_progress < 1.0);
    let dir = options.out_dir.unwrap();
    let rows = timeseries(&dir);
    assert_eq!(
        rows.last().unwrap()[0],
        t_s,
        "the CSV ends at the last good state"
    );
    assert!(rows.iter().all(|r| r.iter().all(|v| v.is_finite())));
    let summary = summary_json(&dir);
    assert_eq!(summary["stopped"]["t_s"].as_f64(), Some(t_s));
    assert!(
        summary["stopped"]["reason"]
            .as_str()
            .unwrap()
            .contains("diverged")
    );
    assert!(summary["settling_time_s"].is_null());
    // The plots are drawn from what there is.
    assert!(dir.join("tensions.png").is_file() && dir.join("cable-side.svg").is_file());
}

#[test]
fn runs_are_deterministic() {
    let first = run(
        "turn",
        &RunOptions {
            t_end: Some(2.0),
            ..reduced("determinism-1")
        },
    );
    let second = run(
        "turn",
        &RunOptions {
            t_end: Some(2.0),
            ..reduced("determinism-2")
        },
    );
    for file in ["timeseries.csv", "cable.csv"] {
        let a = std::fs::read(first.out_dir.join(file)).unwrap();
        let b = std::fs::read(second.out_dir.join(file)).unwrap();
        assert!(a == b, "{file} differs between two runs");
    }
    let mut a = first.summary.clone();
    let mut b = second.summary.clone();
    a.wall_s = 0.0;
    b.wall_s = 0.0;
    assert_eq!(a, b);
}

#[test]
fn outputs_have_their_documented_shape() {
    let options = RunOptions {
        t_end: Some(2.5),
        plots: true,
        ..reduced("shape")
    };
    let out = run("turn", &options);
    let dir = &out.out_dir;
    let summary = summary_json(dir);
    // The keys, in the file's order.
    let text = std::fs::read_to_string(dir.join("summary.json")).unwrap();
    let expected = [
        "scenario",
        "segments",
        "dt",
        "t_end",
        "max_tension_connection_N",
        "t_at_max_tension_s",
        "pitch_oscillation_amplitude_deg",
        "settling_time_s",
        "final",
        "tension_connection_N",
        "tension_tow_N",
        "decoy_pitch_deg",
        "decoy_cg_behind_m",
        "decoy_cg_below_m",
        "decoy_cg_lateral_m",
        "min_cable_clearance_to_exhaust_m",
        "min_decoy_clearance_to_aircraft_m",
        "wall_s",
        "management",
        "posture",
        "worst_margin",
        "first_violation_s",
        "first_advisory_s",
        "advisory_lead_s",
        "collision",
        "tension",
        "exhaust",
    ];
    let positions: Vec<usize> = expected
        .iter()
        .map(|k| {
            text.find(&format!("\"{k}\":"))
                .unwrap_or_else(|| panic!("no key {k} in {text}"))
        })
        .collect();
    assert!(positions.windows(2).all(|w| w[0] < w[1]), "{text}");
    assert_eq!(summary.as_object().unwrap().len(), 14, "{text}");
    let management = summary["management"].as_object().unwrap();
    assert_eq!(management.len(), 4, "{text}");
    for entry in management.values() {
        assert_eq!(entry.as_object().unwrap().len(), 4, "{text}");
    }
    assert_eq!(summary["final"].as_object().unwrap().len(), 6, "{text}");
    let n = config().solver.segments_embedded;
    assert_eq!(summary["segments"], n);
    // cable.csv: snapshots at 0, 1, 2 and 2.5 s, joints 0..=n each.
    let cable = std::fs::read_to_string(dir.join("cable.csv")).unwrap();
    let mut lines = cable.lines();
    assert_eq!(
        lines.next(),
        Some(SIMULATE_CABLE.header().to_string().as_str())
    );
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 4 * (n + 1));
    let times: Vec<f64> = rows.iter().step_by(n + 1).map(|r| r[0]).collect();
    assert_eq!(times, [0.0, 1.0, 2.0, 2.5]);
    // Joint 0 is the connection point (the configuration's, behind and below the
    // reference point in level flight at t = 0); the last joint is 100 m along the cable.
    let connection = config().aircraft.connection_point;
    assert!((rows[0][3] + connection[0]).abs() < 1e-6 && (rows[0][5] - connection[2]).abs() < 1e-6);
    assert!((rows[n][2] - 100.0).abs() < 1e-6);
    for name in decoy_sim::PLOT_NAMES {
        for ext in ["png", "svg"] {
            let file = dir.join(format!("{name}.{ext}"));
            assert!(file.is_file(), "{} missing", file.display());
            assert!(out.files.contains(&file));
        }
    }
}

#[test]
fn straight_initial_state_trails_behind_the_connection_point() {
    let options = RunOptions {
        t_end: Some(0.5),
        initial: InitialState::Straight,
        ..reduced("straight")
    };
    let out = run("steady", &options);
    let rows = timeseries(&out.out_dir);
    let first = &rows[0];
    // Decoy along the flight direction, level, just below the connection point.
    assert!(first[column("decoy_pitch_deg")].abs() < 1e-9);
    let below_connection = config().aircraft.connection_point[2];
    assert!((first[column("decoy_cg_below_m")] - below_connection).abs() < 1e-6);
    // Behind the connection point by the cable's 100 m and the decoy's towing point
    // to CG distance.
    assert!(first[column("decoy_cg_behind_m")] > 100.0 - config().aircraft.connection_point[0]);
    let cable = std::fs::read_to_string(out.out_dir.join("cable.csv")).unwrap();
    let joints = config().solver.segments_embedded + 1;
    for line in cable.lines().skip(1).take(joints) {
        let below: f64 = line.split(',').nth(5).unwrap().parse().unwrap();
        assert!((below - below_connection).abs() < 1e-9, "{line}");
    }
}

/// The rows of `cable.csv` (header checked) as numbers.
fn cable_rows(dir: &Path) -> Vec<Vec<f64>> {
    let text = std::fs::read_to_string(dir.join("cable.csv")).expect("cable.csv");
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some(SIMULATE_CABLE.header().to_string().as_str())
    );
    lines
        .map(|line| line.split(',').map(|v| v.parse().unwrap()).collect())
        .collect()
}

#[test]
fn a_run_that_cannot_start_replaces_the_previous_summary() {
    let steady = Scenario::builtin("steady").unwrap();
    let options = RunOptions {
        t_end: Some(0.2),
        ..reduced("cannot-start")
    };
    simulate(&config(), &steady, &options, |_| {}).unwrap();
    assert!(summary_json(options.out_dir.as_ref().unwrap())["stopped"].is_null());

    // The same directory, a flight condition without a trim.
    let slow = RunOptions {
        mach: Some(0.001),
        ..options.clone()
    };
    let e = simulate(&config(), &steady, &slow, |_| {}).unwrap_err();
    assert!(matches!(e, SimError::NoTrim(_)), "{e:?}");
    let dir = slow.out_dir.unwrap();
    let summary = summary_json(&dir);
    assert_eq!(summary["stopped"]["t_s"].as_f64(), Some(0.0), "{summary}");
    let reason = summary["stopped"]["reason"].as_str().unwrap();
    assert!(reason.contains("no trim"), "{reason}");
    assert!(
        summary["final"]["tension_connection_N"].is_null(),
        "{summary}"
    );
    assert!(timeseries(&dir).is_empty() && cable_rows(&dir).is_empty());
}

#[test]
fn a_rerun_leaves_only_its_own_outputs() {
    let steady = Scenario::builtin("steady").unwrap();
    let with_plots = RunOptions {
        t_end: Some(0.2),
        plots: true,
        ..reduced("rerun")
    };
    simulate(&config(), &steady, &with_plots, |_| {}).unwrap();
    let dir = with_plots.out_dir.clone().unwrap();
    assert!(dir.join("tensions.png").is_file());
    std::fs::write(dir.join("notes.txt"), "mine").unwrap();

    let without_plots = RunOptions {
        plots: false,
        ..with_plots
    };
    let run = simulate(&config(), &steady, &without_plots, |_| {}).unwrap();
    let mut left: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    left.sort();
    assert_eq!(
        left,
        ["cable.csv", "notes.txt", "summary.json", "timeseries.csv"],
        "the old plots are gone, the unknown file stays"
    );
    assert_eq!(run.files.len(), 3);
}

#[test]
fn a_stopped_run_ends_cable_csv_at_its_last_good_state() {
    let options = RunOptions {
        dt: Some(0.3),
        t_end: Some(10.0),
        ..reduced("stopped-cable")
    };
    let e = simulate(
        &config(),
        &Scenario::builtin("steady").unwrap(),
        &options,
        |_| {},
    )
    .unwrap_err();
    let SimError::Stopped { t_s, .. } = e else {
        panic!("expected a stopped run, got {e:?}");
    };
    let dir = options.out_dir.unwrap();
    let rows = cable_rows(&dir);
    let last = rows.last().unwrap();
    assert_eq!(last[0], t_s, "the last snapshot is the last good state");
    let n = config().solver.segments_embedded as f64;
    assert_eq!(last[1], n, "a whole snapshot, joints 0 to n");
    assert!(rows.iter().all(|r| r.iter().all(|v| v.is_finite())));
}

/// `(origin, field, message)` of an [`SimError::InvalidInput`].
fn invalid_parts(e: &SimError) -> (&str, &str, &str) {
    match e {
        SimError::InvalidInput {
            origin,
            field,
            message,
        } => (origin, field, message),
        other => panic!("expected an invalid input, got {other:?}"),
    }
}

#[test]
fn errors_name_the_source_of_the_value() {
    let steady = Scenario::builtin("steady").unwrap();
    // A flag.
    let options = RunOptions {
        t_end: Some(1e9),
        ..reduced("source-flag")
    };
    let e = plan_error(&steady, &options);
    let (origin, field, message) = invalid_parts(&e);
    assert_eq!((origin, field), ("command line", "--t-end"), "{e}");
    assert!(message.starts_with("1e9 s asks for 1.0e12 steps"), "{e}");

    // A configuration field.
    let mut config = config();
    config.solver.segments_host = 0;
    let options = RunOptions {
        segments: None,
        ..reduced("source-config")
    };
    let e = steady.plan(&config, &options).unwrap_err();
    let (origin, field, _) = invalid_parts(&e);
    assert_eq!(
        (origin, field),
        (config.source.as_str(), "solver.segments_host"),
        "{e}"
    );

    // A scenario file's key.
    let file = Scenario::from_toml(
        "name = \"x\"\nkind = \"steady\"\naltitude_m = 9000.0\nmach = 0.8\nt_end_s = 1.0\ndt_s = 2.0\n",
    )
    .unwrap();
    let e = plan_error(
        &file,
        &RunOptions {
            dt: None,
            ..reduced("source-file")
        },
    );
    assert_eq!(invalid_parts(&e).1, "dt_s", "{e}");
}

#[test]
fn huge_numbers_are_short_in_messages() {
    let options = RunOptions {
        mach: Some(f64::MAX),
        ..reduced("huge")
    };
    let e = plan_error(&Scenario::builtin("steady").unwrap(), &options);
    let text = e.to_string();
    assert!(text.ends_with("got 1.7976931348623157e308"), "{text}");
}

/// A recorded-flight CSV of level flight north at 9 km: `(t, speed)` per row,
/// positions following the velocities exactly (trapezoidal).
fn level_recording(rows: &[(f64, f64)]) -> String {
    let mut text = format!("{}\n", RECORDED_COLUMNS.join(","));
    let mut north = 0.0;
    for (k, &(t, v)) in rows.iter().enumerate() {
        if k > 0 {
            let (t0, v0) = rows[k - 1];
            north += 0.5 * (v0 + v) * (t - t0);
        }
        text.push_str(&format!("{t},{north},0,-9000,{v},0,0,1,0,0,0,0,0,0\n"));
    }
    text
}

#[test]
fn a_recorded_flight_beyond_mach_2_is_rejected() {
    let dir = out_dir("mach-3");
    std::fs::create_dir_all(&dir).unwrap();
    let config = config();
    let speed = config.mach_to_speed(9000.0, 3.0).unwrap();
    let csv = dir.join("fast.csv");
    std::fs::write(&csv, level_recording(&[(0.0, speed), (1.0, speed)])).unwrap();
    let toml = dir.join("fast.toml");
    std::fs::write(
        &toml,
        "name = \"fast\"\nkind = \"recorded\"\nfile = \"fast.csv\"\nt_end_s = 1.0\n",
    )
    .unwrap();
    let scenario = Scenario::from_file(&toml).unwrap();
    let e = scenario.plan(&config, &reduced("mach-3-run")).unwrap_err();
    let SimError::RecordedFlight {
        line,
        column,
        message,
        ..
    } = &e
    else {
        panic!("expected a recorded-flight error, got {e:?}");
    };
    assert_eq!((*line, column.as_deref()), (Some(2), Some("vn_mps")), "{e}");
    assert!(
        message.contains("Mach 3") && message.contains("Mach 2"),
        "{e}"
    );
    assert!(e.is_usage());
}

#[test]
fn a_velocity_step_in_a_nanosecond_is_rejected() {
    let text = level_recording(&[(0.0, 200.0), (1.0, 200.0), (1.000_000_001, 250.0)]);
    let e = RecordedFlight::parse("step.csv", &text).unwrap_err();
    let SimError::RecordedAcceleration {
        line,
        acceleration_mps2,
        limit_mps2,
        ..
    } = e
    else {
        panic!("expected an acceleration error, got {e:?}");
    };
    assert_eq!(line, Some(4), "the row of the step");
    assert!(acceleration_mps2 > 1e9 && limit_mps2 == 100.0);
    assert!(
        e.to_string()
            .starts_with("step.csv, line 4: the acceleration"),
        "{e}"
    );
    // The shipped example stays within the bound.
    RecordedFlight::parse("example", decoy_sim::RECORDED_EXAMPLE_CSV).unwrap();
}
