#!/usr/bin/env bash
# Whole-process `quaketwin modal` on a 5 channels × 600 s × 100 Hz CSV event
# (issue 18; docs/performance.md). The event (≈ 3 MB of CSV: a 5-storey shear
# building under ambient excitation, benches/bench_events.rs) is written by
# `bench-event modal` outside the repository; `quaketwin modal EVENT --out D`
# runs N times (a fresh D each time, so nothing is skipped as up to date) under
# /usr/bin/time -v. Prints every run and the medians of wall and CPU
# (user + system) time, with the limit estimate beside them.
#
# Usage: scripts/modal_whole.sh [--repeats N] [--work DIR] [--keep]
#   --repeats N   runs measured (default 7; one unmeasured warm-up run first)
#   --work DIR    where the event and outputs go (default: a new directory
#                 under ${TMPDIR:-/tmp}); never inside the repository
#   --keep        keep the event and outputs
#
# Builds with `cargo build --release` (set CARGO_TARGET_DIR as usual); with
# QUAKETWIN_BIN set, times that binary instead (release-profile comparisons). An event
# already in --work is reused (same seed, same bytes).
set -euo pipefail

repeats=7
work=""
keep=0
while [ $# -gt 0 ]; do
    case "$1" in
        --repeats) repeats="$2"; shift 2 ;;
        --work) work="$2"; shift 2 ;;
        --keep) keep=1; shift ;;
        -h|--help) sed -n '2,18p' "$0"; exit 0 ;;
        *) echo "modal_whole.sh: unknown argument $1" >&2; exit 2 ;;
    esac
done

repo="$(cd "$(dirname "$0")/.." && pwd)"
target="${CARGO_TARGET_DIR:-$repo/target}"
if [ -z "$work" ]; then
    work="$(mktemp -d "${TMPDIR:-/tmp}/quaketwin-modal-whole.XXXXXX")"
fi
case "$(cd "$work" 2>/dev/null && pwd || echo "$work")/" in
    "$repo"/*) echo "modal_whole.sh: --work must be outside the repository" >&2; exit 2 ;;
esac
mkdir -p "$work"
[ "$keep" = 1 ] || trap 'rm -rf "$work"' EXIT

if [ -z "${QUAKETWIN_BIN:-}" ]; then
    (cd "$repo" && cargo build --release --quiet --bin quaketwin)
fi
qt="${QUAKETWIN_BIN:-$target/release/quaketwin}"
event="$work/event-modal-5ch-600s-100hz"
if [ ! -f "$event/event.toml" ]; then
    (cd "$repo" && cargo build --release --quiet -p quaketwin-benches --bin bench-event)
    "$target/release/bench-event" modal "$event"
fi
csv_mb=$(du -m --apparent-size "$event/rec.csv" | cut -f1)
echo "modal_whole event channels=5 duration_s=600 rate_hz=100 csv_mb=$csv_mb dir=$event"

seconds() { # field of a /usr/bin/time -v file → seconds
    awk -F': ' -v f="$2" '$1 ~ f {n = split($2, p, ":"); s = 0; for (i = 1; i <= n; i++) s = s * 60 + p[i]; print s}' "$1"
}
walls=()
cpus=()
for i in $(seq 0 "$repeats"); do
    out="$work/out"
    rm -rf "$out"
    /usr/bin/time -v -o "$work/time" "$qt" modal "$event" --out "$out" -q >"$work/log" 2>&1 || {
        cat "$work/log" >&2
        echo "modal_whole.sh: quaketwin modal failed" >&2
        exit 1
    }
    [ "$i" = 0 ] && continue # warm-up: page cache, binary
    wall=$(seconds "$work/time" 'Elapsed \\(wall clock\\)')
    user=$(seconds "$work/time" 'User time')
    sys=$(seconds "$work/time" 'System time')
    cpu=$(awk -v u="$user" -v s="$sys" 'BEGIN {printf "%.2f", u + s}')
    echo "modal_whole run=$i wall_s=$wall cpu_s=$cpu"
    walls+=("$wall")
    cpus+=("$cpu")
done
median() { printf '%s\n' "$@" | sort -g | awk '{v[NR] = $1} END {print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2}'; }
echo "modal_whole median_wall_s=$(median "${walls[@]}") median_cpu_s=$(median "${cpus[@]}") repeats=$repeats target_s=0.15 limit_estimate='CSV parse of ${csv_mb} MB (tens of ms) + SSI (tens of ms) ≈ 0.1 s'"
