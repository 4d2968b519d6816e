"""Work-precision diagrams (error against run time, log-log, one panel per case). The only module of the
suite that imports matplotlib; without it the plots are skipped with a message."""

import math

MARKERS = {"vibdyn": "o", "mujoco": "s", "scipy": "^"}


def _family(r):
    """Runs of one method form one line: vibdyn dop853 / rk4 / …, mujoco RK4 / implicitfast, scipy X."""
    m = r.get("method") or r["label"].split()[1]
    how = r.get("error_method") or ("rerun" if "error=rerun" in r["label"] else None)
    return f"{r['solver']} {m}" + (f" ({how} estimate)" if how and r["solver"] == "vibdyn" else "")


def work_precision(results, path):
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print(f"plots skipped: matplotlib is not installed ({path})")
        return None
    cases = [c for c in results["cases"] if any(r["error"] and r["time_s"] for r in c["runs"])]
    if not cases:
        return None
    cols = min(3, len(cases))
    rows = math.ceil(len(cases) / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(5.2 * cols, 4.2 * rows), squeeze=False)
    for ax, case in zip(axes.flat, cases):
        draw_case(ax, case)
    for ax in list(axes.flat)[len(cases):]:
        ax.axis("off")
    fig.suptitle(f"{results['name']}: error against run time ({results['mode']} run; one core)", fontsize=11)
    fig.tight_layout(rect=(0, 0, 1, 0.97))
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path


def draw_case(ax, case):
    """One panel: each method's runs as a line (actual error: solid markers), vibdyn's estimates hollow."""
    x_key = case.get("x", "time_s")
    families = {}
    for r in case["runs"]:
        if r["error"] and r["error"] > 0 and r.get(x_key):
            families.setdefault(_family(r), []).append(r)
    for name, runs in families.items():
        runs.sort(key=lambda r: r[x_key])
        x = [r[x_key] for r in runs]
        (line,) = ax.loglog(x, [r["error"] for r in runs], MARKERS.get(runs[0]["solver"], "o") + "-", label=name,
                            ms=5)
        est = [(r[x_key], r["estimate"]) for r in runs if r["estimate"]]
        if est:
            ax.loglog(*zip(*est), MARKERS.get(runs[0]["solver"], "o"), mfc="none", color=line.get_color(), ms=8,
                      label=f"{name}: estimate")
        for r in runs:
            if r["verdict"] == "silently wrong":
                ax.annotate("✗", (r[x_key], r["error"]), color="red", fontsize=11, ha="center", va="bottom")
    refused = [r for r in case["runs"] if r["verdict"] in ("refused loudly", "crashed")]
    title = case["name"] + (f"\n({len(refused)} run(s) refused loudly)" if refused else "")
    ax.set_title(title, fontsize=8)
    ax.set_xlabel("FD step (rad)" if x_key == "step" else "wall time (s)", fontsize=8)
    ax.set_ylabel(f"error ({case.get('unit') or 'relative'})", fontsize=8)
    ax.grid(True, which="both", alpha=0.3)
    ax.tick_params(labelsize=7)
    ax.legend(fontsize=6)
