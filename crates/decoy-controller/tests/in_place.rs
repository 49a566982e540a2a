//! The controller built in place ([`Controller::UNCONFIGURED`], then
//! [`Controller::configure`], as the firmware does in its `static`): unconfigured
//! it answers safely; configured it answers exactly as [`Controller::new`]'s, also
//! after a past of its own; a rejected configuration changes nothing.

mod common;

use common::{CAPACITY, config, controller, frame, running, send};
use decoy_controller::{Controller, ControllerError, NoCounter};
use decoy_link::{
    Command, DeviceMessage, HostMessage, MAX_WIRE_BYTES, Profile, RejectReason, encode,
};
use decoy_schema::Manoeuvre;
use solver_core::ConfigError;

fn command(c: &mut Controller<f32, CAPACITY>, command: Command) -> DeviceMessage {
    c.handle(HostMessage::Command(command), &mut NoCounter)
}

/// The answers to `count` frames from `first` (a gentle climbing turn after the
/// trim, so that the stepping rule and the tensions move), as wire bytes.
fn answers(c: &mut Controller<f32, CAPACITY>, first: u32, count: u32) -> Vec<Vec<u8>> {
    (first..first + count)
        .map(|k| {
            let t = 0.01 * f64::from(k);
            let mut f = frame(k, t);
            if k > first {
                f.acceleration_ned_mps2 = [0.0, 20.0, -10.0];
                f.velocity_ned_mps[1] = (20.0 * (t - 0.01 * f64::from(first))) as f32;
            }
            let mut out = [0u8; MAX_WIRE_BYTES];
            let n = encode(&send(c, f), &mut out).unwrap();
            out[..n].to_vec()
        })
        .collect()
}

#[test]
fn an_unconfigured_controller_answers_commands_and_rejects_state_frames() {
    let mut c = Controller::<f32, CAPACITY>::UNCONFIGURED;
    assert!(matches!(
        command(&mut c, Command::Ping { nonce: 7 }),
        DeviceMessage::Pong { nonce: 7, .. }
    ));
    assert!(matches!(
        command(&mut c, Command::GetStatus),
        DeviceMessage::Status(s) if s.segments == 0
    ));
    // Streamed: the frame cannot be checked against its (zero) atmosphere.
    assert!(matches!(
        send(&mut c, frame(0, 0.0)),
        DeviceMessage::Rejected(_)
    ));
    // A built-in profile skips those checks: nothing to trim.
    assert!(matches!(
        command(
            &mut c,
            Command::SelectProfile(Profile::builtin(Manoeuvre::Steady, 0))
        ),
        DeviceMessage::Status(_)
    ));
    match send(&mut c, frame(1, 0.01)) {
        DeviceMessage::Rejected(r) => assert_eq!(r.reason, RejectReason::NotTrimmed),
        other => panic!("{other:?}"),
    }
    assert!(!c.is_trimmed());
}

#[test]
fn a_controller_configured_in_place_answers_as_the_one_new_builds() {
    let mut fresh = controller();
    let mut in_place = Controller::<f32, CAPACITY>::UNCONFIGURED;
    in_place.configure(&config()).unwrap();
    assert_eq!(in_place.snapshot(), fresh.snapshot());
    assert_eq!(answers(&mut in_place, 0, 30), answers(&mut fresh, 0, 30));
}

#[test]
fn a_reconfigured_controller_keeps_nothing_of_its_past() {
    // A controller that flew, counted, selected a profile and fell silent.
    let mut used = running(20);
    let _ = used.poll_silence(0);
    let _ = used.poll_silence(10_000);
    let _ = command(
        &mut used,
        Command::SelectProfile(Profile::builtin(Manoeuvre::PullUp, 100)),
    );
    let _ = send(&mut used, frame(0, 0.0));
    let _ = send(&mut used, frame(1, 0.01));
    used.configure(&config()).unwrap();
    let mut fresh = controller();
    assert_eq!(used.snapshot(), fresh.snapshot());
    assert_eq!(used.counters(), fresh.counters());
    assert_eq!(used.poll_silence(20_000), fresh.poll_silence(20_000));
    assert_eq!(answers(&mut used, 0, 30), answers(&mut fresh, 0, 30));
}

#[test]
fn a_rejected_configuration_leaves_the_controller_as_it_was() {
    let mut bad_tension = config::<f32>();
    bad_tension.allowable_tension_n = f32::NAN;
    let mut bad_model = config::<f32>();
    bad_model.params.cable.length = -1.0;
    let mut too_many = config::<f32>();
    too_many.params.layout = solver_core::SegmentLayout::Uniform {
        count: CAPACITY + 1,
    };
    let cases = [
        (bad_tension, ControllerError::AllowableTension),
        (
            bad_model,
            ControllerError::Config(ConfigError::NonPositive {
                field: "cable.length",
                value: -1.0,
            }),
        ),
        (
            too_many,
            ControllerError::Config(ConfigError::TooManySegments {
                requested: CAPACITY + 1,
                capacity: CAPACITY,
            }),
        ),
    ];
    for (bad, error) in cases {
        let mut clean = running(10);
        let mut tested = running(10);
        assert_eq!(tested.configure(&bad), Err(error));
        assert_eq!(tested.snapshot(), clean.snapshot(), "{error:?}");
        assert_eq!(tested.counters(), clean.counters(), "{error:?}");
        assert_eq!(
            answers(&mut tested, 11, 20),
            answers(&mut clean, 11, 20),
            "{error:?}"
        );
    }
}
