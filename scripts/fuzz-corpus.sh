#!/usr/bin/env bash
# Seed corpus of the cargo-fuzz targets (docs/robustness.md, "cargo-fuzz
# targets"): writes fuzz/seeds/<target>/ and fuzz/events/small-quake/ (the
# event folder the manifest target loads), both git-ignored.
#
# The seeds are those of the seeded mutation fuzzing (tests/it/fuzz.rs):
# small inputs made from sample-records/ and the real records of
# ../shared/records, read in place (never copied into the repository: only
# into the ignored seeds), plus the pipeline files, the other sample
# manifests and a few small synthetic inputs written below.
#
# Usage: scripts/fuzz-corpus.sh      (uses CARGO_TARGET_DIR as usual)
set -euo pipefail
cd "$(dirname "$0")/.."
fuzz=$PWD/fuzz
QUAKETWIN_FUZZ_CORPUS=$fuzz cargo test --test it fuzz_cargo_fuzz_corpus_shared \
  -- --ignored --nocapture

corpus=$fuzz/seeds
for ev in sample-records/*/; do
  name=$(basename "$ev")
  [ -f "$ev/event.toml" ] && cp "$ev/event.toml" "$corpus/manifest/sample-$name.toml"
done
# Small synthetic inputs: the least each format accepts.
printf 'PEER NGA STRONG MOTION DATABASE RECORD\nsynthetic, 1 component\nACCELERATION TIME SERIES IN UNITS OF G\nNPTS=    4, DT=   .0100 SEC\n  .1000E-01  .2000E-01 -.1000E-01  .0000E+00\n' \
  >"$corpus/at2/tiny.AT2"
printf 'time_s,acc_L1_X,acc_L4_Y\n0,0.1,0.2\n0.01,0.2,0.1\n0.025,-0.1,0.0\n0.03,0.0,0.1\n' \
  >"$corpus/csv/tiny-uneven-time.csv"
printf 'acc_X;acc_Y\n0.1;0.2\n0.2;0.1\n-0.1;0.0\n' >"$corpus/csv/tiny-no-time.csv"
printf '[event]\nname = "tiny"\n' >"$corpus/manifest/tiny.toml"
printf '[pipeline]\nname = "tiny"\n\n[[stage]]\nname = "ingest"\nkind = "ingest"\n' \
  >"$corpus/pipeline/tiny.toml"
for t in "$corpus"/*/; do
  echo "$(basename "$t"): $(ls "$t" | wc -l) seeds, largest $(ls -S -l "$t" | awk 'NR==2 {print $5}') bytes"
done
