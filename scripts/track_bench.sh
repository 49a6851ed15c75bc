#!/usr/bin/env bash
# Continuous-monitoring benchmark (issue 17 item 3; docs/performance.md):
# a synthetic SDS archive of D days × 8 channels × 100 Hz
# (`quaketwin synth-archive`) tracked by `quaketwin track` with the defaults,
# measured with /usr/bin/time -v (wall time, peak resident memory); then the
# tracked frequencies against the archive's truth.csv (needs pyarrow).
#
# Usage: scripts/track_bench.sh [--days D] [--work DIR] [--keep]
#   --days D   archive length in days (default 1: the 24 h × 8 ch benchmark;
#              3: the full check, about 843 MB)
#   --work DIR where the archive and outputs go (default: a new directory
#              under ${TMPDIR:-/tmp}); never inside the repository
#   --keep     keep them (default: removed at the end)
#
# Builds with `cargo build --release` (set CARGO_TARGET_DIR as usual).
set -euo pipefail

days=1
work=""
keep=0
while [ $# -gt 0 ]; do
    case "$1" in
        --days) days="$2"; shift 2 ;;
        --work) work="$2"; shift 2 ;;
        --keep) keep=1; shift ;;
        *) echo "track_bench.sh: unknown argument $1" >&2; exit 2 ;;
    esac
done
repo="$(cd "$(dirname "$0")/.." && pwd)"
if [ -z "$work" ]; then
    work="$(mktemp -d "${TMPDIR:-/tmp}/quaketwin-track.XXXXXX")"
fi
case "$(cd "$work" && pwd)" in
    "$repo"/*) echo "track_bench.sh: --work must be outside the repository" >&2; exit 2 ;;
esac
[ "$keep" = 1 ] || trap 'rm -rf "$work"' EXIT
(cd "$repo" && cargo build --release -q)
bin="${CARGO_TARGET_DIR:-$repo/target}/release/quaketwin"
"$bin" -q synth-archive --out "$work/arch" --days "$days"
/usr/bin/time -v "$bin" -q track "$work/arch/sds" --stationxml "$work/arch/station.xml" \
    --out "$work/track" --json >"$work/summary.json" 2>"$work/time.txt"
wall=$(grep "Elapsed (wall clock)" "$work/time.txt" | awk '{print $NF}')
rss=$(grep "Maximum resident" "$work/time.txt" | awk '{print int($NF/1024)}')
user=$(grep "User time" "$work/time.txt" | awk '{print $NF}')
echo "track days=$days wall=$wall user_s=$user peak_rss_mb=$rss"
python3 - "$work/track/modal_tracking/modal_tracking.parquet" "$work/arch/truth.csv" "$work/summary.json" <<'PY'
import collections, csv, json, sys
import pyarrow.parquet as pq
t = pq.read_table(sys.argv[1]).to_pydict()
truth = collections.defaultdict(dict)
for r in csv.DictReader(open(sys.argv[2])):
    truth[r["window_start"][:19]][(r["axis"], int(r["rank"]))] = float(r["frequency_hz"])
s = json.load(open(sys.argv[3]))
ref = {m["mode"]: m["reference_frequency_hz"] for m in s["modes"]}
worst, n, within = collections.defaultdict(float), 0, 0
for i, mode in enumerate(t["mode"]):
    ws = t["window_start"][i].strftime("%Y-%m-%dT%H:%M:%S")
    key, f_true = min(truth[ws].items(), key=lambda kv: abs(kv[1] - ref[mode]))
    e = abs(t["frequency_hz"][i] - f_true) / f_true
    worst[(mode, key)] = max(worst[(mode, key)], e)
    n += 1
    within += e <= 0.003
for k in sorted(worst):
    print(f"mode {k[0]} ({k[1][0]}{k[1][1]}): largest error {100 * worst[k]:.3f} %")
print(f"{within} of {n} mode-windows within 0.3 %; anomaly from {s['anomaly_from']}; "
      f"{s['identified_windows']} of {s['windows']} windows identified")
PY
