"""What the result cache saves: the README's diagnosis cold, warm, and with one candidate more.

Three diagnoses of the README's campaign (six flows, a concealed hydraulic force, 160-cycle
runs, two sampling phases), each in a fresh process so that only the folder is shared:

1. ``cold``: an empty cache, candidates hydraulic_force and anvil_friction;
2. ``warm``: the same diagnosis again (every run is read);
3. ``plus``: one candidate more (contact_law): only its runs are new.

    python bench/bench_cache.py [--cache DIR]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time

ONE = """
import json, sys, time
from vadsim.fit import candidates, diagnosis
from vadsim.campaigns import synthetic
t0 = time.perf_counter()
truth = candidates.CANDIDATES["hydraulic_force[anvil]"].change({"f_ref": 64.0, "n": 2.0})
camp = synthetic.synthetic_campaign("7in-cde", (200, 300, 400, 500, 600, 650), change=truth,
                                    duration_s=3, cycles=160, analyse_cycles=100, seed=11)
d = diagnosis.diagnose(camp, candidates=json.loads(sys.argv[1]), cycles=160,
                      analyse_cycles=100, phases=2, progress=False, cache=sys.argv[2])
print(json.dumps({"seconds": time.perf_counter() - t0, "physics": d.missing_physics,
                  "heldout": d.final.heldout_rms}))
"""


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cache", default=None, help="cache folder (default: a new temporary one)")
    args = ap.parse_args()
    folder = args.cache or tempfile.mkdtemp(prefix="vadsim-bench-cache-")
    rows = []
    for label, cands in (("cold", ["hydraulic_force", "anvil_friction"]),
                         ("warm", ["hydraulic_force", "anvil_friction"]),
                         ("plus", ["hydraulic_force", "anvil_friction", "contact_law"])):
        t0 = time.perf_counter()
        out = subprocess.run([sys.executable, "-c", ONE, json.dumps(cands), folder],
                             check=True, capture_output=True, text=True)
        got = json.loads(out.stdout.strip().splitlines()[-1])
        rows.append((label, len(cands), time.perf_counter() - t0, got))
        print(f"{label:>5}: {len(cands)} candidates, {got['seconds']:6.1f} s in the diagnosis, "
              f"{rows[-1][2]:6.1f} s wall; {got['physics']}, held-out RMS z "
              f"{got['heldout']:.3f}", flush=True)
    print(f"cache: {folder}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
