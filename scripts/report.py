#!/usr/bin/env python3
"""Self-contained HTML pages for an instructor from `scalpelsim replay` output folders.

    python3 scripts/report.py --out HTML_DIR SESSION_DIR [SESSION_DIR ...]

A page per session (report.json, frames.csv and the pictures, docs/formats.md "Replay report"),
and with several sessions (one trainee's attempts, in order) progress.html. Images are embedded,
so a page can be mailed on its own. Exit status: 0 written, 2 bad input, 3 matplotlib missing.
"""
import argparse
import base64
import csv
import html
import io
import json
import math
import os
import sys

try:
    import matplotlib
    matplotlib.use("Agg")
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.patches import Circle, Polygon
    from matplotlib.transforms import ScaledTranslation
except ImportError:
    sys.stderr.write("report.py: matplotlib is missing: install python3-matplotlib "
                     "(apt install python3-matplotlib)\n")
    sys.exit(3)

# Same input, same bytes: no random SVG ids, no version stamp in the PNGs.
matplotlib.rcParams.update({"svg.hashsalt": "scalpelsim-report", "font.size": 10,
                            "axes.titlesize": 11, "axes.grid": True, "grid.alpha": 0.3})
PNG_META = {"Software": None}
DPI = 110
DEFAULT_PASS_SCORE = 70.0  # task.pass.score's default (config/scenarios/README.md)
FRAME_COLUMNS = ("t", "tip_x", "tip_y", "in_tissue", "material_depth", "incision", "path_s",
                 "speed", "hand_force", "cutting")
PICTURES = (("top.png", "straight down: the target line, its tolerance band, wound and blade"),
            ("oblique.png", "from in front of the target line and above"),
            ("section.png", "cut across the middle of the target line: the layers, the wound"))
COLOURS = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b")
MM = 1000.0  # the files are in metres; instructors read millimetres


class BadInput(Exception):
    """Input the script cannot use; the message names the file and the problem."""


# --- Reading ---

def is_number(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool)


TYPES = {"number": is_number, "bool": lambda v: isinstance(v, bool),
         "str": lambda v: isinstance(v, str), "list": lambda v: isinstance(v, list)}
# The fields of report.json's task that the pages use ("?": may be null).
COMPONENT = {"name": "str", "value": "number", "unit": "str", "threshold": "number?",
             "pass_when": "str", "passed": "bool", "points": "number", "points_max": "number",
             "why": "str"}
INCISION = {"path": "list", "path_length": "number", "tolerance": "number", "coverage": "number",
            "lateral_deviation": {"mean": "number", "max": "number", "frechet": "number"},
            "depth": {k: "number" for k in ("max", "mean", "in_band", "min_accepted",
                                            "max_accepted")},
            "bevel_deg": {"mean": "number", "max": "number"}, "strokes": "number",
            "hesitations": "number"}
TASK = {"score": "number", "passed": "bool", "components": "list", "incisions": "list"}


def check(obj, spec, where):
    """Raise BadInput naming the first field of obj that does not match spec."""
    if not isinstance(obj, dict):
        raise BadInput(f"{where}: should be a JSON object")
    for key, kind in spec.items():
        if key not in obj:
            raise BadInput(f"{where}: missing '{key}'")
        v = obj[key]
        if isinstance(kind, dict):
            check(v, kind, f"{where}.{key}")
        elif not (v is None and kind.endswith("?")) and not TYPES[kind.rstrip("?")](v):
            raise BadInput(f"{where}: '{key}' should be a {kind.rstrip('?')}, "
                           f"not {json.dumps(v)[:40]}")


def check_task(task, path):
    check(task, TASK, f"{path}: task")
    for i, c in enumerate(task["components"]):
        check(c, COMPONENT, f"{path}: task.components[{i}]")
    for i, inc in enumerate(task["incisions"]):
        where = f"{path}: task.incisions[{i}]"
        check(inc, INCISION, where)
        if len(inc["path"]) < 2 or not all(isinstance(p, list) and len(p) == 3
                                           and all(map(is_number, p)) for p in inc["path"]):
            raise BadInput(f"{where}: 'path' should be a list of at least two [x, y, z] points")


def read_report(folder):
    path = os.path.join(folder, "report.json")
    if not os.path.isfile(path):
        raise BadInput(f"{path}: missing (is {folder} a `scalpelsim replay` output folder?)")
    try:
        with open(path, encoding="utf-8") as f:
            report = json.load(f)
    except json.JSONDecodeError as e:
        raise BadInput(f"{path}: not valid JSON: {e}")
    except (OSError, UnicodeDecodeError) as e:
        raise BadInput(f"{path}: cannot be read: {e}")
    if not isinstance(report, dict):
        raise BadInput(f"{path}: should hold a JSON object")
    if report.get("task") is not None:
        check_task(report["task"], path)
    return report


def read_frames(folder):
    """frames.csv as {column: [float, ...]}; None when the folder has none."""
    path = os.path.join(folder, "frames.csv")
    if not os.path.isfile(path):
        return None
    try:
        with open(path, encoding="utf-8", newline="") as f:
            rows = list(csv.reader(f))
    except (OSError, UnicodeDecodeError, csv.Error) as e:
        raise BadInput(f"{path}: cannot be read: {e}")
    if not rows:
        raise BadInput(f"{path}: empty, no header line")
    header = [h.strip() for h in rows[0]]
    missing = [c for c in FRAME_COLUMNS if c not in header]
    if missing:
        raise BadInput(f"{path}: header lacks column(s) {', '.join(missing)}")
    index = {c: header.index(c) for c in FRAME_COLUMNS}
    frames = {c: [] for c in FRAME_COLUMNS}
    for line, row in enumerate(rows[1:], start=2):
        if len(row) != len(header):
            raise BadInput(f"{path}: line {line}: {len(row)} fields, the header has {len(header)}")
        for c, i in index.items():
            if c == "material_depth" and row[i] == "":
                frames[c].append(0.0)  # the tip not located in the tissue: no depth (plotted as such)
                continue
            try:
                v = float(row[i])
            except ValueError:
                v = math.inf
            if not math.isfinite(v):
                raise BadInput(f"{path}: line {line}: column '{c}': {row[i]!r} is not a number")
            frames[c].append(v)
    return frames if frames["t"] else None


def read_session(folder):
    if not os.path.isdir(folder):
        raise BadInput(f"{folder}: no such folder")
    pictures = []
    for name, caption in PICTURES:
        if os.path.isfile(os.path.join(folder, name)):
            with open(os.path.join(folder, name), "rb") as f:
                data = f.read()
            if data.startswith(b"\x89PNG\r\n\x1a\n"):  # embed only what a browser will show
                pictures.append((name, caption, data))
    return {"name": os.path.basename(os.path.abspath(folder)), "report": read_report(folder),
            "frames": read_frames(folder), "pictures": pictures}


def task_of(session):
    return session["report"].get("task")


def components_of(session):
    return (task_of(session) or {}).get("components", [])


# --- Plots ---

def new_figure(w, h, rows=1):
    fig = Figure(figsize=(w, h), dpi=DPI)
    FigureCanvasAgg(fig)
    return fig, fig.subplots(rows, 1, sharex=True)


def png(fig):
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=DPI, metadata=PNG_META, bbox_inches="tight",
                pad_inches=0.1)
    return buf.getvalue()


def legend_below(ax):
    """A legend under the axes' labels, where it hides no data."""
    if ax.get_legend_handles_labels()[0]:
        below_labels = ScaledTranslation(0, -0.5, ax.figure.dpi_scale_trans)
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, 0), ncol=4, fontsize=9,
                  bbox_transform=ax.transAxes + below_labels, frameon=False)


def runs(flags):
    """(start, end) index pairs of consecutive true flags, end exclusive."""
    out, start = [], None
    for i, f in enumerate(list(flags) + [False]):
        if f and start is None:
            start = i
        elif not f and start is not None:
            out.append((start, i))
            start = None
    return out


def band_patches(path_mm, half_width, colour):
    """The points within half_width of the polyline (xy): segment rectangles and round joins."""
    patches = [Circle(p, half_width) for p in path_mm]
    for (x0, y0), (x1, y1) in zip(path_mm, path_mm[1:]):
        length = math.hypot(x1 - x0, y1 - y0) or 1.0
        nx, ny = -(y1 - y0) / length * half_width, (x1 - x0) / length * half_width
        patches.append(Polygon([(x0 + nx, y0 + ny), (x1 + nx, y1 + ny),
                                (x1 - nx, y1 - ny), (x0 - nx, y0 - ny)]))
    for p in patches:  # opaque and light, so that overlaps do not darken
        p.set(facecolor=colour, edgecolor="none", zorder=1)
    return patches


def plot_top_view(frames, incisions):
    x = [v * MM for v in frames["tip_x"]]
    y = [v * MM for v in frames["tip_y"]]
    inside = runs(v > 0 for v in frames["in_tissue"])
    xs = [x[i] for a, b in inside for i in range(a, b)] or x[:1]  # what must be in view
    ys = [y[i] for a, b in inside for i in range(a, b)] or y[:1]
    for inc in incisions:
        tol = inc["tolerance"] * MM
        xs += [p[0] * MM + d for p in inc["path"] for d in (-tol, tol)]
        ys += [p[1] * MM + d for p in inc["path"] for d in (-tol, tol)]
    span_x, span_y = max(xs) - min(xs) + 2, max(ys) - min(ys) + 2
    # equal scaling: size the axes to the data's shape, within reason for the page
    fig, ax = new_figure(8, min(5.5, max(1.1, 6.8 * span_y / span_x)) + 1.4)
    for k, inc in enumerate(incisions):
        path = [(p[0] * MM, p[1] * MM) for p in inc["path"]]
        for patch in band_patches(path, inc["tolerance"] * MM, "#d5ecf7"):
            ax.add_patch(patch)
        ax.plot(*zip(*path), color="#2b8cbe", lw=1.2, ls="--", zorder=2,
                label="target ± tolerance" if k == 0 else None)
        ax.annotate(str(k + 1), path[0], xytext=(-14, 8), textcoords="offset points",
                    color="#2b8cbe", fontweight="bold")
    for n, (a, b) in enumerate(inside):
        ax.plot(x[a:b], y[a:b], color="#222222", lw=1.0, zorder=3,
                label="tip in the tissue" if n == 0 else None)
    cut = [i for i, v in enumerate(frames["cutting"]) if v > 0]
    if cut:
        ax.plot([x[i] for i in cut], [y[i] for i in cut], "o", ms=2.5, color="#e6550d",
                zorder=4, label="frames cutting")
    ax.set_xlim(min(xs) - 1, max(xs) + 1)
    ax.set_ylim(min(ys) - 1, max(ys) + 1)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set(xlabel="x [mm]", ylabel="y [mm]", title="Top view: the tip over the target")
    legend_below(ax)
    return png(fig)


def plot_depth(frames, incisions):
    fig, ax = new_figure(8, 3.6)
    bands = {(inc["depth"]["min_accepted"], inc["depth"]["max_accepted"]) for inc in incisions}
    deepest = 0.0
    for k, inc in enumerate(incisions):
        colour = COLOURS[k % len(COLOURS)]
        lo, hi = inc["depth"]["min_accepted"] * MM, inc["depth"]["max_accepted"] * MM
        if len(bands) > 1 or k == 0:  # one grey band when all incisions share it
            ax.fill_between([0, max(i["path_length"] for i in incisions) * MM if len(bands) == 1
                             else inc["path_length"] * MM], lo, hi, lw=0, alpha=0.2,
                            color="#999999" if len(bands) == 1 else colour,
                            label="accepted depth" + ("" if len(bands) == 1 else f" ({k + 1})"))
        deepest = max(deepest, hi)
        # frames cutting this incision; a depth of 0 in the tissue means not located there
        idx = [i for i in range(len(frames["t"])) if frames["incision"][i] == k
               and frames["in_tissue"][i] > 0 and frames["cutting"][i] > 0
               and frames["material_depth"][i] > 0]
        if idx:
            s = [frames["path_s"][i] * MM for i in idx]
            d = [frames["material_depth"][i] * MM for i in idx]
            deepest = max(deepest, max(d))
            for a, b in runs(frames["in_tissue"][i] > 0 for i in range(len(frames["t"]))):
                # the order within one pass under the surface, faintly
                part = [n for n, i in enumerate(idx) if a <= i < b]
                ax.plot([s[n] for n in part], [d[n] for n in part], "-", lw=0.7, alpha=0.4,
                        color=colour)
            ax.plot(s, d, "o", ms=3.5, color=colour, label=f"incision {k + 1}")
    ax.set_ylim(deepest * 1.15 + 0.1, 0)  # depth grows downwards, the surface on top
    ax.set(xlabel="along the target path [mm]", ylabel="depth in the tissue [mm]",
           title="Depth of the tip while cutting (the tissue's own measure)")
    legend_below(ax)
    return png(fig)


def plot_force_speed(frames):
    fig, (top, bottom) = new_figure(8, 4.8, rows=2)
    t = frames["t"]
    force, speed = frames["hand_force"], [v * MM for v in frames["speed"]]
    top.plot(t, force, color="#6a3d9a", lw=1.0)
    bottom.plot(t, speed, color="#33a02c", lw=1.0)
    top.set_ylim(0, max(max(force) * 1.1, 0.1))  # a flat 0 N still gets a readable axis
    bottom.set_ylim(0, max(max(speed) * 1.1, 1.0))
    dt = t[1] - t[0] if len(t) > 1 else 0.0
    for ax in (top, bottom):
        for n, (a, b) in enumerate(runs(v > 0 for v in frames["in_tissue"])):
            # a frame's time is its end: the span starts at the frame before
            ax.axvspan(t[a] - dt, t[b - 1], color="#fdd0a2", alpha=0.6, lw=0,
                       label="tip in the tissue" if n == 0 else None)
    top.set(ylabel="force on the hand [N]", title="Force on the hand and tip speed")
    bottom.set(ylabel="tip speed [mm/s]", xlabel="time [s]")
    legend_below(bottom)
    return png(fig)


def plot_progress_score(sessions, pass_score):
    fig, ax = new_figure(8, 3.4)
    xs = list(range(1, len(sessions) + 1))
    scores = [task_of(s)["score"] if task_of(s) else math.nan for s in sessions]
    ax.plot(xs, scores, color="#555555", lw=1.2, zorder=2)
    for x, s, score in zip(xs, sessions, scores):
        if task_of(s):
            ax.plot(x, score, "o", ms=8, zorder=3,
                    color="#2ca02c" if task_of(s)["passed"] else "#d62728")
    ax.axhline(pass_score, color="#d62728", ls="--", lw=1.0, label=f"pass: {pass_score:g}")
    ax.set(xticks=xs, xlim=(0.5, len(xs) + 0.5), ylim=(0, 105), xlabel="attempt",
           ylabel="score [points of 100]",
           title="Score over attempts (green: passed, red: not passed)")
    ax.legend(loc="lower right", fontsize=9)
    return png(fig)


def plot_progress_components(sessions):
    most = {}  # scored components in order of appearance, with their maximum
    for s in sessions:
        for c in components_of(s):
            if c["points_max"] > 0:
                most.setdefault(c["name"], c["points_max"])
    if not most:
        return None
    cols = min(5, len(most))
    nrows = (len(most) + cols - 1) // cols
    fig = Figure(figsize=(9, 1.9 * nrows + 0.6), dpi=DPI)
    FigureCanvasAgg(fig)
    xs = list(range(1, len(sessions) + 1))
    for n, name in enumerate(most):
        ax = fig.add_subplot(nrows, cols, n + 1)
        ys = []
        for s in sessions:
            c = next((c for c in components_of(s) if c["name"] == name), None)
            ok = c is not None and c["points_max"] > 0
            ys.append(100.0 * c["points"] / c["points_max"] if ok else math.nan)
        ax.plot(xs, ys, "o-", ms=4, lw=1.0, color="#1f77b4")
        ax.set_title(f"{name} (of {most[name]:g})", fontsize=10)
        ax.set(ylim=(-5, 105), xlim=(0.5, len(xs) + 0.5), xticks=xs)
        ax.tick_params(labelsize=8)
        if n % cols == 0:
            ax.set_ylabel("% of its points", fontsize=9)
        if n >= len(most) - cols:
            ax.set_xlabel("attempt", fontsize=9)
    fig.suptitle("Each component's points as a share of its maximum", fontsize=11)
    fig.tight_layout()
    return png(fig)


# --- HTML ---

CSS = """body { font-family: "DejaVu Sans", Arial, sans-serif; font-size: 15px; color: #222;
  max-width: 980px; margin: 24px auto; padding: 0 16px; line-height: 1.4; }
h1 { font-size: 24px; margin: 0 0 4px 0; } .sub, .note { color: #555; font-size: 14px; }
h2 { font-size: 19px; margin: 28px 0 8px 0; border-bottom: 1px solid #ccc; padding-bottom: 3px; }
.head { display: flex; align-items: center; gap: 28px; margin: 14px 0; }
.score { font-size: 54px; font-weight: bold; } .score small { font-size: 22px; color: #666; }
.badge { font-size: 20px; font-weight: bold; padding: 6px 16px; border-radius: 6px; color: #fff; }
.ok { background: #2e8b3a; } .bad { background: #c0392b; } .none { background: #777; }
table { border-collapse: collapse; width: 100%; font-size: 14px; margin: 6px 0; }
th, td { border: 1px solid #d0d0d0; padding: 4px 7px; text-align: left; vertical-align: top; }
th { background: #f0f0f0; } td.num { text-align: right; white-space: nowrap; }
tr.failed td { background: #fdecea; } .na { color: #999; }
.yes { color: #2e8b3a; font-weight: bold; } .no { color: #c0392b; font-weight: bold; }
figure { margin: 14px 0; } figure img { max-width: 100%; border: 1px solid #ddd; }
figcaption { font-size: 13px; color: #555; margin-top: 3px; }
.pics { display: grid; grid-template-columns: 1fr 1fr; gap: 12px; }
.warn { background: #fff4ce; border: 1px solid #e0c060; padding: 6px 12px; margin: 10px 0; }"""

UNITS = {"%": ("%", 1), "mm": (" mm", 2), "deg": ("°", 1), "count": ("", 0),
         "ratio": ("×", 2), "s": (" s", 2), "mm^2": (" mm²", 2)}
RELATIONS = {"value >= threshold": "≥", "value <= threshold": "≤", "value > threshold": ">",
             "value < threshold": "<", "value == threshold": "="}


def esc(v):
    return html.escape(str(v), quote=True)


def with_unit(v, unit):
    symbol, decimals = UNITS.get(unit, (" " + unit, 2))
    return f"{v:.{decimals}f}{symbol}"


def figure(data, caption):
    src = "data:image/png;base64," + base64.b64encode(data).decode("ascii")
    return (f'<figure><img alt="{esc(caption)}" src="{src}">'
            f"<figcaption>{esc(caption)}</figcaption></figure>")


def page(title, body):
    return (f'<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">\n'
            f'<meta name="viewport" content="width=device-width, initial-scale=1">\n'
            f"<title>{esc(title)}</title><style>{CSS}</style></head>\n"
            f"<body>\n{body}\n</body></html>\n")


def components_table(components):
    rows = []
    for c in components:
        value, threshold = with_unit(c["value"], c["unit"]), c["threshold"]
        if threshold is None:  # nothing to pass: not judged
            when, mark = '<span class="na">none</span>', '<span class="na">–</span>'
        else:
            rel, limit = RELATIONS.get(c["pass_when"]), esc(with_unit(threshold, c["unit"]))
            when = f"{rel} {limit}" if rel else f"{limit} ({esc(c['pass_when'])})"
            mark = '<span class="yes">✔</span>' if c["passed"] else '<span class="no">✘</span>'
        points = (f"{c['points']:.1f} / {c['points_max']:g}" if c["points_max"] > 0
                  else '<span class="na">not scored</span>')
        rows.append(f'<tr{"" if c["passed"] else " class=failed"}><td>{esc(c["name"])}</td>'
                    f'<td class="num">{esc(value)}</td><td class="num">{when}</td>'
                    f'<td class="num">{points}</td><td style="text-align:center">{mark}</td>'
                    f'<td>{esc(c["why"])}</td></tr>')
    return ("<table><tr><th>component</th><th>value</th><th>pass when</th><th>points</th>"
            "<th>passed</th><th>why points were lost</th></tr>" + "".join(rows) + "</table>")


def incisions_table(incisions):
    head = ("<tr><th>#</th><th>length [mm]</th><th>tolerance [mm]</th><th>coverage</th>"
            "<th>deviation mean / max [mm]</th><th>Fréchet [mm]</th>"
            "<th>depth mean / max [mm]</th><th>accepted depth [mm]</th><th>depth in band</th>"
            "<th>bevel mean / max</th>"
            "<th>strokes</th><th>hesi&shy;tations</th></tr>")
    rows = []
    for k, inc in enumerate(incisions):
        lat, dep, bev = inc["lateral_deviation"], inc["depth"], inc["bevel_deg"]
        cells = [k + 1, f"{inc['path_length'] * MM:.1f}", f"{inc['tolerance'] * MM:.2f}",
                 f"{inc['coverage'] * 100:.0f}%",
                 f"{lat['mean'] * MM:.2f} / {lat['max'] * MM:.2f}", f"{lat['frechet'] * MM:.2f}",
                 f"{dep['mean'] * MM:.2f} / {dep['max'] * MM:.2f}",
                 f"{dep['min_accepted'] * MM:.2f}–{dep['max_accepted'] * MM:.2f}",
                 f"{dep['in_band'] * 100:.0f}%", f"{bev['mean']:.1f}° / {bev['max']:.1f}°",
                 f"{inc['strokes']:g}", f"{inc['hesitations']:g}"]
        rows.append("<tr>" + "".join(f'<td class="num">{esc(c)}</td>' for c in cells) + "</tr>")
    return "<table>" + head + "".join(rows) + "</table>"


def key_figures(task):
    force = task.get("hand_force_while_cutting") or {}
    items = [("time with the tip in the tissue", task.get("time_in_tissue"), 1, "s"),
             ("tip path in the tissue", task.get("path_in_tissue"), MM, "mm"),
             ("targets' length", task.get("targets_length"), MM, "mm"),
             ("force on the hand while cutting, mean", force.get("mean"), 1, "N"),
             ("force on the hand while cutting, max", force.get("max"), 1, "N"),
             ("cut surface (one lip)", task.get("cut_area"), MM * MM, "mm²"),
             ("of it outside every tolerance band", task.get("collateral_area"), MM * MM, "mm²"),
             ("of it in protected tissue", task.get("protected_area"), MM * MM, "mm²")]
    rows = "".join(f"<tr><th>{esc(label)}</th><td class='num'>{v * scale:.2f} {unit}</td></tr>"
                   for label, v, scale, unit in items if is_number(v))
    return f"<table style='width:auto'>{rows}</table>" if rows else ""


def session_page(session, progress_link=None):
    task, frames = task_of(session), session["frames"]
    incisions = task["incisions"] if task else []
    inputs = session["report"].get("inputs") or {}
    title = inputs.get("scenario_name") or session["name"]
    body = [f"<h1>{esc(title)}</h1><div class='sub'>session <code>{esc(session['name'])}</code>"
            f" · log <code>{esc(inputs.get('log', '?'))}</code>"
            f" · scenario <code>{esc(inputs.get('scenario', '?'))}</code>"
            + (f" · <a href='{esc(progress_link)}'>all attempts</a>" if progress_link else "")
            + "</div><div class='head'>"]
    warnings = [w for w in session["report"].get("warnings") or [] if isinstance(w, dict)]
    if warnings:  # the replay doubts its own figures: say so beside the score
        body.append("<div class='warn'><b>Warnings of the replay</b> (the figures may mislead):"
                    "<ul>" + "".join(f"<li><code>{esc(w.get('code', '?'))}</code>: "
                                     f"{esc(w.get('message', ''))}</li>" for w in warnings)
                    + "</ul></div>")
    if task:
        body[0] += (f"<div class='score'>{task['score']:.1f}<small> / 100</small></div>"
                    + ("<span class='badge ok'>PASSED</span></div>" if task["passed"]
                       else "<span class='badge bad'>NOT PASSED</span></div>"))
        body += ["<h2>Components</h2>", components_table(task["components"]),
                 "<h2>Incisions</h2>", incisions_table(incisions), key_figures(task)]
    else:
        body[0] += ("<span class='badge none'>NOT SCORED</span><span class='note'>The scenario "
                    "has no task, so there is no score; the tool's motion is below.</span></div>")
    body.append("<h2>The tool's motion</h2>")
    if frames is None:
        body.append("<p class='note'>No frames in frames.csv (or no frames.csv): "
                    "the tool's motion cannot be plotted.</p>")
    else:
        body.append(figure(plot_top_view(frames, incisions),
                           "The tip's path in the tissue seen from above (where it was, world "
                           "coordinates)" + (" over each numbered target and its tolerance band "
                                             "(as drawn on the tissue at rest)" if incisions
                                             else "") + ". Orange dots: frames in which the blade was cutting."))
        if incisions:
            unknown = sum(1 for i in range(len(frames["t"])) if frames["in_tissue"][i] > 0
                          and frames["cutting"][i] > 0 and frames["material_depth"][i] <= 0)
            body.append(figure(plot_depth(frames, incisions),
                               "Depth of the tip below the surface in the tissue's own measure "
                               "(the one the task's band is compared with) at the frames in "
                               "which the blade was cutting, against the position along the target it "
                               "was nearest to; the faint line joins them in time order within "
                               "each pass under the surface."
                               + (f" Left out: {unknown} cutting frame(s) whose depth in this "
                                  "measure is recorded as 0." if unknown else "")))
        body.append(figure(plot_force_speed(frames),
                           "The force the hand pushes against (the tissue's resistance to the "
                           "blade) and the tip's speed; shaded: the tip under the surface."))
    if session["pictures"]:
        body.append("<h2>The renderer's pictures</h2><div class='pics'>")
        body += [figure(data, f"{name}: the final state {caption}.")
                 for name, caption, data in session["pictures"]]
        body.append("</div>")
    return page(f"{title}: {session['name']}", "\n".join(body))


def progress_page(sessions, pages):
    # the least passing score, task.pass_score in the report (the last attempt's scenario)
    threshold = next((float(task_of(s)["pass_score"]) for s in reversed(sessions)
                      if task_of(s) and "pass_score" in task_of(s)), DEFAULT_PASS_SCORE)
    rows = []
    for n, (s, link) in enumerate(zip(sessions, pages), start=1):
        task, inputs = task_of(s), s["report"].get("inputs") or {}
        if task:
            score = f"{task['score']:.1f}"
            result = ('<span class="yes">passed</span>' if task["passed"]
                      else '<span class="no">not passed</span>')
            failed = ", ".join(c["name"] for c in task["components"] if not c["passed"]) or "–"
        else:
            score, result, failed = "–", '<span class="na">no task</span>', "–"
        rows.append(f"<tr><td class='num'>{n}</td><td><a href='{esc(link)}'>{esc(s['name'])}</a>"
                    f"</td><td>{esc(inputs.get('scenario_name', '?'))}</td>"
                    f"<td class='num'>{score}</td><td>{result}</td><td>{esc(failed)}</td></tr>")
    body = ["<h1>Progress over attempts</h1>",
            f"<div class='sub'>{len(sessions)} attempts, in the order given. A session passes "
            f"when every component with a threshold meets it and the score reaches "
            f"{threshold:g}.</div>",
            "<h2>Attempts</h2><table><tr><th>attempt</th><th>session</th><th>scenario</th>"
            "<th>score</th><th>result</th><th>components not passed</th></tr>"
            + "".join(rows) + "</table>",
            "<h2>Score</h2>", figure(plot_progress_score(sessions, threshold),
                                     "The score of each attempt; dashed: the pass score.")]
    parts = plot_progress_components(sessions)
    if parts:
        body += ["<h2>Components</h2>",
                 figure(parts, "Points of each scored component as a share of its maximum.")]
    return page("Progress over attempts", "\n".join(body))


def page_names(sessions):
    """File names per session; folders of the same name get -2, -3, ..., never progress.html."""
    used, names = {"progress"}, []
    for s in sessions:
        name = base = s["name"] or "session"
        n = 1
        while name in used:
            n += 1
            name = f"{base}-{n}"
        used.add(name)
        names.append(name + ".html")
    return names


def main(argv):
    parser = argparse.ArgumentParser(
        prog="report.py", description="Write HTML pages about `scalpelsim replay` sessions.")
    parser.add_argument("--out", required=True, metavar="HTML_DIR", help="folder for the pages")
    parser.add_argument("sessions", nargs="+", metavar="SESSION_DIR",
                        help="replay output folders, attempts in order")
    args = parser.parse_args(argv)
    try:
        # Read everything first, so bad input leaves no half-written pages behind.
        sessions = [read_session(d) for d in args.sessions]
        os.makedirs(args.out, exist_ok=True)
    except BadInput as e:
        sys.stderr.write(f"report.py: {e}\n")
        return 2
    except OSError as e:  # also a file where the folder should be
        sys.stderr.write(f"report.py: {args.out}: cannot make the folder: {e.strerror}\n")
        return 2
    names = page_names(sessions)
    several = len(sessions) > 1
    outputs = [(n, session_page(s, "progress.html" if several else None))
               for n, s in zip(names, sessions)]
    if several:
        outputs.append(("progress.html", progress_page(sessions, names)))
    for name, text in outputs:
        path = os.path.join(args.out, name)
        with open(path, "w", encoding="utf-8") as f:
            f.write(text)
        print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
