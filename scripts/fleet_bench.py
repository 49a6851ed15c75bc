"""Benchmark of quaketwin.fleet (issue 17): the four sample events × N copies
run through the post-earthquake pipeline on a Dask LocalCluster of 2 workers,
against the command line's own parallel many-event run of the same events
(both the same build).  Prints events per second of each and the overhead of
the engine.

    python3 scripts/fleet_bench.py [--copies 50] [--bin target/debug/quaketwin]
"""

import argparse
import os
import pathlib
import shutil
import subprocess
import tempfile
import time

import quaketwin.fleet

ROOT = pathlib.Path(__file__).resolve().parents[1]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--copies", type=int, default=50)
    ap.add_argument("--bin", default=str(ROOT / "target" / "debug" / "quaketwin"))
    args = ap.parse_args()
    samples = sorted(p for p in (ROOT / "sample-records").iterdir() if (p / "event.toml").is_file())
    pipeline = ROOT / "pipelines" / "post-earthquake.toml"
    with tempfile.TemporaryDirectory() as work:
        events_dir = pathlib.Path(work) / "events"
        events = []
        for k in range(args.copies):
            for s in samples:
                dst = events_dir / f"{s.name}-{k:03d}"
                shutil.copytree(s, dst)
                events.append(dst)
        n = len(events)
        t0 = time.perf_counter()
        subprocess.run([args.bin, "-q", "run", pipeline, events_dir, "--out", pathlib.Path(work) / "cli"],
                       check=True)
        cli = time.perf_counter() - t0
        from dask.distributed import Client, LocalCluster

        with LocalCluster(n_workers=2, threads_per_worker=1, dashboard_address=None) as cluster, \
                Client(cluster) as client:
            t0 = time.perf_counter()
            runs = quaketwin.fleet.run(pipeline, events, pathlib.Path(work) / "fleet", client=client,
                                       progress=False)
            fleet = time.perf_counter() - t0
        ok = sum(1 for s in runs.column("status").to_pylist() if s == "ok")
        print(f"events: {n} ({len(samples)} samples x {args.copies}), fleet ok: {ok}")
        print(f"CLI parallel run: {cli:.1f} s, {n / cli:.2f} events/s")
        print(f"fleet, LocalCluster 2 workers: {fleet:.1f} s, {n / fleet:.2f} events/s")
        print(f"engine overhead: {100 * (fleet / cli - 1):+.0f} % wall time")


if __name__ == "__main__":
    main()
