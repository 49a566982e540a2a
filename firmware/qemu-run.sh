#!/usr/bin/env bash
# The firmware's cargo runner (`runner` in .cargo/config.toml): `cargo run
# --release` boots the ELF under QEMU on the board it was built for, through
# `cargo xtask firmware qemu-run ELF`, which takes the board's QEMU machine from
# firmware/boards.toml (the ELF names its board: the `_decoy_board_NAME` symbol
# the build script defines; DECOY_BOARD=NAME overrides it). This script only
# finds the repository; the runner and its environment (DECOY_LINK_PORT,
# DECOY_LINK_LISTEN, DECOY_QEMU, QEMU_TIMEOUT, DEFMT_RAW) are documented in
# xtask/src/firmware.rs and firmware/README.md.
#
#   ./qemu-run.sh ELF
set -euo pipefail

if [[ $# -ne 1 ]]; then
    echo "usage: $0 ELF" >&2
    exit 2
fi
elf="$(realpath "$1")"
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
# From the repository's root, so that the firmware's .cargo/config.toml (its
# target) does not apply to the host's xtask.
cd "$root"
# The firmware build's settings are not the host's.
unset CARGO_TARGET_DIR CARGO_BUILD_TARGET CARGO_BUILD_TARGET_DIR RUSTFLAGS CARGO_ENCODED_RUSTFLAGS CARGO_BUILD_RUSTFLAGS
exec cargo run --quiet --package xtask -- firmware qemu-run "$elf"
