//! What a streamed run writes besides its summary: `timeseries.csv` (the
//! controller's outputs beside the host's f64 replay, docs/outputs.md), the
//! outputs as `decoy simulate` samples for the summary and the plots, and `decoy
//! hil`'s instruction-count plot.

use std::path::{Path, PathBuf};

use decoy_hil::flight;
use decoy_hil::qemu::Board;
use decoy_link::{AircraftStateFrame, DeviceMessage, OutputFrame};
use decoy_schema::Quantity;
use decoy_schema::columns::HIL_TIMESERIES;
use decoy_sim::atomic::write_atomically;
use decoy_sim::{Cell, INSTRUCTIONS_PLOT, Sample, csv_row};

/// The frames answered by an output on both sides, with both outputs, matched by
/// `seq`.
pub fn paired_rows(
    frames: &[AircraftStateFrame],
    firmware: &[DeviceMessage],
    host: &[DeviceMessage],
) -> Vec<(AircraftStateFrame, OutputFrame, OutputFrame)> {
    let host_outputs = flight::outputs(host);
    flight::outputs(firmware)
        .into_iter()
        .filter_map(|fw| {
            let frame = frames.iter().find(|f| f.seq == fw.seq)?;
            let host = host_outputs.iter().find(|h| h.seq == fw.seq)?;
            Some((*frame, fw, *host))
        })
        .collect()
}

/// One output as a `decoy simulate` sample (flight-path frame, degrees; angles
/// relative to the flight-path frame; the closest point's position along the
/// cable is not reported by the controller: NaN).
pub fn sample(out: &OutputFrame, frame: &AircraftStateFrame, lateral_sign: f64) -> Sample {
    let p = out.decoy_position_fp_m.map(f64::from);
    let e = out.decoy_euler_rel_rad.map(|a| f64::from(a).to_degrees());
    let v = frame.velocity_ned_mps.map(f64::from);
    Sample {
        t: out.time_s,
        tension_connection: f64::from(out.connection_tension_n),
        tension_tow: f64::from(out.tow_tension_n),
        // `0.0 - x`, not `-x`: no negative zero in the files.
        cg: [0.0 - p[0], (0.0 - p[1]) * lateral_sign + 0.0, p[2]],
        euler_deg: e,
        aoa_deg: f64::from(out.angle_of_attack_rad).to_degrees(),
        exhaust_clearance: f64::from(out.cable_clearance_exhaust_m),
        exhaust_along: f64::NAN,
        decoy_clearance: f64::from(out.decoy_clearance_aircraft_m),
        speed: (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt(),
        altitude: -frame.position_ned_m[2],
        management: decoy_sim::ManagementSample::of_report(&out.management),
    }
}

/// The cell of the column holding `quantity` in `decoy hil`'s `timeseries.csv`
/// (`decoy_schema::columns::HIL_TIMESERIES`) for the frame whose controller's
/// Output is `controller`, measured as `sample`, beside the host's `host`
/// (`None`: not a column of the file).
pub fn timeseries_cell(
    controller: &OutputFrame,
    sample: &Sample,
    host: &Sample,
    quantity: Quantity,
) -> Option<Cell> {
    Some(match quantity {
        Quantity::Seq => Cell::Count(u64::from(controller.seq)),
        Quantity::Flags => Cell::Count(u64::from(controller.flags)),
        Quantity::Rk4Steps => Cell::Count(u64::from(controller.steps)),
        Quantity::Instructions => Cell::Count(u64::from(controller.instructions)),
        Quantity::HostTensionConnection => Cell::Value(host.tension_connection),
        Quantity::HostTensionTow => Cell::Value(host.tension_tow),
        Quantity::HostDecoyPitch => Cell::Value(host.euler_deg[1]),
        Quantity::HostDecoyAoa => Cell::Value(host.aoa_deg),
        Quantity::TensionConnectionDiff => {
            Cell::Value(sample.tension_connection - host.tension_connection)
        }
        Quantity::TensionTowDiff => Cell::Value(sample.tension_tow - host.tension_tow),
        Quantity::PredictionSteps => Cell::Count(u64::from(controller.prediction_steps)),
        Quantity::ManagementInstructions => {
            Cell::Count(u64::from(controller.management_instructions))
        }
        Quantity::LimitPullUp => Cell::Value(f64::from(controller.management.limits.pull_up_radps)),
        Quantity::LimitTurn => Cell::Value(f64::from(controller.management.limits.turn_radps)),
        Quantity::LimitAcceleration => {
            Cell::Value(f64::from(controller.management.limits.acceleration_mps2))
        }
        Quantity::LimitFloorPullUp => {
            Cell::Value(f64::from(controller.management.limits.pull_up_floor_radps))
        }
        Quantity::LimitFloorTurn => {
            Cell::Value(f64::from(controller.management.limits.turn_floor_radps))
        }
        Quantity::LimitFloorAcceleration => Cell::Value(f64::from(
            controller.management.limits.acceleration_floor_mps2,
        )),
        // The closest point along the cable is not in the controller's Output.
        Quantity::CableExhaustClosestAlong => return None,
        other => return sample.cell(other),
    })
}

/// Writes `decoy hil`'s `timeseries.csv` (`decoy_schema::columns::HIL_TIMESERIES`):
/// the controller's outputs (`firmware`), the host's (`host`) and their
/// differences, one row per element of `rows` (`decoy feed`'s file too).
pub fn write_timeseries(
    path: &Path,
    rows: &[(AircraftStateFrame, OutputFrame, OutputFrame)],
    firmware: &[Sample],
    host: &[Sample],
) -> Result<(), String> {
    let mut text = String::with_capacity(rows.len() * 256);
    text.push_str(&HIL_TIMESERIES.header().to_string());
    text.push('\n');
    for (((_, fw, _), s), h) in rows.iter().zip(firmware).zip(host) {
        text.push_str(&csv_row(&HIL_TIMESERIES, |q| timeseries_cell(fw, s, h, q)));
    }
    write_atomically(path, text.as_bytes())
        .map_err(|e| format!("cannot write {}: {e}", path.display()))
}

/// Draws the instructions of every control step against time (the trim frame
/// left out), with the board's frame budget ([`decoy_hil::budgets::frame`]) for
/// comparison.
pub fn instructions_plot(
    name: &str,
    board: Board,
    rows: &[(AircraftStateFrame, OutputFrame, OutputFrame)],
    dir: &Path,
) -> Result<Vec<PathBuf>, String> {
    let steps: Vec<&OutputFrame> = rows
        .iter()
        .map(|(_, o, _)| o)
        .filter(|o| o.steps > 0)
        .collect();
    let t: Vec<f64> = steps.iter().map(|o| o.time_s).collect();
    let mut series = vec![decoy_plots::Series {
        label: format!("firmware ({board})"),
        x: t.clone(),
        y: steps.iter().map(|o| f64::from(o.instructions)).collect(),
    }];
    if let (Some(first), Some(last)) = (t.first(), t.last()) {
        let budget = decoy_hil::budgets::frame(board);
        series.push(decoy_plots::Series {
            label: format!("budget {} ({})", budget.limit, budget.source),
            x: vec![*first, *last],
            y: vec![f64::from(budget.limit); 2],
        });
    }
    let plot = decoy_plots::Plot {
        title: format!("{name} (HIL, {board}): instructions per 10 ms control step"),
        x_label: "t [s]".to_owned(),
        y_label: "instructions".to_owned(),
        series,
        aspect: decoy_plots::Aspect::Free,
        invert_y: false,
    };
    decoy_plots::write_plot(&plot, &dir.join(INSTRUCTIONS_PLOT))
        .map(Vec::from)
        .map_err(|e| format!("the {INSTRUCTIONS_PLOT} plot: {e}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A row has a cell for every column of the schema, in its order: the
    /// controller's values where the file has them, the host's beside them.
    #[test]
    fn rows_have_every_column_of_the_schema() {
        let mut fw = OutputFrame {
            seq: 17,
            time_s: 1.5,
            flags: 3,
            instructions: 88_000,
            step_instructions: 80_000,
            steps: 4,
            management_instructions: 250_000,
            prediction_steps: 5,
            ..OutputFrame::ZERO
        };
        fw.management.advisories = 8;
        let mut s = Sample {
            t: 1.5,
            tension_connection: 900.25,
            tension_tow: 40.5,
            ..Sample::default()
        };
        s.management.margins.exhaust = -0.5;
        s.management.levels.exhaust = 3;
        s.management.advisories = 8;
        s.management.violation_in.exhaust = 0.25;
        let h = Sample {
            tension_connection: 900.0,
            tension_tow: 40.0,
            ..Sample::default()
        };
        assert!(
            decoy_sim::missing_cells(&HIL_TIMESERIES, |q| timeseries_cell(&fw, &s, &h, q))
                .is_empty()
        );
        let row = csv_row(&HIL_TIMESERIES, |q| timeseries_cell(&fw, &s, &h, q));
        let cells: Vec<&str> = row.trim_end().split(',').collect();
        assert_eq!(cells.len(), HIL_TIMESERIES.columns.len());
        let at = |name: &str| {
            let k = HIL_TIMESERIES.names().position(|n| n == name).unwrap();
            cells[k]
        };
        assert_eq!(
            [
                at("t_s"),
                at("seq"),
                at("tension_connection_N"),
                at("flags"),
                at("instructions"),
                at("host_tension_connection_N"),
                at("tension_connection_diff_N"),
                at("tension_tow_diff_N"),
                at("management_instructions"),
                at("exhaust_level"),
                at("exhaust_margin_m"),
                at("advisories"),
                at("exhaust_violation_in_s"),
                at("posture_violation_in_s"),
            ],
            [
                "1.5",
                "17",
                "900.250000",
                "3",
                "88000",
                "900.000000",
                "0.250000",
                "0.500000",
                "250000",
                "3",
                "-0.500000",
                "8",
                "0.250000",
                "-1.000000",
            ]
        );
    }
}
