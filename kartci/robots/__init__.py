"""kartci's own robot kinds, each a package like a team's would be: parameters and sensors
(`params`), the simulated robot (`robot`, `body`), its metric sets (`metrics`, over the engine
in `kartci.metrics`), and what its reports draw (`plots`)."""
