//! Sweeps and studies: the paper's steady-flight trends, the decoy-settling
//! classification, and the discretisation study's plumbing.

use decoy_config::SystemConfig;
use decoy_studies::study::{StudySpec, Tolerances, discretisation_study};
use decoy_studies::sweep::{
    PullUpSpec, SettlingSpec, StaticMarginSpec, StationVariable, SteadySweepSpec, SteadyVariable,
    SweepRange, centre_of_pressure_offset, pull_up_sweep, settling_sweep, static_margin,
    static_margin_sweep, steady_sweep, with_static_margin, write_pull_up_sweep,
    write_settling_sweep, write_steady_sweep,
};

fn config() -> SystemConfig {
    SystemConfig::builtin().expect("the built-in configuration loads")
}

fn out_dir(name: &str) -> std::path::PathBuf {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("decoy-studies-sweeps")
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn increasing(v: &[f64]) -> bool {
    v.windows(2).all(|w| w[1] > w[0])
}

fn decreasing(v: &[f64]) -> bool {
    v.windows(2).all(|w| w[1] < w[0])
}

#[test]
fn speed_sweep_trims_follow_the_papers_trends() {
    let config = config();
    let spec = SteadySweepSpec::paper(SteadyVariable::Speed, &config);
    assert_eq!(spec.values.len(), 9);
    let sweep = steady_sweep(&config, &spec, |_| {}).unwrap();
    let p = &sweep.points;
    let get = |f: fn(&decoy_studies::sweep::TrimPoint) -> f64| p.iter().map(f).collect::<Vec<_>>();
    let connection = get(|p| p.tension_connection_n);
    // Connection tension grows with Mach, faster than linearly (convex).
    assert!(increasing(&connection), "{connection:?}");
    assert!(connection.windows(3).all(|w| w[2] - w[1] > w[1] - w[0]));
    // Decoy pitch and depth fall with speed.
    assert!(decreasing(&get(|p| p.decoy_pitch_deg)));
    assert!(decreasing(&get(|p| p.decoy_cg_below_m)));
    // The tension grows from the decoy to the aircraft in every trim, and the
    // connection point carries the maximum.
    for point in p {
        assert!(
            point
                .cable
                .windows(2)
                .all(|w| w[0].tension_n >= w[1].tension_n)
        );
        assert_eq!(point.tension_max_n, point.tension_connection_n);
        assert_eq!(point.cable.len(), 301);
    }
    // The towing tension changes much less than the connection tension.
    let tow = get(|p| p.tension_tow_n);
    let relative = |v: &[f64]| (v[v.len() - 1] - v[0]) / v[0];
    assert!(relative(&tow) < 0.5 * relative(&connection));
    // Mach 0.8 at 9 km: the documented reference trim.
    assert!((connection[6] - 271.26).abs() < 0.05, "{}", connection[6]);

    let dir = out_dir("speed");
    let files = write_steady_sweep(&sweep, &dir, false).unwrap();
    assert_eq!(files.len(), 2);
    let table = std::fs::read_to_string(dir.join("sweep.csv")).unwrap();
    assert_eq!(table.lines().count(), 10);
    assert!(table.starts_with(decoy_studies::sweep::STEADY_SWEEP_HEADER));
}

#[test]
fn altitude_sweep_tension_falls_and_the_decoy_sinks() {
    let config = config();
    let spec = SteadySweepSpec::paper(SteadyVariable::Altitude, &config);
    let sweep = steady_sweep(&config, &spec, |_| {}).unwrap();
    let connection: Vec<f64> = sweep
        .points
        .iter()
        .map(|p| p.tension_connection_n)
        .collect();
    assert!(decreasing(&connection), "{connection:?}");
    let pitch: Vec<f64> = sweep.points.iter().map(|p| p.decoy_pitch_deg).collect();
    let depth: Vec<f64> = sweep.points.iter().map(|p| p.decoy_cg_below_m).collect();
    assert!(increasing(&pitch) && increasing(&depth));
    assert!(sweep.points.iter().all(|p| p.mach == 0.7));
}

#[test]
fn bad_sweep_inputs_are_usage_errors() {
    let config = config();
    let mut spec = SteadySweepSpec::paper(SteadyVariable::Speed, &config);
    spec.values = vec![0.5, 2.5];
    let e = steady_sweep(&config, &spec, |_| {}).unwrap_err();
    assert!(e.is_usage() && e.to_string().contains("--to"), "{e}");
    let mut settling = SettlingSpec::paper(StationVariable::TowPoint, &config);
    settling.values = vec![0.1, 1.5];
    let e = settling_sweep(&config, &settling, |_| {}).unwrap_err();
    assert!(e.is_usage() && e.to_string().contains("decoy.x_tow"), "{e}");
    let e = SweepRange {
        from: 0.1,
        to: 0.2,
        step: 0.0,
    }
    .values()
    .unwrap_err();
    assert!(e.is_usage() && e.to_string().contains("--step"), "{e}");
}

/// In this model the decoy settles with its towing point ahead of the CG *and*
/// well behind it (the reference decoy's aerodynamic stiffness dominates the
/// tension's moment, unlike the paper's decoy); it stops settling only when the
/// towing point nears the centre of pressure (0.65 m from the nose), where no
/// trim exists and the perturbed run diverges.
#[test]
fn towing_point_settling_classification() {
    let config = config();
    let mut spec = SettlingSpec::paper(StationVariable::TowPoint, &config);
    spec.values = vec![0.12, 0.40, 0.60];
    let sweep = settling_sweep(&config, &spec, |_| {}).unwrap();
    let [ahead, behind, near_cp] = &sweep.points[..] else {
        panic!("three points");
    };
    assert_eq!(sweep.fixed_station_m, 0.27);
    // Ahead of the CG (the reference stations): trim exists, settles quickly.
    assert!(ahead.trim_exists && ahead.settling.settled);
    assert!(ahead.settling.settling_time_s.unwrap() < 3.0);
    assert!(ahead.settling.final_amplitude_deg < 0.05);
    assert!((ahead.settling.final_pitch_deg - ahead.trim_pitch_deg.unwrap()).abs() < 0.1);
    // 0.13 m behind the CG: still settles (the paper's decoy would not).
    assert!(behind.x_tow_m > behind.x_cg_m);
    assert!(behind.trim_exists && behind.settling.settled);
    assert!(behind.settling.final_amplitude_deg < spec.threshold_deg);
    // Near the centre of pressure: no trim, the run does not settle.
    assert!(!near_cp.trim_exists);
    assert!(!near_cp.settling.settled && near_cp.settling.settling_time_s.is_none());
    assert!(near_cp.settling.final_amplitude_deg > 1.0);

    let dir = out_dir("tow-point");
    write_settling_sweep(&sweep, &dir, false).unwrap();
    let table = std::fs::read_to_string(dir.join("sweep.csv")).unwrap();
    assert_eq!(table.lines().count(), 4);
    assert!(table.lines().nth(3).unwrap().contains(",false,"));
}

#[test]
fn discretisation_study_runs_and_chooses() {
    let config = config();
    // A small study: enough to exercise the step halving (24 segments graded
    // 1.4 need a step shorter than 1 ms) and the choice.
    let spec = StudySpec {
        uniform: vec![50],
        graded: vec![24],
        grading: 1.4,
        dt: 1e-3,
        max_halvings: 4,
        reference_segments: 50,
        embedded_segments: vec![6, 12],
        embedded_ratios: vec![1.3],
        trim_mach: 0.8,
        trim_altitude_m: 9000.0,
        tolerances: Tolerances::default(),
    };
    let study = discretisation_study(&config, &spec, |_| {}).unwrap();
    assert_eq!(study.rows.len(), 2);
    let graded = &study.rows[1];
    assert!(graded.dt_s < 1e-3 && graded.stopped.is_none(), "{graded:?}");
    let uniform = &study.rows[0];
    assert!((uniform.max_tension_connection_n - graded.max_tension_connection_n).abs() < 1.0);
    // 6 segments graded 1.3 are far off; 12 are within the tolerances, graded
    // 1.3 and as configured alike (the configured model is always a candidate,
    // after the grid), and the choice is one of them.
    let choice = &study.embedded;
    let (n, ratio) = study.configured_embedded;
    assert_eq!(choice.candidates.len(), 3);
    assert!(!choice.candidates[0].within_tolerances);
    let configured = &choice.candidates[2];
    assert_eq!(
        (configured.metrics.segments, configured.metrics.grading),
        (n, ratio)
    );
    assert!(configured.within_tolerances);
    assert_eq!(choice.chosen().unwrap().metrics.segments, 12);
}

/// A time step too long for the sweep's runs: the error names the flag (without
/// one the sweep's runs choose their steps, docs/outputs.md "Time steps").
#[test]
fn settling_errors_name_the_source_of_the_time_step() {
    let config = config();
    let spec = SettlingSpec::paper(StationVariable::Cg, &config);
    assert!(spec.plan(&config).is_ok());
    let flagged = SettlingSpec {
        dt: Some(30.0),
        ..spec
    };
    let e = flagged.plan(&config).unwrap_err();
    let decoy_sim::SimError::InvalidInput { origin, field, .. } = &e else {
        panic!("expected an invalid input, got {e:?}");
    };
    assert_eq!(
        (origin.as_str(), field.as_str()),
        ("command line", "--dt"),
        "{e}"
    );
}

/// The pull-up search flies the grid, bisects between the last clear rate and the
/// first that enters the plume, and reports a limit bracketed by a clear run and a
/// run in the plume; the reference installation's limit is the paper's 0.10 rad/s
/// or a little below: 300 uniform segments are clear at 0.095 rad/s (0.145 m) and
/// in the plume at 0.100 (-0.237 m) (`decoy sweep pull-up-rate --from 0.06 --to
/// 0.14 --step 0.04 --tolerance 0.005 --segments 300 --grading 1`), and the
/// embedded model's bracket must hold that.
#[test]
fn pull_up_rate_search_brackets_the_limit() {
    let config = config();
    let mut spec = PullUpSpec::paper(&config);
    spec.rates = vec![0.06, 0.14];
    spec.tolerance_radps = 0.01;
    let sweep = pull_up_sweep(&config, &spec, |_| {}).unwrap();
    let (limit, entering) = (
        sweep.limit_radps.unwrap(),
        sweep.first_entering_radps.unwrap(),
    );
    assert!(entering - limit <= 0.01 + 1e-9 && entering > limit);
    assert!(
        (0.08..=0.095).contains(&limit) && (0.095..=0.11).contains(&entering),
        "{}",
        sweep.describe_limit()
    );
    let at = |r: f64| sweep.points.iter().find(|p| p.rate_radps == r).unwrap();
    assert!(at(limit).clear && at(limit).min_clearance_m >= 0.0);
    assert!(!at(entering).clear && at(entering).min_clearance_m < 0.0);
    assert!(sweep.points.iter().filter(|p| p.bisection).count() >= 2);
    // Faster is closer, and steady flight at Mach 0.6 is well clear.
    let clearances: Vec<f64> = sweep.points.iter().map(|p| p.min_clearance_m).collect();
    assert!(decreasing(&clearances), "{clearances:?}");
    assert!(sweep.points[0].initial_clearance_m > 1.0);
    let dir = out_dir("pull-up-rate");
    let files = write_pull_up_sweep(&sweep, &dir, false).unwrap();
    assert_eq!(files.len(), 2);
    let table = std::fs::read_to_string(dir.join("sweep.csv")).unwrap();
    assert!(table.starts_with(decoy_studies::sweep::PULL_UP_SWEEP_HEADER));
    assert_eq!(table.lines().count(), sweep.points.len() + 1);
}

/// The static margin is the centre of pressure behind the CG over the body length:
/// 41 % for the reference decoy, 10 % for the weak-stability decoy; moving the
/// moment reference point sets it, and a margin that would put the point off the
/// body is a usage error.
#[test]
fn static_margin_of_the_two_decoys() {
    let reference = config();
    let weak = SystemConfig::weak_stability().unwrap();
    let offset = centre_of_pressure_offset(&reference).unwrap();
    assert!((offset - 0.1885).abs() < 1e-3, "{offset}");
    assert!((static_margin(&reference).unwrap() - 0.409).abs() < 1e-3);
    assert!((static_margin(&weak).unwrap() - 0.10).abs() < 1e-3);
    let moved = with_static_margin(&reference, 0.10).unwrap();
    assert!((moved.decoy.x_mrp - weak.decoy.x_mrp).abs() < 1e-3);
    assert!((static_margin(&moved).unwrap() - 0.10).abs() < 1e-12);
    let e = with_static_margin(&reference, 1.5).unwrap_err();
    assert!(e.is_usage() && e.to_string().contains("x_mrp"), "{e}");
}

/// The settled band of towing points of the weak-stability decoy's margin
/// straddles its CG closely (the aft limit within the rule's 5 %), and the
/// reference decoy's margin settles far behind its CG.
#[test]
fn static_margin_study_finds_the_band() {
    let config = config();
    let mut spec = StaticMarginSpec::paper(&config);
    spec.margins = vec![0.10, 0.40];
    spec.tolerance_m = 0.02;
    spec.boundary_bisections = 0;
    let sweep = static_margin_sweep(&config, &spec, |_| {}).unwrap();
    let [weak, stiff] = &sweep.points[..] else {
        panic!("two margins, no bisection: {:?}", sweep.points);
    };
    let (fwd, aft) = (weak.forward_offset.unwrap(), weak.aft_offset.unwrap());
    assert!(fwd < 0.0 && fwd > -0.2, "{fwd}");
    assert!(aft.abs() <= 0.05, "{aft}");
    assert!(weak.must_be_ahead && !weak.rule_band_settles);
    assert!(stiff.aft_offset.unwrap() > 0.15 && !stiff.must_be_ahead);
    assert!(stiff.rule_band_settles);
    assert_eq!(sweep.bracket(), Some((0.10, 0.40)));
    let b = sweep.boundary_margin.unwrap();
    assert!(b > 0.10 && b < 0.40, "{b}");
}
