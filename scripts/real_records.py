#!/usr/bin/env python3
"""Runs the shipped post-earthquake pipeline, with its defaults, over every
real record set in ../shared/records/ and prints one Markdown table row per
event: did it run, how many channels got a level, the modes found (frequency,
direction, kind), the drift rows, the rating and what drives it, and why the
stages that did not apply did not.

    scripts/real_records.py [--bin target/release/quaketwin] [--out /tmp/rr] [--shared ../shared]

Used for the before/after tables in the issue notes (issue 31): the same
script with the binary of two commits.  Needs pyarrow for the drift and mode
tables (without it those columns say "?").
"""
import argparse
import json
import pathlib
import subprocess
import sys

try:
    import pyarrow.parquet as pq
except ImportError:  # the table still runs, with fewer columns
    pq = None

# Real record sets that are events (the two laboratory tests are not).
EVENT_GLOBS = [
    "cesmd-bridges-corpus/*/*.zip",
    "cesmd-bridges-corpus/*/*.ZIP",
    "csmip-ce01336-meloland-overpass/*.zip",
    "csmip-ce89324-painterst-overpass/*.zip",
    "csmip-ce89324-painterst-overpass/nested_original",
    "mdof-mini-shake-table-flexible-3story",
    "nsmp-8040-anchorage-downhole-2018-mseed",
    "peer-at2-records",
    "usgs-gmprocess-format-samples/cosmos",
    "usgs-gmprocess-format-samples/dmg",
    "usgs-gmprocess-format-samples/geonet",
    "usgs-gmprocess-format-samples/sac",
    "usgs-gmprocess-format-samples/smc",
]


def events(shared: pathlib.Path):
    records = shared / "records"
    seen = []
    for g in EVENT_GLOBS:
        for p in sorted(records.glob(g)):
            if p not in seen:
                seen.append(p)
    return seen


def table(path):
    if pq is None or not path.exists():
        return None
    return pq.read_table(path).to_pylist()


def short(text, n=90):
    text = " ".join(str(text).split())
    return text if len(text) <= n else text[: n - 1] + "…"


def row(binary, pipeline, event, out):
    out.mkdir(parents=True, exist_ok=True)
    proc = subprocess.run(
        [binary, "run", pipeline, str(event), "--out", str(out), "--json", "-q"],
        capture_output=True,
        text=True,
        timeout=900,
    )
    try:
        summary = json.loads(proc.stdout)
    except json.JSONDecodeError:
        return ["exit %d" % proc.returncode, "", "", "", "", "", short(proc.stderr.strip().splitlines()[-1] if proc.stderr.strip() else "")]
    if not summary.get("ok"):
        return ["error", "", "", "", "", "", short(summary.get("error"), 140)]
    ev = json.loads((out / "event.json").read_text())
    chans = [c for c in ev.get("channels", []) if not c.get("combines")]
    with_level = sum(1 for c in chans if c.get("level") is not None)
    modes = table(out / "modes/modes.parquet")
    if modes is None:
        mode_text = ", ".join(
            "%.3f %s" % (m["frequency_hz"], m.get("direction") or "") for m in summary.get("modes", [])
        )
    else:
        parts = []
        for m in modes:
            kind = m.get("kind")
            tag = "" if kind in (None, "structural") else " (%s)" % kind
            parts.append("%.3f %s%s" % (m["frequency_hz"], m.get("direction") or "", tag))
        mode_text = ", ".join(parts)
    drift = table(out / "drift/drift.parquet")
    if drift is None:
        drift_text = "?"
    elif not drift:
        drift_text = "none"
    else:
        peak = max(drift, key=lambda r: r.get("peak_drift_ratio") or 0.0)
        drift_text = "%d rows, max %.3f %%" % (len(drift), 100.0 * (peak.get("peak_drift_ratio") or 0.0))
    a = summary.get("assessment") or {}
    rating = a.get("rating") or "NOT RATED"
    drivers = "; ".join(str(d) for d in a.get("drivers", []))
    if rating == "NOT RATED":
        drivers = a.get("not_rated_reason") or "no assess stage"
    else:
        rating = "%s (%s%s)" % (rating, a.get("confidence", ""), ", provisional" if a.get("provisional") else "")

    def hz(v):
        return "—" if v is None else "%.3f" % v

    freq_text = "%s → %s → %s" % (
        hz(a.get("frequency_before_hz")),
        hz(a.get("frequency_min_during_hz")),
        hz(a.get("frequency_after_hz")),
    )
    na = [
        "%s: %s" % (s["name"], short(s.get("reason"), 60))
        for s in summary.get("stages", [])
        if s.get("outcome") == "not_applicable" and s["name"] not in ("update", "damage")
    ]
    return [
        "ok",
        "%d/%d" % (with_level, len(chans)),
        mode_text or "none",
        drift_text,
        freq_text,
        short("%s: %s" % (rating, drivers) if drivers else rating, 220),
        short("; ".join(na), 160),
    ]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bin", default="target/release/quaketwin")
    ap.add_argument("--pipeline", default="pipelines/post-earthquake.toml")
    ap.add_argument("--out", default="/tmp/quaketwin-real-records")
    ap.add_argument("--shared", default="../shared")
    args = ap.parse_args()
    shared = pathlib.Path(args.shared)
    print("| record | run | channels with a level | modes (Hz, direction) | drift | apparent f before → min → after (Hz) | assessment | not applicable |")
    print("|---|---|---|---|---|---|---|---|")
    for ev in events(shared):
        name = str(ev.relative_to(shared / "records"))
        out = pathlib.Path(args.out) / name.replace("/", "__")
        cells = row(args.bin, args.pipeline, ev, out)
        print("| %s | %s |" % (name, " | ".join(c.replace("|", "/") for c in cells)))
        sys.stdout.flush()


if __name__ == "__main__":
    main()
