"""The plotting backend's one home (reports/report/plotting.py): pyplot only when a figure is
drawn, on MPLBACKEND's backend if set, else Agg. Each check runs in a fresh interpreter, where
nothing has imported matplotlib yet."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import pytest


def _python(code: str, **env: str) -> list[str]:
    environ = {k: v for k, v in os.environ.items() if k != "MPLBACKEND"} | env
    return subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code)],
        capture_output=True,
        text=True,
        check=True,
        env=environ,
    ).stdout.splitlines()


def test_the_api_and_the_report_import_no_pyplot():
    """The command line imports the API, and the API the report: pyplot costs ~0.2 s."""
    out = _python(
        """
        import sys
        import hoopbench.reports.api, hoopbench.reports.report.build
        print("matplotlib.pyplot" in sys.modules)
        """
    )
    assert out == ["False"]


@pytest.mark.parametrize(("env", "backend"), [({}, "agg"), ({"MPLBACKEND": "svg"}, "svg")])
def test_the_first_figure_chooses_the_backend(env, backend):
    out = _python(
        """
        import sys
        import matplotlib
        from hoopbench.reports.report.plotting import pyplot
        print("matplotlib.pyplot" in sys.modules)
        plt = pyplot()
        print(plt is sys.modules["matplotlib.pyplot"], matplotlib.get_backend().lower())
        print(pyplot() is plt)
        """,
        **env,
    )
    assert out == ["False", f"True {backend}", "True"]


def _figures_to_save(plt) -> list:
    """Figures as the report makes them: constrained layout (panels of equal aspect, a log
    axis, a legend placed "best", a colour bar, a title over all), and tight_layout()."""
    import numpy as np

    fig, ((a, b), (c, d)) = plt.subplots(2, 2, figsize=(6.0, 4.5), constrained_layout=True)
    t = np.linspace(0.0, 2.0, 400)
    a.plot(t, np.sin(5 * t), label="sin")
    a.plot(t, np.cos(3 * t), label="cos")
    a.legend()
    b.loglog(t[1:], t[1:] ** 3, "o-", ms=2)
    c.plot(np.cos(t * 3), np.sin(t * 3))
    c.set_aspect("equal")
    mesh = d.pcolormesh(np.arange(12.0).reshape(3, 4))
    fig.colorbar(mesh, ax=d, label="value")
    fig.suptitle("a title over every panel")
    tight, ax = plt.subplots(figsize=(4.0, 3.0))
    ax.semilogy(t, np.exp(t))
    ax.set_ylabel("exp")
    tight.tight_layout()
    return [fig, tight]


def test_a_laid_out_figure_is_drawn_once_to_savefig_s_pixels(tmp_path, monkeypatch):
    """save() lays a figure out at the file's dpi before savefig (plotting.laid_out), which
    then draws it once, not twice (once to lay it out, once to render it), to the same
    pixels as savefig's two draws."""
    import numpy as np
    from matplotlib.figure import Figure
    from PIL import Image

    from hoopbench.reports.report import plotting

    plt = plotting.pyplot()
    draw = Figure.draw
    draws: list[Figure] = []

    def counted(fig: Figure, renderer) -> None:
        draws.append(fig)
        draw(fig, renderer)

    monkeypatch.setattr(Figure, "draw", counted)
    files = {}
    with plotting.plain_text():
        for k, fig in enumerate(_figures_to_save(plt)):  # at another dpi than the figure's
            files[k] = plotting.save(fig, tmp_path / f"ours-{k}.png", dpi=110)
        assert len(draws) == 2, "one draw a figure"
        with monkeypatch.context() as m:
            m.setattr(plotting, "laid_out", lambda fig, dpi: None)  # savefig lays it out
            for k, fig in enumerate(_figures_to_save(plt)):
                theirs = plotting.save(fig, tmp_path / f"theirs-{k}.png", dpi=110)
                mine = np.asarray(Image.open(files[k]).convert("RGBA"))
                assert np.array_equal(mine, np.asarray(Image.open(theirs).convert("RGBA")))


def test_a_category_tick_label_s_control_characters_are_drawn_as_their_codes(tmp_path):
    """A category's name from a file (a scene's) on an axis: the axis writes its tick labels
    when drawn, from its formatter (save() wraps it); the label is drawn as visible_controls
    writes it, as the figure's other texts (a title, a legend's)."""
    import numpy as np
    from PIL import Image

    from hoopbench.reports.report import plotting
    from hoopbench.reports.sweep.control_chars import visible_controls

    plt = plotting.pyplot()
    drawn = []
    with plotting.plain_text():
        for names in (["hop\x07top", "seed"], [visible_controls("hop\x07top"), "seed"]):
            fig, ax = plt.subplots(figsize=(3.0, 2.0))
            ax.bar(names, [1.0, 2.0], label=names[0])
            ax.set_title(names[0])  # texts not ticks': save() writes them before drawing
            ax.legend()
            path = plotting.save(fig, tmp_path / f"{len(drawn)}.png", dpi=80)
            drawn.append(np.asarray(Image.open(path)))
    assert visible_controls("hop\x07top") != "hop\x07top"
    assert np.array_equal(drawn[0], drawn[1])


def test_save_draws_text_with_kept_glyphs_to_the_same_pixels(tmp_path, monkeypatch):
    """save() draws text with each glyph rendered once and each line laid out once
    (glyph_cache.with_kept_glyphs), to the pixels matplotlib's own text drawing gives: text at
    several sizes and angles (a rotated label, a text at 30 degrees, math with its rules), the
    same glyphs at many places (tick labels). Cost: about 1 s."""
    import matplotlib
    import numpy as np
    from PIL import Image

    from hoopbench.reports.report import plotting

    plt = plotting.pyplot()

    def figures() -> list:
        fig, ax = plt.subplots(figsize=(4.0, 3.0), constrained_layout=True)
        ax.plot([0.0, 1.0], [0.0, 1.0])
        ax.set_ylabel("clearance (mm), rotated")
        ax.text(0.2, 0.5, "at 30 degrees: 0.123 s", rotation=30, fontsize=11)
        ax.text(0.1, 0.8, r"$\frac{1}{2}\sqrt{x}$ math", parse_math=True)
        return [fig, *_figures_to_save(plt)]

    kept = []
    with plotting.plain_text():
        for k, fig in enumerate(figures()):
            canvas = fig.canvas  # pyplot.close gives the figure another
            plotting.save(fig, tmp_path / f"kept-{k}.png", dpi=90)
            kept.append("_draw_text_glyphs_and_boxes" in vars(canvas.renderer))
        monkeypatch.setattr(plotting, "with_kept_glyphs", lambda canvas: None)
        for k, fig in enumerate(figures()):
            plain = plotting.save(fig, tmp_path / f"plain-{k}.png", dpi=90)
            mine = np.asarray(Image.open(tmp_path / f"kept-{k}.png"))
            assert np.array_equal(mine, np.asarray(Image.open(plain))), k
    if matplotlib.__version__.startswith("3.11."):
        assert all(kept)  # drawn with it, not quietly as before
