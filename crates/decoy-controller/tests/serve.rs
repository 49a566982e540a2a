//! The firmware's main loop (`serve::poll`) on the host, over an in-memory
//! loopback link: every frame answered exactly as the controller answers it
//! directly, garbage answered by typed rejections, silence reported once.

mod common;

use std::cell::Cell;
use std::collections::VecDeque;
use std::convert::Infallible;

use common::{controller, frame};
use decoy_controller::serve::{self, Clock, Event};
use decoy_controller::{InstructionCounter, NoCounter, SILENCE_MS};
use decoy_link::{Command, DeviceMessage, FrameDecoder, HostMessage, RejectReason, encode_vec};

/// Bytes written to `incoming` are what the controller reads; what it writes
/// lands in `outgoing`.
#[derive(Default)]
struct Loopback {
    incoming: VecDeque<u8>,
    outgoing: Vec<u8>,
}

impl embedded_io::ErrorType for Loopback {
    type Error = Infallible;
}

impl embedded_io::Read for Loopback {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Infallible> {
        let n = buf.len().min(self.incoming.len());
        for slot in &mut buf[..n] {
            *slot = self.incoming.pop_front().unwrap_or(0);
        }
        Ok(n)
    }
}

impl embedded_io::ReadReady for Loopback {
    fn read_ready(&mut self) -> Result<bool, Infallible> {
        Ok(!self.incoming.is_empty())
    }
}

impl embedded_io::Write for Loopback {
    fn write(&mut self, buf: &[u8]) -> Result<usize, Infallible> {
        self.outgoing.extend_from_slice(buf);
        Ok(buf.len())
    }
    fn flush(&mut self) -> Result<(), Infallible> {
        Ok(())
    }
}

/// A hand-set millisecond clock that counts nothing.
#[derive(Default)]
struct ManualClock {
    ms: Cell<u32>,
}

impl InstructionCounter for ManualClock {
    fn now(&self) -> u32 {
        0
    }
}

impl Clock for ManualClock {
    fn now_ms(&self) -> u32 {
        self.ms.get()
    }
}

/// Polls until every received byte is consumed; returns the decoded answers and
/// the events' kinds.
fn drain(
    c: &mut decoy_controller::Controller<f32, { common::CAPACITY }>,
    decoder: &mut FrameDecoder,
    link: &mut Loopback,
    clock: &ManualClock,
) -> (Vec<DeviceMessage>, usize) {
    let mut events = 0;
    loop {
        serve::poll(c, decoder, link, clock, &mut |e| {
            assert!(matches!(e, Event::Answered(_) | Event::Silent(_)), "{e:?}");
            events += 1;
        });
        if link.incoming.is_empty() {
            break;
        }
    }
    let mut answers = Vec::new();
    let mut device = FrameDecoder::new();
    for &b in &link.outgoing {
        if let Some(m) = device.push::<DeviceMessage>(b) {
            answers.push(m.unwrap());
        }
    }
    link.outgoing.clear();
    (answers, events)
}

#[test]
fn the_serve_loop_answers_every_frame_as_the_controller_does() {
    let messages: Vec<HostMessage> = std::iter::once(HostMessage::Command(Command::ResetToTrim))
        .chain((0..30).map(|k| HostMessage::State(frame(k, 0.01 * f64::from(k)))))
        .chain([HostMessage::Command(Command::Ping { nonce: 9 })])
        .collect();
    let mut direct = controller();
    let expected: Vec<DeviceMessage> = messages
        .iter()
        .map(|m| direct.handle(*m, &mut NoCounter))
        .collect();

    let mut served = controller();
    let mut decoder = FrameDecoder::new();
    let mut link = Loopback::default();
    let clock = ManualClock::default();
    for m in &messages {
        link.incoming.extend(encode_vec(m).unwrap());
    }
    let (answers, events) = drain(&mut served, &mut decoder, &mut link, &clock);
    assert_eq!(answers, expected);
    assert_eq!(events, messages.len());
    assert_eq!(served.snapshot(), direct.snapshot());
}

#[test]
fn garbage_is_answered_and_silence_reported_once_then_recovered() {
    let mut c = controller();
    let mut decoder = FrameDecoder::new();
    let mut link = Loopback::default();
    let clock = ManualClock::default();
    link.incoming
        .extend(encode_vec(&HostMessage::State(frame(0, 0.0))).unwrap());
    // A frame whose CRC is broken, between delimiters.
    let mut broken = encode_vec(&HostMessage::State(frame(1, 0.01))).unwrap();
    broken[3] ^= 0x40;
    link.incoming.extend(broken);
    let (answers, _) = drain(&mut c, &mut decoder, &mut link, &clock);
    assert!(
        matches!(answers[0], DeviceMessage::Output(_)),
        "{answers:?}"
    );
    match answers[1] {
        DeviceMessage::Rejected(r) => {
            assert_eq!(r.seq, None);
            assert!(matches!(
                r.reason,
                RejectReason::Crc | RejectReason::Cobs | RejectReason::Decode
            ));
        }
        other => panic!("{other:?}"),
    }
    // Silence: one Status with DEGRADED after SILENCE_MS, not two.
    for ms in [1, SILENCE_MS / 2, SILENCE_MS + 1, 2 * SILENCE_MS + 2] {
        clock.ms.set(ms);
        let (answers, _) = drain(&mut c, &mut decoder, &mut link, &clock);
        let expected = usize::from(ms == SILENCE_MS + 1);
        assert_eq!(answers.len(), expected, "at {ms} ms: {answers:?}");
    }
    // The next valid frame is answered and carries RECOVERED.
    link.incoming
        .extend(encode_vec(&HostMessage::State(frame(1, 0.01))).unwrap());
    let (answers, _) = drain(&mut c, &mut decoder, &mut link, &clock);
    match answers.as_slice() {
        [DeviceMessage::Output(o)] => {
            assert!(decoy_link::StatusFlags(o.flags).contains(decoy_link::StatusFlags::RECOVERED))
        }
        other => panic!("{other:?}"),
    }
}

/// The serve loop runs an accepted frame's look-ahead slice in the same poll
/// that writes its answer (after writing it: `serve::poll`), so no slice is
/// left due when the next frame comes; a controller driven by `handle` alone
/// leaves it due until then.
#[test]
fn the_serve_loop_runs_each_frame_slice_after_its_answer() {
    let mut served = controller();
    let mut direct = controller();
    let mut decoder = FrameDecoder::new();
    let mut link = Loopback::default();
    let clock = ManualClock::default();
    let mut due_direct = 0;
    for k in 0..20u32 {
        let m = HostMessage::State(frame(k, 0.01 * f64::from(k)));
        let expected = direct.handle(m, &mut NoCounter);
        link.incoming.extend(encode_vec(&m).unwrap());
        let (answers, _) = drain(&mut served, &mut decoder, &mut link, &clock);
        assert_eq!(answers, [expected], "frame {k}");
        assert_eq!(
            served.background(&mut NoCounter),
            0,
            "frame {k}: a slice left due"
        );
        // `handle` alone leaves the slice due (it runs at the next message):
        // check on a copy, so that `direct` keeps that path.
        due_direct += direct.clone().background(&mut NoCounter);
    }
    assert!(due_direct > 0, "the frames had slices to run");
}
