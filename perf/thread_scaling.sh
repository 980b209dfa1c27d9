#!/bin/bash
# Parallel scaling of the step: loop M particle-steps/s of 1D, 2D and 3D runs at 1..16
# threads, and bitwise thread-count determinism (md5 of particles.csv, equal for every
# thread count). Usage: perf/thread_scaling.sh (TLSMPM=path/to/tlsmpm for another
# binary, T="1 2" for other thread counts).
set -u
B=${TLSMPM:-target/release/tlsmpm}
nproc; lscpu | grep -E "Model name|Socket\(s\)|Core\(s\)|Thread\(s\)|NUMA node\(s\)|L3"
run() {
  name=$1; t=$2; shift 2; rm -rf /tmp/o
  if ! $B run "$@" --set output.plots=false --out /tmp/o --threads $t --quiet >/dev/null 2>/tmp/err; then echo "$name t$t FAILED $(head -c 300 /tmp/err)"; return; fi
  w=$(grep -o '"wall_seconds": *[0-9.e+-]*' /tmp/o/summary.json | grep -o '[0-9.e+-]*$')
  n=$(grep -o '"n_particles": *[0-9]*' /tmp/o/summary.json | grep -o '[0-9]*$')
  s=$(grep -o '"n_steps": *[0-9]*' /tmp/o/summary.json | grep -o '[0-9]*$')
  h=$(md5sum /tmp/o/particles.csv | cut -c1-12)
  echo "$name t$t n=$n steps=$s loop=$w Mps=$(awk "BEGIN{printf \"%.2f\", $n*$s/$w/1e6}") md5=$h"
}
T=${T:-"1 2 4 8 16"}
for t in $T; do run mpm1d $t vibrating_bar --set grid.cells=83334 --set time.dt=5e-9 --set time.end=3e-7; done
for t in $T; do run bspline2_1d $t vibrating_bar --set grid.cells=83334 --set time.dt=5e-9 --set time.end=2e-7 --set method.basis='"bspline"' --set method.order=2; done
for t in $T; do run bspline2_2d $t axis_aligned_mms --set grid.cells=500 --set time.dt=1e-6 --set time.end=1e-5; done
for t in $T; do run bspline2_3d $t axis_aligned_mms --set problem.dim=3 --set particles.per_cell=8 --set grid.cells=50 --set time.dt=1e-6 --set time.end=4e-6; done
for t in 1 4 16; do run tls_kron_2d $t axis_aligned_mms --set grid.cells=250 --set time.dt=1e-6 --set time.end=5e-6 --set method.reconstruction='"tls"' --set method.mass='"consistent"' --set solver.kind='"kron"'; done
