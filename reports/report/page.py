"""report.html: the report as one page to explore, written beside report.md from the same rows.

The page's text and tables are report.md's own, rendered (markdown-it, raw HTML in it shown
as text): the same sections and the same numbers, by construction. Where report.md shows a
figure that has an interactive version, the page shows that instead (error against run time,
the stability matrix, the contact forces, each hop map, each searched engine's best settings,
and each catalogue scene's hoop in motion in place of its paths figure); every other figure
is embedded as its PNG. One file: plotly.js, the script and the style are inside it, so it
opens from disk with no network.
"""

from __future__ import annotations

import base64
import re
from collections.abc import Callable, Sequence
from functools import partial
from pathlib import Path
from typing import Any

import pandas as pd
from markdown_it import MarkdownIt
from plotly.offline import get_plotlyjs

from hoopbench.engines.run import REFERENCE_ENGINE
from hoopbench.models.catalogue import get_scene, scene_names
from hoopbench.reports.compare.suite_file import STABILITY_SUITE
from hoopbench.reports.report.best_settings import BestSettings, figure_names
from hoopbench.reports.report.drawn import drawn_rows, timestep_note
from hoopbench.reports.report.files_section import PAGE_NAME
from hoopbench.reports.report.findings import MORE_FINDINGS
from hoopbench.reports.report.hoop_gif import GIF_SCENE, hoop_gif
from hoopbench.reports.report.markdown import (
    FigurePool,
    Say,
    dearest_first,
    force_panels,
    stored_trajectories,
    with_optional_columns,
)
from hoopbench.reports.report.page_animation import animation_figure, hoop_motions
from hoopbench.reports.report.page_best_settings import best_settings_page_figure
from hoopbench.reports.report.page_figures import (
    force_page_figure,
    precision_page_figure,
    stability_page_figure,
)
from hoopbench.reports.report.page_html import figure_fragment, script_json, text
from hoopbench.reports.report.page_map import map_fragment
from hoopbench.reports.report.page_script import FILTER_COLUMNS, PAGE_SCRIPT, PAGE_STYLE
from hoopbench.reports.sweep import results

__all__ = [
    "PAGE_NAME",
    "gif_runs",
    "page_fragments",
    "page_jobs",
    "render_page",
    "write_gif",
    "write_page",
]

Fragments = dict[str, Callable[[], str]]
"""A figure file's name in report.md -> what the page shows in its place (made when needed)."""


def _figure(figure_id: str, make: Callable[..., dict | None], *args: Any) -> Callable[[], str]:
    """The fragment of the plotly figure ``make(*args)`` (a call a drawing process can make:
    module functions and their arguments, no closure)."""
    return partial(_figure_html, figure_id, make, *args)


def _figure_html(figure_id: str, make: Callable[..., dict | None], *args: Any) -> str:
    figure = make(*args)
    return "" if figure is None else figure_fragment(figure_id, figure)


def _scene_rows(runs: pd.DataFrame, scene: str) -> pd.DataFrame:
    """The rows whose trajectories the report draws (markdown.stored_trajectories')."""
    return drawn_rows(runs, scene)


def _animation(runs: pd.DataFrame, scene: str, figure_id: str) -> Callable[[], str]:
    return partial(_animation_html, runs, scene, figure_id)


def _animation_html(runs: pd.DataFrame, scene: str, figure_id: str) -> str:
    trajectories = stored_trajectories(runs, scene)
    if not trajectories:
        return ""
    rows = _scene_rows(runs, scene)
    motions = hoop_motions(get_scene(scene), trajectories, rows)
    animation = figure_fragment(figure_id, animation_figure(get_scene(scene), motions))
    caption = (
        f"{text(scene)} in motion, every engine that ran it (tuned, default settings, "
        f"{text(timestep_note(rows))}), the exact hoop first. Each panel marks its run's "
        "events in the run's colour where its centre of mass was: slip x, lift-off "
        "triangle, impact square (the key below the strip):"
    )
    return f"<p>{caption}</p>{animation}"


def _force_figure(runs: pd.DataFrame) -> dict | None:
    return force_page_figure(force_panels(runs))


def _split(frame: pd.DataFrame) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The comparison suites' rows and the stability suite's, as report.md splits them."""
    everything = with_optional_columns(frame)
    stability = everything["suite"] == STABILITY_SUITE
    return everything[~stability], everything[stability]


def page_fragments(
    frame: pd.DataFrame,
    maps: Sequence[Path],
    map_prefixes: Sequence[str],
    searches: Sequence[BestSettings] = (),
) -> Fragments:
    """What the page shows in place of report.md's figures (module doc), by figure file name."""
    fragments: Fragments = {}
    if not frame.empty:
        runs, stiff = _split(frame)
        fragments["error_vs_time.png"] = _figure("error-vs-time", precision_page_figure, runs)
        fragments["stability.png"] = _figure("stability", stability_page_figure, stiff)
        fragments["contact_forces.png"] = _figure("contact-forces", _force_figure, runs)
        for k, scene in enumerate(dict.fromkeys(runs["scene"])):
            if scene in scene_names():
                fragments[f"paths_{scene}.png"] = _animation(runs, scene, f"motion-{k}")
    for k, (folder, prefix) in enumerate(zip(maps, map_prefixes, strict=True)):
        fragments[f"{prefix}_regimes.png"] = _map(folder, f"map-{k}")
    for k, (best, name) in enumerate(zip(searches, figure_names(searches), strict=True)):
        fragments[name] = _best_settings(best, f"best-settings-{k}")
    return fragments


def page_jobs(fragments: Fragments) -> dict[str, tuple[Callable[..., Any], tuple[Any, ...]]]:
    """The fragments a drawing process can make (each a partial of a module function with
    its arguments), as calls (function, arguments), by figure file name."""
    return {
        name: (make.func, make.args)
        for name, make in fragments.items()
        if isinstance(make, partial) and not make.keywords
    }


def _best_settings(best: BestSettings, figure_id: str) -> Callable[[], str]:
    return _figure(figure_id, best_settings_page_figure, best)


def _map(folder: Path, figure_id: str) -> Callable[[], str]:
    return partial(map_fragment, folder, figure_id)


# --------------------------------------------------------------------------- rendering
def _image(out: Path, src: str, alt: str) -> str:
    """A PNG of the report folder embedded as data, or its alt text if it is not there."""
    path = out / src
    if "/" in src or "\\" in src or not path.is_file() or path.suffix != ".png":
        return f"<p><em>{text(alt)}</em></p>"
    data = base64.b64encode(path.read_bytes()).decode("ascii")
    return f'<img alt="{text(alt)}" src="data:image/png;base64,{data}">'


def _renderer(out: Path, fragments: Fragments) -> MarkdownIt:
    md = MarkdownIt("commonmark", {"html": False}).enable("table")
    headings: list[int] = []

    def image(self, tokens, idx, options, env) -> str:  # markdown-it's render-rule signature
        token = tokens[idx]
        src, alt = (
            str(token.attrGet("src") or ""),
            self.renderInlineAsText(token.children, options, env),
        )
        return fragments[src]() if src in fragments else _image(out, src, alt)

    def heading(self, tokens, idx, options, env) -> str:
        token = tokens[idx]
        if token.tag == "h2":
            headings.append(idx)
            token.attrSet("id", f"section-{len(headings)}")
        return self.renderToken(tokens, idx, options, env)

    md.add_render_rule("image", image)
    md.add_render_rule("heading_open", heading)
    return md


def _nav(tokens: list) -> str:
    """Links to the report's sections (its h2 headings)."""
    links: list[str] = []
    for k, token in enumerate(tokens):
        if token.type == "heading_open" and token.tag == "h2":
            title = tokens[k + 1].content
            links.append(f'<a href="#section-{len(links) + 1}">{text(title)}</a>')
    return f"<nav>{''.join(links)}</nav>"


_FOLDED = re.compile(
    rf'(<h2 id="section-\d+">{re.escape(MORE_FINDINGS)}</h2>\n)(.*?)(?=<h2 |\Z)', re.DOTALL
)


def _fold_findings(body: str) -> str:
    """The "All findings" section's body in a <details>, closed: the page shows the key
    findings above and folds the rest (the heading stays, so that its link works)."""
    return _FOLDED.sub(
        lambda m: f"{m[1]}<details><summary>show every finding</summary>\n{m[2]}</details>\n",
        body,
    )


def _image_sources(markdown_text: str) -> set[str]:
    """The figure files report.md shows (its images' sources, as the page's renderer reads
    them)."""
    tokens = MarkdownIt("commonmark", {"html": False}).enable("table").parse(markdown_text)
    return {
        str(child.attrGet("src") or "")
        for token in tokens
        if token.type == "inline"
        for child in token.children or ()
        if child.type == "image"
    }


def render_page(markdown_text: str, out: Path, fragments: Fragments) -> str:
    """The whole page: report.md's text with the fragments in place of their figures."""
    md = _renderer(out, fragments)
    tokens = md.parse(markdown_text)
    body = _fold_findings(md.renderer.render(tokens, md.options, {}))
    title = next((t.content for k, t in enumerate(tokens) if k and tokens[k - 1].tag == "h1"), "")
    script = PAGE_SCRIPT.replace("__FILTERS__", script_json(list(FILTER_COLUMNS)))
    return "\n".join(
        [
            "<!DOCTYPE html>",
            '<html lang="en"><head><meta charset="utf-8">',
            f"<title>{text(title or 'hoopbench report')}</title>",
            f"<style>{PAGE_STYLE}</style>",
            f"<script>{get_plotlyjs()}</script>",
            f"</head><body>{_nav(tokens)}",
            body,
            f"<script>{script}</script>",
            "</body></html>",
        ]
    )


def gif_runs(frame: pd.DataFrame) -> bool:
    """Whether the report has hop-top's exact and engine trajectories (write_gif draws them)."""
    if frame.empty or GIF_SCENE not in scene_names():
        return False
    rows = drawn_rows(_split(frame)[0], GIF_SCENE)
    engines = set() if rows.empty else set(rows["engine"])  # none: maybe no columns either
    return REFERENCE_ENGINE in engines and len(engines) >= 2


def write_gif(frame: pd.DataFrame, out: Path, say: Say | None = None) -> Path | None:
    """out/hop-top.gif (hoop_gif.py), when the report has hop-top's exact and engine
    trajectories (gif_runs); `make findings` copies it to reports/img/ for the README."""
    if not gif_runs(frame):
        return None
    runs, _ = _split(frame)
    trajectories = stored_trajectories(runs, GIF_SCENE)
    if say is not None:
        say(f"the animation {GIF_SCENE}.gif")
    scene = get_scene(GIF_SCENE)
    motions = hoop_motions(scene, trajectories, _scene_rows(runs, GIF_SCENE))
    return hoop_gif(scene, motions, out / f"{GIF_SCENE}.gif")


def write_page(
    frame: pd.DataFrame,
    out: Path,
    *,
    maps: Sequence[Path] = (),
    map_prefixes: Sequence[str] = (),
    searches: Sequence[BestSettings] = (),
    say: Say | None = None,
    pool: FigurePool | None = None,
    fragments: Fragments | None = None,
) -> Path:
    """Write out/report.html from out/report.md (written first) and the rows it was made of
    (and the searches read back, whose fronts it draws). The README's animation is
    :func:`write_gif`'s, written before report.md (build.py), whose Files section lists it.
    ``say`` hears what it is doing, a line a step. ``pool``: where the figures report.md
    shows are made, side by side (default: here, each as the page needs it); ``fragments``:
    :func:`page_fragments` of the same arguments, whose drawings the caller started in
    ``pool`` (build.py, right after report.md's): the pool returns those, none is drawn
    twice."""
    out = Path(out)
    markdown_text = (out / "report.md").read_text(encoding="utf-8")
    if say is not None:
        say(f"{PAGE_NAME}: its interactive figures and animations")
    started = fragments is not None
    if fragments is None:
        fragments = page_fragments(frame, maps, map_prefixes, searches)
    fragments = dict(fragments)  # the caller's own left as it was
    if pool is not None:  # those report.md shows, made side by side (each a partial)
        # Started before, every one is drawing already: no need to read which are shown.
        shown = None if started else _image_sources(markdown_text)
        made = {
            name: job
            for name, job in page_jobs(fragments).items()
            if shown is None or name in shown
        }
        names = list(made)
        futures = {}
        for k in dearest_first([made[name] for name in names]):
            function, args = made[names[k]]
            futures[names[k]] = pool.submit(function, *args)
        fragments |= {name: future.result for name, future in futures.items()}
    page = render_page(markdown_text, out, fragments)
    path = out / PAGE_NAME
    results.atomic_write(path, lambda tmp: tmp.write_text(page, encoding="utf-8"))
    return path
