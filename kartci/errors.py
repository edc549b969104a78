"""One error base class; the CLI turns any of these into one line on stderr and exit code 2."""


class KartciError(Exception):
    """Base of every error kartci reports to a user (bad input or a failed run)."""


class SpecError(KartciError):
    """A scenario, world or model file is missing, malformed or has a bad value."""


class LogError(KartciError):
    """A log (ROS 1 bag, rosbag2 directory, MCAP file) cannot be read or lacks what is needed."""


class RunError(KartciError):
    """A simulation run failed (a NaN state, a controller exception, a time limit)."""


class BaselineError(KartciError):
    """A baseline file is malformed or cannot be written."""
