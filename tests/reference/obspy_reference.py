"""Reference numbers for tests/readers_binary.rs, computed with ObsPy (independent
MiniSEED/SAC decoders).  Run from the repository root:

    pip install obspy
    python3 tests/reference/obspy_reference.py

It prints, per file, the trace id, start time, sampling rate, sample count,
first and last three samples and the sum of samples; the test file stores
these numbers (never the data).
"""
import glob
import os

import obspy

ROOT = os.path.join(os.path.dirname(__file__), "..", "..", "..", "shared", "records")

for path in sorted(glob.glob(os.path.join(ROOT, "nsmp-8040-anchorage-downhole-2018-mseed", "*.mseed"))):
    st = obspy.read(path)
    st.merge()
    for tr in st:
        d = tr.data.astype("int64")
        print("mseed", os.path.basename(path), tr.id, tr.stats.starttime, tr.stats.sampling_rate, tr.stats.npts,
              [int(x) for x in d[:3]], [int(x) for x in d[-3:]], int(d.sum()), int((d * d).sum()))

for path in sorted(glob.glob(os.path.join(ROOT, "usgs-gmprocess-format-samples", "sac", "*.sac"))):
    tr = obspy.read(path, format="SAC")[0]
    d = tr.data.astype("float64")
    print("sac", os.path.basename(path), tr.id, tr.stats.starttime, tr.stats.delta, tr.stats.npts,
          [float(x) for x in d[:3]], [float(x) for x in d[-3:]], repr(float(d.sum())))
