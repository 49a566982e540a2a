//! The decoy's aerodynamic table: the CSV of lift, drag and pitching-moment
//! coefficients against the total angle of attack that `decoy.aero_table` names.

use solver_core::{AeroTable, AeroTableError};

use crate::error::ConfigError;
use crate::schema::AeroRow;

/// The header line of the aerodynamic table.
pub const AERO_CSV_HEADER: [&str; 4] = ["alpha_deg", "cl", "cd", "cm"];
/// Largest magnitude of an aerodynamic coefficient of the table (on the body's
/// cross-section, so a slender body's broadside drag is large: the reference
/// table reaches 21.6).
pub const MAX_AERO_COEFFICIENT: f64 = 50.0;

/// Parses the aerodynamic table CSV: `#` comment lines and blank lines are skipped,
/// the first other line must be the header `alpha_deg,cl,cd,cm`, every following
/// line one row of four numbers. The rows must be finite, strictly increasing in
/// angle and span 0 to 180 degrees.
pub fn parse_aero_csv(file: &str, text: &str) -> Result<Vec<AeroRow>, ConfigError> {
    let error = |line: Option<usize>, message: String| ConfigError::AeroCsv {
        file: file.to_owned(),
        line,
        message,
    };
    let mut header_seen = false;
    let mut rows = Vec::new();
    let mut line_numbers = Vec::new();
    for (index, raw) in text.lines().enumerate() {
        let number = index + 1;
        let line = raw.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        if !header_seen {
            if fields != AERO_CSV_HEADER {
                return Err(error(
                    Some(number),
                    format!("expected the header `alpha_deg,cl,cd,cm`, found `{line}`"),
                ));
            }
            header_seen = true;
            continue;
        }
        if fields.len() != 4 {
            return Err(error(
                Some(number),
                format!(
                    "expected 4 values (alpha_deg,cl,cd,cm), found {}: `{line}`",
                    fields.len()
                ),
            ));
        }
        let mut values = [0.0; 4];
        for ((value, name), field) in values.iter_mut().zip(AERO_CSV_HEADER).zip(&fields) {
            let parsed: f64 = field
                .parse()
                .map_err(|_| error(Some(number), format!("{name}: `{field}` is not a number")))?;
            if !parsed.is_finite() {
                return Err(error(
                    Some(number),
                    format!("{name}: `{field}` is not a finite number"),
                ));
            }
            *value = parsed;
        }
        for (name, value) in AERO_CSV_HEADER[1..].iter().zip(&values[1..]) {
            let low = if *name == "cd" {
                0.0
            } else {
                -MAX_AERO_COEFFICIENT
            };
            if !(low..=MAX_AERO_COEFFICIENT).contains(value) {
                return Err(error(
                    Some(number),
                    format!("{name} must be between {low} and {MAX_AERO_COEFFICIENT}, got {value}"),
                ));
            }
        }
        rows.push(AeroRow {
            alpha_deg: values[0],
            cl: values[1],
            cd: values[2],
            cm: values[3],
        });
        line_numbers.push(number);
    }
    if !header_seen {
        return Err(error(
            None,
            "no header line `alpha_deg,cl,cd,cm` found".to_owned(),
        ));
    }
    let arrays: Vec<[f64; 4]> = rows.iter().map(|r| r.to_array()).collect();
    AeroTable::<f64>::from_degrees(&arrays).map_err(|e| match e {
        AeroTableError::NotIncreasing { row } => error(
            Some(line_numbers[row]),
            format!(
                "alpha_deg {} does not increase on the previous row's {} (angles must increase strictly)",
                rows[row].alpha_deg,
                rows[row - 1].alpha_deg
            ),
        ),
        AeroTableError::NonFinite { row } => error(Some(line_numbers[row]), "a value is not finite".to_owned()),
        AeroTableError::DoesNotCover0To180 => error(
            None,
            format!(
                "alpha_deg must run from 0 to 180 degrees, the table runs from {} to {}",
                rows[0].alpha_deg,
                rows[rows.len() - 1].alpha_deg
            ),
        ),
        other => error(None, other.to_string()),
    })?;
    Ok(rows)
}
