"""PSO-initialised back-propagation network (seed 000 §2).

Inputs: the 6 joint angles and the target's 3 displacements from a reference point;
outputs: the 3 position errors. Two hidden layers of the same size; the initial weights
and biases are the best of a particle swarm searching the MSE (all particles evaluated at
once, batched), then back-propagation refines them. Seeded: the same data and seed give
the same network.
"""

from __future__ import annotations

import numpy as np
import torch
from sklearn.base import BaseEstimator, RegressorMixin, clone
from sklearn.model_selection import KFold


def _shapes(n_in: int, hidden: int, n_out: int):
    return [(n_in, hidden), (hidden,), (hidden, hidden), (hidden,), (hidden, n_out), (n_out,)]


def _unflatten(flat: torch.Tensor, shapes):
    """(P, D) particles -> list of (P, *shape) tensors."""
    out, pos = [], 0
    for s in shapes:
        size = int(np.prod(s))
        out.append(flat[:, pos : pos + size].reshape((flat.shape[0],) + s))
        pos += size
    return out


def _forward(params, x):
    """Batched MLP: params from _unflatten, x (N, n_in) -> (P, N, n_out)."""
    w1, b1, w2, b2, w3, b3 = params
    h = torch.tanh(torch.einsum("ni,pih->pnh", x, w1) + b1[:, None, :])
    h = torch.tanh(torch.einsum("pnh,phk->pnk", h, w2) + b2[:, None, :])
    return torch.einsum("pnh,pho->pno", h, w3) + b3[:, None, :]


class PSOBPPredictor(RegressorMixin, BaseEstimator):
    def __init__(self, hidden: int = 13, n_particles: int = 40, pso_iters: int = 60, epochs: int = 600, lr: float = 1e-2, random_state: int = 0,
                 large_n: int = 2000, batch_size: int = 256, validation_fraction: float = 0.1, patience: int = 20):
        self.large_n = large_n
        self.batch_size = batch_size
        self.validation_fraction = validation_fraction
        self.patience = patience
        self.hidden = hidden
        self.n_particles = n_particles
        self.pso_iters = pso_iters
        self.epochs = epochs
        self.lr = lr
        self.random_state = random_state

    def fit(self, X, y, progress=None):
        """Up to large_n poses: full-batch, as seed 000. Above: the swarm scores a subsample of
        large_n poses (memory: particles x poses x hidden), back-propagation runs on
        mini-batches and stops early when a held-out validation split stops improving
        (the best weights are kept). progress(done, total, message) once per epoch."""
        X = np.asarray(X, dtype=float)
        y = np.asarray(y, dtype=float)
        rng = np.random.default_rng(self.random_state)
        if len(X) > self.large_n:
            return self._fit_large(X, y, rng, progress)
        gen = torch.Generator().manual_seed(int(self.random_state))
        self.x_mean_, self.x_std_ = X.mean(axis=0), X.std(axis=0) + 1e-12
        self.y_mean_, self.y_std_ = y.mean(axis=0), y.std(axis=0) + 1e-12
        xt = torch.tensor((X - self.x_mean_) / self.x_std_, dtype=torch.float64)
        yt = torch.tensor((y - self.y_mean_) / self.y_std_, dtype=torch.float64)
        shapes = _shapes(X.shape[1], self.hidden, y.shape[1])
        dim = sum(int(np.prod(s)) for s in shapes)
        # Particle swarm over all weights and biases (fitness: MSE on the training set).
        # Particles start like Xavier-initialised networks: small outputs, near the mean.
        scale = np.concatenate([
            np.full(int(np.prod(s)), np.sqrt(6.0 / (s[0] + s[1])) if len(s) == 2 else 0.1) for s in shapes
        ])
        pos = torch.tensor(rng.uniform(-1.0, 1.0, (self.n_particles, dim)) * scale)
        vel = torch.zeros_like(pos)

        def fitness(p):
            with torch.no_grad():
                return ((_forward(_unflatten(p, shapes), xt) - yt) ** 2).mean(dim=(1, 2))

        f = fitness(pos)
        best_pos, best_f = pos.clone(), f.clone()
        g = int(torch.argmin(best_f))
        for _ in range(self.pso_iters):
            r1 = torch.rand(pos.shape, generator=gen, dtype=torch.float64)
            r2 = torch.rand(pos.shape, generator=gen, dtype=torch.float64)
            vel = 0.72 * vel + 1.49 * r1 * (best_pos - pos) + 1.49 * r2 * (best_pos[g] - pos)
            pos = pos + torch.maximum(torch.minimum(vel, torch.tensor(scale)), -torch.tensor(scale))
            f = fitness(pos)
            better = f < best_f
            best_pos[better], best_f[better] = pos[better], f[better]
            g = int(torch.argmin(best_f))
        self.pso_mse_ = float(best_f[g])
        # Back-propagation from the swarm's best.
        flat = best_pos[g : g + 1].clone().requires_grad_(True)
        opt = torch.optim.Adam([flat], lr=self.lr)
        for _ in range(self.epochs):
            opt.zero_grad()
            loss = ((_forward(_unflatten(flat, shapes), xt) - yt) ** 2).mean()
            loss.backward()
            opt.step()
        self.weights_ = flat.detach()[0].numpy().copy()
        self.shapes_ = shapes
        self.n_features_in_ = X.shape[1]
        return self

    def _fit_large(self, X, y, rng, progress):
        order = rng.permutation(len(X))
        n_val = max(int(self.validation_fraction * len(X)), 1)
        val, train = order[:n_val], order[n_val:]
        swarm = PSOBPPredictor(**{**self.get_params(), "epochs": 0}).fit(X[train[: self.large_n]], y[train[: self.large_n]])
        for key in ("x_mean_", "x_std_", "y_mean_", "y_std_", "shapes_", "pso_mse_"):
            setattr(self, key, getattr(swarm, key))
        # Standardise with the swarm's statistics, so its weights mean the same here.
        xt = torch.tensor((X - self.x_mean_) / self.x_std_, dtype=torch.float64)
        yt = torch.tensor((y - self.y_mean_) / self.y_std_, dtype=torch.float64)
        flat = torch.tensor(swarm.weights_[None]).requires_grad_(True)
        opt = torch.optim.Adam([flat], lr=self.lr)
        gen = torch.Generator().manual_seed(int(self.random_state))
        tr, va = torch.tensor(train), torch.tensor(val)
        best, best_loss, stale = flat.detach().clone(), np.inf, 0
        for epoch in range(self.epochs):
            for batch in tr[torch.randperm(len(tr), generator=gen)].split(self.batch_size):
                opt.zero_grad()
                loss = ((_forward(_unflatten(flat, self.shapes_), xt[batch]) - yt[batch]) ** 2).mean()
                loss.backward()
                opt.step()
            with torch.no_grad():
                val_loss = float(((_forward(_unflatten(flat, self.shapes_), xt[va]) - yt[va]) ** 2).mean())
            if val_loss < best_loss:
                best, best_loss, stale = flat.detach().clone(), val_loss, 0
            else:
                stale += 1
            if progress is not None:
                progress(epoch + 1, self.epochs, f"pso-bp epoch {epoch + 1}: validation MSE {val_loss:.4f} (best {best_loss:.4f})")
            if stale >= self.patience:
                break
        self.weights_ = best[0].numpy().copy()
        self.epochs_run_, self.val_mse_ = epoch + 1, best_loss
        self.n_features_in_ = X.shape[1]
        return self

    def predict(self, X):
        xt = torch.tensor((np.asarray(X, dtype=float) - self.x_mean_) / self.x_std_, dtype=torch.float64)
        with torch.no_grad():
            out = _forward(_unflatten(torch.tensor(self.weights_)[None], self.shapes_), xt)[0].numpy()
        return out * self.y_std_ + self.y_mean_


def hidden_size_table(X, y, sizes=(5, 7, 9, 11, 13, 15), folds: int = 5, threshold_mm: float = 0.11, random_state: int = 0, **params) -> list[dict]:
    """Seed 000 Table 1: cross-validated criteria per hidden-layer size.

    Per size: mean 3-D prediction error AE, MSE, the largest error, the share of errors
    above the threshold (the robot's repeatability) and their mean."""
    X = np.asarray(X, dtype=float)
    y = np.asarray(y, dtype=float)
    rows = []
    for size in sizes:
        errors = np.zeros(len(X))
        for train, test in KFold(folds, shuffle=True, random_state=random_state).split(X):
            model = clone(PSOBPPredictor(hidden=size, random_state=random_state, **params)).fit(X[train], y[train])
            errors[test] = np.linalg.norm(model.predict(X[test]) - y[test], axis=1)
        above = errors > threshold_mm
        rows.append({
            "hidden": size,
            "mean_mm": float(errors.mean()),
            "mse_mm2": float(np.mean(errors**2)),
            "max_mm": float(errors.max()),
            "above_threshold": float(above.mean()),
            "mean_above_mm": float(errors[above].mean()) if above.any() else 0.0,
        })
    return rows
