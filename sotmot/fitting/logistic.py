"""Logistic regression, the one fit of the package's learned models: the confirmation model
(:func:`fit_box_model`) and the lifted solver's pair costs (:mod:`sotmot.fitting.lifted`)."""

from __future__ import annotations

import numpy as np

from sotmot.confidence.box_model import BoxModel, logistic

def fit_logistic(x: np.ndarray, y: np.ndarray, weights: np.ndarray | None = None,
                 l2: float = 1000.0) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """Maximum-likelihood logistic regression of ``y`` (0 / 1) on ``x`` ``(N, F)``: the one fit of the package.

    The features are standardised (``(x - mean) / scale``) and their weights
    carry an L2 penalty ``l2`` (relative to the summed log-likelihood of the
    ``N`` samples); ``weights`` ``(N,)`` weigh the samples (default: all 1).
    Returns ``mean, scale, coef, intercept``: P(y = 1) = sigmoid(z @ coef + intercept).
    """
    from scipy.optimize import minimize

    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    n = len(y)
    sample = np.ones(n) if weights is None else np.asarray(weights, dtype=np.float64) * n / np.sum(weights)
    mean = x.mean(axis=0)
    scale = np.where(x.std(axis=0) > 1e-9, x.std(axis=0), 1.0)
    z = np.hstack([(x - mean) / scale, np.ones((n, 1))])

    def loss(w: np.ndarray) -> tuple[float, np.ndarray]:
        s = z @ w
        nll = sample * (np.logaddexp(0.0, s) - y * s)
        p = logistic(s)
        reg = 0.5 * l2 * float(w[:-1] @ w[:-1])
        grad = z.T @ (sample * (p - y)) / n
        grad[:-1] += l2 * w[:-1] / n
        return float(nll.mean()) + reg / n, grad

    w = minimize(loss, np.zeros(z.shape[1]), jac=True, method="L-BFGS-B").x
    return mean, scale, w[:-1], float(w[-1])



def fit_box_model(x: np.ndarray, y: np.ndarray, l2: float = 1000.0) -> BoxModel:
    """A :class:`~sotmot.confidence.box_model.BoxModel` by maximum-likelihood logistic regression with an L2 penalty
    ``l2`` on the standardised weights."""
    mean, scale, coef, intercept = fit_logistic(x, y, l2=l2)
    return BoxModel(tuple(mean.tolist()), tuple(scale.tolist()), tuple(coef.tolist()), intercept)
