"""`python -m kartci.cli`: an alias of `python -m kartci` (pinned the same way), run by name so
that the command's entry point stays above the CLI it starts."""

import runpy

runpy.run_module("kartci", run_name="__main__", alter_sys=True)
