//! Decoy management end to end in the controller: the monitors' levels and the
//! look-ahead's advisories over the paper's manoeuvres and the steady envelope,
//! in f32 (the Cortex-M4's precision, the embedded model) as the firmware runs it.
//!
//! **Installation.** The reference configuration as shipped (`config/`: the
//! decoy launcher 2 m aft and 1.7 m below the engine axis, a 35 m hot plume),
//! whose cable clears the plume by at least 1.2 m in steady flight over the
//! envelope and enters it in the paper's 0.20 rad/s pull-up.

mod common;

use decoy_config::SystemConfig;
use decoy_controller::path::state_frame;
use decoy_controller::{Controller, NoCounter, SystemParams};
use decoy_link::{
    Advisories, Command, DeviceMessage, HostMessage, MonitorLevel, OutputFrame, Profile,
    Requirement,
};
use decoy_schema::{Manoeuvre, REQUIREMENT_COUNT};
use solver_core::profiles::{LevelAcceleration, LevelTurn, PullUp};
use solver_core::{AircraftState, FlightPath, Real};

use common::CAPACITY;

/// The reference system as shipped.
fn shipped() -> SystemParams {
    SystemConfig::builtin().unwrap().params().unwrap()
}

fn controller<T: Real>(system: &SystemParams) -> Controller<T, CAPACITY> {
    Controller::new(system.controller_config(system.embedded_layout()).unwrap()).unwrap()
}

/// The Outputs of a built-in profile flown for `seconds` in 10 ms frames (from
/// the trim's completion: the frames before it are answered by the
/// initialisation's Status).
fn fly_profile<T: Real>(system: &SystemParams, profile: Profile, seconds: f64) -> Vec<OutputFrame> {
    let mut c = controller::<T>(system);
    c.handle(
        HostMessage::Command(Command::SelectProfile(profile)),
        &mut NoCounter,
    );
    let frames = (seconds / 0.01).round() as u32;
    (0..=frames)
        .filter_map(|k| {
            let t = 0.01 * f64::from(k);
            let f = AircraftState::<f64>::level(9000.0, 200.0);
            common::output_or_initialising(
                c.handle(HostMessage::State(state_frame(k, t, &f)), &mut NoCounter),
            )
        })
        .collect()
}

/// The Outputs of streamed frames along `path` for `seconds` (from the trim's
/// completion).
fn fly_path<T: Real, P: FlightPath<f64>>(
    system: &SystemParams,
    path: &P,
    seconds: f64,
) -> Vec<OutputFrame> {
    let mut c = controller::<T>(system);
    let frames = (seconds / 0.01).round() as u32;
    (0..=frames)
        .filter_map(|k| {
            let t = 0.01 * f64::from(k);
            common::output_or_initialising(c.handle(
                HostMessage::State(state_frame(k, t, &path.state_at(t))),
                &mut NoCounter,
            ))
        })
        .collect()
}

/// Per requirement: the first violation (level violated) and the first advisory.
fn events(outputs: &[OutputFrame]) -> [(Option<f64>, Option<f64>); REQUIREMENT_COUNT] {
    let mut e = [(None, None); REQUIREMENT_COUNT];
    for o in outputs {
        for (requirement, r) in o.management.reports.iter() {
            let k = requirement.index();
            if e[k].0.is_none() && r.level == MonitorLevel::Violated {
                e[k].0 = Some(o.time_s);
            }
            if e[k].1.is_none() && o.management.advisories & requirement.bit() != 0 {
                e[k].1 = Some(o.time_s);
            }
        }
    }
    e
}

/// The name of the requirement at index `k`.
fn name(k: usize) -> &'static str {
    Requirement::ALL[k].name()
}

/// The least advisory lead asserted, s: the 1 s. The look-ahead flies
/// a 12-segment model (`[management] prediction_segments`, graded as the
/// embedded model: now the embedded model itself) whose 1.73 m shortest segment
/// lets it take 12 ms steps, 5 per frame.
const LEAST_LEAD_S: f64 = 1.0;

/// In the paper's pull-up and turn at 0.20 rad/s the controller advises before
/// every violation (at least [`LEAST_LEAD_S`] ahead), and something is violated
/// (the test cannot pass by predicting nothing): as shipped (the map on board
/// and the look-ahead), and by the look-ahead alone (no map), which must hold
/// for the manoeuvres the map does not cover.
#[test]
fn the_paper_manoeuvres_are_advised_ahead_of_every_violation() {
    let mut unmapped = shipped();
    unmapped.limits = decoy_controller::LimitMap::EMPTY;
    for (label, system) in [("shipped", shipped()), ("look-ahead alone", unmapped)] {
        // The paper's 0.20 rad/s pull-up and turn, and every other built-in
        // manoeuvre the product ships (pull-ups 0.05 and 0.10, turn 0.10).
        for profile in [
            Profile::builtin(Manoeuvre::PullUp, 200),
            Profile::builtin(Manoeuvre::Turn, 200),
            Profile::builtin(Manoeuvre::PullUp, 50),
            Profile::builtin(Manoeuvre::PullUp, 100),
            Profile::builtin(Manoeuvre::Turn, 100),
        ] {
            let outputs = fly_profile::<f32>(&system, profile, 12.0);
            let events = events(&outputs);
            let mut violated = 0;
            for (k, (violation, advisory)) in events.iter().enumerate() {
                println!(
                    "{label} {profile:?} {}: violated {violation:?}, advised {advisory:?}",
                    name(k)
                );
                if let Some(v) = violation {
                    violated += 1;
                    let a = advisory.unwrap_or_else(|| {
                        panic!(
                            "{label} {profile:?}: {} violated at {v} s, never advised",
                            name(k)
                        )
                    });
                    assert!(
                        v - a >= LEAST_LEAD_S - 1e-9,
                        "{label} {profile:?}: {} advised at {a} s, violated at {v} s",
                        name(k)
                    );
                }
            }
            if profile == (Profile::builtin(Manoeuvre::PullUp, 200)) {
                assert!(
                    violated > 0,
                    "{label}: the 0.20 rad/s pull-up violates nothing"
                );
            }
        }
    }
}

/// No advisory, no warning and no violation in steady level flight across Mach
/// 0.5-0.9 at 9 km and 3-12 km at Mach 0.7.
#[test]
fn steady_flight_gives_no_advisory_anywhere_in_the_envelope() {
    let system = shipped();
    let config = SystemConfig::builtin().unwrap();
    let mut cases: Vec<(f64, f64)> = [0.5, 0.6, 0.7, 0.8, 0.9].map(|m| (9000.0, m)).to_vec();
    cases.extend([3000.0, 6000.0, 12000.0].map(|h| (h, 0.7)));
    for (altitude, mach) in cases {
        let speed = config.mach_to_speed(altitude, mach).unwrap();
        let path = LevelAcceleration::steady(altitude, speed);
        let outputs = fly_path::<f32, _>(&system, &path, 5.0);
        let last = outputs.last().unwrap();
        let m = &last.management;
        println!(
            "steady {altitude} m Mach {mach}: margins {:?}, predicted {:?}",
            m.reports.map(|r| r.margin),
            m.reports.map(|r| r.predicted_worst_margin)
        );
        assert!(m.prediction_from_s >= 0.0, "no prediction completed");
        for o in &outputs {
            assert_eq!(
                o.management.advisories, 0,
                "{altitude} m Mach {mach} at {} s",
                o.time_s
            );
            assert!(
                o.management.worst_level() < MonitorLevel::Warning,
                "{altitude} m Mach {mach} at {} s: {:?}",
                o.time_s,
                o.management
            );
        }
    }
}

/// The paper's acceleration (Mach 0.6 to 0.8 at 10 m/s^2) is flown without an
/// advisory or a violation.
#[test]
fn the_acceleration_case_gives_no_advisory() {
    let outputs = fly_profile::<f32>(
        &shipped(),
        Profile::builtin(Manoeuvre::Acceleration, 0),
        15.0,
    );
    for o in &outputs {
        assert_eq!(
            o.management.advisories, 0,
            "at {} s: {:?}",
            o.time_s, o.management
        );
        assert!(
            o.management.worst_level() < MonitorLevel::Violated,
            "at {} s",
            o.time_s
        );
    }
}

/// The look-ahead flies at least 3 s ahead and completes a prediction at least
/// every 0.5 s of flight in steady flight (5 steps of 12 ms per frame: 3 s in
/// 50 frames; see `config/reference-system.toml`).
#[test]
fn the_look_ahead_covers_3_s_and_refreshes_every_half_second() {
    let system = shipped();
    let outputs = fly_profile::<f32>(&system, Profile::builtin(Manoeuvre::Steady, 0), 6.0);
    let mut starts: Vec<f64> = outputs
        .iter()
        .map(|o| o.management.prediction_from_s)
        .filter(|t| *t >= 0.0)
        .collect();
    starts.dedup();
    assert!(starts.len() >= 4, "{starts:?}");
    for w in starts.windows(2) {
        assert!(w[1] - w[0] <= 0.5 + 1e-9, "{starts:?}");
    }
    for o in &outputs {
        if o.management.prediction_from_s >= 0.0 {
            assert!(
                o.management.prediction_horizon_s >= 3.0 - 1e-6,
                "{:?}",
                o.management
            );
        }
        assert!(u32::from(o.prediction_steps) <= system.management.prediction_steps_per_frame);
    }
}

/// The predicted worst margins against the margins actually reached over the
/// same horizon, in the 0.20 rad/s pull-up (the prediction holds the manoeuvre,
/// so it is compared where the manoeuvre is held over the whole horizon: the
/// rotation from 2 s to 7 s, the climb after it, snatch included).
#[test]
fn predicted_margins_against_the_margins_reached() {
    // More steps per frame than the M4's budget allows, for more predictions
    // to compare (the accuracy does not depend on how the work is sliced).
    let mut system = shipped();
    system.management.prediction_steps_per_frame = 10;
    let outputs = fly_profile::<f32>(&system, Profile::builtin(Manoeuvre::PullUp, 200), 12.0);
    let mut compared = 0;
    // Largest |predicted - reached| per requirement, in the rotation and in
    // the climb after it (the snatch).
    let mut worst_error = [[0.0f64; 4]; 2];
    let mut seen = -1.0;
    for o in &outputs {
        let m = &o.management;
        let from = m.prediction_from_s;
        let until = from + f64::from(m.prediction_horizon_s);
        let phase = if from > 2.05 && until <= 7.0 {
            0
        } else if from > 7.05 && until <= 12.0 {
            1
        } else {
            continue;
        };
        if from == seen {
            continue;
        }
        seen = from;
        for requirement in [
            Requirement::Collision,
            Requirement::Tension,
            Requirement::Exhaust,
        ] {
            let reached = outputs
                .iter()
                .filter(|p| p.time_s >= from - 1e-9 && p.time_s <= until + 1e-9)
                .map(|p| f64::from(p.management.reports[requirement].margin))
                .fold(f64::INFINITY, f64::min);
            let predicted = f64::from(m.reports[requirement].predicted_worst_margin);
            let error = &mut worst_error[phase][requirement.index()];
            *error = error.max((predicted - reached).abs());
            println!(
                "from {from:.2} s: {} predicted {predicted:.3}, reached {reached:.3}",
                requirement.name()
            );
        }
        compared += 1;
    }
    println!(
        "largest |predicted - reached| (collision m, tension N, exhaust m): rotation {:?}, climb and snatch {:?}",
        &worst_error[0][1..],
        &worst_error[1][1..]
    );
    assert!(compared >= 2, "{compared} predictions compared");
    // The prediction holds a constant-rate pull-up and a straight climb exactly,
    // so what separates predicted from reached is the look-ahead's coarser model
    // step (13 ms against the controller's 2.5 ms; the same 12 segments since the
    // embedded model has 12, until issue 14 they were 12 against 16). Measured
    // in the rotation: collision 0.116 m, tension 0.69 N, exhaust 0.012 m.
    let [rotation, climb] = worst_error;
    assert!(rotation[1] < 0.15 && rotation[3] < 0.02, "{rotation:?}");
    assert!(rotation[2] < 1.5, "{rotation:?}");
    // In the snatch after the rotation the cable's path to the plume is
    // predicted within 0.06 m (measured 0.058 m; 0.043 m before the last bits of
    // the solver's arithmetic changed: the snatch is sensitive to them) and the
    // decoy's to the aircraft within 0.34 m; its peak tension, a jerk of a slack
    // cable, depends on the model and the step: the predicted peak differs by
    // 205 N (a tension advisory comes at 7.45 s that no violation follows).
    assert!(climb[1] < 0.4 && climb[3] < 0.08, "{climb:?}");
    assert!(climb[2] < 300.0, "{climb:?}");
}

/// Where the look-ahead's slice runs changes no bit (docs/management.md): after
/// each answer (`background`: the firmware's serve loop, the bridge) or first
/// thing in the next `handle` (nobody called `background`). Through the 0.20
/// rad/s pull-up, whose snatch load and advisories exercise every branch of the
/// slice, with rejected frames between.
#[test]
fn the_slice_gives_the_same_bits_wherever_it_runs() {
    let system = shipped();
    let messages: Vec<HostMessage> = {
        let select = HostMessage::Command(Command::SelectProfile(Profile::builtin(
            Manoeuvre::PullUp,
            200,
        )));
        let mut m = vec![select];
        for k in 0..=1000u32 {
            let t = 0.01 * f64::from(k);
            let f = AircraftState::<f64>::level(9000.0, 200.0);
            m.push(HostMessage::State(state_frame(k, t, &f)));
            if k % 97 == 5 {
                // Time not increasing: rejected, must not disturb the slices.
                m.push(HostMessage::State(state_frame(k, t, &f)));
            }
        }
        m.push(HostMessage::Command(Command::GetStatus));
        m
    };

    let mut lazy = controller::<f32>(&system);
    let lazy: Vec<DeviceMessage> = messages
        .iter()
        .map(|m| lazy.handle(*m, &mut NoCounter))
        .collect();

    let mut eager = controller::<f32>(&system);
    let mut ran = 0;
    let eager: Vec<DeviceMessage> = messages
        .iter()
        .map(|m| {
            let a = eager.handle(*m, &mut NoCounter);
            ran += eager.background(&mut NoCounter);
            a
        })
        .collect();

    assert!(ran > 2000, "the slices ran ({ran} steps)");
    let advised = lazy
        .iter()
        .any(|a| matches!(a, DeviceMessage::Output(o) if o.management.advisories != 0));
    assert!(advised, "the pull-up is advised");
    let rejected = lazy
        .iter()
        .filter(|a| matches!(a, DeviceMessage::Rejected(_)))
        .count();
    assert_eq!(rejected, 11);
    assert_eq!(lazy, eager, "background after each answer");
}

/// Every Output reports the envelope map's limits at its flight condition:
/// along a level acceleration at 6 km from Mach 0.5 to 0.75, each Output's
/// limits are the map's lookup at the frame's altitude and Mach number, at a
/// grid point the map file's cell (to f32), and between two grid Mach numbers
/// between their cells; the same bits in f32 and f64 up to the precision of
/// the lookup; a controller without a map reports every limit unknown.
#[test]
fn every_output_reports_the_maps_limits_at_its_flight_condition() {
    let config = SystemConfig::builtin().unwrap();
    let system = config.params().unwrap();
    let map = system.limits;
    assert!(!map.pull_up.is_empty() && !map.turn.is_empty() && !map.acceleration.is_empty());
    let speed = |mach: f64| config.mach_to_speed(6000.0, mach).unwrap();
    let path = LevelAcceleration {
        altitude: 6000.0,
        initial_speed: speed(0.5),
        final_speed: speed(0.75),
        start: 1.0,
        acceleration: 8.0,
    };
    let seconds = 1.0 + (speed(0.75) - speed(0.5)) / 8.0 + 0.5;
    let outputs = fly_path::<f32, _>(&system, &path, seconds);
    let outputs64 = fly_path::<f64, _>(&system, &path, seconds);
    assert!(outputs.len() > 100);
    let sound = speed(1.0);
    let mut between = 0;
    // The f64 trim may take another number of frames: pair the Outputs by time.
    for o in &outputs {
        let Some(o64) = outputs64.iter().find(|p| p.time_s == o.time_s) else {
            continue;
        };
        let mach = FlightPath::<f64>::state_at(&path, o.time_s).velocity.norm() / sound;
        let expected = map.at(6000.0f64, mach);
        let got = o.management.limits;
        for (a, b) in [
            (got.pull_up_radps, expected.pull_up_radps),
            (got.turn_radps, expected.turn_radps),
            (got.acceleration_mps2, expected.acceleration_mps2),
            (o64.management.limits.pull_up_radps, expected.pull_up_radps),
        ] {
            assert!(
                (a - b).abs() <= 2e-5 * b.abs().max(1.0),
                "t {}: {a} vs {b} at Mach {mach}",
                o.time_s
            );
        }
        // Halfway between two grid Mach numbers (0.55, 0.65, ...) the nearest
        // cell is a matter of rounding.
        let halfway = ((mach * 10.0).fract() - 0.5).abs() < 1e-4;
        if !halfway {
            assert_eq!(got.limited_by, expected.limited_by, "t {}", o.time_s);
        }
        // The floor: the smallest of the cells weighed, which changes at a
        // grid line (0.5, 0.6, ...: there a rounding decides the side).
        let on_line = ((mach * 10.0) - (mach * 10.0).round()).abs() < 1e-4;
        if !on_line {
            assert_eq!(got.pull_up_floor_radps, expected.pull_up_floor_radps);
            assert_eq!(got.turn_floor_radps, expected.turn_floor_radps);
            assert_eq!(
                got.acceleration_floor_mps2,
                expected.acceleration_floor_mps2
            );
        }
        // (Within 1e-4 of a spacing of a grid line the floor is the line's
        // cells, up to 1e-4 of their difference above the interpolation.)
        assert!(got.pull_up_floor_radps <= got.pull_up_radps + 2e-5);
        assert!(got.turn_floor_radps <= got.turn_radps + 2e-5);
        if (0.52..0.58).contains(&mach) {
            between += 1;
            let low = map.pull_up.at(6000.0f64, 0.5f64).unwrap().0 as f32;
            let high = map.pull_up.at(6000.0f64, f64::from(0.6f32)).unwrap().0 as f32;
            let v = got.pull_up_radps;
            assert!(v >= low.min(high) - 1e-6 && v <= low.max(high) + 1e-6);
        }
    }
    assert!(between > 10, "{between} frames between Mach 0.52 and 0.58");
    // At the start, Mach 0.5 at 6 km: the file's cell.
    let file =
        decoy_config::LimitsFile::parse("built-in", decoy_config::BUILTIN_LIMITS_TOML).unwrap();
    let pull_up = file.pull_up.unwrap();
    let i = pull_up
        .altitudes_m
        .iter()
        .position(|&h| h == 6000.0)
        .unwrap();
    let j = pull_up.machs.iter().position(|&m| m == 0.5).unwrap();
    let cell = pull_up.limits[i][j] as f32;
    assert!((outputs[0].management.limits.pull_up_radps - cell).abs() < 1e-4);

    let mut unmapped = system;
    unmapped.limits = decoy_controller::LimitMap::EMPTY;
    let o = &fly_path::<f32, _>(&unmapped, &path, 0.5)[0];
    assert_eq!(o.management.limits, decoy_link::Limits::UNKNOWN);
}

/// The map on board advises a manoeuvre whose rate is above the map's limit
/// where it was entered, against the requirement that limits it there (with
/// `Advisories::MAP`), on every frame of the manoeuvre; 3 % below the limit it
/// never does, though the pull-up climbs off the cell it started in, and as
/// the map covers that flight no advisory comes at all. The
/// paper's step profiles: the rate jumps at 2 s (the pull-up's stops at 5 s).
#[test]
fn the_map_advises_a_manoeuvre_above_its_limit_where_it_was_entered() {
    let config = SystemConfig::builtin().unwrap();
    let system = config.params().unwrap();
    let cases: [(f64, f64, bool); 2] = [(9000.0, 0.6, true), (12000.0, 0.5, false)];
    for (altitude, mach, pull_up) in cases {
        let speed = config.mach_to_speed(altitude, mach).unwrap();
        let grid = if pull_up {
            &system.limits.pull_up
        } else {
            &system.limits.turn
        };
        let (limit, code) = grid.at(altitude, f64::from(mach as f32)).unwrap();
        let requirement = Requirement::ALL[usize::from(code) - 1];
        for (factor, advised) in [(1.03, true), (0.97, false)] {
            let rate = limit * factor;
            let outputs = if pull_up {
                let path = PullUp {
                    altitude,
                    speed,
                    start: 2.0,
                    rate,
                    duration: 3.0,
                };
                fly_path::<f32, _>(&system, &path, 6.0)
            } else {
                let path = LevelTurn {
                    altitude,
                    speed,
                    start: 2.0,
                    rate,
                    gravity: 9.80665,
                };
                fly_path::<f32, _>(&system, &path, 6.0)
            };
            assert!(outputs.first().is_some_and(|o| o.time_s < 1.5));
            let end = if pull_up { 5.0 } else { f64::INFINITY };
            let mut count = 0;
            for o in &outputs {
                let t = o.time_s;
                let bits = o.management.advisories;
                if (t - 2.0).abs() < 0.015 || (t - end).abs() < 0.015 {
                    continue;
                }
                let expected = advised && t > 2.0 && t < end;
                assert_eq!(
                    bits & Advisories::MAP != 0,
                    expected,
                    "{altitude} m Mach {mach}, {rate} rad/s: t {t}"
                );
                if expected {
                    assert!(bits & requirement.bit() != 0, "t {t}: {bits:#x}");
                    count += 1;
                }
                // Below the limit the map covers the flight: no advisory at
                // all (the look-ahead's bits withheld).
                if !advised {
                    assert_eq!(bits, 0, "{altitude} m Mach {mach}, {rate} rad/s: t {t}");
                }
            }
            assert!(!advised || count > 250, "{count} frames advised");
        }
    }
}
