//! Host study: which embedded models, integrated with which fixed RK4 step, stay
//! within issue 14's 2 % of the host model? For candidate models (segments,
//! grading) and steps, every shipped manoeuvre is integrated in f64 along the
//! very frames a controller receives ([`decoy_hil::flight::frame_reference`]:
//! the controller's `FramePath`, fixed steps, no wave-speed rule), and the peak
//! connection tension at the frame times is compared with the 300 uniform
//! segments' at 0.125 ms (converged). `FAIL`: the integration failed (diverged).
//!
//! `cargo run --release -p decoy-hil --example step_study -- [N:R,... [STEP_S,...]]`
//! (default: 16:1.3,16:1.2,16:1.15 at 0.000125,0.001,0.0025,0.005; about a minute).
//! The numbers behind firmware/README.md, "The worst frame and the accuracy".

use decoy_config::SystemConfig;
use decoy_hil::flight;
use solver_core::SegmentLayout;

/// The reference's step, s.
const REFERENCE_STEP_S: f64 = 0.000125;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let models: Vec<(usize, f64)> = args
        .first()
        .map_or("16:1.3,16:1.2,16:1.15", String::as_str)
        .split(',')
        .map(|a| {
            let (n, r) = a
                .split_once(':')
                .unwrap_or_else(|| panic!("{a:?}: a model is N:R"));
            (
                n.parse().unwrap_or_else(|e| panic!("{n:?}: {e}")),
                r.parse().unwrap_or_else(|e| panic!("{r:?}: {e}")),
            )
        })
        .collect();
    let steps: Vec<f64> = args
        .get(1)
        .map_or("0.000125,0.001,0.0025,0.005", String::as_str)
        .split(',')
        .map(|s| s.parse().unwrap_or_else(|e| panic!("{s:?}: {e}")))
        .collect();
    let config = SystemConfig::builtin().unwrap_or_else(|e| panic!("{e}"));
    let peak = |v: Vec<f64>| v.into_iter().fold(0.0, f64::max);
    let mut references = Vec::new();
    let mut all_frames = Vec::new();
    for (kind, rate, t_end) in flight::SHIPPED_MANOEUVRES {
        let name = kind.name();
        let (_, frames) =
            flight::builtin_frames(&config, name, rate, t_end).unwrap_or_else(|e| panic!("{e}"));
        let reference = flight::frame_reference(
            &config,
            &frames,
            SegmentLayout::Uniform {
                count: config.solver.segments_host,
            },
            REFERENCE_STEP_S,
        )
        .unwrap_or_else(|e| panic!("{e}"));
        references.push(peak(reference));
        all_frames.push(frames);
    }
    println!(
        "| model | step | steady | acceleration | pull-up 0.05 | pull-up 0.10 | pull-up 0.20 | turn 0.10 | turn 0.20 | recorded | worst |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    for &(n, r) in &models {
        let layout = if r == 1.0 {
            SegmentLayout::Uniform { count: n }
        } else {
            SegmentLayout::Graded { count: n, ratio: r }
        };
        for &h in &steps {
            let mut line = format!("| {n} graded {r} | {:.3} ms |", h * 1e3);
            let mut worst = 0.0f64;
            for (frames, reference) in all_frames.iter().zip(&references) {
                match flight::frame_reference(&config, frames, layout, h) {
                    Ok(v) => {
                        let e = peak(v) / reference - 1.0;
                        // A non-finite peak is the worst of all.
                        if e.is_nan() || e.abs() > worst.abs() {
                            worst = if e.is_nan() { f64::INFINITY } else { e };
                        }
                        line += &format!(" {:+.2} % |", e * 100.0);
                    }
                    Err(_) => {
                        worst = f64::INFINITY;
                        line += " FAIL |";
                    }
                }
            }
            println!("{line} {:+.2} % |", worst * 100.0);
        }
    }
}
