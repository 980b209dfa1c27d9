#!/usr/bin/env bash
# The MMS-bar comparison study of the IMLS paper (SPEC §6.5, issue 7), in one command:
#
#   bash scripts/mms_comparison.sh [OUT_DIR]      (default out/mms_comparison)
#
# Runs `tlsmpm study scenarios/mms_bar.toml` over 8, 16, 32, 64, 128 cells (3 particles per
# cell, A = 0.1 m, dt = 1e-5 s, end 0.02 s) for every method below, writes each study into
# OUT_DIR/<method>/, one log-log plot per field (OUT_DIR/rms_<field>.svg, all methods
# against h) and the table of observed RMS orders (OUT_DIR/orders.md, also printed).
# Override the cell counts with CELLS=8,16,32 (e.g. for a quick look).
set -euo pipefail

out=${1:-out/mms_comparison}
cells=${CELLS:-8,16,32,64,128}
cd "$(dirname "$0")/.."
cargo build --release --quiet
bin=target/release/tlsmpm
SECONDS=0

# label | scenario overrides
methods=(
  "MPM|method.reconstruction=none"
  "CPDI|method.basis=cpdi method.reconstruction=none"
  "MLS|method.reconstruction=mls"
  "IMLS|method.reconstruction=imls"
  "IMLS-CONSISTENT|method.reconstruction=imls method.mass=consistent"
  "IMLS-GRADIENT|method.reconstruction=imls method.strain=gradient"
  "IMLS-GRADIENT-USL|method.reconstruction=imls method.strain=gradient method.scheme=usl"
  "IMLS-CPDI|method.reconstruction=imls method.basis=cpdi"
  "IMLS-BSPLINE|method.reconstruction=imls method.basis=bspline method.order=2"
  "MPM-TLS|method.reconstruction=tls"
  "MPM-TLS-USL|method.reconstruction=tls method.scheme=usl"
  "BSMPM-TLS|method.basis=bspline method.order=2 method.reconstruction=tls"
  "BSMPM-TLS-USL|method.basis=bspline method.order=2 method.reconstruction=tls method.scheme=usl"
)

mkdir -p "$out"
dirs=()
labels=()
for entry in "${methods[@]}"; do
  label=${entry%%|*}
  sets=()
  for kv in ${entry#*|}; do sets+=(--set "$kv"); done
  dir="$out/$label"
  echo "== $label (${entry#*|})" >&2
  "$bin" study scenarios/mms_bar.toml --cells "$cells" --quiet --force --out "$dir" "${sets[@]}" >/dev/null
  dirs+=("$dir")
  labels+=(--label "$label")
done

for field in displacement velocity stress; do
  "$bin" overlay "${dirs[@]}" --axis h --field "rms_$field" "${labels[@]}" \
    --out "$out/rms_$field.svg" >/dev/null
done

# Observed orders per field, from each study.csv (columns found by name).
{
  echo "| method | u | v | sigma | u RMS at the finest grid |"
  echo "|---|---|---|---|---:|"
  for dir in "${dirs[@]}"; do
    awk -F, -v label="$(basename "$dir")" '
      NR == 1 { for (i = 1; i <= NF; i++) col[$i] = i; next }
      {
        if (NR > 2) {
          sep = (NR > 3) ? " / " : ""
          u = u sep sprintf("%.2f", $col["order_displacement"])
          v = v sep sprintf("%.2f", $col["order_velocity"])
          s = s sep sprintf("%.2f", $col["order_stress"])
        }
        last = $col["rms_displacement"]
      }
      END { printf "| %s | %s | %s | %s | %.2e |\n", label, u, v, s, last }
    ' "$dir/study.csv"
  done
} | tee "$out/orders.md"
echo "studies, overlays and table: ${SECONDS} s after the build" >&2
