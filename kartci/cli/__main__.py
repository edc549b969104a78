"""`python -m kartci.cli`: the command, pinned as `kartci` is (kartci.__main__)."""

from kartci.__main__ import main

main()
