#!/usr/bin/env bash
# Instructions per particle-step of the 2D / 3D time step, counted by callgrind (valgrind)
# inside `TensorStepper::step` only (set-up, body force and output excluded). Unlike wall
# time, the count does not depend on the load of a shared machine, so two builds can be
# compared in one line each (perf/README.md, "Instruction counts").
#
#   perf/count_instructions.sh [TLSMPM_BINARY] [--set KEY=VALUE]...
#
# Default: target/release/tlsmpm on the built-in axis_aligned_mms (2D, quadratic
# B-splines, 50^2 cells, 4 particles per cell, 20 steps of 1e-5 s), one thread.
set -euo pipefail
bin=target/release/tlsmpm
if [ $# -gt 0 ] && [ "${1#--}" = "$1" ]; then bin=$1; shift; fi
command -v valgrind >/dev/null || { echo "needs valgrind (apt-get install valgrind)" >&2; exit 2; }
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
# Only the trait method `<TensorStepper as TensorTimeStepper>::step_ahead` (or `step`) is
# matched: it calls the inherent `TensorStepper::step_ahead`, and a pattern matching both
# toggles collection on and straight off again (0 instructions counted).
valgrind --tool=callgrind --callgrind-out-file="$out/callgrind.out" \
  --toggle-collect='<*TensorStepper*as*TensorTimeStepper*>::step*' \
  "$bin" run axis_aligned_mms --set grid.cells=50 --set time.end=0.0002 \
  --set output.plots=false "$@" --out "$out/run" --threads 1 --quiet >"$out/log" 2>&1 \
  || { cat "$out/log" >&2; exit 1; }
callgrind_annotate "$out/callgrind.out" >"$out/annotated.txt"
total=$(awk '/PROGRAM TOTALS/ {gsub(",", "", $1); print $1; exit}' "$out/annotated.txt")
read -r particles steps < <(python3 -c "import json,sys; s=json.load(open('$out/run/summary.json')); print(s['n_particles'], s['n_steps'])")
python3 -c "print(f'{$total} instructions in {$steps} steps of {$particles} particles: {$total/($particles*$steps):.0f} per particle-step')"
