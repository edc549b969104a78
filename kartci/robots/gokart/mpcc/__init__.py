"""Model predictive contouring control for the go-kart: model, NLP, compiled-solver cache,
per-stage references with obstacles, and the solve loop.

Nothing is re-exported here: the controller's parameter model (`mpcc.params`) is imported with
every registry, and importing the solver with it would bring CasADi (0.1 s) to every command.
Import from the modules (`mpcc.controller`, `mpcc.reference`)."""
