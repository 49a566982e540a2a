//! Flying the frames through a transport: lockstep (each frame waits for its
//! answer) or free-running (frames published at their pace, the answers
//! collected as they come), paced at real time or flat out, stopped by a
//! rejection (lockstep) or a signal at the next frame.

use std::collections::HashMap;
use std::time::{Duration, Instant};

use decoy_link::AircraftStateFrame;
use decoy_sim::format_time;

use crate::signals::Interrupts;
use crate::transport::{FrameAnswer, FreeRunning, Transport};

/// How long a free-running flight waits for the last answers after its last
/// frame.
pub const FREE_DRAIN: Duration = Duration::from_secs(2);

/// How the frames go to the controller.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// Each frame waits for its answer.
    Lockstep,
    /// Frames are sent at their pace, the answers collected as they come.
    Free,
}

impl Mode {
    /// `lockstep` or `free`.
    pub fn name(self) -> &'static str {
        match self {
            Mode::Lockstep => "lockstep",
            Mode::Free => "free",
        }
    }
}

/// Why a flight ended before its last frame.
#[derive(Clone, Debug, PartialEq)]
pub enum Stop {
    /// The controller rejected a frame (lockstep).
    Rejected {
        /// Time of the last frame the controller took, s.
        t_s: f64,
        /// The rejection, in words (`summary.json`'s `stopped.reason`).
        reason: String,
    },
    /// SIGINT or SIGTERM (`SIGINT`).
    Signal(&'static str),
    /// The transport failed after frames were answered (lockstep: no answer
    /// within the deadline, a link cut): the flight ends at the last answered
    /// frame, whose answers are kept.
    Lost {
        /// Time of the last frame the controller took, s.
        t_s: f64,
        /// The transport's error, in words.
        reason: String,
    },
}

impl Stop {
    /// The reason `summary.json`'s `stopped` records.
    pub fn reason(&self) -> String {
        match self {
            Stop::Rejected { reason, .. } => reason.clone(),
            Stop::Signal(signal) => format!("interrupted by {signal}"),
            Stop::Lost { reason, .. } => format!("link lost: {reason}"),
        }
    }
}

/// The frames flown and their answers.
#[derive(Clone, Debug)]
pub struct Flown<A> {
    /// The frames sent, in order.
    pub sent: Vec<AircraftStateFrame>,
    /// The answer to each frame sent (None: it never came: a free-running
    /// sample the controller's side lost).
    pub answers: Vec<Option<A>>,
    /// The round trip of each answered frame (sent to answered), us.
    pub latency_us: Vec<f64>,
    /// Wall-clock time of the flight.
    pub wall: Duration,
    /// Why it ended early, if it did.
    pub stop: Option<Stop>,
}

impl<A: FrameAnswer> Flown<A> {
    /// The answers that came, in the order of the frames.
    pub fn answered(&self) -> Vec<A> {
        self.answers.iter().flatten().copied().collect()
    }

    /// The frames that got an answer: what the controller took (or rejected).
    pub fn seen(&self) -> Vec<AircraftStateFrame> {
        self.sent
            .iter()
            .zip(&self.answers)
            .filter(|(_, a)| a.is_some())
            .map(|(f, _)| *f)
            .collect()
    }
}

/// Waits until `frame`'s time after `started` (real-time pacing).
fn pace(started: Instant, frame: &AircraftStateFrame) {
    let due = started + Duration::from_secs_f64(frame.time_s.max(0.0));
    let now = Instant::now();
    if due > now {
        std::thread::sleep(due - now);
    }
}

/// The rejection of `frame`, in words.
fn describe_rejection(frame: &AircraftStateFrame, reason: &str, count: u64) -> String {
    format!(
        "frame {} (t = {} s) rejected: {reason} ({count} so far)",
        frame.seq,
        format_time(frame.time_s)
    )
}

/// Flies `frames` through `transport` in lockstep (each frame waits for its
/// answer; a rejection ends the flight), calling `progress` with the fraction
/// done now and then. A transport that fails once a signal came (the
/// firmware's QEMU, in the terminal's process group, got it too) ends the
/// flight as the signal does. A transport that fails once a frame was
/// answered ends the flight there ([`Stop::Lost`]): what was answered is kept.
pub fn lockstep<T: Transport>(
    transport: &mut T,
    frames: &[AircraftStateFrame],
    realtime: bool,
    mut progress: impl FnMut(f64),
    signals: &Interrupts,
) -> Result<Flown<T::Answer>, T::Error>
where
    T::Error: std::fmt::Display,
{
    let started = Instant::now();
    let mut flown = Flown {
        sent: Vec::with_capacity(frames.len()),
        answers: Vec::with_capacity(frames.len()),
        latency_us: Vec::with_capacity(frames.len()),
        wall: Duration::ZERO,
        stop: None,
    };
    let mut last_time = 0.0;
    let every = (frames.len() / 500).max(1);
    for (i, frame) in frames.iter().enumerate() {
        // A signal stops the flight between two frames.
        if let Some(signal) = signals.received() {
            flown.stop = Some(Stop::Signal(signal));
            break;
        }
        if realtime {
            pace(started, frame);
        }
        let t0 = Instant::now();
        let answer = match transport.step(frame) {
            Ok(answer) => answer,
            Err(e) => match signals.received() {
                Some(signal) => {
                    flown.stop = Some(Stop::Signal(signal));
                    break;
                }
                None if flown.sent.is_empty() => return Err(e),
                None => {
                    flown.stop = Some(Stop::Lost {
                        t_s: last_time,
                        reason: format!(
                            "frame {} (t = {} s): {e}",
                            frame.seq,
                            format_time(frame.time_s)
                        ),
                    });
                    break;
                }
            },
        };
        flown.latency_us.push(t0.elapsed().as_secs_f64() * 1e6);
        flown.sent.push(*frame);
        flown.answers.push(Some(answer));
        if let Some((reason, count)) = answer.rejection() {
            flown.stop = Some(Stop::Rejected {
                t_s: last_time,
                reason: describe_rejection(frame, &reason, count),
            });
            break;
        }
        if let Some(t) = answer.time_s() {
            last_time = t;
        }
        if i % every == 0 {
            progress(i as f64 / frames.len() as f64);
        }
    }
    progress(1.0);
    flown.wall = started.elapsed();
    Ok(flown)
}

/// Flies `frames` through `transport` free-running: each frame published at
/// its pace, the answers collected as they come and matched by sequence
/// number, for at most [`FREE_DRAIN`] after the last frame.
pub fn free_running<A: FrameAnswer, E>(
    transport: &mut dyn FreeRunning<Answer = A, Error = E>,
    frames: &[AircraftStateFrame],
    realtime: bool,
    mut progress: impl FnMut(f64),
    signals: &Interrupts,
) -> Result<Flown<A>, E> {
    // What came before (another run's answers) is not this run's.
    transport.take()?;
    let started = Instant::now();
    let mut sent_at: HashMap<u32, Instant> = HashMap::new();
    let mut got: HashMap<u32, (A, Instant)> = HashMap::new();
    let collect = |transport: &mut dyn FreeRunning<Answer = A, Error = E>,
                   got: &mut HashMap<u32, (A, Instant)>,
                   sent_at: &HashMap<u32, Instant>|
     -> Result<(), E> {
        let now = Instant::now();
        for a in transport.take()? {
            if let Some(seq) = a.seq().filter(|s| sent_at.contains_key(s)) {
                got.entry(seq).or_insert((a, now));
            }
        }
        Ok(())
    };
    let every = (frames.len() / 500).max(1);
    let mut stop = None;
    let mut published = 0;
    for (i, frame) in frames.iter().enumerate() {
        // A signal stops the publishing between two frames (the answers to
        // those sent are still collected).
        if let Some(signal) = signals.received() {
            stop = Some(Stop::Signal(signal));
            break;
        }
        if realtime {
            pace(started, frame);
        }
        published = i + 1;
        sent_at.insert(frame.seq, Instant::now());
        transport.publish(frame)?;
        collect(transport, &mut got, &sent_at)?;
        if i % every == 0 {
            progress(i as f64 / frames.len() as f64);
        }
    }
    let frames = &frames[..published];
    let drain_until = Instant::now() + FREE_DRAIN;
    while got.len() < frames.len() && Instant::now() < drain_until {
        transport.wait(Duration::from_millis(20))?;
        collect(transport, &mut got, &sent_at)?;
    }
    progress(1.0);
    let wall = started.elapsed();
    let mut latency_us = Vec::new();
    let answers = frames
        .iter()
        .map(|f| {
            got.get(&f.seq).map(|(a, at)| {
                latency_us.push(at.duration_since(sent_at[&f.seq]).as_secs_f64() * 1e6);
                *a
            })
        })
        .collect();
    Ok(Flown {
        sent: frames.to_vec(),
        answers,
        latency_us,
        wall,
        stop,
    })
}
