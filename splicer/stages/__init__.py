"""The splice's stages, in the order :func:`splicer.pipeline.splice` runs them.

``log`` (warnings, timings, progress) -> ``load`` -> ``rig`` (roles, up axes; the hands take
conditioned) -> ``markers`` -> ``align`` (pass 1, pass 2, confidence) -> ``transfer`` (time
map, fingers, finger sanity) -> ``crosscheck`` (the two hands) -> ``recheck`` (a noisy pair
aligned again, the better-matching maps kept) -> ``risk`` (every sign weighed into the error's
98th percentile) -> ``coverage`` (where the hands' material starts and stops)
-> ``report``.  Each stage is a function with a typed, frozen
result, usable on its own (notebooks, the Blender add-on, ``splice-markers``).
"""
