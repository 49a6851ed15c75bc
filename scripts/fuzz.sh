#!/usr/bin/env bash
# Runs the cargo-fuzz (libFuzzer) targets of fuzz/ for SECONDS each
# (docs/robustness.md, "cargo-fuzz targets").  Needs a nightly toolchain and
# `cargo install cargo-fuzz`; builds the seed corpus first when it is missing
# (scripts/fuzz-corpus.sh).  Not part of CI.
#
# Usage: scripts/fuzz.sh [SECONDS] [TARGET...]
#   SECONDS   per target (default 180)
#   TARGET    default: every target (`cargo fuzz list`)
#
# Every input must: not panic; give Ok or an error naming the file with the
# documented exit code (fuzz/src/lib.rs); allocate no more than 1 GiB at once
# (-malloc_limit_mb) and 2 GiB in all (-rss_limit_mb); take at most 10 s
# (-timeout).  Inputs may grow by the size of the largest seed (at least 4
# KiB, at most 64 KiB).
# Built with debug assertions and overflow checks (-a) and AddressSanitizer.
# A failing input lands in fuzz/artifacts/<target>/; libFuzzer's log of
# each target in fuzz/logs/<target>.log.  Prints one line per target:
#   fuzz <target> secs=… execs=… exec_per_s=… cov=… ft=… corpus=… peak_rss_mb=… crashes=…
set -euo pipefail
cd "$(dirname "$0")/.."
secs=${1:-180}
shift || true
[ -f fuzz/events/small-quake/event.toml ] && [ -d fuzz/seeds ] || scripts/fuzz-corpus.sh
cd fuzz
if [ $# -gt 0 ]; then targets=("$@"); else mapfile -t targets < <(cargo +nightly fuzz list); fi
cargo +nightly fuzz build -a
# The targets write inputs that must be files into a scratch folder under
# TMPDIR: one removed at the end.
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
export TMPDIR=$scratch
# One thread: the machine is shared, and a case runs as it would in a run
# with RAYON_NUM_THREADS=1.
export RAYON_NUM_THREADS=1
mkdir -p logs
artifacts() { if [ -d "artifacts/$1" ]; then find "artifacts/$1" -type f | wc -l; else echo 0; fi; }
status=0
for t in "${targets[@]}"; do
  largest=$(find "seeds/$t" -type f -printf '%s\n' | sort -n | tail -1)
  largest=${largest:-0}
  grow=$(( largest < 4096 ? 4096 : (largest > 65536 ? 65536 : largest) ))
  max_len=$(( largest + grow ))
  before=$(artifacts "$t")
  mkdir -p "corpus/$t"
  cargo +nightly fuzz run -a "$t" "corpus/$t" "seeds/$t" -- -max_total_time="$secs" -max_len="$max_len" \
    -rss_limit_mb=2048 -malloc_limit_mb=1024 -timeout=10 -print_final_stats=1 \
    >"logs/$t.log" 2>&1 || status=1
  after=$(artifacts "$t")
  last=$(grep -E '^#[0-9]+' "logs/$t.log" | tail -1)
  final_stat() { grep -m1 "stat::$1:" "logs/$t.log" | awk '{print $2}'; }
  field() { sed -nE "s/.* $1: ([0-9a-zA-Z\/]+).*/\1/p" <<<"$last"; }
  echo "fuzz $t secs=$secs max_len=$max_len execs=$(final_stat number_of_executed_units)" \
    "exec_per_s=$(final_stat average_exec_per_sec) cov=$(field cov) ft=$(field ft)" \
    "corpus=$(field corp) peak_rss_mb=$(final_stat peak_rss_mb) crashes=$((after - before))"
done
exit $status
