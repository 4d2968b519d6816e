"""Every difference quotient through the kit (issue 41 item 4): :mod:`vibdyn.solvers.differences` (plain functions)
and :mod:`vibdyn.model.fd` (the tangent space, built on it). A quotient written by hand elsewhere fails; the kit's
primitives agree with closed forms, and their estimates cover their actual errors."""

import ast
import math
from pathlib import Path

import numpy as np
import pytest

from vibdyn.model import fd
from vibdyn.solvers import differences as kit
from vibdyn.solvers.newton import fd_jacobian

PACKAGE = Path(__file__).resolve().parents[1] / "vibdyn"
KIT = {"solvers/differences.py", "model/fd.py"}
# names a difference step goes by in the package
STEP = {"h", "hk", "hv", "h0", "d", "dh", "eps", "step", "delta", "e"}
# (file, line text) -> why the quotient there is not a derivative of a function the kit should make
ALLOWED = {
    ("analysis/response/record_spectrum.py", "ak, slope = acc[ks], (acc[ks + 1] - acc[ks]) / h"):
        "the slope of the linear interpolation of a sampled record between two samples (the record is the data, "
        "not a function one can evaluate off its grid)",
}


def _step(node):
    """The step's name if ``node`` is a step (h, e[k], …)."""
    if isinstance(node, ast.Subscript):
        node = node.value
    return node.id if isinstance(node, ast.Name) and node.id in STEP else None


def _denominator(node):
    """(step name, kind) of a difference's denominator: h ("plain"), c·h ("scaled"), h² or h·h ("square"),
    b − a with a step in it ("span": x + h − max(x − h, 0))."""
    if name := _step(node):
        return name, "plain"
    if isinstance(node, ast.BinOp) and isinstance(node.op, (ast.Add, ast.Sub)):
        steps = [n.id for n in ast.walk(node) if isinstance(n, ast.Name) and n.id in STEP]
        return (steps[0], "span") if steps else (None, None)
    if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Pow) and isinstance(node.right, ast.Constant):
        return (_step(node.left), "square") if node.right.value == 2 and _step(node.left) else (None, None)
    if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Mult):
        a, b = node.left, node.right
        if _step(a) and _step(b):
            return _step(a), "square"
        for c, s in ((a, b), (b, a)):
            if isinstance(c, ast.Constant) and isinstance(c.value, (int, float)) and _step(s):
                return _step(s), "scaled"
    return None, None


def _terms(node):
    """The terms of a sum or difference (a factor or an abs around it dropped: 8·(…), (…)·scale, |…|), [] if not
    one."""
    if isinstance(node, ast.Call) and len(node.args) == 1 and getattr(node.func, "id", getattr(node.func, "attr", "")) \
            in ("abs", "fabs"):
        return _terms(node.args[0])
    if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Mult):
        for side in (node.left, node.right):
            if isinstance(side, ast.BinOp) and isinstance(side.op, (ast.Add, ast.Sub)):
                return _terms(side)
    if isinstance(node, ast.BinOp) and isinstance(node.op, (ast.Add, ast.Sub)):
        out = []
        for side in (node.left, node.right):
            out += _terms(side) if isinstance(side, ast.BinOp) and isinstance(side.op, (ast.Add, ast.Sub)) \
                else [side]
        return out
    return []


def _calls_at(term, step):
    """Whether ``term`` evaluates something at a point moved by ``step`` (f(x + h), f(x − h)[0], …)."""
    for node in ast.walk(term):
        if isinstance(node, ast.Call):
            for arg in ast.walk(ast.Module(body=[ast.Expr(a) for a in node.args], type_ignores=[])):
                if isinstance(arg, ast.BinOp) and isinstance(arg.op, (ast.Add, ast.Sub)) and any(
                        _step(n) == step for n in ast.walk(arg)):
                    return True
    return False


def hand_quotients(source):
    """(line, text) of the difference quotients written in ``source``: a sum or difference over a step
    (f(x + h) − f(x − h)) / 2h, (a + b − 2c) / h², (−3a + 4b − c) / (2h) or (f(x + h) − f0) / h."""
    out = []
    lines = source.splitlines()
    for node in ast.walk(ast.parse(source)):
        if not (isinstance(node, ast.BinOp) and isinstance(node.op, ast.Div)):
            continue
        step, kind = _denominator(node.right)
        terms = _terms(node.left)
        if step is None or len(terms) < 2:
            continue
        sampled = len({ast.dump(t.value) for t in terms if isinstance(t, ast.Subscript)}) == 1 and all(
            isinstance(t, ast.Subscript) for t in terms)  # a[k + 1] − a[k]: a slope between samples
        if kind in ("scaled", "square") or any(_calls_at(t, step) for t in terms) or kind == "plain" and sampled:
            out.append((node.lineno, lines[node.lineno - 1].strip()))
    return out


def test_no_difference_quotient_outside_the_kit():
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE).as_posix()
        if rel in KIT:
            continue
        for line, text in hand_quotients(path.read_text()):
            if (rel, text) not in ALLOWED:
                found.append(f"vibdyn/{rel}:{line}: {text}")
    assert not found, "difference quotients written outside vibdyn.solvers.differences / vibdyn.model.fd:\n  " + \
        "\n  ".join(found)


def test_every_allowed_site_is_still_there():
    """The allow-list names only lines that exist (a site moved to the kit leaves it)."""
    for rel, text in ALLOWED:
        assert any(t == text for _, t in hand_quotients((PACKAGE / rel).read_text())), (rel, text)


@pytest.mark.parametrize("code", [
    "d = (f(x + h) - f(x - h)) / (2 * h)",
    "d = (J(y + h * e) - J(y - h * e)) / (2 * h)",
    "d = (fun(x + e) - fun(x - e)) / (2 * e[k])",
    "c = abs(amp(N + h)[0] - 2 * A + amp(N - h)[0]) / h ** 2",
    "c = abs(ap + am - 2 * a0) / h**2",
    "w = (wp - wm) / (2 * h)",
    "d = (-3 * a + 4 * b - c) / (2 * h)",
    "d = (r(w + d) - r(w - d)) * scale / (2 * d)",
    "d = (8 * (g(s + h) - g(s - h)) - (g(s + 2 * h) - g(s - 2 * h))) / (12 * h)",
    "d = (f(x + h) - f0) / h",
    "X[:, k] = (r[0] - r[2]) / (2 * hk)",
    "s = (S(T + h) - S(np.maximum(T - h, 0))) / (T + h - np.maximum(T - h, 0))",
    "s = (a[k + 1] - a[k]) / h",
])
def test_the_checker_sees_one(code):
    assert hand_quotients(code), code


@pytest.mark.parametrize("code", [
    "f = omega / (2 * np.pi)",
    "z = (w2 - w1) / (2 * np.sqrt(w1 * w2))",
    "x = (t - t0) / h",
    "r = err / (2 * r)",
    "d2 = norm(f1 - f0) / h0",
    "s = (b - a) / (t + h - a)",
    "u = xi / h",
])
def test_the_checker_passes_what_is_no_quotient(code):
    assert not hand_quotients(code), code


# the primitives against closed forms: each estimate covers its actual error


def test_central_derivative_of_sin_and_its_estimate():
    for x in (0.3, 1.0, 2.5):
        for h in (1e-2, 1e-3):
            D, T = kit.derivative(math.sin, x, h, estimate=True)
            assert D == kit.derivative(math.sin, x, h)
            err = abs(D - math.cos(x))
            assert err <= abs(T) / 3 * 1.01 + 4 * kit.round_off(h) * 2.2e-16  # T is three times the truncation
            assert abs(T) / 3 <= 1.01 * err + 1e-15  # and not far above it
            assert err == pytest.approx(h**2 / 6 * abs(math.cos(x)), rel=1e-3)


def test_central_derivative_of_an_array_valued_function():
    D = kit.derivative(lambda s: np.array([np.exp(s), s**3]), 1.0, 1e-4)
    assert D == pytest.approx([math.e, 3.0], rel=1e-7)


def test_second_derivative_of_exp():
    for h in (1e-2, 1e-3):
        d1, d2 = kit.second_derivative(np.exp, 0.5, h)
        assert d1 == pytest.approx(math.exp(0.5), rel=h**2)
        assert abs(d2 - math.exp(0.5)) <= h**2 / 12 * math.exp(0.5 + h) * 1.01 + 8 * 2.2e-16 / h**2
    d1, d2 = kit.second_derivative(np.cos, 0.0, 1e-3, f0=1.0)  # the centre given
    assert (d1, d2) == (pytest.approx(0.0, abs=1e-15), pytest.approx(-1.0, rel=1e-6))


def test_one_sided_difference_and_its_estimate():
    x = 1.0
    for h in (1e-2, 1e-3):
        D, T = kit.one_sided([math.exp(x + s * h) for s in kit.ONE_SIDED], h)
        err = abs(D - math.e)
        assert err <= abs(T) / 3 * 1.05 + 8 * 2.2e-16 * math.e * kit.round_off(h, one_sided=True)
        assert err == pytest.approx(h**2 / 3 * math.e, rel=2e-2)  # −h²/3·f‴ to leading order


def test_round_off_weights():
    assert kit.round_off(0.5) == 2.0 and kit.round_off(0.5, one_sided=True) == 8.0


def test_jacobian_and_vector_derivative():
    A = np.array([[1.0, 2.0], [3.0, -1.0], [0.5, 0.0]])
    x = np.array([0.3, -0.7])

    def fun(y):
        return np.sin(A @ y)

    exact = np.cos(A @ x)[:, None] * A
    assert fd_jacobian(fun, x) == pytest.approx(exact, abs=1e-8)
    assert kit.jacobian(fun, x) == pytest.approx(exact, abs=1e-8)
    assert fd.vector_derivative(fun, x, np.full(2, 1e-5)) == pytest.approx(exact, abs=1e-9)
    D, T = kit.differences(np.array([fun(y) for y in kit.displaced_vectors(x, np.full(2, 1e-2), True)]),
                           np.full(2, 1e-2))
    assert np.all(np.abs(D - exact) <= np.abs(T) / 3 * 1.05 + 1e-13)


def test_fd_reexports_the_kit():
    """model.fd offers the kit under the same names (one implementation)."""
    for name in ("differences", "displaced_vectors", "vector_derivative", "derivative", "second_derivative",
                 "one_sided", "round_off", "CENTRAL", "ESTIMATED", "ONE_SIDED"):
        assert getattr(fd, name) is getattr(kit, name), name


def test_fourth_order_derivative_of_sin():
    for h in (1e-2, 2e-3):
        d = kit.derivative(math.sin, 0.7, h, order=4)
        assert abs(d - math.cos(0.7)) == pytest.approx(h**4 / 30 * math.cos(0.7), rel=2e-2)  # h⁴/30·|f⁽⁵⁾|
        D, T = kit.derivative(math.sin, 0.7, h, estimate=True)
        assert d == pytest.approx(D + T / 3, abs=1e-14)  # D(h) + (D(h) − D(2h))/3
    with pytest.raises(ValueError):
        kit.derivative(math.sin, 0.7, 1e-3, estimate=True, order=4)


def test_secant_is_the_central_difference_cut_at_a_bound():
    assert kit.secant(np.exp, 0.0, 2e-3) == pytest.approx((math.exp(2e-3) - 1) / 2e-3, rel=1e-15)
    T, h = np.array([0.0, 0.5]), 1e-4
    s = kit.secant(np.cos, np.maximum(T - h, 0), T + h)
    assert s == pytest.approx(-np.sin(T), abs=h)  # one-sided at 0 (error h/2·|f″|), central inside


def test_hessian_of_a_quadratic_form_and_of_a_product():
    A = np.array([[2.0, 0.5], [0.5, -1.0]])
    H = kit.hessian(lambda x: np.array([x @ A @ x, math.sin(x[0]) * math.exp(x[1])]), [0.3, -0.2], [1e-3, 2e-3])
    assert H.shape == (2, 2, 2)
    assert H[0] == pytest.approx(2 * A, abs=1e-8)  # exact but for round-off (~ε/h²)
    s, c, e = math.sin(0.3), math.cos(0.3), math.exp(-0.2)
    assert H[1] == pytest.approx(np.array([[-s * e, c * e], [c * e, s * e]]), abs=1e-6)
    assert kit.hessian(lambda x: x[0] ** 2, [1.0], 1e-3, f0=1.0)[0, 0, 0] == pytest.approx(2.0, abs=1e-9)
