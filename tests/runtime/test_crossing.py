"""The Python crossing in C (mbgen.runtime.crossing): the common case in C, all else as before.

An entry is made here with a spy as its fallback: the common case must never reach the
spy, and every other call -- each kind of misuse, keywords, a bad status -- must reach it
with the very arguments given.  The model's own entries fall back to the Python path, so
their errors (class and message) must be that path's.
"""

from __future__ import annotations

import gc
import threading
import weakref

import numpy as np
import pytest

import mbgen
from mbgen.errors import MbgenError
from mbgen.model.scene import load_scene
from mbgen.runtime import crossing
from models import pendulum

SPIED = object()


@pytest.fixture(scope="module")
def cart():
    """x (6,), p (with defaults), r (1,); a 2-D output (mass_matrix)."""
    return mbgen.compile(load_scene("n_link_cart", n=2), ("rhs", "mass_matrix"))


@pytest.fixture(scope="module")
def no_defaults():
    return mbgen.compile(pendulum("crossing_pendulum"), ("rhs",))


class Spy:
    def __init__(self):
        self.calls = []

    def __call__(self, *args, **kwargs):
        self.calls.append((args, kwargs))
        return SPIED


def spied(model, output="rhs", defaults=True):
    """A C entry of ``model``'s ``output`` whose fallback is a :class:`Spy`."""
    info = next(i for i in model.rendered.functions if i.output == output)
    spy = Spy()
    p = model.default_parameters.copy() if defaults and model.default_parameters is not None \
        else None
    r = np.zeros(model.n_r) if model.n_r else None
    entry = crossing.c_entry(model.module, info, spy, (model.n_x, model.n_p, model.n_r),
                             p, r)
    return entry, spy


def test_every_function_of_a_compiled_model_has_a_c_entry(cart):
    for output in ("rhs", "mass_matrix"):
        entry = cart._calls[mbgen.Output(output)]
        assert type(entry).__name__ == "mbgen_entry"
        assert entry.fallback is cart._python_calls[output]
    assert cart._rhs is cart._calls[mbgen.Output.RHS]


def test_common_case_is_c_and_matches_the_python_path(cart):
    entry, spy = spied(cart)
    mm, mm_spy = spied(cart, "mass_matrix")
    x = np.linspace(0.1, 0.6, cart.n_x)
    p = cart.default_parameters * 1.1
    r = np.array([0.7])
    python = cart._python_calls["rhs"]
    for args in ((0.5, x), (0.5, x, None), (0.5, x, p), (0.5, x, None, r), (0.5, x, p, r),
                 (0.5, x[::-1].copy(), p, None)):
        got = entry(*args)
        want = python(*(args + (None,) * (4 - len(args))))
        assert type(got) is np.ndarray and got.dtype == np.float64 and got.flags.c_contiguous
        assert got.tobytes() == want.tobytes()
    got = mm(0.5, x, p, r)
    want = cart._python_calls["mass_matrix"](0.5, x, p, r)
    assert got.shape == want.shape == (3, 3) and np.array_equal(got, want)
    assert entry(0.5, x) is not entry(0.5, x)
    read_only = x.copy()
    read_only.flags.writeable = False
    assert np.array_equal(entry(0.5, read_only), entry(0.5, x))
    assert spy.calls == [] and mm_spy.calls == []


def _misuses(model):
    x = np.linspace(0.1, 0.6, model.n_x)
    p = model.default_parameters.copy()

    class Sub(np.ndarray):
        pass

    wide = np.zeros(2 * model.n_x)
    wide[::2] = x
    return {
        "t int": (0, x), "t numpy float": (np.float64(0.0), x), "t str": ("0", x),
        "t None": (None, x), "t complex": (1j, x),
        "x list": (0.0, list(x)), "x float32": (0.0, x.astype(np.float32)),
        "x int": (0.0, np.arange(model.n_x)), "x short": (0.0, x[:-1].copy()),
        "x 2-D": (0.0, np.stack([x, x])), "x strided": (0.0, wide[::2]),
        "x byte-swapped": (0.0, x.astype(">f8")), "x subclass": (0.0, x.view(Sub)),
        "x by name": (0.0, dict(zip(model.state_names, x))), "x None": (0.0, None),
        "x NaN (status)": (0.0, np.full(model.n_x, np.nan)),
        "p list": (0.0, x, list(p)), "p float32": (0.0, x, p.astype(np.float32)),
        "p long": (0.0, x, np.append(p, 1.0)), "p by name": (0.0, x, dict(
            zip(model.parameter_names, p))), "p 2-D": (0.0, x, np.stack([p, p])),
        "r list": (0.0, x, None, [0.5]), "r long": (0.0, x, None, np.zeros(2)),
        "r int": (0.0, x, None, np.zeros(1, dtype=int)),
        "too few": (0.0,), "too many": (0.0, x, p, None, None),
    }


def test_every_misuse_reaches_the_fallback_with_its_own_arguments(cart):
    entry, spy = spied(cart)
    for what, args in _misuses(cart).items():
        spy.calls.clear()
        assert entry(*args) is SPIED, what
        assert len(spy.calls) == 1, what
        (got, kwargs), = spy.calls
        assert kwargs == {} and len(got) == len(args), what
        assert all(a is b for a, b in zip(got, args)), what
    x = np.zeros(cart.n_x)
    spy.calls.clear()
    assert entry(0.0, x, p=None) is SPIED and spy.calls == [((0.0, x), {"p": None})]


def test_no_default_parameters_falls_back(no_defaults):
    entry, spy = spied(no_defaults, defaults=False)
    x = np.array([0.5, 0.0])
    assert entry(0.0, x) is SPIED and entry(0.0, x, None) is SPIED
    assert len(spy.calls) == 2
    assert entry(0.0, x, np.array([1.0, 9.81, 1.0]))[1] == pytest.approx(-9.81 * np.sin(0.5))
    with pytest.raises(ValueError, match="no default for every parameter"):
        no_defaults.rhs(0.0, x)


def _outcome(fn, *args):
    try:
        value = fn(*args)
    except Exception as exc:
        return type(exc), str(exc)
    return "ok", np.asarray(value).tobytes()


def test_errors_are_those_of_the_python_path(cart):
    python = cart._python_calls["rhs"]
    for what, args in _misuses(cart).items():
        if what in ("too few", "too many"):
            continue  # the Python closure's arity errors name it, not the model's method
        padded = args + (None,) * (4 - len(args))
        assert _outcome(cart.rhs, *padded) == _outcome(python, *padded), what


def test_a_bad_status_raises_the_named_error(cart):
    x = np.zeros(cart.n_x)
    x[-1] = np.nan                               # a speed: the mass matrix is fine
    with pytest.raises(mbgen.errors.NonFiniteResultError, match="result is NaN or infinite"):
        cart.rhs(0.0, x)
    x = np.full(cart.n_x, np.nan)                # the pivots of M are NaN
    with pytest.raises(mbgen.errors.SingularMassMatrixError, match="not positive definite"):
        cart.rhs(0.0, x)


def test_defaults_stay_alive_with_the_entry(cart):
    entry, _ = spied(cart)
    gc.collect()
    x = np.linspace(0.1, 0.6, cart.n_x)
    for _ in range(3):
        junk = [np.full(cart.n_p, -1e300) for _ in range(100)]  # reuse freed blocks, if any
        del junk
        assert np.array_equal(entry(0.0, x), cart.rhs(0.0, x))


def test_a_model_with_entries_is_collected():
    model = mbgen.compile(load_scene("n_link_cart", n=2), ("rhs",))
    ref = weakref.ref(model)
    del model
    gc.collect()
    assert ref() is None  # the entry -> closure -> model cycle is the collector's


def test_bad_requests_are_refused(cart):
    info = cart.rendered.functions[0]
    with pytest.raises(MbgenError, match="default p"):
        crossing.c_entry(cart.module, info, Spy(), (cart.n_x, cart.n_p, cart.n_r),
                         np.zeros(cart.n_p + 1), None)
    with pytest.raises(MbgenError, match="C type"):
        other = type(info)(info.output, info.c_name, ("t", "x"), info.out_size, info.out_shape,
                           info.out_labels)
        crossing.c_entry(cart.module, other, Spy(), (cart.n_x, cart.n_p, cart.n_r),
                         None, None)


def test_gil_is_released_for_large_functions_only():
    header = " *   big_rhs: 5000 (9000 before CSE)\n *   small_rhs: 82 (90 before CSE)\n"
    assert crossing.releases_gil(header, "big_rhs")
    assert not crossing.releases_gil(header, "small_rhs")
    assert crossing.releases_gil(header, "unknown_rhs")  # as cffi's calls


@pytest.mark.parametrize("release", [False, True])
def test_threads_get_the_answers_of_one_thread(cart, release):
    info = cart.rendered.functions[0]
    entry = crossing.c_entry(cart.module, info, cart._python_calls["rhs"],
                             (cart.n_x, cart.n_p, cart.n_r), cart.default_parameters.copy(),
                             np.zeros(1), release=release)
    assert entry.release_gil == release
    xs = np.random.default_rng(0).uniform(-1, 1, (64, cart.n_x))
    want = [cart.rhs(0.0, x) for x in xs]
    bad = []

    def work():
        for _ in range(50):
            for x, w in zip(xs, want):
                if not np.array_equal(entry(0.0, x), w):
                    bad.append(x)

    threads = [threading.Thread(target=work) for _ in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not bad


def test_a_model_named_like_the_crossing_compiles():
    """The crossing's C names (``mbgen_*``, ``MBGEN_*``) live beside the model's header."""
    for name in ("mbgen", "mbgen_entry"):
        model = mbgen.compile(pendulum(name), ("rhs", "mass_matrix"))
        assert type(model._rhs).__name__ == "mbgen_entry"
        assert model.rhs(0.0, np.array([0.5, 0.0]), np.array([1.0, 9.81, 1.0]))[1] == \
            pytest.approx(-9.81 * np.sin(0.5))
