"""kartci's own robot kinds, each a package like a team's would be: parameters and sensors
(`params`), the simulated robot (`robot`, `body`), its metric sets (`metrics`, over the engine
in `kartci.metrics`), what its reports draw (`plots`), its controllers (`controllers` registers
them) and, for the line tracker, its own commands (`cli`). Nothing outside this package imports
or names a kind: the rest of kartci asks the registered `RobotKind`."""
