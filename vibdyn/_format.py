"""Numbers as text for reports: exact zeros and values below their error estimate print as ``0``; no ``+0``,
``-0`` or round-off noise such as ``1e-10 rad``."""

import numpy as np


def number(x, unit="", error=0.0, digits=6):
    """``x`` with ``digits`` significant digits (and `` unit`` if given); ``0`` when |x| ≤ ``error``."""
    x = float(x)
    if not np.isfinite(x):
        text = "inf" if x > 0 else "-inf" if x < 0 else "nan"
    elif abs(x) <= error or x == 0.0:
        text = "0"
    else:
        text = f"{x:.{digits}g}"
        if float(text) == 0.0:
            text = "0"
    return f"{text} {unit}" if unit else text


def vector(xs, unit="", error=0.0, digits=6):
    """``(a, b, c)`` of :func:`number` (and `` unit`` if given)."""
    text = "(" + ", ".join(number(x, error=error, digits=digits) for x in np.ravel(xs)) + ")"
    return f"{text} {unit}" if unit else text


def with_units(values, units, names):
    """``values`` (one, or one per coordinate) with their units: ``units`` the joint's ("m" or "rad" per
    coordinate), ``names`` the unit of the quantity for each ({"m": "N/m", "rad": "N·m/rad"}); without units
    (unknown joint) the bare numbers."""
    vals = np.ravel(values)
    us = [names[u] for u in units]
    if not us:
        return number(vals[0]) if vals.size == 1 else vector(vals)
    if vals.size == 1:
        return number(vals[0], us[0] if len(set(us)) == 1 else "") + (" each" if len(us) > 1 else "")
    if len(set(us)) == 1:
        return vector(vals, us[0])
    return "(" + ", ".join(number(v, u) for v, u in zip(vals, us)) + ")"


def table(header, rows, align=None):
    """Columns of text padded to their widest entry; ``align`` "<" or ">" per column (default: first left,
    the others right)."""
    cols = list(zip(*([header] + rows))) if rows else [[h] for h in header]
    width = [max(len(str(c)) for c in col) for col in cols]
    align = align or ["<"] + [">"] * (len(header) - 1)
    return ["  ".join(f"{str(c):{a}{w}}" for c, a, w in zip(row, align, width)).rstrip()
            for row in [header] + rows]


def json_ready(obj):
    """``obj`` with every non-finite float replaced by None (JSON has no inf or NaN): nested dicts, lists,
    tuples and numpy scalars/arrays are walked."""
    if isinstance(obj, dict):
        return {k: json_ready(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [json_ready(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return json_ready(obj.tolist())
    if isinstance(obj, (float, np.floating)):
        return float(obj) if np.isfinite(obj) else None
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    return obj


def values(x, unit="", most=4, digits=4):
    """A few numbers of an array for a one-line summary: "2.397, 5.787, … (7 values) rad/s"."""
    a = np.ravel(np.asarray(x, dtype=float))
    shown = ", ".join(number(v, digits=digits) for v in a[:most])
    more = f", … ({a.size} values)" if a.size > most else ""
    return f"{shown}{more}{' ' + unit if unit else ''}" if a.size else "none"


def summary(name, *parts):
    """A short ``repr``: ``Name(part, part, …)`` with empty parts left out."""
    return f"{name}({', '.join(p for p in parts if p)})"


def duration(seconds):
    """A run time for a summary: "0.42 ms", "1.3 s"."""
    return f"{seconds * 1e3:.2g} ms" if seconds < 1 else f"{seconds:.3g} s"


def html_table(caption, header, rows):
    """A small self-contained HTML table (for Jupyter's ``_repr_html_``); cells are escaped text."""
    from html import escape

    head = "".join(f"<th>{escape(str(h))}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{escape(str(c))}</td>" for c in r) + "</tr>" for r in rows)
    return (f"<table><caption style='text-align:left'>{escape(caption)}</caption><thead><tr>{head}</tr></thead>"
            f"<tbody>{body}</tbody></table>")
