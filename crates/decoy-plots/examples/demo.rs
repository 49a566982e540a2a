//! Writes demonstration figures for a visual check of `decoy-plots`.
//!
//! `cargo run -p decoy-plots --example demo [STEM]` (default stem `/tmp/decoy-plots-demo`)
//! writes `STEM.png/.svg` (three time series, one with a gap and a spike, 100k points),
//! `STEM-cable.png/.svg` (equal aspect, inverted y) and `STEM-stacked.png/.svg`.

use std::path::PathBuf;

use decoy_plots::{Aspect, Plot, PlotError, Series, write_plot, write_stacked};

fn main() -> Result<(), PlotError> {
    let stem = std::env::args_os()
        .nth(1)
        .map_or_else(|| PathBuf::from("/tmp/decoy-plots-demo"), PathBuf::from);
    let suffixed = |s: &str| {
        let mut name = stem.clone().into_os_string();
        name.push(s);
        PathBuf::from(name)
    };

    let n = 100_000;
    let t: Vec<f64> = (0..n).map(|i| f64::from(i) * 60.0 / f64::from(n)).collect();
    let mut tension: Vec<f64> = t
        .iter()
        .map(|&t| 1200.0 + 150.0 * (0.8 * t).sin() + 20.0 * (13.0 * t).sin())
        .collect();
    tension[61_234] = 2100.0; // one-sample snatch load: must stay visible
    let mut tail: Vec<f64> = t
        .iter()
        .map(|&t| 600.0 + 80.0 * (0.8 * t - 0.6).sin())
        .collect();
    for v in &mut tail[20_000..22_000] {
        *v = f64::NAN; // telemetry gap
    }
    let drag: Vec<f64> = t.iter().map(|&t| 300.0 + 2.0 * t).collect();
    let time_series = Plot {
        title: "Cable tension during a turn".into(),
        x_label: "time [s]".into(),
        y_label: "tension [N]".into(),
        series: vec![
            Series {
                label: "tow point".into(),
                x: t.clone(),
                y: tension,
            },
            Series {
                label: "decoy end (gap 12-13.2 s)".into(),
                x: t.clone(),
                y: tail,
            },
            Series {
                label: "drag".into(),
                x: t.clone(),
                y: drag,
            },
        ],
        aspect: Aspect::Free,
        invert_y: false,
    };
    let [png, svg] = write_plot(&time_series, &stem)?;
    println!("{}\n{}", png.display(), svg.display());

    let s: Vec<f64> = (0..=200).map(|i| f64::from(i) * 1.5).collect();
    let shape = |sag: f64| -> Vec<f64> {
        s.iter()
            .map(|&x| sag * (x / 300.0) + 15.0 * (x / 300.0).powi(2))
            .collect()
    };
    let cable = Plot {
        title: "Cable shape (equal aspect, depth down)".into(),
        x_label: "behind tow point [m]".into(),
        y_label: "depth below tow point [m]".into(),
        series: vec![
            Series {
                label: "straight and level".into(),
                x: s.clone(),
                y: shape(10.0),
            },
            Series {
                label: "in the turn".into(),
                x: s.clone(),
                y: shape(40.0),
            },
            Series {
                label: "decoy".into(),
                x: vec![300.0],
                y: vec![55.0],
            },
        ],
        aspect: Aspect::Equal,
        invert_y: true,
    };
    let [png, svg] = write_plot(&cable, &suffixed("-cable"))?;
    println!("{}\n{}", png.display(), svg.display());

    let short: Vec<f64> = t.iter().step_by(100).copied().collect();
    let panel = |title: &str, y_label: &str, f: &dyn Fn(f64) -> f64| Plot {
        title: title.into(),
        x_label: "time [s]".into(),
        y_label: y_label.into(),
        series: vec![Series {
            label: title.into(),
            x: short.clone(),
            y: short.iter().map(|&t| f(t)).collect(),
        }],
        aspect: Aspect::Free,
        invert_y: false,
    };
    let stacked = [
        panel("Altitude", "altitude [m]", &|t| {
            3000.0 + 50.0 * (0.1 * t).sin()
        }),
        panel("Tension", "tension [kN]", &|t| 1.2 + 0.15 * (0.8 * t).sin()),
        panel("Decoy depth", "depth [m]", &|t| {
            0.002 * (0.3 * t).cos() + 1e-3
        }),
    ];
    let [png, svg] = write_stacked(&stacked, &suffixed("-stacked"))?;
    println!("{}\n{}", png.display(), svg.display());
    Ok(())
}
