"""One error tree for the whole project (like python-can's ``CanError`` family).

Everything rtctl, its drivers and the simulator raise on purpose derives from
:class:`RtctlError`, so a caller can catch the family and the CLI can turn it into a
clear message and an exit code instead of a traceback.
"""


# The process's exit codes (the CLI's module doc says when each is used).
EXIT_OK, EXIT_BUG, EXIT_CONFIG, EXIT_FAULT, EXIT_HARDWARE, EXIT_RT, EXIT_SOCKET = range(7)


class RtctlError(Exception):
    """Base of every error rtctl raises on purpose."""


class ModelError(RtctlError):
    """A robot description is malformed or inconsistent (DH table, URDF, parameters)."""


class KinematicsError(RtctlError):
    """A kinematic query has no answer (unreachable pose, IK did not converge)."""


class ConfigError(RtctlError):
    """A configuration file is invalid; names the file, the key path (empty: the file as a
    whole) and what was expected or what is wrong."""

    def __init__(self, file, key_path: str, expected: str):
        self.file = str(file)
        self.key_path = key_path
        self.expected = expected
        super().__init__(f"{self.file}: {key_path}: {expected}" if key_path else f"{self.file}: {expected}")


class HardwareError(RtctlError):
    """A device or its link failed (open, configure, read, write)."""


class DriverNotFoundError(HardwareError):
    """No driver is registered under the name the configuration asks for."""


class ProtocolError(HardwareError):
    """Bytes on a wire do not decode (wrong length, unknown id, corrupt frame)."""


class SettingsError(RtctlError):
    """A device cannot do these settings (e.g. a framegrabber window outside its sampling grid);
    ``key`` names the setting, so a configuration error can name its key path."""

    def __init__(self, key: str, expected: str):
        self.key = key
        self.expected = expected
        super().__init__(f"{key}: {expected}")


class BusLoadError(ConfigError):
    """A bus would be loaded beyond its configured limit at the configured rate."""


class TrajectoryError(RtctlError):
    """A trajectory cannot be planned as asked (duration below the limits' minimum, waypoint out of range)."""


class GuardError(RtctlError):
    """A target or path is infeasible: inside an interference zone, past a limit, or no way around."""


class SafetyError(RtctlError):
    """The safety stage stopped the robot (limit, watchdog, non-finite output, e-stop)."""


class RealtimeError(RtctlError):
    """A real-time knob that ``--enforce-rt`` requires could not be applied."""


class ControlSocketError(RtctlError):
    """The control socket is unreachable or answered with an error."""


class ResourceBusyError(RtctlError):
    """An exclusive resource (control socket, telemetry file) is held by another running daemon."""


class TelemetryError(RtctlError):
    """A telemetry file cannot be written or read back (bad schema, writer died, not a telemetry file)."""


class ControllerError(RtctlError):
    """A controller cannot produce a valid command (e.g. a non-finite estimate); names the joint
    and the quantity. Raised from ``update()``: the safety stage takes over in the same tick."""


# Most specific first: each family of the error tree, its exit code and how the message starts.
_EXIT_FOR = (
    (ConfigError, EXIT_CONFIG, "configuration error: "),
    (RealtimeError, EXIT_RT, "real-time: "),
    (HardwareError, EXIT_HARDWARE, "hardware: "),
    (ControlSocketError, EXIT_SOCKET, ""),
    (ResourceBusyError, EXIT_SOCKET, "busy: "),
    (SafetyError, EXIT_FAULT, "safe stop: "),
    (RtctlError, EXIT_CONFIG, ""),
)


def exit_code_for(error: RtctlError) -> tuple[int, str]:
    """The exit code of an error of the tree, and how its message starts."""
    return next((c, p) for cls, c, p in _EXIT_FOR if isinstance(error, cls))
