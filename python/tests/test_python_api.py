"""The Python package as a Python user meets it (issue 34 item 4): one test
per friction found by trying it as an ObsPy / PyOMA2 / Jupyter user.

- ``quaketwin.fleet`` after ``import quaketwin``; a fleet script without
  ``if __name__ == "__main__":`` told what to add, the guarded one runs;
- unknown keywords are TypeErrors, for every function;
- a missing path is a ``FileNotFoundError``, a bad value a ``ValueError``
  (both ``QuaketwinError``\\ s);
- the library's warnings go through ``warnings`` (nothing on stderr), its
  other lines through ``logging``;
- typed (``py.typed``, a stub for every native function), numpydoc
  docstrings, no names leaking into ``dir(quaketwin)``;
- ``Event`` and ``Modes``: numpy arrays, ObsPy ``Stream``, plots, Jupyter
  HTML, and clear errors when an optional dependency is absent;
- the StationXML of ``synth-archive`` through ObsPy's ``remove_response``;
- the example notebook docs/python-example.ipynb runs (nbclient).

Optional dependencies (numpy, matplotlib, obspy, nbclient + ipykernel) make
a test say SKIPPED with what to install when absent; ``.ci/run`` installs
them.
"""

import ast
import errno
import importlib.util
import inspect as pyinspect
import json
import os
import pathlib
import pickle
import subprocess
import sys
import tempfile
import time
import unittest
import unittest.mock
import warnings
import xml.etree.ElementTree as ET

import pyarrow.parquet as pq

import quaketwin

ROOT = pathlib.Path(__file__).resolve().parents[2]
SAMPLES = ROOT / "sample-records"
AMBIENT = SAMPLES / "synthetic-4storey-ambient"
QUAKE = SAMPLES / "synthetic-4storey-quake"
YIELDING = SAMPLES / "synthetic-2storey-yielding"
PIPELINE = ROOT / "pipelines" / "post-earthquake.toml"
NOTEBOOK = ROOT / "docs" / "python-example.ipynb"
BIN = os.environ.get(
    "QUAKETWIN_BIN",
    str(pathlib.Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target")) / "debug" / "quaketwin"),
)


def have(*modules):
    return all(importlib.util.find_spec(m) is not None for m in modules)


def skip_without(*modules):
    missing = [m for m in modules if importlib.util.find_spec(m) is None]
    return unittest.skipIf(
        bool(missing), f"needs {', '.join(missing)}: pip install {' '.join(missing)} (.ci/run installs them)"
    )


def child(code, cwd=None, timeout=300):
    """Runs ``code`` in a fresh interpreter: (returncode, stdout, stderr)."""
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=cwd, timeout=timeout)
    return r.returncode, r.stdout, r.stderr


def cli(*args):
    r = subprocess.run([BIN, "-q", *map(str, args)], capture_output=True, text=True)
    if r.returncode != 0:
        raise AssertionError(f"quaketwin {args}: {r.stderr}")
    return r.stdout


class Namespace(unittest.TestCase):
    def test_fleet_is_an_attribute_of_the_package(self):
        code, out, err = child(
            "import quaketwin, json; f = quaketwin.fleet;"
            "print(json.dumps([callable(f.run), callable(f.track), 'fleet' in dir(quaketwin)]))"
        )
        self.assertEqual(code, 0, err)
        self.assertEqual(json.loads(out), [True, True, True])

    def test_fleet_without_its_extra_says_what_to_install(self):
        code, out, err = child(
            "import sys; sys.modules['fsspec'] = None\n"
            "import quaketwin\n"
            "try:\n    quaketwin.fleet\nexcept ModuleNotFoundError as e:\n    print(e)\n"
        )
        self.assertEqual(code, 0, err)
        self.assertIn("pip install 'quaketwin[fleet]'", out)

    def test_no_names_leak_into_the_package(self):
        code, out, err = child(
            "import quaketwin, quaketwin.fleet as f, json\n"
            "print(json.dumps([sorted(n for n in dir(quaketwin) if not n.startswith('_')), quaketwin.__all__,"
            " sorted(n for n in dir(f) if not n.startswith('_')), f.__all__]))"
        )
        self.assertEqual(code, 0, err)
        public, declared, fleet_public, fleet_declared = json.loads(out)
        self.assertEqual(set(public) - set(declared), {"fleet"})
        self.assertEqual(set(fleet_public) - set(fleet_declared), set())
        for leak in ("Any", "json", "os", "pa", "pq", "annotations", "Optional"):
            self.assertNotIn(leak, public)

    def test_every_public_name_has_a_numpydoc_docstring(self):
        import quaketwin.fleet as fleet

        for module in (quaketwin, fleet):
            for name in module.__all__:
                obj = getattr(module, name)
                if not (pyinspect.isfunction(obj) or pyinspect.isclass(obj)):
                    continue
                doc = pyinspect.getdoc(obj) or ""
                self.assertGreater(len(doc), 40, f"{module.__name__}.{name} has no docstring")
                params = [
                    p for p in pyinspect.signature(obj).parameters
                    if p not in ("self", "cls") and not p.startswith("_")
                ] if pyinspect.isfunction(obj) else []
                if params and name != "main":
                    self.assertIn("Parameters\n----------", doc, f"{module.__name__}.{name}")
        for cls in (quaketwin.Event, quaketwin.Modes):
            for name, member in vars(cls).items():
                if not name.startswith("_") and (callable(member) or isinstance(member, property)):
                    self.assertTrue(pyinspect.getdoc(getattr(cls, name)), f"{cls.__name__}.{name}")

    def test_typed_package_with_a_stub_for_every_native_function(self):
        package = pathlib.Path(quaketwin.__file__).parent
        self.assertTrue((package / "py.typed").is_file())
        stub = ast.parse((package / "_native.pyi").read_text())
        typed = {n.name for n in stub.body if isinstance(n, ast.FunctionDef)}
        native = {n for n in dir(quaketwin._native) if not n.startswith("__") and callable(getattr(quaketwin._native, n))}
        self.assertEqual(typed, native)
        for name in quaketwin.__all__:
            obj = getattr(quaketwin, name)
            if pyinspect.isfunction(obj):
                self.assertIsNot(pyinspect.signature(obj).return_annotation, pyinspect.Signature.empty, name)


class Keywords(unittest.TestCase):
    """Python raises TypeError for an unknown keyword; ``track`` once took
    ``**options`` and ran the whole archive with ``windw="1h"`` ignored."""

    def test_no_function_takes_arbitrary_keywords(self):
        import quaketwin.fleet as fleet

        allowed = {("quaketwin.fleet", "track"), ("quaketwin.fleet", "local_cluster")}
        for module in (quaketwin, fleet):
            for name in module.__all__:
                obj = getattr(module, name)
                if not pyinspect.isfunction(obj):
                    continue
                kinds = {p.kind for p in pyinspect.signature(obj).parameters.values()}
                if (module.__name__, name) not in allowed:
                    self.assertNotIn(pyinspect.Parameter.VAR_KEYWORD, kinds, f"{module.__name__}.{name}")

    def test_unknown_keywords_raise_type_error_before_any_work(self):
        import quaketwin.fleet as fleet

        with tempfile.TemporaryDirectory() as work:
            out = pathlib.Path(work) / "out"
            calls = [
                lambda: quaketwin.track(work, out, windw="1h"),
                lambda: fleet.track(work, out, windw="1h"),
                lambda: quaketwin.run(PIPELINE, QUAKE, out, refrence=work),
                lambda: quaketwin.inspect(QUAKE, verbose=True),
                lambda: quaketwin.read(QUAKE, channels=["F1-X"]),
                lambda: quaketwin.read_event(QUAKE, channels=["F1-X"]),
                lambda: quaketwin.modal(None, method="ssi-cov"),
                lambda: quaketwin.hysteresis(QUAKE, out, quick=True),
                lambda: quaketwin.update(QUAKE / "twin.toml", work, out, setings=None),
                lambda: quaketwin.event_partition(QUAKE, structure="x"),
                lambda: fleet.run(PIPELINE, [QUAKE], out, clinet=None),
            ]
            for call in calls:
                with self.assertRaises(TypeError):
                    call()
            with self.assertRaisesRegex(TypeError, "windw"):
                quaketwin.track(work, out, windw="1h")
            self.assertFalse(out.exists(), "a call with an unknown keyword did work")

    def test_event_and_modes_methods_reject_unknown_keywords(self):
        event = quaketwin.read(AMBIENT)
        with self.assertRaises(TypeError):
            event.modal(metod="ssi-cov")
        with self.assertRaises(TypeError):
            event.to_numpy(colum="acc_m_s2")


class Exceptions(unittest.TestCase):
    def test_a_missing_path_is_a_file_not_found_error_for_every_function(self):
        with tempfile.TemporaryDirectory() as work:
            missing = pathlib.Path(work) / "no-such-thing"
            out = pathlib.Path(work) / "out"
            calls = {
                "inspect": lambda: quaketwin.inspect(missing),
                "read_event": lambda: quaketwin.read_event(missing),
                "read": lambda: quaketwin.read(missing),
                "run (pipeline)": lambda: quaketwin.run(missing, QUAKE, out),
                "run (event)": lambda: quaketwin.run(PIPELINE, missing, out),
                "run (reference)": lambda: quaketwin.run(PIPELINE, QUAKE, out, reference=missing),
                "hysteresis": lambda: quaketwin.hysteresis(missing, out),
                "update (twin)": lambda: quaketwin.update(missing, work, out),
                "update (modes)": lambda: quaketwin.update(QUAKE / "twin.toml", missing, out),
                "event_partition": lambda: quaketwin.event_partition(missing),
                "track (archive)": lambda: quaketwin.track(missing, out),
                "Modes.read": lambda: quaketwin.Modes.read(missing),
            }
            for what, call in calls.items():
                with self.subTest(what):
                    with self.assertRaises(FileNotFoundError) as caught:
                        call()
                    e = caught.exception
                    self.assertIsInstance(e, quaketwin.QuaketwinError)
                    self.assertIsInstance(e, quaketwin.PathNotFoundError)
                    self.assertEqual(e.errno, errno.ENOENT)
                    self.assertEqual(e.filename, str(missing))
                    self.assertIn(str(missing), str(e))
                    self.assertNotIn("[Errno", str(e))

    def test_bad_values_are_value_errors(self):
        table = quaketwin.read_event(AMBIENT)
        for settings, key in [({"band_hz": [5.0, 1.0]}, "band_hz"), ({"bogus": 1}, "bogus")]:
            with self.assertRaises(ValueError) as caught:
                quaketwin.modal(table, settings)
            self.assertIsInstance(caught.exception, quaketwin.UsageError)
            self.assertIn(key, str(caught.exception))
        with tempfile.TemporaryDirectory() as work:
            with self.assertRaises(ValueError):
                quaketwin.track(work, pathlib.Path(work) / "out", window="0h")
            bad = pathlib.Path(work) / "bad-event"
            bad.mkdir()
            (bad / "rec.AT2").write_bytes(b"garbage\x00\x01")
            with self.assertRaises(ValueError) as caught:
                quaketwin.read_event(bad)
            self.assertIsInstance(caught.exception, quaketwin.InputError)
            self.assertIn("rec.AT2", str(caught.exception))

    def test_exceptions_survive_pickling_as_dask_sends_them(self):
        try:
            quaketwin.inspect("/no/such/event")
        except quaketwin.QuaketwinError as e:
            again = pickle.loads(pickle.dumps(e))
            self.assertIs(type(again), quaketwin.PathNotFoundError)
            self.assertEqual((str(again), again.filename), (str(e), e.filename))
        self.assertEqual(quaketwin.UsageError.__module__, "quaketwin")
        self.assertEqual(repr(quaketwin.UsageError("x")), "UsageError('x')")


class Warnings(unittest.TestCase):
    def test_modal_warnings_go_through_the_warnings_module(self):
        table = quaketwin.read_event(AMBIENT)
        with self.assertWarns(quaketwin.QuaketwinWarning) as caught:
            modes, _ = quaketwin.modal(table)
        # Attributed to the caller (this file), not to the package.
        self.assertEqual(pathlib.Path(caught.filename).resolve(), pathlib.Path(__file__).resolve())
        self.assertIn("stable columns not promoted", str(caught.warning))
        self.assertEqual(
            json.loads(modes.schema.metadata[b"quaketwin.warnings"])[0], str(caught.warning).split("modal: ", 1)[1]
        )
        with warnings.catch_warnings():
            warnings.simplefilter("error", quaketwin.QuaketwinWarning)
            with self.assertRaises(quaketwin.QuaketwinWarning):
                quaketwin.read(AMBIENT).modal()

    def test_a_run_writes_nothing_to_stderr_and_logs_its_stages(self):
        with tempfile.TemporaryDirectory() as work:
            code, out, err = child(
                "import json, logging, warnings, quaketwin\n"
                "lines = []\n"
                "class H(logging.Handler):\n    def emit(self, r): lines.append(r.getMessage())\n"
                "logging.getLogger('quaketwin').addHandler(H()); logging.getLogger('quaketwin').setLevel(logging.INFO)\n"
                "with warnings.catch_warnings(record=True) as w:\n"
                "    warnings.simplefilter('always')\n"
                f"    s = quaketwin.run({str(PIPELINE)!r}, {str(YIELDING)!r}, {work!r})\n"
                "print(json.dumps([s['ok'], [str(x.message) for x in w if x.category is quaketwin.QuaketwinWarning], lines]))\n"
            )
            self.assertEqual(code, 0, err)
            self.assertEqual(err, "", "the library wrote to stderr")
            ok, warned, logged = json.loads(out)
            self.assertTrue(ok)
            self.assertTrue(any("stable columns not promoted" in w for w in warned), warned)
            self.assertTrue(any("done in" in line for line in logged), logged)


class Objects(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.event = quaketwin.read(AMBIENT)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", quaketwin.QuaketwinWarning)
            cls.modes = cls.event.modal({"method": "ssi-cov"})

    def test_event_holds_the_records_and_their_channels(self):
        inventory = quaketwin.inspect(AMBIENT)
        self.assertEqual(self.event.channel_ids, [c["id"] for c in inventory["channels"]])
        self.assertEqual(self.event.name, inventory["name"])
        self.assertIn("Event", repr(self.event))

    @skip_without("numpy")
    def test_numpy_arrays_out(self):
        import numpy as np

        arrays = self.event.to_numpy()
        self.assertEqual(list(arrays), self.event.channel_ids)
        inventory = {c["id"]: c["npts"] for c in quaketwin.inspect(AMBIENT)["channels"]}
        for cid, a in arrays.items():
            self.assertIsInstance(a, np.ndarray)
            self.assertEqual(a.shape, (inventory[cid],))
            rows = self.event.channel(cid)
            self.assertEqual(a.tolist(), rows.column("acc_m_s2").to_pylist())
        f = self.modes.frequencies_hz
        self.assertEqual(f.tolist(), self.modes.table.column("frequency_hz").to_pylist())
        shapes = self.modes.shapes
        self.assertEqual(shapes.shape, (len(self.modes), len(self.modes.output_channels)))
        self.assertTrue(np.iscomplexobj(shapes))
        # Normalised: the largest component of every shape is 1 (real).
        np.testing.assert_allclose(np.abs(shapes).max(axis=1), 1.0, rtol=1e-9)

    @skip_without("numpy")
    def test_intervals_are_students_t_of_the_degrees_of_freedom(self):
        import numpy as np

        f = self.modes.frequencies_hz
        sd = self.modes.frequency_std_data_hz
        intervals = self.modes.frequency_intervals_hz
        self.assertEqual(intervals.shape, (len(self.modes), 2))
        known = np.isfinite(sd)
        self.assertTrue(known.any(), "no mode with a data-driven σ")
        dof = np.array(self.modes.table.column("uncertainty_dof").to_pylist(), dtype=float)
        k = (intervals[known, 1] - f[known]) / sd[known]
        np.testing.assert_allclose(intervals[known, 0], f[known] - k * sd[known], rtol=1e-12)
        # Student's t_{0.975, ν}: above the normal 1.96, and tabulated values.
        self.assertTrue(np.all(k > 1.96) and np.all(k < 13.0), k)
        for t, nu in [(2.2622, 9.0), (2.0452, 29.0)]:
            self.assertAlmostEqual(quaketwin._native.interval_factor(nu), t, places=3)
        if importlib.util.find_spec("scipy") is not None:
            from scipy import stats

            np.testing.assert_allclose(k, stats.t.ppf(0.975, dof[known]), rtol=1e-6)
        self.assertTrue(np.all(np.isnan(intervals[~known])))
        self.assertIn("±", self.modes._repr_html_())

    def test_modes_equal_the_functional_call(self):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", quaketwin.QuaketwinWarning)
            table, _ = quaketwin.modal(self.event.samples, {"method": "ssi-cov"})
        self.assertEqual(self.modes.table.column("frequency_hz").to_pylist(), table.column("frequency_hz").to_pylist())

    def test_modes_read_from_a_run_directory(self):
        with tempfile.TemporaryDirectory() as out:
            cli("modal", AMBIENT, "--out", out)
            read = quaketwin.Modes.read(out)
            expected = pq.read_table(pathlib.Path(out) / "modes/modes.parquet")
            self.assertEqual(read.table.column("frequency_hz").to_pylist(), expected.column("frequency_hz").to_pylist())
            self.assertIsNotNone(read.stabilization)
            self.assertEqual(read.output_channels, json.loads(expected.schema.metadata[b"quaketwin.output_channels"]))

    def test_jupyter_html_is_well_formed_and_complete(self):
        for obj, must in [
            (self.event, self.event.channel_ids),
            (self.modes, [f"{f:.4f}" for f in self.modes.table.column("frequency_hz").to_pylist()]),
        ]:
            text = obj._repr_html_()
            ET.fromstring(text)  # well-formed (escaped) markup
            for m in must:
                self.assertIn(m, text)

    @skip_without("matplotlib")
    def test_plots(self):
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig = self.modes.plot()
        visible = [ax for ax in fig.axes if ax.get_visible()]
        self.assertEqual(len(visible), len(self.modes))
        # The first mode of the 4-storey building in X: four channels drawn
        # at the storey heights 4, 7.5, 11, 14.5 m.
        first = visible[0]
        drawn = [line for line in first.get_lines() if line.get_marker() == "o"]
        heights = sorted({float(y) for line in drawn for y in line.get_ydata()})
        self.assertEqual(heights, [4.0, 7.5, 11.0, 14.5])
        self.assertIn(f"{self.modes.table.column('frequency_hz')[0].as_py():.3f} Hz", first.get_title())
        stab = self.modes.plot_stabilization()
        self.assertEqual(len(stab.axes), 1)
        records = self.event.plot(channels=self.event.channel_ids[:2])
        self.assertEqual(len(records.axes), 2)
        plt.close("all")

    def test_plot_without_matplotlib_says_what_to_install(self):
        with unittest.mock.patch.dict(sys.modules, {"matplotlib": None, "matplotlib.pyplot": None}):
            with self.assertRaises(ImportError) as caught:
                self.modes.plot()
        self.assertIn("pip install matplotlib", str(caught.exception))

    def test_to_obspy_without_obspy_says_what_to_install(self):
        with unittest.mock.patch.dict(sys.modules, {"obspy": None}):
            with self.assertRaises(ImportError) as caught:
                self.event.to_obspy()
        self.assertIn("pip install obspy", str(caught.exception))

    @skip_without("obspy")
    def test_to_obspy_stream(self):
        stream = self.event.to_obspy()
        self.assertEqual(len(stream), len(self.event))
        channels = {c["id"]: c for c in self.event.channels}
        for trace in stream:
            cid = trace.stats.quaketwin.id
            self.assertEqual(trace.stats.sampling_rate, channels[cid]["sampling_rate_hz"])
            self.assertEqual(trace.data.tolist(), self.event.channel(cid).column("acc_m_s2").to_pylist())
            self.assertEqual(trace.stats.quaketwin.level, channels[cid]["level"])


class Fleet(unittest.TestCase):
    """The fleet from a plain script, as docs/python.md shows it."""

    SCRIPT = (
        "import quaketwin\n"
        "{indent}runs = quaketwin.fleet.run({pipeline!r}, [{event!r}], {out!r}, progress=False)\n"
        "{indent}print(runs.column('status').to_pylist())\n"
    )

    def _script(self, work, guarded):
        out = str(pathlib.Path(work) / "ds")
        body = self.SCRIPT.format(
            indent="    " if guarded else "", pipeline=str(PIPELINE), event=str(AMBIENT), out=out
        )
        if guarded:
            first, rest = body.split("\n", 1)
            body = first + '\nif __name__ == "__main__":\n' + rest
        path = pathlib.Path(work) / "fleet_script.py"
        path.write_text(body)
        return path

    def test_a_script_without_the_main_guard_is_told_what_to_add(self):
        with tempfile.TemporaryDirectory() as work:
            script = self._script(work, guarded=False)
            t0 = time.monotonic()
            r = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=300, cwd=work)
            self.assertLess(time.monotonic() - t0, 60.0)
            self.assertNotEqual(r.returncode, 0)
            self.assertIn("ScriptGuardError", r.stderr)
            self.assertIn(f"{script}, line 2", r.stderr)
            self.assertIn('if __name__ == "__main__":', r.stderr)
            self.assertNotIn("Nanny failed", r.stderr)

    def test_the_guarded_script_runs_the_fleet(self):
        with tempfile.TemporaryDirectory() as work:
            script = self._script(work, guarded=True)
            r = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=600, cwd=work)
            self.assertEqual(r.returncode, 0, r.stderr)
            self.assertEqual(r.stdout.strip().splitlines()[-1], "['ok']")


@skip_without("obspy")
class StationXmlWithObsPy(unittest.TestCase):
    """``synth-archive``'s StationXML through ObsPy (issue 34 item 5): the
    response has stages, ``remove_response`` takes it, and what it returns
    is the counts divided by the sensitivity (the archive records the
    acceleration times a flat gain)."""

    def test_remove_response_gives_the_acceleration(self):
        import numpy as np
        import obspy

        with tempfile.TemporaryDirectory() as work:
            arch = pathlib.Path(work) / "arch"
            cli("synth-archive", "--out", arch, "--days", "1", "--day-length", "10m", "--channels", "2", "--rate", "20")
            inventory = obspy.read_inventory(str(arch / "station.xml"))
            files = sorted((arch / "sds").rglob("*.D.*"))
            self.assertEqual(len(files), 2)
            for f in files:
                stream = obspy.read(str(f))
                trace = stream.merge()[0]
                response = inventory.get_response(trace.id, trace.stats.starttime)
                self.assertEqual(len(response.response_stages), 2)
                self.assertEqual(response.instrument_sensitivity.value, 4e5)
                self.assertEqual(response.instrument_sensitivity.input_units, "m/s**2")
                gains = np.prod([s.stage_gain for s in response.response_stages])
                self.assertAlmostEqual(gains / 4e5, 1.0, places=12)
                # Flat from near zero to Nyquist, in acceleration.
                h, freqs = response.get_evalresp_response(trace.stats.delta, 2048, output="ACC")
                np.testing.assert_allclose(np.abs(h[1:]), 4e5, rtol=1e-9)
                counts = trace.data.astype(np.float64)
                trace.remove_response(inventory=inventory, output="ACC", water_level=None, taper=False, zero_mean=False)
                # ObsPy's deconvolution alters two bins of the spectrum: it
                # drops the zero frequency and keeps the Nyquist bin's
                # modulus.  Over the record these add a constant and an
                # alternating ±1 sequence; apart from them the result is the
                # counts divided by the sensitivity, to rounding.
                expected = counts / 4e5
                residual = trace.data - expected
                alternating = (-1.0) ** np.arange(len(residual))
                basis = np.stack([np.ones_like(residual), alternating], axis=1)
                coef, *_ = np.linalg.lstsq(basis, residual, rcond=None)
                rest = residual - basis @ coef
                self.assertLess(np.abs(rest).max(), 1e-9 * np.abs(expected).max())
                self.assertLess(np.abs(coef).max(), 1e-3 * np.abs(expected).max())


@skip_without("nbclient", "ipykernel", "matplotlib", "duckdb")
class Notebook(unittest.TestCase):
    """docs/python-example.ipynb runs from top to bottom (as CI runs it) and
    shows a mode-shape plot and a DuckDB query across a many-event dataset."""

    def test_the_example_notebook_runs(self):
        import nbclient
        import nbformat

        nb = nbformat.read(str(NOTEBOOK), as_version=4)
        nbclient.NotebookClient(
            nb, timeout=600, kernel_name="python3", resources={"metadata": {"path": str(NOTEBOOK.parent)}}
        ).execute()
        outputs = [o for cell in nb.cells if cell.cell_type == "code" for o in cell.get("outputs", [])]
        self.assertFalse([o for o in outputs if o.get("output_type") == "error"])
        pngs = [o for o in outputs if "image/png" in o.get("data", {})]
        self.assertGreaterEqual(len(pngs), 1, "no figure")
        text = "\n".join(
            o.get("text", "") + o.get("data", {}).get("text/plain", "") for o in outputs
        )
        # The DuckDB query over the many-event dataset lists every sample event.
        for event in ("synthetic-4storey-quake", "synthetic-4storey-ambient", "synthetic-2storey-yielding"):
            self.assertIn(event, text)


if __name__ == "__main__":
    unittest.main()
