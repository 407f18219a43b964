"""Genetic-algorithm tuning of a filter bank on a post-processed measurement set (Chaer et al. 1997
§VII–VIII, Fig. 14).

The population *is* the bank: each of its P filters is a binary string, the concatenation of one
l-bit string per unknown parameter. A string's integer I maps to M in the search interval [a, b]
by eq. 33,

    M = (b − a) / (2^l − 1) · I + a,

(most significant bit first). Each generation the whole measurement set is processed by the bank
and the gating network; a filter's fitness is its gating weight after the last measurement.
The next generation is made (Goldberg 1989, as §VIII describes it) by

1. fitness-proportionate (roulette-wheel) selection of two parents,
2. single-point crossover at a boundary between two parameters' strings (probability p_c),
3. bit-flip mutation after crossover (probability p_m per bit),

with the best string of the generation copied unchanged (elitism). The loop stops when every
filter of non-negligible weight agrees with the others within ε in every component (§VIII:
ε = 2), or after the maximum number of iterations (30). A lone filter of non-negligible weight
agrees with itself trivially; the rule asks for a cluster of at least ``min_cluster`` filters, as
Fig. 15's clustering shows.

p_c, p_m, "non-negligible" and the cluster size are not given by the paper; the defaults here
(0.9, 0.02, 1 %, 2) are ours and are named in the results.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

#: fitness of a population: (P, n_params) parameter vectors → (P,) non-negative fitness
Fitness = Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True)
class Coding:
    """Binary coding of ``n_params`` parameters, ``bits`` each, on [lower, upper] (Chaer et al. 1997 eq. 33)."""

    lower: float = 1.0
    upper: float = 50.0
    bits: int = 10
    n_params: int = 4

    def __post_init__(self) -> None:
        if not (np.isfinite(self.lower) and np.isfinite(self.upper) and self.upper > self.lower):
            raise ValueError(f"the search interval must be finite with upper > lower, got [{self.lower}, {self.upper}]")
        if not 1 <= self.bits <= 52:  # integers up to 2^52 are exact in a double
            raise ValueError(f"bits per parameter must be 1..52, got {self.bits}")
        if self.n_params < 1:
            raise ValueError("need at least one parameter")

    @property
    def length(self) -> int:
        return self.bits * self.n_params

    @property
    def step(self) -> float:
        """(b − a) / (2^l − 1): the resolution of eq. 33."""
        return (self.upper - self.lower) / (2 ** self.bits - 1)

    def integers(self, strings: np.ndarray) -> np.ndarray:
        """(..., n_params) integers I of (..., length) bit strings, most significant bit first."""
        s = np.asarray(strings)
        if s.shape[-1] != self.length:
            raise ValueError(f"strings must have {self.length} bits, got {s.shape[-1]}")
        weights = 2 ** np.arange(self.bits - 1, -1, -1, dtype=np.int64)
        return (s.reshape(*s.shape[:-1], self.n_params, self.bits).astype(np.int64) * weights).sum(axis=-1)

    def decode(self, strings: np.ndarray) -> np.ndarray:
        """(..., n_params) real parameters of bit strings by eq. 33."""
        return self.step * self.integers(strings) + self.lower

    def encode(self, values: np.ndarray) -> np.ndarray:
        """The strings whose eq. 33 values are nearest to ``values`` (clipped to [lower, upper])."""
        v = np.clip(np.asarray(values, dtype=float), self.lower, self.upper)
        ints = np.rint((v - self.lower) / self.step).astype(np.int64)
        shifts = np.arange(self.bits - 1, -1, -1, dtype=np.int64)
        bits = (ints[..., None] >> shifts) & 1
        return bits.reshape(*ints.shape[:-1], self.length).astype(bool)

    def boundaries(self) -> np.ndarray:
        """Crossover points between parameters' strings (bit indices 1·l … (n−1)·l)."""
        return self.bits * np.arange(1, self.n_params)


@dataclass(frozen=True)
class GaSettings:
    population: int = 20
    crossover_probability: float = 0.9
    mutation_probability: float = 0.02
    epsilon: float = 2.0
    max_iterations: int = 30
    negligible_weight: float = 0.01
    min_cluster: int = 2

    def __post_init__(self) -> None:
        if self.population < 2:
            raise ValueError("the population needs at least 2 filters")
        for name in ("crossover_probability", "mutation_probability"):
            p = getattr(self, name)
            if not 0.0 <= p <= 1.0:
                raise ValueError(f"{name} must be in [0, 1], got {p}")
        if not self.epsilon > 0.0:
            raise ValueError("epsilon must be positive")
        if self.max_iterations < 1:
            raise ValueError("max_iterations must be at least 1")
        if not 1 <= self.min_cluster <= self.population:
            raise ValueError("min_cluster must be between 1 and the population")
        if not 0.0 <= self.negligible_weight < 1.0:
            raise ValueError("negligible_weight must be in [0, 1)")


@dataclass
class Generation:
    """One iteration: the bank it processed and the fitness (gating weights) it earned."""

    iteration: int  # 1-based, as Chaer et al. 1997 counts ("18th iteration")
    strings: np.ndarray  # (P, length) bool
    params: np.ndarray  # (P, n_params)
    fitness: np.ndarray  # (P,)
    spread: np.ndarray  # (n_params,) max − min over the non-negligible filters
    converged: bool

    @property
    def best(self) -> np.ndarray:
        return self.params[int(np.argmax(self.fitness))]

    def as_dict(self) -> dict:
        return {"iteration": self.iteration, "params": self.params.round(4).tolist(),
                "fitness": self.fitness.round(6).tolist(), "best": self.best.round(4).tolist(),
                "spread": self.spread.round(4).tolist(), "converged": self.converged}


@dataclass
class GaResult:
    coding: Coding
    settings: GaSettings
    generations: list[Generation] = field(default_factory=list)

    @property
    def converged(self) -> bool:
        return bool(self.generations) and self.generations[-1].converged

    @property
    def final(self) -> Generation:
        return self.generations[-1]


def roulette(fitness: np.ndarray, rng: np.random.Generator, size: int) -> np.ndarray:
    """Indices drawn with probability proportional to fitness (uniform if all fitness is zero)."""
    f = np.clip(np.asarray(fitness, dtype=float), 0.0, None)
    total = f.sum()
    p = f / total if total > 0.0 and np.isfinite(total) else np.full(len(f), 1.0 / len(f))
    return rng.choice(len(f), size=size, p=p)


def crossover(a: np.ndarray, b: np.ndarray, coding: Coding, rng: np.random.Generator,
              probability: float) -> tuple[np.ndarray, np.ndarray]:
    """Single-point crossover at a parameter boundary (Chaer et al. 1997 §VIII): the children swap
    whole parameters, never split one parameter's bits."""
    if coding.n_params < 2 or rng.random() >= probability:
        return a.copy(), b.copy()
    cut = int(rng.choice(coding.boundaries()))
    return np.concatenate((a[:cut], b[cut:])), np.concatenate((b[:cut], a[cut:]))


def mutate(s: np.ndarray, rng: np.random.Generator, probability: float) -> np.ndarray:
    """Flip each bit with the given probability."""
    return s ^ (rng.random(s.shape) < probability)


def spread(params: np.ndarray, fitness: np.ndarray, negligible: float) -> np.ndarray:
    """Per component, max − min over the filters whose weight is above ``negligible``."""
    keep = np.asarray(fitness) > negligible
    if not keep.any():
        keep = np.asarray(fitness) >= np.max(fitness)
    sel = np.asarray(params)[keep]
    return sel.max(axis=0) - sel.min(axis=0)


def next_generation(strings: np.ndarray, fitness: np.ndarray, coding: Coding, settings: GaSettings,
                    rng: np.random.Generator) -> np.ndarray:
    """Selection, crossover at parameter boundaries, mutation; the best string is kept (elitism)."""
    P = len(strings)
    out = [strings[int(np.argmax(fitness))].copy()]
    while len(out) < P:
        i, j = roulette(fitness, rng, 2)
        for child in crossover(strings[i], strings[j], coding, rng, settings.crossover_probability):
            if len(out) < P:
                out.append(mutate(child, rng, settings.mutation_probability))
    return np.array(out, dtype=bool)


def run_ga(fitness: Fitness, coding: Coding, settings: GaSettings, rng: np.random.Generator,
           on_generation: Callable[[Generation], None] | None = None,
           initial: np.ndarray | None = None) -> GaResult:
    """Chaer et al. 1997 §VIII: random initial bank, then evaluate → test convergence → breed, until
    converged (spread ≤ ε in every component) or ``max_iterations`` banks have been evaluated."""
    strings = (rng.random((settings.population, coding.length)) < 0.5) if initial is None else np.asarray(initial, bool)
    if strings.shape != (settings.population, coding.length):
        raise ValueError(f"initial strings must be ({settings.population}, {coding.length})")
    result = GaResult(coding, settings)
    for it in range(1, settings.max_iterations + 1):
        params = coding.decode(strings)
        f = np.asarray(fitness(params), dtype=float)
        if f.shape != (settings.population,) or not np.all(np.isfinite(f)):
            raise ValueError("fitness must give one finite value per filter")
        sp = spread(params, f, settings.negligible_weight)
        cluster = int(np.sum(f > settings.negligible_weight))
        done = cluster >= settings.min_cluster and bool(np.all(sp <= settings.epsilon))
        gen = Generation(it, strings.copy(), params, f, sp, done)
        result.generations.append(gen)
        if on_generation is not None:
            on_generation(gen)
        if gen.converged:
            break
        strings = next_generation(strings, f, coding, settings, rng)
    return result
