"""The page's own script and style: figures drawn as they scroll into view, a hop map cell's
runs on a click, and every table sortable (click a header) and filterable (a text box, and a
list for the engine, profile, verdict and scene columns). Plain JavaScript, no library but
plotly.js, which the page embeds.
"""

from __future__ import annotations

__all__ = ["FILTER_COLUMNS", "PAGE_SCRIPT", "PAGE_STYLE"]

FILTER_COLUMNS = ("engine", "profile", "verdict", "scene", "settings")
"""Table headers that get a list of their values to filter by."""

PAGE_STYLE = """
body { font: 15px/1.45 system-ui, sans-serif; margin: 0 auto; max-width: 1200px; padding: 0 1em;
  color: #222; }
nav { position: sticky; top: 0; background: #fff; border-bottom: 1px solid #ddd; padding: .4em 0;
  font-size: 13px; z-index: 10; }
nav a { margin-right: .9em; }
table { border-collapse: collapse; font-size: 13px; margin: .3em 0 1em; }
th, td { border: 1px solid #ccc; padding: 2px 6px; text-align: left; }
th { background: #f2f2f2; cursor: pointer; user-select: none; }
th[aria-sort=ascending]::after { content: " \\25B2"; }
th[aria-sort=descending]::after { content: " \\25BC"; }
.tablebar { font-size: 13px; margin-top: .6em; }
.tablebar input, .tablebar select { margin-right: .6em; font-size: 13px; }
.hoop-figure { width: 100%; min-height: 420px; }
.map-runs-title { font-weight: bold; margin-top: .5em; }
img { max-width: 100%; }
code { background: #f4f4f4; padding: 0 2px; }
"""

PAGE_SCRIPT = """
(function () {
  "use strict";
  var FILTERS = __FILTERS__;
  var drawn = {};
  function json(id) { return JSON.parse(document.getElementById(id).textContent); }

  function draw(div) {
    if (drawn[div.id]) { return drawn[div.id]; }
    var figure = json(div.id + "-data");
    figure.config = { responsive: true, displaylogo: false };
    drawn[div.id] = Plotly.newPlot(div, figure).then(function () {
      if (div.dataset.kind === "map") { div.on("plotly_click", function (event) {
        showRuns(div, event.points[0].customdata); }); }
      div.dataset.drawn = "1";
    });
    return drawn[div.id];
  }

  // A hop map cell's runs: clearance, slip velocity and n/g against time, exact dashed.
  function showRuns(div, key) {
    var cells = json(div.id + "-cells"), cell = cells[key], target = document.getElementById(
      div.id + "-runs"), title = document.getElementById(div.id + "-runs-title");
    if (!cell) { return; }
    var traces = [];
    cell.runs.forEach(function (run) {
      var line = { dash: run.exact ? "dash" : "solid", color: run.colour };
      [["c", "y"], ["v", "y2"], ["n", "y3"]].forEach(function (s, j) {
        traces.push({ x: run.t, y: run[s[0]], yaxis: s[1], name: run.name, legendgroup: run.name,
          showlegend: j === 0, mode: "lines", line: line, type: "scatter" });
      });
    });
    title.textContent = cell.title;
    target.dataset.key = key;
    Plotly.react(target, traces, { height: 560, grid: { rows: 3, columns: 1, pattern: "coupled" },
      xaxis: { title: { text: "t (s)" } }, yaxis: { title: { text: "clearance (mm)" } },
      yaxis2: { title: { text: "slip velocity (m/s)" } }, yaxis3: { title: { text: "n / g" } },
      margin: { t: 20 } }, { displaylogo: false });
  }

  function cellValue(row, i) {
    var text = row.cells[i] ? row.cells[i].textContent.trim() : "";
    var number = parseFloat(text);
    return { text: text, number: /^[-+]?[0-9.]/.test(text) && !isNaN(number) ? number : null };
  }
  function compare(a, b) {
    if (a.number !== null && b.number !== null) { return a.number - b.number; }
    if (a.number !== null) { return -1; }
    if (b.number !== null) { return 1; }
    return a.text.localeCompare(b.text);
  }

  function setupTable(table) {
    if (!table.tHead || !table.tBodies.length) { return; }
    var body = table.tBodies[0], rows = Array.prototype.slice.call(body.rows);
    var heads = Array.prototype.slice.call(table.tHead.rows[0].cells);
    var bar = document.createElement("div"), box = document.createElement("input"), lists = [];
    bar.className = "tablebar";
    box.type = "search"; box.placeholder = "filter rows";
    bar.appendChild(box);
    function apply() {
      var words = box.value.toLowerCase();
      rows.forEach(function (row) {
        var keep = row.textContent.toLowerCase().indexOf(words) >= 0;
        lists.forEach(function (list) {
          keep = keep && (!list.value || cellValue(row, list.column).text === list.value);
        });
        row.hidden = !keep;
      });
    }
    heads.forEach(function (th, i) {
      th.title = "sort";
      th.addEventListener("click", function () {
        var up = th.getAttribute("aria-sort") !== "ascending";
        heads.forEach(function (h) { h.removeAttribute("aria-sort"); });
        th.setAttribute("aria-sort", up ? "ascending" : "descending");
        rows.slice().sort(function (a, b) {
          return (up ? 1 : -1) * compare(cellValue(a, i), cellValue(b, i));
        }).forEach(function (row) { body.appendChild(row); });
      });
      if (FILTERS.indexOf(th.textContent.trim()) < 0) { return; }
      var list = document.createElement("select"), seen = {};
      list.column = i;
      list.add(new Option("every " + th.textContent.trim(), ""));
      rows.forEach(function (row) { seen[cellValue(row, i).text] = true; });
      Object.keys(seen).sort().forEach(function (v) { list.add(new Option(v, v)); });
      list.addEventListener("change", apply);
      lists.push(list);
      bar.appendChild(list);
    });
    box.addEventListener("input", apply);
    table.parentNode.insertBefore(bar, table);
  }

  document.querySelectorAll("table").forEach(setupTable);
  var figures = document.querySelectorAll(".hoop-figure");
  window.hoopDrawAll = function () {
    return Promise.all(Array.prototype.map.call(figures, draw));
  };
  var seen = new IntersectionObserver(function (entries) {
    entries.forEach(function (e) { if (e.isIntersecting) { draw(e.target); } });
  }, { rootMargin: "400px" });
  figures.forEach(function (div) { seen.observe(div); });
})();
"""
