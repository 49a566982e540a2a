"""``python -m decoy._ray_cells ADDRESS DIR``: what ``decoy envelope --ray`` runs.

Maps on the Ray cluster at ADDRESS the cells that the map directory DIR (its
``inputs.json`` written by the command line) lacks, storing each there as it
comes (``decoy._envelope.map_on_ray``); the command line then makes the map from
DIR. Prints ``cells DONE TOTAL`` after each cell on stdout and, when it fails,
``error: MESSAGE`` as the last line on stderr, exiting 2 for an error of the
inputs (InputError, ConfigError, ScenarioError: the command line's usage
errors) and 1 for any other.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Sequence

from decoy import _native
from decoy._envelope import map_on_ray

#: The errors the command line reports as usage errors (exit 2).
USAGE_ERRORS = (_native.InputError, _native.ConfigError, _native.ScenarioError)


def main(argv: Sequence[str]) -> int:
    if len(argv) != 2:
        print("error: usage: python -m decoy._ray_cells RAY_ADDRESS MAP_DIR", file=sys.stderr)
        return 2
    address, directory = argv
    try:
        plan = (Path(directory) / "inputs.json").read_text()
        map_on_ray(plan, address, directory, lambda done, total: print(f"cells {done} {total}", flush=True))
    except USAGE_ERRORS as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    except (OSError, _native.DecoyError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    except Exception as e:  # Ray's own failures (a lost node, a worker crash)
        print(f"error: Ray: {type(e).__name__}: {e}".replace("\n", " "), file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
