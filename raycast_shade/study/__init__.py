"""Truth and judgement: exact images of analytic surfaces, plain-NumPy twins of the kernels,
error metrics, the failure-case catalogue and the diagnosis of a student's renderer. Oracles:
:func:`raycast_shade.render` does not use them (its features are in :mod:`raycast_shade.insight`)."""
