//! Number and layout formats shared by the CSV files, the summaries and the messages.

use solver_core::SegmentLayout;

/// A time summed from steps, rounded to the nanosecond (8.076 rather than 8.076000000000963).
pub(crate) fn round_time(t: f64) -> f64 {
    (t * 1e9).round() / 1e9
}

/// Numbers in messages: as written (`0.25`, `300`) in the usual range, in
/// scientific notation (`1e9`, `1.7976931348623157e308`, `1e-7`) when very large
/// or very small; `NaN`, `inf`, `-inf` as such.
pub fn format_number(v: f64) -> String {
    if v == 0.0 || !v.is_finite() || (1e-4..1e6).contains(&v.abs()) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

/// Times in the CSV files: up to nine decimals, trailing zeros dropped.
pub fn format_time(t: f64) -> String {
    let s = format!("{t:.9}");
    let s = s.trim_end_matches('0');
    let s = s.strip_suffix('.').unwrap_or(s);
    if s == "-0" {
        "0".to_owned()
    } else {
        s.to_owned()
    }
}

/// Values in the CSV files: six decimals (no negative zero).
pub fn format_value(v: f64) -> String {
    let s = format!("{v:.6}");
    if s == "-0.000000" {
        "0.000000".to_owned()
    } else {
        s
    }
}

/// The layout in words ("300 uniform segments").
pub fn describe_layout(layout: &SegmentLayout<f64>) -> String {
    match *layout {
        SegmentLayout::Uniform { count } => format!("{count} uniform segments"),
        SegmentLayout::Graded { count, ratio } => {
            format!("{count} segments graded {ratio} (short at the decoy)")
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_in_messages_are_short() {
        assert_eq!(format_number(1e9), "1e9");
        assert_eq!(format_number(f64::MAX), "1.7976931348623157e308");
        assert_eq!(format_number(-2.5e-7), "-2.5e-7");
        assert_eq!(format_number(0.25), "0.25");
        assert_eq!(format_number(20000.0), "20000");
        assert_eq!(format_number(0.0), "0");
        assert_eq!(format_number(f64::NAN), "NaN");
        assert_eq!(format_number(f64::NEG_INFINITY), "-inf");
    }

    #[test]
    fn number_formats() {
        assert_eq!(format_time(0.0), "0");
        assert_eq!(format_time(1.234_000_000_000_2), "1.234");
        assert_eq!(format_time(2.0), "2");
        assert_eq!(format_value(-1e-9), "0.000000");
        assert_eq!(format_value(1.5), "1.500000");
    }
}

/// One value of a CSV row, formatted as its kind needs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Cell {
    /// A time: [`format_time`].
    Time(f64),
    /// A measured value: [`format_value`].
    Value(f64),
    /// A count, a code or a bit set: as an integer.
    Count(u64),
}

impl std::fmt::Display for Cell {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            Cell::Time(t) => f.write_str(&format_time(t)),
            Cell::Value(v) => f.write_str(&format_value(v)),
            Cell::Count(n) => write!(f, "{n}"),
        }
    }
}

/// One row of `file` (with its newline): each column's cell from `cell`, in the
/// schema's order (`decoy_schema::columns`), so that a row cannot disagree with
/// the header. `cell` answers `None` for a quantity the writer does not have:
/// its tests check that it has every column of its file ([`missing_cells`]);
/// such a cell would be empty.
pub fn csv_row(
    file: &decoy_schema::CsvFile,
    mut cell: impl FnMut(decoy_schema::Quantity) -> Option<Cell>,
) -> String {
    use std::fmt::Write as _;
    let mut row = String::with_capacity(16 * file.columns.len());
    for (k, column) in file.columns.iter().enumerate() {
        if k > 0 {
            row.push(',');
        }
        if let Some(c) = cell(column.quantity) {
            let _ = write!(row, "{c}");
        }
    }
    row.push('\n');
    row
}

/// The columns of `file` for which `cell` has no value (a writer's test: none).
pub fn missing_cells(
    file: &decoy_schema::CsvFile,
    mut cell: impl FnMut(decoy_schema::Quantity) -> Option<Cell>,
) -> Vec<&'static str> {
    file.columns
        .iter()
        .filter(|c| cell(c.quantity).is_none())
        .map(|c| c.name)
        .collect()
}
