#!/usr/bin/env bash
# The project's test command (README: `./dev bash tests/run.sh`; CI runs exactly this).
#   1. ruff check (lint)
#   2. pytest, serial, every test
#   3. the tests marked `parallel` again under `mpirun -n 2`
# A run that collects no test fails. The last line sums both pytest runs: "N passed, N failed".
set -uo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
report=$(mktemp -d)
trap 'rm -rf "$report"' EXIT
status=0

echo "== ruff check"
if ! ruff check .; then status=1; fi

echo "== pytest (serial)"
python3 -m pytest -q -p no:cacheprovider --junitxml="$report/serial.xml" "$@"
rc=$?
[ $rc -eq 0 ] || status=1

echo "== pytest -m parallel under mpirun -n 2"
mpirun -n 2 python3 -m pytest -q -p no:cacheprovider -m parallel \
    --junitxml="$report/parallel.xml" tests/
rc=$?
[ $rc -eq 0 ] || status=1

python3 - "$report" <<'PY' || status=1
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

passed = failed = skipped = 0
for xml in sorted(Path(sys.argv[1]).glob("*.xml")):
    for suite in ET.parse(xml).getroot().iter("testsuite"):
        n = int(suite.get("tests", 0))
        f = int(suite.get("failures", 0)) + int(suite.get("errors", 0))
        s = int(suite.get("skipped", 0))
        passed += n - f - s
        failed += f
        skipped += s
print(f"total: {passed} passed, {failed} failed, {skipped} skipped")
if passed == 0:
    print("error: no test ran", file=sys.stderr)
    sys.exit(1)
PY
exit $status
