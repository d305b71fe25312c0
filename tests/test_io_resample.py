"""merge_streams: anti-aliasing, gaps, separate clocks, sparse GPS placement."""

import numpy as np
import pytest

from spotfree.errors import InputError
from spotfree.io.resample import Stream, merge_streams


def _amplitude(t, x, frequency):
    """Least-squares amplitude of a sinusoid of ``frequency`` Hz in ``x(t)``."""
    basis = np.column_stack([np.sin(2 * np.pi * frequency * t), np.cos(2 * np.pi * frequency * t), np.ones_like(t)])
    coef, *_ = np.linalg.lstsq(basis, x, rcond=None)
    return float(np.hypot(coef[0], coef[1]))


def test_a_tone_above_the_grid_nyquist_is_attenuated_and_the_band_passes():
    fs, grid = 200.0, 20.0
    t = np.arange(0, 20, 1 / fs)
    x = np.sin(2 * np.pi * 1.0 * t) + np.sin(2 * np.pi * 15.0 * t)  # 15 Hz folds onto 5 Hz at 20 Hz
    rec = merge_streams({"imu": Stream(t, x, ("gx",))}, rate=grid)
    inner = (rec.time > 1) & (rec.time < 19)
    out, tt = rec.channels["gx"][inner], rec.time[inner]
    assert _amplitude(tt, out, 5.0) < 0.02
    assert _amplitude(tt, out, 1.0) == pytest.approx(1.0, abs=0.01)
    naive = np.interp(tt, t, x)  # what plain interpolation would give: the alias at full strength
    assert _amplitude(tt, naive, 5.0) > 0.9


def test_a_slower_stream_is_interpolated_without_filtering():
    t = np.arange(0, 10, 0.1)  # 10 Hz onto a 20 Hz grid
    rec = merge_streams({"imu": Stream(t, 3 * t - 1, ("ax",))}, rate=20.0)
    assert np.allclose(rec.channels["ax"], 3 * rec.time - 1)
    assert rec.meta["native_rates"]["imu"] == pytest.approx(10.0)


def test_a_hole_longer_than_max_gap_is_reported_and_nan_in_every_dense_channel():
    t = np.arange(0, 10, 0.01)
    hole = (t > 4.0) & (t < 5.2)
    acc = Stream(t[~hole], np.sin(t[~hole]), ("ax",))
    gyro = Stream(t, np.cos(t), ("gx",))
    rec = merge_streams({"acc": acc, "gyro": gyro}, rate=20.0, max_gap=0.5)
    assert len(rec.gaps) == 1
    gap = rec.gaps[0]
    assert gap.channel == "acc"
    assert gap.start == pytest.approx(4.0) and gap.end == pytest.approx(5.2)
    inside = (rec.time > gap.start) & (rec.time < gap.end)
    assert inside.sum() == 23
    assert np.isnan(rec.channels["ax"][inside]).all() and np.isnan(rec.channels["gx"][inside]).all()
    assert np.isfinite(rec.array()[~inside]).all()
    assert rec.segments() == [(0, int(np.flatnonzero(inside)[0])), (int(np.flatnonzero(inside)[-1]) + 1, len(rec))]


def test_a_hole_shorter_than_max_gap_is_bridged():
    t = np.arange(0, 10, 0.01)
    keep = ~((t > 4.0) & (t < 4.3))
    rec = merge_streams({"acc": Stream(t[keep], 2 * t[keep], ("ax",))}, rate=20.0, max_gap=0.5)
    assert rec.gaps == []
    inner = (rec.time > 0.5) & (rec.time < 9.5)
    assert np.allclose(rec.channels["ax"][inner], 2 * rec.time[inner], atol=1e-3)


def test_nan_samples_count_as_missing():
    t = np.arange(0, 10, 0.01)
    x = np.sin(t)
    x[300:400] = np.nan  # 1 s without values
    rec = merge_streams({"acc": Stream(t, x, ("ax",))}, rate=20.0, max_gap=0.5)
    assert len(rec.gaps) == 1 and rec.gaps[0].start == pytest.approx(2.99) and rec.gaps[0].end == pytest.approx(4.0)


def test_two_clocks_with_an_offset_merge_onto_their_overlap():
    rng = np.random.default_rng(1)
    f = 0.3  # slow signals: the merge must reproduce them at the grid times
    t_acc = 0.003 + np.arange(0, 30, 0.01)
    t_gyro = 0.5 + np.cumsum(rng.uniform(0.018, 0.022, 1200))
    acc = Stream(t_acc, np.sin(2 * np.pi * f * t_acc), ("ax",))
    gyro = Stream(t_gyro, np.cos(2 * np.pi * f * t_gyro), ("gz",))
    rec = merge_streams({"acc": acc, "gyro": gyro}, rate=20.0)
    assert rec.time[0] == pytest.approx(t_gyro[0])
    assert rec.time[-1] <= min(t_acc[-1], t_gyro[-1]) + 1e-9
    assert np.allclose(np.diff(rec.time), 0.05)
    assert np.allclose(rec.channels["ax"], np.sin(2 * np.pi * f * rec.time), atol=2e-3)
    assert np.allclose(rec.channels["gz"], np.cos(2 * np.pi * f * rec.time), atol=2e-3)
    assert rec.gaps == []


def test_gps_fixes_land_on_the_nearest_sample_and_never_make_a_gap():
    t = np.arange(0, 10, 0.01)
    fixes = np.array([-0.5, 1.02, 2.04, 3.06, 9.97, 12.0])  # two outside the IMU span
    gps = Stream(fixes, np.column_stack([35 + fixes, 139 + fixes]), ("lat", "lon"))
    rec = merge_streams({"acc": Stream(t, np.sin(t), ("ax",)), "gps": gps}, rate=20.0)
    placed = np.flatnonzero(np.isfinite(rec.channels["lat"]))
    assert rec.time[placed] == pytest.approx([1.0, 2.05, 3.05, 9.95])
    assert rec.channels["lat"][placed] == pytest.approx(35 + fixes[1:5])
    assert rec.gaps == [] and rec.valid().all()


def test_two_fixes_on_one_sample_keep_the_later():
    t = np.arange(0, 5, 0.01)
    gps = Stream([1.0, 1.01], [[1.0], [2.0]], ("speed",))
    rec = merge_streams({"acc": Stream(t, t, ("ax",)), "gps": gps}, rate=20.0)
    assert rec.channels["speed"][20] == 2.0
    assert np.isfinite(rec.channels["speed"]).sum() == 1


def test_gps_alone_spans_its_fixes():
    gps = Stream([10.0, 11.0, 12.5], [[1.0], [2.0], [3.0]], ("speed",))
    rec = merge_streams({"gps": gps}, rate=2.0)
    assert rec.time[0] == 10.0 and rec.time[-1] == 12.5
    assert rec.channels["speed"][[0, 2, 5]] == pytest.approx([1, 2, 3])


def test_streams_that_do_not_overlap_are_refused():
    a = Stream(np.arange(0, 1, 0.01), np.zeros(100), ("ax",))
    b = Stream(np.arange(2, 3, 0.01), np.zeros(100), ("gx",))
    with pytest.raises(InputError, match="do not overlap"):
        merge_streams({"a": a, "b": b}, source="ride.csv")


def test_a_dense_stream_slower_than_the_gap_limit_is_refused():
    slow = Stream(np.arange(0, 10, 1.0), np.zeros(10), ("ax",))
    with pytest.raises(InputError, match="ride.csv.*'acc'.*max_gap"):
        merge_streams({"acc": slow}, max_gap=0.5, source="ride.csv")


def test_mixing_gps_and_dense_channels_in_one_stream_is_a_programming_error():
    with pytest.raises(ValueError):
        Stream([0, 1], [[1, 2], [3, 4]], ("ax", "lat"))
