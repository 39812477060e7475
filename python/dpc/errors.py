"""Typed exceptions: every libdpc status becomes one of these, carrying the C message."""


class DpcError(Exception):
    """Base class of every dpc error."""


class InvalidArgumentError(DpcError, ValueError):
    """A bad argument: wrong shape, count, option or value (DPC_ERROR_INVALID_ARGUMENT)."""


class ModelIOError(DpcError, OSError):
    """A model file that could not be opened or read (DPC_ERROR_IO)."""


class ModelFormatError(DpcError, ValueError):
    """A file that is not a valid dpc model: malformed, truncated or hostile (DPC_ERROR_FORMAT)."""


class UnsupportedError(DpcError):
    """A valid request this build cannot serve: format version, ISA (DPC_ERROR_UNSUPPORTED)."""


class OutOfMemoryError(DpcError, MemoryError):
    """An allocation inside libdpc failed (DPC_ERROR_OUT_OF_MEMORY)."""


class LimitError(InvalidArgumentError):
    """A request beyond a documented limit, e.g. too many points or more output than max_bytes
    (DPC_ERROR_LIMIT). An InvalidArgumentError too: an oversize count is a bad argument."""


class InternalError(DpcError, RuntimeError):
    """A bug in libdpc (DPC_ERROR_INTERNAL): please report it."""


class CancelledError(DpcError):
    """A generate call stopped by its progress callback (DPC_ERROR_CANCELLED)."""


class ModelNotFoundError(DpcError, LookupError):
    """dpc.load was given a name that is neither a file nor a bundled model."""


# Indexed by the pinned dpc_status value.
BY_STATUS = {
    1: InvalidArgumentError,
    2: ModelIOError,
    3: ModelFormatError,
    4: UnsupportedError,
    5: OutOfMemoryError,
    6: LimitError,
    7: InternalError,
    8: CancelledError,
}
