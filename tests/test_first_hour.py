"""Issue 34, a light first hour: what a newcomer meets on the base install. load_robot without the robots extra
names the extra; a checkout's path to a bundled model says the bare name loads it."""

import pathlib

import pytest

import vibdyn as vd
from vibdyn.io import robots


def test_load_robot_without_the_robots_extra_names_the_extra(monkeypatch):
    monkeypatch.setattr(robots, "_ROBOTS_DIR", [])  # forget the folder found, and find none (as where it is missing)
    monkeypatch.delenv("EXAMPLE_ROBOT_DATA_MODEL_DIR", raising=False)
    monkeypatch.setattr(pathlib.Path, "is_dir", lambda self: False)
    with pytest.raises(vd.ModelError) as e:
        vd.load_robot("ur5")
    message = str(e.value)
    assert message.startswith("robot 'ur5': the robots of example-robot-data are not installed")
    assert "pip install 'vibdyn[robots]'" in message


def test_a_checkout_path_to_a_bundled_model_names_the_bare_name(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(vd.SceneFileError) as e:
        vd.load_scene("models/rod_pivot.toml")
    assert "the bundled model 'rod_pivot' loads by its bare name: vd.load_scene('rod_pivot')" in str(e.value)
    assert vd.load_scene("rod_pivot").name == "rod_pivot"


def _docs_module(name):
    import importlib
    import sys

    from conftest import ROOT

    folder = str(ROOT / "docs" / ("_ext" if name == "vibdyn_gallery" else ""))
    sys.path.insert(0, folder)
    try:
        return importlib.import_module(name)
    finally:
        sys.path.remove(folder)


def test_the_gallery_scraper_leaves_pyplot_figures_to_matplotlibs_scraper(tmp_path):
    """A pyplot figure, closed by matplotlib's scraper, was taken again by vibdyn's (shown twice on the
    four-bar's page); a Figure vibdyn returns (modes.plot()) is vibdyn's scraper's, once."""
    pytest.importorskip("sphinx_gallery", reason="the docs extra")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.figure import Figure

    gallery = _docs_module("vibdyn_gallery")
    src = tmp_path / "examples" / "plot_x.py"
    src.parent.mkdir()
    src.write_text("", encoding="utf-8")
    (tmp_path / "images").mkdir()
    images = iter(tmp_path / "images" / f"sphx_glr_plot_x_{i:03d}.png" for i in range(1, 10))
    mine = Figure()
    mine.subplots().plot([0, 1], [1, 0])
    drawn, _ = plt.subplots()
    plt.close("all")  # what matplotlib's scraper does after saving it
    scraper = gallery.VibdynScraper()
    for _block in range(2):
        scraper({}, {"src_file": str(src), "example_globals": {"fig": drawn, "fig_mode": mine},
                     "image_path_iterator": images}, {"src_dir": str(tmp_path)})
    assert sorted(p.name for p in (tmp_path / "images").iterdir()) == ["sphx_glr_plot_x_001.png"]


def test_the_site_check_finds_a_figure_shown_twice_and_an_object_repr(tmp_path):
    check_site = _docs_module("check_site")
    page = tmp_path / "auto_examples" / "plot_x.html"
    (tmp_path / "_images").mkdir(parents=True)
    page.parent.mkdir()
    for name, data in (("a", b"one"), ("b", b"one"), ("c", b"two")):
        (tmp_path / "_images" / f"sphx_glr_plot_x_{name}.png").write_bytes(data)
    img = '<img src="../_images/sphx_glr_plot_x_{}.png" alt="" class="sphx-glr-single-img">'
    page.write_text(img.format("a") + img.format("c") + "<pre>&lt;matplotlib.legend.Legend object at 0x7f3a9c&gt;"
                    "</pre>", encoding="utf-8")
    assert check_site.gallery_problems(tmp_path, ["auto_examples/plot_x.html"]) == [
        "auto_examples/plot_x.html: an object's repr in its output: <matplotlib.legend.Legend object at 0x7f3a9c>"]
    page.write_text(img.format("a") + img.format("b") + "<pre>ω = 17.466 rad/s</pre>", encoding="utf-8")
    assert check_site.gallery_problems(tmp_path, ["auto_examples/plot_x.html"]) == [
        "auto_examples/plot_x.html: the same figure shown twice (../_images/sphx_glr_plot_x_a.png and "
        "../_images/sphx_glr_plot_x_b.png)"]
