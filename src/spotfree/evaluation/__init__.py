"""The paper's experiments (section V) on the simulator: protocol, measurements, scores, figures and report.

``spotfree.evaluate.evaluate`` runs them all and writes the report folder; the modules here hold the parts:
:mod:`~spotfree.evaluation.protocol` (what is simulated, trained on and tested), :mod:`~spotfree.evaluation.measure`
(the timed runs of spotfree's classifiers and the peers), :mod:`~spotfree.evaluation.metrics` (per-sample scores),
:mod:`~spotfree.evaluation.figures` and :mod:`~spotfree.evaluation.report`.
"""
