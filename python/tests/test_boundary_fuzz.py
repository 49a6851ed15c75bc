"""Seeded fuzzing of the Python boundary (issue 33 item 5).

Each case calls one function of ``quaketwin`` with generated arguments —
extreme numbers, huge lists, FIFOs, devices, sparse files, wrong types —
in a child interpreter (a crash of the native code must not take the test
runner with it), and asserts that the call:

- returns, or raises ``quaketwin.QuaketwinError`` (``UsageError`` is one),
  or ``TypeError`` for an argument of the wrong Python type — never
  ``pyo3_runtime.PanicException`` (a ``BaseException`` that
  ``except Exception`` misses), never a signal (abort, segfault);
- ends within 60 s;
- keeps the child's peak memory under 1 GiB.

``QUAKETWIN_FUZZ_PY_CASES`` sets the number of cases (default: a short
budget for CI); ``QUAKETWIN_FUZZ_SEED`` the seed.
"""

import json
import os
import pathlib
import random
import resource
import subprocess
import sys
import tempfile
import unittest

ROOT = pathlib.Path(__file__).resolve().parents[2]
SAMPLES = ROOT / "sample-records"
EVENT = SAMPLES / "synthetic-4storey-quake"
TWIN = EVENT / "twin.toml"
PIPELINE = ROOT / "pipelines" / "ingest.toml"
CASES = int(os.environ.get("QUAKETWIN_FUZZ_PY_CASES", "16"))
SEED = int(os.environ.get("QUAKETWIN_FUZZ_SEED", "33"))
HANG_S = 60
PEAK_KB = 1 << 20

# The child runs one call and prints one JSON line: what it returned or raised.
CHILD = r"""
import json, sys
import quaketwin
fn, args, kwargs = json.loads(sys.stdin.read())
try:
    if fn == "modal":
        table = quaketwin.read_event(args[0])
        quaketwin.modal(table, args[1])
    else:
        getattr(quaketwin, fn)(*args, **kwargs)
    print(json.dumps({"ok": True}))
except BaseException as e:
    print(json.dumps({"ok": False, "type": type(e).__module__ + "." + type(e).__qualname__,
                      "error": isinstance(e, quaketwin.QuaketwinError), "message": str(e)[:300]}))
"""

NUMBERS = [0, -1, 1, 2, 1e300, -1e300, 1e-300, float("nan"), float("inf"), 2**63 - 1,
           10**11, 2**32, 0.5, 1e12, 1e5]


def number(rng):
    return rng.choice(NUMBERS) if rng.random() < 0.8 else rng.uniform(-100, 100)


def special_path(rng, tmp, good):
    """A FIFO, a device, a directory, nothing, a sparse gigabyte, garbage, or good."""
    k = rng.randrange(8)
    p = pathlib.Path(tmp) / f"special-{rng.randrange(10**9)}"
    if k == 0:
        os.mkfifo(p)
    elif k == 1:
        return rng.choice(["/dev/zero", "/dev/urandom", "/dev/null"])
    elif k == 2:
        p.mkdir()
    elif k == 3:
        return str(p / "missing")
    elif k == 4:
        with open(p, "wb") as f:
            f.truncate(1 << 30)
    elif k == 5:
        p.write_bytes(bytes(rng.randrange(256) for _ in range(rng.randrange(4000))))
    else:
        return str(good)
    return str(p)


def modal_settings(rng):
    keys = ["orders", "block_rows", "decimation", "band_hz", "damping_min", "damping_max",
            "method", "bogus"]
    settings = {}
    for key in rng.sample(keys, rng.randrange(1, 4)):
        if key in ("orders", "band_hz"):
            n = rng.choice([0, 1, 2, 3, 4, 100000])
            settings[key] = [number(rng) for _ in range(n)]
        elif key == "method":
            settings[key] = rng.choice(["auto", "ssi-cov", "io", "bogus", 7])
        else:
            settings[key] = number(rng)
    return settings


def track_options(rng, tmp):
    options = {}
    for key in ["window", "step", "training", "cycle"]:
        if rng.random() < 0.5:
            options[key] = rng.choice(["1h", "0s", "-1h", "1e300h", "", "10m", 3600, None])
    if rng.random() < 0.4:
        options["min_present"] = number(rng)
    if rng.random() < 0.4:
        options["stationxml"] = special_path(rng, tmp, TWIN)
    if rng.random() < 0.3:
        options["reference"] = special_path(rng, tmp, TWIN)
    if rng.random() < 0.2:
        options["windw"] = "1h"  # a misspelt option
    return options


def make_case(rng, tmp):
    out = str(pathlib.Path(tmp) / "out")
    k = rng.randrange(6)
    if k == 0:
        return "inspect", [special_path(rng, tmp, EVENT)], {}
    if k == 1:
        kwargs = {}
        if rng.random() < 0.5:
            kwargs["reference"] = special_path(rng, tmp, EVENT)
        return "run", [special_path(rng, tmp, PIPELINE), special_path(rng, tmp, EVENT), out], kwargs
    if k == 2:
        return "modal", [str(EVENT), modal_settings(rng)], {}
    if k == 3:
        return "track", [special_path(rng, tmp, tmp), out], track_options(rng, tmp)
    if k == 4:
        kwargs = {}
        if rng.random() < 0.5:
            kwargs["settings"] = special_path(rng, tmp, TWIN)
        return "update", [special_path(rng, tmp, TWIN), special_path(rng, tmp, tmp), out], kwargs
    return "read_event", [special_path(rng, tmp, EVENT)], {}


def limit_memory():
    # Address space of the child bounded a little above the peak we accept,
    # so a runaway allocation fails (and is seen) instead of swapping.
    resource.setrlimit(resource.RLIMIT_AS, (8 << 30, 8 << 30))


class BoundaryFuzz(unittest.TestCase):
    def test_no_panic_no_signal_no_hang_at_the_python_boundary(self):
        failures = []
        counts = {}
        for case in range(CASES):
            rng = random.Random(SEED * 1_000_003 + case)
            with tempfile.TemporaryDirectory() as tmp:
                fn, args, kwargs = make_case(rng, tmp)
                call = json.dumps([fn, args, kwargs])
                before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
                try:
                    r = subprocess.run([sys.executable, "-c", CHILD], input=call, capture_output=True,
                                       text=True, timeout=HANG_S, cwd=tmp, preexec_fn=limit_memory)
                except subprocess.TimeoutExpired:
                    failures.append(f"case {case}: {call[:300]}: still running after {HANG_S} s")
                    continue
                peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
                problems = []
                if r.returncode != 0:
                    problems.append(f"exit {r.returncode}: {r.stderr[-500:]}")
                else:
                    result = json.loads(r.stdout.strip().splitlines()[-1])
                    kind = "ok" if result["ok"] else result["type"]
                    counts[kind] = counts.get(kind, 0) + 1
                    if not result["ok"] and not result["error"] and result["type"] != "builtins.TypeError":
                        problems.append(f"raised {result['type']}: {result['message']}")
                # ru_maxrss of children is the largest so far: only a new
                # maximum can be this case's.
                if peak > before and peak > PEAK_KB:
                    problems.append(f"peak memory {peak >> 10} MB")
                if problems:
                    failures.append(f"case {case}: {call[:300]}: {'; '.join(problems)}")
        print(f"python boundary fuzz: {CASES} cases: {counts}", file=sys.stderr)
        self.assertEqual(failures, [], "\n".join(failures))


if __name__ == "__main__":
    unittest.main()
