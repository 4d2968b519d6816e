"""Input checks shared by the scene, the joints and the force elements (all raise ModelError)."""

import difflib
import inspect
import math
import numbers

import numpy as np

from .errors import ModelError, VibdynError


def finite_array(value, shape, what):
    """``value`` as a float array of ``shape`` (None entries free; ``shape`` None: any shape), finite, else
    ModelError naming ``what``. Strings, booleans, complex numbers and None are not numbers here."""
    if callable(value):
        raise ModelError(f"{what}: expected numbers, got a callable")
    try:
        raw = np.asarray(value)
        if raw.dtype.kind not in "iufO" or (raw.dtype.kind == "O" and any(
                x is None or isinstance(x, (str, bytes, bool, np.bool_, complex)) for x in raw.flat)):
            raise TypeError
        arr = raw.astype(float)
    except OverflowError:
        raise ModelError(f"{what}: a number is too large for double precision (beyond ±1.8e308)") from None
    except (TypeError, ValueError):
        expected = "numbers" if shape is None else f"numbers of shape {_fmt(shape)}"
        raise ModelError(f"{what}: expected {expected}, got {value!r}") from None
    if shape is not None and (arr.ndim != len(shape)
                              or any(s is not None and s != a for s, a in zip(shape, arr.shape))):
        raise ModelError(f"{what}: expected shape {_fmt(shape)}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ModelError(f"{what}: contains NaN or inf ({_bad_entries(arr, value)})")
    return arr


def _bad_entries(arr, value):
    """The non-finite entries of ``arr`` in words: the value itself when short, else the first one's index."""
    if arr.size <= 6:
        return repr(value.tolist() if isinstance(value, np.ndarray) else float(arr) if arr.ndim == 0 else value)
    bad = np.argwhere(~np.isfinite(arr))
    first = tuple(int(i) for i in bad[0])
    return (f"{len(bad)} of {arr.size} entries, the first {arr[first]} at index "
            f"{first[0] if len(first) == 1 else first}")


def vector3(value, what):
    return finite_array(value, (3,), what)


def scalar(value, what, *, positive=False, nonnegative=False):
    """A finite float; ``positive`` (> 0) or ``nonnegative`` (>= 0) if asked."""
    if type(value) is float:  # the common case, without the generic checks below
        x = value
    elif isinstance(value, bool) or not isinstance(value, (numbers.Real, np.floating, np.integer)):
        raise ModelError(f"{what}: expected a number, got {value!r}")
    else:
        try:
            x = float(value)
        except OverflowError:
            raise ModelError(f"{what}: too large for double precision (beyond ±1.8e308)") from None
    if not math.isfinite(x):
        raise ModelError(f"{what}: must be finite, got {x}")
    if positive and not x > 0:
        raise ModelError(f"{what}: must be positive, got {x}")
    if nonnegative and x < 0:
        raise ModelError(f"{what}: must not be negative, got {x}")
    return x


# Magnitudes no scene has, refused where they enter (naming the element): the model's scales square the
# lengths and multiply them by the masses, and Pinocchio's mass matrix overflowed with two bodies of 1e300 kg
# (not with 1e150). The observable universe spans ~1e27 m and holds ~1e53 kg.
MAX_LENGTH = 1e100  # m
MAX_MASS = 1e150  # kg


def bounded(value, limit, what, unit):
    """``value`` (finite numbers) unchanged if every |x| ≤ ``limit``, else ModelError naming ``what``."""
    if np.max(np.abs(value), initial=0.0) > limit:
        raise ModelError(f"{what}: {np.max(np.abs(value)):.3g} {unit} is beyond what a scene can hold (at most "
                         f"{limit:g} {unit})")
    return value


def integer(value, what, *, minimum=None, maximum=None):
    """An int (not a bool, not a float with a fraction) within [minimum, maximum], else ModelError."""
    if isinstance(value, bool) or not isinstance(value, (numbers.Integral, np.integer)):
        raise ModelError(f"{what}: expected an integer, got {value!r}")
    n = int(value)
    if (minimum is not None and n < minimum) or (maximum is not None and n > maximum):
        bounds = (f"≥ {minimum}" if maximum is None else f"≤ {maximum}" if minimum is None
                  else f"in [{minimum}, {maximum}]")
        raise ModelError(f"{what}: must be {bounds}, got {n}")
    return n


def all_finite(a):
    """Whether every number of the float array ``a`` is finite. Up to 32 numbers are first summed in Python
    (a NaN or inf makes the sum non-finite; it overflows silently, with no numpy call's fixed cost) and
    tested one by one only where that sum is not finite; more are tested one by one at once."""
    if a.size <= 32 and math.isfinite(sum(a.ravel().tolist())):
        return True
    return bool(np.isfinite(a).all())


def finite_result(value, what):
    """``value`` unchanged if every number in it is finite, else ModelError: a result that overflowed."""
    if not (all_finite(value) if isinstance(value, np.ndarray) and value.dtype == float
            else np.all(np.isfinite(value))):
        raise ModelError(f"{what} is not finite (overflow: state or parameters too large)")
    return value


def unit_axis(value, what):
    """A direction normalised to unit length; a zero or non-finite axis is a ModelError."""
    a = vector3(value, what)
    scale = np.abs(a).max()
    if scale < 1e-12:
        raise ModelError(f"{what}: axis has zero length")
    if scale <= 1.0 + 4 * np.finfo(float).eps and abs(np.linalg.norm(a) - 1.0) <= 4 * np.finfo(float).eps:
        return a  # already unit: kept bit for bit, so scene files round-trip exactly
    a = a / scale  # no overflow for huge components
    return a / np.linalg.norm(a)


def has_coordinates(system, what, nothing="moves"):
    """A ModelError naming ``what`` when ``system`` has no coordinates (a scene without moving bodies)."""
    if system.nv == 0:
        raise ModelError(f"{what}: scene '{system.name}' has no coordinates (no body on a moving joint): nothing "
                         f"{nothing}; add one (scene.add_body(name, joint=vd.Pivot(...), mass=...))")


def turns_hint(system, q, within_limits=False):
    """"" or what a start ``q`` of ``system`` (a System) has in it more than a full turn (2π) from neutral in a
    rotation coordinate (rad), as a hint that degrees were given for radians: "rod = 90 rad, more than a full turn
    (2π) from neutral: degrees by mistake? 90° is 1.5708 rad"; ``within_limits``: of the coordinates within their
    position limits only."""
    offsets = system.difference(system.neutral(), q)
    lower, upper = system.limit_bounds() if within_limits else (offsets, offsets)
    return degrees_hint([(c, x) for c, u, x, lo, hi in zip(system.coordinates, system.units, offsets, lower, upper)
                         if u == "rad" and lo <= x <= hi], "from neutral")


def degrees_hint(angles, where=""):
    """"" or what ``angles`` [(name, angle in rad)] have beyond a full turn (2π) ``where`` ("from neutral"), as a
    hint that degrees were given for radians."""
    big = [(c, float(x)) for c, x in angles if abs(x) > 2 * np.pi]
    if not big:
        return ""
    names = ", ".join(f"{c} = {x:g} rad" for c, x in big)
    degrees = ", ".join(f"{x:g}° is {np.radians(x):.6g} rad" for _, x in big)
    return f"{names}, more than a full turn (2π){' ' + where if where else ''}: degrees by mistake? {degrees}"


def hint(message, what):
    """A UserWarning ``what: message`` at the user's line, when ``message`` says something (a hint such as
    :func:`degrees_hint`'s: the input may be meant, so it is not refused)."""
    if message:
        from ._deprecation import warn_caller

        warn_caller(f"{what}: {message}")


def start_hint(system, q, what):
    """Warn (:func:`hint`) when a start ``q`` the user gave has a rotation beyond a full turn from neutral (within
    its limits: one beyond them is refused, naming them)."""
    if np.abs(q).max(initial=0.0) <= 2 * np.pi:  # (every neutral is 0 in a vector coordinate, and a unit
        return  # quaternion or complex number is within half a turn: no offset can pass a turn)
    hint(turns_hint(system, q, within_limits=True), what)


def rotation_matrix(value, what):
    """A 3×3 rotation matrix, or a rotation vector (axis × angle in rad) of 3 numbers; None is identity."""
    if value is None:
        return np.eye(3)
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        arr = None  # finite_array below says what is wrong
    if arr is not None and arr.shape == (3,):
        from scipy.spatial.transform import Rotation

        angle = float(np.linalg.norm(vector3(value, what)))
        if angle > 2 * np.pi:  # one turn is the most a rotation needs: degrees given for radians?
            raise ModelError(f"{what}: a rotation vector of {angle:.6g} rad (more than a full turn, 2π): give it in "
                             f"radians (degrees by mistake? {angle:g}° is {np.radians(angle):.6g} rad)")
        R = Rotation.from_rotvec(vector3(value, what)).as_matrix()
        if not np.all(np.isfinite(R)):
            raise ModelError(f"{what}: rotation vector too large ({np.linalg.norm(arr):.3g} rad)")
        return R
    R = finite_array(value, (3, 3), what)
    # (an entry beyond 2 fails RᵀR = 1 anyway: refused before RᵀR of huge ones overflows on the way)
    if np.abs(R).max() > 2.0 or not np.allclose(R.T @ R, np.eye(3), atol=1e-9) or np.linalg.det(R) < 0:
        raise ModelError(f"{what}: not a rotation matrix (RᵀR ≠ 1 or det R < 0)")
    return R


def stiffness_like(value, n, what):
    """A nonnegative scalar or per-coordinate vector of length ``n``, returned as an array of ``n``."""
    arr = np.atleast_1d(finite_array(value, None, what))
    if arr.size == 1:
        arr = np.full(n, float(arr[0]))
    if arr.shape != (n,):
        raise ModelError(f"{what}: expected {one_or_each(n)}, got shape {arr.shape}")
    if np.any(arr < 0):
        raise ModelError(f"{what}: must not be negative, got {arr.tolist()}")
    return arr


def count(n, noun, plural=None):
    """'1 number', '3 numbers' (``plural`` for irregular nouns: count(2, 'body', 'bodies'))."""
    return f"{n} {noun if n == 1 else plural or noun + 's'}"


def one_or_each(n):
    """What a per-coordinate parameter of an ``n``-coordinate joint accepts, in words."""
    return "a number" if n == 1 else f"a number or {n} numbers (one per coordinate)"


def unknown_name(name, valid, noun, plural=None, what=None):
    """The ModelError for a name that is not among ``valid``: names the element (``what``), lists the valid
    names and the closest match ("did you mean 'shoulder_pan_joint'?"). Return it for the caller to raise."""
    valid = list(dict.fromkeys(valid))  # unique, in order
    plural = plural or noun + "s"
    close = difflib.get_close_matches(name, valid, n=1, cutoff=0.6) if isinstance(name, str) else []
    hint = f"; did you mean '{close[0]}'?" if close else ""
    shown = ", ".join(valid[:100]) + (f", … ({len(valid)} in all)" if len(valid) > 100 else "")
    prefix = f"{what}: " if what else ""
    return ModelError(f"{prefix}unknown {noun} {name!r}{hint} ({plural}: {shown or 'none'})")


def _fmt(shape):
    return "(" + ", ".join("n" if s is None else str(s) for s in shape) + ("," if len(shape) == 1 else "") + ")"


def kind_of(d, field, registry, what, example, noun):
    """(registry[d[field]], the other entries) of a plain-data table such as ``{"type": "pivot", ...}``."""
    from collections.abc import Mapping

    if not isinstance(d, Mapping):
        raise ModelError(f"{what}: expected a table such as {example}, got {d!r}")
    d = dict(d)
    kind = d.pop(field, None)
    if not isinstance(kind, str) or kind not in registry:
        raise unknown_name(kind, registry, noun, f"{noun}s", what)
    return registry[kind], d



def user_callable(fn, nargs, what):
    """``fn`` if it accepts ``nargs`` positional arguments, else ModelError now (not at t = 0.5 s)."""
    try:
        sig = inspect.signature(fn)
    except (TypeError, ValueError):
        return fn  # a builtin without a signature: it is checked when called
    try:
        sig.bind(*range(nargs))
    except TypeError:
        raise ModelError(f"{what}: the callable must accept {nargs} positional argument(s), its signature is "
                         f"{getattr(fn, '__name__', 'callable')}{sig}") from None
    return fn


def call_user(fn, args, what, t):
    """fn(*args), the one guard around every user callable (force laws, body forces, support motions): any
    exception inside it becomes a ModelError naming the element, the time (s) and the original error."""
    try:
        return fn(*args)
    except VibdynError:
        raise
    except Exception as e:
        raise ModelError(f"{what} failed at t = {t:.6g} s: {type(e).__name__}: {e}") from e


# ---------------------------------------------------------------------------------------------- builders
def call_builder(build, args, kwargs, what, at):
    """build(*args, **kwargs), a user's builder: any exception inside it (but vibdyn's own, which already names
    the element) becomes a ModelError "{what}: the builder failed at {at}: …" with the original chained."""
    try:
        return build(*args, **kwargs)
    except VibdynError:
        raise
    except Exception as e:
        raise ModelError(f"{what}: the builder {getattr(build, '__name__', 'build')} failed at {at}: "
                         f"{type(e).__name__}: {e}") from e


def builder_values(params, what):
    """{keyword: float}: the values given to a builder ``build(**params)``, each a finite number, else a
    ModelError naming the keyword."""
    return {k: scalar(v, f"{what}: parameter {k!r}") for k, v in params.items()}


def scene_builder(build, what):
    """``build`` (a function ``build(**params)`` returning a Scene or a System, as :func:`vibdyn.sweep` takes it)
    as a function returning the Scene; anything else it returns is a ModelError saying what came back."""
    if not callable(build):
        raise ModelError(f"{what}: build must be a function build(**params) returning a Scene, got {build!r}")
    if isinstance(build, type):  # (callable, but its instances are no scenes: Scene(**params) has no bodies)
        raise ModelError(f"{what}: build must be a function build(**params) returning a Scene, got the class "
                         f"{build.__name__} itself")
    try:
        signature = inspect.signature(build)
    except (TypeError, ValueError):
        signature = None  # (a builtin: checked when called)

    def scene(**values):
        try:
            if signature is not None:
                signature.bind(**values)
        except TypeError as e:
            raise ModelError(f"{what}: the builder {getattr(build, '__name__', 'build')}{signature} cannot take the "
                             f"parameters {', '.join(values)}: {e}") from None
        obj = call_builder(build, (), values, what, ", ".join(f"{k} = {v}" for k, v in values.items()))
        if isinstance(obj, type):  # (the class Scene itself, not a scene: its build is unbound)
            raise ModelError(f"{what}: build(**params) must return a Scene or a System, it returned the class "
                             f"{obj.__name__} itself (return {obj.__name__}(...), an instance)")
        if hasattr(obj, "build") and not hasattr(obj, "linearize"):
            return obj
        if hasattr(obj, "linearize") and hasattr(obj, "scene"):  # a System: the scene it was built from
            return obj.scene
        missing = " (does the builder end without `return scene`?)" if obj is None else ""
        raise ModelError(f"{what}: build(**params) must return a Scene or a System, it returned "
                         f"{type(obj).__name__}{missing}")

    return scene


# ---------------------------------------------------------------------------------------------- file values
# Checks of plain-data values (TOML): strict types (no strings for numbers, no booleans), finite numbers.
# Each returns the value in the form the Scene API takes, or raises BadValue (the scene-file reader names the
# file and key); the element kinds declare their scene-file keys with them.

class BadValue(Exception):
    """A scene-file value of the wrong kind (the reader adds the file and key)."""


def is_number(x):
    return isinstance(x, (numbers.Real, np.floating, np.integer)) and not isinstance(x, (bool, np.bool_))


def as_list(x):
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, (list, tuple)):
        return list(x)
    return None


def shown(x):
    s = repr(x)
    return s if len(s) <= 60 else s[:57] + "..."


def value_string(x):
    if not isinstance(x, str):
        raise BadValue(f"expected a string, got {shown(x)}")
    return x


def value_number(x):
    if not is_number(x):
        raise BadValue(f"expected a number, got {shown(x)}")
    if not math.isfinite(x):
        raise BadValue(f"must be finite, got {x}")
    return float(x)


def value_nonnegative(x):
    v = value_number(x)
    if v < 0:
        raise BadValue(f"must not be negative, got {v}")
    return v


def value_boolean(x):
    if not isinstance(x, (bool, np.bool_)):
        raise BadValue(f"expected true or false, got {shown(x)}")
    return bool(x)


def value_vec3(x):
    a = as_list(x)
    if a is None or len(a) != 3 or not all(is_number(v) for v in a):
        raise BadValue(f"expected 3 numbers [x, y, z], got {shown(x)}")
    return value_finite([float(v) for v in a], x)


def value_finite(values, x):
    if not all(math.isfinite(v) for v in values):
        raise BadValue(f"must be finite, got {shown(x)}")
    return values


def value_mat3(x):
    rows = as_list(x)
    if rows is None or len(rows) != 3:
        raise BadValue(f"expected a 3×3 matrix [[...], [...], [...]], got {shown(x)}")
    try:
        return [value_vec3(r) for r in rows]
    except BadValue:
        raise BadValue(f"expected a 3×3 matrix [[...], [...], [...]], got {shown(x)}") from None


def value_rotation(x):
    a = as_list(x)
    if a is not None and len(a) == 3 and all(is_number(v) for v in a):
        return value_finite([float(v) for v in a], x)
    try:
        return value_mat3(x)
    except BadValue:
        raise BadValue(f"expected a 3×3 rotation matrix or a rotation vector of 3 numbers (rad), got {shown(x)}") \
            from None


def value_numbers(x):
    a = as_list(x)
    if a is None or not a or not all(is_number(v) for v in a):
        raise BadValue(f"expected a non-empty list of numbers, got {shown(x)}")
    return value_finite([float(v) for v in a], x)


def value_number_or_list(x, nonnegative=False):
    if is_number(x):
        vals, out = value_finite([float(x)], x), float(x)
    else:
        try:
            vals = out = value_numbers(x)
        except BadValue:
            raise BadValue(f"expected a number or a list of numbers, got {shown(x)}") from None
    if nonnegative and any(v < 0 for v in vals):
        raise BadValue(f"must not be negative, got {shown(x)}")
    return out


def value_nonnegative_number_or_list(x):
    return value_number_or_list(x, nonnegative=True)


def value_attachment(x):
    if isinstance(x, str):
        return x
    a = as_list(x)
    if a is None or len(a) != 2 or not isinstance(a[0], str):
        raise BadValue(f'expected "body" or ["body", [x, y, z]], got {shown(x)}')
    try:
        return [a[0], value_vec3(a[1])]
    except BadValue:
        raise BadValue(f'expected "body" or ["body", [x, y, z]], got {shown(x)}') from None


def value_table(x):
    if not isinstance(x, dict):
        raise BadValue(f"expected a table, got {shown(x)}")
    return x


def value_matrix_or_table(x):
    if isinstance(x, dict):
        return x
    try:
        return value_mat3(x)
    except BadValue:
        raise BadValue(f"expected a 3×3 matrix (kg·m², about the com) or a helper table such as "
                   f'{{ shape = "rod", length = 1.0 }}, got {shown(x)}') from None


def value_strings(x):
    a = as_list(x)
    if a is None or not all(isinstance(v, str) for v in a):
        raise BadValue(f"expected a list of strings, got {shown(x)}")
    return a


def name_values(items, option, meaning):
    """{name: number} from ``NAME=VALUE`` strings of the command-line ``option``; ``meaning`` says what a pair
    is in the error (a ModelError naming the bad item)."""
    out = {}
    for item in items or ():
        name, sep, value = item.partition("=")
        try:
            if not sep or not name.strip():
                raise ValueError
            out[name.strip()] = float(value)
        except ValueError:
            raise ModelError(f"{option} {item!r}: expected NAME=VALUE, {meaning}") from None
    return out
