"""Peers of the spotting-free classifier for the evaluation: each labels every sample of a feature Recording.

* :class:`MiniRocketPeer`: aeon's MiniRocket + ridge, trained on windows labelled by the ground truth;
* :class:`NearestNeighbourPeer`: 1-NN on channel-scaled windows, trained the same way;
* :class:`ClaspPeer`: ClaSP unsupervised segmentation, its segments named afterwards.

All share :class:`~spotfree.evaluation.peers.base.Peer`: ``fit(recordings)``, ``predict(recording)`` -> labels
(``""`` where none), ``fit_time_`` and ``predict_time_`` in seconds. MiniRocket and ClaSP need aeon (``pip install
'spotfree[eval]'``), imported on first fit or predict.
"""

from spotfree.evaluation.peers.base import Peer
from spotfree.evaluation.peers.clasp import ClaspPeer
from spotfree.evaluation.peers.minirocket import MiniRocketPeer
from spotfree.evaluation.peers.neighbours import NearestNeighbourPeer

__all__ = ["ClaspPeer", "MiniRocketPeer", "NearestNeighbourPeer", "Peer"]
