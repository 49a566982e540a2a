//! Where a run's RK4 steps end: the step rule ([`StepRule`]) and the run's
//! timeline of output times, breakpoints and end ([`Timeline`]).
//!
//! A run's clock never adds a step to a time. The output times lie on a grid
//! computed from their index (t_k = k / 100 s: the decimal time, correctly
//! rounded, whatever came before), the profile's breakpoints (a manoeuvre's start
//! and end, a recorded flight's samples) and the end are times the run steps *to*
//! ([`solver_core::Solver::step_to`]), so every one is reached exactly and the
//! manoeuvre starts at its time, not a stage early. Between two such stops the
//! steps are chosen by the rule:
//!
//! - **adaptive** (the default): each step at most [`WAVE_STEP_FACTOR`] / rate,
//!   where rate = max_i c_i / l_i is the wave-speed rate of the state the step
//!   starts from ([`solver_core::Outputs::wave_rate`], the stability limit of RK4
//!   on the rod chain's fastest mode, the same rule as the onboard controller's,
//!   docs/protocol.md §5), and as long as the step's error estimate allows
//!   ([`solver_core::Solver::step_to_checked`]: the relative change of the end
//!   forces within the step, at most [`END_FORCE_TOLERANCE`]; a step over it is
//!   undone and taken again shorter, and the next step grows as the estimate's
//!   dt^3 allows): long steps in steady flight, short ones through a manoeuvre's
//!   onset and a snatch load;
//! - **fixed** (`--dt S`, or a scenario's `dt_s`): steps of S, shortened where
//!   an output time, a breakpoint or the end comes first.
//!
//! Either way the steps up to the next stop are equal (the remaining interval
//! divided by the number of steps the rule asks for there), recomputed at every
//! step from the state it starts from.

use solver_core::WAVE_STEP_FACTOR;

/// Output times per second of simulated time: one every 10 ms (the rows of
/// `timeseries.csv`, `record::SAMPLE_INTERVAL_S`).
pub const ROWS_PER_SECOND: u32 = 100;
/// The shortest step the adaptive rule takes, s: a wave-speed rate that asks for
/// less means the state has diverged (or a model's segment is far too short for
/// its tension), and the run stops there.
pub const MIN_STEP_S: f64 = 1e-6;
/// Allowance of a step count: n steps of (t1 - t0) / n, computed, may exceed the
/// step asked for by a rounding error, which must not add a step.
const COUNT_TOLERANCE: f64 = 1e-9;

/// The adaptive rule's tolerance of a step's error estimate
/// ([`solver_core::StepError::end_force`]: the change of the end forces between
/// the step's last stage and its new state, relative to the connection force).
/// Chosen against fixed steps of 0.0625 ms on the shipped scenarios and the
/// pull-up and turn at 0.05, 0.10 and 0.20 rad/s: the peak connection tension
/// and the pitch amplitude within 0.07 % and the peak's time within 3 ms
/// (docs/host-steps.md, which also shows the cases off that list where it is
/// not within 0.1 %: a 0.30 rad/s pull-up and turn, a turn at 14 km).
pub const END_FORCE_TOLERANCE: f64 = 5e-5;
/// Safety factor of the step from the error estimate.
const SAFETY: f64 = 0.9;
/// The step after a failed one (a non-positive pivot, a non-finite state): a
/// quarter of it.
pub const SHRINK_ON_FAILURE: f64 = 0.25;

/// A step's error estimate over its tolerance (at most 1 to stand).
pub fn error_ratio(error: &solver_core::StepError) -> f64 {
    error.end_force / END_FORCE_TOLERANCE
}

/// The factor of the step after one whose error ratio was `ratio` and stood:
/// the estimate goes as dt^3, so 0.9 ratio^(-1/3), between 0.2 and 2.
pub fn grow(ratio: f64) -> f64 {
    if ratio > 0.0 {
        (SAFETY * ratio.cbrt().recip()).clamp(0.2, 2.0)
    } else {
        2.0
    }
}

/// The factor of a step taken again after one whose error ratio was `ratio`
/// (above 1): 0.9 ratio^(-1/3), at least 0.2.
pub fn shrink(ratio: f64) -> f64 {
    (SAFETY * ratio.cbrt().recip()).clamp(0.2, SAFETY)
}

/// How a run chooses its RK4 steps.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum StepRule {
    /// Each step at most [`WAVE_STEP_FACTOR`] / the wave-speed rate of the
    /// state it starts from, and as long as the error estimate allows.
    Adaptive,
    /// Steps of `dt` s, shortened where an output time, a breakpoint or the end
    /// comes first.
    Fixed {
        /// The step, s.
        dt: f64,
    },
}

impl StepRule {
    /// The fixed step, if the rule is fixed.
    pub fn fixed_step(&self) -> Option<f64> {
        match *self {
            StepRule::Fixed { dt } => Some(dt),
            StepRule::Adaptive => None,
        }
    }

    /// The rule's name in `summary.json` (`step_rule`).
    pub fn name(&self) -> &'static str {
        match self {
            StepRule::Adaptive => "adaptive",
            StepRule::Fixed { .. } => "fixed",
        }
    }

    /// The longest step the rule allows from a state of wave-speed rate `rate`
    /// (1/s; ignored by a fixed rule), s.
    pub fn allowed(&self, rate: f64) -> f64 {
        match *self {
            StepRule::Fixed { dt } => dt,
            StepRule::Adaptive => {
                if rate > 0.0 {
                    WAVE_STEP_FACTOR / rate
                } else {
                    f64::INFINITY
                }
            }
        }
    }
}

/// What a state's time is on the run's timeline.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Marks {
    /// An output time (the first state's, t = 0, included).
    pub row: bool,
    /// The end of the run (also an output time).
    pub end: bool,
}

impl Marks {
    /// The first state, t = 0: an output time.
    pub const START: Marks = Marks {
        row: true,
        end: false,
    };
    /// The last state: an output time and the end.
    pub const END: Marks = Marks {
        row: true,
        end: true,
    };
}

/// The run's stops: output times, breakpoints and the end, and the rule that
/// steps between them.
#[derive(Clone, Debug, PartialEq)]
pub struct Timeline {
    rule: StepRule,
    /// Output times per second when the grid is k / that (10 ms rows), else none
    /// and the grid is k x `interval`.
    per_second: Option<u32>,
    interval: f64,
    breakpoints: Vec<f64>,
    t_end: f64,
}

/// One step's end, as chosen by [`Cursor::next`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepEnd {
    /// The time the step ends at, s.
    pub t: f64,
    /// What that time is on the timeline.
    pub marks: Marks,
}

/// Why no step could be chosen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TooShort {
    /// The step the rule allowed, s (below [`MIN_STEP_S`], or not a number).
    pub allowed: f64,
}

impl Timeline {
    /// The timeline of a run to `t_end` (s, positive) whose path jumps at
    /// `breakpoints` (s, increasing, inside (0, `t_end`)), stepped by `rule`.
    /// Rows every 10 ms ([`ROWS_PER_SECOND`]); a fixed step longer than that has
    /// a row every step.
    pub fn new(rule: StepRule, breakpoints: Vec<f64>, t_end: f64) -> Self {
        let sample = 1.0 / f64::from(ROWS_PER_SECOND);
        let (per_second, interval) = match rule {
            StepRule::Fixed { dt } if dt > sample => (None, dt),
            _ => (Some(ROWS_PER_SECOND), sample),
        };
        Timeline {
            rule,
            per_second,
            interval,
            breakpoints,
            t_end,
        }
    }

    /// The step rule.
    pub fn rule(&self) -> StepRule {
        self.rule
    }

    /// The simulated time, s.
    pub fn t_end(&self) -> f64 {
        self.t_end
    }

    /// The interval between rows, s.
    pub fn row_interval(&self) -> f64 {
        self.interval
    }

    /// Output time number `k`, s: k / 100 (the decimal time correctly rounded), or
    /// k x the fixed step.
    pub fn row_time(&self, k: u64) -> f64 {
        match self.per_second {
            Some(m) => k as f64 / f64::from(m),
            None => k as f64 * self.interval,
        }
    }

    /// A cursor at t = 0.
    pub fn cursor(&self) -> Cursor<'_> {
        Cursor {
            timeline: self,
            t: 0.0,
            next_row: 1,
            next_break: 0,
        }
    }
}

/// Where a run is on its [`Timeline`].
#[derive(Clone, Debug)]
pub struct Cursor<'a> {
    timeline: &'a Timeline,
    t: f64,
    /// The index of the first output time after `t`.
    next_row: u64,
    /// The index of the first breakpoint after `t`.
    next_break: usize,
}

impl Cursor<'_> {
    /// The current time, s.
    pub fn t(&self) -> f64 {
        self.t
    }

    /// True once the end is reached.
    pub fn finished(&self) -> bool {
        self.t >= self.timeline.t_end
    }

    /// The end of the next step from the current time when a step may be at
    /// most `allowed` s long: the next stop (output time, breakpoint or end) if
    /// it is that close, else the first of the equal steps up to it. Does not move
    /// the cursor ([`Cursor::advance`]).
    pub fn next(&self, allowed: f64) -> Result<StepEnd, TooShort> {
        let tl = self.timeline;
        if allowed < MIN_STEP_S || allowed.is_nan() {
            return Err(TooShort { allowed });
        }
        let row = tl.row_time(self.next_row);
        let brk = tl.breakpoints.get(self.next_break).copied();
        let mut stop = row.min(tl.t_end);
        if let Some(b) = brk {
            stop = stop.min(b);
        }
        let remaining = stop - self.t;
        let count = (remaining / allowed - COUNT_TOLERANCE).ceil().max(1.0);
        if count <= 1.0 {
            let end = stop >= tl.t_end;
            let marks = Marks {
                row: stop == row || end,
                end,
            };
            Ok(StepEnd { t: stop, marks })
        } else {
            Ok(StepEnd {
                t: self.t + remaining / count,
                marks: Marks::default(),
            })
        }
    }

    /// Moves the cursor to `end` (the step to it succeeded).
    pub fn advance(&mut self, end: &StepEnd) {
        self.t = end.t;
        let tl = self.timeline;
        while tl.row_time(self.next_row) <= self.t {
            self.next_row += 1;
        }
        while tl
            .breakpoints
            .get(self.next_break)
            .is_some_and(|&b| b <= self.t)
        {
            self.next_break += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every step end of a timeline whose rule sees the wave-speed rate `rate`
    /// at every state.
    fn ends(timeline: &Timeline, rate: f64) -> Vec<StepEnd> {
        let mut cursor = timeline.cursor();
        let mut ends = Vec::new();
        while !cursor.finished() {
            let end = cursor.next(timeline.rule().allowed(rate)).unwrap();
            assert!(end.t > cursor.t(), "time must increase");
            cursor.advance(&end);
            ends.push(end);
        }
        ends
    }

    #[test]
    fn rows_lie_on_the_decimal_grid_and_the_clock_does_not_drift() {
        let timeline = Timeline::new(StepRule::Fixed { dt: 0.00025 }, vec![2.0, 7.0], 20.0);
        let ends = ends(&timeline, 0.0);
        // 40 steps of 0.25 ms per 10 ms row: 80,000 steps, every row exact.
        assert_eq!(ends.len(), 80_000);
        let rows: Vec<f64> = ends.iter().filter(|e| e.marks.row).map(|e| e.t).collect();
        assert_eq!(rows.len(), 2000);
        for (k, t) in rows.iter().enumerate() {
            let expected: f64 = format!("{}.{:02}", (k + 1) / 100, (k + 1) % 100)
                .parse()
                .unwrap();
            assert_eq!(t.to_bits(), expected.to_bits(), "row {k}");
        }
        // The manoeuvre's start and end are step ends, exactly.
        assert!(ends.iter().any(|e| e.t == 2.0));
        assert!(ends.iter().any(|e| e.t == 7.0));
        assert_eq!(ends.last().unwrap().t, 20.0);
        assert_eq!(ends.iter().filter(|e| e.marks.end).count(), 1);
    }

    #[test]
    fn a_breakpoint_between_rows_splits_the_interval() {
        let timeline = Timeline::new(StepRule::Adaptive, vec![0.0123], 0.03);
        // A wave-speed rate of 320/s allows 2.5 ms.
        let ends = ends(&timeline, 320.0);
        let times: Vec<f64> = ends.iter().map(|e| e.t).collect();
        assert!(times.contains(&0.0123));
        assert!(times.contains(&0.01) && times.contains(&0.02) && times.contains(&0.03));
        // Not a row.
        assert!(!ends.iter().find(|e| e.t == 0.0123).unwrap().marks.row);
        // 4 steps of 2.5 ms in each whole interval; [0.01, 0.0123] in one, the rest in 4.
        assert_eq!(ends.len(), 4 + 1 + 4 + 4);
    }

    #[test]
    fn the_wave_speed_rate_shortens_the_steps() {
        let rule = StepRule::Adaptive;
        // A rate of 800/s allows 1 ms: ten steps per row.
        let timeline = Timeline::new(rule, vec![], 0.1);
        assert_eq!(ends(&timeline, 800.0).len(), 100);
        // A slow rate: a step per row (the rows bound the steps).
        assert_eq!(ends(&timeline, 1.0).len(), 10);
        // A diverged state's rate asks for less than a microsecond: an error.
        assert!(timeline.cursor().next(rule.allowed(1e9)).is_err());
        assert!(
            timeline.cursor().next(rule.allowed(f64::NAN)).is_ok(),
            "NaN rate: no limit from it"
        );
        assert!(
            timeline.cursor().next(f64::NAN).is_err(),
            "a NaN step: an error"
        );
    }

    #[test]
    fn an_end_off_the_grid_is_the_last_row() {
        let timeline = Timeline::new(StepRule::Adaptive, vec![], 0.025);
        let ends = ends(&timeline, 0.0);
        let last = ends.last().unwrap();
        assert_eq!(last.t, 0.025);
        assert_eq!(last.marks, Marks::END);
    }

    #[test]
    fn a_fixed_step_longer_than_a_row_writes_every_step() {
        let timeline = Timeline::new(StepRule::Fixed { dt: 0.05 }, vec![], 1.0);
        let ends = ends(&timeline, 0.0);
        assert_eq!(ends.len(), 20);
        assert!(ends.iter().all(|e| e.marks.row));
    }
}
