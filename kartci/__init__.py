"""kartci: record-and-replay CI harness for racing-kart and mobile-robot controllers."""

from kartci.errors import KartciError

__all__ = ["KartciError"]
__version__ = "0.1.0"
