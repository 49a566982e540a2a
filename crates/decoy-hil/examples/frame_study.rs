//! Quick host study: for candidate embedded models (segments, grading) fly every
//! shipped scenario through the f32 host controller (the firmware's bits) and
//! report the RK4 steps per 10 ms frame (most, retries, mean) and the peak
//! tensions against the 300-segment f64 host solution.
//!
//! `cargo run --release -p decoy-hil --example frame_study -- [N:R ...]`

use decoy_config::SystemConfig;
use decoy_hil::flight;
use decoy_link::{DeviceMessage, HostMessage};
use decoy_sim::{RunOptions, Scenario, TraceOptions, trace};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let models: Vec<(usize, f64)> = if args.is_empty() {
        vec![
            (16, 1.3),
            (16, 1.2),
            (16, 1.15),
            (16, 1.1),
            (16, 1.0),
            (12, 1.15),
            (12, 1.0),
        ]
    } else {
        args.iter()
            .map(|a| {
                let (n, r) = a.split_once(':').unwrap();
                (n.parse().unwrap(), r.parse().unwrap())
            })
            .collect()
    };
    let base = SystemConfig::builtin().unwrap();
    let scenarios: [(&str, Option<f64>); 8] = [
        ("steady", None),
        ("acceleration", None),
        ("pull-up", Some(0.05)),
        ("pull-up", Some(0.10)),
        ("pull-up", Some(0.20)),
        ("turn", Some(0.10)),
        ("turn", Some(0.20)),
        ("recorded", None),
    ];
    // The 300-segment f64 reference, sampled every 10 ms.
    let mut references = Vec::new();
    for (name, rate) in scenarios {
        let plan = Scenario::builtin(name)
            .unwrap()
            .plan(
                &base,
                &RunOptions {
                    rate,
                    plots: false,
                    ..RunOptions::default()
                },
            )
            .unwrap();
        let t = std::time::Instant::now();
        let tr = trace(
            &base,
            &plan,
            &TraceOptions {
                sample_interval_s: 0.01,
                ..TraceOptions::default()
            },
            |_| {},
        )
        .unwrap();
        let peak10 = tr
            .samples
            .iter()
            .map(|s| s.tension_connection)
            .fold(0.0, f64::max);
        let tow10 = tr.samples.iter().map(|s| s.tension_tow).fold(0.0, f64::max);
        eprintln!(
            "reference {name} {rate:?}: {} segments, {} steps, t_end {}: peak {:.2} N (every step {:.2}), tow peak {tow10:.2}, stopped {:?} ({:.1} s)",
            plan.layout.count(),
            plan.timeline.rule().name(),
            plan.t_end,
            peak10,
            tr.max_tension_connection_n,
            tr.stopped,
            t.elapsed().as_secs_f64()
        );
        references.push((plan, peak10, tow10, tr.samples));
    }
    for (n, r) in models {
        let mut config = base.clone();
        config.solver.segments_embedded = n;
        config.solver.grading_ratio_embedded = r;
        let shortest = if r == 1.0 {
            config.cable.length / n as f64
        } else {
            config.cable.length * (r - 1.0) / (r.powi(n as i32) - 1.0)
        };
        println!("== {n} segments graded {r} (shortest {shortest:.3} m)");
        for ((name, rate), (plan, peak, tow_peak, samples)) in scenarios.iter().zip(&references) {
            let frames = flight::scenario_frames(&plan.profile, flight::frame_count(plan.t_end));
            let messages = flight::scenario_messages(&frames);
            let mut c = flight::host_controller::<f32>(&config).unwrap();
            let (mut most, mut retries, mut total, mut count, mut executed_max) =
                (0u16, 0, 0u64, 0u64, 0f64);
            let mut peak_c = 0f64;
            let mut peak_t = 0f64;
            let mut rejected = 0;
            let mut below_diff = 0f64;
            for m in &messages {
                let rate_before = c.snapshot().wave_rate;
                // The steps the controller plans for this frame from the previous
                // one's wave-speed rate (docs/protocol.md §5, restated: 2 steps of
                // 5 ms at least, ceil(dt rate / 0.8) in f32, at most 20).
                let predicted = {
                    let w = (0.01f32 * rate_before * (1.0 / 0.8f32)).ceil() as f64;
                    w.clamp(2.0, 20.0)
                };
                let answer = c.handle(*m, &mut decoy_controller::NoCounter);
                match (m, answer) {
                    (HostMessage::State(f), DeviceMessage::Output(o)) => {
                        if f.seq == 0 {
                            continue;
                        }
                        let steps = f64::from(o.steps);
                        // More steps than planned from the previous frame: the
                        // frame was integrated again (docs/protocol.md §5), so the
                        // planned steps were taken too (at least; a failed step
                        // doubles again).
                        let executed = if steps > predicted {
                            retries += 1;
                            steps + predicted
                        } else {
                            steps
                        };
                        executed_max = executed_max.max(executed);
                        most = most.max(o.steps);
                        total += executed as u64;
                        count += 1;
                        peak_c = peak_c.max(f64::from(o.connection_tension_n));
                        peak_t = peak_t.max(f64::from(o.tow_tension_n));
                        if let Some(s) = samples.iter().find(|s| (s.t - f.time_s).abs() < 1e-6) {
                            below_diff = below_diff
                                .max((s.cg[2] - f64::from(o.decoy_position_fp_m[2])).abs());
                        }
                    }
                    (HostMessage::State(_), _) => rejected += 1,
                    _ => {}
                }
            }
            println!(
                "{name:>12} {:>5}: steps max {most:>2} (executed max {executed_max:>2}), retries {retries:>3}, mean {:.2}, rejected {rejected}; peak conn {peak_c:8.2} vs {peak:8.2} ({:+.2} %), peak tow {peak_t:8.2} vs {tow_peak:8.2} ({:+.2} %), decoy below max diff {below_diff:.3} m",
                rate.map_or(String::new(), |r| r.to_string()),
                total as f64 / count as f64,
                100.0 * (peak_c / peak - 1.0),
                100.0 * (peak_t / tow_peak - 1.0),
            );
        }
    }
}
