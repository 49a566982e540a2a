//! Decoy management in steady flight over the declared operating envelope
//! (`[envelope]`: 0 to 15 km, Mach 0.3 to 0.95): every monitor normal and no
//! advisory, on the host model (300 uniform segments) and on the embedded one
//! (12 graded 1.26, what the controller flies), at the envelope's corners and
//! centre and at 16 conditions of a Halton sequence over it (not chosen to
//! pass), every 10 ms row of 2 s (the posture window) from the trim.
//!
//! The one exception is the known corner where the cable itself nears or
//! passes its allowable tension in steady flight: dynamic pressure above about
//! 47 kPa (low altitude, high Mach: 1,200 N, the allowable, at sea level and
//! Mach 0.95; docs/management.md), where the tension monitor is at caution or
//! worse, as it should be. The test excuses the tension above
//! [`CORNER_Q_PA`] and checks that it is not normal above [`OVER_Q_PA`], so
//! that the corner is stated, not hidden: the declared envelope does not yet
//! exclude it (a dynamic pressure bound in `[envelope]` is open work).

use decoy_config::SystemConfig;
use decoy_schema::Requirement;
use decoy_sim::{InitialState, RunOptions, Scenario, simulate_recorded};

/// The i-th point (from 1) of the radical inverse in `base`: in [0, 1).
fn halton(mut i: u32, base: u32) -> f64 {
    let (mut f, mut r) = (1.0, 0.0);
    while i > 0 {
        f /= f64::from(base);
        r += f * f64::from(i % base);
        i /= base;
    }
    r
}

/// Dynamic pressure above which the steady tension may be at caution, Pa
/// (measured: normal at 45.3 kPa, sea level Mach 0.8, 346 N of margin;
/// caution at 48.9 kPa, 937.5 m Mach 0.878, 281 N).
const CORNER_Q_PA: f64 = 46_000.0;
/// Dynamic pressure above which the steady tension is at caution or worse, Pa.
const OVER_Q_PA: f64 = 50_000.0;

#[test]
fn steady_flight_is_normal_over_the_envelope() {
    let config = SystemConfig::builtin().unwrap();
    let [h0, h1] = config.envelope.altitude_m;
    let [m0, m1] = config.envelope.mach;
    let mut conditions = vec![
        (h0, m0),
        (h0, m1),
        (h1, m0),
        (h1, m1),
        (0.5 * (h0 + h1), 0.5 * (m0 + m1)),
    ];
    conditions.extend((1..=16).map(|i| {
        let h = h0 + (h1 - h0) * halton(i, 2);
        let m = m0 + (m1 - m0) * halton(i, 3);
        ((h * 10.0).round() / 10.0, (m * 1000.0).round() / 1000.0)
    }));
    let steady = Scenario::builtin("steady").unwrap();
    let mut failures = Vec::new();
    let mut corner_seen = false;
    for (segments, grading) in [(config.solver.segments_host, 1.0), (12, 1.26)] {
        for &(altitude, mach) in &conditions {
            let options = RunOptions {
                segments: Some(segments),
                grading: Some(grading),
                t_end: Some(2.0),
                altitude: Some(altitude),
                mach: Some(mach),
                initial: InitialState::Trim,
                plots: false,
                ..RunOptions::default()
            };
            let recording = simulate_recorded(&config, &steady, &options, |_| {}, || None).unwrap();
            assert!(recording.ended.is_none(), "{altitude} m, Mach {mach}");
            let speed = config.mach_to_speed(altitude, mach).unwrap();
            let density = config.atmosphere::<f64>().at(altitude).unwrap().density;
            let q = 0.5 * density * speed * speed;
            let corner = q > CORNER_Q_PA;
            for sample in &recording.samples {
                let m = &sample.management;
                for r in Requirement::ALL {
                    let excused = r == Requirement::Tension && corner;
                    let advised = m.advisories & r.bit() != 0;
                    if !excused && (m.levels[r] != 0 || advised) {
                        failures.push(format!(
                            "{segments} segments, {altitude} m, Mach {mach}, t {} s: {} level {} (margin {}), advised {advised}",
                            sample.t,
                            r.name(),
                            m.levels[r],
                            m.margins[r]
                        ));
                    }
                }
            }
            if q > OVER_Q_PA {
                corner_seen = true;
                let last = recording.samples.last().unwrap();
                assert_ne!(
                    last.management.levels[Requirement::Tension],
                    0,
                    "{altitude} m, Mach {mach}: the corner's tension is expected over its caution"
                );
            }
        }
    }
    failures.dedup_by(|a, b| a.split(", t ").next() == b.split(", t ").next());
    assert!(
        failures.is_empty(),
        "not normal in steady flight:\n{}",
        failures.join("\n")
    );
    assert!(
        corner_seen,
        "the envelope's corner (0 m, Mach 0.95) is among the conditions"
    );
}
