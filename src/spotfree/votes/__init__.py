"""Offline votes on a model's label stream: the segment vote, the event vote and the event edges.

They see a whole stretch of a ride, so they are for offline labelling, not for a live stream: the algorithms in
:mod:`~spotfree.votes.segments`, their options per model, checked, run and stored in a model file in
:mod:`~spotfree.votes.options`.
"""

from spotfree.votes.options import Votes, apply_votes, stored_votes, voted_labels, voted_models, with_votes

__all__ = ["Votes", "apply_votes", "stored_votes", "voted_labels", "voted_models", "with_votes"]
