//! `hil-reference --precision 32|64 [--segments N]`: the host reference of the HIL
//! tests. It runs `decoy_link::Controller` (capacity 64, the reference system's
//! embedded model, `N` segments) with the maths the target uses (the `libm` crate,
//! forced through nalgebra's `libm-force`), so its f32 answers equal the firmware's
//! bit for bit.
//!
//! Protocol on stdin/stdout, one request at a time, each answered at once:
//!
//! ```text
//! request:  kind u8, length u32 LE, body
//!   kind 0: body = bytes received by the controller (wire frames, garbage...)
//!   kind 1: body = now_ms u32 LE: poll the link supervision at that clock reading
//! answer:   count u32 LE, then `count` wire frames of DeviceMessage (decoy_link framing)
//! ```
//!
//! End of input ends the process. Errors go to stderr with exit code 2.

#[path = "../../hil-tests/src/host.rs"]
mod host;

use std::io::{self, BufWriter, Read, Write};
use std::process::ExitCode;

use decoy_config::SystemConfig;
use decoy_link::{Controller, DeviceMessage, FrameDecoder, NoCounter};
use solver_core::Real;

/// The firmware's solver capacity.
const CAPACITY: usize = 64;

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("hil-reference: {e}");
            ExitCode::from(2)
        }
    }
}

fn run() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut precision = 32;
    let mut segments = None;
    let mut it = args.iter();
    while let Some(arg) = it.next() {
        let value = it.next().ok_or(format!("{arg} needs a value"))?;
        match arg.as_str() {
            "--precision" => {
                precision = value
                    .parse()
                    .map_err(|_| format!("bad precision {value}"))?
            }
            "--segments" => {
                segments = Some(
                    value
                        .parse()
                        .map_err(|_| format!("bad segment count {value}"))?,
                )
            }
            _ => return Err(format!("unknown argument {arg}")),
        }
    }
    let mut config = SystemConfig::builtin().map_err(|e| e.to_string())?;
    if let Some(n) = segments {
        config.solver.segments_embedded = n;
    }
    match precision {
        32 => serve::<f32>(&config),
        64 => serve::<f64>(&config),
        other => Err(format!("precision must be 32 or 64, not {other}")),
    }
}

fn serve<T: Real>(config: &SystemConfig) -> Result<(), String> {
    let controller_config = host::controller_config::<T>(config).map_err(|e| e.to_string())?;
    let mut controller: Box<Controller<T, CAPACITY>> =
        Box::new(Controller::new(controller_config).map_err(|e| e.to_string())?);
    let mut decoder = FrameDecoder::new();
    let mut stdin = io::stdin().lock();
    let mut stdout = BufWriter::new(io::stdout().lock());
    loop {
        let mut header = [0u8; 5];
        match stdin.read_exact(&mut header) {
            Ok(()) => {}
            Err(e) if e.kind() == io::ErrorKind::UnexpectedEof => return Ok(()),
            Err(e) => return Err(e.to_string()),
        }
        let length = u32::from_le_bytes([header[1], header[2], header[3], header[4]]) as usize;
        let mut body = vec![0u8; length];
        stdin.read_exact(&mut body).map_err(|e| e.to_string())?;
        let mut answers: Vec<DeviceMessage> = Vec::new();
        match header[0] {
            0 => controller.handle_bytes(&mut decoder, &body, &mut NoCounter, |a| answers.push(*a)),
            1 => {
                let now: [u8; 4] = body
                    .as_slice()
                    .try_into()
                    .map_err(|_| "a poll needs 4 bytes")?;
                answers.extend(controller.poll_silence(u32::from_le_bytes(now)));
            }
            other => return Err(format!("unknown request kind {other}")),
        }
        stdout
            .write_all(&(answers.len() as u32).to_le_bytes())
            .map_err(|e| e.to_string())?;
        for answer in &answers {
            let wire = decoy_link::encode_vec(answer).map_err(|e| e.to_string())?;
            stdout.write_all(&wire).map_err(|e| e.to_string())?;
        }
        stdout.flush().map_err(|e| e.to_string())?;
    }
}
