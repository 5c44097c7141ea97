"""Minimizers of a robustness over the unit cube [0, 1]^d, by batches: `ask()` a batch of points, `tell(points, values)`.

Each is deterministic for its seed and the values it is told (a resumed search asks the same points again):
- uniform: independent uniform points (numpy's PCG64), the baseline every comparison is against;
- cmaes: CMA-ES (Hansen's `cma`), bounded to the cube, restarted with a doubled population (IPOP) when it stops;
- tpe: optuna's Tree-structured Parzen Estimator (multivariate; a batch is asked with the constant liar);
- neldermead: Nelder-Mead with restarts, its four candidate moves of a step (reflection, expansion, outside and
  inside contraction) asked as one batch, a shrink's d points as another; restarted from a random simplex when the
  simplex has collapsed.
"""

from __future__ import annotations

import numpy as np

NAMES = ("uniform", "cmaes", "tpe", "neldermead")


class Optimizer:
    batch: int
    independent = False  # its asks do not depend on what it was told: batches may be asked before earlier ones are told

    def ask(self) -> np.ndarray:  # (n, d) points of the unit cube
        raise NotImplementedError

    def tell(self, points: np.ndarray, values: list[float]) -> None:
        raise NotImplementedError


class UniformRandom(Optimizer):
    independent = True

    def __init__(self, dim: int, seed: int, batch: int | None = None) -> None:
        self.dim, self.batch = dim, batch or 4
        self.rng = np.random.default_rng(seed)

    def ask(self) -> np.ndarray:
        return self.rng.random((self.batch, self.dim))

    def tell(self, points, values) -> None:
        pass


class CmaEs(Optimizer):
    """sigma0 = 0.3 of the cube from its centre; cma's own bound handling; IPOP restarts (popsize doubled)."""

    def __init__(self, dim: int, seed: int, batch: int | None = None) -> None:
        self.dim = dim
        self.width = max(dim, 2)  # cma refuses one dimension: a second one is carried and ignored
        self.seed = seed
        self.popsize = batch or 4 + int(3 * np.log(self.width))
        self.batch = self.popsize
        self.restarts = 0
        self._start()

    def _start(self) -> None:
        import cma

        # cma takes a seed of 0 as "random": shift it; each restart its own stream
        options = {"bounds": [0.0, 1.0], "seed": self.seed * 1000 + self.restarts + 1, "popsize": self.popsize,
                   "verbose": -9, "verb_log": 0, "verb_disp": 0, "tolfun": 1e-11, "tolx": 1e-9}
        self.es = cma.CMAEvolutionStrategy([0.5] * self.width, 0.3, options)
        self._asked = None

    def ask(self) -> np.ndarray:
        if self.es.stop():
            self.restarts += 1
            self.popsize *= 2
            self.batch = self.popsize
            self._start()
        self._asked = [np.asarray(x, dtype=float) for x in self.es.ask()]
        return np.clip(np.array(self._asked)[:, :self.dim], 0.0, 1.0)

    def tell(self, points, values) -> None:
        self.es.tell(self._asked, [float(v) for v in values])


class Tpe(Optimizer):
    def __init__(self, dim: int, seed: int, batch: int | None = None) -> None:
        import optuna

        optuna.logging.set_verbosity(optuna.logging.WARNING)
        self.dim, self.batch = dim, batch or 4
        sampler = optuna.samplers.TPESampler(seed=seed, multivariate=True, constant_liar=True, n_startup_trials=10)
        self.study = optuna.create_study(direction="minimize", sampler=sampler)
        self.space = {f"u{i}": optuna.distributions.FloatDistribution(0.0, 1.0) for i in range(dim)}
        self._trials: list = []

    def ask(self) -> np.ndarray:
        self._trials = [self.study.ask(self.space) for _ in range(self.batch)]
        return np.array([[t.params[f"u{i}"] for i in range(self.dim)] for t in self._trials])

    def tell(self, points, values) -> None:
        for trial, v in zip(self._trials, values):
            self.study.tell(trial, float(v))


class NelderMead(Optimizer):
    """The standard coefficients (reflection 1, expansion 2, contractions 0.5, shrink 0.5) in the unit cube (points
    clipped); the first simplex and each restart's: a uniform point and d more at +-SIZE along each axis (towards the
    cube's inside). batch is ignored: a step asks 4 points, a shrink d, a (re)start d + 1."""

    SIZE = 0.25  # the (re)start simplex's edge, in units of the cube
    TOL = 1e-3  # restart when every vertex is this close to the best (a collapsed simplex)

    def __init__(self, dim: int, seed: int, batch: int | None = None) -> None:
        self.dim = dim
        self.rng = np.random.default_rng(seed)
        self.batch = max(4, dim + 1)  # the largest batch it asks
        self._restart()

    def _restart(self) -> None:
        x0 = self.rng.random(self.dim)
        vertices = [x0]
        for i in range(self.dim):
            v = x0.copy()
            v[i] += self.SIZE if x0[i] + self.SIZE <= 1.0 else -self.SIZE
            vertices.append(v)
        self.phase, self.pending = "start", np.array(vertices)
        self.simplex, self.values = None, None

    def ask(self) -> np.ndarray:
        if self.phase == "step":
            order = np.argsort(self.values, kind="stable")
            self.simplex, self.values = self.simplex[order], self.values[order]
            centroid = self.simplex[:-1].mean(axis=0)
            worst = self.simplex[-1]
            self.pending = np.clip(np.array([centroid + (centroid - worst), centroid + 2.0 * (centroid - worst),
                                             centroid + 0.5 * (centroid - worst), centroid - 0.5 * (centroid - worst)]),
                                   0.0, 1.0)
        return self.pending.copy()

    def tell(self, points, values) -> None:
        f = np.asarray(values, dtype=float)
        if self.phase == "start":
            self.simplex, self.values = np.array(points, dtype=float), f
        elif self.phase == "shrink":
            self.simplex[1:], self.values[1:] = np.array(points, dtype=float), f
        else:
            fr, fe, foc, fic = f
            best, second, worst = self.values[0], self.values[-2], self.values[-1]
            pick = None
            if fr < best:
                pick = 1 if fe < fr else 0
            elif fr < second:
                pick = 0
            elif fr < worst:
                pick = 2 if foc <= fr else None
            else:
                pick = 3 if fic < worst else None
            if pick is None:  # shrink towards the best vertex
                self.simplex[1:] = self.simplex[0] + 0.5 * (self.simplex[1:] - self.simplex[0])
                self.phase, self.pending = "shrink", self.simplex[1:].copy()
                return
            self.simplex[-1], self.values[-1] = self.pending[pick], f[pick]
        self.phase = "step"
        order = np.argsort(self.values, kind="stable")
        self.simplex, self.values = self.simplex[order], self.values[order]
        if np.max(np.abs(self.simplex[1:] - self.simplex[0])) < self.TOL:
            self._restart()


def make(name: str, dim: int, seed: int, batch: int | None = None) -> Optimizer:
    kinds = {"uniform": UniformRandom, "cmaes": CmaEs, "tpe": Tpe, "neldermead": NelderMead}
    if name not in kinds:
        raise ValueError(f"unknown optimizer {name} (one of {', '.join(NAMES)})")
    return kinds[name](dim, seed, batch)


def minimize(name: str, objective, dim: int, budget: int, seed: int = 0, batch: int | None = None) -> tuple[np.ndarray, list]:
    """Run an optimizer on a function of the unit cube for `budget` evaluations: (points, values) in the order asked."""
    opt = make(name, dim, seed, batch)
    points, values = [], []
    while len(values) < budget:
        asked = opt.ask()
        got = [float(objective(x)) for x in asked]
        opt.tell(asked, got)
        points.extend(asked)
        values.extend(got)
    return np.array(points[:budget]), values[:budget]
