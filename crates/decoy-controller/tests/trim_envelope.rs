//! The onboard trim over the declared operating envelope (`[envelope]` of the
//! reference configuration: 0-15 km, Mach 0.3-0.95): it converges everywhere in
//! f32 and in f64, the two agree, and its work fits the frames the controller
//! spreads it over ([`TRIM_SLICE_UNITS`] per frame in f32, at most two
//! frames; [`TRIM_SLICE_UNITS_F64`] in f64, at most six), on a grid of 500 m
//! and Mach 0.05 with the tropopause's neighbours and the envelope's corners.

use decoy_config::SystemConfig;
use decoy_controller::{TRIM_SLICE_UNITS, TRIM_SLICE_UNITS_F64};
use solver_core::{AircraftState, Real, Solver, State, TrimTask, Uniform};

const N: usize = 16;

/// The trim at `altitude` and `mach` in `T`: its work units and the connection
/// and towing-point tensions, N.
fn trim<T: Real>(config: &SystemConfig, altitude: f64, mach: f64) -> (u64, f64, f64) {
    let model = config.model::<T, N>(config.embedded_layout()).unwrap();
    let speed = config.mach_to_speed(altitude, mach).unwrap();
    let aircraft = AircraftState::<T>::level(T::lit(altitude), T::lit(speed));
    let mut state = State::<T, N>::default();
    let mut task = TrimTask::start(&model, &aircraft, &mut state).unwrap();
    loop {
        match task.advance(&model, &mut state, u32::MAX) {
            Ok(true) => break,
            Ok(false) => {}
            Err(e) => panic!(
                "{altitude} m Mach {mach} in {}: {e:?}",
                core::any::type_name::<T>()
            ),
        }
    }
    let mut solver = Solver::new(model, state).unwrap();
    let out = solver.outputs(&Uniform { initial: aircraft }).unwrap();
    let n = out.segment_count();
    (
        task.spent(),
        out.tension(0).to_f64(),
        out.tension(n).to_f64(),
    )
}

#[test]
fn the_trim_converges_everywhere_in_the_envelope_within_its_frames() {
    let config = SystemConfig::builtin().unwrap();
    let e = &config.envelope;
    let mut altitudes: Vec<f64> = (0..=30).map(|k| 500.0 * f64::from(k)).collect();
    altitudes.extend([10_900.0, 10_990.0, 11_010.0, 11_100.0]);
    let mut machs: Vec<f64> = (0..=13).map(|k| 0.3 + 0.05 * f64::from(k)).collect();
    machs.push(e.mach[1]);
    let (mut most32, mut most64) = ((0, 0.0, 0.0), (0, 0.0, 0.0));
    let mut worst_diff = 0.0f64;
    for &h in &altitudes {
        assert!(h >= e.altitude_m[0] && h <= e.altitude_m[1]);
        for &m in &machs {
            let m = m.min(e.mach[1]);
            let (u32_, t0_32, tn_32) = trim::<f32>(&config, h, m);
            let (u64_, t0_64, tn_64) = trim::<f64>(&config, h, m);
            if u32_ > most32.0 {
                most32 = (u32_, h, m);
            }
            if u64_ > most64.0 {
                most64 = (u64_, h, m);
            }
            let diff = ((t0_32 - t0_64) / t0_64)
                .abs()
                .max(((tn_32 - tn_64) / tn_64).abs());
            worst_diff = worst_diff.max(diff);
            assert!(
                diff < 5e-4,
                "{h} m Mach {m}: f32 tensions {t0_32}/{tn_32} N, f64 {t0_64}/{tn_64} N"
            );
        }
    }
    println!(
        "trim work: f32 at most {} units ({} m, Mach {:.2}), f64 at most {} ({} m, Mach {:.2}); \
         {TRIM_SLICE_UNITS} (f32) and {TRIM_SLICE_UNITS_F64} (f64) per frame; f32 and f64 tensions within {worst_diff:.1e}",
        most32.0, most32.1, most32.2, most64.0, most64.1, most64.2
    );
    assert!(
        most32.0 <= 2 * u64::from(TRIM_SLICE_UNITS),
        "f32 trim over more than two frames: {most32:?}"
    );
    assert!(
        most64.0 <= 6 * u64::from(TRIM_SLICE_UNITS_F64),
        "f64 trim over more than six frames: {most64:?}"
    );
}
