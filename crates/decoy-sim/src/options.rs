//! [`RunOptions`]: the command line's overrides of a scenario and how a run starts.

use std::path::PathBuf;

/// How the run starts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum InitialState {
    /// The trim (steady equilibrium) of the flight condition at t = 0.
    #[default]
    Trim,
    /// Every segment along the air's velocity relative to the connection point
    /// (the cable trailing straight behind it), the decoy's axis along the flight
    /// direction with its wings level, nothing rotating.
    Straight,
}

/// Overrides of the scenario's values (the command line's flags) and run options.
#[derive(Clone, Debug, PartialEq)]
pub struct RunOptions {
    /// Number of cable segments.
    pub segments: Option<usize>,
    /// Segment length ratio, short at the decoy (1 = uniform).
    pub grading: Option<f64>,
    /// RK4 time step, s.
    pub dt: Option<f64>,
    /// Simulated time, s.
    pub t_end: Option<f64>,
    /// Initial altitude, m.
    pub altitude: Option<f64>,
    /// Initial Mach number.
    pub mach: Option<f64>,
    /// Flight-path rotation rate, rad/s (pull-up, turn).
    pub rate: Option<f64>,
    /// Time to build (and remove) the rotation rate, s (pull-up, turn;
    /// [`crate::flyable`]; 0: the paper's step).
    pub onset: Option<f64>,
    /// How the run starts.
    pub initial: InitialState,
    /// Output directory (default `out/<scenario name>`, relative to the working directory).
    pub out_dir: Option<PathBuf>,
    /// Draw the plots (PNG + SVG) as well as the CSV and JSON files.
    pub plots: bool,
}

impl Default for RunOptions {
    fn default() -> Self {
        RunOptions {
            segments: None,
            grading: None,
            dt: None,
            t_end: None,
            altitude: None,
            mach: None,
            rate: None,
            onset: None,
            initial: InitialState::Trim,
            out_dir: None,
            plots: true,
        }
    }
}
