"""Truth and judgement: exact images of analytic surfaces, plain-NumPy twins of
the kernels, error metrics, and the automatic choice of shading method."""
