"""The twin's sparse eigen-solve against scipy (issue 18): the 10 lowest
modes of the benchmark shell plate (162 × 102 elements: 100 116 free DoFs),
by `quaketwin twin modes` and by scipy.sparse.linalg.eigsh in shift-invert
mode (sigma = 0) on the same K and M, exported with `quaketwin twin export`.
Prints both times, their ratio and the largest relative frequency difference.

    python3 scripts/eigsh_compare.py [--nx 162 --ny 102] [--bin target/release/quaketwin]
"""

import argparse
import json
import pathlib
import subprocess
import tempfile
import time

import numpy as np
import scipy.io
import scipy.sparse
import scipy.sparse.linalg

ROOT = pathlib.Path(__file__).resolve().parents[1]


def quaketwin(bin_, *args):
    r = subprocess.run([bin_, "-q", *map(str, args)], capture_output=True, text=True, check=True)
    return r.stdout


def symmetric(path):
    """A `coordinate real symmetric` Matrix Market file (lower triangle) as the full CSC matrix."""
    a = scipy.io.mmread(path)  # scipy mirrors the symmetric storage itself
    return scipy.sparse.csc_matrix(a)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--nx", type=int, default=162)
    ap.add_argument("--ny", type=int, default=102)
    ap.add_argument("--count", type=int, default=10)
    ap.add_argument("--bin", default=str(ROOT / "target" / "release" / "quaketwin"))
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as work:
        work = pathlib.Path(work)
        plate = work / "plate.toml"
        quaketwin(args.bin, "twin", "plate", "--nx", args.nx, "--ny", args.ny, "--out", plate)
        ours = json.loads(quaketwin(args.bin, "--json", "twin", "modes", plate, "--count", args.count))
        t0 = time.perf_counter()
        quaketwin(args.bin, "twin", "export", plate, "--out", work)
        export_s = time.perf_counter() - t0
        k, m = symmetric(work / "stiffness.mtx"), symmetric(work / "mass.mtx")
        t0 = time.perf_counter()
        values = scipy.sparse.linalg.eigsh(k, k=args.count, M=m, sigma=0.0, which="LM",
                                           return_eigenvectors=False)
        scipy_s = time.perf_counter() - t0
        f_scipy = np.sort(np.sqrt(np.abs(values)) / (2 * np.pi))
        f_ours = np.array(ours["frequencies_hz"])
        rel = np.max(np.abs(f_ours - f_scipy) / f_scipy)
        print(f"model: {ours['dofs']} free DoFs, {args.count} modes")
        print(f"quaketwin (shift-invert Lanczos): {ours['solve_seconds']:.2f} s")
        print(f"scipy eigsh (shift-invert, SuperLU): {scipy_s:.2f} s (export + read not counted: {export_s:.1f} s)")
        print(f"ratio quaketwin / scipy: {ours['solve_seconds'] / scipy_s:.2f}")
        print(f"largest relative frequency difference: {rel:.2e}")
        print("frequencies (Hz):", ", ".join(f"{f:.4f}" for f in f_ours))


if __name__ == "__main__":
    main()
