#!/usr/bin/env python3
"""Compare the outputs of two quaketwin runs, file by file.

Used around refactors that must not change results ("behaviour unchanged"):
run the sample events with the old and the new binary into two directories
and compare them:

    python3 tests/reference/compare_outputs.py OLD_DIR NEW_DIR

Each directory holds one subdirectory per run (as written by
`quaketwin run … --out OLD_DIR/<name>`), or is itself one run.

- Parquet files: the schema (column names and types) and every data column
  must be identical, value for value (NaN equal to NaN).  Key-value
  metadata is not compared (it carries versions and fingerprints); the
  script says when it differs.
- run.json and report.html are not compared (timings, fingerprints).
- Every other file (event.json, .toml, .mtx) must be byte-identical.

Exit 0 when everything matches, 1 otherwise (each difference is printed).
"""
import math
import sys
from pathlib import Path

import pyarrow.parquet as pq

SKIP = {"run.json", "report.html"}


def same_value(a, b):
    if isinstance(a, float) and isinstance(b, float):
        return (math.isnan(a) and math.isnan(b)) or a == b
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(same_value(x, y) for x, y in zip(a, b))
    return a == b


def compare_parquet(old: Path, new: Path) -> list[str]:
    a, b = pq.read_table(old), pq.read_table(new)
    problems = []
    if a.schema.remove_metadata() != b.schema.remove_metadata():
        problems.append(f"schema differs:\n  old {a.schema.remove_metadata()}\n  new {b.schema.remove_metadata()}")
        return problems
    if a.num_rows != b.num_rows:
        return [f"{a.num_rows} rows before, {b.num_rows} after"]
    for name in a.column_names:
        ca, cb = a.column(name).to_pylist(), b.column(name).to_pylist()
        bad = [i for i, (x, y) in enumerate(zip(ca, cb)) if not same_value(x, y)]
        if bad:
            i = bad[0]
            problems.append(f"column {name}: {len(bad)} rows differ (first row {i}: {ca[i]!r} -> {cb[i]!r})")
    if (a.schema.metadata or {}) != (b.schema.metadata or {}):
        print(f"  note: {new}: key-value metadata differs (not compared)")
    return problems


def runs(root: Path) -> dict[str, Path]:
    if any(p.is_file() for p in root.iterdir()):
        return {".": root}
    return {p.name: p for p in sorted(root.iterdir()) if p.is_dir()}


def main() -> int:
    if len(sys.argv) != 3:
        print(__doc__)
        return 2
    old_root, new_root = Path(sys.argv[1]), Path(sys.argv[2])
    old_runs, new_runs = runs(old_root), runs(new_root)
    failures = 0
    for name in sorted(set(old_runs) | set(new_runs)):
        if name not in old_runs or name not in new_runs:
            print(f"{name}: only in {'new' if name in new_runs else 'old'}")
            failures += 1
            continue
        o, n = old_runs[name], new_runs[name]
        files = sorted({p.name for p in o.iterdir()} | {p.name for p in n.iterdir()})
        for f in files:
            if f in SKIP:
                continue
            po, pn = o / f, n / f
            if not po.exists() or not pn.exists():
                print(f"{name}/{f}: only in {'new' if pn.exists() else 'old'}")
                failures += 1
                continue
            if f.endswith(".parquet"):
                problems = compare_parquet(po, pn)
            else:
                problems = [] if po.read_bytes() == pn.read_bytes() else ["bytes differ"]
            for p in problems:
                print(f"{name}/{f}: {p}")
            failures += bool(problems)
            if not problems:
                print(f"{name}/{f}: identical")
    print("all identical" if failures == 0 else f"{failures} files differ")
    return 0 if failures == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
