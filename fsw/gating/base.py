"""The interface every gating network shares: consume bank records, produce filter weights.

A gating network sees one :class:`~fsw.filters.record.BankRecord` per measurement and keeps a
weight per filter. The weights sum to one over the *active* filters; a disabled filter
(``record.active`` False) has weight zero. Networks differ in when they produce new weights:
per measurement (Magill, mixture of experts, residual correlation) or per batch of M measurements
(the Lubey & Ely 2022 chi-square networks).

Rules shared by all networks (enforced here, so each network only writes its own equations):

* the record's filter names must be the network's, in the same order; arrays must have the
  shapes the record declares and be finite — otherwise :class:`GatingInputError`;
* parameters are a frozen config dataclass (``fsw.interface.typed.spec`` fields), validated on
  construction and by :meth:`GatingNetwork.validate_param` (which :meth:`GatingNetwork.set_param`
  calls before changing anything), raising :class:`UnknownParameterError` /
  :class:`InvalidParameterError`;
* when a filter is disabled its weight goes to zero and the others are renormalised; when it is
  enabled again it re-enters with the a-priori share 1/N_active and the others are scaled down to
  make room (:func:`reenter_probabilities`), so no network needs an infinite time to trust it.
"""

from __future__ import annotations

import dataclasses
import math
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Any, ClassVar, Sequence

import numpy as np

from fsw.filters.record import BankRecord
from fsw.interface import typed
from fsw.interface.frozen import fast_init
from fsw.kernels import on_first_call
from fsw.kernels.codes import RECORD_NEGATIVE_CHI2, RECORD_NON_FINITE

record_values_status = on_first_call(globals(), "record_values_status", "fsw.kernels.record_check")


class GatingError(ValueError):
    """Base class of every error a gating network raises on bad input or configuration."""


class GatingInputError(GatingError):
    """A bank record the network cannot use (wrong filters, shapes, or non-finite numbers)."""


class UnknownParameterError(GatingError, KeyError):
    """``set_param`` named a parameter the network does not have."""

    def __str__(self) -> str:  # KeyError would otherwise quote the message
        return str(self.args[0]) if self.args else ""


class InvalidParameterError(GatingError):
    """A parameter value outside its declared type or range, or inconsistent with the bank."""


@fast_init
@dataclass(frozen=True)
class WeightsUpdate:
    """New weights produced by a gating network.

    Attributes
    ----------
    network : registry name of the network (``"chi2"``, ...).
    t : time tag of the last measurement that went into these weights [s].
    seq : sequence number of that measurement.
    batch : 0-based index of the update (batch index for batch networks, update count otherwise).
    filters : filter names, bank order.
    weights : (N,) weight per filter, zero for disabled filters, summing to one.
    statistic : (N,) per-filter statistic behind the weights (e.g. G_k,i of Lubey & Ely 2022 eq. 6), or None.
    group_names, group_weights : hierarchical networks: bank names and top-level weights g_i.
    conditional_weights : hierarchical networks: (N,) in-bank weight g_{j|i} of each filter.
    """

    network: str
    t: float
    seq: int
    batch: int
    filters: tuple[str, ...]
    weights: np.ndarray
    statistic: np.ndarray | None = None
    group_names: tuple[str, ...] = ()
    group_weights: np.ndarray | None = None
    conditional_weights: np.ndarray | None = None

    def groups(self) -> dict[str, float]:
        """Top-level weight per bank (empty for single-level networks)."""
        if self.group_weights is None:
            return {}
        return {name: float(w) for name, w in zip(self.group_names, self.group_weights)}

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready form (lists of floats)."""
        out: dict[str, Any] = {
            "network": self.network,
            "t": float(self.t),
            "seq": int(self.seq),
            "batch": int(self.batch),
            "filters": list(self.filters),
            "weights": [float(w) for w in self.weights],
        }
        if self.statistic is not None:
            out["statistic"] = [float(s) for s in self.statistic]
        if self.group_weights is not None:
            out["groups"] = self.groups()
        if self.conditional_weights is not None:
            out["conditional_weights"] = [float(w) for w in self.conditional_weights]
        return out


def log_normalize(log_w: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Log-sum-exp normalisation over ``mask``; entries outside the mask become −inf."""
    if mask.ndim == 1 and False not in mask.tolist():
        # Every filter active (the usual case): no masking, the largest term found in Python.
        # exp, sum and log stay numpy's, so the result is the masked form's to the bit.
        top = max(log_w.tolist())
        terms = np.exp(log_w - top)
        # numpy adds up to three terms left to right from 0.0 (more: in its own order); written
        # out, not sum(): from Python 3.12 on, sum() of floats compensates its rounding
        if terms.size <= 3:
            total = 0.0
            for term in terms.tolist():
                total += term
        else:
            total = terms.sum()
        return log_w - (top + np.log(total))
    out = np.full(log_w.shape, -np.inf)
    if not np.any(mask):
        return out
    sub = log_w[mask]
    top = np.max(sub)
    out[mask] = sub - (top + np.log(np.sum(np.exp(sub - top))))
    return out


def apply_lower_bound(log_p: np.ndarray, mask: np.ndarray, lower_bound: float | None) -> np.ndarray:
    """Hanlon & Maybeck 2000 §II.B.2 "lower bounding of the conditional probabilities": raise every active
    probability below ``lower_bound`` to it, taking the excess proportionally from the others,
    so a hypothesis never becomes so improbable that it cannot win back quickly.

    ``log_p`` must be normalised over ``mask``. Works in the linear domain: every probability
    that could underflow there is below the bound and is replaced by it.
    """
    if lower_bound is None:
        return log_p
    n_active = int(np.count_nonzero(mask))
    if n_active == 0:
        return log_p
    bound = min(lower_bound, 1.0 / n_active)
    p = np.where(mask, np.exp(np.where(mask, log_p, 0.0)), 0.0)
    floored = mask & (p < bound)
    if not np.any(floored):
        return log_p
    # Scaling the free probabilities down can push another one under the bound: repeat.
    for _ in range(n_active):
        free = mask & ~floored
        scale = (1.0 - bound * np.count_nonzero(floored)) / np.sum(p[free]) if np.any(free) else 0.0
        newly = free & (p * scale < bound)
        if not np.any(newly):
            break
        floored |= newly
    out = np.full(log_p.shape, -np.inf)
    free = mask & ~floored
    out[floored] = np.log(bound)
    if np.any(free):
        scale = (1.0 - bound * np.count_nonzero(floored)) / np.sum(p[free])
        out[free] = np.log(p[free] * scale)
    return out


def reenter_probabilities(p: np.ndarray, old_mask: np.ndarray, new_mask: np.ndarray) -> np.ndarray:
    """Probability vector after the active set changes from ``old_mask`` to ``new_mask``.

    Disabled filters drop to 0 and the rest are renormalised; each newly enabled filter gets the
    a-priori share 1/N_active and the previously active ones keep their ratios in what is left.
    If no previously active filter survives, the result is the uniform a-priori vector.
    """
    p = np.where(new_mask, p, 0.0)
    kept = new_mask & old_mask
    entering = new_mask & ~old_mask
    n_active = int(np.count_nonzero(new_mask))
    out = np.zeros_like(p, dtype=float)
    if n_active == 0:
        return out
    total = float(np.sum(p[kept]))
    if not np.any(kept) or total <= 0.0:
        out[new_mask] = 1.0 / n_active
        return out
    share = 1.0 / n_active
    out[entering] = share
    out[kept] = p[kept] / total * (1.0 - share * np.count_nonzero(entering))
    return out


def _values_status(res: np.ndarray, S: np.ndarray, chi2: np.ndarray) -> int:
    """:func:`~fsw.kernels.record_check.record_values_status` of arrays of any dtype and layout:
    numbers (bool, integer, float) are copied to the kernel's writable C-ordered float64, anything
    else (strings, objects) counts as non-finite."""
    arrays = []
    for a in (res, S, chi2):
        if a.dtype.kind not in "biuf":
            return RECORD_NON_FINITE
        arrays.append(np.array(a, dtype=np.float64, order="C"))  # a copy: writable, as the signature wants
    return int(record_values_status(*arrays))


def check_record(record: BankRecord, filters: tuple[str, ...]) -> np.ndarray:
    """Validate a bank record for networks over ``filters``; return its active mask (N,) bool.

    The record's filter names must be ``filters`` in order, its arrays of the shapes it declares,
    finite, with non-negative chi-squares — otherwise :class:`GatingInputError`. Checked once per
    record and shared by every network of the bank (:meth:`GatingNetwork.update_checked`); the
    numbers are read in compiled code (:mod:`fsw.kernels.record_check`), arrays of another dtype
    or layout than the bank's converted first.
    """
    if not isinstance(record, BankRecord):
        raise GatingInputError(f"expected a BankRecord, got {type(record).__name__}")
    if record.filters is not filters and tuple(record.filters) != filters:
        raise GatingInputError(f"record filters {tuple(record.filters)!r} differ from the bank {filters!r}")
    n_f = len(filters)
    res, S, chi2, processed = record.residual, record.S, record.chi2, record.processed
    # the bank's own arrays as they are (np.asarray of an array is the array: only the type is tested)
    if type(res) is not np.ndarray:
        res = np.asarray(res)
    if res.ndim != 2 or res.shape[0] != n_f or res.shape[1] < 1:
        raise GatingInputError(f"residual must have shape ({n_f}, n), got {res.shape}")
    n = res.shape[1]
    if type(S) is not np.ndarray:
        S = np.asarray(S)
    if S.shape != (n_f, n, n):
        raise GatingInputError(f"S must have shape ({n_f}, {n}, {n}), got {S.shape}")
    if type(chi2) is not np.ndarray:
        chi2 = np.asarray(chi2)
    if type(processed) is not np.ndarray:
        processed = np.asarray(processed)
    if chi2.shape != (n_f,) or processed.shape != (n_f,):
        raise GatingInputError(f"chi2 and processed must have shape ({n_f},)")
    try:
        status = record_values_status(res, S, chi2)
    except TypeError:  # not C-ordered, writable float64 arrays (the bank makes no others): converted
        status = _values_status(res, S, chi2)
    if status == RECORD_NON_FINITE:
        raise GatingInputError(f"non-finite residual, S or chi2 in record seq={record.seq}")
    if status == RECORD_NEGATIVE_CHI2:
        raise GatingInputError(f"negative chi-square in record seq={record.seq}")
    if not math.isfinite(record.t):
        raise GatingInputError("non-finite time tag")
    mask = record.active_mask()
    if mask.shape != (n_f,):
        raise GatingInputError(f"active mask must have shape ({n_f},)")
    return mask


class GatingNetwork(ABC):
    """A gating network over a fixed, named bank of N filters.

    Subclasses set ``name`` (registry name) and ``params_type`` (their frozen config dataclass)
    and implement :meth:`_update`, :meth:`_reset` and :meth:`_weights`.
    """

    # slotted: see fsw.executive.FrameExecutive (a subclass declares its own slots too, or keeps a dict)
    __slots__ = ("filters", "params", "_active", "_updates", "_rejected")

    name: ClassVar[str] = ""
    params_type: ClassVar[type]

    def __init__(self, filter_names: Sequence[str], params: Any = None):
        names = tuple(str(n) for n in filter_names)
        if len(names) == 0:
            raise GatingError("a gating network needs at least one filter")
        if len(set(names)) != len(names):
            raise GatingError(f"duplicate filter names in {names!r}")
        self.filters: tuple[str, ...] = names
        self.params = self._validated(params if params is not None else self.params_type())
        self._active = np.ones(len(names), dtype=bool)
        self._updates = 0
        self._rejected = 0
        self.reset()

    # ------------------------------------------------------------------ parameters
    def _validated(self, params: Any) -> Any:
        if isinstance(params, dict):
            try:
                params = typed.decode(self.params_type, params)
            except typed.DecodeError as exc:
                raise InvalidParameterError(str(exc)) from None
        if not isinstance(params, self.params_type):
            raise InvalidParameterError(
                f"{self.name}: parameters must be {self.params_type.__name__}, got {type(params).__name__}"
            )
        try:
            # Round trip through the declaration: enforces types, ranges and shapes even for
            # instances built directly in code.
            params = typed.decode(self.params_type, typed.encode(params))
        except typed.DecodeError as exc:
            raise InvalidParameterError(f"{self.name}: {exc}") from None
        self._check_params(params)
        return params

    def _check_params(self, params: Any) -> None:
        """Cross-field and bank-dependent checks; raise :class:`InvalidParameterError`."""

    def validate_param(self, name: str, value: Any) -> Any:
        """The parameters ``set_param(name, value)`` would install, checked completely (types,
        ranges, cross-field and bank-dependent rules); the network is not changed.

        Raises :class:`UnknownParameterError` for a name the network does not have and
        :class:`InvalidParameterError` for a value outside its declaration.
        """
        known = {f.name for f in dataclasses.fields(self.params_type)}
        if name not in known:
            raise UnknownParameterError(
                f"{self.name} has no parameter {name!r}; known: {', '.join(sorted(known))}"
            )
        data = typed.encode(self.params)
        data[name] = value.tolist() if isinstance(value, np.ndarray) else value
        try:
            new = typed.decode(self.params_type, data)
        except typed.DecodeError as exc:
            raise InvalidParameterError(f"{self.name}.{name}: {exc}") from None
        return self._validated(new)

    def install_params(self, params: Any) -> None:
        """Install parameters checked by :meth:`validate_param`; take effect from the next update.

        Everything that can reject a value is in the validation, so a telecommand addressing
        several networks validates all of them before installing any."""
        new = self._validated(params)
        old = self.params
        self.params = new
        self._params_changed(old, new)

    def set_param(self, name: str, value: Any) -> None:
        """Change one parameter (telecommand ``set-param``): :meth:`validate_param`, then
        :meth:`install_params`. A rejected value changes nothing."""
        self.install_params(self.validate_param(name, value))

    def _params_changed(self, old: Any, new: Any) -> None:
        """Hook for networks whose state depends on a parameter (e.g. the memory matrix); must
        not reject anything :meth:`_check_params` accepted."""

    # ------------------------------------------------------------------ records
    def _check_record(self, record: BankRecord) -> np.ndarray:
        return check_record(record, self.filters)

    def update(self, record: BankRecord) -> WeightsUpdate | None:
        """Consume one record; return new weights when the network produces them, else None.

        Raises :class:`GatingInputError` (and counts the rejection) for a record it cannot use;
        the network state is then unchanged.
        """
        try:
            mask = self._check_record(record)
        except GatingInputError:
            self._rejected += 1
            raise
        return self.update_checked(record, mask)

    def update_checked(self, record: BankRecord, mask: np.ndarray) -> WeightsUpdate | None:
        """:meth:`update` of a record :func:`check_record` has already accepted for this bank,
        ``mask`` being what it returned: a core running several networks on one record checks
        it once, not once per network."""
        if mask.tobytes() != self._active.tobytes():  # both (N,) bool: cheaper than array_equal
            if not mask.any():
                self._rejected += 1
                raise GatingInputError("every filter of the bank is disabled")
            self._activation_changed(self._active.copy(), mask.copy())
            self._active = mask.copy()
        result = self._update(record, self._active)
        if result is not None:
            self._updates += 1
        return result

    def refuse(self) -> None:
        """Count a record refused for this network by a :func:`check_record` made on its behalf."""
        self._rejected += 1

    def _make_update(self, record: BankRecord, batch: int, weights: np.ndarray, **extra: Any) -> WeightsUpdate:
        return WeightsUpdate(
            network=self.name, t=float(record.t), seq=int(record.seq), batch=batch,
            filters=self.filters, weights=np.array(weights, dtype=float), **extra,
        )

    # ------------------------------------------------------------------ state
    @property
    def weights(self) -> np.ndarray:
        """Current weight per filter (N,), zero for disabled filters, summing to one."""
        return np.array(self._weights(), dtype=float)

    @property
    def active(self) -> np.ndarray:
        """Active mask the network is currently using (N,)."""
        return self._active.copy()

    def flush(self) -> WeightsUpdate | None:
        """End of a data arc: weights from evidence held back so far, or None.

        Per-measurement networks hold nothing back; batch networks close their partial batch."""
        return None

    def reset(self) -> None:
        """Return to the a-priori weights (telecommand ``reset-gating``, Lubey & Ely 2022 §3.2)."""
        self._reset()

    def state_dict(self) -> dict[str, Any]:
        """Status for telemetry and the ``status`` telecommand (JSON-ready)."""
        out = {
            "network": self.name,
            "filters": list(self.filters),
            "active": [bool(a) for a in self._active],
            "weights": [float(w) for w in self.weights],
            "params": typed.encode(self.params),
            "updates": self._updates,
            "rejected": self._rejected,
        }
        out.update(self._state_extra())
        return out

    def _state_extra(self) -> dict[str, Any]:
        return {}

    # ------------------------------------------------------------------ to implement
    @abstractmethod
    def _update(self, record: BankRecord, active: np.ndarray) -> WeightsUpdate | None:
        """Network equations for one validated record."""

    @abstractmethod
    def _reset(self) -> None:
        """Back to the a-priori state (all filters' shares equal over the active set)."""

    @abstractmethod
    def _weights(self) -> np.ndarray:
        """Current (N,) weights."""

    @abstractmethod
    def _activation_changed(self, old: np.ndarray, new: np.ndarray) -> None:
        """Adapt the internal state to a new active mask (see :func:`reenter_probabilities`)."""

