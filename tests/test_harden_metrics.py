"""Issue 33: metric rules checked away from their defaults (DNSMOS after a latency).

These tests need no DNSMOS model: the network is replaced by a recorder of what it is given.
"""

from __future__ import annotations

import numpy as np

from benchmarks.metrics import dnsmos


def test_dnsmos_of_an_output_skips_its_declared_latency(monkeypatch):
    # Oracle: the output channel from sample `latency` on, passed unchanged at 16 kHz and
    # resampled (length n * 16000 / fs) at another rate.
    seen = []
    monkeypatch.setattr(dnsmos, "dnsmos_p835", lambda x, fs: seen.append((np.array(x), fs)) or {})
    y = np.arange(1000.0)
    dnsmos.output_columns(y, 16000, 37)
    np.testing.assert_array_equal(seen[0][0], y[37:])
    assert seen[0][1] == 16000
    dnsmos.output_columns(np.ones(8000), 8000, 400)
    assert seen[1][0].size == (8000 - 400) * 2
