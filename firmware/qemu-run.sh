#!/usr/bin/env bash
# Boots a firmware ELF under QEMU and returns QEMU's exit code (the firmware's
# semihosting exit status on a failure; the controller itself runs until QEMU is
# stopped). `cargo run --release` calls it (the runner in .cargo/config.toml).
#
#   ./qemu-run.sh ELF
#
# Environment:
#   DECOY_BOARD        m4 (mps2-an386, Cortex-M4F), m7 (mps2-an500, Cortex-M7) or
#                      stm32f405 (netduinoplus2, STM32F405, Cortex-M4F).
#                      Default: m7 if the ELF is under a `m7/` target dir
#                      (`cargo build-m7`), stm32f405 under a `stm32f405/` one
#                      (`cargo build-stm32f405`), else m4.
#   DECOY_LINK_PORT    the host link: UART0 (USART1 on the STM32F405) connects as a TCP client to
#                      127.0.0.1:PORT, where the host must already listen (what
#                      the HIL tests and `decoy hil` do).
#   DECOY_LINK_LISTEN  for a person: QEMU listens on 127.0.0.1:PORT and boots
#                      without waiting; connect any client that speaks
#                      docs/protocol.md.
#                      Neither set: UART0 is not connected (the firmware boots,
#                      logs and idles).
#   QEMU_TIMEOUT       seconds before the run is stopped (default 120).
#   DECOY_QEMU         the QEMU binary (a path, or a name on PATH) instead of
#                      qemu-system-arm from PATH: for example the second version
#                      `cargo xtask setup` unpacks under target/qemu/ (the same
#                      variable decoy-hil reads).
#   DEFMT_RAW=1        write the raw defmt stream to stdout instead of decoding it
#                      with `defmt-print -e ELF` (install: cargo install defmt-print --locked).
#
# -icount shift=0,align=off,sleep=off: virtual time advances exactly 1 ns per
# executed instruction, so SysTick counts instructions deterministically
# (docs/toolchain.md §3). Semihosting carries the defmt logs and the exit code.
set -euo pipefail

if [[ $# -lt 1 ]]; then
    echo "usage: $0 ELF" >&2
    exit 2
fi
ELF="$1"

qemu_bin="${DECOY_QEMU:-qemu-system-arm}"
if ! command -v "$qemu_bin" >/dev/null; then
    if [[ -n "${DECOY_QEMU:-}" ]]; then
        echo "DECOY_QEMU=$DECOY_QEMU: no such QEMU binary" >&2
    else
        echo "qemu-system-arm not found: run \`cargo xtask setup\`" >&2
    fi
    exit 127
fi

board="${DECOY_BOARD:-}"
if [[ -z "$board" ]]; then
    case "$ELF" in
        */m7/*) board=m7 ;;
        */stm32f405/*) board=stm32f405 ;;
        *) board=m4 ;;
    esac
fi
case "$board" in
    m4) machine=(-M mps2-an386 -cpu cortex-m4) ;;
    m7) machine=(-M mps2-an500 -cpu cortex-m7) ;;
    # The machine fixes its CPU (a Cortex-M4F); USART1 is the first -serial.
    stm32f405) machine=(-M netduinoplus2) ;;
    *) echo "DECOY_BOARD must be m4, m7 or stm32f405, not '$board'" >&2; exit 2 ;;
esac

if [[ -n "${DECOY_LINK_PORT:-}" ]]; then
    serial=(-serial "tcp:127.0.0.1:${DECOY_LINK_PORT},nodelay=on")
elif [[ -n "${DECOY_LINK_LISTEN:-}" ]]; then
    serial=(-serial "tcp:127.0.0.1:${DECOY_LINK_LISTEN},server=on,wait=off,nodelay=on")
else
    serial=(-serial null)
fi

qemu=(timeout --kill-after=5 "${QEMU_TIMEOUT:-120}"
    "$qemu_bin" "${machine[@]}"
    -display none -monitor none
    -semihosting-config enable=on,target=native
    -icount shift=0,align=off,sleep=off
    "${serial[@]}"
    -kernel "$ELF")

if [[ "${DEFMT_RAW:-0}" == 1 ]]; then
    exec "${qemu[@]}"
fi
if ! command -v defmt-print >/dev/null; then
    echo "defmt-print not found: cargo install defmt-print --locked (or DEFMT_RAW=1)" >&2
    exit 127
fi
"${qemu[@]}" | defmt-print -e "$ELF"
