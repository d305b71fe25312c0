"""Windows confined to stretches: label the samples of each stretch of a mask by windows that hold that stretch only.

A model trained on some stretches of its recordings alone (the rest left out, so that none of its windows spans the
cut) has never seen a window that holds samples from both sides of a cut. At run time the stretches come from
another classifier (the first stage of a cascade), and an ordinary window over the first samples of a stretch holds
samples of what came before it, unlike any window the model was trained on. Here every window is confined to the
stretch of the sample it labels: where the stretch does not yet fill a window, its first sample stands for the
samples before it (and, centred, its last sample for the samples after it). A stretch of ``n`` samples
``x_a .. x_{a+n-1}`` is labelled, with the alignment offset ``o`` of :func:`~spotfree.classify.batch.alignment_offset`
(0 causal, ``L // 2`` centred), from the windows of

    x_a (L - 1 - o times), x_a, ..., x_{a+n-1}, x_{a+n-1} (o times)

taken every ``step`` samples as :func:`~spotfree.classify.batch.classify_recording` takes them, each labelling the
sample it is aligned with, so that every sample of the stretch has a label. A causal label still reads no sample
after the one it labels, nor any before its stretch: the label of a sample depends on the samples of its stretch up
to it, and on where the stretch started.

:func:`classify_stretches` labels a whole Recording; :class:`StretchClassifier` does it sample by sample (causal),
with the same labels.
"""

from __future__ import annotations

import numpy as np

from spotfree.classify.batch import alignment_offset, dictionary_classifier
from spotfree.classify.stream import RideClassifier
from spotfree.errors import InputError
from spotfree.io.checks import true_runs
from spotfree.io.recording import Recording
from spotfree.model import DictionaryModel
from spotfree.windows import block_hankel, normalise_columns


def padded_stretch(x: np.ndarray, length: int, offset: int) -> np.ndarray:
    """The samples ``x`` ``(n, c)`` of one stretch with its first row repeated ``length - 1 - offset`` times before
    them and its last row ``offset`` times after them (module docstring): ``n`` windows of ``length`` samples."""
    if not 0 <= offset < length:
        raise InputError(f"alignment offset {offset} must lie in 0..{length - 1} for windows of {length} samples")
    return np.vstack([np.repeat(x[:1], length - 1 - offset, axis=0), x, np.repeat(x[-1:], offset, axis=0)])


def classify_stretches(model: DictionaryModel, rec: Recording, keep: np.ndarray, centred: bool = False,
                       classifier=None) -> np.ndarray:
    """One label per sample of ``rec`` (a Recording of the model's channels): the samples of every stretch of
    ``keep`` (consecutive True samples within one gap-free segment of one experiment, all finite) labelled by windows
    confined to it (module docstring), ``""`` elsewhere. ``classifier``: fitted by
    :func:`~spotfree.classify.batch.dictionary_classifier` (the causal columns unless ``centred``; fitted here when
    None)."""
    keep = np.asarray(keep, dtype=bool)
    if keep.shape != (len(rec),):
        raise InputError(f"the stretch mask has {keep.shape} values for {len(rec)} samples; give one per sample")
    clf = classifier if classifier is not None else dictionary_classifier(model, causal=not centred)
    offset = alignment_offset(model, centred)
    x = rec.array(tuple(model.channels)) / model.scale
    blocks, targets = [], []
    for start, stop in rec.segments():
        for a, b in true_runs(keep[start:stop]):
            a, b = start + a, start + b
            if not np.isfinite(x[a:b]).all():
                raise InputError(f"{rec.source}: a stretch to classify holds samples that are not finite "
                                 f"(samples {a}..{b - 1}); leave them out of the mask")
            blocks.append(block_hankel(padded_stretch(x[a:b], model.window, offset), model.window, model.step))
            targets.append((a, b, len(blocks[-1].T)))
    label = np.full(len(rec), "", dtype=object)
    if not blocks:
        return label
    windows = normalise_columns(np.hstack(blocks), model.normalisation)
    predicted = np.asarray(clf.predict(model.inputs(windows))).astype(str)
    first = 0
    for a, b, count in targets:
        label[a:b] = predicted[first + np.arange(b - a) // model.step]
        first += count
    return label


class StretchClassifier:
    """Causal :func:`classify_stretches` one sample at a time: :meth:`update` with the model's channels and whether
    the sample belongs to a stretch gives that sample's label (``""`` outside a stretch).

    A stretch starts at a sample inside it after one outside (or after :meth:`reset`): the model's window then
    starts afresh, filled with that sample's ``window - 1`` copies before it.
    """

    def __init__(self, model: DictionaryModel, classifier=None):
        self.model = model
        self._stream = RideClassifier(model, classifier=classifier)
        self.reset()

    def reset(self) -> None:
        """The next sample inside a stretch starts a new one."""
        self._inside = False

    def update(self, x, inside: bool) -> str:
        """The label of this sample (``x``: the model's channels, in ``model.channels`` order and units, finite when
        ``inside``)."""
        if not inside:
            self._inside = False
            return ""
        x = np.asarray(x, dtype=float)
        if not np.isfinite(x).all():
            raise InputError("a sample inside a stretch to classify is not finite; leave it out of the stretch")
        if not self._inside:
            self._stream.reset()
            for _ in range(self.model.window - 1):
                self._stream.update_features(x)
            self._inside = True
        return self._stream.update_features(x) or ""
