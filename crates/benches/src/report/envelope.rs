//! The operating envelope's section: the firmware's worst frame over the full
//! grid of `decoy_hil::sweep` (issue 22), per board, per altitude band, per
//! group and per shipped manoeuvre, and its figure
//! (`docs/figures/envelope-worst-frame.{png,svg}`).

use std::fmt::Write as _;

use decoy_plots::{Aspect, Plot, Series};

use super::*;

/// The bound every frame over the envelope must meet on the f32 boards (the M4
/// and the STM32F405): their budget (`decoy_hil::budgets`, issue 22).
pub const F32_FRAME_BOUND: u32 = decoy_hil::budgets::FRAME_F32.limit;
/// The f64 boards' (the M7's) budget.
pub const M7_FRAME_BOUND: u32 = decoy_hil::budgets::FRAME_F64.limit;
/// The boards of the sweep, as the report names them (its tables' columns):
/// every board's label in `firmware/boards.toml`, in the table's order.
pub fn boards() -> Vec<&'static str> {
    decoy_hil::qemu::Board::all()
        .iter()
        .map(|b| b.spec().label())
        .collect()
}

/// A table's separator line: the label column, then one right-aligned column
/// per board.
fn separator(boards: usize) -> String {
    format!("|---|{}", "---:|".repeat(boards))
}

/// The row of a table with nothing measured.
fn not_run(boards: usize) -> String {
    format!("| not run |{}", " - |".repeat(boards))
}

/// One flight of the sweep on one board, as measured.
#[derive(Clone, Debug, PartialEq)]
pub struct EnvelopeFlight {
    /// What it is (`decoy_hil::sweep::Case::label`).
    pub label: String,
    /// Its group's name.
    pub group: String,
    /// State frames.
    pub frames: usize,
    /// Most instructions of a State frame (control step or trim).
    pub worst: u32,
    /// Mean instructions of a control step.
    pub mean: f64,
    /// Frames of the trim and the most instructions of one.
    pub trim: (usize, u32),
    /// Worst frame per altitude band (band index, km).
    pub bands: Vec<(i64, u32)>,
    /// Frames flagged OUTSIDE_ENVELOPE.
    pub outside_envelope: usize,
    /// Frames flagged STEP_LIMITED.
    pub step_limited: usize,
}

/// The sweep on one board.
#[derive(Clone, Debug, PartialEq)]
pub struct EnvelopeBoard {
    /// The board's name.
    pub board: String,
    /// The bound its frames are held to.
    pub bound: u32,
    /// Its flights, or why they were not flown.
    pub flights: Result<Vec<EnvelopeFlight>, String>,
}

impl EnvelopeBoard {
    /// The costliest frame and its flight.
    pub fn worst(&self) -> Option<(u32, &str)> {
        self.flights
            .as_ref()
            .ok()?
            .iter()
            .map(|f| (f.worst, f.label.as_str()))
            .max_by_key(|w| w.0)
    }

    /// Worst frame per altitude band over every flight, sorted by band.
    pub fn bands(&self) -> Vec<(i64, u32)> {
        let mut bands: Vec<(i64, u32)> = Vec::new();
        for f in self.flights.iter().flatten() {
            for &(band, worst) in &f.bands {
                match bands.iter_mut().find(|(b, _)| *b == band) {
                    Some((_, w)) => *w = (*w).max(worst),
                    None => bands.push((band, worst)),
                }
            }
        }
        bands.sort_unstable();
        bands
    }
}

/// The figure: the worst frame per 1 km altitude band, the f32 boards with
/// their bound in one panel, the M7 with its own in another.
pub fn envelope_plot(inputs: &Inputs) -> Vec<Plot> {
    let series = |b: &EnvelopeBoard| Series {
        label: b.board.clone(),
        x: b.bands()
            .iter()
            .map(|(band, _)| *band as f64 + 0.5)
            .collect(),
        y: b.bands().iter().map(|(_, w)| f64::from(*w)).collect(),
    };
    let bound = |value: u32, label: &str| Series {
        label: label.to_owned(),
        x: vec![0.0, 16.0],
        y: vec![f64::from(value); 2],
    };
    let mut plots = Vec::new();
    let f32_boards: Vec<&EnvelopeBoard> = inputs
        .envelope
        .iter()
        .filter(|b| b.bound == F32_FRAME_BOUND && b.flights.is_ok())
        .collect();
    if !f32_boards.is_empty() {
        let mut s: Vec<Series> = f32_boards.iter().map(|b| series(b)).collect();
        s.push(bound(
            F32_FRAME_BOUND,
            &format!("bound {}", thousands(u64::from(F32_FRAME_BOUND))),
        ));
        plots.push(Plot {
            title: "Worst frame per altitude band over the envelope: Cortex-M4F, f32".into(),
            x_label: "aircraft altitude [km] (1 km bands)".into(),
            y_label: "instructions per 10 ms frame".into(),
            series: s,
            aspect: Aspect::Free,
            invert_y: false,
        });
    }
    for b in inputs
        .envelope
        .iter()
        .filter(|b| b.bound != F32_FRAME_BOUND && b.flights.is_ok())
    {
        plots.push(Plot {
            title: format!(
                "Worst frame per altitude band over the envelope: {}, f64",
                b.board
            ),
            x_label: "aircraft altitude [km] (1 km bands)".into(),
            y_label: "instructions per 10 ms frame".into(),
            series: vec![
                series(b),
                bound(b.bound, &format!("bound {}", thousands(u64::from(b.bound)))),
            ],
            aspect: Aspect::Free,
            invert_y: false,
        });
    }
    plots
}

/// The target rows of the envelope (one per board).
pub(super) fn render_envelope_targets(s: &mut String, inputs: &Inputs) -> std::fmt::Result {
    for b in &inputs.envelope {
        match (&b.flights, b.worst()) {
            (Ok(flights), Some((worst, label))) => writeln!(
                s,
                "| every 10 ms frame over the operating envelope ≤ {} instructions, the trim's \
                 included, {} | {} at worst ({label}) over {} flights, {} frames | {} |",
                thousands(u64::from(b.bound)),
                b.board,
                thousands(u64::from(worst)),
                flights.len(),
                thousands(flights.iter().map(|f| f.frames as u64).sum()),
                pass(worst <= b.bound)
            )?,
            (Err(why), _) => writeln!(
                s,
                "| every frame over the envelope ≤ {}, {} | not measured: {} | - |",
                thousands(u64::from(b.bound)),
                b.board,
                one_line(why)
            )?,
            _ => {}
        }
    }
    Ok(())
}

/// The section.
pub(super) fn render_envelope(s: &mut String, inputs: &Inputs) -> std::fmt::Result {
    writeln!(
        s,
        "## The operating envelope (firmware under QEMU `-icount`)"
    )?;
    writeln!(s)?;
    if inputs.envelope.is_empty() {
        writeln!(s, "Not run (`bench-report --no-firmware`).")?;
        writeln!(s)?;
    }
    writeln!(
        s,
        "The full grid of `decoy_hil::sweep` (`Grid::Full`), each flight from its own trim \
         over the decoy link, every frame counted: steady level flight 4 s at every \
         kilometre from 0 to 15 km and at 10.5 and 11.5 km, by Mach 0.30, 0.45, 0.62, 0.80 \
         and 0.95 (a Mach number beyond the envelope's dynamic-pressure bound, below 2.7 km, \
         flown at the bound); every shipped manoeuvre at its full duration (the scenario files: steady, \
         the acceleration, the pull-ups at 0.05, 0.10 and 0.20 rad/s, the turns at 0.10 and \
         0.20 rad/s, the recorded flight); pull-ups and turns at the envelope's load factor \
         (4 g, 2 % inside) or body rate (0.35 rad/s), whichever binds, at 0, 5, 9, 11, 13 \
         and 15 km by Mach 0.3, 0.6 and 0.95 (at sea level 0.95 is the bound's 0.80), 12 s \
         each; a climb and a descent through \
         11 km. The frame is the whole State frame's work (validation, the trim's slice or \
         the RK4 steps, outputs), the trim's frames included. `cargo xtask test` flies a \
         smaller grid and asserts the same bounds (`crates/hil-tests/tests/envelope.rs`)."
    )?;
    writeln!(s)?;
    writeln!(
        s,
        "![worst frame per altitude band](figures/envelope-worst-frame.png)"
    )?;
    writeln!(s)?;
    writeln!(
        s,
        "The worst frame of any flight whose aircraft was in the band at that frame (also \
         `docs/figures/envelope-worst-frame.svg`)."
    )?;
    writeln!(s)?;
    // Per altitude band, one column per board (the same columns whatever ran).
    let board = |name: &str| inputs.envelope.iter().find(|b| b.board == name);
    let mut bands: Vec<i64> = inputs
        .envelope
        .iter()
        .flat_map(|b| b.bands())
        .map(|(k, _)| k)
        .collect();
    bands.sort_unstable();
    bands.dedup();
    write!(s, "| altitude band |")?;
    for name in boards() {
        write!(s, " {name} worst |")?;
    }
    writeln!(s)?;
    writeln!(s, "{}", separator(boards().len()))?;
    if bands.is_empty() {
        writeln!(s, "{}", not_run(boards().len()))?;
    }
    for band in &bands {
        write!(s, "| {band}-{} km |", band + 1)?;
        for name in boards() {
            match board(name).and_then(|b| b.bands().into_iter().find(|(k, _)| k == band)) {
                Some((_, w)) => write!(s, " {} |", thousands(u64::from(w)))?,
                None => write!(s, " - |")?,
            }
        }
        writeln!(s)?;
    }
    writeln!(s)?;
    // Per group and per board.
    writeln!(
        s,
        "Per group: the worst frame, the mean control step, the trim's frames."
    )?;
    writeln!(s)?;
    writeln!(
        s,
        "| board | group | flights | worst frame | mean control step | trim: most frames, worst frame | frames outside the envelope | STEP_LIMITED |"
    )?;
    writeln!(s, "|---|---|---:|---:|---:|---:|---:|---:|")?;
    if inputs.envelope.is_empty() {
        writeln!(s, "| not run | | | | | | | |")?;
    }
    for b in &inputs.envelope {
        let Ok(flights) = &b.flights else {
            writeln!(s, "| {} | not measured | | | | | | |", b.board)?;
            continue;
        };
        let mut groups: Vec<&str> = flights.iter().map(|f| f.group.as_str()).collect();
        groups.dedup();
        for g in groups {
            let of: Vec<&EnvelopeFlight> = flights.iter().filter(|f| f.group == g).collect();
            let mean = of.iter().map(|f| f.mean).sum::<f64>() / of.len() as f64;
            writeln!(
                s,
                "| {} | {g} | {} | {} | {} | {}, {} | {} | {} |",
                b.board,
                of.len(),
                thousands(u64::from(of.iter().map(|f| f.worst).max().unwrap_or(0))),
                thousands(mean.round() as u64),
                of.iter().map(|f| f.trim.0).max().unwrap_or(0),
                thousands(u64::from(of.iter().map(|f| f.trim.1).max().unwrap_or(0))),
                of.iter().map(|f| f.outside_envelope).sum::<usize>(),
                of.iter().map(|f| f.step_limited).sum::<usize>(),
            )?;
        }
    }
    writeln!(s)?;
    writeln!(
        s,
        "Per shipped manoeuvre (the two 0.20 rad/s manoeuvres, 4.7 g and 5.1 g, are beyond \
         the envelope's 4 g: their frames there are flagged OUTSIDE_ENVELOPE and are held to \
         the same bound):"
    )?;
    writeln!(s)?;
    write!(s, "| manoeuvre |")?;
    for name in boards() {
        write!(s, " {name} worst / mean |")?;
    }
    writeln!(s)?;
    writeln!(s, "{}", separator(boards().len()))?;
    let mut shipped: Vec<&str> = Vec::new();
    for f in inputs
        .envelope
        .iter()
        .flat_map(|b| b.flights.iter().flatten())
    {
        if f.group == "shipped" && !shipped.contains(&f.label.as_str()) {
            shipped.push(f.label.as_str());
        }
    }
    if shipped.is_empty() {
        writeln!(s, "{}", not_run(boards().len()))?;
    }
    for label in shipped {
        write!(s, "| {label} |")?;
        for name in boards() {
            match board(name)
                .and_then(|b| b.flights.as_ref().ok())
                .and_then(|f| f.iter().find(|f| f.label == label))
            {
                Some(f) => write!(
                    s,
                    " {} / {} |",
                    thousands(u64::from(f.worst)),
                    thousands(f.mean.round() as u64)
                )?,
                None => write!(s, " - |")?,
            }
        }
        writeln!(s)?;
    }
    writeln!(s)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flight(label: &str, group: &str, worst: u32, bands: Vec<(i64, u32)>) -> EnvelopeFlight {
        EnvelopeFlight {
            label: label.into(),
            group: group.into(),
            frames: 400,
            worst,
            mean: f64::from(worst) - 500.0,
            trim: (1, 57_000),
            bands,
            outside_envelope: 0,
            step_limited: 0,
        }
    }

    /// The section shows each board's worst frame per band and per manoeuvre,
    /// and the target row passes or fails against the bound.
    #[test]
    fn the_envelope_renders_its_bands_and_verdicts() {
        let inputs = Inputs {
            envelope: vec![
                EnvelopeBoard {
                    board: "M4".into(),
                    bound: F32_FRAME_BOUND,
                    flights: Ok(vec![
                        flight("steady 0 m Mach 0.30", "steady", 88_120, vec![(0, 88_120)]),
                        flight(
                            "pull-up 0.10 rad/s (20 s)",
                            "shipped",
                            89_400,
                            vec![(9, 88_480), (10, 89_400)],
                        ),
                    ]),
                },
                EnvelopeBoard {
                    board: "M7".into(),
                    bound: M7_FRAME_BOUND,
                    flights: Ok(vec![flight(
                        "steady 0 m Mach 0.30",
                        "steady",
                        161_000,
                        vec![(0, 161_000)],
                    )]),
                },
            ],
            ..Inputs::default()
        };
        let mut s = String::new();
        render_envelope(&mut s, &inputs).unwrap();
        assert!(s.contains("| 10-11 km | 89,400 | - | - |"), "{s}");
        assert!(
            s.contains("| pull-up 0.10 rad/s (20 s) | 89,400 / 88,900 | - | - |"),
            "{s}"
        );
        let mut t = String::new();
        render_envelope_targets(&mut t, &inputs).unwrap();
        assert!(t.lines().next().unwrap().ends_with("| **pass** |"), "{t}");
        assert!(!t.lines().nth(1).unwrap().ends_with("| **pass** |"), "{t}");
        let plots = envelope_plot(&inputs);
        assert_eq!(plots.len(), 2);
        assert_eq!(plots[0].series.len(), 2);
    }
}
