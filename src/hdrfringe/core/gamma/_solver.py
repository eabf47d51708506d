"""Levenberg-Marquardt solver of the fringe gamma fit (thesis Sec. 2.6, Eq. 2.16-2.17).

Private machinery of :func:`hdrfringe.core.gamma.fit_gamma_fringes`. Unknowns: one global gamma
and, per pixel, the phase and (unless black/white captures fix them) a scale and one offset
per set or a single offset. Each damped Gauss-Newton step eliminates the small per-pixel
blocks by the Schur complement, as in bundle adjustment, so an iteration costs O(pixels) with
batched 3x3 / 4x4 solves. docs/gamma.md has the derivation.

Why not ``scipy.optimize.least_squares``: it offers no Schur elimination of per-pixel
blocks; with a sparse Jacobian (``jac_sparsity``, ``tr_solver="lsmr"``) it solves the same
problem (about 40 000 unknowns for 10 000 pixels) iteratively and inexactly, so its results
would differ from these beyond the tests' tolerances on the estimate and its standard error,
and it would be slower. The sandwich standard error clustered by pixel
(:func:`_gamma_stderr`) has no library counterpart either.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from hdrfringe.core.patterns import fringe_profile

__all__: list[str] = []

F64 = NDArray[np.float64]


@dataclass
class _Group:
    """Sets sharing the per-pixel phase: their samples at the chosen pixels, and the model.

    Per-pixel parameters (rows of a (P, M) array): phase, then, unless black/white are given,
    scale and one offset per set (``offset_per_set``) or a single offset.
    """

    y: F64  # (K, M) captured DN
    valid: F64  # (K, M) 1 for a usable sample, 0 for a clipped one
    delta: F64  # (K,) phase shift of each sample: pattern P(phi + delta)
    lo: F64  # (K,) imin / full
    amp: F64  # (K,) (migl - imin) / full
    inv_gh: F64  # (K,) 1 / gamma-hat of each sample's set
    pattern: list[str]  # (K,)
    set_of: NDArray[np.intp]  # (K,) index of each sample's set within the group
    offset_per_set: bool = True
    black: F64 | None = None  # (M,) black_white mode
    span: F64 | None = None  # (M,) white - black
    w: F64 = field(default_factory=lambda: np.zeros((0, 0)))  # (K, M) fit weights

    def __post_init__(self) -> None:
        if self.w.shape != self.y.shape:
            self.w = self.valid.copy()

    def take(self, keep: NDArray[np.bool_] | NDArray[np.intp]) -> _Group:
        return _Group(
            y=self.y[:, keep],
            valid=self.valid[:, keep],
            delta=self.delta,
            lo=self.lo,
            amp=self.amp,
            inv_gh=self.inv_gh,
            pattern=self.pattern,
            set_of=self.set_of,
            offset_per_set=self.offset_per_set,
            black=None if self.black is None else self.black[keep],
            span=None if self.span is None else self.span[keep],
            w=self.w[:, keep],
        )

    def pattern_value(self, phi: F64) -> tuple[F64, F64]:
        """Normalised linear pattern value h = g/full and dh/dphi, shape (K, M)."""
        arg = phi[None, :] + self.delta[:, None]
        h = np.empty_like(arg)
        dh = np.empty_like(arg)
        for kind in set(self.pattern):
            rows = np.array([p == kind for p in self.pattern])
            t = arg[rows] / (2 * np.pi)
            h[rows] = fringe_profile(t, kind)
            if kind == "sinusoidal":
                dh[rows] = -np.sin(arg[rows])
            else:  # triangular: 1 - 4|t - round(t)| has slope -4 sign(t - round(t)) per period
                dh[rows] = -4.0 * np.sign(t - np.round(t)) / (2 * np.pi)
        h = self.lo[:, None] + self.amp[:, None] * (1.0 + h) / 2.0
        dh = self.amp[:, None] * dh / 2.0
        return h, dh


def _basis(grp: _Group, phi: F64, gamma: float) -> tuple[F64, F64, F64, F64]:
    """f = x^gamma with x = h^(1/gamma-hat) the sent fraction; df/dphi, df/dgamma; and x."""
    h, dh = grp.pattern_value(phi)
    h = np.clip(h, 1e-9, 1.0)
    lnx = np.log(h) * grp.inv_gh[:, None]
    f = np.exp(gamma * lnx)
    f_phi = f * gamma * grp.inv_gh[:, None] * dh / h
    f_gamma = f * lnx
    return f, f_phi, f_gamma, np.exp(lnx)


def _offset_index(grp: _Group) -> NDArray[np.intp]:
    """Row of each sample's offset in the per-pixel parameters."""
    return 2 + (grp.set_of if grp.offset_per_set else np.zeros_like(grp.set_of))


def _offset_scale(grp: _Group, params: F64) -> tuple[F64, F64]:
    """Per-sample offset and scale (K, M) from the per-pixel parameters."""
    k = grp.y.shape[0]
    if grp.black is not None and grp.span is not None:
        m = grp.black.size
        return np.broadcast_to(grp.black, (k, m)), np.broadcast_to(grp.span, (k, m))
    return params[_offset_index(grp)], np.broadcast_to(params[1], (k, params.shape[1]))


def _residual(grp: _Group, params: F64, gamma: float) -> F64:
    """Model minus captured DN, (K, M)."""
    f = _basis(grp, params[0], gamma)[0]
    off, sc = _offset_scale(grp, params)
    return off + sc * f - grp.y


def _jacobians(grp: _Group, params: F64, gamma: float) -> tuple[F64, F64, F64]:
    """Weighted residual e (K, M), per-pixel Jacobian (M, K, P) and gamma column (K, M)."""
    f, f_phi, f_gamma, _ = _basis(grp, params[0], gamma)
    off, sc = _offset_scale(grp, params)
    sw = np.sqrt(grp.w)
    e = (off + sc * f - grp.y) * sw
    k, m = grp.y.shape
    p = params.shape[0]
    jac = np.zeros((m, k, p))
    jac[:, :, 0] = (sc * f_phi * sw).T
    if p > 1:
        jac[:, :, 1] = (f * sw).T
        for kk, row in enumerate(_offset_index(grp)):
            jac[:, kk, row] = sw[kk]
    return e, jac, sc * f_gamma * sw


def _cost(groups: list[_Group], params: list[F64], gamma: float) -> float:
    pairs = zip(groups, params, strict=True)
    return sum(float(np.sum(g.w * _residual(g, p, gamma) ** 2)) for g, p in pairs)


def _normal_blocks(grp: _Group, prm: F64, gamma: float) -> tuple[F64, F64, F64, F64, F64, F64]:
    """Per-pixel normal matrices U (M,P,P), couplings to gamma (M,P), gradients (M,P), etc."""
    e, jac, jg = _jacobians(grp, prm, gamma)
    u = np.einsum("mki,mkj->mij", jac, jac)
    wv = np.einsum("mki,km->mi", jac, jg)
    gl = np.einsum("mki,km->mi", jac, e)
    return e, jac, jg, u, wv, gl


def _lm_step(
    groups: list[_Group], params: list[F64], gamma: float, lam: float, fix_gamma: bool
) -> tuple[list[F64], float]:
    """One damped Gauss-Newton step; the per-pixel blocks are eliminated by the Schur complement.

    With ``J_p`` the per-pixel Jacobian and ``j`` the gamma column, the step solves
    ``[[U, w], [w^T, v]] [dp; dg] = -[g_p; g_g]`` with ``U = J_p^T J_p``, ``w = J_p^T j`` pixel
    by pixel: ``dg = -(g_g - sum w^T U^-1 g_p) / (v - sum w^T U^-1 w)``, then
    ``dp = -U^-1 (g_p + w dg)``. Marquardt damping scales the diagonals by ``1 + lam``.
    """
    blocks = []
    schur = 0.0
    rhs = 0.0
    for grp, prm in zip(groups, params, strict=True):
        e, _, jg, u, wv, gl = _normal_blocks(grp, prm, gamma)
        p = u.shape[1]
        diag = np.maximum(np.einsum("mii->mi", u), 1e-12)
        ud = u + lam * diag[:, :, None] * np.eye(p) + 1e-12 * np.eye(p)
        sol = np.linalg.solve(ud, np.stack([wv, gl], axis=2))  # (M, P, 2)
        uw, ug = sol[..., 0], sol[..., 1]
        schur += float(np.sum(jg * jg)) * (1 + lam) - float(np.sum(wv * uw))
        rhs += float(np.sum(jg * e)) - float(np.sum(wv * ug))
        blocks.append((uw, ug))
    dg = 0.0 if fix_gamma or schur <= 0 else -rhs / schur
    new = []
    for (uw, ug), prm in zip(blocks, params, strict=True):
        step = -(ug + uw * dg).T
        step[0] = np.clip(step[0], -0.5, 0.5)  # phase steps of at most ~30 degrees
        new.append(prm + step)
    return new, gamma + dg


def _levenberg_marquardt(
    groups: list[_Group], params: list[F64], gamma: float, *, fix_gamma: bool, max_iter: int
) -> tuple[list[F64], float, float]:
    """Damped Gauss-Newton iterations (:func:`_lm_step`); return parameters, gamma and cost.

    A step is taken when it does not raise the cost (the damping then falls five-fold), else
    the damping rises ten-fold; gamma stays in [0.05, 20]. Stops after ``max_iter`` steps, when
    gamma moves less than 1e-6 and the cost falls by at most 1e-9 of itself, or when the
    damping exceeds 1e8.
    """
    lam = 1e-3
    cost = _cost(groups, params, gamma)
    for _ in range(max_iter):
        new, g_new = _lm_step(groups, params, gamma, lam, fix_gamma)
        g_new = float(np.clip(g_new, 0.05, 20.0))
        c_new = _cost(groups, new, g_new)
        if np.isfinite(c_new) and c_new <= cost:
            done = abs(g_new - gamma) < 1e-6 and cost - c_new <= 1e-9 * cost
            params, gamma, cost = new, g_new, c_new
            lam = max(lam / 5, 1e-9)
            if done:
                break
        else:
            lam *= 10
            if lam > 1e8:
                break
    return params, gamma, cost


def _gamma_stderr(groups: list[_Group], params: list[F64], gamma: float) -> float:
    """Standard error of gamma: sandwich estimate, clustered by pixel, per-pixel blocks profiled.

    The gamma column with the per-pixel parameters projected out, ``j~ = j - J_p U^-1 w``, gives
    the Schur complement ``S = sum j~^2`` and, at the solution, ``gamma - gamma_true ~ -(1/S)
    sum_px sum_k j~ e``; summing the squared per-pixel terms allows for weights, noise that
    varies between pixels and errors correlated within a pixel.
    """
    s = 0.0
    meat = 0.0
    n_px = 0
    for grp, prm in zip(groups, params, strict=True):
        e, jac, jg, u, wv, _ = _normal_blocks(grp, prm, gamma)
        p = u.shape[1]
        uw = np.linalg.solve(u + 1e-12 * np.eye(p), wv[..., None])[..., 0]
        jt = jg - np.einsum("mkp,mp->km", jac, uw)
        s += float(np.sum(jt * jt))
        meat += float(np.sum(np.sum(jt * e, axis=0) ** 2))
        n_px += e.shape[1]
    if s <= 0 or n_px < 2:
        return math.nan
    return math.sqrt(meat * n_px / (n_px - 1)) / s


def _level_weights(groups: list[_Group], params: list[F64], gamma: float) -> None:
    """Weights making the samples uniform over the linear level ``u = (sent/full)^gamma``.

    ``u`` is the requested level (as a fraction of full scale) that pre-compensation with this
    gamma would send as the sample's gray. 32 equal bins; weight = 1/count, normalised to mean 1
    over the usable samples and capped at 20.
    """
    us = [_basis(g, p[0], gamma)[0] for g, p in zip(groups, params, strict=True)]
    edges = np.linspace(0.0, 1.0, 33)
    counts = np.zeros(32)
    for grp, u in zip(groups, us, strict=True):
        counts += np.histogram(u[grp.valid > 0], bins=edges)[0]
    dens = np.maximum(counts, 1.0)
    raw = []
    for grp, u in zip(groups, us, strict=True):
        b = np.clip(np.searchsorted(edges, u, side="right") - 1, 0, 31)
        raw.append(grp.valid / dens[b])
    n_valid = sum(float(g.valid.sum()) for g in groups)
    mean = sum(float(r.sum()) for r in raw) / max(n_valid, 1.0)
    for grp, r in zip(groups, raw, strict=True):
        grp.w = np.minimum(r / mean, 20.0)


def _init_params(grp: _Group, gamma: float) -> F64:
    """Phase from the samples' first Fourier component; scale and offsets by linear LS."""
    c = np.sum(grp.valid * grp.y * np.cos(grp.delta)[:, None], axis=0)
    s = -np.sum(grp.valid * grp.y * np.sin(grp.delta)[:, None], axis=0)
    phi = np.arctan2(s, c)
    if grp.black is not None:
        return phi[None, :]
    f = _basis(grp, phi, gamma)[0]
    oidx = _offset_index(grp)
    fc = np.zeros_like(f)
    yc = np.zeros_like(f)
    means = {}
    for row in np.unique(oidx):
        sel = oidx == row
        w = grp.valid[sel]
        sw = np.maximum(np.sum(w, axis=0), 1e-12)
        mf = np.sum(w * f[sel], axis=0) / sw
        my = np.sum(w * grp.y[sel], axis=0) / sw
        fc[sel] = f[sel] - mf
        yc[sel] = grp.y[sel] - my
        means[int(row)] = (mf, my)
    sxx = np.sum(grp.valid * fc * fc, axis=0)
    a = np.where(sxx > 0, np.sum(grp.valid * fc * yc, axis=0) / np.maximum(sxx, 1e-30), 0.0)
    rows = [phi, a] + [means[r][1] - a * means[r][0] for r in sorted(means)]
    return np.stack(rows)


def _solve(
    groups: list[_Group],
    gamma_init: float,
    *,
    level_weights: bool,
    keep_positive_scale: bool,
    rng: np.random.Generator,
) -> tuple[list[_Group], list[F64], float, float]:
    """Fit gamma and the per-pixel parameters; return the groups kept, parameters, gamma, stderr.

    Start: a coarse scan of gamma (``gamma_init`` and 1..4) on a subsample of 1500 pixels per
    group, per-pixel parameters refined at each trial value; then Levenberg-Marquardt with
    gamma fixed, then free. Pixels whose RMS residual exceeds the median plus 5 robust standard
    deviations (and, with ``keep_positive_scale``, those with a scale <= 0) are dropped once
    and the fit is repeated, with three rounds of level weights (:func:`_level_weights`) when
    ``level_weights``.
    """
    scan = [g.take(np.sort(rng.permutation(g.y.shape[1])[:1500])) for g in groups]
    best = (math.inf, float(gamma_init))
    for g0 in sorted({float(gamma_init), 1.0, 1.5, 2.0, 2.5, 3.0, 4.0}):
        trial = [_init_params(g, g0) for g in scan]
        c = _levenberg_marquardt(scan, trial, g0, fix_gamma=True, max_iter=15)[2]
        if c < best[0]:
            best = (c, g0)
    gamma = best[1]
    params = [_init_params(g, gamma) for g in groups]
    params, _, _ = _levenberg_marquardt(groups, params, gamma, fix_gamma=True, max_iter=20)
    params, gamma, _ = _levenberg_marquardt(groups, params, gamma, fix_gamma=False, max_iter=100)

    # drop outlier pixels once and refit
    groups = list(groups)
    for i, (grp, prm) in enumerate(zip(groups, params, strict=True)):
        r = _residual(grp, prm, gamma)
        rms_px = np.sqrt(np.sum(grp.valid * r * r, 0) / np.sum(grp.valid, 0))
        med = float(np.median(rms_px))
        mad = 1.4826 * float(np.median(np.abs(rms_px - med)))
        keep = rms_px <= med + 5 * max(mad, 1e-6 * max(med, 1e-9))
        if keep_positive_scale:
            keep &= prm[1] > 0
        groups[i] = grp.take(keep)
        params[i] = prm[:, keep]
    if level_weights:
        for _ in range(3):
            _level_weights(groups, params, gamma)
            params, gamma, _ = _levenberg_marquardt(
                groups, params, gamma, fix_gamma=False, max_iter=100
            )
    else:
        params, gamma, _ = _levenberg_marquardt(
            groups, params, gamma, fix_gamma=False, max_iter=100
        )
    return groups, params, gamma, _gamma_stderr(groups, params, gamma)
