//! Issue 27, item 3: the bridge's host model (`decoy bridge --segments 300
//! --grading 1 --precision f64`, docs/bridge.md) flies every shipped manoeuvre,
//! at its full duration, at every frame spacing the protocol allows (10 ms, the
//! control period; 50 ms; 100 ms, the largest interval a State frame may follow
//! the last by), with every frame answered: no rejection. The backend is the one
//! `decoy bridge` runs (its 300-segment controller on a thread with the bridge's
//! stack); the frames are the built-in scenarios' aircraft states.

use decoy_config::SystemConfig;
use decoy_hil::flight::{SHIPPED_MANOEUVRES, state_frame};
use decoy_link::{Command, DeviceMessage, HostMessage, RejectReason, StatusFlags};
use decoy_sim::options::RunOptions;
use decoy_sim::scenario::Scenario;
use host_bridge::backend::{BackendOptions, Precision, host_backend};
use host_bridge::local::BRIDGE_STACK_BYTES;

/// Frame spacings, s: the control period, a slow client, the protocol's limit.
const SPACINGS_S: [f64; 3] = [0.01, 0.05, 0.1];

/// The host model behind the bridge: 300 uniform segments in f64.
fn host_model_options() -> BackendOptions {
    BackendOptions {
        precision: Some(Precision::F64),
        segments: Some(300),
        grading: Some(1.0),
        ..BackendOptions::default()
    }
}

/// Flies `name` at `rate` over its full duration with frames `spacing` apart
/// through the host model; returns the rejections (frame, time, answer) and the
/// frames flown.
fn fly(config: &SystemConfig, name: &str, rate: Option<f64>, spacing: f64) -> (Vec<String>, u32) {
    let plan = Scenario::builtin(name)
        .unwrap()
        .plan(
            config,
            &RunOptions {
                rate,
                plots: false,
                ..RunOptions::default()
            },
        )
        .unwrap();
    let mut backend = host_backend(config, &host_model_options()).unwrap();
    let reset = backend
        .handle(HostMessage::Command(Command::ResetToTrim))
        .unwrap();
    assert!(matches!(reset, DeviceMessage::Status(_)), "{reset:?}");
    let frames = (plan.t_end / spacing - 1e-9).ceil() as u32;
    let mut rejected = Vec::new();
    for k in 0..=frames {
        // A product, not a running sum: no accumulated rounding in the times.
        let t = f64::from(k) * spacing;
        let frame = state_frame(k, t, &plan.profile.state_at(t));
        let answer = backend.handle(HostMessage::State(frame)).unwrap();
        match answer {
            DeviceMessage::Output(_) => {}
            // The first frame may answer with the status while it trims.
            DeviceMessage::Status(_) if k == 0 => {}
            other => rejected.push(format!("frame {k} at t = {t:.2} s: {other:?}")),
        }
        backend.background();
    }
    (rejected, frames + 1)
}

#[test]
fn the_host_model_flies_every_shipped_manoeuvre_at_every_frame_spacing() {
    // The 300-segment solver's fixed-capacity arrays are values: the bridge's stack.
    let failures = std::thread::Builder::new()
        .stack_size(BRIDGE_STACK_BYTES)
        .spawn(|| {
            let config = SystemConfig::builtin().unwrap();
            let mut failures = Vec::new();
            // Every shipped manoeuvre at the scenario file's full duration.
            for (kind, rate, _) in SHIPPED_MANOEUVRES {
                let name = kind.name();
                for spacing in SPACINGS_S {
                    let (rejected, flown) = fly(&config, name, rate, spacing);
                    println!(
                        "{name} {rate:?} at {:.0} ms: {flown} frames, {} rejected",
                        spacing * 1e3,
                        rejected.len()
                    );
                    if let Some(first) = rejected.first() {
                        failures.push(format!(
                            "{name} {rate:?} at {:.0} ms spacing: {} of {flown} frames rejected, first {first}",
                            spacing * 1e3,
                            rejected.len()
                        ));
                    }
                }
            }
            failures
        })
        .unwrap()
        .join()
        .unwrap();
    assert!(failures.is_empty(), "{failures:#?}");
}

/// Issue 27, item 4: 48 free-running samples lost at 10 ms spacing (0.49 s
/// without a frame) cost the run, not the session: the first sample after the
/// gap is rejected `TimeJump`, the next one (which follows it) ends the run and
/// starts the initialisation there (docs/protocol.md §4, "A gap"), and every
/// later sample is answered, as a fresh start at that sample would be. The
/// embedded model (the bridge's default, the firmware's bit-exact reference).
#[test]
fn lost_samples_restart_the_run_and_every_later_sample_is_answered() {
    let config = SystemConfig::builtin().unwrap();
    let plan = Scenario::builtin("steady")
        .unwrap()
        .plan(&config, &RunOptions::default())
        .unwrap();
    let frame_at = |k: u32| {
        state_frame(
            k,
            f64::from(k) * 0.01,
            &plan.profile.state_at(f64::from(k) * 0.01),
        )
    };
    let mut backend = host_backend(&config, &BackendOptions::default()).unwrap();
    let mut fresh = host_backend(&config, &BackendOptions::default()).unwrap();
    for b in [&mut backend, &mut fresh] {
        b.handle(HostMessage::Command(Command::ResetToTrim))
            .unwrap();
    }
    for k in 0..100 {
        let answer = backend.handle(HostMessage::State(frame_at(k))).unwrap();
        assert!(
            !matches!(answer, DeviceMessage::Rejected(_)),
            "frame {k}: {answer:?}"
        );
    }
    // Samples 100..148 lost.
    let first = backend.handle(HostMessage::State(frame_at(148))).unwrap();
    let DeviceMessage::Rejected(r) = first else {
        panic!("the first sample after the gap: {first:?}");
    };
    assert_eq!(r.reason, RejectReason::TimeJump);
    for k in 149..400 {
        let (a, b) = (
            backend.handle(HostMessage::State(frame_at(k))).unwrap(),
            fresh.handle(HostMessage::State(frame_at(k))).unwrap(),
        );
        match (&a, &b) {
            (DeviceMessage::Output(x), DeviceMessage::Output(y)) => assert_eq!(
                (
                    x.connection_tension_n.to_bits(),
                    x.decoy_position_fp_m.map(f32::to_bits),
                    x.flags
                ),
                (
                    y.connection_tension_n.to_bits(),
                    y.decoy_position_fp_m.map(f32::to_bits),
                    y.flags
                ),
                "frame {k}"
            ),
            (DeviceMessage::Status(x), DeviceMessage::Status(y)) => {
                assert_ne!(x.flags & StatusFlags::INITIALISING, 0, "frame {k}: {a:?}");
                assert_eq!(x.flags, y.flags, "frame {k}");
            }
            _ => panic!("frame {k} after the gap: {a:?}, a fresh start's {b:?}"),
        }
    }
    let status = backend
        .handle(HostMessage::Command(Command::GetStatus))
        .unwrap();
    let DeviceMessage::Status(s) = status else {
        panic!("{status:?}");
    };
    assert_eq!(s.counters.gap_restarts, 1);
    assert_eq!(s.counters.time_jump, 1);
}
