"""Hand posture and gesture data for steering a power wheelchair: the tracking service's frames
(:mod:`~spotfree.hand.frames`), logs of them (:mod:`~spotfree.hand.log`), the live client
(:mod:`~spotfree.hand.live`) and the feature channels (:mod:`~spotfree.hand.features`).
"""
