"""Filtering by piecewise polynomial approximation (PPA) and its baselines.

``ppa`` (the seed report's iterative knot algorithm), ``exact`` (the global optimum of its loss),
``butterworth`` (zero-phase Butterworth with Winter's residual cut-off, smoothing spline);
``chunks`` holds the shared pieces: exact chunk SSRs by QR updating, fits, the piecewise model.
"""
