//! Seeded random input: arbitrary (finite or not) State frames, commands and raw
//! bytes never panic the controller, every rejection leaves its state exactly as
//! it was, and every decoded frame gets exactly one answer.

mod common;

use common::{frame, output, running, send};
use decoy_controller::NoCounter;
use decoy_link::{AircraftStateFrame, Command, DeviceMessage, FrameDecoder, HostMessage, Profile};
use decoy_schema::Manoeuvre;

/// SplitMix64, so failures reproduce.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Mostly plausible values, sometimes extreme or non-finite ones.
    fn value(&mut self, plausible: f64, scale: f64) -> f64 {
        match self.next() % 20 {
            0 => f64::from_bits(self.next()),
            1 => [
                f64::NAN,
                f64::INFINITY,
                -f64::INFINITY,
                0.0,
                -0.0,
                1e300,
                -1e300,
            ][(self.next() % 7) as usize],
            _ => plausible + scale * ((self.next() % 2001) as f64 / 1000.0 - 1.0),
        }
    }
}

fn random_frame(r: &mut Rng, seq: u32, t: f64) -> AircraftStateFrame {
    let base = frame(seq, t);
    let mut f = base;
    f.time_s = r.value(t, 0.02);
    for i in 0..3 {
        f.position_ned_m[i] = r.value(base.position_ned_m[i], 5.0);
        f.velocity_ned_mps[i] = r.value(f64::from(base.velocity_ned_mps[i]), 30.0) as f32;
        f.acceleration_ned_mps2[i] = r.value(0.0, 20.0) as f32;
        f.body_rate_radps[i] = r.value(0.0, 0.3) as f32;
        f.body_angular_acceleration_radps2[i] = r.value(0.0, 1.0) as f32;
    }
    for i in 0..4 {
        f.attitude_wxyz[i] = r.value(f64::from(base.attitude_wxyz[i]), 0.05) as f32;
    }
    f
}

#[test]
fn random_frames_never_panic_and_rejections_change_nothing() {
    let mut r = Rng(0xF022);
    let mut c = running(3);
    let mut t = 0.03;
    let (mut outputs, mut rejections) = (0, 0);
    for k in 0..3000u32 {
        let message = match r.next() % 40 {
            0 => HostMessage::Command(Command::ResetToTrim),
            1 => HostMessage::Command(Command::SelectProfile(match r.next() % 4 {
                0 => Profile::Streamed,
                1 => Profile::builtin(Manoeuvre::Steady, 0),
                2 => Profile::builtin(Manoeuvre::Turn, (r.next() % 2000) as u16),
                _ => Profile::builtin(Manoeuvre::PullUp, (r.next() % 400) as u16),
            })),
            2 => HostMessage::Command(Command::GetStatus),
            _ => {
                t += 0.01;
                HostMessage::State(random_frame(&mut r, k, t))
            }
        };
        let before = c.snapshot();
        match c.handle(message, &mut NoCounter) {
            DeviceMessage::Rejected(_) => {
                rejections += 1;
                assert_eq!(c.snapshot(), before, "frame {k}: {message:?}");
            }
            DeviceMessage::Output(o) => {
                outputs += 1;
                assert!(o.time_s.is_finite());
            }
            _ => {}
        }
        // Now and then bring it back to a sane run.
        if k % 500 == 499 {
            c.handle(
                HostMessage::Command(Command::SelectProfile(Profile::Streamed)),
                &mut NoCounter,
            );
            t += 1.0;
            output(send(&mut c, frame(k, t)));
        }
    }
    assert!(
        outputs > 100 && rejections > 100,
        "{outputs} outputs, {rejections} rejections"
    );
}

#[test]
fn random_bytes_get_one_answer_per_chunk_and_never_panic() {
    let mut r = Rng(0xB17E5);
    let mut c = running(3);
    let mut decoder = FrameDecoder::new();
    let mut bytes = Vec::new();
    for _ in 0..50_000 {
        // Zeros about one byte in 30: chunks of all lengths, some oversize.
        let b = r.next() as u8;
        bytes.push(if r.next().is_multiple_of(30) {
            0
        } else {
            b | 1
        });
    }
    // Every piece before a 0x00 that is not empty is a chunk the decoder closes.
    let pieces: Vec<&[u8]> = bytes.split(|&b| b == 0).collect();
    let chunks = pieces[..pieces.len() - 1]
        .iter()
        .filter(|p| !p.is_empty())
        .count();
    let before = c.snapshot();
    let mut answers = 0;
    c.handle_bytes(&mut decoder, &bytes, &mut NoCounter, |a| {
        answers += 1;
        assert!(
            matches!(a, DeviceMessage::Rejected(r) if r.seq.is_none()),
            "{a:?}"
        );
    });
    assert_eq!(answers, chunks);
    assert_eq!(c.snapshot(), before);
}
