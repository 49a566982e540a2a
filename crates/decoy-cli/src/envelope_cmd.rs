//! `decoy envelope`: the manoeuvre envelope map (`decoy_studies::envelope`),
//! on this machine's cores or, with `--ray ADDRESS`, as Ray tasks of the
//! Python package `decoy` (`python -m decoy._ray_cells`), whose cells the map
//! then resumes from its directory.

use std::io::{BufRead as _, BufReader, Read as _};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::Mutex;
use std::time::Instant;

use clap::{Args, ValueEnum};
use decoy_config::SystemConfig;
use decoy_studies::envelope::{
    EnvelopePlan, EnvelopeRequest, EnvelopeSpec, Manoeuvre, map_envelope, pending_cells,
};

use crate::failure::{Failure, to_json, usage};
use crate::progress::Progress;

/// `decoy limits-table`.
#[derive(Args, Debug)]
pub struct LimitsTableArgs {
    /// Output directories of `decoy envelope` (complete maps of the pull-up,
    /// the turn and the acceleration; any of them), made with the
    /// configuration (`--config`, default the built-in reference system).
    #[arg(required = true, value_name = "DIR")]
    maps: Vec<PathBuf>,
    /// The file to write (default, for the built-in reference system only:
    /// config/reference-system.limits.toml; with --config, required).
    #[arg(long, value_name = "FILE")]
    out: Option<PathBuf>,
}

/// `decoy limits-table`: the envelope map on board
/// (`decoy_studies::onboard`), written to `--out`.
pub fn limits_table_command(
    config: &SystemConfig,
    args: &LimitsTableArgs,
    json: bool,
    given_config: bool,
) -> Result<String, Failure> {
    let out = match (&args.out, given_config) {
        (Some(out), _) => out.clone(),
        (None, false) => PathBuf::from("config/reference-system.limits.toml"),
        (None, true) => {
            return Err(usage(
                "--out is required with --config (the default is the reference system's map)",
            ));
        }
    };
    decoy_studies::onboard::write_limits_table(config, &args.maps, &out)?;
    let hash = decoy_config::config_hash(config);
    if json {
        return Ok(to_json(&serde_json::json!({
            "file": out.display().to_string(),
            "config_hash": hash,
            "maps": args.maps.iter().map(|d| d.display().to_string()).collect::<Vec<_>>(),
        })));
    }
    Ok(format!(
        "wrote {} ({} maps) for the configuration {}\n",
        out.display(),
        args.maps.len(),
        hash
    ))
}

/// The manoeuvres the map covers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum EnvelopeManoeuvre {
    /// The pull-up (5 s of rotation, then the climb).
    PullUp,
    /// The level coordinated turn.
    Turn,
    /// The level acceleration along the flight path (by `--mach-gain`).
    Acceleration,
}

/// `decoy envelope`.
#[derive(Args, Debug)]
pub struct EnvelopeArgs {
    /// The manoeuvre whose largest clear rate (or acceleration) is mapped.
    #[arg(long, value_enum)]
    manoeuvre: EnvelopeManoeuvre,
    /// Altitudes, m: `a,b,c` or `start:stop:step` (default: the configuration's
    /// `[envelope]` altitudes by 3000 m).
    #[arg(long, value_name = "LIST", allow_hyphen_values = true)]
    altitudes: Option<String>,
    /// Mach numbers: `a,b,c` or `start:stop:step` (default: the configuration's
    /// `[envelope]` Mach range by 0.1, and its upper end; for the acceleration,
    /// up to the upper end less the Mach gain).
    #[arg(long, value_name = "LIST", allow_hyphen_values = true)]
    machs: Option<String>,
    /// Cable segments (default: the configuration's host model, `solver.segments_host`).
    #[arg(long, value_name = "N", allow_negative_numbers = true)]
    segments: Option<usize>,
    /// Segment length ratio, short at the decoy (default 1, uniform).
    #[arg(long, value_name = "R", allow_negative_numbers = true)]
    grading: Option<f64>,
    /// Time over which the rate is built (and the pull-up's removed), s
    /// (default 0.5; docs/outputs.md "Flyable manoeuvres"; not for the
    /// acceleration).
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    onset: Option<f64>,
    /// The acceleration's gain in Mach number from each cell's (default 0.1;
    /// to the envelope's largest Mach at the cell's altitude at most).
    #[arg(long, value_name = "DM", allow_negative_numbers = true)]
    mach_gain: Option<f64>,
    /// Bisection tolerance: rad/s on a rate (default 0.005), m/s^2 on the
    /// acceleration (default 0.05).
    #[arg(long, value_name = "W", allow_negative_numbers = true)]
    tolerance: Option<f64>,
    /// Cells mapped side by side (default: the machine's cores).
    #[arg(long, value_name = "N", allow_negative_numbers = true)]
    workers: Option<usize>,
    /// Map the cells as tasks on the Ray cluster at ADDRESS (`host:port`, or
    /// `auto`), through the Python package `decoy` (the interpreter
    /// `$DECOY_PYTHON`, else the nearest `.venv/bin/python`, else `python3`).
    #[arg(long, value_name = "ADDRESS", conflicts_with = "workers")]
    ray: Option<String>,
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

/// Runs `decoy envelope`: maps (here or on Ray), writes `envelope.csv`,
/// `envelope.json`, `summary.txt` and the heat map `limit.png/.svg` into the
/// output directory, and returns the summary (or the JSON).
pub fn envelope_command(
    config: &SystemConfig,
    args: &EnvelopeArgs,
    json: bool,
) -> Result<String, Failure> {
    let manoeuvre = match args.manoeuvre {
        EnvelopeManoeuvre::PullUp => Manoeuvre::PullUp,
        EnvelopeManoeuvre::Turn => Manoeuvre::Turn,
        EnvelopeManoeuvre::Acceleration => Manoeuvre::Acceleration,
    };
    let altitudes_m = match &args.altitudes {
        Some(list) => Some(parse_list("--altitudes", list)?),
        None => None,
    };
    let machs = match &args.machs {
        Some(list) => Some(parse_list("--machs", list)?),
        None => None,
    };
    if args.workers == Some(0) {
        return Err(usage("--workers must be at least 1"));
    }
    let spec = EnvelopeSpec::new(
        config,
        manoeuvre,
        &EnvelopeRequest {
            altitudes_m,
            machs,
            segments: args.segments,
            grading: args.grading,
            onset_s: args.onset,
            tolerance: args.tolerance,
            mach_gain: args.mach_gain,
        },
    )?;
    let workers = args.workers.unwrap_or_else(|| {
        std::thread::available_parallelism()
            .map(usize::from)
            .unwrap_or(1)
    });
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| Path::new("out").join(format!("envelope-{}", manoeuvre.name())));
    let started = Instant::now();
    let bar = Mutex::new(Progress::new("mapping", json));
    let progress = |done: usize, all: usize| {
        if let Ok(mut b) = bar.lock() {
            b.update(done as f64 / all.max(1) as f64);
        }
    };
    // On Ray the cells land in `out`, and the map below resumes from them.
    let mut on_ray = None;
    if let Some(address) = &args.ray {
        let plan = EnvelopePlan::new(config, &spec)?;
        let pending = pending_cells(&plan, &out)?;
        let all = spec.conditions().len();
        map_on_ray(address, &out, pending.len(), all, &progress)?;
        on_ray = Some((address, pending.len()));
    }
    let map = map_envelope(config, &spec, workers, Some(&out), &progress);
    if let Ok(b) = bar.into_inner() {
        b.finish();
    }
    let map = map?;
    let elapsed = started.elapsed().as_secs_f64();
    map.write_outputs(&out)?;
    if json {
        return Ok(to_json(&map.json()));
    }
    let cells = map.cells.len();
    // Ray mapped what it stored; the rest of the cells not resumed (none, when
    // Ray stored them all) were mapped here.
    let here = cells - map.resumed;
    let (mapped, resumed, where_) = match on_ray {
        Some((address, pending)) => (
            pending - here,
            cells - pending,
            if here == 0 {
                format!("on the Ray cluster {address}")
            } else {
                format!("on the Ray cluster {address} and {here} here")
            },
        ),
        None => (
            here,
            map.resumed,
            format!("on {workers} worker{}", if workers == 1 { "" } else { "s" }),
        ),
    };
    Ok(format!(
        "{}{cells} cells ({resumed} resumed from an earlier run; {mapped} mapped {where_} in {elapsed:.1} s, {:.2} cells/s); written to {}\n",
        map.summary(),
        mapped as f64 / elapsed.max(1e-9),
        out.display()
    ))
}

/// The Python interpreter `--ray` runs: `$DECOY_PYTHON`, else the nearest
/// `.venv/bin/python` above the working directory or this executable (the
/// repository's, which `cargo xtask setup` makes), else `python3`.
fn python() -> PathBuf {
    if let Some(p) = std::env::var_os("DECOY_PYTHON") {
        return PathBuf::from(p);
    }
    let starts = [std::env::current_dir().ok(), std::env::current_exe().ok()];
    starts
        .into_iter()
        .flatten()
        .flat_map(|start| {
            start
                .ancestors()
                .map(|dir| dir.join(".venv/bin/python"))
                .collect::<Vec<_>>()
        })
        .find(|candidate| candidate.is_file())
        .unwrap_or_else(|| PathBuf::from("python3"))
}

/// Maps the `pending` cells of the map prepared in `out` as Ray tasks
/// (`python -m decoy._ray_cells ADDRESS OUT`, which stores each cell in `out`
/// as it comes and prints `cells DONE TOTAL` lines), telling `progress` of
/// them. Its `error: ` line is the failure's message: a usage error when it
/// exits 2 (the inputs', as locally), else the solver's; with no such line
/// (no Python, no package, no Ray) the message says what to install.
fn map_on_ray(
    address: &str,
    out: &Path,
    pending: usize,
    all: usize,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<(), Failure> {
    if pending == 0 {
        return Ok(());
    }
    let python = python();
    let unready = |what: String| {
        Failure::Solver(format!(
            "--ray: {what} (the cells are Ray tasks of the Python package `decoy`: `cargo xtask setup` installs it and Ray into .venv/, and DECOY_PYTHON names another interpreter)"
        ))
    };
    let mut child = Command::new(&python)
        .args(["-m", "decoy._ray_cells", address])
        .arg(out)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| unready(format!("cannot run {}: {e}", python.display())))?;
    // Ray's own logging goes to stderr: read it aside, keep it for the message.
    let mut stderr = child.stderr.take();
    let reader = std::thread::spawn(move || {
        let mut bytes = Vec::new();
        if let Some(s) = stderr.as_mut() {
            let _ = s.read_to_end(&mut bytes);
        }
        String::from_utf8_lossy(&bytes).into_owned()
    });
    if let Some(stdout) = child.stdout.take() {
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            // `cells DONE TOTAL`, DONE counting the cells resumed.
            let done = line
                .strip_prefix("cells ")
                .and_then(|rest| rest.split_whitespace().next())
                .and_then(|d| d.parse::<usize>().ok());
            if let Some(done) = done {
                progress(done, all);
            }
        }
    }
    let status = child
        .wait()
        .map_err(|e| unready(format!("{} did not finish: {e}", python.display())))?;
    let stderr = reader.join().unwrap_or_default();
    if status.success() {
        return Ok(());
    }
    match stderr.lines().rev().find_map(|l| l.strip_prefix("error: ")) {
        Some(message) if status.code() == Some(2) => Err(usage(message)),
        Some(message) => Err(Failure::Solver(message.to_owned())),
        None => {
            let last = stderr
                .lines()
                .rev()
                .find(|l| !l.trim().is_empty())
                .unwrap_or("no message");
            Err(unready(format!(
                "{} -m decoy._ray_cells failed ({status}): {last}",
                python.display()
            )))
        }
    }
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
        let defaults =
            EnvelopeSpec::new(&config, Manoeuvre::Turn, &EnvelopeRequest::default()).unwrap();
        assert_eq!(
            defaults.machs,
            vec![0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 0.95]
        );
        assert_eq!(
            defaults.altitudes_m,
            parse_list("--altitudes", "0:15000:3000").unwrap()
        );
    }
}
