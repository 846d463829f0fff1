"""``rtctl identify RUN --period P`` resamples the recording every P seconds: at 1 kHz and
P = 0.02 s, every 20th row — the fit is the fit of those rows, and its sample time is P."""
import numpy as np

from rtctl.estimation import ArxOrder, identify, simulate
from rtctl.estimation.identify import identify_run
from rtctl.telemetry import Recorder

ORDER = ArxOrder(2, 2, 1)


def test_a_period_resamples_the_recording_every_period_seconds(tmp_path):
    rate, rows, period = 1000, 2000, 0.02
    rng = np.random.default_rng(5)
    u = rng.normal(size=(rows, 2))
    q = np.column_stack([simulate(ORDER, np.array([1.5, -0.7, 1.0, 0.5, 0.2]), u[:, j], 0.01 * rng.normal(size=rows))
                         for j in range(2)])
    rec = Recorder(tmp_path / "run.msgpack", {"t": ((), "f8"), "q": (2, "f8"), "tau": (2, "f8")},
                   {"rate_hz": rate, "joints": ["a", "b"]}, wait_when_full=True)
    for k in range(rows):
        rec.row["t"][()], rec.row["q"][:], rec.row["tau"][:] = k / rate, q[k], u[k]
        rec.commit()
    rec.close()
    every = 20  # 0.02 s × 1000 rows/s
    got = identify_run(tmp_path / "run.msgpack", period=period, order=ORDER)
    assert got["period"] == period and got["joints"] == ["a", "b"]
    assert got["eps"].shape == (rows // every - 1, 2)
    expected = identify(q[::every], u[::every], ORDER)
    np.testing.assert_array_equal(got["theta"], expected["theta"])
    np.testing.assert_array_equal(got["eps"], expected["eps"])
