//! The report's figures, and the PNG recompression that keeps them small.

use decoy_plots::{Plot, Series};

use crate::sweep::{plot, trim_number};
use decoy_sim::error::SimError;
use decoy_sim::format::describe_layout;
use decoy_sim::trace::Trace;

use super::data::{Data, Manoeuvre};

pub(super) fn series(
    label: String,
    trace: &Trace,
    y: impl Fn(&decoy_sim::record::Sample) -> f64,
) -> Series {
    Series {
        label,
        x: trace.samples.iter().map(|s| s.t).collect(),
        y: trace.samples.iter().map(y).collect(),
    }
}

pub(super) fn figures(data: &Data) -> Vec<(String, Vec<Plot>)> {
    let mut figures: Vec<(String, Vec<Plot>)> = Vec::new();
    for (prefix, sweep) in [("speed", &data.speed), ("altitude", &data.altitude)] {
        for (stem, panels) in sweep.plots() {
            figures.push((format!("{prefix}-{stem}"), panels));
        }
    }
    if let Some(row) = data.study.reference_row() {
        let t = &row.trace;
        figures.push((
            "acceleration".to_owned(),
            vec![
                plot(
                    format!(
                        "Acceleration, {} uniform segments: cable tension",
                        row.segments
                    ),
                    "t [s]",
                    "tension [N]",
                    vec![
                        series("connection point".into(), t, |s| s.tension_connection),
                        series("towing point".into(), t, |s| s.tension_tow),
                    ],
                ),
                plot(
                    "Acceleration: decoy pitch".to_owned(),
                    "t [s]",
                    "pitch [deg]",
                    vec![series("pitch".into(), t, |s| s.euler_deg[1])],
                ),
            ],
        ));
    }
    let rate_label = |m: &Manoeuvre| format!("{} rad/s", trim_number(m.rate, 2));
    let pull = |title: &str, y_label: &str, y: fn(&decoy_sim::record::Sample) -> f64| {
        plot(
            title.to_owned(),
            "t [s]",
            y_label,
            data.pull_ups
                .iter()
                .map(|m| series(rate_label(m), &m.trace, y))
                .collect(),
        )
    };
    let embedded = describe_layout(&data.embedded);
    figures.push((
        "pull-up".to_owned(),
        vec![
            pull(
                &format!("Pull-up at Mach 0.6 ({embedded}): connection tension"),
                "tension [N]",
                |s| s.tension_connection,
            ),
            pull(
                "Pull-up: cable clearance to the exhaust plume (negative: inside)",
                "clearance [m]",
                |s| s.exhaust_clearance,
            ),
            pull(
                "Pull-up: decoy CG below the flight path",
                "below [m]",
                |s| s.cg[2],
            ),
        ],
    ));
    let mut tension: Vec<Series> = data
        .turns
        .iter()
        .map(|m| series(rate_label(m), &m.trace, |s| s.tension_connection))
        .collect();
    if let Some(first) = data.turns.first() {
        let t_end = first.trace.last().t;
        tension.push(Series {
            label: "straight flight".into(),
            x: vec![0.0, t_end],
            y: vec![data.straight_tension; 2],
        });
    }
    let host = describe_layout(&data.host);
    figures.push((
        "turn".to_owned(),
        vec![
            plot(
                format!(
                    "Level turn at Mach {} ({host}): connection tension",
                    trim_number(data.turn_mach, 2)
                ),
                "t [s]",
                "tension [N]",
                tension,
            ),
            plot(
                "Level turn: decoy CG outside the flight path".to_owned(),
                "t [s]",
                "outward [m]",
                data.turns
                    .iter()
                    .map(|m| series(rate_label(m), &m.trace, |s| s.cg[1]))
                    .collect(),
            ),
        ],
    ));
    for (stem, panels) in data.pull_up_limit.plots() {
        figures.push((format!("pull-up-limit-{stem}"), panels));
    }
    for (prefix, sweep) in [
        ("tow-point", &data.tow_point),
        ("cg", &data.cg),
        ("weak-tow-point", &data.weak_tow_point),
        ("weak-cg", &data.weak_cg),
    ] {
        for (stem, panels) in sweep.plots() {
            figures.push((format!("{prefix}-{stem}"), panels));
        }
    }
    for (stem, panels) in data.static_margin.plots() {
        figures.push((format!("static-margin-{stem}"), panels));
    }
    for (stem, panels) in data.study.plots() {
        figures.push((format!("discretisation-{stem}"), panels));
    }
    figures
}

/// Re-encodes the PNG at `path` with the best deflate compression and adaptive
/// filtering: the same pixels in about a quarter of the bytes (the report's
/// figures stay small in the repository). Deterministic.
pub fn recompress_png(path: &std::path::Path) -> Result<(), SimError> {
    let failed = |message: String| SimError::Plot {
        stem: path.with_extension(""),
        message,
    };
    let data = std::fs::read(path).map_err(|source| SimError::Io {
        action: "read",
        path: path.to_owned(),
        source,
    })?;
    let mut reader = png::Decoder::new(std::io::Cursor::new(&data))
        .read_info()
        .map_err(|e| failed(format!("cannot decode {}: {e}", path.display())))?;
    let mut pixels = vec![0; reader.output_buffer_size()];
    let frame = reader
        .next_frame(&mut pixels)
        .map_err(|e| failed(format!("cannot decode {}: {e}", path.display())))?;
    let (colour, depth) = reader.output_color_type();
    let mut out = Vec::with_capacity(data.len() / 2);
    {
        let mut encoder = png::Encoder::new(&mut out, frame.width, frame.height);
        encoder.set_color(colour);
        encoder.set_depth(depth);
        encoder.set_compression(png::Compression::Best);
        encoder.set_adaptive_filter(png::AdaptiveFilterType::Adaptive);
        let mut writer = encoder
            .write_header()
            .map_err(|e| failed(format!("cannot encode {}: {e}", path.display())))?;
        writer
            .write_image_data(&pixels[..frame.buffer_size()])
            .map_err(|e| failed(format!("cannot encode {}: {e}", path.display())))?;
    }
    if out.len() < data.len() {
        write_text_bytes(path, &out)?;
    }
    Ok(())
}

/// Writes `bytes` to `path`, whole ([`decoy_sim::atomic`]).
pub(super) fn write_text_bytes(path: &std::path::Path, bytes: &[u8]) -> Result<(), SimError> {
    decoy_sim::atomic::write_atomically(path, bytes).map_err(|source| SimError::Io {
        action: "write",
        path: path.to_owned(),
        source,
    })
}
