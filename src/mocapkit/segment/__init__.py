"""Segmentation of motion into actions.

``features`` (limb-bone/spine partition angles, Tables 2–3 of the ARMA seed paper), ``arma`` (the
seed paper's ARMA segmenter), ``baselines`` (PCA, K-means, MLP, ruptures and claspy adapters),
``metrics`` (RI, F1 with margin, Covering). Every segmenter has the ``fit(X).predict()`` /
``fit_predict(X)`` shape of ruptures and claspy and returns sorted 0-based cut frames.
"""
