"""Sphinx configuration of kartci's documentation site.

Why Sphinx + MyST + furo: pages stay Markdown (as README.md and docs/tutorial.md are), while
Sphinx gives what the reference needs from the code itself: autodoc over the docstrings, and
small directives of our own (`_ext/kartci_docs.py`) over the command line (typer's click
group; sphinx-click rejects typer's vendored click), the metric registry, the scenario,
profile and project JSON Schemas and the built-in scenarios. rosbags and Gymnasium, tools
kartci's users already read, use the same stack. Build strictly:

    sphinx-build -W --keep-going -n -b html docs OUT

(`-n`: a reference to anything that does not exist fails the build.)
"""

from __future__ import annotations

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "_ext"))
sys.path.insert(0, str(HERE.parent))  # kartci from this checkout, even when not installed

import kartci  # noqa: E402  (after the path: the checkout's kartci, not another install)

project = "kartci"
author = "kartci's authors"
copyright = "kartci's authors, Apache-2.0"
release = version = kartci.__version__

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",  # the docstrings' Google-style Args: / Returns: / Raises:

    "kartci_docs",
]
myst_enable_extensions = ["colon_fence", "deflist"]
myst_heading_anchors = 3  # [text](page.md#a-heading) links, checked like any reference
source_suffix = {".md": "markdown"}
smartquotes = False  # names, paths and quotes read as typed (and as the tests grep them)
exclude_patterns = ["_build", "_ext"]
root_doc = "index"

html_theme = "furo"
html_title = f"kartci {release}"
html_static_path: list[str] = []

autodoc_member_order = "bysource"
autodoc_typehints = "description"
autodoc_typehints_format = "short"
autodoc_typehints_description_target = "documented"  # types of what a docstring describes
# Types from other packages are not linked: the build runs offline (no intersphinx), so each
# is named here instead of failing the nitpicky build. kartci's own types must resolve.
nitpick_ignore_regex = [
    ("py:.*", r"(numpy|np|pandas|pd|pydantic|typer|click|collections|typing|pathlib|types|"
              r"enum|abc|dataclasses|datetime|rosbags|pybullet|casadi|_pytest|pytest)\b.*"),
    ("py:class", r"(Path|Any|Callable|Iterator|Iterable|Mapping|Sequence|Self|T|P|"
                 r"NoneType|BaseModel|FieldInfo|ConfigDict|Enum|StrEnum|Protocol)"),
]
