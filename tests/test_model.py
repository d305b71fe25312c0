import json

import numpy as np
import pytest

from spotfree.errors import InputError
from spotfree.model import DictionaryModel
from spotfree.representation import representation_size


def _model():
    rng = np.random.default_rng(0)
    return DictionaryModel(
        classes=["cruising", "sudden-braking"],
        channels=["pitch", "pitch_rate"],
        rate=20.0,
        window=5,
        step=1,
        normalisation="scale",
        scale=[0.1, 0.3],
        dictionary=rng.normal(size=(10, 7)),
        column_class=[0, 0, 0, 1, 1, 0, 1],
        summary={"clusters": [{"name": "cruising", "confidence": 0.9}]},
    )


def test_round_trip_keeps_every_field(tmp_path):
    model = _model()
    model.save(tmp_path / "m.npz")
    loaded = DictionaryModel.load(tmp_path / "m.npz")
    np.testing.assert_array_equal(loaded.dictionary, model.dictionary)
    np.testing.assert_array_equal(loaded.column_class, model.column_class)
    assert loaded.metadata() == model.metadata()


def test_causal_columns_round_trip_and_are_checked(tmp_path):
    model = _model()
    model.causal_dictionary, model.causal_column_class = model.dictionary[:, :4] * 2, [1, 0, 1, 1]
    model.__post_init__()
    model.save(tmp_path / "c.npz")
    loaded = DictionaryModel.load(tmp_path / "c.npz")
    np.testing.assert_array_equal(loaded.causal_dictionary, model.causal_dictionary)
    np.testing.assert_array_equal(loaded.columns(causal=True)[1], [1, 0, 1, 1])
    np.testing.assert_array_equal(loaded.columns(causal=False)[1], model.column_class)
    np.testing.assert_array_equal(_model().columns(causal=True)[1], _model().column_class)  # none: the others
    with pytest.raises(InputError, match="go together"):
        DictionaryModel(**{**vars(_model()), "causal_column_class": [0]})
    with pytest.raises(InputError, match="causal dictionary"):
        DictionaryModel(**{**vars(_model()), "causal_dictionary": np.zeros((10, 2)), "causal_column_class": [0, 5]})


def test_same_model_gives_the_same_bytes(tmp_path):
    _model().save(tmp_path / "a.npz")
    _model().save(tmp_path / "b.npz")
    a = np.load(tmp_path / "a.npz", allow_pickle=False)
    b = np.load(tmp_path / "b.npz", allow_pickle=False)
    assert all(np.array_equal(a[k], b[k]) for k in a.files)


def test_garbage_file_is_a_clear_error_and_pickles_are_refused(tmp_path):
    (tmp_path / "junk.npz").write_bytes(b"not a zip")
    with pytest.raises(InputError, match="not a spotfree model"):
        DictionaryModel.load(tmp_path / "junk.npz")
    np.savez(tmp_path / "obj.npz", metadata=np.array([{"a": 1}], dtype=object), dictionary=np.zeros((2, 2)))
    with pytest.raises(InputError, match="not a spotfree model"):
        DictionaryModel.load(tmp_path / "obj.npz")


def _rewrite_metadata(path, **changes):
    with np.load(path, allow_pickle=False) as archive:
        arrays = {k: archive[k] for k in archive.files}
    meta = json.loads(str(arrays["metadata"]))
    meta.update(changes)
    meta = {k: v for k, v in meta.items() if v is not None}
    np.savez_compressed(path, **{**arrays, "metadata": np.array(json.dumps(meta))})


def test_a_model_on_vibration_channels_of_an_earlier_feature_version_is_refused(tmp_path):
    road = DictionaryModel(**{**vars(_model()), "channels": ["vib_y", "vib_z"]})
    road.save(tmp_path / "road.npz")
    assert DictionaryModel.load(tmp_path / "road.npz").channels == ["vib_y", "vib_z"]
    _rewrite_metadata(tmp_path / "road.npz", feature_version=None)  # written before versions were stored
    with pytest.raises(InputError, match="vib_y, vib_z as computed before feature version 2.*retrain"):
        DictionaryModel.load(tmp_path / "road.npz")
    _model().save(tmp_path / "braking.npz")  # channels whose computation has not changed load as before
    _rewrite_metadata(tmp_path / "braking.npz", feature_version=None)
    assert DictionaryModel.load(tmp_path / "braking.npz").channels == ["pitch", "pitch_rate"]


def test_a_summary_model_of_an_older_schema_is_refused_and_a_hankel_one_still_loads(tmp_path):
    summary = DictionaryModel(**{**vars(_model()), "representation": "summary",
                                 "dictionary": np.zeros((representation_size(2, 5, "summary"), 3)),
                                 "column_class": [0, 1, 1], "feature_offset": None, "feature_scale": None})
    summary.save(tmp_path / "summary.npz")
    assert DictionaryModel.load(tmp_path / "summary.npz").representation == "summary"
    _rewrite_metadata(tmp_path / "summary.npz", schema_version=2)
    with pytest.raises(InputError, match="summary model of schema 2.*retrain"):
        DictionaryModel.load(tmp_path / "summary.npz")
    _model().save(tmp_path / "hankel.npz")
    _rewrite_metadata(tmp_path / "hankel.npz", schema_version=2)
    assert DictionaryModel.load(tmp_path / "hankel.npz").representation == "hankel"


def test_inconsistent_shapes_are_rejected():
    with pytest.raises(InputError, match="rows"):
        DictionaryModel(classes=["a"], channels=["x"], rate=20, window=3, step=1, normalisation="scale",
                        scale=[1.0], dictionary=np.zeros((4, 2)), column_class=[0, 0])


def test_failed_save_keeps_the_existing_file(tmp_path, monkeypatch):
    path = tmp_path / "m.npz"
    _model().save(path)
    before = path.read_bytes()

    def boom(*args, **kwargs):
        raise OSError("disk full")

    monkeypatch.setattr(np, "savez_compressed", boom)
    with pytest.raises(OSError):
        _model().save(path)
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["m.npz"]
