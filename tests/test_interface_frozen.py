"""fsw/interface/frozen.py: a decorated frozen dataclass builds the very instance its dataclass
``__init__`` builds, refuses what it refuses, and stays frozen."""

from __future__ import annotations

import copy
import dataclasses
import pickle
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pytest

from fsw.executive.report import BudgetReportData
from fsw.executive.work import Job, JobError, Stage
from fsw.fdir.detector import AnomalyState
from fsw.filters.estimate import FilterEstimate, StateEstimate
from fsw.filters.record import BankRecord
from fsw.gating.base import WeightsUpdate
from fsw.interface import messages as m
from fsw.interface.examples import examples
from fsw.interface.frozen import DECORATED, fast_init
from fsw.transport.pubsub import Received

def _noop(ctx: object) -> None:
    pass


_STAGE = Stage("primary", _noop)


def _records() -> list[Any]:
    """An instance of every decorated class outside the ICD, every field set to its own value."""
    a = np.arange(3.0)
    return [
        BankRecord(1.0, 2, "doppler", ("a", "b", "c"), a[:, None], a[:, None, None], a, a > 0, a >= 0),
        BankRecord(1.0, 2, "range", ("a", "b", "c"), a[:, None], a[:, None, None], a, a > 0),
        Job(3.5, (_STAGE, _STAGE), "7", object()),
        Job(3.5, (_STAGE,)),
        BudgetReportData(4, 5.0, "cpu", 0.1, 0.2, 0.5, 1, 2, 3, 4, 5, 6.0, True),
        WeightsUpdate("chi2", 1.0, 3, 4, ("a", "b"), np.array([0.25, 0.75]), np.array([1.0, 2.0]), ("g",),
                      np.array([1.0])),
        WeightsUpdate("magill", 1.0, 3, 4, ("a", "b"), np.array([0.25, 0.75])),
        AnomalyState("chi2", 1.0, True, "dynamics", 0.9, 0.5, 0.75, None, 3.0, 2.0, {"a": 1.0}, {"b": 2.0}, {"c": 3.0}),
        AnomalyState("chi2", None, False, "none", 0.0, None, None, None, None, 2.0),
        StateEstimate("radio", 1.0, ("x", "y"), a[:2], np.eye(2)),
        FilterEstimate("radio", 1.0, ("x", "y"), a[:2], np.eye(2)),
        m.AuthTag("ab" * 16, "cd" * 32),  # examples() has no signed message
        Received("sim/measurements", b"{}", 7, "navbank.Measurement/v1", None, 3),
        Received("fsw/status", b"{}", 7, "", object(), None, "bad tag"),
    ]


def _nested(obj: Any) -> list[Any]:
    """``obj`` and the dataclass instances inside it (a message's stamp, a batch's samples)."""
    if dataclasses.is_dataclass(obj):
        return [obj] + [inner for value in _values(obj) for inner in _nested(value)]
    if isinstance(obj, (tuple, list)):
        return [inner for value in obj for inner in _nested(value)]
    return []


def _instances() -> list[Any]:
    found = _nested([msg for group in examples().values() for msg in group]) + _records()
    first: dict[type, Any] = {}
    for obj in found:  # one of each class, with every example of the classes examples() lists
        first.setdefault(type(obj), obj)
    return [obj for obj in found if obj is first[type(obj)] or type(obj).__name__ in examples()
            or type(obj).__module__ != m.__name__]


def _values(obj: Any) -> list[Any]:
    return [getattr(obj, f.name) for f in dataclasses.fields(obj)]


def _reference(cls: type, *args: Any, **kwargs: Any) -> Any:
    """What the dataclass-generated ``__init__`` builds from these arguments."""
    obj = object.__new__(cls)
    DECORATED[cls](obj, *args, **kwargs)
    return obj


def test_every_icd_message_and_every_per_measurement_record_is_decorated():
    icd = {cls for cls in vars(m).values()
           if isinstance(cls, type) and dataclasses.is_dataclass(cls) and cls.__module__ == m.__name__}
    assert icd <= set(DECORATED)
    records = {BankRecord, Job, BudgetReportData, WeightsUpdate, AnomalyState, StateEstimate, FilterEstimate, Received}
    assert records <= set(DECORATED)
    assert {type(obj) for obj in _instances()} == set(DECORATED)  # the cases below cover every one


@pytest.mark.parametrize("obj", _instances(), ids=lambda o: type(o).__name__)
def test_the_instance_is_the_one_the_dataclass_init_builds(obj):
    cls = type(obj)
    values = _values(obj)
    names = [f.name for f in dataclasses.fields(cls)]
    for built in (cls(*values), cls(**dict(zip(names, values)))):
        ref = _reference(cls, *values)
        assert type(built) is cls
        assert all(b is r for b, r in zip(_values(built), _values(ref)))
        if "__dict__" in dir(built):
            assert vars(built).keys() == vars(ref).keys()
    # the defaults and default factories where the arguments leave them out
    required = [f.name for f in dataclasses.fields(cls)
                if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING]
    if len(required) < len(names):
        given = {k: getattr(obj, k) for k in required}
        assert _outcome(lambda: cls(**given)) == _outcome(lambda: _reference(cls, **given))


def _outcome(build: Any) -> Any:
    """The fields built, or the error raised (type and message: __post_init__ may refuse)."""
    try:
        return _values(build())
    except Exception as exc:  # compared, not swallowed
        return type(exc), str(exc)


@pytest.mark.parametrize("cls", sorted(DECORATED, key=lambda c: c.__qualname__), ids=lambda c: c.__qualname__)
def test_argument_errors_are_the_dataclass_init_errors(cls):
    n = len(dataclasses.fields(cls))
    for args, kwargs in (((), {}), ((None,) * (n + 1), {}), ((None,) * n, {"not_a_field": 1})):
        with pytest.raises(TypeError):
            _reference(cls, *args, **kwargs)
        with pytest.raises(TypeError):
            cls(*args, **kwargs)


def test_post_init_still_refuses():
    with pytest.raises(ValueError, match="sigma components must be > 0"):
        m.Measurement(0, 1.0, m.Stamp(0, 0), "range", "DSS-14", (1.0,), (0.0,))
    with pytest.raises(ValueError, match="needs attitude_q"):
        m.Measurement(0, 1.0, m.Stamp(0, 0), "optical", "mars", (1.0, 2.0), (1.0, 1.0))
    with pytest.raises(JobError, match="non-empty tuple of stages"):
        Job(1.0, ())
    with pytest.raises(JobError, match="finite"):
        Job(float("nan"), (_STAGE,))


@pytest.mark.parametrize("obj", _instances(), ids=lambda o: type(o).__name__)
def test_still_frozen_and_still_copies(obj):
    with pytest.raises(dataclasses.FrozenInstanceError):
        setattr(obj, dataclasses.fields(obj)[0].name, None)
    for clone in (copy.deepcopy(obj), copy.copy(obj), dataclasses.replace(obj)):
        assert type(clone) is type(obj)
        assert len(_values(clone)) == len(_values(obj))
    if not any(isinstance(v, np.ndarray) or type(v) is object for v in _values(obj)):
        assert pickle.loads(pickle.dumps(obj)) == obj
        assert copy.deepcopy(obj) == obj


def test_default_factories_give_each_instance_its_own():
    a = AnomalyState("chi2", None, False, "none", 0.0, None, None, None, None, 2.0)
    b = AnomalyState("chi2", None, False, "none", 0.0, None, None, None, None, 2.0)
    assert a.evidence == {} and a.evidence is not b.evidence


def test_what_it_cannot_serve_exactly_is_refused_when_the_class_is_made():
    @dataclass
    class Mutable:
        a: int

    @dataclass(frozen=True)
    class Computed:
        a: int
        b: int = field(init=False, default=0)

    @dataclass(frozen=True, kw_only=True)
    class KeywordOnly:
        a: int

    class NotADataclass:
        pass

    for cls in (Mutable, Computed, KeywordOnly, NotADataclass):
        with pytest.raises(TypeError, match="fast_init"):
            fast_init(cls)


def test_subclass_fields_and_slots_are_served():
    @fast_init
    @dataclass(frozen=True, slots=True)
    class Base:
        a: int
        b: list = field(default_factory=list)

    @fast_init
    @dataclass(frozen=True, slots=True)
    class Derived(Base):
        c: str = "c"

    d = Derived(1, [2], "x")
    assert (d.a, d.b, d.c) == (1, [2], "x")
    assert Derived(1) == Derived(1, [], "c")
    assert Derived.__init__.__qualname__.endswith("Derived.__init__")


def test_fields_named_like_the_generated_code_s_own_names():
    @fast_init
    @dataclass(frozen=True)
    class Named:  # no slots: stored in the instance dictionary
        self: int
        d: int
        _MISSING: int = 3
        _default0: list = field(default_factory=list)

    @fast_init
    @dataclass(frozen=True, slots=True)
    class Slotted:
        self: int
        _set0: int = 5

    a = Named(1, 2)
    assert (a.self, a.d, a._MISSING, a._default0) == (1, 2, 3, [])
    assert Named(self=1, d=2, _MISSING=4, _default0=[5]) == Named(1, 2, 4, [5])
    assert (Slotted(7).self, Slotted(7)._set0, Slotted(self=7, _set0=8)._set0) == (7, 5, 8)
