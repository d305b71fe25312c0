"""The generic CSV reader and writer, and read_recording's handling of paths."""

import numpy as np
import pandas as pd
import pytest

from spotfree.errors import InputError
from spotfree.io import checks, read_recording
from spotfree.io.csvlog import read_csv, write_csv
from spotfree.io.recording import Recording

RATE = 20.0


def ride(n=120, rate=RATE, experiments=(1, 2), restart=True, seed=0):
    """A simulator-like Recording: IMU with gravity, sparse GPS at 1 Hz, truth, several experiments."""
    rng = np.random.default_rng(seed)
    parts = []
    for k, number in enumerate(experiments):
        t = np.arange(n) / rate + (0 if restart else k * n / rate)
        gps = np.full(n, np.nan)
        gps[:: int(rate)] = 1.0
        parts.append(pd.DataFrame({
            "experiment": number, "time": t,
            "ax": rng.normal(0, 0.5, n), "ay": rng.normal(0, 0.5, n), "az": 9.81 + rng.normal(0, 0.5, n),
            "gx": rng.normal(0, 0.1, n), "gy": rng.normal(0, 0.1, n), "gz": rng.normal(0, 0.1, n),
            "lat": 35.7 + 1e-5 * np.arange(n) * gps, "lon": 139.7 + 1e-5 * np.arange(n) * gps,
            "speed": 3.0 * gps,
            "label": np.where(np.arange(n) < n // 2, "cruising", "sudden-braking"),
            "event": np.where(np.arange(n) % 17 == 0, "bump, small", ""),
        }))
    table = pd.concat(parts, ignore_index=True)
    channels = {c: table[c].to_numpy() for c in ["ax", "ay", "az", "gx", "gy", "gz", "lat", "lon", "speed"]}
    return Recording(
        time=table["time"].to_numpy(), channels=channels, rate=rate, experiment=table["experiment"].to_numpy(),
        truth={"label": table["label"].to_numpy(dtype=str), "event": table["event"].to_numpy(dtype=str)},
    )


def write_table(path, columns: dict, sep=","):
    pd.DataFrame(columns).to_csv(path, index=False, sep=sep)
    return path


def imu_table(n=100, rate=RATE, seed=0):
    rng = np.random.default_rng(seed)
    return {
        "time": np.arange(n) / rate,
        "ax": rng.normal(0, 0.3, n), "ay": rng.normal(0, 0.3, n), "az": 9.81 + rng.normal(0, 0.3, n),
        "gx": rng.normal(0, 0.1, n), "gy": rng.normal(0, 0.1, n), "gz": rng.normal(0, 0.1, n),
    }


def assert_same(a: Recording, b: Recording):
    assert a.names == b.names
    for name in a.names:
        np.testing.assert_allclose(a.channels[name], b.channels[name], rtol=1e-9, atol=0, equal_nan=True)
    np.testing.assert_allclose(a.time, b.time, rtol=0, atol=1e-9)
    assert a.rate == b.rate
    assert set(a.truth) == set(b.truth)
    for name in a.truth:
        assert a.truth[name].tolist() == b.truth[name].tolist()
    if a.experiment is None:
        assert b.experiment is None
    else:
        assert a.experiment.tolist() == b.experiment.tolist()


# ---------------------------------------------------------------- round trips


@pytest.mark.parametrize("restart", [True, False], ids=["time-restarts", "time-continues"])
def test_simulator_files_round_trip_exactly(tmp_path, restart):
    rec = ride(restart=restart)
    write_csv(rec, tmp_path / "ride.csv")
    back = read_csv(tmp_path / "ride.csv")
    assert_same(rec, back)
    assert back.meta["repairs"] == [] and back.meta["warnings"] == [] and back.gaps == []
    header = (tmp_path / "ride.csv").read_text().splitlines()[0]
    assert header == "experiment,time,ax,ay,az,gx,gy,gz,lat,lon,speed,label,event"


def test_gps_cells_are_empty_where_there_is_no_fix(tmp_path):
    write_csv(ride(n=40), tmp_path / "ride.csv")
    table = pd.read_csv(tmp_path / "ride.csv", dtype=str, keep_default_na=False)
    assert (table["lat"] == "").sum() == 2 * 38
    assert "nan" not in (tmp_path / "ride.csv").read_text().lower()


def test_writing_without_truth_drops_label_and_event(tmp_path):
    write_csv(ride(n=30), tmp_path / "f.csv", truth=False)
    assert not {"label", "event"} & set(pd.read_csv(tmp_path / "f.csv").columns)


def test_a_file_at_another_rate_goes_onto_the_requested_grid_and_says_so(tmp_path):
    """Logs of several rates go onto one grid (anti-aliased: a 30 Hz sway of a 100 Hz log is gone at 20 Hz); a
    file within 10 % of the requested rate keeps its samples."""
    rec = ride(n=1000, rate=100.0, experiments=(1,))
    t = np.arange(1000) / 100.0
    rec.channels["gx"] = 0.5 + 0.2 * np.sin(2 * np.pi * 30.0 * t)
    write_csv(rec, tmp_path / "fast.csv")
    back = read_csv(tmp_path / "fast.csv", rate=20.0)
    assert back.rate == 20.0 and abs(back.duration - rec.duration) <= 0.05
    assert any("sampled at 100 Hz; resampled onto the 20 Hz grid" in r for r in back.meta["repairs"])
    middle = back.channels["gx"][20:-20]
    assert np.max(np.abs(middle - 0.5)) < 0.02  # the 30 Hz sway is not aliased into the 20 Hz grid
    same = read_csv(tmp_path / "fast.csv", rate=95.0)
    assert same.rate == 100.0 and not same.meta["repairs"]
    np.testing.assert_allclose(same.channels["gx"], rec.channels["gx"], rtol=1e-9)


def test_jittered_times_are_snapped_to_the_files_rate(tmp_path):
    columns = imu_table(n=200)
    columns["time"] = columns["time"] + np.random.default_rng(2).uniform(-0.005, 0.005, 200)
    rec = read_csv(write_table(tmp_path / "j.csv", columns))
    assert rec.rate == pytest.approx(20.0, rel=1e-3)
    assert np.allclose(np.diff(rec.time), 1 / rec.rate)
    assert np.array_equal(rec.channels["gx"], columns["gx"])


def test_a_short_fast_log_at_a_late_epoch_reads_back_at_its_rate(tmp_path):
    # 15 samples at 1 kHz some 7 years after the epoch: the float times are 30 ns apart at best, and the written
    # and read times may each be two of those spacings off, enough to move a rate estimate over 14 ms by 4 ppm
    rec = Recording(time=229215237.9013299 + np.arange(15) / 1000.0, channels={"roll": np.zeros(15)}, rate=1000.0)
    write_csv(rec, tmp_path / "fast.csv")
    assert read_csv(tmp_path / "fast.csv", rate=1000.0).rate == 1000.0


def test_a_failed_write_leaves_the_old_file_intact(tmp_path, monkeypatch):
    target = tmp_path / "ride.csv"
    target.write_text("old content\n")

    def broken_replace(src, dst):
        raise OSError("disk full")

    monkeypatch.setattr(checks.os, "replace", broken_replace)
    with pytest.raises(OSError):
        write_csv(ride(n=30), target)
    assert target.read_text() == "old content\n"
    assert [p.name for p in tmp_path.iterdir()] == ["ride.csv"]


def test_writing_into_a_missing_folder_is_an_input_error(tmp_path):
    with pytest.raises(InputError, match="does not exist"):
        write_csv(ride(n=30), tmp_path / "nope" / "ride.csv")


# ---------------------------------------------------------------- columns


def test_case_and_spaces_in_standard_names_are_renamed_and_logged(tmp_path):
    columns = imu_table()
    columns["Time"] = columns.pop("time")
    columns[" ax "] = columns.pop("ax")
    rec = read_csv(write_table(tmp_path / "c.csv", columns))
    assert {"ax", "gx"} <= set(rec.names)
    assert any("'Time' -> 'time'" in r and "' ax ' -> 'ax'" in r for r in rec.meta["repairs"])


@pytest.mark.parametrize(
    "wrong, right", [("acc_x", "ax"), ("gyro_z", "gz"), ("Accel X", "ax"), ("tiem", "time"), ("latitude", "lat"),
                     ("x_acc", "ax"), ("z_gyro", "gz"), ("timestamp", "time")]
)
def test_misspelt_columns_are_refused_with_the_right_name(tmp_path, wrong, right):
    columns = imu_table()
    columns["lat"] = np.full(100, 35.0)
    columns[wrong] = columns.pop(right)
    path = write_table(tmp_path / "m.csv", columns)
    with pytest.raises(InputError) as info:
        read_csv(path)
    message = str(info.value)
    assert str(path) in message and f"'{wrong}' should be '{right}'" in message and "\n" not in message


def test_a_gzip_compressed_log_reads_as_the_file_it_holds_and_a_truncated_one_is_refused(tmp_path):
    import gzip

    plain = write_table(tmp_path / "log.csv", imu_table())
    packed = tmp_path / "log.csv.gz"
    packed.write_bytes(gzip.compress(plain.read_bytes()))
    assert_same(read_recording(str(packed)), read_recording(str(plain)))
    broken = tmp_path / "broken.csv.gz"
    broken.write_bytes(packed.read_bytes()[:60])
    with pytest.raises(InputError, match=r"broken\.csv\.gz: cannot be read .*; check the file$"):
        read_recording(str(broken))


def test_a_gzip_log_that_inflates_past_the_limit_is_refused(tmp_path, monkeypatch):
    import gzip

    packed = tmp_path / "big.csv.gz"
    packed.write_bytes(gzip.compress(write_table(tmp_path / "big.csv", imu_table()).read_bytes()))
    assert 2 * packed.stat().st_size < (tmp_path / "big.csv").stat().st_size
    monkeypatch.setattr(checks, "MAX_UNPACKED", 2 * packed.stat().st_size)  # more than the file, less than it holds
    with pytest.raises(InputError, match=r"big\.csv\.gz: holds more than .* GiB once uncompressed; split the log"):
        read_recording(str(packed))


def test_a_missing_time_column_is_named(tmp_path):
    columns = imu_table()
    columns["clock"] = columns.pop("time")
    path = write_table(tmp_path / "t.csv", columns)
    with pytest.raises(InputError, match=r"t\.csv: no 'time' column.*'clock'"):
        read_csv(path)


def test_gravity_free_ride_features_named_acc_x_are_accepted(tmp_path):
    rng = np.random.default_rng(0)
    columns = {"time": np.arange(50) / 20, "roll": rng.normal(0, 0.01, 50), "pitch": rng.normal(0, 0.01, 50),
               "acc_x": rng.normal(0, 0.2, 50), "acc_y": rng.normal(0, 0.2, 50), "acc_z": rng.normal(0, 0.2, 50)}
    rec = read_csv(write_table(tmp_path / "features.csv", columns))
    assert rec.names == ["roll", "pitch", "acc_x", "acc_y", "acc_z"]


def test_acc_x_with_gravity_is_a_misspelt_raw_column(tmp_path):
    rng = np.random.default_rng(0)
    columns = {"time": np.arange(50) / 20, "acc_x": rng.normal(0, 0.2, 50), "acc_y": rng.normal(0, 0.2, 50),
               "acc_z": 9.8 + rng.normal(0, 0.2, 50)}
    with pytest.raises(InputError, match="'acc_x' should be 'ax'"):
        read_csv(write_table(tmp_path / "raw.csv", columns))


# ---------------------------------------------------------------- cells


@pytest.mark.parametrize(
    "name, text, message",
    [("empty.csv", "", r"empty\.csv: the file is empty"),
     ("header.csv", "time,ax,ay,az\n", r"header\.csv: 0 data row"),
     ("dup.csv", "time,ax,ax\n0,1,2\n0.05,1,2\n", r"dup\.csv: column 'ax' appears twice")],
)
def test_files_without_usable_rows_or_columns_are_refused(name, text, message, tmp_path):
    path = tmp_path / name
    path.write_text(text)
    with pytest.raises(InputError, match=message):
        read_csv(path)


def test_a_non_numeric_cell_is_named_with_its_line(tmp_path):
    columns = {k: v.astype(object) for k, v in imu_table().items()}
    columns["gy"][6] = "1.2.3"
    with pytest.raises(InputError, match=r"n\.csv: column 'gy', line 8: '1\.2\.3' is not a finite number"):
        read_csv(write_table(tmp_path / "n.csv", columns))


def test_an_infinite_cell_is_refused(tmp_path):
    columns = {k: v.astype(object) for k, v in imu_table().items()}
    columns["ax"][3] = "1e400"
    with pytest.raises(InputError, match=r"inf\.csv: column 'ax', line 5: '1e400' is not a finite number"):
        read_csv(write_table(tmp_path / "inf.csv", columns))


def test_a_text_column_is_refused_as_a_whole(tmp_path):
    columns = imu_table()
    columns["note"] = ["ok"] * 100
    with pytest.raises(InputError, match="column 'note' holds text"):
        read_csv(write_table(tmp_path / "text.csv", columns))


def test_an_empty_column_is_refused(tmp_path):
    columns = imu_table()
    columns["gz"] = np.full(100, np.nan)
    with pytest.raises(InputError, match="column 'gz' holds no numbers"):
        read_csv(write_table(tmp_path / "e.csv", columns))


def test_short_nan_runs_are_filled_and_long_ones_are_gaps(tmp_path):
    columns = imu_table(n=100)
    truth = columns["gx"].copy()
    columns["gx"][[10, 11]] = np.nan  # two samples: filled
    columns["ay"][50:60] = np.nan  # ten samples: a gap
    rec = read_csv(write_table(tmp_path / "nan.csv", columns))
    assert np.isfinite(rec.channels["gx"][10:12]).all()
    assert rec.channels["gx"][10] == pytest.approx(truth[9] + (truth[12] - truth[9]) / 3)
    assert any("interpolated 2 missing sample(s) of 'gx'" in r for r in rec.meta["repairs"])
    assert len(rec.gaps) == 1 and rec.gaps[0].channel == "ay"
    assert rec.gaps[0].start == pytest.approx(49 / 20) and rec.gaps[0].end == pytest.approx(60 / 20)
    assert np.isnan(rec.array()[50:60]).all() and np.isfinite(rec.array()[60:]).all()


def test_a_missing_value_in_a_resampled_file_is_dropped_and_logged(tmp_path):
    columns = imu_table(n=250, rate=50.0)
    columns["gx"][100] = np.nan
    rec = read_csv(write_table(tmp_path / "nan50.csv", columns), rate=20.0)
    assert np.isfinite(rec.array()).all() and not rec.gaps
    assert any("dropped 1 sample(s)" in r and "missing (empty or NaN) gx" in r for r in rec.meta["repairs"])
    assert not any("dropped" in r for r in read_csv(write_table(tmp_path / "ok50.csv", imu_table(n=250, rate=50.0)),
                                                    rate=20.0).meta["repairs"])


def test_a_speed_of_minus_one_or_nan_is_an_unknown_speed_and_a_note_says_how_many(tmp_path):
    columns = {k: v.astype(object) for k, v in imu_table(n=100).items()}
    columns["lat"], columns["lon"] = [35.7] * 100, [139.7] * 100
    columns["speed"] = [3.0] * 100
    for row in range(10):
        columns["speed"][row] = -1  # iOS Core Location writes -1 for an unknown speed
    columns["speed"][20], columns["speed"][21] = "NaN", "nan"
    columns["speed"][30] = ""  # no fix: not an unknown speed
    columns["lat"][30] = columns["lon"][30] = ""
    rec = read_csv(write_table(tmp_path / "ios.csv", columns))
    assert np.isnan(rec.channels["speed"][[*range(10), 20, 21, 30]]).all()
    assert (rec.channels["speed"][11:20] == 3.0).all()
    assert [r for r in rec.meta["repairs"] if "speed" in r] == [
        f"{tmp_path / 'ios.csv'}: -1 (iOS's mark for an unknown speed) in 10 and NaN in 2 speed cell(s), "
        f"read as missing GPS speed samples"]


def test_another_negative_speed_is_refused_with_a_plain_number(tmp_path):
    from spotfree.limits import check_recording

    columns = imu_table(n=100)
    columns["speed"] = np.where(np.arange(100) == 5, -0.5, 3.0)
    rec = read_csv(write_table(tmp_path / "neg.csv", columns))
    with pytest.raises(InputError, match=r"channel 'speed', sample 6 \(t = 0\.250 s\): -0\.5 is outside") as error:
        check_recording(rec)
    assert "np." not in str(error.value)


# ---------------------------------------------------------------- time


def test_a_few_out_of_order_rows_are_sorted_and_logged(tmp_path):
    columns = imu_table(n=200)
    order = np.arange(200)
    order[[50, 51]] = order[[51, 50]]
    table = {k: v[order] for k, v in columns.items()}
    rec = read_csv(write_table(tmp_path / "o.csv", table))
    assert np.array_equal(rec.channels["ax"], columns["ax"])
    assert any("sorted 1 out-of-order row" in r for r in rec.meta["repairs"])


def test_time_going_back_often_is_refused_with_the_line(tmp_path):
    columns = imu_table(n=100)
    columns["time"] = np.tile(np.arange(50) / 20, 2)
    with pytest.raises(InputError, match=r"b\.csv: column 'time' goes back in time at line 52"):
        read_csv(write_table(tmp_path / "b.csv", columns))


def test_duplicated_rows_are_dropped_and_logged(tmp_path):
    columns = imu_table(n=100)
    table = {k: np.insert(v, 30, v[30]) for k, v in columns.items()}
    rec = read_csv(write_table(tmp_path / "d.csv", table))
    assert len(rec) == 100 and np.array_equal(rec.channels["az"], columns["az"])
    assert any("dropped 1 duplicated row" in r for r in rec.meta["repairs"])


def test_many_repeated_timestamps_with_other_values_are_refused(tmp_path):
    columns = imu_table(n=100)
    columns["time"] = np.repeat(np.arange(50) / 20, 2)
    with pytest.raises(InputError, match=r"r\.csv: column 'time' repeats the time"):
        read_csv(write_table(tmp_path / "r.csv", columns))


def test_time_in_milliseconds_is_refused_with_the_fix(tmp_path):
    columns = imu_table()
    columns["time"] = columns["time"] * 1000
    with pytest.raises(InputError, match=r"ms\.csv: column 'time'.*milliseconds; convert it to seconds"):
        read_csv(write_table(tmp_path / "ms.csv", columns))


def test_irregular_times_are_resampled_and_long_holes_reported(tmp_path):
    rng = np.random.default_rng(3)
    t = np.cumsum(rng.uniform(0.005, 0.015, 2000))
    t = t[(t < 6) | (t > 7)]
    columns = {"time": t, "gx": np.sin(t), "gy": np.cos(t), "label": np.where(t < 5, "a", "b")}
    rec = read_csv(write_table(tmp_path / "irregular.csv", columns), rate=25.0)
    assert rec.rate == 25.0 and np.allclose(np.diff(rec.time), 0.04)
    ok = rec.valid()
    assert np.allclose(rec.channels["gx"][ok], np.sin(rec.time[ok]), atol=2e-3)
    assert len(rec.gaps) == 1 and 5.9 < rec.gaps[0].start < 6.0 and 7.0 < rec.gaps[0].end < 7.1
    assert set(rec.truth["label"][rec.time < 4.9]) == {"a"} and set(rec.truth["label"][rec.time > 5.1]) == {"b"}
    assert any("resampled onto a 25 Hz grid" in r for r in rec.meta["repairs"])


# ---------------------------------------------------------------- units and experiments


def test_accelerations_in_g_are_refused_with_the_factor(tmp_path):
    columns = imu_table()
    for c in ("ax", "ay", "az"):
        columns[c] = columns[c] / 9.80665
    with pytest.raises(InputError, match=r"g\.csv: columns 'ax', 'ay', 'az'.*in g; multiply them by 9\.80665"):
        read_csv(write_table(tmp_path / "g.csv", columns))


def test_accelerations_in_g_of_ios_sign_are_refused_with_minus_g(tmp_path):
    columns = imu_table()
    for c in ("ax", "ay", "az"):
        columns[c] = -columns[c] / 9.80665  # iOS: minus the specific force, in g; face up reads z = -1
    with pytest.raises(InputError, match=r"in g; multiply them by -9\.80665 to get m/s\^2 \(they read minus the "
                                         r"specific force, as iOS's acceleration does"):
        read_csv(write_table(tmp_path / "ios.csv", columns))


def test_gravity_free_accelerations_are_reported(tmp_path):
    columns = imu_table()
    columns["az"] = columns["az"] - 9.81
    rec = read_csv(write_table(tmp_path / "lin.csv", columns))
    assert any("include gravity" in w for w in rec.meta["warnings"])


def test_an_experiment_split_in_two_blocks_is_refused(tmp_path):
    columns = imu_table(n=90)
    columns["experiment"] = np.repeat([1, 2, 1], 30)
    columns["time"] = np.tile(np.arange(30) / 20, 3)
    with pytest.raises(InputError, match=r"x\.csv: column 'experiment', line 62: experiment 1 starts again"):
        read_csv(write_table(tmp_path / "x.csv", columns))


def test_a_fractional_experiment_number_is_refused(tmp_path):
    columns = imu_table(n=40)
    columns["experiment"] = np.r_[np.ones(20), np.full(20, 1.5)]
    with pytest.raises(InputError, match=r"f\.csv: column 'experiment', line 22: '1\.5' is not a whole number"):
        read_csv(write_table(tmp_path / "f.csv", columns))


def test_semicolon_and_decimal_comma_are_read(tmp_path):
    columns = imu_table(n=60)
    path = tmp_path / "eu.csv"
    pd.DataFrame(columns).to_csv(path, index=False, sep=";", decimal=",")
    rec = read_csv(path)
    np.testing.assert_allclose(rec.channels["az"], columns["az"], rtol=1e-12)


# ---------------------------------------------------------------- read_recording


def test_read_recording_selects_an_experiment(tmp_path):
    rec = ride()
    write_csv(rec, tmp_path / "ride.csv")
    second = read_recording(f"{tmp_path / 'ride.csv'}@2")
    assert len(second) == 120 and set(second.experiment) == {2}
    with pytest.raises(InputError, match="no experiment 5"):
        read_recording(f"{tmp_path / 'ride.csv'}@5")
    with pytest.raises(InputError, match="experiment number"):
        read_recording(f"{tmp_path / 'ride.csv'}@two")


@pytest.mark.parametrize("rate", [RATE, 50.0])
def test_a_motion_channel_that_never_changes_is_warned_about(tmp_path, rate):
    columns = imu_table(n=250, rate=rate)
    columns["gy"] = np.full(250, 0.5)
    rec = read_recording(write_table(tmp_path / "still.csv", columns))
    assert [w for w in rec.meta["warnings"] if "never changes" in w] == [
        f"{tmp_path / 'still.csv'}: gy holds 0.5 throughout; check that its sensor recorded (a channel that never "
        "changes tells no class apart)"]
    assert not read_recording(write_table(tmp_path / "moving.csv", imu_table(n=250, rate=rate))).meta["warnings"]


def test_read_recording_names_a_missing_file(tmp_path):
    with pytest.raises(InputError, match=r"nope\.csv: file not found"):
        read_recording(tmp_path / "nope.csv")
