#!/bin/bash
# FE family survey of issue 14 item 4 (issue 18): for each seed k = 1..12, the transient from a
# mode-k seed (0.1 d) of SCENE, then `stickslip travel` at the mode it reached, started from its
# last sample (--fixed-omega: nearest admissible speed). One JSON line per seed on stdout.
# Usage: ./dev bash benchmarks/travel_family.sh figure1_n132_damped /tmp/fam >> runs.jsonl
set -u
scene=$1; out=$2
mkdir -p "$out"
for k in 1 2 3 4 5 6 7 8 9 10 11 12; do
  r=$out/${scene}_seed$k
  stickslip run "scenes/$scene.toml" --set initial.mode=$k -o "$r" --force > "$r.log" 2>&1
  m=$(python3 -c "import json; print(json.load(open('$r/summary.json'))['mode'])")
  stickslip travel "scenes/$scene.toml" --k "$m" --from "$r" --fixed-omega -o "${r}_travel" \
    --force > "${r}_travel.log" 2>&1
  python3 - "$scene" "$k" "$r" <<'PY'
import json, sys
scene, k, r = sys.argv[1], int(sys.argv[2]), sys.argv[3]
a = json.load(open(f"{r}/summary.json"))
b = json.load(open(f"{r}_travel/summary.json"))
keys_a = ["regime", "mode", "celerity_m_s", "amplitude_m", "psi1", "psi2", "limit_cycle"]
keys_b = ["status", "regime", "mode", "celerity_m_s", "amplitude_m", "psi1", "psi2",
          "psi1_subnode", "psi2_subnode", "last_residual", "violated", "wall_time_s"]
print(json.dumps({"scene": scene, "seed": k, "run": {x: a.get(x) for x in keys_a},
                  "travel": {x: b.get(x) for x in keys_b}}))
PY
done
