"""Deprecated: the scenario model is `kartci.scenario` ("spec" read as "test specification").

Every name here and in the submodules is `kartci.scenario`'s own object, so code written against
the old path keeps working. Nothing in kartci imports this package.
"""

from kartci.scenario import *  # noqa: F403
from kartci.scenario import __all__ as __all__
