//! The framing: round trips of every message kind (property-style, seeded), and
//! the decoder's answers to corrupted, truncated, oversize and garbage input.

use decoy_link::framing::{CRC_BYTES, MAX_PAYLOAD_BYTES};
use decoy_link::{
    AircraftStateFrame, BoardName, Command, Counters, DeviceMessage, FrameDecoder, FrameError,
    Hello, HostMessage, Limits, MAX_FRAME_BYTES, MAX_WIRE_BYTES, Management, MonitorLevel,
    MonitorReport, OutputFrame, PerRequirement, Profile, RejectReason, Rejected, StatusFrame,
    crc32, encode,
};
use decoy_schema::Manoeuvre;

/// A small deterministic generator (SplitMix64), so failures reproduce.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn u32(&mut self) -> u32 {
        self.next() as u32
    }
    fn u16(&mut self) -> u16 {
        self.next() as u16
    }
    /// Any finite f64, from tiny to huge, including zeros and negatives.
    fn f64(&mut self) -> f64 {
        loop {
            let v = f64::from_bits(self.next());
            if v.is_finite() {
                return v;
            }
        }
    }
    fn f32(&mut self) -> f32 {
        loop {
            let v = f32::from_bits(self.u32());
            if v.is_finite() {
                return v;
            }
        }
    }
    fn byte(&mut self) -> u8 {
        self.next() as u8
    }
}

fn state(r: &mut Rng) -> AircraftStateFrame {
    AircraftStateFrame {
        seq: r.u32(),
        time_s: r.f64(),
        position_ned_m: [r.f64(), r.f64(), r.f64()],
        velocity_ned_mps: [r.f32(), r.f32(), r.f32()],
        acceleration_ned_mps2: [r.f32(), r.f32(), r.f32()],
        attitude_wxyz: [r.f32(), r.f32(), r.f32(), r.f32()],
        body_rate_radps: [r.f32(), r.f32(), r.f32()],
        body_angular_acceleration_radps2: [r.f32(), r.f32(), r.f32()],
    }
}

fn host_message(r: &mut Rng) -> HostMessage {
    match r.next() % 8 {
        0..=2 => HostMessage::State(state(r)),
        3 => HostMessage::Command(Command::ResetToTrim),
        4 => HostMessage::Command(Command::GetStatus),
        5 => HostMessage::Command(Command::Ping { nonce: r.u32() }),
        6 => HostMessage::Command(Command::SelectProfile(
            match r.next() as usize % (Manoeuvre::ALL.len() + 1) {
                0 => Profile::Streamed,
                k => Profile::builtin(Manoeuvre::ALL[k - 1], r.u16()),
            },
        )),
        _ => HostMessage::State(AircraftStateFrame {
            seq: u32::MAX,
            ..state(r)
        }),
    }
}

fn counters(r: &mut Rng) -> Counters {
    Counters {
        frames_ok: r.u32(),
        oversize: r.u32(),
        cobs: r.u32(),
        crc: r.u32(),
        truncated: r.u32(),
        decode: r.u32(),
        non_finite: r.u32(),
        out_of_range: r.u32(),
        time_not_increasing: r.u32(),
        time_jump: r.u32(),
        not_trimmed: r.u32(),
        solver_failure: r.u32(),
        wrong_mode: r.u32(),
        bad_quaternion: r.u32(),
        silences: r.u32(),
        gap_restarts: r.u32(),
    }
}

fn monitor(r: &mut Rng) -> MonitorReport {
    MonitorReport {
        level: match r.next() % 4 {
            0 => MonitorLevel::Normal,
            1 => MonitorLevel::Caution,
            2 => MonitorLevel::Warning,
            _ => MonitorLevel::Violated,
        },
        margin: r.f32(),
        worst_margin: r.f32(),
        cautions: r.u32(),
        warnings: r.u32(),
        violations: r.u32(),
        predicted_worst_margin: r.f32(),
        time_to_violation_s: r.f32(),
    }
}

fn management(r: &mut Rng) -> Management {
    Management {
        // In wire order: the generator's draws are those of the four named
        // fields before the reports were a `PerRequirement`.
        reports: PerRequirement::from_fn(|_| monitor(r)),
        advisories: r.byte(),
        prediction_from_s: r.f64(),
        prediction_horizon_s: r.f32(),
        // Protocol 7's limits, drawing nothing (the other fields' draws as before).
        limits: Limits::ZERO,
    }
}

fn device_message(r: &mut Rng) -> DeviceMessage {
    match r.next() % 5 {
        0 => DeviceMessage::Output(OutputFrame {
            seq: r.u32(),
            time_s: r.f64(),
            connection_tension_n: r.f32(),
            tow_tension_n: r.f32(),
            decoy_position_fp_m: [r.f32(), r.f32(), r.f32()],
            decoy_euler_rel_rad: [r.f32(), r.f32(), r.f32()],
            angle_of_attack_rad: r.f32(),
            cable_clearance_exhaust_m: r.f32(),
            decoy_clearance_aircraft_m: r.f32(),
            flags: r.u16(),
            instructions: r.u32(),
            step_instructions: r.u32(),
            steps: r.u16(),
            management_instructions: r.u32(),
            prediction_steps: r.u16(),
            management: management(r),
        }),
        1 => DeviceMessage::Rejected(Rejected {
            seq: if r.next().is_multiple_of(2) {
                None
            } else {
                Some(r.u32())
            },
            reason: [
                RejectReason::Oversize,
                RejectReason::Cobs,
                RejectReason::Crc,
                RejectReason::Truncated,
                RejectReason::Decode,
                RejectReason::NonFinite,
                RejectReason::OutOfRange,
                RejectReason::TimeNotIncreasing,
                RejectReason::TimeJump,
                RejectReason::NotTrimmed,
                RejectReason::SolverFailure,
                RejectReason::WrongMode,
                RejectReason::BadQuaternion,
            ][(r.next() % 13) as usize],
            count: r.u32(),
        }),
        2 => DeviceMessage::Status(StatusFrame {
            protocol_version: r.u16(),
            flags: r.u16(),
            segments: r.u16(),
            time_s: r.f64(),
            counters: counters(r),
            instructions: r.u32(),
        }),
        3 => DeviceMessage::Pong {
            nonce: r.u32(),
            protocol_version: r.u16(),
        },
        _ => DeviceMessage::Hello(Hello {
            protocol_version: r.u16(),
            board: BoardName::new(
                [
                    "mps2-an386",
                    "mps2-an500",
                    "netduinoplus2",
                    "a-board-named-24-chars-x",
                ][(r.next() % 4) as usize],
            )
            .unwrap(),
            core_clock_hz: r.u32(),
            precision_bits: r.byte(),
            segments: r.u16(),
            capacity: r.u16(),
            control_period_us: r.u32(),
            max_step_us: r.u32(),
        }),
    }
}

/// Every frame decoded from `bytes`.
fn decode_all<M: serde::de::DeserializeOwned>(bytes: &[u8]) -> Vec<Result<M, FrameError>> {
    let mut decoder = FrameDecoder::new();
    let mut frames = Vec::new();
    decoder.push_slice(bytes, |f| frames.push(f));
    frames
}

fn wire<M: serde::Serialize>(message: &M) -> Vec<u8> {
    let mut out = [0u8; MAX_WIRE_BYTES];
    let n = encode(message, &mut out).unwrap();
    out[..n].to_vec()
}

/// A frame with an arbitrary payload and trailer (for hand-made errors).
fn raw_frame(raw: &[u8]) -> Vec<u8> {
    let mut out = vec![0u8; raw.len() + raw.len() / 254 + 3];
    let n = cobs::encode(raw, &mut out[1..]);
    out.truncate(n + 2);
    out[n + 1] = 0;
    out
}

#[test]
fn every_message_round_trips_and_frames_are_well_formed() {
    let mut r = Rng(0x5EED);
    for _ in 0..5000 {
        let host = host_message(&mut r);
        let bytes = wire(&host);
        assert!(bytes.len() <= MAX_WIRE_BYTES);
        assert_eq!((bytes[0], bytes[bytes.len() - 1]), (0, 0));
        assert!(bytes[1..bytes.len() - 1].iter().all(|&b| b != 0));
        assert_eq!(decode_all::<HostMessage>(&bytes), vec![Ok(host)]);

        let device = device_message(&mut r);
        let bytes = wire(&device);
        assert!(bytes.len() <= MAX_WIRE_BYTES);
        assert_eq!(decode_all::<DeviceMessage>(&bytes), vec![Ok(device)]);
    }
}

#[test]
fn back_to_back_frames_share_delimiters() {
    let mut r = Rng(7);
    let messages: Vec<HostMessage> = (0..50).map(|_| host_message(&mut r)).collect();
    let mut stream = Vec::new();
    for m in &messages {
        // Drop the leading delimiter: the previous frame's trailing one serves.
        stream.extend_from_slice(&wire(m)[1..]);
    }
    let decoded: Vec<HostMessage> = decode_all(&stream)
        .into_iter()
        .map(|f| f.unwrap())
        .collect();
    assert_eq!(decoded, messages);
}

#[test]
fn non_finite_values_round_trip_bit_for_bit() {
    let mut r = Rng(3);
    let mut s = state(&mut r);
    s.time_s = f64::NAN;
    s.velocity_ned_mps[1] = f32::NEG_INFINITY;
    let bytes = wire(&HostMessage::State(s));
    let back = decode_all::<HostMessage>(&bytes).pop().unwrap().unwrap();
    assert_eq!(wire(&back), bytes);
}

#[test]
fn a_wrong_crc_is_a_crc_error() {
    let payload = postcard::to_allocvec(&HostMessage::Command(Command::GetStatus)).unwrap();
    let mut raw = payload.clone();
    raw.extend_from_slice(&(crc32(&payload) ^ 1).to_le_bytes());
    assert_eq!(
        decode_all::<HostMessage>(&raw_frame(&raw)),
        vec![Err(FrameError::Crc)]
    );
}

#[test]
fn every_single_bit_flip_is_detected() {
    let message = HostMessage::State(state(&mut Rng(11)));
    let good = wire(&message);
    for i in 1..good.len() - 1 {
        for bit in 0..8 {
            let mut bad = good.clone();
            bad[i] ^= 1 << bit;
            let frames = decode_all::<HostMessage>(&bad);
            assert!(!frames.is_empty(), "byte {i} bit {bit}: nothing reported");
            assert!(
                frames.iter().all(|f| f.is_err()),
                "byte {i} bit {bit}: {frames:?}"
            );
        }
    }
}

#[test]
fn every_truncation_is_an_error_and_the_next_frame_decodes() {
    let message = HostMessage::State(state(&mut Rng(12)));
    let good = wire(&message);
    for cut in 2..good.len() - 1 {
        let mut bytes = good[..cut].to_vec();
        bytes.extend_from_slice(&good);
        let frames = decode_all::<HostMessage>(&bytes);
        assert_eq!(frames.len(), 2, "cut at {cut}");
        assert!(frames[0].is_err(), "cut at {cut}: {:?}", frames[0]);
        assert_eq!(frames[1], Ok(message));
    }
}

#[test]
fn shorter_than_the_crc_is_truncated() {
    for n in 1..CRC_BYTES {
        let raw: Vec<u8> = (1..=n as u8).collect();
        assert_eq!(
            decode_all::<HostMessage>(&raw_frame(&raw)),
            vec![Err(FrameError::Truncated)]
        );
    }
}

#[test]
fn invalid_cobs_and_trailing_bytes_are_reported() {
    // A code byte pointing past the end of the chunk.
    assert_eq!(
        decode_all::<HostMessage>(&[0, 9, 1, 2, 0]),
        vec![Err(FrameError::Cobs)]
    );
    // A valid CRC over a message followed by extra bytes.
    let mut payload = postcard::to_allocvec(&HostMessage::Command(Command::GetStatus)).unwrap();
    payload.push(42);
    let mut raw = payload.clone();
    raw.extend_from_slice(&crc32(&payload).to_le_bytes());
    assert_eq!(
        decode_all::<HostMessage>(&raw_frame(&raw)),
        vec![Err(FrameError::Decode)]
    );
    // A valid CRC over bytes that are no message (enum tag 200).
    let payload = [200u8, 1, 2];
    let mut raw = payload.to_vec();
    raw.extend_from_slice(&crc32(&payload).to_le_bytes());
    assert_eq!(
        decode_all::<HostMessage>(&raw_frame(&raw)),
        vec![Err(FrameError::Decode)]
    );
}

#[test]
fn oversize_chunks_are_dropped_once_and_the_decoder_recovers() {
    let message = HostMessage::Command(Command::Ping { nonce: 99 });
    for length in [MAX_FRAME_BYTES + 1, 1000, 10_000] {
        let mut bytes = vec![0u8];
        bytes.extend(std::iter::repeat_n(0x55, length));
        bytes.extend_from_slice(&wire(&message));
        assert_eq!(
            decode_all::<HostMessage>(&bytes),
            vec![Err(FrameError::Oversize), Ok(message)],
            "{length}"
        );
    }
    // Exactly MAX_FRAME_BYTES is not oversize (it fails later, as bad COBS or CRC).
    let mut bytes = vec![0u8];
    bytes.extend(std::iter::repeat_n(0x55, MAX_FRAME_BYTES));
    bytes.push(0);
    let frames = decode_all::<HostMessage>(&bytes);
    assert_eq!(frames.len(), 1);
    assert_ne!(frames[0], Err(FrameError::Oversize));
}

#[test]
fn garbage_between_frames_costs_one_error_each_and_never_a_frame() {
    let mut r = Rng(21);
    let messages: Vec<HostMessage> = (0..200).map(|_| host_message(&mut r)).collect();
    let mut stream = Vec::new();
    let mut garbage_chunks = 0;
    for m in &messages {
        let length = (r.next() % 40) as usize;
        let garbage: Vec<u8> = (0..length).map(|_| r.byte() | 1).collect();
        if !garbage.is_empty() {
            garbage_chunks += 1;
        }
        stream.extend_from_slice(&garbage);
        stream.extend_from_slice(&wire(m));
    }
    let frames = decode_all::<HostMessage>(&stream);
    let ok: Vec<HostMessage> = frames.iter().filter_map(|f| f.ok()).collect();
    assert_eq!(ok, messages);
    assert_eq!(frames.len() - ok.len(), garbage_chunks);
}

#[test]
fn random_noise_never_stalls_the_decoder() {
    let mut r = Rng(99);
    let noise: Vec<u8> = (0..100_000).map(|_| r.byte()).collect();
    let mut stream = noise;
    let message = HostMessage::Command(Command::Ping { nonce: 1 });
    stream.extend_from_slice(&wire(&message));
    let frames = decode_all::<HostMessage>(&stream);
    assert_eq!(frames.last(), Some(&Ok(message)));
}

#[test]
fn encode_reports_a_short_buffer() {
    let message = HostMessage::State(state(&mut Rng(5)));
    let needed = wire(&message).len();
    let mut out = vec![0u8; needed - 1];
    assert!(encode(&message, &mut out).is_err());
    const { assert!(MAX_PAYLOAD_BYTES + CRC_BYTES < MAX_FRAME_BYTES) };
}

/// The example of docs/protocol.md and firmware/README.md, byte for byte: the
/// ping and its answer (protocol version 8).
#[test]
fn the_documented_ping_frame() {
    let ping = HostMessage::Command(Command::Ping { nonce: 7 });
    assert_eq!(
        wire(&ping),
        [0x00, 0x08, 0x01, 0x03, 0x07, 0x45, 0x75, 0xca, 0x4b, 0x00]
    );
    let pong = DeviceMessage::Pong {
        nonce: 7,
        protocol_version: decoy_link::PROTOCOL_VERSION,
    };
    assert_eq!(
        wire(&pong),
        [0x00, 0x08, 0x03, 0x07, 0x08, 0xbe, 0x79, 0x9d, 0xbc, 0x00]
    );
}

/// The largest Output frame (every count and varint at its longest, one report
/// per requirement) fits in a frame: a requirement more may need a larger
/// `MAX_FRAME_BYTES` (a protocol change).
#[test]
fn the_largest_output_frame_fits() {
    let report = MonitorReport {
        level: MonitorLevel::Violated,
        margin: f32::MAX,
        worst_margin: f32::MAX,
        cautions: u32::MAX,
        warnings: u32::MAX,
        violations: u32::MAX,
        predicted_worst_margin: f32::MAX,
        time_to_violation_s: f32::MAX,
    };
    let output = DeviceMessage::Output(OutputFrame {
        seq: u32::MAX,
        time_s: f64::MAX,
        connection_tension_n: f32::MAX,
        tow_tension_n: f32::MAX,
        decoy_position_fp_m: [f32::MAX; 3],
        decoy_euler_rel_rad: [f32::MAX; 3],
        angle_of_attack_rad: f32::MAX,
        cable_clearance_exhaust_m: f32::MAX,
        decoy_clearance_aircraft_m: f32::MAX,
        flags: u16::MAX,
        instructions: u32::MAX,
        step_instructions: u32::MAX,
        steps: u16::MAX,
        management_instructions: u32::MAX,
        prediction_steps: u16::MAX,
        management: Management {
            reports: PerRequirement::splat(report),
            advisories: u8::MAX,
            prediction_from_s: f64::MAX,
            prediction_horizon_s: f32::MAX,
            limits: Limits {
                pull_up_radps: f32::MAX,
                turn_radps: f32::MAX,
                acceleration_mps2: f32::MAX,
                pull_up_floor_radps: f32::MAX,
                turn_floor_radps: f32::MAX,
                acceleration_floor_mps2: f32::MAX,
                limited_by: [u8::MAX; 3],
            },
        },
    });
    let mut payload = [0u8; 1024];
    let length = postcard::to_slice(&output, &mut payload).unwrap().len();
    assert!(
        length <= MAX_PAYLOAD_BYTES,
        "the largest Output is {length} bytes, over MAX_PAYLOAD_BYTES = {MAX_PAYLOAD_BYTES}: raise MAX_FRAME_BYTES (a protocol change)"
    );
    let mut out = [0u8; MAX_WIRE_BYTES];
    assert!(encode(&output, &mut out).is_ok());
}

/// Output frames (whose `management` carries one report per requirement) of the
/// seeded generator, encoded: the bytes of protocol version 6 as they were when
/// the four reports were four named fields of `Management` (the length and
/// CRC-32 of the whole stream, and one `Management` byte for byte, recorded
/// then), so that gathering them into `decoy_schema::PerRequirement` moved no
/// byte: postcard writes a struct as its fields one after the other, nested or
/// not. Protocol 7 appends the limits to `Management`, the last field of an
/// Output: each payload is version 6's then the limits' 27 bytes (zero here),
/// checked by framing the payloads without them.
#[test]
fn output_frames_encode_as_they_did_with_four_named_reports() {
    let mut r = Rng(0x0123_4567);
    let mut stream = Vec::new();
    let mut version6 = Vec::new();
    let mut outputs = 0;
    while outputs < 400 {
        let message = device_message(&mut r);
        if let DeviceMessage::Output(_) = message {
            stream.extend(wire(&message));
            let payload = postcard::to_allocvec(&message).unwrap();
            let (before, limits) = payload.split_at(payload.len() - 27);
            assert_eq!(limits, [0u8; 27]);
            let mut raw = before.to_vec();
            raw.extend_from_slice(&crc32(before).to_le_bytes());
            version6.extend(raw_frame(&raw));
            outputs += 1;
        }
    }
    assert_eq!((version6.len(), crc32(&version6)), (91_300, 0xe505_e62c));
    assert_eq!((stream.len(), crc32(&stream)), (102_100, 0x9680_847d));

    let levels = [
        MonitorLevel::Normal,
        MonitorLevel::Caution,
        MonitorLevel::Warning,
        MonitorLevel::Violated,
    ];
    let report = |k: usize| MonitorReport {
        level: levels[k],
        margin: 1.0 + k as f32,
        worst_margin: -2.0,
        cautions: 10 + k as u32,
        warnings: 20 + k as u32,
        violations: 30 + k as u32,
        predicted_worst_margin: 0.5,
        time_to_violation_s: -1.0,
    };
    let management = Management {
        reports: PerRequirement::from_fn(|req| report(req.index())),
        advisories: 0b1010,
        prediction_from_s: 2.5,
        prediction_horizon_s: 3.0,
        limits: Limits {
            pull_up_radps: 0.125,
            turn_radps: -1.0,
            acceleration_mps2: 9.5,
            pull_up_floor_radps: 0.125,
            turn_floor_radps: -1.0,
            acceleration_floor_mps2: 9.5,
            limited_by: [4, 0, 0x80],
        },
    };
    let mut buf = [0u8; 256];
    let bytes = postcard::to_slice(&management, &mut buf).unwrap();
    // Per report: level (varint), margin, worst margin (f32 LE), the three
    // counts (varints), predicted worst margin, time to violation (f32 LE);
    // posture, collision, tension, exhaust; then advisories, the prediction's
    // start (f64 LE) and horizon (f32 LE); from protocol 7 the limits (three
    // f32 LE, the three floors, then the three codes).
    let golden = "00\
        0000803f000000c00a141e0000003f000080bf\
        01\
        00000040000000c00b151f0000003f000080bf\
        02\
        00004040000000c00c16200000003f000080bf\
        03\
        00008040000000c00d17210000003f000080bf\
        0a\
        0000000000000440\
        00004040\
        0000003e000080bf00001841\
        0000003e000080bf00001841\
        040080";
    let hex: String = bytes.iter().map(|b| format!("{b:02x}")).collect();
    assert_eq!(hex, golden);
    assert_eq!(
        postcard::from_bytes::<Management>(bytes).unwrap(),
        management
    );
}
