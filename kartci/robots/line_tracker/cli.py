"""The line tracker's own commands (entry points `kartci.commands`): `kartci characterise`,
its sensor characterisation, and `kartci study`, the source document's study figures from its grid
runs."""

from __future__ import annotations

import csv
import io
from pathlib import Path
from typing import Annotated

import typer

from kartci.atomic import check_target, write_text_atomic
from kartci.command_options import (
    AllowOutsideOpt,
    OutOpt,
    SetOpt,
    command_project,
    out_console,
    out_dir,
)
from kartci.errors import SpecError
from kartci.scenario import load_scenario

app = typer.Typer(rich_markup_mode=None)  # help shown as written, as kartci's own commands


@app.command()
def characterise(
    out: OutOpt = None,
    scenario: Annotated[str, typer.Option(help="Scenario whose robot and world are used.")]
    = "line_straight",
    fovs: Annotated[str, typer.Option(help="Fields of view to compare, rad, comma-separated.")]
    = "0.5,0.75,1.0,1.2,1.4,1.5,2.0",
    step_m: Annotated[float, typer.Option(help="Offset step of the sweep, m.")] = 0.0005,
    set_: SetOpt = None,
    allow_outside_paths: AllowOutsideOpt = False,
) -> None:
    """Sweep the line tracker across the line and characterise its sensor (source document, Fig.
    5.2.2.2, 6.3.1, 5.2.2.3): sweep.csv, fov_sweep.csv, characterisation.html, fitted slope."""
    # CLI start-up: numpy and the simulator load when the command runs, not on `kartci --help`
    import numpy as np

    from kartci.robots.line_tracker.characterise import sweep

    out = out_dir(out, "characterisation")
    spec = load_scenario(scenario, set_ or [], project=command_project(),
                         allow_outside_paths=allow_outside_paths)
    agent = next(iter(spec.agents))
    try:
        fov_list = [float(f) for f in fovs.split(",") if f.strip()]
    except ValueError as err:
        raise SpecError(f"--fovs {fovs!r}: expected comma-separated numbers") from err
    if not fov_list or not all(0.05 < f < 3.0 for f in fov_list):
        raise SpecError(f"--fovs {fovs!r}: each field of view must be in (0.05, 3.0) rad")
    if not 0 < step_m <= 0.005:
        raise SpecError(f"--step-m {step_m}: expected 0 < step <= 0.005")
    offsets = np.round(np.arange(-0.03, 0.03 + step_m / 2, step_m), 9)
    for name in ("sweep.csv", "fov_sweep.csv", "characterisation.html"):
        check_target(out / name)  # before the sweeps, not after them
    out.mkdir(parents=True, exist_ok=True)
    geo = sweep(spec, agent, offsets, mode="geometric")
    ren = sweep(spec, agent, offsets, mode="rendered")
    buf = io.StringIO(newline="")
    w = csv.writer(buf)
    w.writerow(["offset_m", "left", "right", "difference", "left_rendered",
                "right_rendered", "difference_rendered"])
    for i, d in enumerate(offsets):
        w.writerow([f"{d:.6f}", f"{geo.left[i]:.6f}", f"{geo.right[i]:.6f}",
                    f"{geo.difference[i]:.6f}", f"{ren.left[i]:.6f}", f"{ren.right[i]:.6f}",
                    f"{ren.difference[i]:.6f}"])
    write_text_atomic(out / "sweep.csv", buf.getvalue())
    fov_curves = {f: sweep(spec, agent, offsets, fov_rad=f, mode="geometric") for f in fov_list}
    buf = io.StringIO(newline="")
    w = csv.writer(buf)
    w.writerow(["offset_m", *[f"difference_fov_{x:g}" for x in fov_list]])
    for i, d in enumerate(offsets):
        w.writerow([f"{d:.6f}", *[f"{fov_curves[x].difference[i]:.6f}" for x in fov_list]])
    write_text_atomic(out / "fov_sweep.csv", buf.getvalue())
    slope, intercept, r2 = geo.fit()
    rslope, rintercept, rr2 = ren.fit()
    lines = [f"geometric: y = {slope:.2f} d + {intercept:.4f}  (R^2 {r2:.4f} over |d| <= 8 mm)",
             f"rendered:  y = {rslope:.2f} d + {rintercept:.4f}  (R^2 {rr2:.4f})",
             "source document (Eq. 6.12): y = 39.4022 d + 0.0036"]
    for x in fov_list:
        s, _, r = fov_curves[x].fit()
        lines.append(f"fov {x:g} rad: slope {s:.2f} /m, R^2 {r:.3f}")
    figs = [sensor_sweep(list(offsets), {"left": list(geo.left), "right": list(geo.right),
                                         "left - right": list(geo.difference),
                                         "left - right (rendered)": list(ren.difference)},
                         "camera outputs across the line (fov 1.2 rad)"),
            sensor_sweep(list(offsets), {f"fov {x:g} rad": list(c.difference)
                                         for x, c in fov_curves.items()},
                         "left - right for several fields of view")]
    html_text = ("<!doctype html><html><head><meta charset='utf-8'><title>line sensor "
                 "characterisation</title></head><body><h1>Line-sensor characterisation</h1><pre>"
                 + "\n".join(lines) + "</pre>" + "".join(figs) + "</body></html>\n")
    write_text_atomic(out / "characterisation.html", html_text)
    for line in lines:
        out_console.print(line, highlight=False)
    out_console.print(f"wrote {out}/sweep.csv, fov_sweep.csv, characterisation.html",
                      highlight=False)


def sensor_sweep(offsets_m: list[float], curves: dict[str, list[float]], title: str) -> str:
    """Line-sensor luminance curves against the sensor's lateral offset (mm), its ±8 mm range
    marked."""
    # CLI start-up: matplotlib and kartci's figure look (Agg) load to draw, not with kartci
    import matplotlib.pyplot as plt

    from kartci.plotstyle import finish

    fig, ax = plt.subplots(figsize=(5.5, 3.5))
    for label, ys in curves.items():
        ax.plot([o * 1000 for o in offsets_m], ys, lw=1.2, label=label)
    ax.axvline(-8, color="grey", ls="--", lw=0.8)
    ax.axvline(8, color="grey", ls="--", lw=0.8)
    return finish(fig, ax, "offset of the sensor from the line axis [mm]", "luminance", title)


@app.command()
def study(
    out: Annotated[Path, typer.Argument(help="A folder written by `kartci run` with the line "
                                              "tracker's grids in it.")],
) -> None:
    """Draw the source document's study figures (Figs. 7.1.2-7.1.4, Sec. 7.2) from the line
    tracker's grid runs in OUT (line_straight_grid, line_circle_grid, line_circle_edge_fast/slow):
    OUT/study.html, one SVG per figure."""
    # CLI start-up: matplotlib and the run folders' tables load when the command runs
    from kartci.robots.line_tracker import figures
    from kartci.robots.line_tracker import study as st

    if not out.is_dir():
        raise SpecError(f"{out}: no such folder; run the grids first (`kartci run "
                        "line_straight_grid line_circle_grid --out OUT`)")
    check_target(out / "study.html")
    svgs: list[str] = []
    names = [p.name.partition("@")[0] for p in out.iterdir() if "@" in p.name]
    if "line_straight_grid" in names:
        panels = st.straight_panels(st.grid(out, "line_straight_grid"))
        svgs += [figures.responses(p) for p in panels if p.curves]
    if "line_circle_grid" in names:
        svgs += [figures.circle_distance(p)
                 for p in st.circle_panels(st.grid(out, "line_circle_grid"))]
    edge = [c for n in ("line_circle_edge_fast", "line_circle_edge_slow") if n in names
            for c in st.grid(out, n)]
    if edge:
        svgs += [figures.circle_distance(p) for p in st.circle_panels(edge)]
    if not svgs:
        raise SpecError(f"{out}: no line-tracker grid runs in it (line_straight_grid@..., "
                        "line_circle_grid@..., line_circle_edge_*@...)")
    html_text = ("<!doctype html><html><head><meta charset='utf-8'><title>line tracker study"
                 "</title></head><body><h1>The source document's study, run by kartci</h1>"
                 + "".join(svgs) + "</body></html>\n")
    write_text_atomic(out / "study.html", html_text)
    out_console.print(f"wrote {out}/study.html ({len(svgs)} figures)", highlight=False)
