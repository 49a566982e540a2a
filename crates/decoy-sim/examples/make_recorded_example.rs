//! Writes `scenarios/recorded-example.csv`, the recorded flight the shipped
//! `recorded` scenario uses: Mach 0.6 at 9 km heading north; a pull-up at
//! 0.1 rad/s from 1 s to 3 s into an 11.5 deg climb; a roll into a right turn
//! between 4 s and 5 s (bank to 45 deg, heading rate g tan(bank) / V), then the
//! climbing turn to the end at 10 s. Sampled at 50 Hz.
//!
//! ```sh
//! cargo run -p decoy-sim --example make_recorded_example [-- OUTPUT.csv]
//! ```
//!
//! The heading and position are integrated with RK4 on 0.1 ms steps, so the
//! recorded positions follow the recorded velocities to far below the file's
//! micrometre resolution.

use std::fmt::Write as _;
use std::path::PathBuf;

use decoy_config::SystemConfig;
use nalgebra::{UnitQuaternion, Vector3};

const ALTITUDE_M: f64 = 9000.0;
const MACH: f64 = 0.6;
const SAMPLE_HZ: f64 = 50.0;
const DURATION_S: f64 = 10.0;
const SUBSTEPS: usize = 200;
const BANK_DEG: f64 = 45.0;

/// `value` with `decimals` decimals, never "-0.000".
fn fixed(value: f64, decimals: usize) -> String {
    let s = format!("{value:.decimals$}");
    if s.starts_with('-') && s[1..].chars().all(|c| c == '0' || c == '.') {
        s[1..].to_owned()
    } else {
        s
    }
}

/// Flight-path angle rate, rad/s.
fn gamma_rate(t: f64) -> f64 {
    if (1.0..3.0).contains(&t) { 0.1 } else { 0.0 }
}

/// Flight-path angle, rad.
fn gamma(t: f64) -> f64 {
    (t.clamp(1.0, 3.0) - 1.0) * 0.1
}

/// Bank angle and its rate.
fn bank(t: f64) -> (f64, f64) {
    let max = BANK_DEG.to_radians();
    if t < 4.0 {
        (0.0, 0.0)
    } else if t < 5.0 {
        ((t - 4.0) * max, max)
    } else {
        (max, 0.0)
    }
}

/// d(position, heading)/dt.
fn derivative(t: f64, heading: f64, speed: f64, gravity: f64) -> (Vector3<f64>, f64) {
    let g = gamma(t);
    let velocity = Vector3::new(g.cos() * heading.cos(), g.cos() * heading.sin(), -g.sin()) * speed;
    let heading_rate = gravity * bank(t).0.tan() / speed;
    (velocity, heading_rate)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args().nth(1).map_or_else(
        || PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../scenarios/recorded-example.csv"),
        PathBuf::from,
    );
    let config = SystemConfig::builtin()?;
    let speed = config.mach_to_speed(ALTITUDE_M, MACH)?;
    let gravity = config.environment.gravity;

    let mut text = String::new();
    writeln!(
        text,
        "# Example recorded flight for the `recorded` scenario (written by\n# `cargo run -p decoy-sim --example make_recorded_example`): Mach {MACH} at {ALTITUDE_M} m\n# heading north; pull-up 0.1 rad/s 1-3 s into a climb, roll into a {BANK_DEG} deg\n# right turn 4-5 s, climbing turn held to {DURATION_S} s. {SAMPLE_HZ} Hz.\n# Columns: docs/outputs.md (NED position and velocity of the aircraft reference\n# point, body-to-NED quaternion scalar first, body rates p q r)."
    )?;
    writeln!(text, "{}", decoy_sim::RECORDED_COLUMNS.join(","))?;

    let mut position = Vector3::new(0.0, 0.0, -ALTITUDE_M);
    let mut heading = 0.0_f64;
    let samples = (DURATION_S * SAMPLE_HZ).round() as usize;
    let h = 1.0 / SAMPLE_HZ / SUBSTEPS as f64;
    for k in 0..=samples {
        let t = k as f64 / SAMPLE_HZ;
        let g = gamma(t);
        let (phi, phi_rate) = bank(t);
        let (velocity, psi_rate) = derivative(t, heading, speed, gravity);
        let theta_rate = gamma_rate(t);
        let attitude = UnitQuaternion::from_euler_angles(phi, g, heading);
        let q = attitude.quaternion();
        // Body rates from the ZYX Euler angle rates.
        let p = phi_rate - psi_rate * g.sin();
        let q_rate = theta_rate * phi.cos() + psi_rate * g.cos() * phi.sin();
        let r = -theta_rate * phi.sin() + psi_rate * g.cos() * phi.cos();
        let mut row = format!("{t}");
        for (value, decimals) in [
            (position.x, 6),
            (position.y, 6),
            (position.z, 6),
            (velocity.x, 6),
            (velocity.y, 6),
            (velocity.z, 6),
            (q.w, 9),
            (q.i, 9),
            (q.j, 9),
            (q.k, 9),
            (p, 9),
            (q_rate, 9),
            (r, 9),
        ] {
            row.push(',');
            row.push_str(&fixed(value, decimals));
        }
        writeln!(text, "{row}")?;
        if k == samples {
            break;
        }
        // Integrate to the next sample.
        for i in 0..SUBSTEPS {
            let t0 = t + i as f64 * h;
            let (v1, w1) = derivative(t0, heading, speed, gravity);
            let (v2, w2) = derivative(t0 + 0.5 * h, heading + 0.5 * h * w1, speed, gravity);
            let (v3, w3) = derivative(t0 + 0.5 * h, heading + 0.5 * h * w2, speed, gravity);
            let (v4, w4) = derivative(t0 + h, heading + h * w3, speed, gravity);
            position += (v1 + v2 * 2.0 + v3 * 2.0 + v4) * (h / 6.0);
            heading += (w1 + 2.0 * w2 + 2.0 * w3 + w4) * (h / 6.0);
        }
    }
    std::fs::write(&out, text)?;
    println!("wrote {} ({} samples)", out.display(), samples + 1);
    Ok(())
}
