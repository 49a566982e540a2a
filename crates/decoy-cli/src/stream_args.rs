//! The options `decoy hil` and `decoy feed` share: those of every streamed run
//! (`decoy_stream::run::StreamOptions`).

use std::path::PathBuf;

use clap::Args;
use decoy_stream::fly::Mode;
use decoy_stream::run::StreamOptions;

use crate::scenario_arg::ScenarioArg;

/// The scenario and outputs of a streamed run (`decoy hil`, `decoy feed`).
#[derive(Args, Debug)]
pub struct StreamArgs {
    /// A shipped scenario or the path of a scenario TOML file.
    #[arg(long, value_name = "NAME|FILE", value_parser = ScenarioArg)]
    pub scenario: String,
    /// Simulated time, s (default: the scenario's).
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    pub t_end: Option<f64>,
    /// Flight-path rotation rate of a pull-up or turn, rad/s.
    #[arg(long, value_name = "W", allow_negative_numbers = true)]
    pub rate: Option<f64>,
    /// Output directory (default: out/hil-NAME for `decoy hil`, out/feed-NAME for `decoy feed`).
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Do not draw the plots.
    #[arg(long)]
    pub no_plots: bool,
}

impl StreamArgs {
    /// The pipeline's options, flown in `mode`, paced at real time if
    /// `realtime`.
    pub fn options(&self, mode: Mode, realtime: bool) -> StreamOptions {
        StreamOptions {
            t_end: self.t_end,
            rate: self.rate,
            out_dir: self.out.clone(),
            plots: !self.no_plots,
            mode,
            realtime,
        }
    }
}
