"""Evaluation on the simulator: the paper's experiments (section V), the ride models, the hand, and the peers.

:func:`spotfree.evaluation.run.evaluate` (``spotfree evaluate``) runs them and writes the report folder; the modules
here hold the parts: :mod:`~spotfree.evaluation.protocol` (what is simulated, trained on and tested),
:mod:`~spotfree.evaluation.measure` (the timed runs of spotfree's classifiers and the peers),
:mod:`~spotfree.evaluation.peers` (the published classifiers spotfree is compared with; MiniRocket and ClaSP need
the ``eval`` extra), :mod:`~spotfree.evaluation.metrics` (per-sample scores), :mod:`~spotfree.evaluation.ride_models`
and :mod:`~spotfree.evaluation.lateral_road` (the braking, lateral and road models),
:mod:`~spotfree.evaluation.hand` (the hand recogniser), :mod:`~spotfree.evaluation.figures` and
:mod:`~spotfree.evaluation.report`.
"""
