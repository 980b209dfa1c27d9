#!/usr/bin/env bash
# The MMS-bar comparison (13 methods, 8..128 cells) is `tlsmpm reproduce mms_bar` (docs/reproduce.md).
exec cargo run --release --quiet -- reproduce mms_bar --force --out "${1:-out/mms_comparison}"
