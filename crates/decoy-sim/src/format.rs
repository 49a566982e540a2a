//! Number and layout formats shared by the CSV files, the summaries and the messages.

use solver_core::SegmentLayout;

/// A time summed from steps, rounded to the nanosecond (8.076 rather than 8.076000000000963).
pub(crate) fn round_time(t: f64) -> f64 {
    (t * 1e9).round() / 1e9
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
    fn number_formats() {
        assert_eq!(format_time(0.0), "0");
        assert_eq!(format_time(1.234_000_000_000_2), "1.234");
        assert_eq!(format_time(2.0), "2");
        assert_eq!(format_value(-1e-9), "0.000000");
        assert_eq!(format_value(1.5), "1.500000");
    }
}
