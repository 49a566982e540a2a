//! The bridge's qemu backend (`decoy bridge --backend qemu`): the firmware
//! under QEMU behind a bridge, built as `decoy hil` builds it and talked to
//! over its UART ([`decoy_hil::link::Session`]), so that host-bridge, which
//! serves it through its [`Backend`] trait, depends on nothing of the firmware's
//! build, QEMU or the scenarios.

use std::time::Duration;

use decoy_config::SystemConfig;
use decoy_hil::link::{LinkError, Session};
use decoy_hil::qemu::Board;
use decoy_link::{DeviceMessage, HostMessage, StatusFlags};
use host_bridge::BridgeError;
use host_bridge::backend::{Backend, ModelInfo, Precision};

use crate::firmware::{build_firmware, check_segments};

/// How to build the qemu backend.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct QemuOptions {
    /// The board (its precision is the board's: `firmware/boards.toml`).
    pub board: Board,
    /// A precision asked for: it must be the board's.
    pub precision: Option<Precision>,
    /// Segments (None: the configuration's embedded count; another builds a
    /// firmware variant).
    pub segments: Option<usize>,
    /// A grading ratio asked for: it must be the configuration's embedded one.
    pub grading: Option<f64>,
}

/// The firmware under QEMU over its UART.
struct QemuBackend {
    session: Session,
    info: ModelInfo,
    /// Silence reports the firmware sent on its own (its link went quiet).
    silences: u64,
}

impl Backend for QemuBackend {
    fn handle(&mut self, message: HostMessage) -> Result<DeviceMessage, BridgeError> {
        let link = &mut self.session.link;
        link.send(&message).map_err(link_failure)?;
        loop {
            let answer = link.recv().map_err(link_failure)?;
            // The firmware's own silence report (DEGRADED set; the answer to a
            // command never has it, the command having ended the silence) came
            // before the answer: skip it.
            if let DeviceMessage::Status(s) = &answer
                && s.flags & StatusFlags::DEGRADED != 0
            {
                self.silences += 1;
                continue;
            }
            return Ok(answer);
        }
    }
    fn info(&self) -> &ModelInfo {
        &self.info
    }
}

fn link_failure(e: LinkError) -> BridgeError {
    BridgeError::Backend(format!("the firmware link: {e}"))
}

/// Builds (or finds) the firmware for `options.board` and boots it under QEMU.
pub fn qemu_backend(
    config: &SystemConfig,
    options: &QemuOptions,
) -> Result<Box<dyn Backend + Send>, BridgeError> {
    let board = options.board;
    let board_precision = board.precision();
    if let Some(p) = options.precision
        && p != board_precision
    {
        return Err(BridgeError::Usage(format!(
            "the {board} firmware computes in f{}; --precision f{} needs the other board",
            board_precision.bits(),
            p.bits()
        )));
    }
    let configured = config.solver.segments_embedded;
    let segments = options.segments.unwrap_or(configured);
    if let Some(g) = options.grading
        && g != config.solver.grading_ratio_embedded
    {
        return Err(BridgeError::Usage(format!(
            "the firmware's segments are graded {} (the configuration's solver.grading_ratio_embedded), not {g}",
            config.solver.grading_ratio_embedded
        )));
    }
    check_segments(segments).map_err(BridgeError::Usage)?;
    let elf = build_firmware(board, segments, configured)
        .map_err(|e| BridgeError::Backend(e.to_string()))?;
    let mut session = Session::start(&elf, board).map_err(link_failure)?;
    session.link.set_timeout(Duration::from_secs(5));
    let hello = session.hello;
    Ok(Box::new(QemuBackend {
        info: ModelInfo {
            backend: bridge_types::backend::QEMU,
            board: hello.board.as_str().to_owned(),
            precision_bits: hello.precision_bits,
            segments: hello.segments,
            capacity: hello.capacity,
            grading_ratio: config.solver.grading_ratio_embedded,
            link_protocol_version: hello.protocol_version,
            elf: Some(elf.display().to_string()),
        },
        session,
        silences: 0,
    }))
}
