//! No panic in flight (issue 22): the firmware's frame path, built alone
//! (`firmware/examples/panic_never.rs`: the serve loop over the board's UART and
//! clock, with the controller's `handle` and `background` on every frame, the
//! controller's state hidden from the optimiser), keeps no branch to a panic in
//! any function of this workspace. Each board's build is scanned
//! (`decoy_hil::panic_sites`), and every site that remains must be in a
//! function of [`ALLOWED`]: inside third-party code, each unreachable for the
//! reason given (firmware/README.md, "No panic in flight"). How many branches
//! each such function keeps on each board is a baseline
//! (`crates/hil-tests/baselines.toml`, `[panic_sites.BOARD]`; written with
//! `DECOY_BLESS=1`, `cargo xtask bless`): one more fails, as does a site in a
//! function not listed, whatever the baselines say.
//!
//! The same example built with feature `panic-never` (its panic handler calls a
//! function defined nowhere) would link only with no site at all; the sites
//! listed below are why it does not yet.

use std::collections::BTreeMap;
use std::time::Duration;

mod common;

use common::baselines::{self, Margin, Ratchet};
use common::on_each;
use decoy_hil::firmware;
use decoy_hil::panic_sites::{self, by_function};
use decoy_hil::qemu::Board;

/// The firmware's example of the frame path alone.
const EXAMPLE: &str = "panic_never";
/// Time limit of a build.
const BUILD_TIMEOUT: Duration = Duration::from_secs(900);

/// The section of the baselines.
const SECTION: &str = "panic_sites";

/// The functions whose sites may remain: (the board module whose boards have
/// them, as `firmware/boards.toml` names it, or `None` for every board;
/// function, why unreachable). [`every_allowance_names_a_board_module`] checks
/// the modules; how many branches each keeps is a baseline.
const ALLOWED: &[(Option<&str>, &str, &str)] = &[
    (
        None,
        "panic_never::__cortex_m_rt_main",
        "cobs::decode_in_place (cobs 0.5, dec.rs:535 and :547, inlined with the frame \
         decoder into the serve loop): two indices below the chunk's end by the loop's own \
         condition and the length check before them (malformed input is an Err; the HIL \
         tests and the fuzz test feed garbage, truncated and corrupted frames)",
    ),
    (
        None,
        "_defmt_acquire",
        "defmt-semihosting's logger (QEMU only; hardware logs with defmt-rtt): 'taken \
         reentrantly' needs a log inside a log, i.e. from an interrupt, and the firmware logs \
         in thread mode only; semihosting's BorrowedFd assert (fd != -1) holds for the \
         stdout it opened",
    ),
    (
        None,
        "_defmt_release",
        "defmt-semihosting's logger: release without acquire (defmt pairs them); the same \
         BorrowedFd assert",
    ),
    (
        None,
        "_defmt_write",
        "defmt-semihosting's logger: write outside acquire (defmt writes only between \
         them); the same BorrowedFd assert",
    ),
    (
        Some("stm32f4"),
        "stm32f4xx_hal::rcc::f4::pll::MainPll::fast_setup",
        "stm32f4xx-hal's PLL set-up, at boot (Board::take) before the serve loop, with the \
         board's fixed clock configuration: not on the frame path",
    ),
    (
        Some("stm32f4"),
        "stm32f4xx_hal::rcc::f4::pll::I2sPll::optimize_fixed_m",
        "stm32f4xx-hal's PLL set-up at boot, as above",
    ),
    (
        Some("stm32f4"),
        "stm32f4xx_hal::rcc::f4::pll::I2sPll::setup_shared_m",
        "stm32f4xx-hal's PLL set-up at boot, as above",
    ),
];

fn check(board: Board) {
    let elf = firmware::build_example(board, EXAMPLE, BUILD_TIMEOUT)
        .unwrap_or_else(|e| panic!("{board}: {e}"));
    let sites = panic_sites::panic_sites(&elf).unwrap_or_else(|e| panic!("{board}: {e}"));
    let counts = by_function(&sites);
    let allowed: BTreeMap<&str, &str> = ALLOWED
        .iter()
        .filter(|(module, ..)| module.is_none_or(|m| m == board.module()))
        .map(|(_, f, why)| (*f, *why))
        .collect();
    for (function, n) in &counts {
        println!("{board}: {n} panic branch(es) in {function}");
    }
    let unexpected: Vec<String> = counts
        .iter()
        .filter(|(f, _)| !allowed.contains_key(f.as_str()))
        .map(|(f, n)| {
            let at: Vec<String> = sites
                .iter()
                .filter(|s| &s.function == f)
                .map(|s| format!("{:#x} -> {}", s.address, s.target))
                .collect();
            format!("{n} in {f}: {}", at.join(", "))
        })
        .collect();
    assert!(
        unexpected.is_empty(),
        "{board}: panic sites on the frame path beyond the documented ones:\n{}",
        unexpected.join("\n")
    );
    let ours: Vec<&String> = counts
        .keys()
        .filter(|f| {
            [
                "solver_core::",
                "decoy_controller::",
                "decoy_link::",
                "decoy_firmware::",
            ]
            .iter()
            .any(|p| f.starts_with(p))
        })
        .collect();
    assert!(
        ours.is_empty(),
        "{board}: panic sites in the workspace's code: {ours:?}"
    );
    println!(
        "{board}: {} panic branches, all in the documented third-party places",
        sites.len()
    );
    let path = [SECTION, board.name()];
    if baselines::blessing() {
        baselines::record(&path, |t| {
            t.clear();
            for (function, n) in &counts {
                t.insert(function.clone(), baselines::int(*n as u64));
            }
        });
        return;
    }
    let mut ratchet = Ratchet::new(&path, board.to_string());
    for (function, n) in &counts {
        ratchet.at_most(function, *n as f64, Margin::Exact);
    }
    let functions: Vec<&str> = counts.keys().map(String::as_str).collect();
    ratchet.note_gone(&functions);
    ratchet.finish();
}

/// Every board of the table, one after the other (each build uses both cores).
#[test]
fn no_board_s_frame_path_can_panic() {
    on_each(Board::all(), check);
}

/// Every board module [`ALLOWED`] names is some board's in the table (a
/// renamed module must not lose its allowances silently, nor keep them).
#[test]
fn every_allowance_names_a_board_module() {
    for (module, function, ..) in ALLOWED {
        if let Some(module) = module {
            assert!(
                Board::all().iter().any(|b| b.module() == *module),
                "ALLOWED, {function}: no board of firmware/boards.toml has the module `{module}`"
            );
        }
    }
}
