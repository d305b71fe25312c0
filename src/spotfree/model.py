"""Model files: a dictionary of class representatives and everything needed to window new data like it.

A model file is a NumPy ``.npz`` archive holding

* ``dictionary``  ``(d, N)`` float: the training windows kept as pure class representatives (one per column),
* ``column_class`` ``(N,)`` int: index into ``classes`` of every column,
* ``causal_dictionary`` ``(d, M)`` and ``causal_column_class`` ``(M,)`` (optional): the columns for causal
  classification, each named by the class at its window's last sample instead of its centre,
* ``scale``       ``(c,)`` float: the per-channel scale the windows were divided by,
* ``feature_offset``, ``feature_scale`` ``(d,)`` (models of the ``summary`` representation): a represented window
  ``f`` is compared as ``(f - feature_offset) / feature_scale``,
* ``metadata``    a JSON string (schema version, classes, channels, rate, window, step, normalisation,
  representation, feature pipeline, training parameters and the training summary).

Schema 2 added the representation (:mod:`spotfree.representation`); a schema-1 file is a ``hankel`` model. Schema 3
added to every ``summary`` window the change of level and spread across it: a ``summary`` model of an older schema
must be retrained (its ``hankel`` models stay readable).

Loading uses ``allow_pickle=False``: a model file can never execute code.
"""

from __future__ import annotations

import json
import zipfile
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from spotfree.errors import InputError
from spotfree.io.checks import MAX_RATE, MIN_RATE, replacing
from spotfree.representation import REPRESENTATIONS, represent, representation_size
from spotfree.signal.features import CHANNEL_CHANGED, FEATURE_CHANGES, FEATURE_VERSION

SCHEMA_VERSION = 3
READABLE_SCHEMAS = (1, 2, 3)
MAX_MODEL_BYTES = 1 << 30
"""Bytes the arrays of a model file may declare in all (uncompressed); a trained model is a few MB."""
_METADATA_TYPES = {"classes": list, "channels": list, "rate": (int, float), "window": int, "step": int,
                   "normalisation": str, "features": str, "orientation": str, "parameters": dict, "summary": dict}


@dataclass
class DictionaryModel:
    """A trained dictionary: ``dictionary[:, j]`` is a window of class ``classes[column_class[j]]``.

    ``channels`` are the feature channels in window order, sampled at ``rate`` Hz; a window is ``window`` samples,
    each channel divided by ``scale`` and the column normalised by ``normalisation`` (see :mod:`spotfree.windows`),
    then represented by ``representation`` (:mod:`spotfree.representation`) and, for ``summary``, standardised by
    ``feature_offset`` and ``feature_scale``; :meth:`inputs` does all of it.
    ``features`` names how channels are made from a raw log (``"ride"`` for :func:`ride_features` with
    ``orientation``, ``"channels"`` when the input columns are used as they are).
    """

    classes: list[str]
    channels: list[str]
    rate: float
    window: int
    step: int
    normalisation: str
    scale: np.ndarray
    dictionary: np.ndarray
    column_class: np.ndarray
    representation: str = "hankel"
    feature_offset: np.ndarray | None = None
    feature_scale: np.ndarray | None = None
    features: str = "ride"
    orientation: str = "default"
    parameters: dict = field(default_factory=dict)
    summary: dict = field(default_factory=dict)
    causal_dictionary: np.ndarray | None = None
    causal_column_class: np.ndarray | None = None

    def __post_init__(self) -> None:
        self.scale = np.asarray(self.scale, dtype=float)
        self.dictionary = np.asarray(self.dictionary, dtype=float)
        self.column_class = np.asarray(self.column_class, dtype=int)
        if self.representation not in REPRESENTATIONS:
            raise InputError(f"model representation {self.representation!r} is not one of {', '.join(REPRESENTATIONS)}")
        if not all(isinstance(c, str) and c for c in self.classes) or len(set(self.classes)) != len(self.classes):
            raise InputError("model classes must be distinct, non-empty names; retrain the model")
        if isinstance(self.rate, bool) or not isinstance(self.rate, (int, float, np.number)) or \
                not MIN_RATE <= self.rate <= MAX_RATE:
            raise InputError(f"model rate {self.rate!r} is not a sampling rate from {MIN_RATE:g} to {MAX_RATE:g} Hz; "
                             "retrain the model")
        for name in ("scale", "dictionary"):
            if not np.isfinite(getattr(self, name)).all():
                raise InputError(f"model {name} holds values that are not finite (NaN or infinite); retrain the model")
        d = representation_size(len(self.channels), self.window, self.representation)
        if self.representation == "summary":
            self.feature_offset = np.zeros(d) if self.feature_offset is None else np.asarray(self.feature_offset, float)
            self.feature_scale = np.ones(d) if self.feature_scale is None else np.asarray(self.feature_scale, float)
            if self.feature_offset.shape != (d,) or self.feature_scale.shape != (d,) or \
                    not np.all(np.isfinite(self.feature_scale) & (self.feature_scale > 0)):
                raise InputError(f"model feature_offset and feature_scale must hold {d} finite values (scale > 0)")
        if self.dictionary.ndim != 2 or self.dictionary.shape[0] != d:
            raise InputError(f"model dictionary must have {d} rows ({self.representation} of channels x window), has "
                             f"{self.dictionary.shape}")
        if self.column_class.shape != (self.dictionary.shape[1],):
            raise InputError("model column_class must give one class per dictionary column")
        if self.scale.shape != (len(self.channels),):
            raise InputError("model scale must give one scale per channel")
        if len(self.column_class) and not 0 <= self.column_class.min() <= self.column_class.max() < len(self.classes):
            raise InputError("model column_class indexes a class that is not in classes")
        if (self.causal_dictionary is None) != (self.causal_column_class is None):
            raise InputError("model causal_dictionary and causal_column_class go together")
        if self.causal_dictionary is not None:
            self.causal_dictionary = np.asarray(self.causal_dictionary, dtype=float)
            self.causal_column_class = np.asarray(self.causal_column_class, dtype=int)
            if not np.isfinite(self.causal_dictionary).all():
                raise InputError("model causal_dictionary holds values that are not finite; retrain the model")
            if self.causal_dictionary.ndim != 2 or self.causal_dictionary.shape[0] != d or \
                    self.causal_column_class.shape != (self.causal_dictionary.shape[1],) or \
                    (len(self.causal_column_class) and not 0 <= self.causal_column_class.min()
                     <= self.causal_column_class.max() < len(self.classes)):
                raise InputError(f"model causal dictionary must have {d} rows and one class of classes per column")

    def columns(self, causal: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """``(dictionary, column_class)``: the causal columns when ``causal`` and the model has them."""
        if causal and self.causal_dictionary is not None:
            return self.causal_dictionary, self.causal_column_class
        return self.dictionary, self.column_class

    def inputs(self, windows: np.ndarray) -> np.ndarray:
        """The classifier's input rows ``(m, d)`` for windows ``(channels * window, m)`` already scaled and
        normalised (:func:`~spotfree.windows.recording_windows`): represented, standardised for ``summary``, with
        the constant row ``parameters["affine"]`` appended for ``hankel``."""
        if self.representation == "summary":
            return (represent(windows, len(self.channels), "summary") - self.feature_offset) / self.feature_scale
        windows = np.asarray(windows, dtype=float)
        affine = float(self.parameters.get("affine", 0.0))
        if affine:
            windows = np.vstack([windows, np.full((1, windows.shape[1]), affine)])
        return np.ascontiguousarray(windows.T)

    def metadata(self) -> dict:
        return {
            "schema_version": SCHEMA_VERSION,
            "classes": list(self.classes),
            "channels": list(self.channels),
            "rate": float(self.rate),
            "window": int(self.window),
            "step": int(self.step),
            "normalisation": self.normalisation,
            "representation": self.representation,
            "features": self.features,
            "feature_version": FEATURE_VERSION,
            "orientation": self.orientation,
            "parameters": self.parameters,
            "summary": self.summary,
        }

    def save(self, path: str | Path) -> None:
        """Write the model atomically: a failed write never leaves a half-written file at ``path``."""
        path = Path(path)
        if path.suffix != ".npz":
            raise InputError(f"{path}: a model file must end in .npz")
        with replacing(path, suffix=".tmp.npz") as tmp:
            causal = ({} if self.causal_dictionary is None else
                      {"causal_dictionary": self.causal_dictionary, "causal_column_class": self.causal_column_class})
            if self.representation == "summary":
                causal.update(feature_offset=self.feature_offset, feature_scale=self.feature_scale)
            np.savez_compressed(
                tmp,
                dictionary=self.dictionary,
                column_class=self.column_class,
                scale=self.scale,
                metadata=np.array(json.dumps(self.metadata(), sort_keys=True)),
                **causal,
            )

    @classmethod
    def load(cls, path: str | Path) -> "DictionaryModel":
        """Read a model file written by :meth:`save`; never unpickles."""
        path = Path(path)
        if not path.exists():
            raise InputError(f"{path}: no such model file; train one with 'spotfree train -o {path.name} ...'")
        check_model_file(path)
        try:
            with np.load(path, allow_pickle=False) as archive:
                meta = json.loads(str(archive["metadata"]))
                arrays = {k: archive[k] for k in ("dictionary", "column_class", "scale")}
                arrays.update({k: archive[k] for k in ("causal_dictionary", "causal_column_class", "feature_offset",
                                                       "feature_scale") if k in archive.files})
        except (OSError, ValueError, KeyError, json.JSONDecodeError) as exc:
            raise InputError(f"{path}: not a spotfree model file ({exc})") from None
        if meta.get("schema_version") not in READABLE_SCHEMAS:
            raise InputError(
                f"{path}: model schema version {meta.get('schema_version')} is not one of "
                f"{', '.join(map(str, READABLE_SCHEMAS))}; retrain it"
            )
        if meta.get("representation") == "summary" and meta["schema_version"] < 3:
            raise InputError(f"{path}: a summary model of schema {meta['schema_version']}, whose windows lack the "
                             "change of level and spread across them; retrain it with 'spotfree train'")
        version = meta.get("feature_version", 1)
        stale = [c for c in meta["channels"] if meta["features"] == "ride" and CHANNEL_CHANGED.get(c, 0) > version]
        if stale:
            changed = max(CHANNEL_CHANGED[c] for c in stale)
            raise InputError(f"{path}: trained on {', '.join(stale)} as computed before feature version {changed} "
                             f"({FEATURE_CHANGES[changed]}); retrain it with 'spotfree train'")
        try:
            return cls._from_file(meta, arrays)
        except InputError as exc:
            raise InputError(f"{path}: not a spotfree model file ({exc})") from None

    @classmethod
    def _from_file(cls, meta: dict, arrays: dict) -> "DictionaryModel":
        return cls(
            classes=meta["classes"],
            channels=meta["channels"],
            rate=meta["rate"],
            window=meta["window"],
            step=meta["step"],
            normalisation=meta["normalisation"],
            representation=meta.get("representation", "hankel"),
            features=meta["features"],
            orientation=meta["orientation"],
            parameters=meta["parameters"],
            summary=meta["summary"],
            **arrays,
        )


def check_model_file(path: Path) -> None:
    """Refuse (InputError, one line) a file that :meth:`DictionaryModel.load` should not read, before reading any
    array: not a zip archive, truncated or corrupt (every member is read once, in bounded chunks, and its CRC
    checked), a member that is not a NumPy array of numbers or text (object arrays would need unpickling), an
    array whose header declares more bytes than the member holds, arrays declaring more than
    :data:`MAX_MODEL_BYTES` in all (the sizes the zip directory and the array headers declare are checked
    before anything is decompressed), or metadata that is not the JSON object a model file holds."""
    where = f"{path}: not a spotfree model file"
    fix = "give the .npz that 'spotfree train' wrote, or train it again"
    try:
        with zipfile.ZipFile(path) as archive:
            members = archive.infolist()
            declared = sum(info.file_size for info in members)
            if declared > MAX_MODEL_BYTES:
                raise InputError(f"{where} (it declares {declared} bytes, more than {MAX_MODEL_BYTES}); {fix}")
            for info in members:
                with archive.open(info) as member:
                    _check_member(member, info, where, fix)
            if "metadata.npy" not in archive.namelist():
                raise InputError(f"{where} (no metadata); {fix}")
            with archive.open("metadata.npy") as member:
                meta = np.lib.format.read_array(member, allow_pickle=False)
    except InputError:
        raise
    except (zipfile.BadZipFile, zlib.error, EOFError, OSError, ValueError) as exc:
        reason = "truncated or corrupt" if not isinstance(exc, ValueError) else "unreadable array"
        raise InputError(f"{where} ({reason}); {fix}") from None
    try:
        meta = json.loads(str(meta))
    except (ValueError, RecursionError):  # not JSON, an integer of thousands of digits, nesting thousands deep
        meta = None
    if not isinstance(meta, dict):
        raise InputError(f"{where} (its metadata is not a JSON object); {fix}")
    for key, kind in _METADATA_TYPES.items():
        value = meta.get(key)
        if not isinstance(value, kind) or isinstance(value, bool):
            raise InputError(f"{where} (metadata field {key!r} is missing or not a {getattr(kind, '__name__', 'number')})"
                             f"; {fix}")
    if not all(isinstance(c, str) for c in meta["classes"] + meta["channels"]) or not meta["channels"] or \
            not (meta["window"] > 0 and meta["step"] > 0 and 0 < meta["rate"] < float("inf")):
        raise InputError(f"{where} (metadata classes, channels, rate, window or step out of range); {fix}")


def _check_member(member, info: zipfile.ZipInfo, where: str, fix: str) -> None:
    """One ``.npy`` member: its header read (bounded), its dtype plain, its declared size that of its data; then
    the rest read in chunks, so that a truncated or altered member fails its CRC here."""
    if not info.filename.endswith(".npy"):
        raise InputError(f"{where} (it holds {info.filename!r}, not an array); {fix}")
    version = np.lib.format.read_magic(member)
    readers = {(1, 0): np.lib.format.read_array_header_1_0, (2, 0): np.lib.format.read_array_header_2_0}
    if version not in readers:
        raise InputError(f"{where} ({info.filename}: NumPy format {version}); {fix}")
    shape, _, dtype = readers[version](member)
    if dtype.hasobject or dtype.kind not in "biufU":
        raise InputError(f"{where} ({info.filename} holds {dtype} values; a model holds numbers and text only); "
                         f"{fix}")
    size = dtype.itemsize
    for n in shape:
        size *= int(n)
    if size != info.file_size - member.tell():
        raise InputError(f"{where} ({info.filename} declares {size} bytes of data but holds "
                         f"{info.file_size - member.tell()}); {fix}")
    while member.read(1 << 20):
        pass
