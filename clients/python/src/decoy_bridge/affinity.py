"""CPU affinity, as ``decoy bridge --cpu`` and ``decoy feed --cpu`` (docs/bridge.md,
"Cores"): a lockstep client on the bridge's core hands each frame over with a
context switch instead of waking an idle core. Linux's list format: ``0``,
``0,2``, ``0-3``."""

from __future__ import annotations

import os


def parse_cpu_list(text: str) -> set[int]:
    """The CPUs of ``text``; ``ValueError`` saying what is wrong."""
    cpus: set[int] = set()
    for part in text.split(","):
        part = part.strip()
        if not part:
            raise ValueError(f"--cpu {text!r}: an empty item (expected CPU numbers such as 0, 0,2 or 0-3)")
        lo, sep, hi = part.partition("-")
        try:
            a = int(lo)
            b = int(hi) if sep else a
        except ValueError:
            raise ValueError(f"--cpu {text!r}: {part!r} is not a CPU number or range") from None
        if a < 0 or b > 1023:
            raise ValueError(f"--cpu {text!r}: CPUs are 0 to 1023")
        if a > b:
            raise ValueError(f"--cpu {text!r}: the range {a}-{b} runs backwards")
        cpus.update(range(a, b + 1))
    return cpus


def format_cpu_list(cpus: set[int]) -> str:
    """``cpus`` in the list format, ranges folded (``0-3,6``), as the bridge prints them."""
    out: list[str] = []
    ordered = sorted(cpus)
    i = 0
    while i < len(ordered):
        j = i
        while j + 1 < len(ordered) and ordered[j + 1] == ordered[j] + 1:
            j += 1
        out.append(str(ordered[i]) if i == j else f"{ordered[i]}-{ordered[j]}")
        i = j + 1
    return ",".join(out)


def current_cpus() -> str:
    """The CPUs this thread may run on, in the list format ("" where unknown)."""
    try:
        return format_cpu_list(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return ""


def pin(cpus: set[int]) -> None:
    """This thread (and the threads and processes it starts) on ``cpus`` only;
    ``ValueError`` naming a CPU it may not use, nothing changed then."""
    before = os.sched_getaffinity(0)
    try:
        os.sched_setaffinity(0, cpus)
    except OSError as e:
        raise ValueError(f"--cpu {format_cpu_list(cpus)}: none of these CPUs is available to this process ({e.strerror})") from None
    now = os.sched_getaffinity(0)
    missing = sorted(cpus - now)
    if missing:
        os.sched_setaffinity(0, before)
        raise ValueError(f"--cpu {format_cpu_list(cpus)}: CPU {missing[0]} is not available to this process")
