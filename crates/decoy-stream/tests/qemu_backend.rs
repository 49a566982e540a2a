//! The bridge's qemu backend (`decoy_stream::qemu_backend`): the firmware under
//! QEMU (every f32 board of `firmware/boards.toml`: the M4 and the STM32F405)
//! behind the bridge. A
//! scenario flown in lockstep through shared memory gets the firmware's answers,
//! which equal the host replay of the same frames bit for bit (as `decoy hil`
//! checks over the UART), with the firmware's exact instruction counts.

use bridge_local::{Isolated, LocalBridge};
use decoy_config::SystemConfig;
use decoy_hil::flight::{self, host_controller, replay, scenario_frames, scenario_messages};
use decoy_hil::qemu::{Board, Precision};
use decoy_link::DeviceMessage;
use decoy_stream::qemu_backend::{QemuOptions, qemu_backend};
use host_bridge::client::BridgeClient;
use host_bridge::convert::{from_link_frame, output_to_link};

#[test]
fn lockstep_through_every_f32_firmware_equals_the_host_replay() {
    let boards = Board::with_precision(Precision::F32);
    assert!(!boards.is_empty(), "no f32 board in firmware/boards.toml");
    for board in boards {
        println!("{board}: the scenario in lockstep through the bridge");
        lockstep_through(board);
    }
}

fn lockstep_through(board: Board) {
    let iso = Isolated::new().unwrap();
    let config = SystemConfig::builtin().unwrap();
    let system = config.clone();
    let bridge = LocalBridge::start_with("qemu", &iso.config, move || {
        qemu_backend(
            &system,
            &QemuOptions {
                board,
                ..QemuOptions::default()
            },
        )
    })
    .unwrap();
    let mut c = BridgeClient::connect("qemu", "qemu-client", &iso.config).unwrap();
    let status = c.get_status().unwrap();
    assert_eq!(bridge_types::field_text(&status.board), board.hello());
    assert_eq!((status.precision_bits, status.segments), (32, 12));
    c.simple_command(bridge_types::command::RESET_TO_TRIM)
        .unwrap();
    let scenario = decoy_sim::Scenario::builtin("pull-up").unwrap();
    let plan = scenario
        .plan(
            &config,
            &decoy_sim::RunOptions {
                t_end: Some(3.0),
                ..Default::default()
            },
        )
        .unwrap();
    let frames = scenario_frames(&plan.profile, flight::frame_count(plan.t_end));
    let answers: Vec<DeviceMessage> = frames
        .iter()
        .map(|f| {
            let a = c.step(&from_link_frame(f)).unwrap();
            assert_eq!(a.header.kind, bridge_types::kind::OUTPUT, "{a:?}");
            DeviceMessage::Output(output_to_link(&a.output))
        })
        .collect();
    let host = replay(
        &mut host_controller::<f32>(&config).unwrap(),
        &scenario_messages(&frames),
    );
    let (agreement, mismatches) = flight::compare(&answers, &host[1..]);
    assert!(mismatches.is_empty(), "{:?}", mismatches.first());
    assert_eq!(agreement.outputs, frames.len());
    assert_eq!(agreement.identical, frames.len());
    let stats = flight::instruction_stats(&answers);
    assert!(stats.max > 50_000 && stats.mean > 50_000.0, "{stats:?}");
    drop(c);
    let summary = bridge.stop().unwrap();
    assert_eq!(summary.counters.accepted, frames.len() as u64);
    assert_eq!(summary.backend, "qemu");
}
