//! End to end: the smallest-client example against a bridge in an iceoryx2 setup
//! of its own; its printed tensions are the host replay's.

use std::process::Command;

use bridge_local::{Isolated, LocalBridge};
use decoy_config::SystemConfig;
use host_bridge::backend::BackendOptions;

/// The example's binary: `cargo test -p host-bridge` builds it beside the tests
/// (target/<profile>/examples/); a run of this test alone builds it.
fn example_binary() -> std::path::PathBuf {
    let exe = std::env::current_exe().unwrap();
    let profile_dir = exe.parent().unwrap().parent().unwrap();
    let binary = profile_dir.join("examples").join("smallest_client");
    if !binary.exists() {
        let mut cargo = Command::new(env!("CARGO"));
        cargo.args(["build", "-p", "host-bridge", "--example", "smallest_client"]);
        if profile_dir.ends_with("release") {
            cargo.arg("--release");
        }
        assert!(
            cargo.status().unwrap().success(),
            "cannot build the example"
        );
    }
    binary
}

#[test]
fn the_smallest_client_flies_a_second_in_lockstep() {
    let iso = Isolated::new().unwrap();
    let bridge = LocalBridge::start(
        "smallest",
        &SystemConfig::builtin().unwrap(),
        &BackendOptions::default(),
        &iso.config,
    )
    .unwrap();
    let binary = example_binary();
    assert!(
        binary.exists(),
        "{} (cargo test builds the examples)",
        binary.display()
    );
    let out = Command::new(&binary)
        .arg("smallest")
        .envs(iso.env())
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let lines: Vec<&str> = stdout.lines().collect();
    assert_eq!(lines[0], "reset: result 0");
    assert_eq!(lines.len(), 12, "{stdout}");
    assert!(
        lines[11].starts_with("t = 1.00 s  connection tension "),
        "{stdout}"
    );
    let summary = bridge.stop().unwrap();
    assert_eq!(summary.counters.accepted, 101);
    assert_eq!(summary.counters.commands, 1);
    assert_eq!(summary.counters.rejected(), 0);

    // Without a bridge: an error within the deadline, not a hang.
    let out = Command::new(&binary)
        .arg("smallest")
        .envs(iso.env())
        .output()
        .unwrap();
    assert!(!out.status.success());
}
