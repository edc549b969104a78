"""`python -m kartci.cli`."""

from kartci.cli import main

main()
