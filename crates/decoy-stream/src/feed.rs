//! `decoy feed`: a scenario (the flight profiles of `decoy simulate` and `decoy
//! hil`) flown through a running bridge ([`BridgeClient`], `crate::bridge`) at
//! the 10 ms control period, lockstep or free-running, written as `decoy hil`
//! writes its runs (`timeseries.csv`, `summary.json`, plots) beside the host's
//! replay of the same frames with the bridge's model, by the pipeline of
//! `crate::run`.
//!
//! The bridge decides the model: the scenario is checked with one uniform
//! segment standing for it before the output directory is cleared, and
//! planned with the bridge's layout once its status is read.

use std::time::Duration;

use bridge_types::{Answer, Status, field_text};
use decoy_config::SystemConfig;
use decoy_link::{DeviceMessage, HostMessage};
use decoy_sim::format::format_number;
use decoy_sim::{Scenario, Summary};
use host_bridge::BridgeError;
use host_bridge::backend::{BackendOptions, Precision, host_backend};
use host_bridge::client::BridgeClient;
use host_bridge::remote::ZenohOptions;
use host_bridge::timing::Percentiles;
use serde::Serialize;

use crate::run::{
    self, Device, DeviceError, Flight, Model, PlotTitles, Replays, StreamError, StreamOptions,
};

/// What `decoy feed` runs.
#[derive(Clone, Debug)]
pub struct FeedOptions {
    /// The bridge instance.
    pub instance: String,
    /// Deadline of each answer.
    pub timeout: Duration,
    /// Across hosts: the bridge over Zenoh (host_bridge::remote), not shared memory.
    pub zenoh: Option<ZenohOptions>,
    /// What every streamed run takes (the default output directory is
    /// `out/feed-<scenario>`).
    pub stream: StreamOptions,
}

impl Default for FeedOptions {
    fn default() -> Self {
        FeedOptions {
            instance: "default".to_owned(),
            timeout: host_bridge::client::ANSWER_TIMEOUT,
            zenoh: None,
            stream: StreamOptions::default(),
        }
    }
}

/// The longest deadline of an answer `--timeout` accepts, s (a day: a longer
/// one is no deadline but a hang).
pub const MAX_TIMEOUT_S: f64 = 86_400.0;

/// `--timeout S` as the deadline of each answer: a number of seconds above 0
/// (at least a nanosecond) and at most [`MAX_TIMEOUT_S`], else a
/// [`BridgeError::Usage`] naming the value.
pub fn answer_timeout(seconds: f64) -> Result<Duration, BridgeError> {
    let usable = seconds.is_finite() && seconds > 0.0 && seconds <= MAX_TIMEOUT_S;
    match Duration::try_from_secs_f64(seconds) {
        Ok(d) if usable && !d.is_zero() => Ok(d),
        _ => Err(BridgeError::Usage(format!(
            "--timeout must be a number of seconds above 0 and at most {} (a day), got {}",
            format_number(MAX_TIMEOUT_S),
            format_number(seconds)
        ))),
    }
}

/// `decoy feed`'s `summary.json`: `decoy simulate`'s summary of the bridge's run
/// plus the keys of `decoy hil` that apply and the feed's own.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FeedSummary {
    /// The run's summary, as `decoy simulate` defines it.
    #[serde(flatten)]
    pub run: Summary,
    /// The bridge instance.
    pub instance: String,
    /// The bridge's backend: `host` or `qemu`.
    pub backend: String,
    /// `host` or the firmware's board.
    pub board: String,
    /// The controller's precision, bits.
    pub precision_bits: u8,
    /// The model's grading ratio (1: uniform).
    pub grading_ratio: f64,
    /// `lockstep` or `free`.
    pub mode: String,
    /// `shm` (shared memory, one host) or `zenoh` (across hosts).
    pub transport: String,
    /// Paced at real time.
    pub realtime: bool,
    /// The CPUs the client could run on (Linux's list format; `--cpu` sets
    /// them; empty where unknown).
    pub client_cpus: String,
    /// State frames sent (the reset command before them not counted).
    pub frames_sent: usize,
    /// Of those, answered by an output.
    pub frames_answered: usize,
    /// Of those, answered while the controller initialised (the trim's frames:
    /// an `initialising` answer each, docs/bridge.md).
    pub frames_initialising: usize,
    /// Of those, answered by a rejection.
    pub frames_rejected: usize,
    /// Of those, never answered (free-running samples the bridge lost).
    pub frames_lost: usize,
    /// Round trip (state sent to its answer received), us.
    pub latency_us: Percentiles,
    /// Frames per second of wall-clock time.
    pub frames_per_s: f64,
    /// Most instructions one 10 ms control step took (qemu backend; 0 from the host).
    pub instructions_per_step_max: u32,
    /// Mean instructions per control step.
    pub instructions_per_step_mean: f64,
    /// Largest difference of either tension from the host's f64 replay of the
    /// same frames with the bridge's model, N.
    #[serde(rename = "max_tension_diff_vs_host_N")]
    pub max_tension_diff_vs_host_n: f64,
    /// Largest difference from the host replay in the bridge's own precision, N:
    /// 0 when they agree bit for bit.
    #[serde(rename = "max_tension_diff_vs_host_same_precision_N")]
    pub max_tension_diff_vs_host_same_precision_n: f64,
    /// Outputs equal to the same-precision replay's in every field but the
    /// instruction counts.
    pub frames_identical_to_host_same_precision: usize,
}

/// A finished feed.
pub type FeedRun = run::StreamRun<FeedSummary>;

impl DeviceError for BridgeError {
    const WHO: &'static str = "the bridge";

    fn is_usage(&self) -> bool {
        BridgeError::is_usage(self)
    }
}

/// Why `decoy feed` failed.
pub type FeedError = StreamError<BridgeError>;

/// A running bridge, as a [`Device`] of the pipeline.
struct Bridge<'a> {
    config: &'a SystemConfig,
    options: &'a FeedOptions,
    iox: &'a iceoryx2::config::Config,
    /// The bridge's status when the feed connected.
    status: Status,
}

impl Bridge<'_> {
    /// The host's replay of `messages` with the bridge's model in `precision`.
    fn replay_in(
        &self,
        precision: Precision,
        trim_at_once: bool,
        messages: &[HostMessage],
    ) -> Result<Vec<DeviceMessage>, BridgeError> {
        let mut backend = host_backend(
            self.config,
            &BackendOptions {
                precision: Some(precision),
                segments: Some(usize::from(self.status.segments)),
                grading: Some(self.status.grading_ratio),
                trim_at_once,
            },
        )?;
        messages.iter().map(|m| backend.handle(*m)).collect()
    }
}

impl Device for Bridge<'_> {
    type Transport = BridgeClient;
    type Error = BridgeError;
    type Summary = FeedSummary;
    const OUT_PREFIX: &'static str = "feed";
    const SERIES: &'static str = "bridge";

    fn config(&self) -> &SystemConfig {
        self.config
    }

    fn planned_layout(&self) -> Result<(usize, f64), FeedError> {
        // The bridge decides the layout: one uniform segment stands for it
        // until its status is read.
        Ok((1, 1.0))
    }

    fn open(&mut self) -> Result<(BridgeClient, Model), FeedError> {
        let mut client = match &self.options.zenoh {
            Some(z) => BridgeClient::connect_zenoh(&self.options.instance, z)?,
            None => {
                let node_name = format!("feed-{}-{}", self.options.instance, std::process::id());
                BridgeClient::connect(&self.options.instance, &node_name, self.iox)?
            }
        };
        client.set_timeout(self.options.timeout);
        self.status = client.get_status()?;
        let model = Model {
            segments: usize::from(self.status.segments),
            grading: self.status.grading_ratio,
            precision_bits: self.status.precision_bits,
        };
        Ok((client, model))
    }

    fn replay(&self, model: &Model, messages: &[HostMessage]) -> Result<Replays, FeedError> {
        let precision = if model.precision_bits == 64 {
            Precision::F64
        } else {
            Precision::F32
        };
        // The f64 accuracy reference trims in the first frame (as the f32
        // controller does); the same-precision replay is the bridge's controller.
        Ok(Replays {
            host64: self.replay_in(Precision::F64, true, messages)?,
            same: self.replay_in(precision, false, messages)?,
        })
    }

    fn plot_titles(&self, name: &str) -> PlotTitles {
        PlotTitles {
            comparison: format!(
                "{name} (bridge {}, {})",
                self.options.instance,
                bridge_types::backend::name(self.status.backend)
            ),
            management: format!("{name} (bridge {})", self.options.instance),
        }
    }

    fn summary(&self, flight: Flight<'_, Answer>) -> FeedSummary {
        let flown = flight.flown;
        let answered = flight.frames_answered();
        let initialising = flight.frames_initialising();
        let mut latency = flown.latency_us.clone();
        FeedSummary {
            instance: self.options.instance.clone(),
            backend: bridge_types::backend::name(self.status.backend).to_owned(),
            board: field_text(&self.status.board),
            precision_bits: self.status.precision_bits,
            grading_ratio: self.status.grading_ratio,
            mode: self.options.stream.mode.name().to_owned(),
            transport: if self.options.zenoh.is_some() {
                "zenoh"
            } else {
                "shm"
            }
            .to_owned(),
            realtime: self.options.stream.realtime,
            client_cpus: cpu_affinity::current_list(),
            frames_sent: flown.sent.len(),
            frames_answered: answered,
            frames_initialising: initialising,
            frames_rejected: flight.answered.len() - answered - initialising,
            frames_lost: flown.sent.len() - flight.answered.len(),
            latency_us: Percentiles::of(&mut latency),
            frames_per_s: flown.sent.len() as f64 / flown.wall.as_secs_f64().max(1e-9),
            instructions_per_step_max: flight.steps.max,
            instructions_per_step_mean: flight.steps.mean,
            max_tension_diff_vs_host_n: flight.vs_host.max_tension_diff_n,
            max_tension_diff_vs_host_same_precision_n: flight.vs_same.max_tension_diff_n,
            frames_identical_to_host_same_precision: flight.vs_same.identical,
            run: flight.run,
        }
    }
}

/// Flies `scenario` through bridge `options.instance` (in the iceoryx2 setup
/// `iox`) and writes the outputs; `progress` gets the fraction of frames done;
/// SIGINT or SIGTERM stops the flight at the next frame
/// ([`StreamError::Interrupted`]).
pub fn run_feed(
    config: &SystemConfig,
    scenario: &Scenario,
    options: &FeedOptions,
    iox: &iceoryx2::config::Config,
    progress: impl FnMut(f64),
) -> Result<FeedRun, FeedError> {
    let mut device = Bridge {
        config,
        options,
        iox,
        status: Status::default(),
    };
    run::run(scenario, &options.stream, &mut device, progress)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bridge's host controller up to 64 segments has the capacity of
    /// `decoy hil`'s host reference.
    #[test]
    fn the_host_backend_has_the_reference_capacity() {
        assert_eq!(
            host_bridge::backend::SMALL_CAPACITY,
            decoy_hil::flight::CONTROLLER_CAPACITY
        );
    }

    #[test]
    fn timeouts_are_positive_and_at_most_a_day() {
        assert_eq!(answer_timeout(0.5).unwrap(), Duration::from_millis(500));
        for bad in [0.0, -1.0, 1e-12, f64::NAN, f64::INFINITY, 86_401.0] {
            let e = answer_timeout(bad).unwrap_err();
            assert!(e.is_usage(), "{bad}: {e}");
            assert!(e.to_string().starts_with("--timeout must be"), "{e}");
        }
    }
}
