//! The smallest client of `decoy bridge`: iceoryx2 and the wire types only.
//! Resets the controller, flies one second of steady level flight (9 km, 240 m/s)
//! in lockstep and prints the cable tension every 0.1 s. See README.md.

use core::time::Duration;
use std::time::Instant;

use bridge_types::{
    AircraftState, Answer, Command, CommandReply, Header, Status, command, event, kind,
};
use iceoryx2::prelude::*;

fn main() -> Result<(), Box<dyn core::error::Error>> {
    let instance = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "default".to_owned());

    // The bridge's iceoryx2 setup (the same prefix and root; defaults otherwise).
    let mut config = Config::default();
    if let Ok(prefix) = std::env::var("DECOY_IOX_PREFIX") {
        config.global.prefix = FileName::new(prefix.as_bytes())?;
    }
    if let Ok(root) = std::env::var("DECOY_IOX_ROOT") {
        config
            .global
            .set_root_path(&Path::new(format!("{root}/").as_bytes())?);
    }
    let node = NodeBuilder::new()
        .config(&config)
        .create::<ipc::Service>()?;

    let service = |name: &str| ServiceName::new(&format!("decoy/{instance}/{name}"));
    // Ready once the `status` service has its publisher: the bridge creates it
    // after every other service and port (docs/bridge.md, "Readiness"), so
    // nothing sent from here on is lost to a bridge still starting.
    let deadline = Instant::now() + Duration::from_secs(5);
    while !node
        .service_builder(&service("status")?)
        .publish_subscribe::<Status>()
        .open()
        .is_ok_and(|status| status.dynamic_config().number_of_publishers() > 0)
    {
        if Instant::now() > deadline {
            return Err(format!("no bridge {instance:?} ready within 5 s").into());
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    let lockstep = node
        .service_builder(&service("lockstep")?)
        .request_response::<AircraftState, Answer>()
        .open()?
        .client_builder()
        .create()?;
    let commands = node
        .service_builder(&service("commands")?)
        .request_response::<Command, CommandReply>()
        .open()?
        .client_builder()
        .create()?;
    let wake_bridge = node
        .service_builder(&service("to-bridge")?)
        .event()
        .open()?
        .notifier_builder()
        .create()?;
    let bridge_woke_us = node
        .service_builder(&service("from-bridge")?)
        .event()
        .open()?
        .listener_builder()
        .create()?;

    // The next state trims the controller.
    let reset = Command {
        header: Header::new(kind::COMMAND, 0),
        command: command::RESET_TO_TRIM,
        ..Default::default()
    };
    let pending = commands.send_copy(reset)?;
    wake_bridge.notify_with_custom_event_id(EventId::new(event::COMMAND))?;
    loop {
        if let Some(reply) = pending.receive()? {
            println!("reset: result {}", reply.result);
            break;
        }
        if bridge_woke_us.timed_wait(|_| {}, Duration::from_secs(5))? == 0 {
            return Err("no answer from the bridge within 5 s".into());
        }
    }

    for k in 0..=100u32 {
        let t = f64::from(k) * 0.01;
        let state = AircraftState {
            header: Header::new(kind::AIRCRAFT_STATE, k),
            time_s: t,
            position_ned_m: [240.0 * t, 0.0, -9000.0],
            velocity_ned_mps: [240.0, 0.0, 0.0],
            attitude_wxyz: [1.0, 0.0, 0.0, 0.0],
            ..Default::default()
        };
        let pending = lockstep.send_copy(state)?;
        wake_bridge.notify_with_custom_event_id(EventId::new(event::REQUEST))?;
        let answer = loop {
            if let Some(answer) = pending.receive()? {
                break *answer;
            }
            if bridge_woke_us.timed_wait(|_| {}, Duration::from_secs(5))? == 0 {
                return Err("no answer from the bridge within 5 s".into());
            }
        };
        match answer.header.kind {
            kind::OUTPUT => {}
            // The controller is still computing its trim: no solution yet.
            kind::INITIALISING => {
                println!("t = {t:.2} s  initialising");
                continue;
            }
            _ => {
                return Err(
                    format!("state {k} rejected: reason {}", answer.rejection.reason).into(),
                );
            }
        }
        if k % 10 == 0 {
            println!(
                "t = {:.2} s  connection tension {:.3} N  decoy {:.2} m behind, {:.2} m below",
                answer.output.time_s,
                answer.output.connection_tension_n,
                -answer.output.decoy_position_fp_m[0],
                answer.output.decoy_position_fp_m[2]
            );
        }
    }
    Ok(())
}
