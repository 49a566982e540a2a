//! `decoy envelope`: the manoeuvre envelope map (`decoy_studies::envelope`).

use std::path::{Path, PathBuf};
use std::sync::Mutex;

use clap::{Args, ValueEnum};
use decoy_config::SystemConfig;
use decoy_studies::envelope::{EnvelopeSpec, Manoeuvre, map_envelope};

use crate::failure::{Failure, to_json, usage};
use crate::progress::Progress;

/// The manoeuvres the map covers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum EnvelopeManoeuvre {
    /// The pull-up (5 s of rotation, then the climb).
    PullUp,
    /// The level coordinated turn.
    Turn,
}

/// `decoy envelope`.
#[derive(Args, Debug)]
pub struct EnvelopeArgs {
    /// The manoeuvre whose largest clear rate is mapped.
    #[arg(long, value_enum)]
    manoeuvre: EnvelopeManoeuvre,
    /// Altitudes, m: `a,b,c` or `start:stop:step` (default: the configuration's
    /// `[envelope]` altitudes by 3000 m).
    #[arg(long, value_name = "LIST", allow_hyphen_values = true)]
    altitudes: Option<String>,
    /// Mach numbers: `a,b,c` or `start:stop:step` (default: the configuration's
    /// `[envelope]` Mach range by 0.1, and its upper end).
    #[arg(long, value_name = "LIST", allow_hyphen_values = true)]
    machs: Option<String>,
    /// Cable segments (default: the configuration's host model, `solver.segments_host`).
    #[arg(long, value_name = "N", allow_negative_numbers = true)]
    segments: Option<usize>,
    /// Segment length ratio, short at the decoy (default 1, uniform).
    #[arg(long, value_name = "R", allow_negative_numbers = true)]
    grading: Option<f64>,
    /// Time over which the rate is built (and the pull-up's removed), s
    /// (docs/outputs.md "Flyable manoeuvres").
    #[arg(
        long,
        value_name = "S",
        default_value_t = 0.5,
        allow_negative_numbers = true
    )]
    onset: f64,
    /// Bisection tolerance on the rate, rad/s.
    #[arg(
        long,
        value_name = "W",
        default_value_t = 0.005,
        allow_negative_numbers = true
    )]
    tolerance: f64,
    /// Cells mapped side by side (default: the machine's cores).
    #[arg(long, value_name = "N", allow_negative_numbers = true)]
    workers: Option<usize>,
    /// Output directory (default out/envelope-MANOEUVRE); a map of the same
    /// inputs there is resumed.
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
}

/// A LIST flag's values: `a,b,c` or `start:stop:step` (stop included when the
/// steps reach it within 1e-9 of a step).
fn parse_list(flag: &str, text: &str) -> Result<Vec<f64>, Failure> {
    let number = |s: &str| -> Result<f64, Failure> {
        s.trim()
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| usage(format!("{flag}: `{s}` is not a number")))
    };
    let parts: Vec<&str> = text.split(':').collect();
    let values = match parts.as_slice() {
        [start, stop, step] => {
            let (start, stop, step) = (number(start)?, number(stop)?, number(step)?);
            if step <= 0.0 || step.is_nan() || stop < start {
                return Err(usage(format!(
                    "{flag}: `{text}` needs start <= stop and a positive step"
                )));
            }
            let count = ((stop - start) / step + 1e-9).floor() as usize + 1;
            if count > 1000 {
                return Err(usage(format!("{flag}: `{text}` has more than 1000 values")));
            }
            // Rounded to 1e-9, so that 0.3:0.9:0.1 gives 0.6, not 0.6000000000000001.
            (0..count)
                .map(|i| ((start + step * i as f64) * 1e9).round() / 1e9)
                .collect()
        }
        [_] => text.split(',').map(number).collect::<Result<Vec<_>, _>>()?,
        _ => {
            return Err(usage(format!(
                "{flag}: `{text}` is neither a,b,c nor start:stop:step"
            )));
        }
    };
    if values.is_empty() {
        return Err(usage(format!("{flag}: no values")));
    }
    Ok(values)
}

/// The default Mach numbers: from the envelope's lower end by 0.1, and its
/// upper end.
fn default_machs(config: &SystemConfig) -> Vec<f64> {
    let [lo, hi] = config.envelope.mach;
    let mut machs: Vec<f64> = (0..)
        .map(|i| ((lo + 0.1 * f64::from(i)) * 1000.0).round() / 1000.0)
        .take_while(|m| *m <= hi + 1e-9)
        .collect();
    if machs.last().is_none_or(|m| *m < hi - 1e-9) {
        machs.push(hi);
    }
    machs
}

/// Runs `decoy envelope`: maps, writes `envelope.csv`, `envelope.json`,
/// `summary.txt` and the heat map `limit.png/.svg` into the output directory, and returns the summary (or the
/// JSON).
pub fn envelope_command(
    config: &SystemConfig,
    args: &EnvelopeArgs,
    json: bool,
) -> Result<String, Failure> {
    let manoeuvre = match args.manoeuvre {
        EnvelopeManoeuvre::PullUp => Manoeuvre::PullUp,
        EnvelopeManoeuvre::Turn => Manoeuvre::Turn,
    };
    let altitudes_m = match &args.altitudes {
        Some(list) => parse_list("--altitudes", list)?,
        None => {
            let [lo, hi] = config.envelope.altitude_m;
            parse_list("--altitudes", &format!("{lo}:{hi}:3000"))?
        }
    };
    let machs = match &args.machs {
        Some(list) => parse_list("--machs", list)?,
        None => default_machs(config),
    };
    if args.workers == Some(0) {
        return Err(usage("--workers must be at least 1"));
    }
    if args.onset < 0.0 || !args.onset.is_finite() {
        return Err(usage(format!(
            "--onset must be a non-negative number of seconds, got {}",
            args.onset
        )));
    }
    let workers = args.workers.unwrap_or_else(|| {
        std::thread::available_parallelism()
            .map(usize::from)
            .unwrap_or(1)
    });
    let spec = EnvelopeSpec {
        manoeuvre,
        altitudes_m,
        machs,
        segments: args.segments.unwrap_or(config.solver.segments_host),
        grading: args.grading.unwrap_or(1.0),
        onset_s: args.onset,
        tolerance: args.tolerance,
    };
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| Path::new("out").join(format!("envelope-{}", manoeuvre.name())));
    let bar = Mutex::new(Progress::new("mapping", json));
    let progress = |done: usize, all: usize| {
        if let Ok(mut b) = bar.lock() {
            b.update(done as f64 / all.max(1) as f64);
        }
    };
    let map = map_envelope(config, &spec, workers, Some(&out), &progress);
    if let Ok(b) = bar.into_inner() {
        b.finish();
    }
    let map = map?;
    let write = |name: &str, text: &str| -> Result<(), Failure> {
        let path = out.join(name);
        decoy_sim::atomic::write_atomically(&path, text.as_bytes())
            .map_err(|e| Failure::Solver(format!("cannot write {}: {e}", path.display())))
    };
    let value = map.json();
    let mut pretty = serde_json::to_string_pretty(&value)
        .map_err(|e| Failure::Solver(format!("cannot write envelope.json: {e}")))?;
    pretty.push('\n');
    write("envelope.json", &pretty)?;
    write("envelope.csv", &map.csv())?;
    let summary = map.summary();
    write("summary.txt", &summary)?;
    map.write_heatmap(&out)?;
    if json {
        return Ok(to_json(&value));
    }
    Ok(format!(
        "{summary}{} cells ({} resumed from an earlier run); written to {}\n",
        map.cells.len(),
        map.resumed,
        out.display()
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lists_are_values_or_ranges() {
        assert_eq!(parse_list("--machs", "0.5,0.7").unwrap(), vec![0.5, 0.7]);
        assert_eq!(
            parse_list("--altitudes", "0:15000:3000").unwrap(),
            vec![0.0, 3000.0, 6000.0, 9000.0, 12000.0, 15000.0]
        );
        assert_eq!(
            parse_list("--machs", "0.3:0.9:0.1").unwrap(),
            vec![0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9]
        );
        for bad in ["", "a", "1:2", "1:0:1", "0:1:0", "0:1:-1", "1,x", "nan"] {
            assert!(parse_list("--machs", bad).is_err(), "{bad}");
        }
        let config = SystemConfig::builtin().unwrap();
        assert_eq!(
            default_machs(&config),
            vec![0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 0.95]
        );
    }
}
