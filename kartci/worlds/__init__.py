"""kartci's own world kinds, one package each (`hall`, `circuit`, `line_lab`; `track` holds what
the worlds around a closed race track share), registered through the `kartci.worlds` entry point
like any team's: each package holds its parameters, its simulated world and its geometry, and
exports its `WorldKind` as `WORLD`."""
