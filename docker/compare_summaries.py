"""Compare the summary.json files of two run trees to round-off (docker/test-image.sh).

    python3 docker/compare_summaries.py REFERENCE_DIR OTHER_DIR

Every ``summary.json`` under REFERENCE_DIR must exist at the same relative path under
OTHER_DIR, with the same keys, the same strings/booleans, and every number equal within

    |a - b| <= RTOL * max(|a|, |b|) + ATOL_FLOOR.

RTOL = 1e-9: both trees come from the same code and the same Debian binaries (the image and
./dev's rootfs install one package list; docker/test-image.sh prints whether the versions
agree), run with the same rank count, hence the same mesh partition.  Measured (2026-11-23):
the single-rank sweep scenes are identical bit for bit; the 2-rank smoke run differed by up
to 1.5e-13 (amplitude_m) with the numpy step kernel, exactly as much as two ./dev runs of it
differ from each other (parallel reductions in a different order), and by 0 with the numba
kernel.  1e-9 is round-off with a wide margin, and 1e6
times below any physical difference a scene change makes (the four smoke4 scenes differ by
>= 0.2 % in celerity).  ATOL_FLOOR = 1e-300 only keeps exact zeros comparable.
Machine-dependent keys (wall and phase times, memory) are skipped.  Exit 1 on a mismatch.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

RTOL = 1e-9
ATOL_FLOOR = 1e-300
# Timings and memory (machine- and cache-dependent: the image's numba and JIT caches are cold).
# A key missing here fails the comparison loudly, which is the safe direction.
SKIP = {"wall_time_s", "profile_s", "peak_rss_mb", "contact_s", "kernel_first_call_s"}


def _walk(a: object, b: object, where: str, out: list[str], worst: list[float]) -> None:
    """Append to ``out`` every difference between ``a`` and ``b``; track the worst rel. error."""
    if isinstance(a, dict) and isinstance(b, dict):
        keys_a = set(a) - SKIP
        keys_b = set(b) - SKIP
        if keys_a != keys_b:
            out.append(f"{where}: keys differ: {sorted(keys_a ^ keys_b)}")
        for key in sorted(keys_a & keys_b):
            _walk(a[key], b[key], f"{where}.{key}", out, worst)
    elif isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            _walk(x, y, f"{where}[{i}]", out, worst)
    elif (isinstance(a, (int, float)) and isinstance(b, (int, float))
          and not isinstance(a, bool) and not isinstance(b, bool)):
        if math.isnan(a) or math.isnan(b):
            if not (math.isnan(a) and math.isnan(b)):
                out.append(f"{where}: {a!r} != {b!r}")
            return
        scale = max(abs(a), abs(b))
        err = abs(a - b) / scale if scale > 0 else 0.0
        worst[0] = max(worst[0], err)
        if abs(a - b) > RTOL * scale + ATOL_FLOOR:
            out.append(f"{where}: {a!r} != {b!r} (relative difference {err:.1e})")
    elif a != b:
        out.append(f"{where}: {a!r} != {b!r}")


def compare(ref: Path, other: Path) -> tuple[int, list[str], float]:
    """(number of summaries compared, differences, worst relative difference)."""
    diffs: list[str] = []
    worst = [0.0]
    files = sorted(ref.rglob("summary.json"))
    for f in files:
        rel = f.relative_to(ref)
        g = other / rel
        if not g.is_file():
            diffs.append(f"{rel}: missing under {other}")
            continue
        _walk(json.loads(f.read_text()), json.loads(g.read_text()), str(rel), diffs, worst)
    return len(files), diffs, worst[0]


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        print("usage: compare_summaries.py REFERENCE_DIR OTHER_DIR", file=sys.stderr)
        return 2
    ref, other = Path(argv[0]), Path(argv[1])
    n, diffs, worst = compare(ref, other)
    if n == 0:
        print(f"error: no summary.json under {ref}", file=sys.stderr)
        return 1
    for d in diffs:
        print(f"  {d}", file=sys.stderr)
    verdict = "match" if not diffs else f"{len(diffs)} differences"
    print(f"{n} summaries, {verdict}; largest relative difference {worst:.1e} (rtol {RTOL:g})")
    return 0 if not diffs else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
