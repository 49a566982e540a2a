//! The study behind the operating envelope's load-factor limit
//! (`config/reference-system.toml`, `[envelope]`): the f32 controller on the
//! host (the firmware's bits) flies pull-ups and turns at several normal load
//! factors across altitudes and Mach numbers, and prints each flight's peak
//! connection tension, its most RK4 steps in a frame and its frames flagged
//! STEP_LIMITED (more than the nominal four steps: beyond the frame budget).
//!
//! `cargo run --release -p decoy-hil --example envelope_scan [pull-up] [turn]`;
//! the grid from the environment: `LOADS` (g, default 3,4,5), `ALTS` (m,
//! default 0,3000,6000,9000,11000,15000), `MACHS` (default 0.3,0.6,0.95). A
//! pull-up at load factor n rotates at (n - 1) g / V for 5 s; a turn at
//! g sqrt(n² - 1) / V. Each flight 12 s.

use decoy_config::SystemConfig;
use decoy_hil::flight::{frame_count, host_controller, replay, scenario_frames, scenario_messages};
use decoy_link::{DeviceMessage, StatusFlags};
use decoy_sim::{RunOptions, Scenario};

/// The comma-separated numbers of environment variable `name`, or `default`.
fn grid(name: &str, default: &[f64]) -> Vec<f64> {
    match std::env::var(name) {
        Ok(v) => v
            .split(',')
            .map(|x| {
                x.trim()
                    .parse()
                    .unwrap_or_else(|e| panic!("{name}: `{x}` is not a number: {e}"))
            })
            .collect(),
        Err(_) => default.to_vec(),
    }
}

fn main() {
    let config = SystemConfig::builtin().expect("the built-in configuration");
    let args: Vec<String> = std::env::args().skip(1).collect();
    let scenarios: Vec<&str> = if args.is_empty() {
        vec!["pull-up", "turn"]
    } else {
        args.iter().map(String::as_str).collect()
    };
    let loads = grid("LOADS", &[3.0, 4.0, 5.0]);
    let altitudes = grid("ALTS", &[0.0, 3000.0, 6000.0, 9000.0, 11000.0, 15000.0]);
    let machs = grid("MACHS", &[0.3, 0.6, 0.95]);
    let g = config.environment.gravity;
    let t_end = 12.0;
    for name in scenarios {
        for &h in &altitudes {
            for &m in &machs {
                let v = config
                    .mach_to_speed(h, m)
                    .expect("an altitude of the atmosphere");
                for &n in &loads {
                    let rate = if name == "turn" {
                        g * (n * n - 1.0f64).sqrt() / v
                    } else {
                        (n - 1.0) * g / v
                    };
                    let plan = Scenario::builtin(name)
                        .and_then(|s| {
                            s.plan(
                                &config,
                                &RunOptions {
                                    rate: Some(rate),
                                    altitude: Some(h),
                                    mach: Some(m),
                                    t_end: Some(t_end),
                                    plots: false,
                                    ..RunOptions::default()
                                },
                            )
                        })
                        .unwrap_or_else(|e| panic!("{name} at {h} m, Mach {m}: {e}"));
                    let frames = scenario_frames(&plan.profile, frame_count(t_end));
                    let mut controller =
                        host_controller::<f32>(&config).unwrap_or_else(|e| panic!("{e}"));
                    let answers = replay(&mut controller, &scenario_messages(&frames));
                    let (mut peak, mut steps, mut limited, mut rejected) = (0.0f32, 0u16, 0, 0);
                    for a in &answers {
                        match a {
                            DeviceMessage::Output(o) => {
                                peak = peak.max(o.connection_tension_n);
                                steps = steps.max(o.steps);
                                if StatusFlags(o.flags).contains(StatusFlags::STEP_LIMITED) {
                                    limited += 1;
                                }
                            }
                            DeviceMessage::Rejected(_) => rejected += 1,
                            _ => {}
                        }
                    }
                    println!(
                        "{name:8} {h:6.0} m Mach {m:4.2} {n:3.1} g ({rate:6.3} rad/s): peak {peak:8.1} N, \
                         most steps {steps:2}, step-limited frames {limited:4}, rejected {rejected}"
                    );
                }
            }
        }
    }
}
