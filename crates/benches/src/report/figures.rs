//! The log-log scaling figure (`docs/figures/bench-scaling.{png,svg}`).

use decoy_plots::{Aspect, Plot, Series};

use super::*;

/// Points `(log10 N, log10 µs)` of the wall-clock costs `(N, ns)`.
pub(super) fn log_log(label: String, points: &[(u32, f64)]) -> Series {
    Series {
        label,
        x: points.iter().map(|(n, _)| f64::from(*n).log10()).collect(),
        y: points.iter().map(|(_, ns)| (ns / 1e3).log10()).collect(),
    }
}

/// The log-log scaling figure, two panels (pendulum, towed system): log10 of the
/// wall-clock µs per call against log10 N. Series with fewer than two points are
/// left out; so is a panel without any series.
pub fn scaling_plot(inputs: &Inputs) -> Vec<Plot> {
    let mut plots = Vec::new();
    for system in System::ALL {
        let mut series = Vec::new();
        for variant in Variant::ALL {
            let (wall, _) = step_costs(inputs, system, variant);
            if wall.len() >= 2 {
                series.push(log_log(format!("RK4 step, {}", variant.label()), &wall));
            }
        }
        if system == System::Pendulum {
            for (method, label) in [
                ("two_sweep", "tension solve, two-sweep O(N)"),
                ("shooting", "tension solve, shooting O(N)"),
                ("dense", "tension solve, dense O(N^3)"),
            ] {
                let points: Vec<(u32, f64)> = TENSION_SIZES
                    .iter()
                    .filter_map(|&n| {
                        inputs
                            .wall
                            .get(&wall_tension_key(method, n))
                            .map(|&t| (n, t))
                    })
                    .collect();
                if points.len() >= 2 {
                    series.push(log_log(label.into(), &points));
                }
            }
        }
        if series.is_empty() {
            continue;
        }
        let title = match system {
            System::Pendulum => "Pendulum: cost per call (log-log, wall clock)",
            System::Towed => {
                "Towed system, uniform segments: cost per RK4 step (log-log, wall clock)"
            }
        };
        plots.push(Plot {
            title: title.into(),
            x_label: "log10(N)".into(),
            y_label: "log10(time per call / µs)".into(),
            series,
            aspect: Aspect::Free,
            invert_y: false,
        });
    }
    plots
}
