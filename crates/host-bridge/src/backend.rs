//! What answers the states: a [`Backend`], which takes the decoy link's
//! messages, so the bridge maps every request the same way whatever answers
//! it. The host backend (`decoy bridge --backend host`) is here: the
//! controller in this process. The qemu backend, the firmware under QEMU over
//! its UART, is `decoy_stream::qemu_backend` (it builds and boots the firmware
//! as `decoy hil` does, which a client of the bridge need not compile).

use decoy_config::SystemConfig;
use decoy_controller::{Controller, NoCounter};
use decoy_link::{DeviceMessage, HostMessage, PROTOCOL_VERSION};
use solver_core::{Real, SegmentLayout};

use crate::BridgeError;

/// Segment capacity of the host controller up to 64 segments (that of
/// `decoy_hil::flight::CONTROLLER_CAPACITY`, the host reference of `decoy hil`:
/// a test of decoy-stream checks that they agree).
pub const SMALL_CAPACITY: usize = 64;
/// Segment capacity of the host controller above 64 segments.
pub const LARGE_CAPACITY: usize = 512;

/// The solver's scalar (the schema's, as the boards' table has it).
pub use decoy_schema::Precision;

/// How to build the host backend.
#[derive(Clone, Debug, Default)]
pub struct BackendOptions {
    /// The precision (None: f32).
    pub precision: Option<Precision>,
    /// Segments (None: the configuration's embedded count).
    pub segments: Option<usize>,
    /// Grading ratio (None: the configuration's embedded ratio; 1: uniform).
    pub grading: Option<f64>,
    /// The host backend completes its trim in the first State frame, whatever
    /// the work (`ControllerConfig::trim_units_per_frame` unlimited): for an
    /// accuracy reference that must start its run where an f32 controller does
    /// (`decoy_hil::flight::accuracy_controller`). False: the onboard slice.
    pub trim_at_once: bool,
}

/// What a backend runs (the status's model part).
#[derive(Clone, Debug, PartialEq)]
pub struct ModelInfo {
    /// [`bridge_types::backend`] code.
    pub backend: u8,
    /// `host`, or the firmware's board name.
    pub board: String,
    /// 32 or 64.
    pub precision_bits: u8,
    /// Segments of the model.
    pub segments: u16,
    /// Capacity of the solver.
    pub capacity: u16,
    /// Grading ratio of the segments (1: uniform).
    pub grading_ratio: f64,
    /// The decoy link protocol the controller speaks.
    pub link_protocol_version: u16,
    /// The firmware ELF (qemu backend).
    pub elf: Option<String>,
}

/// A controller behind the decoy link's messages.
pub trait Backend {
    /// The one answer to `message` (a link failure is an error, not an answer).
    fn handle(&mut self, message: HostMessage) -> Result<DeviceMessage, BridgeError>;
    /// Called once the answer of [`Backend::handle`] is sent: work that the
    /// answer need not wait for (the host controller's look-ahead slice).
    fn background(&mut self) {}
    /// What runs.
    fn info(&self) -> &ModelInfo;
}

struct HostBackend<T: Real, const N: usize> {
    controller: Box<Controller<T, N>>,
    info: ModelInfo,
}

impl<T: Real, const N: usize> Backend for HostBackend<T, N> {
    fn handle(&mut self, message: HostMessage) -> Result<DeviceMessage, BridgeError> {
        // No silence polling here: the bridge supervises its clients itself, so
        // that an answer never depends on the client's pace (docs/bridge.md).
        Ok(self.controller.handle(message, &mut NoCounter))
    }
    fn background(&mut self) {
        // The frame's look-ahead slice, after its answer went out (as the
        // firmware does): the answer does not wait for the prediction.
        self.controller.background(&mut NoCounter);
    }
    fn info(&self) -> &ModelInfo {
        &self.info
    }
}

/// A backend and its board in words, as the summaries print them: `qemu m4`,
/// or `host` alone for the host backend (whose board is `host`).
pub fn describe_backend(backend: &str, board: &str) -> String {
    if board == backend {
        backend.to_owned()
    } else {
        format!("{backend} {board}")
    }
}

/// The layout of `segments` graded by `grading` (exactly uniform at 1).
fn layout<T: Real>(segments: usize, grading: f64) -> SegmentLayout<T> {
    if grading == 1.0 {
        SegmentLayout::Uniform { count: segments }
    } else {
        SegmentLayout::Graded {
            count: segments,
            ratio: T::lit(grading),
        }
    }
}

fn host<T: Real, const N: usize>(
    config: &SystemConfig,
    segments: usize,
    grading: f64,
    trim_at_once: bool,
) -> Result<Box<dyn Backend + Send>, BridgeError> {
    let mut controller_config = config
        .controller_config::<T>(layout::<T>(segments, grading))
        .map_err(|e| BridgeError::Usage(format!("the model: {e}")))?;
    // A finer model than the embedded one (the host model of 300 segments) has no
    // frame budget to keep, and the wave-speed limit of its short segments asks
    // for more steps than the onboard 20 in a 100 ms frame or a snatch: it takes
    // what it needs and trims in the first frame. The embedded model behaves as
    // onboard (the firmware's bit-exact reference).
    let embedded = segments == config.solver.segments_embedded
        && grading == config.solver.grading_ratio_embedded;
    if !embedded {
        controller_config.max_steps_per_frame = decoy_controller::HOST_MAX_STEPS_PER_FRAME;
    }
    if trim_at_once || !embedded {
        controller_config.trim_units_per_frame = u32::MAX;
    }
    let controller = Controller::<T, N>::new(controller_config)
        .map(Box::new)
        .map_err(|e| BridgeError::Usage(format!("the controller: {e}")))?;
    Ok(Box::new(HostBackend {
        controller,
        info: ModelInfo {
            backend: bridge_types::backend::HOST,
            board: "host".to_owned(),
            precision_bits: (std::mem::size_of::<T>() * 8) as u8,
            segments: segments as u16,
            capacity: N as u16,
            grading_ratio: grading,
            link_protocol_version: PROTOCOL_VERSION,
            elf: None,
        },
    }))
}

/// The controller in this process. Needs a large stack for more than 64
/// segments (the solver's fixed-capacity arrays are values): run it on a worker
/// thread of a few tens of MB.
pub fn host_backend(
    config: &SystemConfig,
    options: &BackendOptions,
) -> Result<Box<dyn Backend + Send>, BridgeError> {
    let segments = options.segments.unwrap_or(config.solver.segments_embedded);
    let grading = options
        .grading
        .unwrap_or(config.solver.grading_ratio_embedded);
    if !(1..=LARGE_CAPACITY).contains(&segments) {
        // The value's own origin: the flag, or the configuration file's key.
        let field = match options.segments {
            Some(_) => "--segments".to_owned(),
            None => format!("{}: solver.segments_embedded", config.source),
        };
        return Err(BridgeError::Usage(format!(
            "{field} must be between 1 and {LARGE_CAPACITY}, got {segments}"
        )));
    }
    if !(grading.is_finite() && grading > 0.0) {
        return Err(BridgeError::Usage(format!(
            "--grading must be a positive number, got {grading}"
        )));
    }
    let at_once = options.trim_at_once;
    match (
        options.precision.unwrap_or(Precision::F32),
        segments <= SMALL_CAPACITY,
    ) {
        (Precision::F32, true) => host::<f32, SMALL_CAPACITY>(config, segments, grading, at_once),
        (Precision::F32, false) => host::<f32, LARGE_CAPACITY>(config, segments, grading, at_once),
        (Precision::F64, true) => host::<f64, SMALL_CAPACITY>(config, segments, grading, at_once),
        (Precision::F64, false) => host::<f64, LARGE_CAPACITY>(config, segments, grading, at_once),
    }
}
