"""`kartci map`: a world's point-cloud map from a mapping run of the simulated lidar."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from kartci import project
from kartci.atomic import check_target
from kartci.cli.common import app, out_console
from kartci.scenario.load import load_world


@app.command("map")
def map_(
    world: Annotated[str, typer.Argument(help="World file name on the search path, e.g. "
                                         "winti/hall.")],
    out: Annotated[Path | None, typer.Option(help="PLY file to write; default: beside the "
                                             "world file, <world>_map.ply.")] = None,
    lidar: Annotated[str, typer.Option(help="Lidar model of the mapping run.")] = "vlp16",
    step_m: Annotated[float, typer.Option(help="Scan spacing along the track, m.")] = 1.0,
    voxel_m: Annotated[float, typer.Option(help="Voxel size of the map, m.")] = 0.2,
    seed: Annotated[int, typer.Option(help="Seed of the range noise.")] = 0,
) -> None:
    """Build a world's point-cloud map (PLY, world frame, m) from a mapping run of the simulated
    lidar along its track: the map a localization node registers scans against."""
    from kartci.worlds.track.mapping import (  # CLI start-up: PyBullet, scipy (+0.8 s)
        MapRun,
        save_map,
    )

    params, path = load_world(world, project.current())
    target = out if out is not None else path.with_name(f"{path.stem}_map.ply")
    check_target(target)  # before the mapping run
    n = save_map(params, world, target, MapRun(lidar, step_m, 1.0, voxel_m, seed))
    out_console.print(f"{target}: {n} points")
