#!/usr/bin/env bash
# Big-input load measurement (issue 14 item 5; docs/performance.md).
#
# Generates a 64-channel × H-hour × 200 Hz event (benches/bigload.rs: a
# 31-storey building in X and Y plus two base channels, measurement noise,
# an earthquake in the first hour) outside the repository and measures
# `quaketwin ingest` and, optionally, `quaketwin run pipelines/post-earthquake.toml`
# with /usr/bin/time -v: wall time and peak resident memory.
#
# Usage: scripts/bigload.sh [--hours H] [--format csv|mseed] [--channels N]
#                           [--work DIR] [--structure] [--no-run] [--no-ingest] [--keep]
#   --hours H       record length (default 1)
#   --format F      csv (one 582 MB-per-hour CSV, default) or mseed (one
#                   float32 MiniSEED file per channel, 276 MB per hour: a day
#                   fits a small disk)
#   --channels N    the first N of the 64 channels (a day of all 64 needs about
#                   61 GB of disk: 4 GB of event, 21.4 GB of outputs and a
#                   35 GB spill file, measured in session 13)
#   --work DIR      where the event and outputs go (default: a new directory
#                   under ${TMPDIR:-/tmp}); never inside the repository
#   --structure     state storey heights and masses in event.toml
#   --no-run        measure `ingest` only (the day-long case)
#   --no-ingest     measure `run` only
#   --keep          keep the event and outputs (default: removed at the end)
#
# Builds with `cargo build --release` (set CARGO_TARGET_DIR as usual).
# Prints one line per measurement:
#   bigload <command> hours=H format=F wall_s=… peak_rss_mb=… out_mb=…
set -euo pipefail

hours=1
format=csv
channels=64
work=""
structure=""
do_run=1
do_ingest=1
keep=0
while [ $# -gt 0 ]; do
    case "$1" in
        --hours) hours="$2"; shift 2 ;;
        --format) format="$2"; shift 2 ;;
        --channels) channels="$2"; shift 2 ;;
        --work) work="$2"; shift 2 ;;
        --structure) structure="--structure"; shift ;;
        --no-run) do_run=0; shift ;;
        --no-ingest) do_ingest=0; shift ;;
        --keep) keep=1; shift ;;
        -h|--help) sed -n '2,28p' "$0"; exit 0 ;;
        *) echo "bigload.sh: unknown argument $1" >&2; exit 2 ;;
    esac
done

repo="$(cd "$(dirname "$0")/.." && pwd)"
target="${CARGO_TARGET_DIR:-$repo/target}"
if [ -z "$work" ]; then
    work="$(mktemp -d "${TMPDIR:-/tmp}/quaketwin-bigload.XXXXXX")"
fi
case "$(cd "$work" 2>/dev/null && pwd || echo "$work")/" in
    "$repo"/*) echo "bigload.sh: --work must be outside the repository" >&2; exit 2 ;;
esac
mkdir -p "$work"
[ "$keep" = 1 ] || trap 'rm -rf "$work"' EXIT

(cd "$repo" && cargo build --release --quiet --bin quaketwin \
    && cargo build --release --quiet -p quaketwin-benches --bin bigload)
qt="$target/release/quaketwin"
event="$work/event-${hours}h-${channels}ch-$format"
if [ ! -f "$event/event.toml" ]; then
    "$target/release/bigload" --hours "$hours" --out "$event" --format "$format" \
        --channels "$channels" $structure
fi
in_mb=$(du -sm "$event" | cut -f1)
echo "bigload event hours=$hours format=$format channels=$channels rate_hz=200 input_mb=$in_mb dir=$event"

measure() { # name, output dir, command…
    local name="$1" out="$2"
    shift 2
    rm -rf "$out"
    /usr/bin/time -v -o "$work/$name.time" "$@" >"$work/$name.log" 2>&1 &
    local timed=$!
    # The spill file is unlinked as soon as it is open: its size is read
    # through the process's open file descriptors, its largest kept.
    local spill=0 size f pid
    while kill -0 "$timed" 2>/dev/null; do
        for pid in $(pgrep -P "$timed" || true); do
            for f in /proc/"$pid"/fd/*; do
                case "$(readlink "$f" 2>/dev/null)" in
                    *.samples.quaketwin-*) size=$(stat -Lc %s "$f" 2>/dev/null || echo 0)
                        [ "$size" -gt "$spill" ] && spill=$size ;;
                esac
            done
        done
        sleep 1
    done
    wait "$timed" || {
        cat "$work/$name.log" >&2
        echo "bigload.sh: $name failed" >&2
        exit 1
    }
    local wall rss out_mb in_bytes out_bytes
    wall=$(awk -F': ' '/Elapsed \(wall clock\)/ {n = split($2, p, ":"); s = 0; for (i = 1; i <= n; i++) s = s * 60 + p[i]; print s}' "$work/$name.time")
    rss=$(awk -F': ' '/Maximum resident set size/ {printf "%.0f", $2 / 1024}' "$work/$name.time")
    out_mb=$(du -sm "$out" | cut -f1)
    in_bytes=$(du -sb "$event" | cut -f1)
    out_bytes=$(du -sb "$out" | cut -f1)
    echo "bigload $name hours=$hours channels=$channels format=$format wall_s=$wall peak_rss_mb=$rss out_mb=$out_mb" \
        "input_bytes=$in_bytes output_bytes=$out_bytes spill_bytes=$spill"
    awk -F': ' '/User time|System time/ {printf "    %s: %s s\n", $1, $2}' "$work/$name.time"
    grep -E '^\[[^]]*\] +[a-z-]+ +(done|not applicable)' "$work/$name.log" | sed 's/^/    /' || true
}

if [ "$do_ingest" = 1 ]; then
    measure ingest "$work/out-ingest" "$qt" ingest "$event" --out "$work/out-ingest"
    rm -rf "$work/out-ingest"
fi
if [ "$do_run" = 1 ]; then
    measure run "$work/out-run" "$qt" run "$repo/pipelines/post-earthquake.toml" "$event" --out "$work/out-run"
    rm -rf "$work/out-run"
fi
