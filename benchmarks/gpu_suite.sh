#!/usr/bin/env bash
# The GPU benchmark suite of the batched ensemble, in one call (docs/gpu.md):
#
#   bash benchmarks/gpu_suite.sh [--out DIR] [--data DIR] [--budget S] [MODE]
#
# MODE: (none) the GPU node: every stage, CuPy and the CUDA kernel;
#       --emulate   rehearsal on a CPU: the GPU stages with the CUDA source compiled for the
#                   CPU (benchmarks/gpu_emulate.py), small sizes;
#       --cpu-only  the CPU stages only (the GPU stages are listed as skipped);
#       --quick     the GPU node, every stage with shorter timed spans and one CPU batch
#                   size per N (a lease with a few minutes left);
#       --dry-run   print the stages, their sizes and time limits; run nothing.
#
# Writes DIR/stages.jsonl (one line per measurement), DIR/gpu_suite.json and DIR/gpu_suite.md
# (the table: scene-steps/s of the kernel alone and of the full path with the observers, the
# ratio to one core of the batched numba kernel measured in the same run on the same node,
# the implied memory bandwidth against the device's peak, the GPU/CPU checks and the census).
# DIR defaults to $OUT (set on the device machine), else build/gpu_suite/out. The bundles
# (solver.bundle; node_census: `stickslip attractors figure1_n132_damped --starts 16
# --meshes 132,264 --max-time 0.3 --bundle`) come from --data (default build/gpu_suite);
# where they are missing they are made first, which needs dolfinx (./dev).
#
# Each stage runs under `timeout` with its own limit, clipped to what is left of --budget
# (default 480 s); a stage that fails or runs out of time is recorded as skipped and the suite
# goes on. Exit status: 0 when every stage ran, 1 when one was skipped or failed, 2 on bad use.
set -uo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

mode=gpu
out="${OUT:-build/gpu_suite/out}"
data=build/gpu_suite
budget=480
while [ $# -gt 0 ]; do
  case "$1" in
    --emulate) mode=emulate ;;
    --quick) mode=quick ;;
    --cpu-only) mode=cpu ;;
    --dry-run) mode=dry ;;
    --out) out="$2"; shift ;;
    --data) data="$2"; shift ;;
    --budget) budget="$2"; shift ;;
    -h|--help) sed -n '2,24p' "${BASH_SOURCE[0]}"; exit 0 ;;
    *) echo "error: unknown argument $1 (see --help)" >&2; exit 2 ;;
  esac
  shift
done
case "$budget" in ''|*[!0-9]*) echo "error: --budget $budget: give whole seconds" >&2; exit 2 ;; esac

PY="${PYTHON:-python3}"
BENCH=(env PYTHONUNBUFFERED=1 "$PY" benchmarks/gpu_bench.py)
# one core for the CPU path: pinned, and no thread pool anywhere
ONE_CORE=(env OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1 NUMBA_NUM_THREADS=1)
if command -v taskset >/dev/null; then ONE_CORE+=(taskset -c 0); fi

# sizes: (B of the GPU at N = 132, at N = 528), CPU batch sizes, timed steps, census
if [ "$mode" = gpu ] || [ "$mode" = dry ] || [ "$mode" = quick ]; then
  B132=4096; B528=1024; CPU132="64 256"; CPU528="16 64"
  STEPS=1000; BLOCK=100; CPU_BLOCK=20; SECONDS_CAP=24; CPU_SECONDS=15
  if [ "$mode" = quick ]; then CPU132="256"; CPU528="64"; SECONDS_CAP=5; CPU_SECONDS=4; fi
  CHECK_B=(4096 1024); CHECK_STEPS=200
  CENSUS=(--B 4096 --end-time 0.3 --sample-interval 1e-3)
  CLI=(--starts 4096 --end-time 0.3 --backend gpu)
elif [ "$mode" = cpu ]; then  # the CPU half: the same batch sizes, seconds per stage
  B132=0; B528=0; CPU132="64 256"; CPU528="16 64"
  STEPS=1000; BLOCK=0; CPU_BLOCK=20; SECONDS_CAP=0; CPU_SECONDS=15
  CHECK_B=(0 0); CHECK_STEPS=0
  CENSUS=(); CLI=(--starts 2 --end-time 0.002 --sample-interval 2e-4 --backend cpu)
else  # rehearsal sizes: seconds each on a shared 2-core machine
  B132=16; B528=4; CPU132="16"; CPU528="4"
  STEPS=60; BLOCK=20; CPU_BLOCK=20; SECONDS_CAP=6; CPU_SECONDS=6
  CHECK_B=(16 4); CHECK_STEPS=40
  CENSUS=(--B 16 --end-time 0.01 --sample-interval 2e-4 --scenes 4 --workers 2)
  CLI=(--starts 2 --end-time 0.002 --sample-interval 2e-4 --backend cpu)
fi
EMU=()
[ "$mode" = emulate ] && EMU=(--emulate)

start=$(date +%s)
failed=0
jsonl="$out/stages.jsonl"

left() { echo $(( budget - ($(date +%s) - start) )); }

skip() {  # skip WHAT WHY
  printf '{"stage": "skipped", "what": "%s", "why": "%s"}\n' "$1" "$2" >>"$jsonl"
  echo "-- skipped $1: $2"
}

stage() {  # stage KIND(gpu|cpu|any) NAME LIMIT_S COMMAND...
  local kind="$1" name="$2" limit="$3"; shift 3
  if [ "$mode" = dry ]; then echo "[$kind, <= ${limit} s] $name: $*"; return; fi
  if [ "$kind" = gpu ] && [ "$mode" = cpu ]; then skip "$name" "--cpu-only"; return; fi
  local remaining; remaining=$(( $(left) - 10 ))  # 10 s kept for the report
  if [ "$remaining" -lt 5 ]; then skip "$name" "suite budget spent"; failed=1; return; fi
  [ "$limit" -gt "$remaining" ] && limit=$remaining
  echo "== $name (<= ${limit} s, $(( $(date +%s) - start )) s into the suite)"
  timeout --kill-after=5 "$limit" "$@"
  local rc=$?
  if [ $rc -ne 0 ]; then
    skip "$name" "exit $rc$([ $rc -ge 124 ] && echo ", time limit ${limit} s")"
    failed=1
  fi
}

if [ "$mode" != dry ]; then
  mkdir -p "$out"
  : >"$jsonl"
  for f in problem_n132 problem_n528 census_n132; do
    if [ ! -f "$data/$f/manifest.json" ]; then
      if ! "$PY" -c "import dolfinx" 2>/dev/null; then
        echo "error: $data/$f is missing and dolfinx does not import here: run" \
             "'./dev python3 benchmarks/gpu_bench.py prepare $data' where it does" >&2
        exit 2
      fi
      "${BENCH[@]}" prepare "$data" || exit 2
      break
    fi
  done
  if [ ! -f "$data/node_census/manifest.json" ] && "$PY" -c "import dolfinx" 2>/dev/null; then
    # --max-time 0.3: the suite times the node's legs only, never the answer's continuation,
    # so the census's disk guard need not count samples to 4 s
    stickslip attractors figure1_n132_damped --starts 16 --meshes 132,264 --max-time 0.3 \
      --bundle "$data/node_census" -o "$data/node_census_answer" || exit 2
  fi
fi
P132="$data/problem_n132"
P528="$data/problem_n528"
J=(--json "$jsonl" "${EMU[@]}")

stage any env 60 "${BENCH[@]}" env "${J[@]}"
stage gpu "check N=132" 90 "${BENCH[@]}" check --bundle "$P132" --B "${CHECK_B[0]}" \
  --steps "$CHECK_STEPS" "${J[@]}"
for n in 132 528; do
  if [ $n = 132 ]; then P=$P132; BG=$B132; BC=$CPU132; else P=$P528; BG=$B528; BC=$CPU528; fi
  # the kernel alone, with the observers at the sweep's and at a coarse cadence: in turn
  stage gpu "gpu N=$n B=$BG" 90 "${BENCH[@]}" rate --bundle "$P" --target gpu --B "$BG" \
    --steps "$STEPS" --block "$BLOCK" --seconds "$SECONDS_CAP" "${J[@]}"
  for b in $BC; do
    stage cpu "cpu N=$n B=$b" 60 "${ONE_CORE[@]}" "${BENCH[@]}" rate --bundle "$P" --target cpu \
      --B "$b" --steps "$STEPS" --block "$CPU_BLOCK" --seconds "$CPU_SECONDS" "${J[@]}"
  done
done
stage gpu "check N=528" 90 "${BENCH[@]}" check --bundle "$P528" --B "${CHECK_B[1]}" \
  --steps "$((CHECK_STEPS / 2))" "${J[@]}"
# the product's node runner on the tutorial census's bundle, GPU against CPU (not emulated:
# the runner is its own process)
if [ "$mode" = gpu ] || [ "$mode" = dry ] || [ "$mode" = quick ]; then
  stage gpu "node census" 240 "${BENCH[@]}" node --bundle "$data/node_census" "${J[@]}"
fi
stage gpu "census N=132" 180 "${BENCH[@]}" census --bundle "$data/census_n132" \
  "${CENSUS[@]}" "${J[@]}"
stage gpu "pytest tests/test_gpu.py" 120 "${BENCH[@]}" pytest --bundle "$P132" "${J[@]}"
# the census from the command line needs the FE stack (steady states, meshes) on this node
if [ "$mode" = dry ] || "$PY" -c "import dolfinx" 2>/dev/null; then
  if [ "$mode" = gpu ] || [ "$mode" = dry ] || [ "$mode" = quick ]; then
    stage gpu "cli census" 120 "${BENCH[@]}" cli "${CLI[@]}" "${J[@]}"
  else  # rehearsal: the refusal without CuPy, and a small CPU census through the CLI
    stage cpu "cli --backend gpu" 60 "${BENCH[@]}" cli --starts 2 --end-time 0.002 \
      --backend gpu "${J[@]}"
    stage cpu "cli census" 120 "${BENCH[@]}" cli "${CLI[@]}" "${J[@]}"
  fi
else
  skip "cli census" "dolfinx does not import on this node: the CLI needs the FE stack"
fi
[ "$mode" = dry ] && exit 0
"${BENCH[@]}" report "$jsonl" --out "$out" || failed=1
echo "suite: $(( $(date +%s) - start )) s; results in $out"
exit $failed
