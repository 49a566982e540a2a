#!/usr/bin/env bash
# Boots a firmware ELF on QEMU's MPS2 AN386 board (Cortex-M4F) and returns its
# semihosting exit code. Semihosting output goes to stdout.
#
# -icount shift=0,align=off,sleep=off makes virtual time advance exactly 1 ns per
# executed instruction, so the SysTick counter measures instructions,
# deterministically (see /work/shared/TOOLCHAIN.md). QEMU_TIMEOUT (seconds,
# default 120) bounds a run that never exits.
set -euo pipefail

if [[ $# -lt 1 ]]; then
    echo "usage: $0 ELF" >&2
    exit 2
fi
ELF="$1"

if ! command -v qemu-system-arm >/dev/null; then
    echo "qemu-system-arm not found: run \`cargo xtask setup\`" >&2
    exit 127
fi

exec timeout --kill-after=5 "${QEMU_TIMEOUT:-120}" \
    qemu-system-arm -M mps2-an386 -cpu cortex-m4 \
    -display none -monitor none -serial none \
    -semihosting-config enable=on,target=native \
    -icount shift=0,align=off,sleep=off \
    -kernel "$ELF"
