#!/usr/bin/env bash
# Training speed on a GPU machine, wgpu and CPU side by side, in one command.
#
#   scripts/gpu-bench.sh                 # on a machine with a GPU: 640×480 and 1752×1168
#   scripts/gpu-bench.sh --smoke         # anywhere with a Vulkan driver (lavapipe): tiny sizes
#
# Builds the release binaries (or takes them from $OBJECTSPLAT_BIN_DIR, e.g. built on
# another machine of the same architecture), prints the device, then runs
# `objectsplat-bench device-speed`: iterations/s per component kind (small object,
# table-sized object, the background behind the frozen objects with both depth terms,
# the holistic model) on both backends, the peak GPU memory of each run (nvidia-smi),
# and the demo graph's `objects` and `train` wall time on both backends. Fails if any
# wgpu training item ran host steps. Results: $OUT_DIR (default out/gpu-bench/),
# device-speed.md there; copy the table into docs/benchmarks.md with the device's name.
set -euo pipefail
cd "$(dirname "$0")/.."

smoke=0
[ "${1:-}" = "--smoke" ] && smoke=1
out=${OUT_DIR:-out/gpu-bench}
mkdir -p "$out"

if [ -n "${OBJECTSPLAT_BIN_DIR:-}" ]; then
  bin=$OBJECTSPLAT_BIN_DIR
else
  cargo build --release --quiet -p objectsplat -p objectsplat-bench
  bin=target/release
fi

{
  echo "date: $(date -u +%F) commit: $(git rev-parse --short HEAD 2>/dev/null || echo unknown)"
  echo "cpu: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs) × $(nproc)"
  if command -v nvidia-smi >/dev/null; then
    nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader
  fi
} | tee "$out/machine.txt"

# SIZES (empty: none), BACKENDS, ITERATIONS, CPU_ITERATIONS, VIEWS and DEMO_ITERATIONS override
# the defaults. The schedule's events come every 500 iterations whatever the budget.
if [ $smoke = 1 ]; then
  # The suite's smoke test: every stage of the bench on lavapipe in seconds.
  args=(--sizes "${SIZES-64x48}" --iterations "${ITERATIONS:-12}" --views "${VIEWS:-8}"
        --demo-iterations "${DEMO_ITERATIONS:-0}")
else
  # The CPU gets fewer iterations: at 1752×1168 a CPU background runs at about 1 it/s.
  args=(--sizes "${SIZES-640x480,1752x1168}" --iterations "${ITERATIONS:-300}"
        --cpu-iterations "${CPU_ITERATIONS:-40}" --views "${VIEWS:-16}"
        --demo-iterations "${DEMO_ITERATIONS:-3000}")
fi
"$bin/objectsplat-bench" device-speed --binary "$bin/objectsplat" --out "$out" \
 --backends "${BACKENDS:-cpu,wgpu}" \
  --require-device-steps "${args[@]}" 2>&1 | tee "$out/log.txt"
