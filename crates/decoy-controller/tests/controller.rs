//! The controller's robustness: every rejection leaves its state bit-identical and
//! the next valid frame is answered exactly as if the bad frame had never come;
//! the stepping rule; silence, degradation and recovery; profiles; commands.

mod common;

use common::{CAPACITY, controller, frame, output, running, send};
use decoy_controller::{Controller, InstructionCounter, NoCounter, SILENCE_MS};
use decoy_link::{
    Command, DeviceMessage, FrameDecoder, HostMessage, MAX_WIRE_BYTES, PROTOCOL_VERSION, Profile,
    RejectReason, StatusFlags, encode,
};
use decoy_schema::Manoeuvre;

/// A board of that name with a 168 MHz core clock (any name: no enum to extend).
fn board(name: &str) -> decoy_link::BoardInfo {
    decoy_link::BoardInfo {
        name: decoy_link::BoardName::new(name).unwrap(),
        core_clock_hz: 168_000_000,
    }
}

fn rejected(answer: DeviceMessage) -> (Option<u32>, RejectReason, u32) {
    match answer {
        DeviceMessage::Rejected(r) => (r.seq, r.reason, r.count),
        other => panic!("expected a rejection, got {other:?}"),
    }
}

fn status_flags(answer: DeviceMessage) -> u16 {
    match answer {
        DeviceMessage::Status(s) => s.flags,
        other => panic!("expected a Status, got {other:?}"),
    }
}

fn wire(message: &HostMessage) -> Vec<u8> {
    let mut out = [0u8; MAX_WIRE_BYTES];
    let n = encode(message, &mut out).unwrap();
    out[..n].to_vec()
}

/// Feeds `bad` to a running controller, checks it is rejected for `reason` with
/// the state untouched, then checks the next valid frame gets exactly the answer
/// a controller that never saw `bad` gives.
fn rejects_cleanly(bad: decoy_link::AircraftStateFrame, reason: RejectReason) {
    let mut clean = running(5);
    let mut tested = running(5);
    let before = tested.snapshot();
    assert_eq!(
        rejected(send(&mut tested, bad)),
        (Some(bad.seq), reason, 1),
        "{bad:?}"
    );
    assert_eq!(tested.snapshot(), before, "state changed by {reason:?}");
    assert_eq!(tested.counters().of(reason), 1);
    let next = frame(6, 0.06);
    let (a, b) = (
        output(send(&mut clean, next)),
        output(send(&mut tested, next)),
    );
    assert_eq!(wire_output(&a), wire_output(&b));
    assert_eq!(clean.snapshot(), tested.snapshot());
}

fn wire_output(o: &decoy_link::OutputFrame) -> Vec<u8> {
    let mut out = [0u8; MAX_WIRE_BYTES];
    let n = encode(&DeviceMessage::Output(*o), &mut out).unwrap();
    out[..n].to_vec()
}

#[test]
fn steady_flight_stays_at_the_trim_with_four_steps_per_frame() {
    let mut c = controller();
    let first = output(send(&mut c, frame(0, 0.0)));
    assert_eq!(first.steps, 0);
    assert!(StatusFlags(first.flags).contains(StatusFlags::TRIMMED));
    let t0 = first.connection_tension_n;
    assert!(t0 > 50.0 && t0 < 1200.0, "{t0}");
    for k in 1..=100 {
        let o = output(send(&mut c, frame(k, 0.01 * f64::from(k))));
        assert_eq!((o.seq, o.steps), (k, 4));
        assert_eq!(o.time_s, 0.01 * f64::from(k));
        assert!(
            ((o.connection_tension_n - t0) / t0).abs() < 5e-3,
            "{k}: {o:?}"
        );
        // The decoy hangs behind and below, clear of the plume and the aircraft.
        assert!(o.decoy_position_fp_m[0] < -50.0 && o.decoy_position_fp_m[2] > 0.0);
        assert!(o.cable_clearance_exhaust_m > 0.0 && o.decoy_clearance_aircraft_m > 1.0);
        assert_eq!(o.flags, StatusFlags::TRIMMED);
    }
}

#[test]
fn the_stepping_rule() {
    // n = ceil(dt / 2.5 ms - 1e-9), at most 20: 2.5 ms -> 1, 5 ms -> 2, 10 ms -> 4,
    // 12 ms -> 5, 100 ms -> 20 (5 ms steps).
    let mut c = running(0);
    let mut t = 0.0;
    for (dt, steps) in [
        (0.0025, 1),
        (0.005, 2),
        (0.01, 4),
        (0.012, 5),
        (0.0001, 1),
        (0.1, 20),
    ] {
        t += dt;
        assert_eq!(output(send(&mut c, frame(1, t))).steps, steps, "{dt}");
        assert_eq!(c.state().time, t);
    }
}

#[test]
fn non_finite_fields_are_rejected() {
    let setters: [fn(&mut decoy_link::AircraftStateFrame, f64); 8] = [
        |f, v| f.time_s = v,
        |f, v| f.position_ned_m[1] = v,
        |f, v| f.velocity_ned_mps[0] = v as f32,
        |f, v| f.acceleration_ned_mps2[2] = v as f32,
        |f, v| f.attitude_wxyz[3] = v as f32,
        |f, v| f.body_rate_radps[1] = v as f32,
        |f, v| f.body_angular_acceleration_radps2[0] = v as f32,
        |f, v| f.position_ned_m[2] = v,
    ];
    for set in setters {
        for v in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            let mut bad = frame(6, 0.06);
            set(&mut bad, v);
            rejects_cleanly(bad, RejectReason::NonFinite);
        }
    }
}

#[test]
fn out_of_range_values_are_rejected() {
    let cases: [fn(&mut decoy_link::AircraftStateFrame); 7] = [
        // Zero airspeed: zero dynamic pressure.
        |f| f.velocity_ned_mps = [0.0; 3],
        // Mach 2.1 at 9 km (a = 303.8 m/s).
        |f| f.velocity_ned_mps = [2.1 * 303.8, 0.0, 0.0],
        // Below -500 m and above 20 km.
        |f| f.position_ned_m[2] = 501.0,
        |f| f.position_ned_m[2] = -20_001.0,
        |f| f.position_ned_m[2] = 1e300,
        // Enormous but finite velocity.
        |f| f.velocity_ned_mps = [f32::MAX, f32::MAX, 0.0],
        |f| f.velocity_ned_mps = [-1e6, 0.0, 0.0],
    ];
    for set in cases {
        let mut bad = frame(6, 0.06);
        set(&mut bad);
        rejects_cleanly(bad, RejectReason::OutOfRange);
    }
}

#[test]
fn bad_quaternions_are_rejected_and_near_unit_ones_accepted() {
    for q in [[1.01, 0.0, 0.0, 0.0], [0.0; 4], [0.5, 0.5, 0.5, 0.0]] {
        let mut bad = frame(6, 0.06);
        bad.attitude_wxyz = q;
        rejects_cleanly(bad, RejectReason::BadQuaternion);
    }
    let mut c = running(2);
    let mut ok = frame(3, 0.03);
    ok.attitude_wxyz = [1.0005, 0.0, 0.0, 0.0];
    output(send(&mut c, ok));
}

#[test]
fn time_going_backwards_standing_still_or_jumping_is_rejected() {
    rejects_cleanly(frame(6, 0.05), RejectReason::TimeNotIncreasing);
    rejects_cleanly(frame(6, 0.04), RejectReason::TimeNotIncreasing);
    rejects_cleanly(frame(6, -1.0), RejectReason::TimeNotIncreasing);
    rejects_cleanly(frame(6, 0.05 + 0.1 + 1e-6), RejectReason::TimeJump);
    rejects_cleanly(frame(6, 1e9), RejectReason::TimeJump);
    // Exactly the limit is accepted.
    let mut c = running(5);
    output(send(&mut c, frame(6, 0.05 + 0.1)));
}

/// A gap in the stream (0.2 s without a frame: lost samples, or a frame the
/// solver failed): the first frame after it is rejected (TimeJump) and leaves
/// the run as it was; the next, which follows it within the jump limit, ends
/// the run and the controller initialises there (counted in `gap_restarts`),
/// answering as a controller started at that frame. Strays are mere
/// rejections: a far time followed by the stream's own next frame, or two far
/// times that do not follow each other.
#[test]
fn a_gap_in_the_stream_restarts_the_run_and_a_stray_time_does_not() {
    let mut c = running(5);
    let t = 0.05 + 0.2;
    assert_eq!(
        rejected(send(&mut c, frame(6, t))).1,
        RejectReason::TimeJump
    );
    assert!(c.is_trimmed());
    assert_eq!(c.counters().gap_restarts, 0);
    let mut fresh = controller();
    for k in 0..10u32 {
        let f = frame(7 + k, t + 0.01 * f64::from(k + 1));
        let (a, b) = (send(&mut c, f), send(&mut fresh, f));
        match (&a, &b) {
            (DeviceMessage::Output(x), DeviceMessage::Output(y)) => {
                assert_eq!(wire_output(x), wire_output(y), "frame {k} after the gap")
            }
            (DeviceMessage::Status(x), DeviceMessage::Status(y)) => {
                assert!(StatusFlags(x.flags).contains(StatusFlags::INITIALISING));
                assert_eq!(x.flags, y.flags);
            }
            _ => panic!("frame {k} after the gap: {a:?} against a fresh controller's {b:?}"),
        }
    }
    assert_eq!(c.counters().gap_restarts, 1);
    assert_eq!(c.counters().time_jump, 1);
    assert!(c.is_trimmed());

    // Two strays that do not follow each other, then the stream's own frame.
    let mut clean = running(5);
    let mut tested = running(5);
    assert_eq!(
        rejected(send(&mut tested, frame(6, 5.0))).1,
        RejectReason::TimeJump
    );
    assert_eq!(
        rejected(send(&mut tested, frame(6, 9.0))).1,
        RejectReason::TimeJump
    );
    let next = frame(6, 0.06);
    assert_eq!(
        wire_output(&output(send(&mut clean, next))),
        wire_output(&output(send(&mut tested, next)))
    );
    assert_eq!(tested.counters().gap_restarts, 0);
    // A stray time does not arm a later gap: the stream went on meanwhile.
    assert_eq!(
        rejected(send(&mut tested, frame(7, 5.0))).1,
        RejectReason::TimeJump
    );
    output(send(&mut tested, frame(7, 0.07)));
    assert_eq!(
        rejected(send(&mut tested, frame(8, 5.01))).1,
        RejectReason::TimeJump
    );
    assert_eq!(tested.counters().gap_restarts, 0);
}

#[test]
fn a_reset_accepts_any_time_and_trims_again() {
    let mut c = running(5);
    let status = c.handle(HostMessage::Command(Command::ResetToTrim), &mut NoCounter);
    assert_eq!(status_flags(status) & StatusFlags::TRIMMED, 0);
    assert!(!c.is_trimmed());
    let trimmed = output(send(&mut c, frame(7, 100.0)));
    assert_eq!(trimmed.steps, 0);
    let stepped = output(send(&mut c, frame(8, 100.01)));
    assert_eq!(stepped.steps, 4);
    // Exactly what a fresh controller trimmed at that frame answers.
    let mut fresh = controller();
    assert_eq!(
        wire_output(&output(send(&mut fresh, frame(7, 100.0)))),
        wire_output(&trimmed)
    );
    assert_eq!(
        wire_output(&output(send(&mut fresh, frame(8, 100.01)))),
        wire_output(&stepped)
    );
    assert_eq!(fresh.snapshot(), c.snapshot());
}

#[test]
fn frame_errors_are_answered_without_seq_and_change_nothing() {
    let mut c = running(5);
    let before = c.snapshot();
    let mut decoder = FrameDecoder::new();
    let mut answers = Vec::new();
    let good = wire(&HostMessage::State(frame(6, 0.06)));
    let mut corrupted = good.clone();
    corrupted[10] ^= 0x40;
    let mut stream = vec![0x11, 0x22, 0x33]; // garbage before a frame
    stream.extend_from_slice(&corrupted); // CRC error
    stream.extend_from_slice(&good[..good.len() / 2]); // truncated...
    stream.extend(std::iter::repeat_n(0x7F, 400)); // ...then oversize
    stream.push(0);
    c.handle_bytes(&mut decoder, &stream, &mut NoCounter, |a| answers.push(*a));
    assert!(answers.len() >= 3, "{answers:?}");
    for a in &answers {
        let (seq, _, _) = rejected(*a);
        assert_eq!(seq, None);
    }
    assert_eq!(c.snapshot(), before);
    assert_eq!(c.counters().oversize, 1);
    assert!(c.counters().crc + c.counters().cobs + c.counters().decode >= 2);
    // The next valid frame is answered as by a controller that saw none of it.
    answers.clear();
    c.handle_bytes(&mut decoder, &good, &mut NoCounter, |a| answers.push(*a));
    let mut clean = running(5);
    assert_eq!(
        wire_output(&output(answers[0])),
        wire_output(&output(send(&mut clean, frame(6, 0.06))))
    );
}

#[test]
fn silence_degrades_once_and_the_next_frame_recovers() {
    let mut c = running(5);
    assert_eq!(c.poll_silence(1_000), None);
    assert_eq!(c.poll_silence(1_000 + SILENCE_MS - 1), None);
    let status = c
        .poll_silence(1_000 + SILENCE_MS)
        .expect("a Status at the silence");
    assert!(
        StatusFlags(status_flags(status)).contains(StatusFlags::DEGRADED | StatusFlags::TRIMMED)
    );
    assert_eq!(c.counters().silences, 1);
    // Reported once per silence.
    assert_eq!(c.poll_silence(5_000), None);
    assert_eq!(c.counters().silences, 1);
    // Garbage does not end a silence.
    let answer = c.on_frame_error(decoy_link::FrameError::Crc);
    assert_eq!(rejected(answer).1, RejectReason::Crc);
    assert!(StatusFlags(c.flags()).contains(StatusFlags::DEGRADED));
    // The next valid frame does; its Output says RECOVERED, the one after does not.
    let o = output(send(&mut c, frame(6, 0.06)));
    assert_eq!(o.flags, StatusFlags::TRIMMED | StatusFlags::RECOVERED);
    assert_eq!(c.flags() & StatusFlags::DEGRADED, 0);
    assert_eq!(
        output(send(&mut c, frame(7, 0.07))).flags,
        StatusFlags::TRIMMED
    );
    // Frames keep the link alive; a second silence is counted again.
    assert_eq!(c.poll_silence(5_100), None);
    assert_eq!(c.poll_silence(5_299), None);
    assert!(c.poll_silence(5_300).is_some());
    assert_eq!(c.counters().silences, 2);
}

#[test]
fn supervision_starts_with_the_first_valid_frame() {
    let mut c = controller();
    assert_eq!(c.poll_silence(0), None);
    assert_eq!(c.poll_silence(10 * SILENCE_MS), None);
    assert_eq!(c.counters().silences, 0);
    // A command is a valid frame too.
    c.handle(HostMessage::Command(Command::GetStatus), &mut NoCounter);
    assert_eq!(c.poll_silence(20 * SILENCE_MS), None);
    assert!(c.poll_silence(21 * SILENCE_MS).is_some());
    let o = output(send(&mut c, frame(0, 0.0)));
    assert!(StatusFlags(o.flags).contains(StatusFlags::RECOVERED));
}

#[test]
fn no_trim_and_solver_failures_leave_the_state_alone() {
    // A vertical climb: the flight-path frame degenerates and no trim exists (or
    // the decoy cannot trim); either way a typed rejection, no panic.
    let mut c = controller();
    let before = c.snapshot();
    let mut f = frame(0, 0.0);
    f.velocity_ned_mps = [0.0, 0.0, -200.0];
    f.attitude_wxyz = [
        core::f32::consts::FRAC_1_SQRT_2,
        0.0,
        core::f32::consts::FRAC_1_SQRT_2,
        0.0,
    ];
    match send(&mut c, f) {
        DeviceMessage::Rejected(r) => {
            assert!(matches!(
                r.reason,
                RejectReason::NotTrimmed | RejectReason::SolverFailure
            ));
            assert_eq!(c.snapshot(), before);
        }
        DeviceMessage::Output(_) => {}
        other => panic!("{other:?}"),
    }
    // A violent, inconsistent manoeuvre: 10 g sideways jumps in 10 ms, repeatedly.
    let mut c = running(5);
    for k in 6..200u32 {
        let mut f = frame(k, 0.01 * f64::from(k));
        let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
        f.position_ned_m[1] += sign * 50.0;
        f.velocity_ned_mps[1] = (sign * 3000.0) as f32;
        f.acceleration_ned_mps2[1] = (sign * 1e5) as f32;
        f.body_rate_radps = [(sign * 50.0) as f32, 0.0, 0.0];
        let before = c.snapshot();
        match send(&mut c, f) {
            DeviceMessage::Output(o) => assert!(o.connection_tension_n.is_finite()),
            DeviceMessage::Rejected(r) => {
                assert_eq!(c.snapshot(), before, "{r:?}");
            }
            other => panic!("{other:?}"),
        }
    }
}

#[test]
fn commands_are_answered() {
    let mut c = running(1);
    let h = c.hello(&board("mps2-an386"));
    assert_eq!(
        h,
        DeviceMessage::Hello(decoy_link::Hello {
            protocol_version: PROTOCOL_VERSION,
            board: decoy_link::BoardName::new("mps2-an386").unwrap(),
            core_clock_hz: 168_000_000,
            precision_bits: 32,
            segments: 12,
            capacity: CAPACITY as u16,
            control_period_us: 10_000,
            max_step_us: 2_500,
        })
    );
    assert_eq!(
        c.handle(
            HostMessage::Command(Command::Ping { nonce: 42 }),
            &mut NoCounter
        ),
        DeviceMessage::Pong {
            nonce: 42,
            protocol_version: PROTOCOL_VERSION
        }
    );
    match c.handle(HostMessage::Command(Command::GetStatus), &mut NoCounter) {
        DeviceMessage::Status(s) => {
            assert_eq!(
                (s.protocol_version, s.segments, s.time_s),
                (PROTOCOL_VERSION, 12, 0.01)
            );
            assert_eq!(s.counters.frames_ok, 4);
            assert_eq!(s.flags, StatusFlags::TRIMMED);
        }
        other => panic!("{other:?}"),
    }
    let too_fast = Profile::builtin(Manoeuvre::Turn, 5000);
    let before = c.snapshot();
    let answer = c.handle(
        HostMessage::Command(Command::SelectProfile(too_fast)),
        &mut NoCounter,
    );
    assert_eq!(rejected(answer), (None, RejectReason::OutOfRange, 1));
    assert_eq!(c.snapshot(), before);
}

#[test]
fn the_acceleration_profile_uses_frames_as_the_clock() {
    let mut c = controller();
    let status = c.handle(
        HostMessage::Command(Command::SelectProfile(Profile::builtin(
            Manoeuvre::Acceleration,
            0,
        ))),
        &mut NoCounter,
    );
    assert!(StatusFlags(status_flags(status)).contains(StatusFlags::PROFILE_BUILTIN));
    // The frames' kinematics are ignored (here: nonsense, but finite), only the clock counts.
    let clock = |seq: u32, t: f64| {
        let mut f = frame(seq, t);
        f.velocity_ned_mps = [0.0; 3];
        f.attitude_wxyz = [3.0, 0.0, 0.0, 0.0];
        f.position_ned_m[2] = 1e6;
        f
    };
    let start = 50.0;
    let first = output(send(&mut c, clock(0, start)));
    assert!(StatusFlags(first.flags).contains(StatusFlags::PROFILE_BUILTIN | StatusFlags::TRIMMED));
    let mut peak: f32 = 0.0;
    for k in 1..=400u32 {
        let o = output(send(&mut c, clock(k, start + 0.01 * f64::from(k))));
        peak = peak.max(o.connection_tension_n);
    }
    // The run started at the profile's t = 0 (the solver's clock is the frames':
    // profile time 4 s is frame time start + 4 s); it accelerated from t = 2 s.
    assert!((c.state().time - (start + 4.0)).abs() < 1e-9);
    assert!(
        peak > 1.2 * first.connection_tension_n,
        "{peak} vs {}",
        first.connection_tension_n
    );
    // Non-finite clock frames are still rejected.
    let mut bad = clock(401, start + 4.01);
    bad.body_rate_radps[0] = f32::NAN;
    assert_eq!(rejected(send(&mut c, bad)).1, RejectReason::NonFinite);
}

#[test]
fn the_counter_measures_state_frames() {
    struct Ticking(std::cell::Cell<u32>);
    impl InstructionCounter for Ticking {
        fn now(&self) -> u32 {
            self.0.set(self.0.get().wrapping_add(1000));
            self.0.get()
        }
    }
    let mut c = running(1);
    let mut counter = Ticking(std::cell::Cell::new(u32::MAX - 500));
    let o = output(c.handle(HostMessage::State(frame(2, 0.02)), &mut counter));
    // Four readings, 1000 apart, across the wrap: the frame's start, the
    // integration's start and end, the frame's end.
    assert_eq!(o.instructions, 3000);
    assert_eq!(o.step_instructions, 1000);
}

#[test]
fn f64_controllers_agree_with_f32_ones() {
    let mut c64: Controller<f64, 16> = Controller::new(common::config()).unwrap();
    let mut c32: Controller<f32, 16> = Controller::new(common::config()).unwrap();
    // The same frames to both; each initialises over its first frames (f64 to
    // its own resolution, so perhaps a frame later): compared once both answer.
    let mut compared = 0;
    for k in 0..=50u32 {
        let f = frame(k, 0.01 * f64::from(k));
        let answers = (
            common::output_or_initialising(send(&mut c64, f)),
            common::output_or_initialising(send(&mut c32, f)),
        );
        let (Some(a), Some(b)) = answers else {
            assert!(k < 5, "still initialising at frame {k}");
            continue;
        };
        compared += 1;
        let rel =
            ((a.connection_tension_n - b.connection_tension_n) / a.connection_tension_n).abs();
        assert!(rel < 1e-3, "{k}: {a:?} {b:?}");
        assert!((a.cable_clearance_exhaust_m - b.cable_clearance_exhaust_m).abs() < 1e-2);
        for i in 0..3 {
            assert!((a.decoy_position_fp_m[i] - b.decoy_position_fp_m[i]).abs() < 1e-2);
        }
    }
    assert!(compared > 40);
    assert_eq!(
        c64.hello(&board("a-new-board")),
        DeviceMessage::Hello(decoy_link::Hello {
            protocol_version: PROTOCOL_VERSION,
            board: decoy_link::BoardName::new("a-new-board").unwrap(),
            core_clock_hz: 168_000_000,
            precision_bits: 64,
            segments: 12,
            capacity: 16,
            control_period_us: 10_000,
            max_step_us: 2_500,
        })
    );
}

/// Flies a built-in profile for `seconds` with 10 ms clock frames; returns the
/// peak connection tension and the most RK4 steps a frame took.
fn fly_builtin<T: solver_core::Real>(profile: Profile, seconds: f64) -> (f32, u16) {
    let mut c: Controller<T, 64> = Controller::new(common::config()).unwrap();
    let status = c.handle(
        HostMessage::Command(Command::SelectProfile(profile)),
        &mut NoCounter,
    );
    assert!(StatusFlags(status_flags(status)).contains(StatusFlags::PROFILE_BUILTIN));
    let (_, first) = common::initialise(&mut c, |k| frame(k, 0.01 * f64::from(k)));
    let (mut peak, mut most_steps) = (0.0f32, 0u16);
    let mut hist = std::collections::BTreeMap::new();
    let frames = (seconds * 100.0).round() as u32;
    // The profile's clock starts at the frame that completed the trim.
    for k in first + 1..=first + frames {
        let answer = send(&mut c, frame(k, 0.01 * f64::from(k)));
        let DeviceMessage::Output(o) = answer else {
            panic!(
                "{profile:?}: frame {k} (t = {} s) answered {answer:?}",
                0.01 * f64::from(k)
            );
        };
        peak = peak.max(o.connection_tension_n);
        most_steps = most_steps.max(o.steps);
        *hist.entry(o.steps).or_insert(0u32) += 1;
    }
    println!("{profile:?}: frames by RK4 steps {hist:?}");
    (peak, most_steps)
}

#[test]
fn the_paper_manoeuvres_fly_through_with_the_wave_step_limit() {
    // The snatch load after the pull-up (the cable jerked taut at about 8.6 s)
    // would diverge with a step fixed at the cap; the wave-speed limit shortens the
    // step for those frames only. Steady flight keeps four steps per 10 ms frame.
    let cases = [
        (Profile::builtin(Manoeuvre::Steady, 0), 5.0),
        (Profile::builtin(Manoeuvre::Acceleration, 0), 25.0),
        (Profile::builtin(Manoeuvre::PullUp, 50), 15.0),
        (Profile::builtin(Manoeuvre::PullUp, 100), 15.0),
        (Profile::builtin(Manoeuvre::PullUp, 200), 15.0),
        (Profile::builtin(Manoeuvre::Turn, 200), 15.0),
    ];
    for (profile, seconds) in cases {
        let (peak32, steps32) = fly_builtin::<f32>(profile, seconds);
        let (peak64, steps64) = fly_builtin::<f64>(profile, seconds);
        println!(
            "{profile:?}: peak {peak32} N (f64 {peak64} N), at most {steps32} steps (f64 {steps64})"
        );
        if profile == Profile::builtin(Manoeuvre::Steady, 0) {
            assert_eq!(steps32, 4);
        }
        assert!(
            ((peak32 - peak64) / peak64).abs() < 0.05,
            "{profile:?}: f32 peak {peak32} N, f64 {peak64} N"
        );
    }
}

/// The next `count` answers after frame 5, the frames of a gentle climbing turn
/// (so that the stepping rule and the tensions move), as wire bytes.
fn answers_after<T: solver_core::Real>(
    c: &mut Controller<T, CAPACITY>,
    count: u32,
) -> Vec<Vec<u8>> {
    (6..6 + count)
        .map(|k| {
            let t = 0.01 * f64::from(k);
            let mut f = frame(k, t);
            f.acceleration_ned_mps2 = [0.0, 20.0, -10.0];
            f.velocity_ned_mps[1] = (20.0 * (t - 0.05)) as f32;
            f.position_ned_m[1] += 10.0 * (t - 0.05) * (t - 0.05);
            let answer = send(c, f);
            let mut out = [0u8; MAX_WIRE_BYTES];
            let n = encode(&answer, &mut out).unwrap();
            out[..n].to_vec()
        })
        .collect()
}

/// Sends `bad` after frame 5 to one controller and not to another; returns the
/// rejection reason, after checking that the next 20 answers of the two are the
/// same bytes (Outputs, with `instructions` 0 under [`NoCounter`]).
fn disturbed_run_answers_as_the_undisturbed<T: solver_core::Real>(
    bad: decoy_link::AircraftStateFrame,
) -> Option<RejectReason> {
    let mut clean = common::running_in::<T>(5);
    let mut tested = common::running_in::<T>(5);
    let reason = match send(&mut tested, bad) {
        DeviceMessage::Rejected(r) => r.reason,
        DeviceMessage::Output(_) => return None,
        other => panic!("{other:?}"),
    };
    assert_eq!(
        answers_after(&mut clean, 20),
        answers_after(&mut tested, 20),
        "f{}: the answers after a {reason:?} rejection differ from an undisturbed run's",
        core::mem::size_of::<T>() * 8
    );
    Some(reason)
}

#[test]
fn the_answers_after_any_rejection_are_those_of_an_undisturbed_run() {
    let base = frame(6, 0.06);
    let mut cases: Vec<(decoy_link::AircraftStateFrame, Option<RejectReason>)> = vec![
        (
            {
                let mut f = base;
                f.acceleration_ned_mps2[0] = f32::NAN;
                f
            },
            Some(RejectReason::NonFinite),
        ),
        (
            {
                let mut f = base;
                f.attitude_wxyz = [0.9, 0.0, 0.0, 0.0];
                f
            },
            Some(RejectReason::BadQuaternion),
        ),
        (
            {
                let mut f = base;
                f.position_ned_m[2] = 1000.0;
                f
            },
            Some(RejectReason::OutOfRange),
        ),
        (
            {
                let mut f = base;
                f.body_angular_acceleration_radps2 = [1e5, 0.0, 0.0];
                f
            },
            Some(RejectReason::OutOfRange),
        ),
        (
            {
                let mut f = base;
                f.acceleration_ned_mps2 = [0.0, 1e30, 0.0];
                f
            },
            Some(RejectReason::OutOfRange),
        ),
        (
            {
                let mut f = base;
                f.body_rate_radps = [0.0, 0.0, 1e30];
                f
            },
            Some(RejectReason::OutOfRange),
        ),
        (
            {
                let mut f = base;
                f.time_s = 0.05;
                f
            },
            Some(RejectReason::TimeNotIncreasing),
        ),
        (
            {
                let mut f = base;
                f.time_s = 0.5;
                f
            },
            Some(RejectReason::TimeJump),
        ),
    ];
    // Frames inside the envelope whose path the solver cannot follow: the
    // position jumps sideways, so the cubic between the frames demands enormous
    // accelerations (a SolverFailure, or an accepted Output if it copes).
    for jump in [1e2, 1e3, 1e4, 1e5, 1e6] {
        let mut f = base;
        f.position_ned_m[1] += jump;
        cases.push((f, None));
    }
    let mut failures = [0usize; 2];
    for (bad, expected) in &cases {
        let got = [
            disturbed_run_answers_as_the_undisturbed::<f32>(*bad),
            disturbed_run_answers_as_the_undisturbed::<f64>(*bad),
        ];
        for (precision, reason) in got.iter().enumerate() {
            match expected {
                Some(e) => assert_eq!(reason.as_ref(), Some(e), "{bad:?}"),
                None => {
                    failures[precision] += usize::from(*reason == Some(RejectReason::SolverFailure))
                }
            }
        }
    }
    assert!(
        failures.iter().all(|&n| n > 0),
        "no case reached a SolverFailure (f32, f64): {failures:?}"
    );
}

#[test]
fn a_trim_frame_at_the_edge_of_the_envelope_gives_finite_outputs_or_a_rejection() {
    // Huge but finite inputs at the trim: rejected as out of range, never an
    // accepted frame with an infinite tension.
    for set in [
        |f: &mut decoy_link::AircraftStateFrame| f.acceleration_ned_mps2 = [0.0, 0.0, 1e30],
        |f: &mut decoy_link::AircraftStateFrame| {
            f.body_angular_acceleration_radps2 = [0.0, 1e30, 0.0]
        },
        |f: &mut decoy_link::AircraftStateFrame| f.body_rate_radps = [1e30, 0.0, 0.0],
    ] {
        let mut f = frame(0, 0.0);
        set(&mut f);
        let mut c = controller();
        assert_eq!(rejected(send(&mut c, f)).1, RejectReason::OutOfRange);
        assert!(!c.is_trimmed());
    }
    // At the envelope's limits every accepted value is finite.
    let mut f = frame(0, 0.0);
    f.acceleration_ned_mps2 = [0.0, 149.0, 0.0];
    f.body_rate_radps = [6.9, 0.0, 0.0];
    f.body_angular_acceleration_radps2 = [0.0, 0.0, 49.0];
    // The first answers may be the initialisation's (the trim is of the frame's
    // steady flight): the frames after, 10 ms apart, until it is done.
    fn settled<T: solver_core::Real>(
        c: &mut Controller<T, CAPACITY>,
        f: decoy_link::AircraftStateFrame,
    ) -> DeviceMessage {
        for k in 0..64 {
            let mut g = f;
            g.seq = k;
            g.time_s = f.time_s + 0.01 * f64::from(k);
            g.position_ned_m[0] += 182.0 * 0.01 * f64::from(k);
            let answer = send(c, g);
            let initialising = matches!(&answer, DeviceMessage::Status(s)
                if StatusFlags(s.flags).contains(StatusFlags::INITIALISING));
            if !initialising {
                return answer;
            }
        }
        panic!("still initialising");
    }
    for answer in [
        settled(&mut controller(), f),
        settled(
            &mut Controller::<f64, CAPACITY>::new(common::config()).unwrap(),
            f,
        ),
    ] {
        match answer {
            DeviceMessage::Output(o) => {
                assert!(
                    o.connection_tension_n.is_finite() && o.tow_tension_n.is_finite(),
                    "{o:?}"
                )
            }
            DeviceMessage::Rejected(r) => assert_eq!(r.reason, RejectReason::SolverFailure),
            other => panic!("{other:?}"),
        }
    }
}
