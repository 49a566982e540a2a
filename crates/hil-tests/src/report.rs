//! The firmware's semihosting output, parsed.
//!
//! Lines (see `firmware/src/main.rs`), each `key=value` fields after an optional
//! leading word:
//!
//! ```text
//! trim instr=<n>
//! t=<s> T0=<N> TN=<N> pitch=<deg> instr=<n>
//! memory solver_bytes=<n> stack_used=<n> stack_size=<n>
//! done steps=<n> max_instr=<n> mean_instr=<n>
//! ```
//!
//! Any other line, in particular `error: ...`, `panic: ...` or `hardfault: ...`, is
//! an error naming the line.

use std::fmt;

/// One periodic sample.
#[derive(Clone, Debug, PartialEq)]
pub struct Sample {
    /// Simulation time, s.
    pub time: f64,
    /// Tension at the connection point (T0), N.
    pub connection_tension: f64,
    /// Tension at the towing point (TN), N.
    pub tow_tension: f64,
    /// Decoy pitch, degrees.
    pub pitch_deg: f64,
    /// Instructions executed by the control step that ended at `time`.
    pub instructions: u64,
    /// The line as printed.
    pub line: String,
}

/// The firmware's static and stack memory, as it measured them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Memory {
    /// Size of the solver (model, state, workspace), bytes.
    pub solver_bytes: u64,
    /// Deepest stack use, bytes.
    pub stack_used: u64,
    /// Room the stack had, bytes.
    pub stack_size: u64,
}

/// The closing summary.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Done {
    /// Control steps run.
    pub steps: u64,
    /// Most instructions in one control step.
    pub max_instructions: u64,
    /// Mean instructions per control step (rounded down).
    pub mean_instructions: u64,
}

/// Everything the firmware printed.
#[derive(Clone, Debug, PartialEq)]
pub struct Report {
    /// Instructions the trim took.
    pub trim_instructions: u64,
    /// The periodic samples, in order.
    pub samples: Vec<Sample>,
    /// Memory use.
    pub memory: Memory,
    /// The closing summary.
    pub done: Done,
}

/// A line that does not parse, or a missing one.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ParseError {
    /// 1-based line number (0: the output as a whole).
    pub line_number: usize,
    /// The line.
    pub line: String,
    /// What is wrong.
    pub reason: String,
}

impl fmt::Display for ParseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.line_number == 0 {
            write!(f, "firmware output: {}", self.reason)
        } else {
            write!(
                f,
                "firmware output line {}: {} in `{}`",
                self.line_number, self.reason, self.line
            )
        }
    }
}

impl std::error::Error for ParseError {}

/// The `key=value` fields of a line.
struct Fields<'a> {
    fields: Vec<(&'a str, &'a str)>,
}

impl<'a> Fields<'a> {
    fn parse(words: impl Iterator<Item = &'a str>) -> Result<Self, String> {
        let fields = words
            .map(|w| {
                w.split_once('=')
                    .ok_or_else(|| format!("`{w}` is not key=value"))
            })
            .collect::<Result<_, _>>()?;
        Ok(Fields { fields })
    }

    fn get<T: std::str::FromStr>(&self, key: &str) -> Result<T, String> {
        let (_, value) = self
            .fields
            .iter()
            .find(|(k, _)| *k == key)
            .ok_or_else(|| format!("no `{key}=`"))?;
        value
            .parse()
            .map_err(|_| format!("`{key}={value}` does not parse"))
    }
}

/// Parses the firmware's stdout.
pub fn parse(stdout: &str) -> Result<Report, ParseError> {
    let mut trim = None;
    let mut samples = Vec::new();
    let mut memory = None;
    let mut done = None;
    for (index, line) in stdout.lines().enumerate() {
        let error = |reason: String| ParseError {
            line_number: index + 1,
            line: line.to_owned(),
            reason,
        };
        let mut words = line.split_whitespace().peekable();
        let kind = match words.peek() {
            Some(w) if w.starts_with("t=") => "t",
            Some(w) => {
                let w = *w;
                words.next();
                w
            }
            None => continue,
        };
        if done.is_some() {
            return Err(error("output after `done`".into()));
        }
        let fields = Fields::parse(words).map_err(error)?;
        match kind {
            "trim" => trim = Some(fields.get("instr").map_err(error)?),
            "t" => samples.push(
                (|| {
                    Ok::<_, String>(Sample {
                        time: fields.get("t")?,
                        connection_tension: fields.get("T0")?,
                        tow_tension: fields.get("TN")?,
                        pitch_deg: fields.get("pitch")?,
                        instructions: fields.get("instr")?,
                        line: line.to_owned(),
                    })
                })()
                .map_err(error)?,
            ),
            "memory" => {
                memory = Some(
                    (|| {
                        Ok::<_, String>(Memory {
                            solver_bytes: fields.get("solver_bytes")?,
                            stack_used: fields.get("stack_used")?,
                            stack_size: fields.get("stack_size")?,
                        })
                    })()
                    .map_err(error)?,
                )
            }
            "done" => {
                done = Some(
                    (|| {
                        Ok::<_, String>(Done {
                            steps: fields.get("steps")?,
                            max_instructions: fields.get("max_instr")?,
                            mean_instructions: fields.get("mean_instr")?,
                        })
                    })()
                    .map_err(error)?,
                )
            }
            _ => {
                return Err(error(
                    "the firmware reported a failure or an unknown line".into(),
                ));
            }
        }
    }
    let missing = |what: &str| ParseError {
        line_number: 0,
        line: String::new(),
        reason: format!("no `{what}` line"),
    };
    Ok(Report {
        trim_instructions: trim.ok_or_else(|| missing("trim"))?,
        samples,
        memory: memory.ok_or_else(|| missing("memory"))?,
        done: done.ok_or_else(|| missing("done"))?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = "trim instr=1302520
t=0.1000 T0=162.8434 TN=30.6021 pitch=2.0402 instr=234960
t=0.2000 T0=162.8608 TN=30.6189 pitch=2.0404 instr=235040
memory solver_bytes=15616 stack_used=34552 stack_size=4178668
done steps=20 max_instr=235040 mean_instr=235000
";

    #[test]
    fn parses_every_line() {
        let r = parse(GOOD).unwrap();
        assert_eq!(r.trim_instructions, 1_302_520);
        assert_eq!(r.samples.len(), 2);
        assert_eq!(r.samples[1].time, 0.2);
        assert_eq!(r.samples[1].connection_tension, 162.8608);
        assert_eq!(r.samples[1].instructions, 235_040);
        assert_eq!(r.memory.stack_used, 34_552);
        assert_eq!(
            r.done,
            Done {
                steps: 20,
                max_instructions: 235_040,
                mean_instructions: 235_000
            }
        );
    }

    #[test]
    fn failures_and_truncation_are_errors() {
        let e = parse("trim instr=5\nerror: solver: non-finite state\n").unwrap_err();
        assert_eq!(e.line_number, 2);
        assert!(e.to_string().contains("error: solver"), "{e}");
        let e = parse(
            GOOD.replace("done steps=20 max_instr=235040 mean_instr=235000\n", "")
                .as_str(),
        )
        .unwrap_err();
        assert!(e.to_string().contains("no `done` line"), "{e}");
        let e = parse("trim instr=x\n").unwrap_err();
        assert!(e.to_string().contains("`instr=x` does not parse"), "{e}");
    }
}
