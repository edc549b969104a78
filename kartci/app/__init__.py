"""The workflows the CLI, the Python API and the pytest plugin share (accepting baselines,
comparing two runs), so that each is written once: `cli/` parses and prints, `kartci.api`
documents and forwards, the pytest plugin maps them to options and fixtures."""
