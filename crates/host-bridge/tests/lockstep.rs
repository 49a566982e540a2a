//! The bridge in this process (host backend) driven by clients over iceoryx2,
//! each test in an iceoryx2 setup of its own: lockstep answers equal `decoy
//! hil`'s host replay of the same frames bit for bit, whatever the pace; typed
//! rejections leave the controller untouched; free-running samples are all
//! processed and counted; commands; two instances side by side.

use std::time::Duration;

use bridge_types::{
    AircraftState, Answer, Command, Header, command, health, kind, profile, reason, result,
};
use decoy_config::SystemConfig;
use decoy_hil::flight::{self, host_controller, replay, scenario_frames, scenario_messages};
use decoy_link::{AircraftStateFrame, DeviceMessage};
use decoy_schema::Manoeuvre;
use host_bridge::BridgeError;
use host_bridge::backend::{BackendOptions, Precision};
use host_bridge::client::BridgeClient;
use host_bridge::convert::{from_link_frame, output_from_link};
use host_bridge::local::{Isolated, LocalBridge};
use solver_core::profiles::LevelAcceleration;

fn frames(count: u32) -> Vec<AircraftStateFrame> {
    let path = LevelAcceleration {
        altitude: 9000.0,
        initial_speed: 182.0,
        final_speed: 243.0,
        start: 0.5,
        acceleration: 10.0,
    };
    scenario_frames(&path, count)
}

/// The host replay's answers (f32, decoy-hil's reference), as wire answers'
/// outputs, for the states only.
fn replay_outputs(frames: &[AircraftStateFrame]) -> Vec<DeviceMessage> {
    let config = SystemConfig::builtin().unwrap();
    let mut c = host_controller::<f32>(&config).unwrap();
    replay(&mut c, &scenario_messages(frames))[1..].to_vec()
}

fn bits(a: &Answer) -> Vec<u32> {
    let o = &a.output;
    let mut v = vec![
        o.request_seq,
        u32::from(o.flags),
        u32::from(o.steps),
        o.instructions,
    ];
    v.extend(
        [
            o.connection_tension_n,
            o.tow_tension_n,
            o.angle_of_attack_rad,
            o.cable_clearance_exhaust_m,
            o.decoy_clearance_aircraft_m,
        ]
        .iter()
        .chain(&o.decoy_position_fp_m)
        .chain(&o.decoy_euler_rel_rad)
        .map(|x| x.to_bits()),
    );
    v.push(o.time_s.to_bits() as u32);
    v
}

fn assert_equal_to_replay(answers: &[Answer], replayed: &[DeviceMessage]) {
    assert_eq!(answers.len(), replayed.len());
    for (i, (a, r)) in answers.iter().zip(replayed).enumerate() {
        let DeviceMessage::Output(out) = r else {
            panic!("the replay rejected frame {i}: {r:?}");
        };
        assert_eq!(a.header.kind, kind::OUTPUT, "frame {i}: {a:?}");
        let expected = output_from_link(out);
        assert_eq!(a.output, expected, "frame {i}");
        assert_eq!(bits(a), {
            let mut e = *a;
            e.output = expected;
            bits(&e)
        });
    }
}

fn start(iso: &Isolated, instance: &str) -> LocalBridge {
    LocalBridge::start(
        instance,
        &SystemConfig::builtin().unwrap(),
        &BackendOptions::default(),
        &iso.config,
    )
    .unwrap()
}

fn client(iso: &Isolated, instance: &str, name: &str) -> BridgeClient {
    BridgeClient::connect(instance, name, &iso.config).unwrap()
}

fn reset(c: &mut BridgeClient) {
    let r = c.simple_command(command::RESET_TO_TRIM).unwrap();
    assert_eq!(r.result, result::OK);
    assert_eq!(r.status.health, health::WAITING);
}

/// A whole scenario (25 s of the paper's acceleration, 2,501 frames) in
/// lockstep: every frame answered, none lost, each output equal to `decoy
/// hil`'s host replay (f32, the firmware's bits) of the same frames bit for bit.
#[test]
fn lockstep_over_a_whole_scenario_equals_the_host_replay_bit_for_bit() {
    let iso = Isolated::new().unwrap();
    let bridge = start(&iso, "whole");
    let mut c = client(&iso, "whole", "whole-client");
    reset(&mut c);
    let config = SystemConfig::builtin().unwrap();
    let scenario = decoy_sim::Scenario::builtin("acceleration").unwrap();
    let plan = scenario
        .plan(&config, &decoy_sim::RunOptions::default())
        .unwrap();
    let frames = scenario_frames(&plan.profile, flight::frame_count(plan.t_end));
    assert_eq!(frames.len(), 2501);
    let answers: Vec<Answer> = frames
        .iter()
        .map(|f| c.step(&from_link_frame(f)).unwrap())
        .collect();
    assert_equal_to_replay(&answers, &replay_outputs(&frames));
    let status = c.get_status().unwrap();
    assert_eq!(status.counters.lockstep_requests, 2501);
    assert_eq!(status.counters.accepted, 2501);
    assert_eq!(status.counters.rejected(), 0);
    assert_eq!(status.counters.lost, 0);
    drop(c);
    let summary = bridge.stop().unwrap();
    assert_eq!(summary.counters.accepted, 2501);
    assert_eq!(summary.ended_by, "stop request");
}

/// The same states give the same bytes flat out and with pauses longer than the
/// silence time between them (the bridge reports the silences, the answers do
/// not change).
#[test]
fn answers_do_not_depend_on_the_pace_of_the_client() {
    let iso = Isolated::new().unwrap();
    let _bridge = start(&iso, "pace");
    let mut c = client(&iso, "pace", "pace-client");
    let frames = frames(60);
    reset(&mut c);
    let flat: Vec<Answer> = frames
        .iter()
        .map(|f| c.step(&from_link_frame(f)).unwrap())
        .collect();
    reset(&mut c);
    let mut paused = Vec::new();
    for (i, f) in frames.iter().enumerate() {
        if i == 10 || i == 40 {
            std::thread::sleep(Duration::from_millis(450));
            let s = c.get_status().unwrap();
            assert_eq!(s.health, health::DEGRADED, "after a pause at frame {i}");
        }
        paused.push(c.step(&from_link_frame(f)).unwrap());
    }
    let strip = |v: &[Answer]| v.iter().map(|a| a.output).collect::<Vec<_>>();
    assert_eq!(strip(&flat), strip(&paused));
    assert_equal_to_replay(&flat, &replay_outputs(&frames));
    let s = c.get_status().unwrap();
    assert_eq!(s.health, health::RECOVERED);
    assert!(s.counters.silences >= 2, "{:?}", s.counters);
}

/// Every kind of bad state gets its typed rejection and counter; the
/// controller's state is untouched: the valid states around them are answered
/// exactly as in an undisturbed run.
#[test]
fn bad_states_are_typed_rejections_and_change_nothing() {
    let iso = Isolated::new().unwrap();
    let _bridge = start(&iso, "bad");
    let mut c = client(&iso, "bad", "bad-client");
    reset(&mut c);
    let frames = frames(40);
    let replayed = replay_outputs(&frames);
    let mut answers = Vec::new();
    let mut expected_counts = std::collections::HashMap::new();
    for (i, f) in frames.iter().enumerate() {
        if i > 0 && i % 5 == 0 {
            let good = from_link_frame(f);
            let mut bad: Vec<(AircraftState, u16)> = Vec::new();
            let mut s = good;
            s.velocity_ned_mps[1] = f32::NAN;
            bad.push((s, reason::NON_FINITE));
            let mut s = good;
            s.attitude_wxyz = [0.9, 0.0, 0.0, 0.0];
            bad.push((s, reason::BAD_QUATERNION));
            let mut s = good;
            s.position_ned_m[2] = -30_000.0;
            bad.push((s, reason::OUT_OF_RANGE));
            let mut s = good;
            s.time_s = frames[i - 1].time_s;
            bad.push((s, reason::TIME_NOT_INCREASING));
            let mut s = good;
            s.time_s += 0.5;
            bad.push((s, reason::TIME_JUMP));
            let mut s = good;
            s.header.protocol_version = bridge_types::PROTOCOL_VERSION + 1;
            bad.push((s, reason::WRONG_VERSION));
            let mut s = good;
            s.header.kind = kind::STATUS;
            bad.push((s, reason::WRONG_TYPE));
            for (state, code) in bad {
                let a = c.step(&state).unwrap();
                assert_eq!(a.header.kind, kind::REJECTED, "{code}: {a:?}");
                assert_eq!(a.rejection.reason, code);
                assert_eq!(a.rejection.request_seq, state.header.seq);
                let n = expected_counts.entry(code).or_insert(0u64);
                *n += 1;
                assert_eq!(a.rejection.count, *n);
                assert_eq!(a.output, Default::default());
            }
        }
        answers.push(c.step(&from_link_frame(f)).unwrap());
    }
    assert_equal_to_replay(&answers, &replayed);
    let s = c.get_status().unwrap().counters;
    assert_eq!(s.non_finite, 8);
    assert_eq!(s.bad_quaternion, 8);
    assert_eq!(s.out_of_range, 8);
    assert_eq!(s.time_not_increasing, 8);
    assert_eq!(s.time_jump, 8);
    assert_eq!(s.wrong_version, 8);
    assert_eq!(s.wrong_type, 8);
    assert_eq!(s.accepted, 41);
}

/// Free-running: every published state is processed in order and answered on
/// the outputs service, as the replay answers it; nothing lost.
#[test]
fn free_running_states_are_all_processed_in_order() {
    let iso = Isolated::new().unwrap();
    let _bridge = start(&iso, "free");
    let mut c = client(&iso, "free", "free-client");
    reset(&mut c);
    c.take_outputs().unwrap();
    let frames = frames(300);
    for f in &frames {
        c.publish(&from_link_frame(f)).unwrap();
    }
    let mut got: Vec<Answer> = Vec::new();
    let deadline = std::time::Instant::now() + Duration::from_secs(20);
    while got.len() < frames.len() && std::time::Instant::now() < deadline {
        c.wait_event(Duration::from_millis(50)).unwrap();
        got.extend(c.take_outputs().unwrap());
    }
    assert_eq!(got.len(), frames.len());
    for w in got.windows(2) {
        assert_eq!(
            w[1].header.seq,
            w[0].header.seq.wrapping_add(1),
            "outputs numbered +1"
        );
    }
    assert_equal_to_replay(&got, &replay_outputs(&frames));
    let s = c.get_status().unwrap().counters;
    assert_eq!(s.free_samples, 301);
    assert_eq!(s.lost, 0);
}

/// A gap in a publisher's numbers is counted as lost, never hidden.
#[test]
fn gaps_in_free_running_numbers_are_counted_lost() {
    let iso = Isolated::new().unwrap();
    let _bridge = start(&iso, "gaps");
    let mut c = client(&iso, "gaps", "gaps-client");
    reset(&mut c);
    let frames = frames(20);
    for f in frames.iter().filter(|f| f.seq != 7 && f.seq != 8) {
        c.publish(&from_link_frame(f)).unwrap();
    }
    let deadline = std::time::Instant::now() + Duration::from_secs(10);
    loop {
        let s = c.get_status().unwrap().counters;
        if s.free_samples == 19 || std::time::Instant::now() > deadline {
            assert_eq!(s.free_samples, 19);
            assert_eq!(s.lost, 2);
            assert_eq!(
                s.time_jump, 0,
                "10 ms frames with a 30 ms gap are still within 0.1 s"
            );
            break;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn commands_answer_with_the_status() {
    let iso = Isolated::new().unwrap();
    let _bridge = start(&iso, "cmd");
    let mut c = client(&iso, "cmd", "cmd-client");
    let r = c
        .command(Command {
            command: command::PING,
            nonce: 0xDEC0,
            ..Default::default()
        })
        .unwrap();
    assert_eq!(
        (r.result, r.nonce, r.command),
        (result::OK, 0xDEC0, command::PING)
    );
    assert_eq!(r.status.segments, 12);
    assert_eq!(r.status.precision_bits, 32);
    assert_eq!(r.status.capacity, 64);
    assert_eq!(bridge_types::field_text(&r.status.board), "host");
    assert_eq!(bridge_types::field_text(&r.status.instance), "cmd");
    let r = c
        .command(Command {
            command: command::SELECT_PROFILE,
            profile: profile::of(Manoeuvre::Turn),
            rate_milli_radps: 2000,
            ..Default::default()
        })
        .unwrap();
    assert_eq!(
        (r.result, r.reason),
        (result::REJECTED, reason::OUT_OF_RANGE)
    );
    let r = c.simple_command(42).unwrap();
    assert_eq!((r.result, r.reason), (result::REJECTED, reason::WRONG_TYPE));
    let mut bad = Command {
        command: command::GET_STATUS,
        ..Default::default()
    };
    bad.header = Header::new(kind::COMMAND, 1);
    let r = c.command(bad).unwrap();
    assert_eq!(r.result, result::OK);
    // A built-in profile: the states are the clock only.
    let r = c
        .command(Command {
            command: command::SELECT_PROFILE,
            profile: profile::of(Manoeuvre::Steady),
            ..Default::default()
        })
        .unwrap();
    assert_eq!(r.result, result::OK);
    let a = c.step(&from_link_frame(&frames(0)[0])).unwrap();
    assert_eq!(a.header.kind, kind::OUTPUT);
    assert_ne!(a.output.flags & decoy_link::StatusFlags::PROFILE_BUILTIN, 0);
    assert_eq!(c.get_status().unwrap().counters.commands, 6);
}

/// Two bridges with different names in one setup, and two with the same name in
/// two setups: each client reaches its own bridge only.
#[test]
fn instances_side_by_side_never_cross_talk() {
    let iso = Isolated::new().unwrap();
    let other_setup = Isolated::new().unwrap();
    let _a = start(&iso, "alpha");
    let _b = LocalBridge::start(
        "beta",
        &SystemConfig::builtin().unwrap(),
        &BackendOptions {
            precision: Some(Precision::F64),
            segments: Some(8),
            ..BackendOptions::default()
        },
        &iso.config,
    )
    .unwrap();
    let _a2 = start(&other_setup, "alpha");
    let mut ca = client(&iso, "alpha", "ca");
    let mut cb = client(&iso, "beta", "cb");
    let mut ca2 = client(&other_setup, "alpha", "ca2");
    reset(&mut ca);
    reset(&mut cb);
    for f in &frames(5) {
        assert_eq!(
            ca.step(&from_link_frame(f)).unwrap().header.kind,
            kind::OUTPUT
        );
    }
    // The f64 bridge answers `initialising` while its trim runs (a frame or
    // two in f64), then outputs.
    let kinds: Vec<u16> = frames(5)
        .iter()
        .map(|f| cb.step(&from_link_frame(f)).unwrap().header.kind)
        .collect();
    let first_output = kinds.iter().position(|&k| k == kind::OUTPUT).unwrap();
    assert!(
        kinds[..first_output]
            .iter()
            .all(|&k| k == kind::INITIALISING)
            && kinds[first_output..].iter().all(|&k| k == kind::OUTPUT),
        "{kinds:?}"
    );
    let (sa, sb, sa2) = (
        ca.get_status().unwrap(),
        cb.get_status().unwrap(),
        ca2.get_status().unwrap(),
    );
    assert_eq!(
        (sa.counters.accepted, sa.segments, sa.precision_bits),
        (6, 12, 32)
    );
    assert_eq!(
        (sb.counters.accepted, sb.segments, sb.precision_bits),
        // `accepted` counts the states answered by an output.
        ((kinds.len() - first_output) as u64, 8, 64)
    );
    assert_eq!(sa2.counters.accepted, 0);
    // A second bridge with a taken name does not start.
    let again = LocalBridge::start(
        "alpha",
        &SystemConfig::builtin().unwrap(),
        &BackendOptions::default(),
        &iso.config,
    );
    assert!(matches!(again, Err(BridgeError::Ipc(m)) if m.contains("another bridge")));
}

#[test]
fn no_bridge_is_a_plain_error_not_a_hang() {
    let iso = Isolated::new().unwrap();
    let started = std::time::Instant::now();
    let e = BridgeClient::connect("nobody", "lonely", &iso.config)
        .err()
        .unwrap();
    assert!(matches!(e, BridgeError::NoBridge(_)), "{e}");
    assert!(e.to_string().contains("no bridge named \"nobody\""), "{e}");
    assert!(started.elapsed() < Duration::from_secs(5));
}

/// A stopped bridge leaves nothing behind but iceoryx2's global management file.
#[test]
fn a_stopped_bridge_leaves_no_files() {
    let iso = Isolated::new().unwrap();
    let bridge = start(&iso, "tidy");
    {
        let mut c = client(&iso, "tidy", "tidy-client");
        reset(&mut c);
        c.step(&from_link_frame(&frames(0)[0])).unwrap();
    }
    bridge.stop().unwrap();
    assert_eq!(iso.leftovers(), Vec::<std::path::PathBuf>::new());
}
